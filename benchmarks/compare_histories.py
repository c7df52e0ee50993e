"""Histories of the demos from two source trees, compared column by column (issue 21 item 6).

A change of the finite-element layer that is meant to keep every existing result (a refactoring,
a new feature beside the old ones) is checked by running the demos at a small size from the old
tree and from the new one and comparing every CSV they write: for each numeric column, the
largest difference relative to the column's peak ``max |a - b| / max |a|``. Columns of timings
(``wall``, ``elapsed``, ``seconds``) are left out; a column or a row that is in one file only is
reported as a difference. A column of an older tree named by a built-in mesh's older group
name (``R_master_xmin_x``, ``S_slave_left_x``) is read under today's (``R_primary_xmin_x``):
the groups were renamed, the numbers are compared.

    # run the demos of a tree (each one its own process; PYTHONPATH = the tree)
    python3 benchmarks/compare_histories.py run --tree /path/to/old --out scratch/old [--ranks 2]
    python3 benchmarks/compare_histories.py run --tree . --out scratch/new
    # compare (exit code 1 if a column differs by more than --tol of its peak)
    python3 benchmarks/compare_histories.py compare scratch/old scratch/new [--tol 1e-10]

Under ``./run exec`` only the worktree is mounted: put the old tree inside it (e.g. ``git worktree
add --detach scratch/main main``). Nothing here is timed.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import re
import subprocess
import sys
from pathlib import Path

# run -> the demo and its small command line (the suite's sizes, tests/demos/test_demos_run.py):
# every demo of the finite-element layer that writes a history
DEMOS: dict[str, tuple[str, list[str]]] = {
    "block_on_base": ("block_on_base", ["--n", "4", "--hold", "1", "--dt", "0.1"]),
    "pad_on_plate": ("pad_on_plate", ["--n", "2", "--holds", "0", "5", "--dt", "0.1"]),
    "punch": ("punch", ["--n", "4", "--dt", "0.1"]),
    "lap_joint": ("lap_joint", ["--n", "4", "--cycles", "2", "--dt", "0.2"]),
    "hertz": ("hertz", ["--n", "4"]),
    "hertz_apart": ("hertz", ["--n", "4", "--meshed-apart", "--no-figures"]),
    "cattaneo_mindlin": ("cattaneo_mindlin", ["--n", "4"]),
    "bolted_joint": ("bolted_joint", ["--n", "2", "--cycles", "1"]),
    "two_bodies_api": ("two_bodies_api", ["--n", "4", "--dt", "0.1"]),
    "block_sliding_far": ("block_sliding_far", ["--n", "4", "--slide", "20", "--no-figures"]),
    "user_loop": ("user_loop", ["--n", "4", "--dt", "0.25"]),
    "shrink_fit": ("shrink_fit", ["--h", "5", "--steps", "4"]),
    "bolt_clamped_joint": ("bolt_clamped_joint", ["--h", "5", "--cycles", "1", "--dt", "1"]),
    "fretting": ("fretting", ["--n", "4", "--cycles", "1", "--steps", "4", "--no-figures"]),
    "stick_slip": ("stick_slip", ["--steps", "100", "--no-figures"]),
}
SKIP = ("wall", "elapsed", "seconds")
OLDER_NAMES = re.compile(r"^([RS])_(master|slave)(?=_)")
"""A reaction's or spring's column under a built-in mesh group's older name."""


def today(column: str) -> str:
    """A column's name today (``R_master_xmin_x`` -> ``R_primary_xmin_x``)."""
    new = {"master": "primary", "slave": "secondary"}
    return OLDER_NAMES.sub(lambda m: f"{m.group(1)}_{new[m.group(2)]}", column)


def run(tree: Path, out: Path, ranks: int, names: list[str]) -> int:
    """Run the demos of ``tree`` into ``out/<run>``; the number of runs that failed."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX"))}
    env["PYTHONPATH"] = str(tree)
    failed = 0
    for name in names:
        dest = out / name
        dest.mkdir(parents=True, exist_ok=True)
        demo, args = DEMOS[name]
        cmd = [sys.executable, str(tree / "demos" / f"{demo}.py"), *args, "--out", str(dest)]
        if ranks > 1:
            cmd = ["mpirun", "-n", str(ranks), sys.executable, "-m", "mpi4py", *cmd[1:]]
        with open(dest / "stdout.txt", "w") as log:
            proc = subprocess.run(cmd, cwd=tree, env=env, stdout=log, stderr=subprocess.STDOUT)
        rc = proc.returncode
        print(f"{name}: exit code {rc}", flush=True)
        failed += rc != 0
    return failed


def _read(path: Path) -> dict[str, list[str]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(row for row in f if not row.startswith("#")))
    if not rows:
        return {}
    head, body = [today(h) for h in rows[0]], rows[1:]
    return {h: [r[i] if i < len(r) else "" for r in body] for i, h in enumerate(head)}


def _number(s: str) -> float | None:
    try:
        return float(s)
    except ValueError:
        return None


def kind(column: str) -> str:
    """The quantity of a column: its prefix before ``_``; forces (``F_``, ``R_``, ``S_``) one."""
    head = column.split("_")[0] if "_" in column else column
    return "force" if head in ("F", "R", "S") else head


def compare_file(a: Path, b: Path) -> list[tuple[str, float, float]]:
    """Differences of every numeric column of ``a`` to ``b``.

    Returns:
        (column, difference / its kind's peak, difference / its own peak); ``inf`` where the
        column is missing in ``b`` or of another length.
    """
    ca, cb = _read(a), _read(b)
    peaks: dict[str, float] = {}
    for col, va in ca.items():
        xa = [_number(s) for s in va]
        if xa and all(x is not None for x in xa):
            k = kind(col)
            peaks[k] = max(peaks.get(k, 0.0), max(abs(x) for x in xa))
    out = []
    for col, va in ca.items():
        if any(s in col.lower() for s in SKIP):
            continue
        xa = [_number(s) for s in va]
        if any(x is None for x in xa):
            continue  # a text column
        vb = cb.get(col)
        xb = [_number(s) for s in vb] if vb is not None and len(vb) == len(va) else [None]
        if any(x is None for x in xb):
            out.append((col, math.inf, math.inf))
            continue
        own = max((abs(x) for x in xa), default=0.0)
        diff = max((abs(x - y) for x, y in zip(xa, xb, strict=True)), default=0.0)
        scale = peaks[kind(col)]
        out.append((col, diff / scale if scale > 0 else diff, diff / own if own > 0 else diff))
    return out


def compare(old: Path, new: Path, tol: float) -> int:
    """Print the largest relative difference per file (and the columns above ``tol``)."""
    bad = 0
    files = sorted(p.relative_to(old) for p in old.rglob("*.csv"))
    if not files:
        print(f"no CSV file under {old}")
        return 1
    for rel in files:
        if not (new / rel).exists():
            print(f"{rel}: missing in {new}")
            bad += 1
            continue
        cols = compare_file(old / rel, new / rel)
        worst = max(cols, key=lambda c: c[1], default=("-", 0.0, 0.0))
        own = max(cols, key=lambda c: c[2], default=("-", 0.0, 0.0))
        over = [f"{c} {d:.1e}" for c, d, _ in cols if d > tol]
        print(
            f"{rel}: {len(cols)} columns; largest difference {worst[1]:.1e} of its quantity's "
            f"peak ({worst[0]}), {own[2]:.1e} of its own ({own[0]})"
            + (f"; above {tol:g}: {', '.join(over)}" if over else "")
        )
        bad += bool(over)
    return int(bad > 0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the demos of a tree")
    r.add_argument("--tree", type=Path, default=Path(__file__).resolve().parents[1])
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--ranks", type=int, default=1)
    r.add_argument("--only", nargs="+", choices=sorted(DEMOS), default=sorted(DEMOS))
    c = sub.add_parser("compare", help="compare the CSV files of two runs")
    c.add_argument("old", type=Path)
    c.add_argument("new", type=Path)
    c.add_argument("--tol", type=float, default=1e-10)
    args = ap.parse_args(argv)
    if args.cmd == "run":
        return int(run(args.tree.resolve(), args.out.resolve(), args.ranks, args.only) > 0)
    return compare(args.old, args.new, args.tol)


if __name__ == "__main__":
    sys.exit(main())
