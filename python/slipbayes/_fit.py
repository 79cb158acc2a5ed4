"""``slipbayes.fit``: a model file or a dict in, ArviZ's container of the posterior out (an
``xarray.DataTree`` under ArviZ 1.x, an ``arviz.InferenceData`` under ArviZ 0.x)."""

from __future__ import annotations

import copy
import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from slipbayes import _idata, _native

TIME_COLUMN = "time_s"
FORCE_COLUMN = "force_N"
NORMAL_FORCE_COLUMN = "normal_force_N"


def _column(data, name):
    """Column ``name`` of a pandas or polars frame, or of a dict of arrays; None if absent."""
    if isinstance(data, dict):
        return None if name not in data else np.asarray(data[name], dtype=np.float64)
    columns = getattr(data, "columns", None)
    if columns is not None and name in list(columns):
        column = data[name]
        return np.asarray(column.to_numpy() if hasattr(column, "to_numpy") else column, dtype=np.float64)
    return None


def _series(run_name, data):
    """(time_s, force_N, normal_force_N or None) of a run's in-memory data."""
    time, force = _column(data, TIME_COLUMN), _column(data, FORCE_COLUMN)
    if time is not None and force is not None:
        return time, force, _column(data, NORMAL_FORCE_COLUMN)
    if isinstance(data, tuple) and len(data) in (2, 3):
        arrays = [np.asarray(a, dtype=np.float64) for a in data]
        return arrays[0], arrays[1], arrays[2] if len(arrays) == 3 else None
    array = np.asarray(data, dtype=np.float64) if not hasattr(data, "columns") else None
    if array is not None and array.ndim == 2 and array.shape[1] in (2, 3):
        return array[:, 0], array[:, 1], array[:, 2] if array.shape[1] == 3 else None
    raise ValueError(
        f"run {run_name!r}: data must be a path, a frame or dict with columns "
        f"{TIME_COLUMN!r} and {FORCE_COLUMN!r} (optionally {NORMAL_FORCE_COLUMN!r}), a tuple "
        "(time_s, force_N) or an array of shape (n, 2)"
    )


def _write_csv(path: Path, time, force, normal):
    """The simple CSV format the library reads; repr() keeps every bit of each value."""
    if len(time) != len(force) or (normal is not None and len(normal) != len(time)):
        raise ValueError(f"{path.name}: the data's columns differ in length")
    header = [TIME_COLUMN, FORCE_COLUMN] + ([NORMAL_FORCE_COLUMN] if normal is not None else [])
    rows = zip(time, force, normal) if normal is not None else zip(time, force)
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in rows:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def _plain(value):
    """JSON-ready values: numpy scalars as Python numbers, paths as strings, no None."""
    if isinstance(value, dict):
        # A model file has no null: a key set to None is a key left out.
        return {str(k): _plain(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


def _model_json(model: dict, data_dir: Path) -> str:
    """The model dict as JSON for the library, runs' in-memory data written as CSV files into
    ``data_dir`` (part of the run directory, so that ``load`` finds them later)."""
    model = copy.copy(model)
    runs = []
    for i, run in enumerate(model.get("run", [])):
        run = dict(run)
        data = run.get("data")
        if data is not None and not isinstance(data, (str, os.PathLike)):
            name = str(run.get("name", f"run{i}"))
            time, force, normal = _series(name, data)
            data_dir.mkdir(parents=True, exist_ok=True)
            path = data_dir / f"{name}.csv"
            _write_csv(path, time, force, normal)
            run["data"] = str(path.resolve())
        runs.append(run)
    if runs:
        model["run"] = runs
    return json.dumps(_plain(model), allow_nan=False)


def _note_to_stderr(text):
    sys.stderr.write(f"note: {text}\n")
    sys.stderr.flush()


class _Progress:
    """One line of progress, rewritten in place (tqdm's bar when tqdm is installed)."""

    def __init__(self):
        self.bar = None
        self.started = False
        self.last = None
        try:
            from tqdm.auto import tqdm

            self.tqdm = tqdm
        except ImportError:
            self.tqdm = None

    def __call__(self, step, last_step, acceptance, tau_max, r_hat_max, eta_s):
        # While the run is summarised the last step's progress stays as it was.
        if (step, tau_max, r_hat_max) == self.last:
            return
        self.last = (step, tau_max, r_hat_max)
        extra = f"acc {acceptance:.2f}" if not math.isnan(acceptance) else ""
        if tau_max is not None:
            extra += f"  τ_max {tau_max:.1f}"
        if r_hat_max is not None:
            extra += f"  R̂ {r_hat_max:.3f}"
        if self.tqdm is not None:
            if self.bar is None:
                self.bar = self.tqdm(total=last_step, unit="step", desc="slipbayes")
            self.bar.total = last_step
            self.bar.update(step - self.bar.n)
            self.bar.set_postfix_str(extra)
            return
        eta = f"  ETA {eta_s:.0f}s" if eta_s is not None else ""
        sys.stdout.write(f"\rstep {step}/{last_step}  {extra}{eta}    ")
        sys.stdout.flush()
        self.started = True

    def note(self, text):
        """Shows a note of the fit (why it samples on after its summaries) as its own line,
        above the progress, as the command line prints it."""
        line = f"note: {text}"
        if self.bar is not None:
            self.bar.write(line)
            return
        if self.started:
            sys.stdout.write("\n")
            self.started = False
        sys.stdout.write(line + "\n")
        sys.stdout.flush()

    def close(self):
        if self.bar is not None:
            self.bar.close()
        elif self.started:
            sys.stdout.write("\n")
            sys.stdout.flush()


def fit(
    model,
    *,
    seed=None,
    walkers=None,
    steps=None,
    max_steps=None,
    max_time=None,
    threads=None,
    out=None,
    overwrite=False,
    resume=False,
    report=False,
    progress=True,
    log_likelihood_draws=2000,
):
    """Fits a friction model and returns its posterior as ArviZ's container: an
    ``xarray.DataTree`` under ArviZ 1.x, an ``arviz.InferenceData`` under ArviZ 0.x, with the
    same groups either way.

    ``model`` is a model file (a path, as for ``slipbayes fit MODEL``) or a dict of the same
    structure: ``{"material": [{"name": ...}], "contact": [{"name", "material"}], "run":
    [{"name", "contact", "data", "velocity_m_per_s", "scene"}], "levels": ..., "priors": ...,
    "sampler": ...}``. A run's ``data`` is a path (relative to the current directory) or the
    data themselves: a pandas or polars frame, or a dict, with columns ``time_s`` and
    ``force_N`` (SI), a tuple ``(time_s, force_N)``, or an array of shape (n, 2); these are
    written to ``OUT/data/RUN.csv``.

    ``seed``, ``walkers`` (per ensemble), ``steps`` (a fixed number; default: until
    converged, up to ``max_steps``), ``max_time`` (s, the sampling budget) override the
    model's ``[sampler]`` table, as the command line's flags do. ``threads``: the sampler's
    threads (default: every core); the result does not depend on it.

    ``out``: the run directory to write (chains, summary.json, model.toml, settings.json,
    predictive.csv, and report.html with ``report=True``), the same files as ``slipbayes fit
    --out``; ``load(out)`` reads it back. ``None`` fits into a temporary directory that is
    removed once the result is read. ``out`` must be new, empty or a slipbayes run directory
    (it carries the marker ``.slipbayes-run``); any other directory raises ``SlipbayesError``
    naming the files that would be replaced, unless ``overwrite``, which also replaces an
    earlier run there (only slipbayes' own files are written, every other file stays);
    ``resume`` continues an interrupted one. The run directory is locked while the fit writes it (the
    lock file ``.slipbayes.lock``, the command line's own lock): a second fit into a directory
    that another live fit holds, from this process or another, raises ``SlipbayesError``
    naming the holder and the lock file, before anything is written.

    The GIL is released while sampling. ``progress=True`` shows a progress line (a tqdm bar
    when tqdm is installed); ``False`` shows none; a function is called instead, about five
    times a second, with ``(step, last_step, acceptance, tau_max, r_hat_max, eta_s)``. When the
    sampler's rule is met but the summaries of every reported quantity are not yet, the fit
    samples on, and says why in a line ``note: the summaries at step N ... do not pass the
    strict standard yet, M more steps: <first problem>``: printed with the progress line,
    written to standard error beside a function of your own, not shown with ``progress=False``.
    Ctrl-C (or the notebook's interrupt)
    stops the fit after its current step and a checkpoint and raises ``KeyboardInterrupt``
    saying how to resume (one that comes as the last step ends raises it too, saying the fit
    finished).

    The result is :func:`slipbayes.load`'s (``log_likelihood_draws`` as
    there: about that many draws of the pointwise log-likelihood and of the posterior
    predictive); its docstring says which ArviZ call reproduces which number of summary.json
    (ESS: ``az.ess(idata)``; R̂: ``az.rhat(slipbayes.ensembles_as_chains(idata))``). When a
    run's record is long enough to be fitted on sufficient statistics (more than ``[likelihood]
    exact_up_to`` points, 10,000 by default), the result has no ``log_likelihood`` group and a
    ``SlipbayesWarning`` names the run (see :func:`slipbayes.load`).

    Raises ``SlipbayesError`` (a ``ValueError``) with the library's message, naming the file,
    line, column or key at fault; for a dict, the key path in the dict (e.g.
    ``run[1].velocity_m_per_s``).
    """
    if callable(progress):
        callback = progress
        note = _note_to_stderr
    else:
        callback = _Progress() if progress else None
        note = callback.note if callback is not None else None
    with tempfile.TemporaryDirectory(prefix="slipbayes-") as scratch:
        run_dir = Path(out) if out is not None else Path(scratch) / "run"
        kwargs = dict(
            seed=seed,
            walkers=walkers,
            steps=steps,
            max_steps=max_steps,
            max_time_s=None if max_time is None else float(max_time),
            threads=threads,
            overwrite=overwrite,
            resume=resume,
            report=report,
            progress=callback,
            note=note,
        )
        if not isinstance(model, (dict, str, os.PathLike)):
            raise TypeError(f"model must be a path or a dict, not {type(model).__name__}")
        # The lock is taken before anything is written into the run directory (the dict's
        # data files) and held until the fit and its report are written.
        with _native.RunDirLock(os.fspath(run_dir), overwrite=overwrite) as lock:
            if isinstance(model, dict):
                kwargs["model_json"] = _model_json(model, run_dir / "data")
                kwargs["base_dir"] = os.getcwd()
            else:
                kwargs["model_path"] = os.fspath(model)
            try:
                written = _native.fit(lock, **kwargs)
            finally:
                if isinstance(callback, _Progress):
                    callback.close()
        raw = _native.load_run(written, log_likelihood_draws)
        return _idata.from_native(raw, written if out is not None else None)
