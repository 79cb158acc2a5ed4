"""slipbayes: Bayesian inference of the onset of frictional slip, from Python.

The Rust library does every computation; this package moves numpy arrays in and builds
ArviZ objects out. All values are SI (N, s, m/s, 1/m, N/m).

- :func:`law`, :func:`simulate`, :func:`peak`: the friction law in interface time, the force
  a slide records in instrument time, and the static friction peak, vectorised over numpy
  arrays.
- :func:`fit`: fit a model file or a dict; returns ArviZ's container of groups: an
  ``xarray.DataTree`` under ArviZ 1.x (Python >= 3.12), an ``arviz.InferenceData`` under 0.x.
- :func:`load`: the same object for a finished ``slipbayes fit`` run directory.
- :func:`ensembles_as_chains`, :func:`summary`: R̂ as slipbayes computes it (between
  ensembles), with ArviZ.
- :func:`arviz_1`: whether the installed ArviZ is 1.x (DataTree) rather than 0.x.
- :class:`SlipbayesError`: every error of the library, with its message.
- :class:`SlipbayesWarning`: a result lacks something (a ``log_likelihood`` group left out).
"""

from slipbayes._native import SlipbayesError, __version__
from slipbayes._law import Peak, Simulated, law, peak, simulate
from slipbayes._fit import fit
from slipbayes._idata import SlipbayesWarning, arviz_1, ensembles_as_chains, load, summary

__all__ = [
    "SlipbayesError",
    "SlipbayesWarning",
    "__version__",
    "Peak",
    "Simulated",
    "law",
    "peak",
    "simulate",
    "fit",
    "load",
    "ensembles_as_chains",
    "summary",
    "arviz_1",
]
