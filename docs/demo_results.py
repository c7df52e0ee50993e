"""Run every demo as the README's table says and keep what the README and the docs quote.

    ./run exec python3 docs/demo_results.py            # all (about 15 minutes on 2 cores)
    ./run exec python3 docs/demo_results.py --only lap_joint punch

Each run is ``mpirun -n 2 python3 docs/demo_results.py --child KEY`` (the numpy-only demos: one
process), which calls the demo's ``main`` with its default options (or those of :data:`RUNS`),
times it, and writes on rank 0 what the demo measured (:func:`numbers`), the warnings it issued
and its wall time. This script then copies the figures of the default runs into
``docs/figures/<demo>/`` (the demo pages show them) and writes ``docs/demo_results.json``,
stamped with the code it measured (``report/stamp.py``: ``constitutive/``, ``fem/``, ``demos/``).
``tests/demos/test_readme.py`` checks every number the README quotes from it, and that the stamp
still describes the code.
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

# key -> (demo, options, MPI ranks, figures of this run go to the docs)
RUNS: dict[str, tuple[str, list[str], int, bool]] = {
    "block_on_base": ("block_on_base", [], 2, True),
    "pad_on_plate": ("pad_on_plate", [], 2, True),
    "punch": ("punch", [], 2, True),
    "lap_joint": ("lap_joint", [], 2, True),
    "bolted_joint": ("bolted_joint", [], 2, True),
    "paper_figures": ("paper_figures", [], 1, True),
    "calibration": ("calibration", [], 1, True),
    "two_bodies_api": ("two_bodies_api", [], 2, True),
    "hertz": ("hertz", [], 2, True),
    "hertz_n4": ("hertz", ["--n", "4"], 2, False),
    "hertz_n8": ("hertz", ["--n", "8"], 2, False),
    "cattaneo_mindlin": ("cattaneo_mindlin", [], 2, True),
    "cattaneo_mindlin_n4": ("cattaneo_mindlin", ["--n", "4", "--no-subloading"], 2, False),
    "cattaneo_mindlin_n16": ("cattaneo_mindlin", ["--n", "16", "--no-subloading"], 2, False),
    "elastic_smoke": ("elastic_smoke", [], 2, False),
}
for _demo in sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__"):
    RUNS.setdefault(_demo, (_demo, [], 2, True))  # a demo added later: its default run, 2 ranks


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


def numbers(demo: str, result: Any) -> dict[str, Any]:
    """What the demo measured, from the object its ``main`` returned."""
    if demo == "block_on_base":
        h = result.history
        t = np.array([r["t"] for r in h])
        ft = np.array([r["F_t1"] / r["area"] for r in h])
        return {
            "peak_forward": ft[(t > 1) & (t <= 2)].max(),
            "peak_reverse": -ft[(t > 2) & (t <= 4)].min(),
            "peak_reload": ft[t > 24].max(),
            "info": plain(result.info),
        }
    if demo == "lap_joint":
        from demos import lap_joint

        out = {}
        cycles = lap_joint.parser().get_default("cycles")
        for name, res in result.items():
            s = lap_joint.slip_per_cycle(res.history, cycles)
            out[name] = {
                "slip_per_cycle_um": (1e3 * np.diff(s)).tolist(),
                "total_um": 1e3 * float(s[-1] - s[0]),
            }
        return out
    if demo == "punch":
        return plain(result[0].info["punch"])
    if demo == "cattaneo_mindlin":
        cres, sres = result
        out = {"coulomb": plain(cres.info["cattaneo_mindlin"])}
        if sres is not None:
            out["subloading"] = plain(sres.info["slips"])
        return out
    if demo == "block_sliding_far":
        return plain(result["report"])
    if demo == "two_bodies_api":
        return {"steps": len(result["history"])}
    if isinstance(result, dict):
        return plain(result)
    info = getattr(result, "info", None)
    return plain(info) if info is not None else {}


def child(key: str, out: Path) -> None:
    """Run one demo in this (MPI) process; rank 0 writes ``out/result.json``."""
    import importlib
    import inspect

    demo, options, ranks, _ = RUNS[key]
    module = importlib.import_module(f"demos.{demo}")
    argv = [*options, "--out", str(out / "files")]
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        if ranks > 1:
            from mpi4py import MPI

            comm = MPI.COMM_WORLD
            takes_comm = "comm" in inspect.signature(module.main).parameters
            result = module.main(argv, comm) if takes_comm else module.main(argv)
            wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
            rank = comm.rank
        else:
            result = module.main(argv)
            wall = time.perf_counter() - t0
            rank = 0
    if rank == 0:
        ours = sorted(
            {
                f"{w.category.__name__}: {w.message}"
                for w in seen
                if w.category.__module__.startswith("subfric_dolfinx")
            }
        )
        record = {
            "command": ["mpirun", "-n", str(ranks), "python3", f"demos/{demo}.py", *options]
            if ranks > 1
            else ["python3", f"demos/{demo}.py", *options],
            "ranks": ranks,
            "wall_s": wall,
            "load": os.getloadavg()[0],
            "warnings": ours,
            "numbers": numbers(demo, result),
        }
        (out / "result.json").write_text(json.dumps(record, indent=1, default=float))


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
    ap.add_argument(
        "--merge",
        type=Path,
        nargs="+",
        help="merge these results files (of the same code) into --results, run none",
    )
    args = ap.parse_args()
    if args.child:
        child(args.child, Path(args.dir))
        return 0
    results = args.results.resolve()
    data = json.loads(results.read_text()) if results.exists() else {"demos": {}}
    stamp = stamps.make(stamps.DEMOS_MEASURE)
    if data.get("stamp", {}).get("trees") != stamp["trees"] or stamp["dirty"]:
        data["demos"] = {}  # results of other code: not mixed with these
    if args.merge:
        for other in args.merge:
            more = json.loads(other.read_text())
            if more["stamp"]["trees"] != stamp["trees"] or more["stamp"]["dirty"]:
                raise SystemExit(f"{other} measured other code: not merged")
            data["demos"].update(more["demos"])
        write(data, stamp, results)
        return 0
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for key in args.only or list(RUNS):
        demo, _, ranks, keep_figures = RUNS[key]
        with tempfile.TemporaryDirectory(
            dir=ROOT / "scratch" if (ROOT / "scratch").is_dir() else None
        ) as tmp:
            cmd = [sys.executable, __file__, "--child", key, "--dir", tmp]
            if ranks > 1:
                cmd = ["mpirun", "-n", str(ranks), *cmd]
            print(f"[demo_results] {key}: {' '.join(cmd[:4])} ...", flush=True)
            p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
            if p.returncode != 0:
                print(p.stdout[-3000:], p.stderr[-3000:])
                raise SystemExit(f"{key} failed with exit code {p.returncode}")
            record = json.loads((Path(tmp) / "result.json").read_text())
            data["demos"][key] = record
            print(
                f"[demo_results] {key}: {record['wall_s']:.1f} s, warnings "
                f"{record['warnings'] or 'none'}",
                flush=True,
            )
            if keep_figures:
                dest = FIGURES / demo
                shutil.rmtree(dest, ignore_errors=True)
                dest.mkdir(parents=True)
                files = Path(tmp) / "files"
                for png in sorted(files.rglob("*.png")):
                    rel = png.relative_to(files)
                    shutil.copy2(png, dest / "_".join(rel.parts))
        write(data, stamp, results)  # after each run: an interrupted run keeps what it measured
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
