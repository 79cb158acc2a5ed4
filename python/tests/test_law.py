"""The law, the observed-time model and the peak against the Rust library's own numbers,
bit for bit: the command line's `simulate` (which writes every double exactly) and the
derived columns a fit stores in its chains."""

import subprocess

import numpy as np
import pytest

import slipbayes
from conftest import PTFE, REPO, same_bits, slipbayes_binary


def cli_simulate(tmp_path, *args):
    binary = slipbayes_binary()
    if binary is None:
        pytest.skip("the slipbayes command line is not built (cargo build --release)")
    out = tmp_path / "sim.csv"
    subprocess.run([str(binary), "simulate", *args, "--out", str(out), "--overwrite"], check=True,
                   capture_output=True)
    table = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.float64,
                       converters=float, ndmin=2)
    return table


def ptfe_args(scene, **extra):
    args = ["--scene", scene, "--alpha", "0.92e6", "--a", "6.2e-3", "--f-d", "10e-3",
            "--t0", "14.8", "--velocity", "1e-9"]
    for k, v in extra.items():
        args += [f"--{k.replace('_', '-')}", str(v)]
    return args


def test_simulate_equals_the_command_line_bit_for_bit(tmp_path):
    table = cli_simulate(tmp_path, *ptfe_args("first", k="1.2e4", duration=30000,
                                              interval=10, sigma="1e-4", seed=3))
    run = slipbayes.simulate("first", **PTFE, velocity_m_per_s=1e-9, k_n_per_m=1.2e4,
                             duration_s=30000, interval_s=10, sigma_n=1e-4, seed=3)
    assert same_bits(run.time_s, table[:, 0])
    assert same_bits(run.force_n, table[:, 1])
    # Another seed gives other noise: the comparison can fail.
    other = slipbayes.simulate("first", **PTFE, velocity_m_per_s=1e-9, k_n_per_m=1.2e4,
                               duration_s=30000, interval_s=10, sigma_n=1e-4, seed=4)
    assert not same_bits(other.force_n, table[:, 1])


def test_law_equals_the_library_bit_for_bit():
    # tests/reference/law_rust_values.csv holds `Law::force_and_rate`'s bits, written and
    # kept current by the Rust test `law_bits_match_the_table_bindings_are_checked_against`
    # (tests/law.rs).
    table = np.loadtxt(REPO / "tests" / "reference" / "law_rust_values.csv", delimiter=",",
                       skiprows=1, dtype=np.float64)
    alpha, a, f_d, t0, v, tau, force, rate = table.T
    got_force, got_rate = slipbayes.law(tau, alpha_per_m=alpha, a_n=a, f_d_n=f_d, t0_s=t0,
                                        velocity_m_per_s=v, rate=True)
    assert same_bits(got_force, force)
    assert same_bits(got_rate, rate)
    assert (force[tau < t0] == 0).all() and (force[tau > t0] > 0).all()


def test_observed_time_model_equals_the_command_line_bit_for_bit(tmp_path):
    for scene, extra in [("stiff-fast", {}), ("first", {"k": "1.2e4"}),
                         ("repeat", {"k": "1.2e4", "f_end": "0.012"})]:
        table = cli_simulate(tmp_path, *ptfe_args(scene, duration=20000, interval=2.5,
                                                  sigma=0, **extra))
        time = table[:, 0]
        kwargs = {}
        if "k" in extra:
            kwargs["k_n_per_m"] = float(extra["k"])
        if "f_end" in extra:
            kwargs["f_end_n"] = float(extra["f_end"])
        model = slipbayes.simulate(scene, **PTFE, velocity_m_per_s=1e-9, time_s=time,
                                   **kwargs)
        assert same_bits(model, table[:, 1]), scene
        # The vector kernel of the observed-time model and the law one τ at a time agree to
        # rounding on a stiff slide (τ = t), not necessarily to the bit.
        if scene == "stiff-fast":
            np.testing.assert_allclose(
                slipbayes.law(time, **PTFE, velocity_m_per_s=1e-9), model, rtol=2e-15,
                atol=0)


def test_law_broadcasts_and_gives_the_rate():
    tau = np.linspace(20.0, 2e4, 7)
    alphas = np.array([[0.5e6], [0.92e6], [2e6]])
    force, rate = slipbayes.law(tau, alpha_per_m=alphas, a_n=6.2e-3, f_d_n=10e-3,
                                t0_s=14.8, velocity_m_per_s=1e-9, rate=True)
    assert force.shape == rate.shape == (3, 7)
    for i, alpha in enumerate(alphas[:, 0]):
        row = slipbayes.law(tau, alpha_per_m=alpha, a_n=6.2e-3, f_d_n=10e-3, t0_s=14.8,
                            velocity_m_per_s=1e-9)
        assert same_bits(force[i], row)
    # dF/dτ against a central difference.
    h = 1e-3
    up = slipbayes.law(tau + h, **PTFE, velocity_m_per_s=1e-9)
    down = slipbayes.law(tau - h, **PTFE, velocity_m_per_s=1e-9)
    np.testing.assert_allclose(rate[1], (up - down) / (2 * h), rtol=1e-6, atol=1e-12)


def test_peak_is_the_fits_derived_columns_bit_for_bit(fitted):
    idata, _ = fitted
    post = idata.posterior

    def draws(var, label):
        return post[var].sel({post[var].dims[-1]: label}).values

    run = "ptfe-c1-first"
    peak = slipbayes.peak(
        alpha_per_m=draws("alpha", "PTFE"),
        a_n=draws("a", "ptfe-c1"),
        f_d_n=draws("F_d", "ptfe-c1"),
        t0_s=draws("t0", run),
        velocity_m_per_s=1e-9,
        k_n_per_m=draws("k", "ptfe-c1"),
    )
    assert same_bits(peak.force_n, draws("F_peak", run))
    assert same_bits(peak.tau_s, draws("tau_peak", run))
    assert same_bits(peak.slip_m, draws("s_peak", run))
    assert same_bits(peak.time_s, draws("t_peak", run))
    # The peak lies on the law: its rate vanishes there.
    one = slipbayes.peak(**PTFE, velocity_m_per_s=1e-9)
    _, rate = slipbayes.law(one.tau_s, **PTFE, velocity_m_per_s=1e-9, rate=True)
    assert abs(rate) < 1e-15 and np.isnan(one.time_s) == False  # noqa: E712
    assert same_bits(one.time_s, one.tau_s)


def test_no_interior_peak_without_aging():
    p = slipbayes.peak(alpha_per_m=1e6, a_n=0.0, f_d_n=1e-2, t0_s=1.0, velocity_m_per_s=1e-9)
    assert np.isnan(p.force_n) and np.isnan(p.tau_s)
