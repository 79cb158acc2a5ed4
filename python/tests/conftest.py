"""Shared fixtures: the bundled PTFE contact of the repository, fitted once per session."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import slipbayes

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data"
# Fixed steps keep the session's fits at a few seconds each; every test that compares fits
# uses the same settings.
STEPS = 300
SEED = 7
# The law's parameters of the bundled PTFE data (SI), for simulations.
PTFE = dict(alpha_per_m=0.92e6, a_n=6.2e-3, f_d_n=10e-3, t0_s=14.8)


# ArviZ 1.x (Python >= 3.12) returns an xarray.DataTree; 0.x an InferenceData. The package
# supports both, and CI runs these tests under each.
import arviz as az

ARVIZ_1 = int(az.__version__.split(".")[0]) >= 1


def group_names(idata):
    """The groups of a DataTree (ArviZ 1.x) or an InferenceData (ArviZ 0.x)."""
    return set(idata.children) if ARVIZ_1 else set(idata.groups())


def p_loo(loo):
    """The effective number of parameters of ``az.loo``'s result in either version."""
    return loo.p if ARVIZ_1 else loo["p_loo"]


def same_bits(a, b):
    """Equal shapes and every float64 equal to the bit (NaN to NaN, 0.0 not -0.0)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def one_contact(first=None, repeat=None):
    """The bundled PTFE contact (first slide and repeat slide at 1 nm/s) as a model dict."""
    return {
        "material": [{"name": "PTFE"}],
        "contact": [{"name": "ptfe-c1", "material": "PTFE"}],
        "run": [
            {
                "name": "ptfe-c1-first",
                "contact": "ptfe-c1",
                "data": first if first is not None else str(DATA / "ptfe-c1-first.csv"),
                "velocity_m_per_s": 1e-9,
                "scene": "first",
            },
            {
                "name": "ptfe-c1-repeat",
                "contact": "ptfe-c1",
                "data": repeat if repeat is not None else str(DATA / "ptfe-c1-repeat.csv"),
                "velocity_m_per_s": 1e-9,
                "scene": "repeat",
            },
        ],
    }


ONE_CONTACT_TOML = """
[[material]]
name = "PTFE"

[[contact]]
name = "ptfe-c1"
material = "PTFE"

[[run]]
name = "ptfe-c1-first"
contact = "ptfe-c1"
data = "{data}/ptfe-c1-first.csv"
velocity_m_per_s = 1e-9
scene = "first"

[[run]]
name = "ptfe-c1-repeat"
contact = "ptfe-c1"
data = "{data}/ptfe-c1-repeat.csv"
velocity_m_per_s = 1e-9
scene = "repeat"
"""


@pytest.fixture(scope="session")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "ptfe.toml"
    path.write_text(ONE_CONTACT_TOML.format(data=DATA.as_posix()))
    return path


@pytest.fixture(scope="session")
def fitted(tmp_path_factory, model_file):
    """(DataTree or InferenceData, run directory) of the PTFE contact fitted from its model
    file."""
    out = tmp_path_factory.mktemp("fit") / "run"
    idata = slipbayes.fit(model_file, seed=SEED, steps=STEPS, out=out, progress=False)
    return idata, out


def slipbayes_binary():
    """The command line built from this repository (CI builds it before the Python tests),
    or None."""
    path = os.environ.get("SLIPBAYES_BIN") or REPO / "target" / "release" / "slipbayes"
    path = Path(path)
    if path.exists():
        return path
    found = shutil.which("slipbayes")
    return Path(found) if found else None
