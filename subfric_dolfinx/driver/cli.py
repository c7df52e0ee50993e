"""The command line of the material-point driver: ``python3 -m subfric_dolfinx.driver``."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from .case import CaseError, load_case
from .run import RunawayError, run_case

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status.

    0: stable and complete; 2: bad case or arguments; 3: stability lost (no stable quasi-static
    solution beyond the reported time) or runaway under stress control.
    """
    ap = argparse.ArgumentParser(
        prog="python3 -m subfric_dolfinx.driver",
        description="Material-point driver of the subloading-friction law.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    ap.add_argument("case", help="CASE.json")
    ap.add_argument(
        "--steps-per-mm", type=float, default=None, help="steps per mm (the case's when not given)"
    )
    ap.add_argument("--out", help="write the result to this JSON file")
    ap.add_argument(
        "--continue-unstable",
        action="store_true",
        help="go on after stability is lost (results flagged), instead of stopping",
    )
    args = ap.parse_args(argv)
    try:
        case = load_case(args.case)
        spm = args.steps_per_mm
        if spm is not None and not (math.isfinite(spm) and spm > 0):
            raise CaseError(f"--steps-per-mm must be finite and > 0, got {spm!r}")
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    code = 0
    try:
        result = run_case(
            case,
            steps_per_mm=args.steps_per_mm,
            on_instability="continue" if args.continue_unstable else "stop",
        )
        out = result.to_dict()
        if result.stability_lost is not None:
            lost = result.stability_lost
            r = f", r = {lost['r']:.4g}" if "r" in lost else ""
            print(
                f"unstable: no stable quasi-static solution beyond t = {lost['t']:.6g} "
                f"({lost['reason']}{r}, f_t1 = {lost['f_t1']:.6g} MPa)"
                + ("" if args.continue_unstable else "; stopped there"),
                file=sys.stderr,
            )
            code = 3
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except RunawayError as e:
        print(f"error: {e}", file=sys.stderr)
        out = e.partial.to_dict() if e.partial is not None else {}
        out["error"] = {"kind": "runaway", "t": e.t, "message": str(e)}
        code = 3
    text = json.dumps(out, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n")
    else:
        print(text)
    if code == 0:
        print(
            f"ok: {result.n_steps} steps in {result.wall_time:.3g} s; "
            + ", ".join(f"{k} {v}" for k, v in result.status_counts.items() if v),
            file=sys.stderr,
        )
    return code
