# ---
# jupyter:
#   jupytext:
#     cell_markers: '"""'
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.16.4
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
"""# Calibrating the law to friction tests

Fit the subloading law to noisy synthetic friction curves: data, fit, errors, correlations.

Every user of a friction model first fits its parameters to their own friction tests. The
usual test slides a specimen at constant normal stress and constant velocity from rest and
records the tangential stress against the slip: a rise to a static peak, then softening to a
kinetic level. This demo does what a user would do with such curves, on "measured" curves that
the model itself computed (the Sec. 7 set of the paper) with noise added, so that the answer
is known:

```bash
python3 demos/calibration.py            # demos/output/calibration: DATA.json, FIT.json, PNG
python3 demos/calibration.py --quick    # fewer points and parameters (a check, a few s)
```

The same fit from the command line, on any DATA.json:

```bash
python3 -m subfric_dolfinx.calibrate DATA.json --out FIT.json --plot FIT.png
```

## What is fitted, and what the curves can tell

The law has eight parameters. At a prescribed normal stress `alpha_n` never shows (it only
turns `f_n` into a normal gap), and `alpha_t`, the elastic slope, is usually taken from the
unloading branch of the test. The five fitted here are the static and kinetic levels `mu_s`,
`mu_k`, the softening rate `kappa` (1/mm), the rate `u_tilde` at which the subloading surface
approaches the yield surface (the roundness of the rise), and the saturation constant `c_n`.

Some combinations cannot be told apart, and the calibration says so instead of returning
arbitrary numbers: at one sliding velocity the recovery `xi` (per second) trades off against
the softening (`kappa`, `mu_k`, per mm of slip); at one normal stress `c_n` trades off against
`mu_s` and `mu_k` (only `g(f_n) mu` shows). Below, the fit is refused once on purpose. And even
with five normal stresses `c_n` and `mu_s` stay strongly correlated: between 100 and 600 MPa
`g(f_n) = 1 - exp(-c_n f_n)` is nearly linear, and only its curvature separates them. The
correlation matrix in FIT.json shows it.
"""

# %%
from __future__ import annotations

# %%
import argparse
import json
import pathlib
import time
from collections.abc import Sequence

# %%
import numpy as np

# %%
from subfric_dolfinx.calibrate import (
    CalibrationError,
    fit,
    parse_data,
    synthetic_curves,
)
from subfric_dolfinx.calibrate.cli import plot_fit
from subfric_dolfinx.calibrate.data import UNITS
from subfric_dolfinx.commandline import main_block, program_args, summary
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.logs import launcher_rank

# %% [markdown]
"""
## The "measured" curves

The Sec. 7 set is the truth. Five curves at 100 to 600 MPa, 1 mm/s, slip to 4 mm sampled every
0.05 mm, with Gaussian noise of 0.2 MPa (the peaks are 8 to 46 MPa).
"""

# %%
TRUE = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}
FITTED = ["mu_s", "mu_k", "kappa", "u_tilde", "c_n"]
START = {**TRUE, "mu_s": 400.0, "mu_k": 80.0, "kappa": 1.0, "u_tilde": 10.0, "c_n": 3e-4}


# %%
def measured(quick: bool, noise: float, seed: int = 1) -> list[dict]:
    """The synthetic test curves (DATA.json's ``curves``)."""
    f_n = [150.0, 450.0] if quick else [100.0, 200.0, 300.0, 450.0, 600.0]
    slip = np.linspace(0.0, 4.0, 21 if quick else 81)
    return synthetic_curves(TRUE, f_n, [1.0] * len(f_n), slip, noise=noise, seed=seed)


# %% [markdown]
"""
## A refused fit

`xi` together with `kappa` from curves at one velocity: the calibration stops before fitting
and says why.
"""


# %%
def refused(curves: list[dict]) -> str:
    """The message of the fit the data cannot support."""
    data = parse_data({"params": TRUE, "fit": ["xi", "kappa"], "curves": curves})
    try:
        fit(data)
    except CalibrationError as e:
        return str(e)
    raise AssertionError("the fit of xi at one velocity was not refused")


# %% [markdown]
"""
## The fit

Least squares (`scipy.optimize.least_squares`) on the logarithms of the fitted parameters; each
Jacobian is one run of the batched material-point driver with all curves and all perturbed
parameter sets side by side. Standard errors and correlations come from the Jacobian at the
optimum.
"""


# %%
def run_demo(
    out: str | pathlib.Path, quick: bool = False, noise: float = 0.2, verbose: bool = True
) -> dict:
    """Write DATA.json, FIT.json and calibration.png into ``out``; return FIT.json's content."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say = print if verbose else (lambda *a, **k: None)
    curves = measured(quick, noise)
    fitted = FITTED[:3] if quick else FITTED
    start = {**TRUE, **{k: START[k] for k in fitted}}  # the others fixed at their true values
    raw = {"params": start, "fit": fitted, "curves": curves}
    (out / "DATA.json").write_text(json.dumps(raw, indent=1))
    say("refused on purpose:", refused(curves))
    data = parse_data(raw)
    res = fit(data, log=say if verbose else None)
    fit_json = res.to_dict()
    (out / "FIT.json").write_text(json.dumps(fit_json, indent=1))
    plot_fit(data, res, out / "calibration.png", 50.0)
    head = ("true", "start", "fitted", "stderr", "off/stderr")
    say(f"\n{'':8s} " + " ".join(f"{h:>10s}" for h in head) + "  unit")
    for k in fitted:
        off = (res.params[k] - TRUE[k]) / res.stderr[k]
        say(
            f"{k:8s} {TRUE[k]:10.4g} {START[k]:10.4g} {res.params[k]:10.4g} "
            f"{res.stderr[k]:10.2g} {off:10.2f}  {UNITS[k]}"
        )
    say(
        f"rms {res.rms:.3f} MPa (noise {noise} MPa), {res.evaluations} driver runs, "
        f"{res.seconds:.1f} s; correlation:"
    )
    for k, row in zip(fitted, res.correlation, strict=True):
        say(f"  {k:8s} " + " ".join(f"{c:+.3f}" for c in row))
    return fit_json


# %% [markdown]
"""
## What to read in the output

* `calibration.png`: the noisy points and the fitted curves, one colour per normal stress.
* The table: each fitted value against the truth, in units of its standard error (within 2-3
  standard errors, as noise of this size should leave them).
* The correlation of `c_n` with `mu_s` (about -0.999): the product `g(f_n) mu_s` is pinned by
  the peaks, the split between the two only by how the peaks grow with `f_n`.
"""


# %%
def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=summary(__doc__), formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    ap.add_argument("--out", default="demos/output/calibration", help="output directory")
    ap.add_argument("--quick", action="store_true", help="two curves, three parameters (a check)")
    ap.add_argument("--noise", type=float, default=0.2, help="noise of the curves, MPa")
    args = ap.parse_args(program_args(argv))  # in a notebook: the defaults
    if not args.noise >= 0:
        ap.error("--noise must be >= 0")
    if launcher_rank() != 0:  # under mpirun: rank 0 fits and writes, the others have nothing to do
        return 0
    t0 = time.perf_counter()
    run_demo(args.out, quick=args.quick, noise=args.noise)
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    main_block(main)
