"""Reference posteriors from posteriordb, for tests/posteriordb.rs and benches/posteriordb.rs.

Usage:  python tests/reference/posteriordb/make_reference.py MIRROR
where MIRROR is a git directory of stan-dev/posteriordb (a bare clone works: every file is read
with `git show HEAD:...`). Needs numpy, scipy and arviz. Writes, beside this script:

- data/<data name>.json: the posterior's data, as posteriordb publishes it, compact.
- reference/<posterior>.json: per constrained parameter (named as posteriordb names it) the
  reference draws' mean, sd, quantiles (5, 25, 50, 75, 95 %), and the reference's own Monte
  Carlo standard errors of the mean and of the sd (ArviZ `mcse`, method "mean" and "sd", with
  the reference's chains as chains); the number of draws and chains; the posteriordb commit.
  The means are checked against posteriordb's own summary_statistics/mean_value file: a
  disagreement beyond rounding stops the script.
- ode_reference.json: solutions of the two ODE models (Lotka-Volterra; one-compartment
  Michaelis-Menten elimination with first-order absorption) at a few parameter points, by
  scipy's solve_ivp with DOP853 and Radau at rtol 1e-13, which must agree with each other to
  1e-10 relative (plus 1e-12 absolute); the Rust integrator of the tests is checked against
  them.
- density_reference.json: each posterior's log-density at three points of its sampled
  (unconstrained) coordinates, from an independent scipy.stats transcription of the Stan
  program (whole densities, Jacobians of the transforms included; the ODEs by DOP853 at
  rtol 1e-12); the tests compare the differences between the points with the Rust densities.

Parameters whose posterior sd does not exist (HEAVY_TAILED below) also get the same summary of
their logarithm, with Hill estimates of the tail index as evidence; the tests compare those on
the log scale. The centred eight schools has no draws of its own: posteriordb names the non-centred
reference for it (same posterior over mu, tau, theta), and so do the tests.
"""

import io
import json
import pathlib
import subprocess
import sys
import zipfile

import arviz as az
import numpy as np
from scipy import stats
from scipy.integrate import solve_ivp
from scipy.special import expit

HERE = pathlib.Path(__file__).resolve().parent
DB = "posterior_database"
POSTERIORS = [
    "eight_schools-eight_schools_noncentered",
    "arK-arK",
    "garch-garch11",
    "low_dim_gauss_mix-low_dim_gauss_mix",
    "hudson_lynx_hare-lotka_volterra",
    "one_comp_mm_elim_abs-one_comp_mm_elim_abs",
]
# The centred eight schools shares the non-centred reference (posteriordb says so too).
EXTRA_DATA = ["eight_schools-eight_schools_centered"]
QUANTILES = [0.05, 0.25, 0.5, 0.75, 0.95]
# Parameters whose posterior sd does not exist. In one_comp_mm_elim_abs, for K_m >> C the
# elimination is linear, (V_m/K_m) C/V, so the likelihood fixes only r = V_m/K_m and the tail
# is the two half-Cauchy priors along V_m = r K_m: p(K_m) ~ K_m^-2 (r K_m)^-2 K_m ~ K_m^-3,
# and V_m likewise, a tail of index 2: finite mean, infinite variance. The sample sd then grows
# with the number of draws and no MCSE describes it; these are compared on the log scale (the
# sampled coordinate), where every moment exists. The Hill estimates of the tail index from
# the reference draws are written as evidence (below 2 or near it).
HEAVY_TAILED = {"one_comp_mm_elim_abs-one_comp_mm_elim_abs": ["K_m", "V_m"]}
HILL_K = [100, 300, 1000]
# posteriordb's mean_value files are rounded to ~15 significant digits.
MEAN_CHECK_RTOL = 1e-9
MEAN_CHECK_ATOL = 1e-12
# Two independent high-order integrators must agree this closely for a solution to be kept.
# (absolute as well as relative: the one-compartment concentration decays to ~1e-6, where the
# integrators' atol, not their rtol, bounds the error).
ODE_RTOL = 1e-13
ODE_ATOL = 1e-14
ODE_AGREE = 1e-10
ODE_AGREE_ATOL = 1e-12


def git_show(mirror, path):
    return subprocess.run(
        ["git", "-C", str(mirror), "show", f"HEAD:{path}"],
        check=True,
        capture_output=True,
    ).stdout


def unzip_json(blob):
    with zipfile.ZipFile(io.BytesIO(blob)) as z:
        (name,) = z.namelist()
        return json.loads(z.read(name))


def write_json(path, value, compact):
    path.parent.mkdir(parents=True, exist_ok=True)
    text = (
        json.dumps(value, separators=(",", ":"))
        if compact
        else json.dumps(value, indent=1)
    )
    path.write_text(text + "\n")


def reference(mirror, commit, posterior):
    info = json.loads(git_show(mirror, f"{DB}/posteriors/{posterior}.json"))
    ref_name = info["reference_posterior_name"]
    chains = unzip_json(
        git_show(mirror, f"{DB}/reference_posteriors/draws/draws/{ref_name}.json.zip")
    )
    names = list(chains[0].keys())
    lengths = {len(c[n]) for c in chains for n in names}
    if len(lengths) != 1:
        sys.exit(f"{posterior}: chains of unequal length {sorted(lengths)}")
    published = json.loads(
        git_show(
            mirror,
            f"{DB}/reference_posteriors/summary_statistics/mean_value/mean_value/{ref_name}.json",
        )
    )
    published_mean = dict(zip(published["names"], published["mean_value"]))
    params = []
    for n in names:
        x = np.array([c[n] for c in chains], dtype=float)  # chains x draws
        flat = x.ravel()
        mean = float(flat.mean())
        want = published_mean[n]
        if not np.isclose(mean, want, rtol=MEAN_CHECK_RTOL, atol=MEAN_CHECK_ATOL):
            sys.exit(
                f"{posterior}: mean of {n} from the draws is {mean!r} but posteriordb's "
                f"mean_value file says {want!r}"
            )
        param = {
            "name": n,
            "mean": mean,
            "sd": float(flat.std(ddof=1)),
            "quantiles": [float(q) for q in np.quantile(flat, QUANTILES)],
            "mcse_mean": float(az.mcse(x, method="mean")),
            "mcse_sd": float(az.mcse(x, method="sd")),
            "ess_bulk": float(az.ess(x, method="bulk")),
        }
        if n in HEAVY_TAILED.get(posterior, []):
            lx = np.log(x)
            top = np.sort(flat)[::-1]
            param["hill_tail_index"] = {
                str(k): float(1.0 / np.mean(np.log(top[:k] / top[k]))) for k in HILL_K
            }
            param["log"] = {
                "mean": float(lx.mean()),
                "sd": float(lx.ravel().std(ddof=1)),
                "mcse_mean": float(az.mcse(lx, method="mean")),
                "mcse_sd": float(az.mcse(lx, method="sd")),
            }
        params.append(param)
    return {
        "posterior": posterior,
        "reference_posterior": ref_name,
        "model": info["model_name"],
        "data": info["data_name"],
        "posteriordb_commit": commit,
        "chains": len(chains),
        "draws": len(chains) * lengths.pop(),
        "quantile_probs": QUANTILES,
        "parameters": params,
    }


# --- Log-densities written independently with scipy.stats (whole densities, constants
# included), in the coordinates of the Rust densities (tests/posteriordb_models/models.rs):
# positive parameters as logs, (0, 1) as logits, beta1 as logit(beta1 / (1 - alpha1)), the
# ordered pair as (mu1, ln(mu2 - mu1)). The tests compare differences between points, where
# the constants cancel.
_DATA = {}


def DATA(name):
    return _DATA[name]


def es_nc(x):
    d = DATA("eight_schools")
    y, s = np.array(d["y"]), np.array(d["sigma"])
    theta_trans, mu, tau = x[:8], x[8], np.exp(x[9])
    theta = theta_trans * tau + mu
    return (
        stats.norm.logpdf(theta_trans).sum()
        + stats.norm.logpdf(y, theta, s).sum()
        + stats.norm.logpdf(mu, 0, 5)
        + stats.halfcauchy.logpdf(tau, 0, 5)
        + x[9]
    )


def es_c(x):
    d = DATA("eight_schools")
    y, s = np.array(d["y"]), np.array(d["sigma"])
    mu, tau, theta = x[0], np.exp(x[1]), x[2:]
    return (
        stats.halfcauchy.logpdf(tau, 0, 5)
        + stats.norm.logpdf(theta, mu, tau).sum()
        + stats.norm.logpdf(y, theta, s).sum()
        + stats.norm.logpdf(mu, 0, 5)
        + x[1]
    )


def ark(x):
    d = DATA("arK")
    y, k = np.array(d["y"]), d["K"]
    alpha, beta, sigma = x[0], x[1 : k + 1], np.exp(x[k + 1])
    lp = (
        stats.norm.logpdf(alpha, 0, 10)
        + stats.norm.logpdf(beta, 0, 10).sum()
        + stats.halfcauchy.logpdf(sigma, 0, 2.5)
        + x[k + 1]
    )
    for t in range(k, len(y)):
        mu = alpha + sum(beta[j] * y[t - j - 1] for j in range(k))
        lp += stats.norm.logpdf(y[t], mu, sigma)
    return lp


def garch(x):
    d = DATA("garch")
    y = np.array(d["y"])
    mu, alpha0, alpha1 = x[0], np.exp(x[1]), expit(x[2])
    frac = expit(x[3])
    beta1 = (1 - alpha1) * frac
    # ln|J|: exp, logit, and the (0, 1 - alpha1) bound of beta1.
    jac = x[1] + np.log(alpha1 * (1 - alpha1)) + np.log((1 - alpha1) * frac * (1 - frac))
    sigma = [d["sigma1"]]
    for t in range(1, len(y)):
        sigma.append(np.sqrt(alpha0 + alpha1 * (y[t - 1] - mu) ** 2 + beta1 * sigma[-1] ** 2))
    return jac + stats.norm.logpdf(y, mu, np.array(sigma)).sum()


def gmix(x):
    y = np.array(DATA("low_dim_gauss_mix")["y"])
    mu1 = x[0]
    mu2 = mu1 + np.exp(x[1])
    s1, s2, theta = np.exp(x[2]), np.exp(x[3]), expit(x[4])
    jac = x[1] + x[2] + x[3] + np.log(theta * (1 - theta))
    lp = (
        stats.halfnorm.logpdf([s1, s2], 0, 2).sum()
        + stats.norm.logpdf([mu1, mu2], 0, 2).sum()
        + stats.beta.logpdf(theta, 5, 5)
    )
    lp += np.logaddexp(
        np.log(theta) + stats.norm.logpdf(y, mu1, s1),
        np.log(1 - theta) + stats.norm.logpdf(y, mu2, s2),
    ).sum()
    return lp + jac


def lv(x):
    d = DATA("hudson_lynx_hare")
    p = np.exp(x)
    th, z0, sig = p[:4], p[4:6], p[6:8]
    z = solve_ivp(
        lambda t, z: lotka_volterra(t, z, th),
        (0, d["ts"][-1]),
        z0,
        t_eval=d["ts"],
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
    ).y.T
    lp = (
        stats.norm.logpdf(th[[0, 2]], 1, 0.5).sum()
        + stats.norm.logpdf(th[[1, 3]], 0.05, 0.05).sum()
        + stats.lognorm.logpdf(sig, 1, scale=np.exp(-1)).sum()
        + stats.lognorm.logpdf(z0, 1, scale=10).sum()
    )
    y = np.array(d["y"])
    for k in range(2):
        lp += stats.lognorm.logpdf(d["y_init"][k], sig[k], scale=z0[k])
        lp += stats.lognorm.logpdf(y[:, k], sig[k], scale=z[:, k]).sum()
    return lp + x.sum()


def oc(x):
    d = DATA("one_comp_mm_elim_abs")
    p = np.exp(x)
    c = solve_ivp(
        lambda t, c: one_comp(t, c, p[:3], d["D"], d["V"]),
        (d["t0"], d["times"][-1]),
        [0.0],
        t_eval=d["times"],
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
    ).y[0]
    lp = stats.halfcauchy.logpdf(p, 0, 1).sum()
    lp += stats.lognorm.logpdf(d["C_hat"], p[3], scale=c).sum()
    return lp + x.sum()


# Where the densities are compared: a modeller's start and two points near it (the Rust
# densities' own coordinates; the centred eight schools is (mu, ln tau, theta)).
DENSITY_POINTS = {
    "eight_schools-eight_schools_noncentered": [0.0] * 9 + [1.0],
    "eight_schools-eight_schools_centered": [0.0, 1.0] + [0.0] * 8,
    "arK-arK": [0.0] * 7,
    "garch-garch11": [0.0] * 4,
    "low_dim_gauss_mix-low_dim_gauss_mix": [-1.0, float(np.log(2.0)), 0.0, 0.0, 0.0],
    "hudson_lynx_hare-lotka_volterra": [
        float(v) for v in np.log([1.0, 0.05, 1.0, 0.05, 30.0, 4.0, np.exp(-1), np.exp(-1)])
    ],
    "one_comp_mm_elim_abs-one_comp_mm_elim_abs": [0.0] * 4,
}
DENSITIES = {
    "eight_schools-eight_schools_noncentered": es_nc,
    "eight_schools-eight_schools_centered": es_c,
    "arK-arK": ark,
    "garch-garch11": garch,
    "low_dim_gauss_mix-low_dim_gauss_mix": gmix,
    "hudson_lynx_hare-lotka_volterra": lv,
    "one_comp_mm_elim_abs-one_comp_mm_elim_abs": oc,
}


def density_reference(data):
    _DATA.update(data)
    out = {}
    for name, start in DENSITY_POINTS.items():
        points = [
            [v + 0.1 * ((i * 7 + k * 3) % 5) - 0.2 for i, v in enumerate(start)]
            for k in range(3)
        ]
        lp = [float(DENSITIES[name](np.array(x))) for x in points]
        out[name] = {"points": points, "log_density": lp}
    return out


def lotka_volterra(t, z, theta):
    alpha, beta, gamma, delta = theta
    u, v = z
    return [(alpha - beta * v) * u, (-gamma + delta * u) * v]


def one_comp(t, c, theta, dose_mg, volume_l):
    k_a, k_m, v_m = theta
    dose = np.exp(-k_a * t) * dose_mg * k_a / volume_l if t > 0 else 0.0
    return [dose - (v_m / volume_l) * c[0] / (k_m + c[0])]


def solve(rhs, y0, ts, what):
    sols = []
    for method in ("DOP853", "Radau"):
        s = solve_ivp(
            rhs,
            (0.0, ts[-1]),
            y0,
            method=method,
            t_eval=ts,
            rtol=ODE_RTOL,
            atol=ODE_ATOL,
        )
        if not s.success:
            sys.exit(f"{what}: {method} failed: {s.message}")
        sols.append(s.y.T)
    if not np.allclose(sols[0], sols[1], rtol=ODE_AGREE, atol=ODE_AGREE_ATOL):
        worst = np.max(np.abs(sols[0] - sols[1]) / np.abs(sols[1]))
        sys.exit(f"{what}: DOP853 and Radau disagree by {worst:.2e} relative")
    return sols[0].tolist()


def ode_reference(data):
    lv = data["hudson_lynx_hare"]
    ts = [float(t) for t in lv["ts"]]
    lv_points = [
        # Near the posterior mean, then two points well away from it.
        {"theta": [0.55, 0.028, 0.80, 0.024], "z_init": [33.9, 5.9]},
        {"theta": [1.0, 0.05, 1.0, 0.05], "z_init": [10.0, 10.0]},
        {"theta": [0.3, 0.01, 1.5, 0.04], "z_init": [60.0, 3.0]},
    ]
    for p in lv_points:
        p["z"] = solve(
            lambda t, z, th=p["theta"]: lotka_volterra(t, z, th),
            p["z_init"],
            ts,
            f"lotka_volterra at {p['theta']}",
        )
    oc = data["one_comp_mm_elim_abs"]
    times = [float(t) for t in oc["times"]]
    oc_points = [
        {"k_a": 0.9, "K_m": 0.4, "V_m": 4.6},
        {"k_a": 2.0, "K_m": 5.0, "V_m": 20.0},
        {"k_a": 0.3, "K_m": 0.01, "V_m": 1.0},
    ]
    for p in oc_points:
        th = [p["k_a"], p["K_m"], p["V_m"]]
        p["C"] = [
            c[0]
            for c in solve(
                lambda t, c, th=th: one_comp(t, c, th, oc["D"], oc["V"]),
                [0.0],
                times,
                f"one_comp_mm_elim_abs at {th}",
            )
        ]
    return {
        "method": f"scipy solve_ivp DOP853, rtol {ODE_RTOL}, atol {ODE_ATOL}; agrees with "
        f"Radau to {ODE_AGREE} relative + {ODE_AGREE_ATOL} absolute",
        "lotka_volterra": {"ts": ts, "points": lv_points},
        "one_comp_mm_elim_abs": {
            "times": times,
            "D": oc["D"],
            "V": oc["V"],
            "points": oc_points,
        },
    }


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    mirror = pathlib.Path(sys.argv[1])
    commit = (
        subprocess.run(
            ["git", "-C", str(mirror), "rev-parse", "HEAD"],
            check=True,
            capture_output=True,
        )
        .stdout.decode()
        .strip()
    )
    data = {}
    for posterior in POSTERIORS + EXTRA_DATA:
        info = json.loads(git_show(mirror, f"{DB}/posteriors/{posterior}.json"))
        name = info["data_name"]
        if name not in data:
            data[name] = unzip_json(git_show(mirror, f"{DB}/data/data/{name}.json.zip"))
            write_json(HERE / "data" / f"{name}.json", data[name], compact=True)
    for posterior in POSTERIORS:
        ref = reference(mirror, commit, posterior)
        write_json(HERE / "reference" / f"{posterior}.json", ref, compact=False)
        print(f"{posterior}: {len(ref['parameters'])} parameters, {ref['draws']} draws")
    write_json(HERE / "ode_reference.json", ode_reference(data), compact=False)
    write_json(HERE / "density_reference.json", density_reference(data), compact=False)
    print("ode_reference.json and density_reference.json written")


if __name__ == "__main__":
    main()
