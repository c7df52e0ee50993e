"""The command line of the calibration: ``python3 -m subfric_dolfinx.calibrate``.

Exit codes as in the package docstring: 0 converged, 1 an output could not be written, 2 bad
data or arguments or unidentifiable parameters, 3 not converged (FIT.json written).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..commandline import ArgumentError, ArgumentParser, error_line
from ..driver.cli import check_out, program_name, write_atomically
from ..logs import launcher_rank
from .data import UNITS, CalibrationData, CalibrationError, Curve, load_data
from .fit import MAX_STEPS, STEPS_PER_MM, FitResult, fit, simulate

__all__ = ["main", "plot_fit"]


def plot_fit(data: CalibrationData, result: FitResult, path: Path, steps_per_mm: float) -> None:
    """Measured points and fitted curves, one colour per curve, written to ``path`` (PNG).

    Raises:
        CalibrationError: matplotlib is not installed (the extra ``plot``).
    """
    try:
        import matplotlib
    except ImportError:
        raise CalibrationError(
            "--plot needs matplotlib (pip install 'subfric-dolfinx[plot]', or Debian's "
            "python3-matplotlib)"
        ) from None

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dense = [
        Curve(c.f_n, c.velocity, np.linspace(0.0, c.slip[-1], 401), np.zeros(401))
        for c in data.curves
    ]
    model = simulate([result.params], dense, steps_per_mm)[0]
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for i, (c, d, f) in enumerate(zip(data.curves, dense, model, strict=True)):
        col = f"C{i % 10}"
        ax.plot(c.slip, c.f_t, "o", ms=3, color=col, alpha=0.6)
        ax.plot(d.slip, f, "-", color=col, label=f"{c.f_n:g} MPa, {c.velocity:g} mm/s")
    ax.set_xlabel(r"slip $\bar u_t$ (mm)")
    ax.set_ylabel(r"$f_t$ (MPa)")
    fitted = ", ".join(
        f"{k} = {result.params[k]:.4g} ± {result.stderr[k]:.2g} {UNITS[k]}" for k in result.fit
    )
    ax.set_title(f"data (points) and fit (lines); rms {result.rms:.3g} MPa", fontsize=10)
    fig.text(0.01, 0.01, fitted, fontsize=7)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".png", dir=path.parent)
    tmp = Path(name)
    try:
        with os.fdopen(fd, "wb") as fh:
            fig.savefig(fh, format="png", dpi=110)
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    ap = ArgumentParser(
        prog=program_name("subfric_dolfinx.calibrate"),
        description="Fit the subloading law to measured friction curves (least squares).",
    )
    ap.add_argument("data", help="DATA.json")
    ap.add_argument("--out", required=True, help="FIT.json (written atomically)")
    ap.add_argument("--plot", help="a PNG of the data and the fit")
    ap.add_argument(
        "--steps-per-mm",
        type=float,
        default=STEPS_PER_MM,
        help=f"step density of the driver (default {STEPS_PER_MM:g})",
    )
    ap.add_argument(
        "--max-evaluations",
        type=int,
        default=200,
        help="limit of the solver's residual evaluations (default 200)",
    )
    ap.add_argument(
        "--max-steps",
        type=float,
        default=MAX_STEPS,
        help=f"limit of the driver steps of the whole fit, checked before it "
        f"(default {MAX_STEPS:g})",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    try:
        args = ap.parse_args(argv)
    except ArgumentError as e:
        return error_line(str(e))
    if launcher_rank() != 0:  # under mpirun: rank 0 computes and writes, the others return
        return 0
    spm = args.steps_per_mm
    if not (math.isfinite(spm) and spm > 0):
        return error_line(f"--steps-per-mm must be finite and > 0, got {spm!r}")
    if args.max_evaluations < 1:
        return error_line(f"--max-evaluations must be >= 1, got {args.max_evaluations}")
    try:
        out = check_out(args.out)
        plot = check_out(args.plot) if args.plot else None
    except OSError as e:
        return error_line(str(e))
    try:
        data = load_data(args.data)
        if plot is not None and plot.suffix.lower() != ".png":
            raise CalibrationError(f"--plot {args.plot!r} must name a .png file")
        log = None if args.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
        result = fit(
            data,
            steps_per_mm=spm,
            max_evaluations=args.max_evaluations,
            log=log,
            max_steps=args.max_steps,
        )
    except CalibrationError as e:
        return error_line(str(e))
    except (RecursionError, MemoryError, OverflowError, TypeError, ValueError) as e:
        return error_line(f"malformed data file {args.data!r}: {type(e).__name__}: {e}")
    try:
        write_atomically(out, json.dumps(result.to_dict(), indent=1) + "\n")
    except OSError as e:
        return error_line(f"cannot write {str(out)!r}: {e.strerror or e}", 1)
    if plot is not None:
        try:
            plot_fit(data, result, plot, spm)
        except OSError as e:
            return error_line(f"cannot write {str(plot)!r}: {e.strerror or e}", 1)
    fitted = ", ".join(
        f"{k} {result.params[k]:.6g} ± {result.stderr[k]:.2g} {UNITS[k]}" for k in result.fit
    )
    if not result.converged:
        print(
            f"error: not converged ({result.message}); FIT.json holds the last values: {fitted}",
            file=sys.stderr,
        )
        return 3
    print(
        f"ok: {fitted}; rms {result.rms:.4g} MPa over {result.n_points} points, "
        f"{result.evaluations} driver runs in {result.seconds:.3g} s",
        file=sys.stderr,
    )
    return 0
