"""`fit` and `load`: the InferenceData's contents, its round trips, and ArviZ's diagnostics
against summary.json."""

import json
import os
import signal
import threading
import warnings
import time

import arviz as az
import numpy as np
import pandas as pd
import pytest

import slipbayes
from conftest import DATA, SEED, STEPS, one_contact, same_bits


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
    assert {"posterior", "sample_stats", "observed_data"} <= set(idata.groups())
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
    out = tmp_path / "run"
    lines = []

    def progress(step, *_):
        # One SIGINT, as Ctrl-C sends, once the sampler is under way.
        if step >= 20 and not lines:
            lines.append(step)
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt, match="resume=True"):
        slipbayes.fit(one_contact(), seed=SEED, steps=STEPS, out=out, progress=progress)
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
    assert 4 < loo["p_loo"] < 10
