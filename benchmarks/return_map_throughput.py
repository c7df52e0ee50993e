"""Throughput of the return maps: numpy against a C reference, the previous map, Coulomb.

Three parts (thread CPU time ``time.thread_time`` and wall time, best of ``--repeats``; the
machine is shared, so compare within one run):

1. **Throughput** at 1e4, 1e5, 1e6 interface points in 3-D contact (two tangential components),
   Sec. 7 preset. The states are realistic rather than virgin: every point first goes through a
   few random loading steps (increments of the order of the elastic range ``g(f_n) mu /
   alpha_t``, normal gaps over the working range, about 8 % opening the contact); the timed step
   is one more increment: half of the points load (along the current elastic gap, turned by up
   to 60 degrees: plastic, and since they carry a start traction every loading point takes the
   rotation of the flow direction), half unload (elastic). Rows:

   * ``numpy``: the package's map (``SubloadingLaw.return_map``, chunks of 8192 points);
   * ``C``: ``benchmarks/c_reference/return_map.c``, the same algorithm transliterated (built
     on the fly with ``gcc -O2`` and called through ctypes; the script says so when there is no
     compiler), on the SAME states and gap, the repeats alternating with numpy's; without the
     branch-and-bound scan (points needing it are counted). Agreement printed: largest
     difference of traction and tangent relative to the point's largest tangent entry, and the
     number of points whose status or iteration count differs (counts may differ by one at
     rounding-level ties of the root finder's stopping test);
   * ``previous``: the map before issue 14 (``benchmarks/old_map``: radial return, Newton in
     ``dl``, no start traction), on its own states from the same gap history;
   * ``coulomb``: penalty Coulomb on its own states.

   ``--radial`` adds the numpy/C pair on the same states without the start traction (the radial
   return with the new root finder: no split, no rotation).
2. **One call on a handful of points**: elastic, one plastic point (1-D, 2-D
   along the start traction, 2-D turn, 1-D reversal), previous and current map, and the C
   reference's per-call cost through ctypes for scale.
3. **Driver, per step** (``run_case``) on the report's paths: previous map, current map, and a
   map that returns at once (the driver's own cost).

Single core: run as ``./run exec python3 benchmarks/return_map_throughput.py`` (the runner sets
``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``). No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import driver_steps
from benchmarks.c_reference import c_map as c_ref
from benchmarks.old_map import old
from subfric_dolfinx.constitutive import CoulombLaw, InterfaceState, Status, preset

DT = 0.01  # s per step (recovery matters little within it, but is exercised)


def random_gaps(rng, n, p, steps, separated=0.08):
    """Gap histories (steps, n, 3) and the elastic range per point (mm)."""
    fn_max = 600.0
    un = rng.uniform(0.05, 1.0, n) * fn_max / p.alpha_n
    opened = rng.random(n) < separated
    un[opened] = -rng.uniform(0.0, 0.2, opened.sum()) * fn_max / p.alpha_n
    g = -np.expm1(-p.c_n * p.alpha_n * np.maximum(un, 0.0))
    scale = np.maximum(g, 1e-3) * p.mu_s / p.alpha_t
    gaps = np.empty((steps, n, 3))
    ut = np.zeros((n, 2))
    for k in range(steps):
        theta = rng.uniform(0.0, 2.0 * np.pi, n)
        size = rng.uniform(0.2, 1.5, n)[:, None] * scale[:, None]
        ut = ut + size * np.column_stack([np.cos(theta), np.sin(theta)])
        gaps[k, :, :2] = ut
        gaps[k, :, 2] = un
    return gaps, scale


def final_gap(seed, last, state, scale):
    """The timed step: half load (along the elastic gap, turned up to 60 degrees), half unload."""
    rng = np.random.default_rng(seed)
    n = last.shape[0]
    d = last[:, :2] - state["up"]
    nd = np.linalg.norm(d, axis=1)
    phi = np.where(nd > 0.0, np.arctan2(d[:, 1], d[:, 0]), rng.uniform(0, 2 * np.pi, n))
    phi = phi + rng.uniform(-np.pi / 3.0, np.pi / 3.0, n)
    load = rng.random(n) < 0.5
    size = np.where(load, rng.uniform(0.2, 1.0, n) * scale, -rng.uniform(0.1, 0.8, n) * nd)
    gap = last.copy()
    gap[:, :2] += size[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    return gap


def history(law, gaps, scale, seed):
    """The law's own states after the gap history, and the timed gap."""
    n = gaps.shape[1]
    st = law.initial_state(n, 2)
    for k in range(gaps.shape[0]):
        st = law.return_map(gaps[k], st, DT).state
    return st, final_gap(seed, gaps[-1], st, scale)


def _timed(fn):
    w0, c0 = time.perf_counter(), time.thread_time()
    res = fn()
    return res, time.perf_counter() - w0, time.thread_time() - c0


def plastic_iters(res) -> float:
    pl = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
    return float(res.iterations[pl].mean()) if pl.any() else 0.0


def numpy_vs_c(law, cmap, st, gap, repeats, radial=False):
    """The package's map and the C reference on the same states, repeats alternating."""
    n = gap.shape[0]
    f = None if radial else st["f"]
    if radial:
        st = InterfaceState({"up": st["up"], "mu": st["mu"], "r": st["r"]}, 2)
    out = st.copy() if hasattr(st, "copy") else None
    best = {"numpy": [math.inf, math.inf], "C": [math.inf, math.inf]}
    res = cres = None
    for _ in range(repeats):
        res, w, c = _timed(lambda: law.return_map(gap, st, DT, out=out))
        best["numpy"] = [min(best["numpy"][0], w), min(best["numpy"][1], c)]
        if cmap is not None:
            cres, w, c = _timed(
                lambda o=cres: cmap(law, gap, st["up"], st["mu"], st["r"], f, DT, out=o)
            )
            best["C"] = [min(best["C"][0], w), min(best["C"][1], c)]
    row = {
        "numpy": best["numpy"],
        "C": best["C"] if cmap is not None else None,
        "plastic": float(np.mean(res.status == Status.PLASTIC)),
        "iters": plastic_iters(res),
    }
    if cmap is not None:
        use = cres["status"] != c_ref.NEEDS_SCAN
        sc = np.maximum(np.abs(res.tangent).reshape(n, -1).max(axis=1), 1e-300)[use]
        d_tr = np.abs(res.traction - cres["traction"]).max(axis=1)[use] / sc
        d_tan = np.abs(res.tangent - cres["tangent"]).reshape(n, -1).max(axis=1)[use] / sc
        row["agree"] = (float(d_tr.max(initial=0.0)), float(d_tan.max(initial=0.0)))
        row["differ"] = (
            int(np.sum(res.status[use] != cres["status"][use])),
            int(np.sum(res.iterations[use] != cres["iterations"][use])),
        )
        row["n_scan"] = int(cres["n_scan"])
    return row


def own_states(law, gaps, scale, seed, repeats):
    """Best wall and CPU time of ``law`` on its own states."""
    st, gap = history(law, gaps, scale, seed)
    best = [math.inf, math.inf]
    res = None
    for _ in range(repeats):
        res, w, c = _timed(lambda: law.return_map(gap, st, DT))
        best = [min(best[0], w), min(best[1], c)]
    return best, res


def throughput(args, sub, cmap) -> None:
    coul = CoulombLaw(alpha_t=sub.alpha_t, alpha_n=sub.alpha_n, mu_c=args.mu_c)
    prev = old(sub)
    print(
        f"1. throughput, 3-D contact (nt = 2), preset {args.preset}, best of {args.repeats} "
        "(wall / thread CPU, s)"
    )
    if cmap is None:
        print(f"   C reference: {c_ref.reason()}")
    else:
        print(f"   C reference built with: {cmap.command}")
    head = (
        f"   {'points':>8s} {'numpy':>15s} {'C':>15s} {'ratio':>11s} {'previous':>15s} "
        f"{'coulomb':>15s}  {'plastic':>7s} {'it/pl':>5s} {'it/pl prev':>10s} "
        f"{'scan':>4s} {'agree tr/D':>15s} {'st !=':>5s} {'it !=':>5s}"
    )
    print(head)
    radial_rows = []
    for n in args.sizes:
        rng = np.random.default_rng(args.seed)
        gaps, scale = random_gaps(rng, n, sub, args.history)
        st, gap = history(sub, gaps, scale, args.seed + 1)
        r = numpy_vs_c(sub, cmap, st, gap, args.repeats)
        (pw, pc), pres = own_states(prev, gaps, scale, args.seed + 1, args.repeats)
        (cw, cc), _ = own_states(coul, gaps, scale, args.seed + 1, args.repeats)
        nw, nc = r["numpy"]
        if r["C"] is not None:
            xw, xc = r["C"]
            c_cells = f"{xw:7.4f}/{xc:7.4f} {nw / xw:5.2f}/{nc / xc:5.2f}"
            tail = (
                f"{r['n_scan']:4d} {r['agree'][0]:7.1e}/{r['agree'][1]:7.1e} "
                f"{r['differ'][0]:5d} {r['differ'][1]:5d}"
            )
        else:
            c_cells, tail = f"{'-':>15s} {'-':>11s}", ""
        print(
            f"   {n:8d} {nw:7.4f}/{nc:7.4f} {c_cells} {pw:7.4f}/{pc:7.4f} "
            f"{cw:7.4f}/{cc:7.4f}  {r['plastic']:7.1%} {r['iters']:5.2f} "
            f"{plastic_iters(pres):10.2f} {tail}"
        )
        if args.radial:
            radial_rows.append((n, numpy_vs_c(sub, cmap, st, gap, args.repeats, radial=True)))
    if radial_rows:
        print("   the same states without the start traction (radial return, new root finder):")
        for n, r in radial_rows:
            nw, nc = r["numpy"]
            cells = (
                ""
                if r["C"] is None
                else (
                    f" C {r['C'][0]:7.4f}/{r['C'][1]:7.4f}, ratio {nw / r['C'][0]:.2f}/"
                    f"{nc / r['C'][1]:.2f}, agree {r['agree'][0]:.1e}/{r['agree'][1]:.1e}"
                )
            )
            print(f"   {n:8d} numpy {nw:7.4f}/{nc:7.4f}{cells}, it/pl {r['iters']:.2f}")


def per_call(cmap) -> None:
    print("\n2. one call, one point (us, thread CPU time, best of 5):")
    print(
        f"   {'case':20s} {'previous':>9s} {'current':>8s} {'C (ctypes)':>10s}  "
        "current status/evaluations"
    )
    P = driver_steps.P
    prev = driver_steps.OLD
    for name, gap, radial, full, dt in driver_steps.call_cases():
        a = driver_steps.best_call(lambda g=gap, s=radial, d=dt: prev.return_map(g, s, d))
        b = driver_steps.best_call(lambda g=gap, s=full, d=dt: P.return_map(g, s, d))
        c = math.nan
        if cmap is not None:
            args = (P, gap, full["up"], full["mu"], full["r"], full["f"], dt)
            c = driver_steps.best_call(lambda a=args: cmap(*a))
        r = P.return_map(gap, full, dt)
        print(
            f"   {name:20s} {1e6 * a:9.1f} {1e6 * b:8.1f} {1e6 * c:10.1f}  "
            f"{int(r.status[0])}/{int(r.iterations[0])}"
        )


def driver(repeats: int) -> None:
    print(f"\n3. driver, us per step (thread CPU time, best of {repeats}):")
    for key, (rows, nt, spm) in driver_steps.PATHS.items():
        path = np.array(rows, dtype=float)
        ts = np.union1d(np.linspace(path[0, 0], path[-1, 0], 41), path[:, 0])
        cells = []
        for name, law in (
            ("previous map", driver_steps.OLD),
            ("current map", driver_steps.P),
            ("null map", driver_steps.null_law(nt)),
        ):
            c, n = driver_steps.per_step(law, path, ts, nt, spm, repeats)
            cells.append(f"{name} {1e6 * c:.1f}")
        print(f"   {key} at {spm:g} steps/mm ({n} steps): " + ", ".join(cells))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="comma-separated point counts")
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats (best is kept)")
    ap.add_argument("--preset", default="sec7", help="subloading preset (default sec7)")
    ap.add_argument("--mu-c", type=float, default=0.1, help="Coulomb friction coefficient")
    ap.add_argument("--history", type=int, default=4, help="random loading steps before timing")
    ap.add_argument("--seed", type=int, default=2022)
    ap.add_argument("--no-c", action="store_true", help="skip the C reference")
    ap.add_argument("--radial", action="store_true", help="also states without start traction")
    ap.add_argument("--only", default="1,2,3", help="parts to run (comma-separated of 1,2,3)")
    args = ap.parse_args(argv)
    args.sizes = [int(float(s)) for s in args.sizes.split(",")]
    parts = set(args.only.split(","))
    sub = preset(args.preset)
    print(f"numpy {np.__version__}, Python {platform.python_version()}, {platform.machine()}")
    cmap = None if args.no_c else c_ref.load()
    if "1" in parts:
        throughput(args, sub, cmap)
    if "2" in parts:
        per_call(cmap)
    if "3" in parts:
        driver(args.repeats)


if __name__ == "__main__":
    main()
