"""Calibration of the subloading law to measured friction curves (scipy on the batched driver).

Command line::

    subfric-calibrate DATA.json --out FIT.json [--plot FIT.png]
    python3 -m subfric_dolfinx.calibrate DATA.json ...        # the same

DATA.json::

    {"params": {"alpha_t": 500, "alpha_n": 500, "mu_s": 500, "mu_k": 63, "kappa": 1.5,
                "xi": 0.022, "u_tilde": 15, "c_n": 2e-4},   # all eight: start or fixed values
     "fit": ["mu_s", "mu_k", "kappa", "u_tilde", "c_n"],
     "bounds": {"kappa": [0.1, 10]},                          # optional, [lo, hi], null: none
     "curves": [{"f_n": 300, "velocity": 1.0, "slip": [0, 0.05, ...], "f_t": [0, 9.1, ...]},
                {"f_n": 600, "velocity": 1.0, "csv": "run_600MPa.csv",    # or from a CSV file
                 "columns": {"slip": "disp_mm", "f_t": "shear_MPa"}},    # optional: its headers
                ...]}

Each curve is a monotonic slide at constant normal stress ``f_n`` (MPa) from the virgin state at
``velocity`` (mm/s; the recovery of ``mu`` makes the response rate dependent, so each curve's
velocity enters the model); ``slip`` is the tangential displacement ``ubar_t`` (mm), strictly
increasing from >= 0, and ``f_t`` the measured tangential stress (MPa) there. A curve may come
from a CSV file (a tribometer's export; relative to DATA.json's folder): a header line naming the
columns (``slip`` and ``f_t`` unless ``columns`` maps them to the file's own names), then rows of
numbers; ``,``, ``;`` or tab; lines starting with ``#`` (e.g. units) are skipped
(:func:`subfric_dolfinx.driver.case.read_table`).

Units: the hardening function ``mu`` and its bounds ``mu_s`` (static) and ``mu_k`` (kinetic) are
stresses in MPa (the strength is ``g(f_n) mu`` with ``g = 1 - exp(-c_n f_n)`` dimensionless), not
friction coefficients; ``alpha_t``, ``alpha_n`` MPa/mm, ``kappa`` and ``u_tilde`` 1/mm, ``xi`` 1/s,
``c_n`` 1/MPa.

FIT.json: ``{"params": {all eight}, "stderr": {fitted: standard error}, "correlation": [[...]]
(in the order of "fit"), "rms": MPa, "converged": bool, "fit": [...], "message", "n_points",
"evaluations", "seconds"}``.

Exit codes: 0 converged; 1 FIT.json or the plot could not be written; 2 bad data or arguments, or
parameters the data cannot identify (``error: ...`` on stderr, before the fit where possible);
3 the solver stopped without converging (FIT.json written, ``converged`` false).

Modules: :mod:`.data` (DATA.json), :mod:`.fit` (the model, least squares, identifiability,
statistics), :mod:`.cli` (command line, plot).

May import: :mod:`subfric_dolfinx.driver`, :mod:`subfric_dolfinx.constitutive`, the layer-0
modules (:mod:`subfric_dolfinx.values`, :mod:`subfric_dolfinx.commandline`, ...), numpy, scipy
(matplotlib for ``--plot`` only, when asked).
"""

from .data import NAMES, CalibrationData, CalibrationError, Curve, load_data, parse_data
from .fit import IDENT_TOL, STEPS_PER_MM, FitResult, fit, simulate, synthetic_curves

__all__ = [
    "IDENT_TOL",
    "NAMES",
    "STEPS_PER_MM",
    "CalibrationData",
    "CalibrationError",
    "Curve",
    "FitResult",
    "fit",
    "load_data",
    "parse_data",
    "simulate",
    "synthetic_curves",
]
