"""Throughput of the batched return maps: subloading friction vs penalty Coulomb.

Prints points per second for 1e4, 1e5 and 1e6 interface points in 3-D contact (two tangential
components), best of a few repeats, with the fraction of points per status and the mean number of
root-finder iterations, and the cost ratio subloading / Coulomb.

The states are realistic rather than virgin: every point first goes through a few random loading
steps (random tangential increments of the order of the elastic range ``g(f_n) mu / alpha_t``,
normal gaps spread over the preset's working range, about 8 % of them opening the contact), and
the timed step is one more increment: for half of the points it loads (along the current elastic
gap, turned by up to 60 degrees: plastic), for the other half it unloads (elastic) -- the mix an
implicit step sees. Each law builds its own states from the same gap history and random numbers.

Single core: the script sets nothing, so run it as::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python3 benchmarks/return_map_throughput.py

(``./run exec`` sets both). numpy's element-wise kernels are single-threaded anyway; the variables
keep a threaded BLAS out of the picture. No timing is asserted.
"""

from __future__ import annotations

import argparse
import math
import platform
import time

import numpy as np

from subfric_dolfinx.constitutive import CoulombLaw, Status, preset

DT = 0.01  # s per step (recovery matters little within it, but is exercised)


def random_gaps(rng, n, p, steps, separated=0.08):
    """Gap histories (steps, n, 3) and the elastic range per point.

    Each point gets a normal gap and a random tangential walk; the elastic range
    ``g(f_n) mu_s / alpha_t`` (mm) scales the increments.
    """
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
    """The gap of the timed step.

    From the current elastic gap ``d = ubar_t - up``, half of the points load (an increment along
    +d, turned by up to 60 degrees), half unload (along -d, shorter than |d|).
    """
    rng = np.random.default_rng(seed)
    n = last.shape[0]
    d = last[:, :2] - state.up
    nd = np.linalg.norm(d, axis=1)
    phi = np.where(nd > 0.0, np.arctan2(d[:, 1], d[:, 0]), rng.uniform(0, 2 * np.pi, n))
    phi = phi + rng.uniform(-np.pi / 3.0, np.pi / 3.0, n)
    load = rng.random(n) < 0.5
    size = np.where(load, rng.uniform(0.2, 1.0, n) * scale, -rng.uniform(0.1, 0.8, n) * nd)
    gap = last.copy()
    gap[:, :2] += size[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])
    return gap


def bench(law, gaps, scale, repeats, seed):
    n = gaps.shape[1]
    st = law.initial_state(n, 2)
    for k in range(gaps.shape[0]):  # the history: realistic states
        st = law.return_map(gaps[k], st, DT).state
    gap = final_gap(seed, gaps[-1], st, scale)
    out = law.initial_state(n, 2)
    best = math.inf
    res = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = law.return_map(gap, st, DT, out=out)
        best = min(best, time.perf_counter() - t0)
    counts = res.counts()
    plastic = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
    return {
        "time": best,
        "rate": n / best,
        "counts": {k: v / n for k, v in counts.items()},
        "iters_plastic": float(res.iterations[plastic].mean()) if plastic.any() else 0.0,
        "iters_max": int(res.iterations.max()),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="comma-separated point counts")
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats (best is kept)")
    ap.add_argument("--preset", default="sec7", help="subloading preset (default sec7)")
    ap.add_argument("--mu-c", type=float, default=0.1, help="Coulomb friction coefficient")
    ap.add_argument("--history", type=int, default=4, help="random loading steps before timing")
    ap.add_argument("--seed", type=int, default=2022)
    args = ap.parse_args(argv)
    sizes = [int(float(s)) for s in args.sizes.split(",")]

    sub = preset(args.preset)
    coul = CoulombLaw(alpha_t=sub.alpha_t, alpha_n=sub.alpha_n, mu_c=args.mu_c)
    print(
        f"numpy {np.__version__}, Python {platform.python_version()}, {platform.machine()}; "
        f"preset {args.preset}, Coulomb mu_c = {args.mu_c}; 3-D (nt = 2); best of {args.repeats}"
    )
    head = (
        f"{'law':10s} {'points':>9s} {'best (s)':>9s} {'points/s':>10s}  "
        f"{'elastic':>7s} {'plastic':>7s} {'separ.':>7s} {'jump':>5s} {'failed':>6s} "
        f"{'iter/plastic':>12s} {'max':>4s}"
    )
    print(head)
    print("-" * len(head))
    ratios = []
    for n in sizes:
        rng = np.random.default_rng(args.seed)
        gaps, scale = random_gaps(rng, n, sub, args.history)
        rows = {}
        for name, law in (("subloading", sub), ("coulomb", coul)):
            r = bench(law, gaps, scale, args.repeats, args.seed + 1)
            rows[name] = r
            c = r["counts"]
            print(
                f"{name:10s} {n:9d} {r['time']:9.4f} {r['rate']:10.3g}  "
                f"{c['ELASTIC']:7.1%} {c['PLASTIC']:7.1%} {c['SEPARATED']:7.1%} "
                f"{c['JUMP']:5.1%} {c['FAILED']:6.1%} {r['iters_plastic']:12.2f} "
                f"{r['iters_max']:4d}"
            )
        ratios.append((n, rows["subloading"]["time"] / rows["coulomb"]["time"]))
    print()
    print(
        "cost ratio subloading / Coulomb (time per point): "
        + ", ".join(f"{n:g} points: {q:.1f}x" for n, q in ratios)
    )


if __name__ == "__main__":
    main()
