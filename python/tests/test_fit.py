"""`fit` and `load`: the returned groups' contents (an xarray DataTree under ArviZ 1.x, an
InferenceData under 0.x), their round trips, and ArviZ's diagnostics against summary.json."""

import json
import os
import pathlib
import re
import signal
import subprocess
import threading
import warnings
import time

import arviz as az
import numpy as np
import pandas as pd
import pytest

import slipbayes
from conftest import (ARVIZ_1, DATA, PTFE, SEED, STEPS, group_names, one_contact, p_loo,
                      same_bits)


def assert_same_posterior(a, b):
    assert set(a.posterior.data_vars) == set(b.posterior.data_vars)
    for name in a.posterior.data_vars:
        assert same_bits(a.posterior[name].values, b.posterior[name].values), name
    assert same_bits(a.sample_stats["lp"].values, b.sample_stats["lp"].values)


def summary_json(run_dir):
    return json.loads((run_dir / "summary.json").read_text())


def test_groups_dimensions_and_attributes(fitted):
    idata, run_dir = fitted
    s = summary_json(run_dir)["sampler"]
    assert {"posterior", "sample_stats", "observed_data", "log_likelihood",
            "posterior_predictive"} <= group_names(idata)
    post = idata.posterior
    chains, kept = s["ensembles"] * s["walkers"], s["steps"] - s["burn_in"]
    assert post.sizes["chain"] == chains and post.sizes["draw"] == kept
    assert list(post["draw"].values) == list(range(s["burn_in"], s["steps"]))
    assert list(post["ensemble"].values) == [c // s["walkers"] for c in range(chains)]
    assert post["alpha"].dims == ("chain", "draw", "material")
    assert list(post["material"].values) == ["PTFE"]
    assert post["F_d"].dims == ("chain", "draw", "contact")
    assert post["sigma"].dims == ("chain", "draw", "run")
    assert list(post["run"].values) == ["ptfe-c1-first", "ptfe-c1-repeat"]
    # t0 and the peak belong to the first slide alone: a dimension of their own.
    assert list(post["t0_run"].values) == ["ptfe-c1-first"]
    # a is reported per contact and per material.
    assert post["a"].dims[-1] == "contact" and post["a_material"].dims[-1] == "material"
    assert post["alpha"].attrs["units"] == "1/m"
    assert idata.sample_stats["lp"].shape == (chains, kept)
    moved = idata.sample_stats["moved"].values
    assert set(np.unique(moved[~np.isnan(moved)])) <= {0.0, 1.0}
    assert 0.05 < np.nanmean(moved) < 1.0
    attrs = post.attrs
    assert attrs["seed"] == SEED and attrs["steps"] == STEPS
    assert attrs["slipbayes_version"] == slipbayes.__version__
    assert json.loads(attrs["settings"])["seed"] == SEED
    assert attrs["acceptance"] == pytest.approx(s["acceptance"], rel=0, abs=0)
    observed = idata.observed_data["force"]
    of_first = observed["run_of_observation"].values == "ptfe-c1-first"
    first = np.loadtxt(DATA / "ptfe-c1-first.csv", delimiter=",", skiprows=1)
    assert same_bits(observed.values[of_first], first[:, 1])
    assert same_bits(observed["time_s"].values[of_first], first[:, 0])


def check_arviz_gives_slipbayes_numbers(idata, run_dir):
    summary = summary_json(run_dir)
    if ARVIZ_1:
        # ArviZ 1.x takes the tail ESS at rcParams["stats.ci_prob"] (0.89 by default);
        # slipbayes and ArviZ 0.x at the 5 % and 95 % quantiles.
        with az.rc_context({"stats.ci_prob": 0.95}):
            table = az.summary(idata, round_to="none")
        assert {"eti95_lb", "eti95_ub"} <= set(slipbayes.summary(idata).columns)
    else:
        table = az.summary(idata, round_to="none")
    rhat = az.rhat(slipbayes.ensembles_as_chains(idata))
    ours = slipbayes.summary(idata)
    quantities = summary["parameters"] + summary["derived"]
    checked = 0
    for q in quantities:
        var = q["name"]
        if var not in idata.posterior or q["group"] not in idata.posterior[var].coords[
            idata.posterior[var].dims[-1]
        ]:
            var = f"{q['name']}_material"
        dim = idata.posterior[var].dims[-1]
        label = f"{var}[{q['group']}]"
        row = table.loc[label]
        assert row["ess_bulk"] == pytest.approx(q["ess_bulk"], rel=1e-9), label
        assert row["ess_tail"] == pytest.approx(q["ess_tail"], rel=1e-9), label
        assert row["mean"] == pytest.approx(q["mean"], rel=1e-12), label
        r = float(rhat[var].sel({dim: q["group"]}))
        assert abs(r - q["r_hat"]) < 1e-12, label
        assert abs(ours.loc[label, "r_hat"] - q["r_hat"]) < 1e-12, label
        assert ours.loc[label, "ess_bulk"] == row["ess_bulk"]
        checked += 1
    assert checked == len(quantities) >= 10
    # The aggregates (F_d and F_peak over the material's contacts and slides) too.
    for agg in summary["aggregates"]:
        label = f"{agg['name']}_material[{agg['group']}]"
        assert table.loc[label, "ess_bulk"] == pytest.approx(agg["ess_bulk"], rel=1e-9)
        assert abs(ours.loc[label, "r_hat"] - agg["r_hat"]) < 1e-12
    # Walkers as chains is a different R̂: the two layouts are not interchangeable.
    walkers_rhat = az.rhat(idata)
    assert not np.allclose(walkers_rhat["alpha"].values, rhat["alpha"].values, rtol=0,
                           atol=1e-12)


def test_arviz_summary_gives_slipbayes_numbers_odd_kept_steps(fitted):
    idata, run_dir = fitted
    # An odd number of kept steps: the middle step is left out of R̂'s halves.
    assert idata.posterior.sizes["draw"] % 2 == 1
    check_arviz_gives_slipbayes_numbers(idata, run_dir)


def test_arviz_summary_gives_slipbayes_numbers_even_kept_steps(tmp_path):
    out = tmp_path / "run"
    idata = slipbayes.fit(one_contact(), seed=SEED, steps=STEPS + 1, out=out, progress=False)
    assert idata.posterior.sizes["draw"] % 2 == 0
    check_arviz_gives_slipbayes_numbers(idata, out)


def test_netcdf_and_load_round_trips(fitted, tmp_path):
    idata, run_dir = fitted
    path = tmp_path / "fit.nc"
    idata.to_netcdf(str(path))
    back = az.from_netcdf(str(path))
    assert_same_posterior(idata, back)
    assert back.posterior.attrs["seed"] == SEED
    assert same_bits(back.observed_data["force"].values, idata.observed_data["force"].values)
    assert same_bits(back.log_likelihood["force"].values, idata.log_likelihood["force"].values)
    assert_same_posterior(idata, slipbayes.load(run_dir))


def test_a_dict_with_frames_fits_as_the_model_file(fitted, tmp_path):
    idata, _ = fitted
    first = pd.read_csv(DATA / "ptfe-c1-first.csv")
    repeat = np.loadtxt(DATA / "ptfe-c1-repeat.csv", delimiter=",", skiprows=1)
    model = one_contact(first=first, repeat=(repeat[:, 0], repeat[:, 1]))
    out = tmp_path / "dict-run"
    from_dict = slipbayes.fit(model, seed=SEED, steps=STEPS, out=out, progress=False)
    assert_same_posterior(idata, from_dict)
    assert (out / "data" / "ptfe-c1-first.csv").exists()
    # Without `out` the run lives in a temporary directory; another seed, other draws.
    other = slipbayes.fit(one_contact(), seed=SEED + 1, steps=STEPS, progress=False)
    assert "run_dir" not in other.posterior.attrs
    assert not same_bits(other.posterior["alpha"].values, idata.posterior["alpha"].values)


def test_the_gil_is_released_while_sampling(tmp_path):
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.01)

    counter = threading.Thread(target=count)
    counter.start()
    start = time.perf_counter()
    try:
        slipbayes.fit(one_contact(), seed=SEED, steps=200, threads=1, progress=False,
                      out=tmp_path / "run")
    finally:
        done.set()
        counter.join()
    elapsed = time.perf_counter() - start
    # A thread that could not run would tick only at the fit's few GIL hand-overs.
    assert len(ticks) > 0.3 * elapsed / 0.01


def test_ctrl_c_stops_after_a_checkpoint_and_resumes(tmp_path, fitted):
    idata, _ = fitted
    # Ctrl-C at a terminal raises KeyboardInterrupt through Python's default handler. A
    # process started in the background of a shell without job control (as a CI job may be)
    # inherits SIGINT ignored, and Python then installs no handler: put the terminal's back.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        interrupted_out = None
        # The whole fit samples for about a second. On a loaded machine the sampler can finish
        # its steps before the first progress reaches Python, or between the Ctrl-C and its
        # next step (then the fit is whole and the KeyboardInterrupt says so). Such a fit is
        # tried again in a fresh directory; one Ctrl-C in three attempts must stop a fit.
        for attempt in range(3):
            out = tmp_path / f"run{attempt}"
            sent = []

            def progress(step, last_step, *_):
                # One SIGINT, as Ctrl-C sends, while the sampler is under way.
                if step < last_step and not sent:
                    sent.append(step)
                    os.kill(os.getpid(), signal.SIGINT)

            try:
                slipbayes.fit(one_contact(), seed=SEED, steps=STEPS, out=out, progress=progress)
            except KeyboardInterrupt as interrupted:
                if "resume=True" in str(interrupted):
                    interrupted_out = out
                    break
                assert "it finished" in str(interrupted), str(interrupted)
            else:
                assert not sent, "a Ctrl-C sent while the fit ran was swallowed"
            assert (out / "summary.json").exists(), "a fit that was not stopped is whole"
    finally:
        signal.signal(signal.SIGINT, previous)
    assert interrupted_out is not None, "none of three fits was stopped by a Ctrl-C"
    out = interrupted_out
    assert not (out / "summary.json").exists() and (out / "checkpoint.bin").exists()
    resumed = slipbayes.fit(one_contact(), seed=SEED, steps=STEPS, out=out, resume=True,
                            progress=False)
    assert_same_posterior(idata, resumed)


def test_pointwise_log_likelihood_and_az_loo(fitted):
    idata, _ = fitted
    ll = idata.log_likelihood["force"]
    post = idata.posterior
    chains = post.sizes["chain"]
    # About 2,000 draws: every n-th kept step of every chain.
    assert ll.sizes["chain"] == chains and 1000 < chains * ll.sizes["draw"] <= 2048 + chains
    assert set(ll["draw"].values) <= set(post["draw"].values)
    obs = idata.observed_data["force"]
    runs = obs["run_of_observation"].values
    time = obs["time_s"].values

    def at(var, chain, step):
        da = post[var].sel(chain=chain, draw=step)
        return float(da.values.ravel()[0])

    # At a few draws: the Gaussian term of each observation around the observed-time model
    # (through `simulate`, another path into the library) with the draw's σ.
    for chain, step in [(0, int(ll["draw"][0])), (77, int(ll["draw"][-1]))]:
        law = dict(alpha_per_m=at("alpha", chain, step), a_n=at("a", chain, step),
                   f_d_n=at("F_d", chain, step), t0_s=at("t0", chain, step),
                   velocity_m_per_s=1e-9, k_n_per_m=at("k", chain, step))
        first = runs == "ptfe-c1-first"
        model_first = slipbayes.simulate("first", time_s=time[first], **law)
        model_repeat = slipbayes.simulate("repeat", time_s=time[~first],
                                          f_end_n=model_first[-1], **law)
        for mask, model, run in [(first, model_first, "ptfe-c1-first"),
                                 (~first, model_repeat, "ptfe-c1-repeat")]:
            sigma = float(post["sigma"].sel(chain=chain, draw=step, run=run))
            want = (-0.5 * ((obs.values[mask] - model) / sigma) ** 2 - np.log(sigma)
                    - 0.5 * np.log(2 * np.pi))
            got = ll.sel(chain=chain, draw=step).values[mask]
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # The whole model's PSIS-LOO, with no warning (a Pareto k above 0.7 would warn).
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loo = az.loo(idata)
    assert not loo["warning"]
    assert (loo["pareto_k"].values < 0.7).all()
    # About one effective parameter per sampled one (α, a/F_d, F_d, t0, k, and two σ).
    assert 4 < p_loo(loo) < 10
    # az.compare ranks models by it; a model against itself ties.
    table = az.compare({"one": idata, "same": idata})
    assert list(table["rank"]) == [0, 1]
    assert abs(float(table["elpd_diff"].iloc[1])) < 1e-9


def test_posterior_predictive_replicates_every_observation(fitted, tmp_path):
    idata, run_dir = fitted
    pp = idata.posterior_predictive["force"]
    ll = idata.log_likelihood["force"]
    obs = idata.observed_data["force"]
    # The draws of log_likelihood, the observations of observed_data, the same names.
    assert pp.dims == ("chain", "draw", "observation")
    assert pp.sizes["observation"] == obs.sizes["observation"]
    assert list(pp["chain"].values) == list(ll["chain"].values)
    assert list(pp["draw"].values) == list(ll["draw"].values)
    walkers = idata.posterior.attrs["walkers"]
    assert list(pp["walker"].values) == [c % walkers for c in pp["chain"].values]
    for coord in ("run_of_observation", "time_s"):
        assert (pp[coord].values == obs[coord].values).all()
    assert pp.attrs["units"] == "N"
    # Reproducible: the same run read again gives the same bits; with fewer draws, the draws
    # both hold have the same replicates (each draw has a noise stream of its own).
    again = slipbayes.load(run_dir)
    assert same_bits(again.posterior_predictive["force"].values, pp.values)
    fewer = slipbayes.load(run_dir, log_likelihood_draws=300).posterior_predictive["force"]
    common = sorted(set(fewer["draw"].values) & set(pp["draw"].values))
    assert common and fewer.sizes["draw"] < pp.sizes["draw"]
    assert same_bits(fewer.sel(draw=common).values, pp.sel(draw=common).values)
    # Each replicate scatters around the fitted forces with the draw's σ: the mean over the
    # draws is the posterior median force of predictive.csv (written by the fit from other
    # draws) within the Monte Carlo error of the noise (σ / √draws, 5 standard errors), plus
    # a quarter of the model's own 95 % band for its mean against its median and the band's
    # 200 draws.
    bands = pd.read_csv(run_dir / "predictive.csv")
    draws = pp.sizes["chain"] * pp.sizes["draw"]
    mean = pp.mean(("chain", "draw")).values
    spread = pp.std(("chain", "draw")).values
    runs = obs["run_of_observation"].values
    time_s = obs["time_s"].values
    for run, band in bands.groupby("run"):
        index = {t: i for i, t in enumerate(time_s) if runs[i] == run}
        at = np.array([index[t] for t in band["time_s"].values])
        sigma = float(idata.posterior["sigma"].sel(run=run).median())
        width = (band["model_q975_N"] - band["model_q025_N"]).values
        error = np.abs(mean[at] - band["model_median_N"].values)
        assert (error < 5 * sigma / np.sqrt(draws) + 0.25 * width).all(), run
        # Not the observations: those scatter by σ around the model.
        assert np.sqrt(np.mean((band["observed_N"].values - mean[at]) ** 2)) > 0.5 * sigma
        of_run = runs == run
        assert np.mean(spread[of_run]) == pytest.approx(sigma, rel=0.05), run
    # The posterior predictive check plot pairs observed_data and posterior_predictive by
    # name: az.plot_ppc_dist in ArviZ 1.x, az.plot_ppc in 0.x.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if ARVIZ_1:
        plot = az.plot_ppc_dist(idata, num_samples=50)
        for drawn in ("predictive_dist", "observed_dist"):
            assert "force" in plot.viz[drawn].data_vars, drawn
    else:
        axes = az.plot_ppc(idata, num_pp_samples=50, random_seed=1)
        assert np.size(axes) == 1
    plt.close("all")


def test_a_record_on_sufficient_statistics_has_no_log_likelihood_and_a_warning():
    # 20,001 points, over the 10,000 that the likelihood evaluates point by point.
    sim = slipbayes.simulate("first", **PTFE, velocity_m_per_s=1e-9, k_n_per_m=1.2e4,
                             duration_s=20000.0, interval_s=1.0, sigma_n=1e-4, seed=3)
    model = {
        "material": [{"name": "PTFE"}],
        "contact": [{"name": "c"}],
        "run": [{"name": "long", "contact": "c", "data": (sim.time_s, sim.force_n),
                 "velocity_m_per_s": 1e-9, "scene": "first"}],
    }
    model["contact"][0]["material"] = "PTFE"
    with pytest.warns(slipbayes.SlipbayesWarning,
                      match=r'run "long" has 20001 points and is evaluated on sufficient '
                            r'statistics.*leave-one-out needs') as caught:
        idata = slipbayes.fit(model, seed=SEED, steps=80, progress=False)
    assert "no log_likelihood group" in str(caught[0].message)
    assert "log_likelihood" not in group_names(idata)
    assert "sufficient statistics" in idata.posterior.attrs["log_likelihood_missing"]
    # The replicates are there, solved at every point: at 2,048 draws they would hold 41
    # million values, over the 25 million allowed, so every chain at fewer steps.
    pp = idata.posterior_predictive["force"]
    assert pp.sizes["observation"] == sim.time_s.size
    assert pp.sizes["chain"] == idata.posterior.sizes["chain"]
    assert pp.sizes["chain"] * pp.sizes["draw"] * sim.time_s.size <= 25_000_000
    assert pp.sizes["chain"] * pp.sizes["draw"] > 1000
    # Around the truth, with the noise of the simulation.
    mean = pp.mean(("chain", "draw")).values
    assert np.sqrt(np.mean((mean - sim.clean_force_n) ** 2)) < 0.2e-4
    assert float(pp.std(("chain", "draw")).mean()) == pytest.approx(1e-4, rel=0.05)


def test_a_second_fit_into_a_locked_run_directory_fails_naming_the_lock(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    lock = out / ".slipbayes.lock"
    first = pd.read_csv(DATA / "ptfe-c1-first.csv")
    # A live process holds the lock, as a fit in another process would.
    holder = subprocess.Popen(["sleep", "60"])
    try:
        # Popen may return before the child has become `sleep` (its /proc cmdline is empty
        # until then, and the lock would rightly be judged stale): wait until it has.
        cmdline = pathlib.Path(f"/proc/{holder.pid}/cmdline")
        deadline = time.monotonic() + 10
        while cmdline.read_bytes() != b"sleep\x0060\x00" and time.monotonic() < deadline:
            time.sleep(0.01)
        lock.write_text(f"{holder.pid}\nsleep 60\n")
        with pytest.raises(slipbayes.SlipbayesError, match=re.escape(str(lock))) as info:
            slipbayes.fit(one_contact(first=first), steps=STEPS, out=out, progress=False)
        assert f"process {holder.pid} (`sleep 60`)" in str(info.value)
        # Nothing was written, not even the dict's data.
        assert sorted(p.name for p in out.iterdir()) == [".slipbayes.lock"]
    finally:
        holder.kill()
        holder.wait()
    # Its holder gone, the lock is taken over; while that fit runs, a second fit from this
    # very process into the same directory is refused too.
    refused = []

    def progress(step, *_):
        if not refused:
            with pytest.raises(slipbayes.SlipbayesError, match=re.escape(str(lock))) as info:
                slipbayes.fit(one_contact(), steps=STEPS, out=out, overwrite=True,
                              progress=False)
            refused.append(str(info.value))

    slipbayes.fit(one_contact(first=first), seed=SEED, steps=STEPS, out=out, progress=progress)
    assert refused and f"process {os.getpid()}" in refused[0]
    assert (out / "summary.json").exists() and not lock.exists()


def test_a_dict_chooses_the_law_and_the_machine(tmp_path):
    """`law` and `elastic` of a model dict are the model file's keys: the fit samples only the
    chosen model's parameters, and summary.json records the model and the settings it did not
    read; a prior no model reads is refused by its key."""
    prior = {"dist": "log-uniform", "low": 1e3, "high": 1e9}
    model = dict(one_contact(), law="log-aging", elastic=False, priors={"alpha": prior})
    out = tmp_path / "log-aging-rigid"
    idata = slipbayes.fit(model, seed=SEED, steps=100, out=out, progress=False)
    assert "alpha" not in idata.posterior and "k" not in idata.posterior
    assert "a" in idata.posterior and "t0" in idata.posterior
    assert summary_json(out)["model"] == {
        "law": "log-aging",
        "elastic": False,
        "unread": ["priors.alpha"],
    }
    model = dict(one_contact(), priors={"a": prior})
    with pytest.raises(slipbayes.SlipbayesError, match=r"priors\.a: .*no effect"):
        slipbayes.fit(model, steps=10, progress=False)


def test_a_note_is_a_line_of_its_own_above_the_progress(capsys):
    """A note of the fit (why it samples on after its summaries) breaks the progress line it
    comes in rather than being overwritten by the next step's."""
    from slipbayes._fit import _Progress, _note_to_stderr

    shown = _Progress()
    shown.tqdm = None
    shown(10, 200, 0.5, 3.2, 1.02, 4.0)
    shown.note("the summaries at step 200 (made in 1.0 s) do not pass the strict standard yet")
    shown(20, 200, 0.5, 3.2, 1.02, 3.0)
    lines = capsys.readouterr().out.split("\n")
    assert lines[0].startswith("\rstep 10/200")
    assert lines[1] == ("note: the summaries at step 200 (made in 1.0 s) do not pass the strict "
                        "standard yet")
    assert lines[2].startswith("\rstep 20/200")

    class Bar:
        written = []

        def write(self, line):
            self.written.append(line)

    with_bar = _Progress()
    with_bar.bar = Bar()
    with_bar.note("x")
    assert Bar.written == ["note: x"]
    assert capsys.readouterr().out == ""

    _note_to_stderr("y")
    assert capsys.readouterr().err == "note: y\n"
