"""Run every demo as the README's table says and keep what the README and the docs quote.

    ./run exec python3 docs/demo_results.py            # all (about 5 minutes on 2 cores)
    ./run exec python3 docs/demo_results.py --only lap_joint punch

(``./run refresh`` runs this with the report and rewrites the quotes.) Each run is ``mpirun -n 2
python3 docs/demo_results.py --child KEY`` (the numpy-only demos: one process), which calls the
demo's ``main`` with the options of :data:`RUNS` and writes on rank 0 what the demo measured
(:func:`numbers`) and the warnings it issued; the wall time recorded is that of the whole command
(start-up included: what a user typing it waits). Besides each demo's default run (and the
variants the README quotes) every demo has a run at its smallest size (``<demo>_small``, the
sizes of :data:`SMALL`): ``tests/demos/test_records.py`` re-runs those and the cheap quoted runs
on the current code and compares what they measure with these records. This script then copies
the figures of the default runs into ``docs/figures/<demo>/`` (the demo pages show them) and
writes ``docs/demo_results.json``, stamped with the commit, date and load of the run
(``report/stamp.py``; each run carries its own stamp too).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "demo_results.json"
FIGURES = HERE / "figures"
if not __package__:  # run as a script, not imported as docs.demo_results: the repository's packages
    sys.path.insert(0, str(ROOT))
from report import stamp as stamps  # noqa: E402


@dataclass(frozen=True)
class Run:
    """One recorded run of a demo.

    Attributes:
        demo: The demo (``demos/<demo>.py``).
        options: Its command-line options.
        ranks: MPI ranks (1: a plain process).
        figures: Its figures go to the docs' demo page.
    """

    demo: str
    options: tuple[str, ...] = ()
    ranks: int = 2
    figures: bool = False

    @property
    def command(self) -> list[str]:
        """The command a user types for this run."""
        cmd = ["python3", f"demos/{self.demo}.py", *self.options]
        return ["mpirun", "-n", str(self.ranks), *cmd] if self.ranks > 1 else cmd


DEMOS = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
"""Every demo of the repository."""

NUMPY_ONLY = ("calibration", "paper_figures")
"""Demos without MPI or DOLFINx: recorded in one process."""

SMALL: dict[str, tuple[str, ...]] = {
    "block_on_base": ("--n", "4", "--hold", "1", "--dt", "0.1"),
    "pad_on_plate": ("--n", "2", "--holds", "0", "5", "--dt", "0.1"),
    "punch": ("--n", "4", "--dt", "0.1"),
    "lap_joint": ("--n", "4", "--cycles", "2", "--dt", "0.2"),
    "elastic_smoke": ("--n", "4"),
    "paper_figures": ("--quick", "--only", "fig5"),
    "calibration": ("--quick",),
    "hertz": ("--n", "4"),
    "cattaneo_mindlin": ("--n", "4", "--no-subloading"),
    "bolted_joint": ("--n", "2", "--cycles", "1"),
    "user_loop": ("--n", "4", "--dt", "0.25"),
    "shrink_fit": ("--h", "5", "--steps", "4"),
    "bolt_clamped_joint": ("--h", "5", "--cycles", "1", "--dt", "1"),
    "fretting": ("--n", "4", "--cycles", "1", "--steps", "4", "--no-subloading"),
    "block_sliding_far": ("--n", "4", "--slide", "20"),
    "stick_slip": ("--steps", "100"),
    "two_bodies_api": ("--n", "4", "--dt", "0.1"),
}
"""Each demo's smallest configuration (the test suite's sizes)."""


def _runs() -> dict[str, Run]:
    runs = {
        "hertz_n4": Run("hertz", ("--n", "4")),
        "hertz_n8": Run("hertz", ("--n", "8")),
        "hertz_apart_n4": Run("hertz", ("--n", "4", "--meshed-apart")),
        "hertz_apart_n8": Run("hertz", ("--n", "8", "--meshed-apart")),
        "cattaneo_mindlin_n4": Run("cattaneo_mindlin", ("--n", "4", "--no-subloading")),
        "cattaneo_mindlin_n16": Run("cattaneo_mindlin", ("--n", "16", "--no-subloading")),
    }
    for demo in DEMOS:
        ranks = 1 if demo in NUMPY_ONLY else 2
        runs[demo] = Run(demo, (), ranks, figures=demo != "elastic_smoke")
        if demo in SMALL:
            runs[f"{demo}_small"] = Run(demo, SMALL[demo], ranks)
    return dict(sorted(runs.items()))


RUNS: dict[str, Run] = _runs()
"""Every recorded run by key: each demo's default run, its smallest one, the quoted variants."""


def plain(v: Any, limit: int = 64) -> Any:
    """A JSON value of ``v`` (arrays of at most ``limit`` numbers; larger ones dropped)."""
    if isinstance(v, dict):
        out = {str(k): plain(x, limit) for k, x in v.items()}
        return {k: x for k, x in out.items() if x is not None}
    if isinstance(v, list | tuple | np.ndarray):
        a = np.asarray(v, dtype=object)
        if a.size > limit:
            return None
        return [plain(x, limit) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if v is None or isinstance(v, bool | int | float | str):
        return v
    return None


def digest(rows: Any) -> dict[str, Any]:
    """A history (a sequence of row dicts) in a few numbers.

    Its steps, and each numeric column's largest, smallest and last value.
    """
    rows = list(rows)
    out: dict[str, Any] = {"steps": len(rows)}
    if not rows:
        return out
    for col in rows[0]:
        vals = [r.get(col) for r in rows]
        if all(isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in vals):
            a = np.asarray(vals, dtype=float)
            out[col] = {"max": float(a.max()), "min": float(a.min()), "last": float(a[-1])}
    return out


def _csv_digest(path: Path) -> dict[str, Any]:
    """A CSV file's numeric columns: largest, smallest and last value, and the row count."""
    import csv

    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out: dict[str, Any] = {"rows": len(rows)}
    for k in rows[0] if rows else ():
        try:
            a = np.array([float(r[k]) for r in rows])
        except (TypeError, ValueError):
            continue  # a text column
        out[k] = {"max": float(a.max()), "min": float(a.min()), "last": float(a[-1])}
    return out


def numbers(demo: str, result: Any, files: Path | None = None) -> dict[str, Any]:
    """What the demo measured, from the object its ``main`` returned.

    The numpy-only demos' ``main`` returns an exit code: what they measured is read from the
    files they wrote into ``files``.
    """
    if demo == "calibration":
        return plain(json.loads((files / "FIT.json").read_text()))
    if demo == "paper_figures":
        return {f.stem: _csv_digest(f) for f in sorted(files.glob("*.csv"))}
    if demo == "block_on_base":
        h = result.history
        t = np.array([r["t"] for r in h])
        ft = np.array([r["F_t1"] / r["area"] for r in h])
        out: dict[str, Any] = {"history": digest(h), "info": plain(result.info)}
        for name, window, sign in (
            ("peak_forward", (t > 1) & (t <= 2), 1),
            ("peak_reverse", (t > 2) & (t <= 4), -1),
            ("peak_reload", t > 24, 1),
        ):
            if window.any():
                out[name] = float((sign * ft[window]).max())
        return out
    if demo == "lap_joint":
        from demos import lap_joint

        out = {}
        t_end = max(r["t"] for r in next(iter(result.values())).history)
        cycles = int(np.rint((t_end - lap_joint.CLAMP_TIME) / lap_joint.PERIOD))
        for name, res in result.items():
            s = lap_joint.slip_per_cycle(res.history, cycles)
            out[name] = {
                "slip_per_cycle_um": (1e3 * np.diff(s)).tolist(),
                "total_um": 1e3 * float(s[-1] - s[0]),
                "history": digest(res.history),
            }
        return out
    if demo == "punch":
        return {**plain(result[0].info["punch"]), "history": digest(result[0].history)}
    if demo == "cattaneo_mindlin":
        cres, sres = result
        out = {"coulomb": plain(cres.info["cattaneo_mindlin"])}
        if sres is not None:
            out["subloading"] = plain(sres.info["slips"])
        return out
    if demo in ("block_sliding_far", "stick_slip"):
        return plain(result["report"])
    if isinstance(result, dict):
        out = {}
        for k, v in result.items():
            if k == "history" or k == "reference":
                out[k] = digest(v)
            elif k == "results" and isinstance(v, dict):
                out[k] = {
                    name: digest(r["history"] if isinstance(r, dict) else r.history)
                    for name, r in v.items()
                    if (isinstance(r, dict) and "history" in r) or hasattr(r, "history")
                }
            else:
                out[k] = plain(v)
        return {k: v for k, v in out.items() if v is not None}
    out = plain(getattr(result, "info", None) or {})
    if hasattr(result, "history"):
        out["history"] = digest(result.history)
    return out


def measure(key: str, files: Path, comm: Any = None) -> dict[str, Any]:
    """Run ``RUNS[key]`` in this process (on ``comm``'s ranks); what it measured and warned.

    Args:
        key: The run.
        files: The demo's output directory (``--out``).
        comm: The communicator of the demo's ``main`` (``None``: a numpy-only demo, or
            ``MPI.COMM_WORLD``).

    Returns:
        ``{"numbers": ..., "warnings": [...], "main_s": ...}`` on every rank (the numbers of rank
        0; the warnings of the package's own classes, as text).
    """
    import importlib
    import inspect

    run = RUNS[key]
    module = importlib.import_module(f"demos.{run.demo}")
    argv = [*run.options, "--out", str(files)]
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        if run.demo in NUMPY_ONLY:
            result = module.main(argv)
        else:
            if comm is None:
                from mpi4py import MPI

                comm = MPI.COMM_WORLD
            takes_comm = "comm" in inspect.signature(module.main).parameters
            result = module.main(argv, comm) if takes_comm else module.main(argv)
        main_s = time.perf_counter() - t0
    ours = sorted(
        {
            f"{w.category.__name__}: {w.message}"
            for w in seen
            if w.category.__module__.startswith("subfric_dolfinx")
        }
    )
    if comm is None or comm.size == 1:
        return {"numbers": numbers(run.demo, result, files), "warnings": ours, "main_s": main_s}
    got: Any = None
    if comm.rank == 0:  # some demos give their report on rank 0 only
        try:
            got = numbers(run.demo, result, files)
        except Exception as e:  # every rank raises it, none waits in the broadcast
            got = e
    got = comm.bcast(got, root=0)
    if isinstance(got, Exception):
        raise got
    # the package shows each warning once, on rank 0 (logs.warn): the other ranks record none
    ours = comm.bcast(ours, root=0)
    return {"numbers": got, "warnings": ours, "main_s": main_s}


def child(key: str, out: Path) -> None:
    """Run one demo in this (MPI) process; rank 0 writes ``out/result.json``."""
    rec = measure(key, out / "files")
    rank = 0
    if RUNS[key].demo not in NUMPY_ONLY:
        from mpi4py import MPI

        rank = MPI.COMM_WORLD.rank
    if rank == 0:
        (out / "result.json").write_text(json.dumps(rec, indent=1, default=float))


def main() -> int:
    """Run the demos (each in its own job), collect figures and numbers."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="+", choices=sorted(RUNS), help="these runs only")
    ap.add_argument("--child", choices=sorted(RUNS), help=argparse.SUPPRESS)
    ap.add_argument("--dir", help=argparse.SUPPRESS)
    ap.add_argument(
        "--results",
        type=Path,
        default=RESULTS,
        help="the results file (another one to run several jobs at once)",
    )
    args = ap.parse_args()
    if args.child:
        child(args.child, Path(args.dir))
        return 0
    try:
        stamps.require_record_stack()
    except stamps.WrongStack as e:
        print(f"demo_results: {e}", file=sys.stderr)
        return 2
    results = args.results.resolve()
    data = json.loads(results.read_text()) if results.exists() and args.only else {"demos": {}}
    stamp = stamps.make()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for key in args.only or list(RUNS):
        run = RUNS[key]
        with tempfile.TemporaryDirectory(
            dir=ROOT / "scratch" if (ROOT / "scratch").is_dir() else None
        ) as tmp:
            cmd = [sys.executable, __file__, "--child", key, "--dir", tmp]
            if run.ranks > 1:
                cmd = ["mpirun", "-n", str(run.ranks), *cmd]
            print(f"[demo_results] {key}: {' '.join(run.command)} ...", flush=True)
            t0 = time.perf_counter()
            p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if p.returncode != 0:
                print(p.stdout[-3000:], p.stderr[-3000:])
                raise SystemExit(f"{key} failed with exit code {p.returncode}")
            measured = json.loads((Path(tmp) / "result.json").read_text())
            record = {
                "command": run.command,
                "ranks": run.ranks,
                "wall_s": wall,
                "main_s": measured["main_s"],
                "warnings": measured["warnings"],
                "numbers": measured["numbers"],
                # what the user's terminal shows (the demo's lines and the launcher's, if any)
                "output_lines": len((p.stdout + p.stderr).splitlines()),
                "stamp": stamps.make(),
            }
            data["demos"][key] = record
            print(
                f"[demo_results] {key}: {wall:.1f} s, warnings {record['warnings'] or 'none'}",
                flush=True,
            )
            if run.figures:
                dest = FIGURES / run.demo
                shutil.rmtree(dest, ignore_errors=True)
                dest.mkdir(parents=True)
                files = Path(tmp) / "files"
                for png in sorted(files.rglob("*.png")):
                    rel = png.relative_to(files)
                    shutil.copy2(png, dest / "_".join(rel.parts))
        # after each run: an interrupted run keeps what it measured
        write(data, stamp if not args.only else data.get("stamp", stamp), results)
    print(f"[demo_results] wrote {results} and {FIGURES}/", flush=True)
    return 0


def write(data: dict[str, Any], stamp: dict[str, Any], results: Path = RESULTS) -> None:
    """The results file (atomically: a temporary file renamed over it)."""
    data["stamp"] = stamp
    data["demos"] = dict(sorted(data["demos"].items()))
    tmp = results.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(results)


if __name__ == "__main__":
    sys.exit(main())
