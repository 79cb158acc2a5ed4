"""A finished run directory as ArviZ's container of groups: an ``xarray.DataTree`` under
ArviZ 1.x, an ``arviz.InferenceData`` under ArviZ 0.x. Both hold the same groups
(``posterior``, ``sample_stats``, ``observed_data``, ``log_likelihood``,
``posterior_predictive``), each the same ``xarray.Dataset``, so ``az.loo``, ``az.compare``,
``az.summary``, ``az.ess`` and ``az.rhat`` of either version read them alike.

The arrays come from the Rust library (``_native.load_run``: summary.json, settings.json,
the Parquet chains and the model's data); this module names and shapes them.

Layout (see :func:`load` for why): ``chain`` is one walker of one ensemble, ``chain =
ensemble * walkers + walker`` with non-index coordinates ``ensemble`` and ``walker``;
``draw`` is the step (its coordinate is the step number), post-burn-in steps only.
"""

from __future__ import annotations

import json
import os
import warnings
from collections import OrderedDict

import numpy as np

from slipbayes import _native

# Finest level first: a quantity reported at several levels keeps its plain name at the
# finest one and gets `_<level>` at the others (`a` per contact, `a_material`).
_LEVELS = ("run", "contact", "material")


def _arviz():
    import arviz as az  # imported late: `law`, `peak` and `simulate` do not need it

    return az


def arviz_1():
    """Whether the installed ArviZ is 1.x or later (DataTree) rather than 0.x
    (InferenceData)."""
    return int(_arviz().__version__.split(".")[0]) >= 1


def groups_of(datasets):
    """ArviZ's container of the named ``xarray.Dataset`` groups: an ``xarray.DataTree`` under
    ArviZ 1.x, an ``arviz.InferenceData`` under ArviZ 0.x."""
    if arviz_1():
        import xarray as xr

        return xr.DataTree.from_dict(dict(datasets))
    return _arviz().InferenceData(**datasets)


def group_names(idata):
    """The groups of a DataTree or an InferenceData, e.g. ``["posterior", "sample_stats"]``."""
    if hasattr(idata, "children"):
        return list(idata.children)
    return list(idata.groups())


def _dataset(group):
    """A group as an ``xarray.Dataset`` (a DataTree node is converted)."""
    return group.to_dataset() if hasattr(group, "to_dataset") and hasattr(group, "children") else group


def _floats(raw: bytes, shape) -> np.ndarray:
    return np.frombuffer(raw, dtype=np.float64).reshape(shape).copy()


class SlipbayesWarning(UserWarning):
    """A result of slipbayes lacks something a user may expect (e.g. the log_likelihood group
    of a fit whose long record was reduced to sufficient statistics)."""


def from_native(raw: dict, run_dir=None, stacklevel=3):
    """ArviZ's container of the dict ``_native.load_run`` returns; warnings point
    ``stacklevel`` frames up."""
    import xarray as xr

    summary = json.loads(raw["summary_json"])
    settings = json.loads(raw["settings_json"])
    ensembles, walkers = raw["ensembles"], raw["walkers"]
    steps, burn_in = raw["steps"], raw["burn_in"]
    chains, kept = ensembles * walkers, steps - burn_in
    columns = {name: _floats(b, (chains, kept)) for name, b in raw["columns"]}

    members = {
        "material": list(raw["materials"]),
        "contact": [c for c, _ in raw["contacts"]],
        "run": [r for r, _, _ in raw["runs"]],
    }

    def level_of(group):
        for level in _LEVELS:
            if group in members[level]:
                return level
        return None

    # Every reported quantity: (name, level) -> {group: draws}, in summary order.
    found = OrderedDict()
    units = {}
    for q in summary["parameters"] + summary["derived"]:
        key = (q["name"], level_of(q["group"]) if q["group"] else None)
        found.setdefault(key, OrderedDict())[q["group"]] = columns[q["column"]]
        units[key] = q["unit"]
    # Means over several columns (e.g. F_d over a material's contacts), per draw, as the
    # summary computes them.
    for agg in summary.get("aggregates", []):
        key = (agg["name"], level_of(agg["group"]))
        found.setdefault(key, OrderedDict())[agg["group"]] = np.mean(
            [columns[c] for c in agg["of"]], axis=0
        )
        units[key] = agg["unit"]

    def finest(name):
        levels = [lvl for (n, lvl) in found if n == name]
        return min(levels, key=lambda lvl: _LEVELS.index(lvl) if lvl in _LEVELS else 99)

    chain_coords = {
        "chain": np.arange(chains),
        "draw": np.arange(burn_in, steps),
    }
    extra_coords = {
        "ensemble": ("chain", np.arange(chains) // walkers),
        "walker": ("chain", np.arange(chains) % walkers),
    }
    data_vars = {}
    coords = dict(chain_coords)
    for (name, level), groups in found.items():
        var = name if level == finest(name) or level is None else f"{name}_{level}"
        attrs = {"units": units[(name, level)]}
        if level is None:
            (draws,) = groups.values()
            data_vars[var] = (("chain", "draw"), draws, attrs)
            continue
        labels = list(groups)
        # A dimension shared by every variable over all of a level's members; a variable
        # over some of them (t0 and F_peak of first slides only) gets its own.
        dim = level if labels == members[level] else f"{var}_{level}"
        coords[dim] = labels
        data_vars[var] = (("chain", "draw", dim), np.stack(list(groups.values()), axis=-1), attrs)
    posterior = xr.Dataset(data_vars, coords={**coords, **extra_coords})

    sample_stats = xr.Dataset(
        {
            "lp": (("chain", "draw"), columns["log_density"]),
            "moved": (("chain", "draw"), _floats(raw["moved"], (chains, kept))),
        },
        coords={**chain_coords, **extra_coords},
    )
    sample_stats["lp"].attrs["description"] = "log posterior density (up to a constant)"
    sample_stats["moved"].attrs["description"] = (
        "1 where the walker's position changed at this step (some proposal of the step was "
        "accepted), 0 where it did not, NaN at step 0"
    )

    groups = {"posterior": posterior, "sample_stats": sample_stats}
    # Every observation of every run along one dimension, `observation`, with each one's run
    # and time as coordinates: one variable `force`, so that `az.loo(idata)` sees the whole
    # model's pointwise log-likelihood.
    if raw.get("observed") is not None:
        runs, times, forces = [], [], []
        for run, time, force in raw["observed"]:
            t = _floats(time, (-1,))
            runs.append(np.full(t.size, run, dtype=object))
            times.append(t)
            forces.append(_floats(force, (-1,)))
        obs_coords = {
            "observation": np.arange(sum(t.size for t in times)),
            "run_of_observation": ("observation", np.concatenate(runs).astype(str)),
            "time_s": ("observation", np.concatenate(times)),
        }
        groups["observed_data"] = xr.Dataset(
            {"force": (("observation",), np.concatenate(forces), {"units": "N"})},
            coords=obs_coords,
        )

        def pointwise(name, description):
            """A group over (chain, draw, observation) of the draws the library chose."""
            grid_chains = np.asarray(raw[f"{name}_chains"])
            grid_steps = np.asarray(raw[f"{name}_steps"])
            shape = (grid_chains.size, grid_steps.size, -1)
            values = np.concatenate([_floats(v, shape) for _, v in raw[name]], axis=2)
            ds = xr.Dataset(
                {"force": (("chain", "draw", "observation"), values)},
                coords={
                    "chain": grid_chains,
                    "draw": grid_steps,
                    "ensemble": ("chain", grid_chains // walkers),
                    "walker": ("chain", grid_chains % walkers),
                    **obs_coords,
                },
            )
            ds["force"].attrs["description"] = description
            return ds

        if raw.get("log_likelihood") is not None:
            groups["log_likelihood"] = pointwise(
                "log_likelihood", "ln N(observed force | model force, sigma^2) at the draw"
            )
        if raw.get("posterior_predictive") is not None:
            groups["posterior_predictive"] = pointwise(
                "posterior_predictive",
                "replicated observation: the model force at the draw plus Gaussian noise of "
                "the draw's sigma",
            )
            groups["posterior_predictive"]["force"].attrs["units"] = "N"

    sampler = summary["sampler"]
    attrs = {
        "inference_library": "slipbayes",
        "slipbayes_version": settings.get("slipbayes_version", _native.__version__),
        "seed": int(sampler["seed"]),
        "ensembles": int(ensembles),
        "walkers": int(walkers),
        "steps": int(steps),
        "burn_in": int(burn_in),
        "acceptance": float(sampler["acceptance"]),
        "converged": int(bool(sampler["converged"])),
        "stopped_by": str(sampler["stopped_by"]),
        "settings": json.dumps(settings["settings"]),
        "command": " ".join(settings.get("command", [])),
        "model_file": settings.get("model_file", ""),
        "chain_layout": "chain = ensemble * walkers + walker; draw = step (post-burn-in)",
    }
    if run_dir is not None:
        attrs["run_dir"] = os.fspath(run_dir)
    if raw.get("observed_error"):
        attrs["observed_data_missing"] = raw["observed_error"]
    if raw.get("log_likelihood_missing"):
        attrs["log_likelihood_missing"] = raw["log_likelihood_missing"]
        warnings.warn(
            "slipbayes: the result has no log_likelihood group, so az.loo and "
            "az.compare cannot use it: " + raw["log_likelihood_missing"],
            SlipbayesWarning,
            stacklevel=stacklevel,
        )
    for ds in groups.values():
        ds.attrs.update(attrs)
    return groups_of(groups)


def load(run_dir, log_likelihood_draws=2000):
    """The posterior of a finished run directory (``slipbayes fit ... --out RUN_DIR``) as
    ArviZ's container: an ``xarray.DataTree`` under ArviZ 1.x, an ``arviz.InferenceData``
    under ArviZ 0.x, with the same groups, variables and attributes.

    Groups: ``posterior`` (every reported quantity in SI units, named as in summary.json:
    ``alpha`` over ``material``, ``F_d`` and ``k`` over ``contact``, ``t0``, ``sigma`` and
    ``F_peak`` over ``run``; a quantity reported at two levels keeps its name at the finer one
    and gets ``_material`` (or ``_contact``) at the other, e.g. ``a`` and ``a_material``;
    variables over some of a level's members have a dimension of their own, e.g.
    ``F_peak_run``), ``sample_stats`` (``lp``, the log-density; ``moved``), ``observed_data``
    (``force``: every run's data as the fit used them, one after the other along
    ``observation``, whose coordinates ``run_of_observation`` and ``time_s`` say which run
    and when; select a run with ``.where(... == "name", drop=True)`` or a boolean mask),
    ``log_likelihood`` and ``posterior_predictive`` (below) and attributes with the seed, the
    settings and the version.

    Chains and draws: ``chain`` is a walker of an ensemble and ``draw`` a step, post-burn-in
    steps only. Then ArviZ's own functions reproduce slipbayes' numbers as follows:

    - ``az.ess(idata)`` (bulk, tail, mean), ``az.mcse`` and the ``mean``, ``sd``,
      ``ess_bulk``, ``ess_tail`` columns of ``az.summary(idata, round_to="none")`` are
      summary.json's ``ess_bulk``, ``ess_tail``, ``ess_mean``, ``mean`` and ``sd``:
      slipbayes counts every walker as a chain for ESS.
    - R̂ is between *ensembles* in slipbayes (the walkers of one ensemble move together and
      are not independent): ``az.rhat(slipbayes.ensembles_as_chains(idata))`` is
      summary.json's ``r_hat``. ``az.rhat(idata)`` treats walkers as independent chains,
      as ``az.from_emcee`` does, and reads higher (about 1.02 on the demo where slipbayes
      finds 1.001).
    - :func:`slipbayes.summary` is ``az.summary`` with its ``r_hat`` column taken from the
      ensembles: every column as slipbayes reports it.

    ``log_likelihood`` (for ``az.loo`` and ``az.compare``): ``force``, the pointwise
    log-likelihood ln N(F_i | model_i, σ²) of every observation of ``observed_data``, at
    every n-th kept step of every chain, n the smallest that evaluates at most about
    ``log_likelihood_draws`` draws (every draw of a long run would take gigabytes: 128 chains
    × 385 steps × 5,500 points is 2 GB); its ``draw`` coordinate says which steps. σ is the
    reported ``sigma`` of the draw (where the fit integrates σ out, its draw from the
    conditional posterior, so that the parameters and σ are a joint posterior draw). A run
    whose record was fitted on sufficient statistics (more than ``[likelihood] exact_up_to``
    points, 10,000 by default) keeps no likelihood per point, and leave-one-out needs every
    point's term: then the group is left out, the attribute ``log_likelihood_missing`` says
    why, and a ``SlipbayesWarning`` names the run (raise ``[likelihood] exact_up_to`` above
    its length, or fit a thinned copy of the record, to compare models on it).

    ``posterior_predictive`` (for ``az.plot_ppc_dist`` in ArviZ 1.x, ``az.plot_ppc`` in 0.x,
    and posterior predictive checks): ``force``,
    a replicated observation of every point of ``observed_data`` (same name, same
    ``observation`` dimension and coordinates) at each draw: the model force at the draw's
    parameters plus Gaussian noise of the draw's σ, computed by the library
    (``Posterior::replicated_observations``) at the draws of ``log_likelihood`` (also when
    that group is left out). The noise of the draw at step s of chain c comes from a stream
    of its own of the run's seed, so that loading a run twice, or with other
    ``log_likelihood_draws``, gives the same numbers for the same draw. When those draws
    would hold more than 25 million values (200 MB; a 10⁶-point record), fewer are used:
    evenly spaced steps of every chain, or one step of every m-th chain, as the group's
    ``chain`` and ``draw`` coordinates say.

    ``log_likelihood_draws=None`` leaves both groups out.
    """
    raw = _native.load_run(os.fspath(run_dir), log_likelihood_draws)
    return from_native(raw, run_dir)


def ensembles_as_chains(idata):
    """The posterior with one chain per *ensemble*, for ArviZ's ``rhat``.

    slipbayes splits each ensemble into its first and last ``steps // 2`` kept steps and
    pools all walkers within each half. Here each ensemble's draws are laid out as every
    walker's first half, then every walker's last half, so that ArviZ's own split of a chain
    into two halves is that split, and ``az.rhat(ensembles_as_chains(idata))`` equals
    summary.json's ``r_hat`` (the middle step of an odd number of kept steps is left out, as
    slipbayes leaves it out). Only R̂ is meaningful on this view: its draws are not in time
    order, so ESS on it is not an ESS.
    """
    import xarray as xr

    post = _dataset(idata.posterior)
    walkers = int(post.attrs["walkers"])
    ensembles = int(post.attrs["ensembles"])
    kept = post.sizes["draw"]
    half = kept // 2
    out = {}
    for name, da in post.data_vars.items():
        values = da.transpose("chain", "draw", ...).values
        rest = values.shape[2:]
        grid = values.reshape((ensembles, walkers, kept) + rest)
        first = grid[:, :, :half].reshape((ensembles, walkers * half) + rest)
        last = grid[:, :, kept - half :].reshape((ensembles, walkers * half) + rest)
        dims = ("chain", "draw") + da.dims[2:]
        out[name] = (dims, np.concatenate([first, last], axis=1), da.attrs)
    coords = {d: post.coords[d] for d in post.dims if d not in ("chain", "draw")}
    coords["chain"] = np.arange(ensembles)
    coords["draw"] = np.arange(2 * walkers * half)
    ds = xr.Dataset(out, coords=coords, attrs=dict(post.attrs))
    ds.attrs["chain_layout"] = (
        "chain = ensemble; draw = every walker's first half of the kept steps, then every "
        "walker's last half (for R-hat only)"
    )
    return groups_of({"posterior": ds})


def summary(idata, **kwargs):
    """``az.summary(idata)`` with ``r_hat`` between ensembles: every column as slipbayes
    reports it, unrounded unless ``round_to`` is given. Other keyword arguments go to
    ``az.summary``.

    Under ArviZ 1.x the tail ESS and the interval follow ``rcParams["stats.ci_prob"]``
    (0.89 by default: ESS of the 11 % and 89 % quantiles, an 89 % interval); here they are
    taken at 0.95 unless ``ci_prob`` is given, so that ``ess_tail`` is slipbayes' (and
    ArviZ 0.x's) ESS of the 5 % and 95 % quantiles and the interval columns
    (``eti95_lb``, ``eti95_ub``) are summary.json's 95 % equal-tailed interval. Under ArviZ
    0.x the interval columns are ArviZ's ``hdi_3%`` and ``hdi_97%``."""
    az = _arviz()
    kwargs.setdefault("round_to", "none")
    if arviz_1():
        with az.rc_context({"stats.ci_prob": kwargs.pop("ci_prob", 0.95)}):
            return _summary(az, idata, kwargs)
    return _summary(az, idata, kwargs)


def _summary(az, idata, kwargs):
    table = az.summary(idata, **kwargs)
    if "r_hat" in table:
        rhat = az.summary(
            ensembles_as_chains(idata),
            kind="diagnostics",
            **{k: v for k, v in kwargs.items() if k in ("var_names", "filter_vars", "coords", "round_to")},
        )["r_hat"]
        table["r_hat"] = rhat.reindex(table.index)
    return table
