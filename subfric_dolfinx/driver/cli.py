"""The command line of the material-point driver: ``python3 -m subfric_dolfinx.driver``.

Exit codes: 0 stable and complete; 1 the result could not be written (``--out``); 2 a bad case
file or bad arguments (``error: ...`` on stderr, nothing run); 3 stability lost (no stable
quasi-static solution beyond the reported time) or runaway under stress control.

Every malformed case file (not readable, not UTF-8, not JSON, nested too deeply, numbers beyond
the float range, wrong types, unknown names) gets one ``error: ...`` line and exit code 2, before
any step. ``--out`` is checked before the run (its directory must exist and be writable, the path
must not be a directory or a device) and written atomically (a temporary file in the same
directory, renamed over the target), so a run never ends with its result lost or half written.
Long runs print a progress line to stderr at most every ``PROGRESS_SECONDS``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import stat
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from .. import logs
from ..commandline import ArgumentError, ArgumentParser, error_line
from ..logs import launcher_rank
from .case import MAX_TOTAL_STEPS, CaseError, load_case
from .run import RunawayError, run_case

__all__ = ["PROGRESS_SECONDS", "check_out", "main", "program_name", "write_atomically"]

PROGRESS_SECONDS = logs.PROGRESS_SECONDS  # at most one progress line per this many seconds


def check_out(path: str | Path) -> Path:
    """Check before a run that a result can be written to ``path``; return it.

    The directory must exist and accept a new file (probed by creating and removing a temporary
    one), and ``path`` must not be a directory or anything but a regular file (a device such as
    ``/dev/full`` is refused: the atomic rename would replace it).

    Raises:
        OSError: The message names the path and what is wrong.
    """
    p = Path(path)
    if p.name in ("", ".", ".."):
        raise OSError(f"--out {str(p)!r} names a directory, not a file")
    try:
        st = p.stat()
    except FileNotFoundError:
        st = None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OSError(f"--out {str(p)!r} is a directory")
        if not stat.S_ISREG(st.st_mode):
            raise OSError(f"--out {str(p)!r} is not a regular file (a device, pipe or socket)")
    parent = p.parent
    if not parent.is_dir():
        raise OSError(f"--out {str(p)!r}: the directory {str(parent)!r} does not exist")
    fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{p.name}.", suffix=".probe")
    os.close(fd)
    os.unlink(tmp)
    return p


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file next to ``path``, flush it to disk, rename it over.

    Raises:
        OSError: Disk full, permissions, ...; the target is untouched and no temporary file is
            left behind.
    """
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


class _Progress:
    """A progress line on stderr at most every ``PROGRESS_SECONDS`` (the first after that)."""

    def __init__(self) -> None:
        self.clock = logs.Progress(PROGRESS_SECONDS)

    def __call__(self, done: int, total: int, t: float) -> None:
        if self.clock.due():
            print(
                f"progress: {100.0 * done / total:.0f} % ({done} of {total} steps), "
                f"t = {t:.6g} s, {self.clock.elapsed:.0f} s elapsed",
                file=sys.stderr,
                flush=True,
            )


def program_name(module: str) -> str:
    """The command as called: its console script (``subfric-driver``) or ``python3 -m ...``."""
    name = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else ""
    return name if name.startswith("subfric-") else f"python3 -m {module}"


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status (see the module docstring)."""
    ap = ArgumentParser(
        prog=program_name("subfric_dolfinx.driver"),
        description="Material-point driver of the subloading-friction law.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    ap.add_argument("case", help="CASE.json")
    ap.add_argument(
        "--steps-per-mm", type=float, default=None, help="steps per mm (the case's when not given)"
    )
    ap.add_argument("--out", help="write the result to this JSON file (atomically)")
    ap.add_argument(
        "--max-steps",
        type=float,
        default=MAX_TOTAL_STEPS,
        help="refuse cases needing more steps in all",
    )
    ap.add_argument(
        "--continue-unstable",
        action="store_true",
        help="go on after stability is lost (results flagged), instead of stopping",
    )
    try:
        args = ap.parse_args(argv)
    except ArgumentError as e:
        return error_line(str(e))
    if launcher_rank() != 0:  # under mpirun: rank 0 computes and writes, the others return
        return 0
    try:
        spm = args.steps_per_mm
        if spm is not None and not (math.isfinite(spm) and spm > 0):
            raise CaseError(f"--steps-per-mm must be finite and > 0, got {spm!r}")
        if not (math.isfinite(args.max_steps) and args.max_steps >= 1):
            raise CaseError(f"--max-steps must be finite and >= 1, got {args.max_steps!r}")
        case = load_case(args.case)
        out_path = check_out(args.out) if args.out else None
    except CaseError as e:
        return error_line(str(e))
    except OSError as e:
        return error_line(str(e) if not e.strerror else f"--out {args.out!r}: {e.strerror}")
    except (RecursionError, MemoryError, OverflowError, TypeError, ValueError) as e:
        return error_line(f"malformed case file {args.case!r}: {type(e).__name__}: {e}")
    code = 0
    result = None
    try:
        result = run_case(
            case,
            steps_per_mm=spm,
            on_instability="continue" if args.continue_unstable else "stop",
            max_steps=args.max_steps,
            progress=_Progress(),
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
        return error_line(str(e))
    except RunawayError as e:
        print(f"error: {e}", file=sys.stderr)
        out = e.partial.to_dict() if e.partial is not None else {}
        out["error"] = {"kind": "runaway", "t": e.t, "message": str(e)}
        code = 3
    text = json.dumps(out, indent=1)
    if out_path is not None:
        try:
            write_atomically(out_path, text + "\n")
        except OSError as e:
            return error_line(f"cannot write {str(out_path)!r}: {e.strerror or e}", 1)
    else:
        print(text)
    if code == 0 and result is not None:
        print(
            f"ok: {result.n_steps} steps in {result.wall_time:.3g} s; "
            + ", ".join(f"{k} {v}" for k, v in result.status_counts.items() if v),
            file=sys.stderr,
        )
    return code
