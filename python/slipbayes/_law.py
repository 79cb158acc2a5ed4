"""The law, the observed-time model and the peak, vectorised over numpy arrays.

Every number is computed by the Rust library (``slipbayes::law``, ``slipbayes::simulate``);
this module only broadcasts the arguments and moves the arrays across. All values are SI:
forces in N, times in s, velocities in m/s, α in 1/m, k in N/m.
"""

from __future__ import annotations

import json
from typing import NamedTuple, Optional

import numpy as np

from slipbayes import _native


def _f64(*arrays):
    """The arrays broadcast to one shape, as contiguous float64 bytes, and that shape."""
    broadcast = np.broadcast_arrays(*[np.asarray(a, dtype=np.float64) for a in arrays])
    shape = broadcast[0].shape
    return [np.ascontiguousarray(b).tobytes() for b in broadcast], shape


def _array(raw: bytes, shape) -> np.ndarray:
    return np.frombuffer(raw, dtype=np.float64).reshape(shape).copy()


def law(tau_s, *, alpha_per_m, a_n, f_d_n, t0_s, velocity_m_per_s, rate: bool = False):
    """Friction force F(τ) of the aging–rejuvenation law at interface time ``tau_s``.

    F(τ) = a e^(−αvτ) [Ei(αvτ) − Ei(αv t0)] + F_d (1 − e^(−αvτ)) for τ ≥ t0, and 0 before t0
    (docs/model.md). Every argument is an array or a scalar; they are broadcast together, so
    one parameter set over many τ, or many posterior draws at one τ, are one call.

    Parameters (SI): ``tau_s`` interface time (s); ``alpha_per_m`` α (1/m); ``a_n`` the aging
    amplitude a (N); ``f_d_n`` the steady-state friction F_d (N); ``t0_s`` the short-time
    cut-off t0 (s); ``velocity_m_per_s`` the sliding velocity v (m/s).

    Returns the force in N (an array of the broadcast shape), or ``(force_n,
    rate_n_per_s)`` with dF/dτ in N/s when ``rate=True``.

    Raises ``SlipbayesError`` naming the element and parameter when a parameter is outside
    its domain (α ≤ 0, a < 0, F_d < 0, t0 ≤ 0, v ≤ 0 or not finite).
    """
    raw, shape = _f64(tau_s, alpha_per_m, a_n, f_d_n, t0_s, velocity_m_per_s)
    force, slope = _native.law(*raw)
    if rate:
        return _array(force, shape), _array(slope, shape)
    return _array(force, shape)


class Peak(NamedTuple):
    """The static friction peak of the law (arrays of the broadcast shape; NaN where a = 0
    and F rises monotonically to F_d)."""

    tau_s: np.ndarray
    """Interface time of the peak τ_peak (s)."""
    force_n: np.ndarray
    """Peak force F_peak (N)."""
    slip_m: np.ndarray
    """Slip at the peak s_peak = v τ_peak (m)."""
    time_s: np.ndarray
    """Instrument time of the peak t_peak = τ_peak + F_peak/(kv) (s); τ_peak when stiff."""


def peak(*, alpha_per_m, a_n, f_d_n, t0_s, velocity_m_per_s, k_n_per_m=None) -> Peak:
    """The static friction peak: where a/τ = αv (F − F_d), the law's unique maximum.

    The same computation as a fit's derived columns ``F_peak``, ``tau_peak``, ``s_peak`` and
    ``t_peak`` (applied to a posterior's ``alpha``, ``a``, ``F_d``, ``t0`` and ``k`` it gives
    those columns bit for bit). Arguments broadcast; ``k_n_per_m`` (N/m) is the machine
    stiffness, needed only for ``time_s``: ``None`` (or NaN) for a stiff slide.
    """
    k = np.nan if k_n_per_m is None else k_n_per_m
    raw, shape = _f64(alpha_per_m, a_n, f_d_n, t0_s, velocity_m_per_s, k)
    return Peak(*(_array(r, shape) for r in _native.peak(*raw)))


class Simulated(NamedTuple):
    """A simulated run, as ``slipbayes simulate`` writes it."""

    time_s: np.ndarray
    """Instrument times 0, Δt, 2Δt, … (s)."""
    force_n: np.ndarray
    """Recorded force: the model plus Gaussian noise of sd ``sigma_n`` (N)."""
    clean_force_n: np.ndarray
    """The model force without noise (N)."""
    normal_force_n: Optional[np.ndarray]
    """Normal force (N), when ``normal_force_n`` was given."""
    f_end_n: Optional[float]
    """Repeat slide: the force where the previous slide stopped (N)."""


_SCENES = ("first", "repeat", "stiff-fast")


def simulate(
    scene: str,
    *,
    alpha_per_m: float,
    a_n: float,
    f_d_n: float,
    t0_s: float,
    velocity_m_per_s: float,
    k_n_per_m: Optional[float] = None,
    time_s=None,
    duration_s: Optional[float] = None,
    interval_s: Optional[float] = None,
    sigma_n: float = 0.0,
    seed: int = 1,
    f_end_n: Optional[float] = None,
    after_first_s: Optional[float] = None,
    normal_force_n: Optional[float] = None,
    normal_sigma_n: float = 0.0,
):
    """The force a slide records in instrument time: the observed-time model of a fit.

    ``scene`` is ``"first"`` (a first slide on a fresh contact: aging, rejuvenation and the
    elastic correction t = τ + F(τ)/(kv), which needs ``k_n_per_m``), ``"repeat"`` (elastic
    loading F = kvt up to F_end, then F_end; F_end is ``f_end_n``, or the first slide's force
    after ``after_first_s`` seconds, or F_d) or ``"stiff-fast"`` (τ = t, no spring).

    With ``time_s`` (an increasing array of instrument times, s): the noiseless model force
    (N) at those times, an array; this is what a fit's likelihood compares with the data.

    Without it, ``duration_s`` and ``interval_s`` give the grid 0, Δt, … of ``slipbayes
    simulate``, Gaussian noise of sd ``sigma_n`` (N) is added from the seeded stream ``seed``,
    and a :class:`Simulated` is returned, equal bit for bit to the CSV the command writes with
    the same settings.

    Raises ``SlipbayesError`` for invalid settings, or stick-slip (no quasi-static path).
    """
    if scene not in _SCENES:
        raise ValueError(f"scene = {scene!r}: use one of {', '.join(_SCENES)}")
    spec = {
        "scene": scene,
        "params": {"alpha_per_m": alpha_per_m, "a_n": a_n, "f_d_n": f_d_n, "t0_s": t0_s},
        "stiffness_n_per_m": k_n_per_m,
        "velocity_m_per_s": velocity_m_per_s,
        "duration_s": duration_s if duration_s is not None else 0.0,
        "interval_s": interval_s if interval_s is not None else 0.0,
        "noise_sd_n": sigma_n,
        "seed": seed,
        "f_end_n": f_end_n,
        "after_first_s": after_first_s,
        "normal_force_n": normal_force_n,
        "normal_noise_sd_n": normal_sigma_n,
    }
    spec = {k: (float(v) if isinstance(v, (np.floating, np.integer)) else v) for k, v in spec.items()}
    spec["params"] = {k: float(v) for k, v in spec["params"].items()}
    if time_s is not None:
        if duration_s is not None or interval_s is not None or sigma_n != 0.0:
            raise ValueError(
                "time_s gives the noiseless model at those times; leave out duration_s, "
                "interval_s and sigma_n (or leave out time_s to simulate noisy data)"
            )
        times = np.ascontiguousarray(np.asarray(time_s, dtype=np.float64))
        forces = _native.observed_forces(json.dumps(spec), times.ravel().tobytes())
        return _array(forces, times.shape)
    if duration_s is None or interval_s is None:
        raise ValueError("give time_s, or duration_s and interval_s")
    time, force, clean, normal, f_end = _native.simulate(json.dumps(spec))
    n = len(time) // 8
    return Simulated(
        time_s=_array(time, (n,)),
        force_n=_array(force, (n,)),
        clean_force_n=_array(clean, (n,)),
        normal_force_n=None if normal is None else _array(normal, (n,)),
        f_end_n=f_end,
    )
