"""Material point: cost of one call of the return map, of one driver step, and of batches.

Prints (thread CPU time, ``time.thread_time``, best of 5: the machine is shared):

1. one call of ``return_map`` for one point (Sec. 7 preset, f_n = 300 MPa),
   the previous map (``benchmarks/old_map``) beside the current one: elastic, plastic 1-D,
   plastic 2-D along the start traction, 2-D at 90 degrees to it, a 1-D reversal;
2. the driver's cost per step (``run_case``) on the report's paths (``report/mp_study.py``: 41
   samples plus the breakpoints): the previous map, the current one, and a map that returns at
   once (the driver's own cost);
3. the cost per step against the number of path rows (a straight slide cut into 10 .. 10^6
   rows, one step per row interval): constant, where the previous driver interpolated over the
   whole path at every step (27 ms per step at 10^6 rows);
4. the batch driver (``run_cases``): the six curves of Fig. 10 (20 mm at 100..600 MPa) one by
   one and together, and N = 30, 100, 1000 cases;
5. one call of the map (one numpy implementation for any number of points) on N points, from
   1 to 10^5 (elastic, 1-D plastic, 2-D plastic with a turn): its fixed cost per call and its
   cost per point.

Usage: ``./run exec python3 benchmarks/driver_steps.py [--quick]`` (``--quick``: no 10^6 rows,
no 1000 cases). No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.old_map import old
from subfric_dolfinx.constitutive import InterfaceState, SubloadingLaw, preset
from subfric_dolfinx.driver import Case, run_case, run_cases

P = preset("sec7")
OLD = old(P)
FN = 300.0
UN = FN / P.alpha_n
G = -math.expm1(-P.c_n * FN)


def best_call(fn, repeats: int = 5) -> float:
    t = timeit.Timer(fn, timer=time.thread_time)
    best = math.inf
    for _ in range(repeats):
        n, s = t.autorange()
        best = min(best, s / n)
    return best


def call_cases():
    """(name, gap, state without f, state with f, dt) of the one-point calls."""
    mu, r = 70.0, 0.95
    f0 = G * r * mu  # on the loading surface
    e = f0 / P.alpha_t  # the elastic gap
    out = []
    for name, nt, gap_t in [
        ("elastic", 1, [0.05 + 0.5 * e]),
        ("plastic 1-D", 1, [0.05 + e + 0.002]),
        ("plastic 2-D along", 2, [0.05 + e + 0.002, 0.0]),
        ("plastic 2-D turn", 2, [0.05 + e, 0.002]),
        ("reversal 1-D", 1, [0.05 - e - 0.002]),
    ]:
        up = np.zeros((1, nt))
        up[0, 0] = 0.05
        f = np.zeros((1, nt + 1))
        f[0, 0], f[0, nt] = f0, FN
        gap = np.array([[*gap_t, UN]])
        radial = InterfaceState({"up": up, "mu": [mu], "r": [r]}, nt)
        full = InterfaceState({"up": up, "mu": [mu], "r": [r], "f": f}, nt)
        out.append((name, gap, radial, full, 0.0025))
    return out


class _Null(SubloadingLaw):
    """A law whose map returns a precomputed result at once (the driver's own cost)."""

    def return_map(self, gap, state, dt, **kw):
        return object.__getattribute__(self, "_res")


def null_law(nt: int) -> _Null:
    law = _Null(**P.parameters())
    res = P.return_map(np.array([[0.0] * nt + [UN]]), P.initial_state(1, nt), 0.0)
    object.__setattr__(law, "_res", res)
    return law


PATHS = {
    "reversal": (
        [[0, 0, 0, UN], [1, 1, 0, UN], [3, -1, 0, UN], [23, -1, 0, UN], [25, 1, 0, UN]],
        1,
        100.0,
    ),
    "turn": ([[0, 0, 0, UN], [0.3, 0.3, 0, UN], [0.45, 0.3, 0.15, UN]], 2, 400.0),
}


def per_step(law, path, ts, nt, spm, repeats=5) -> tuple[float, int]:
    case = Case(law, "disp", path, ts, nt, spm)
    best = math.inf
    for _ in range(repeats):
        t0 = time.thread_time()
        res = run_case(case)
        best = min(best, (time.thread_time() - t0) / res.n_steps)
    return best, res.n_steps


def fig10(fn: float, spm: float = 50.0) -> Case:
    un = fn / P.alpha_n
    path = np.array([[0.0, 0.0, 0.0, un], [20.0, 20.0, 0.0, un]])
    return Case(P, "disp", path, np.linspace(0.0, 20.0, 81), 1, spm)


def timed(fn) -> float:
    t0 = time.thread_time()
    fn()
    return time.thread_time() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the largest sizes")
    args = ap.parse_args()

    print("1. one call, one point (us, thread CPU time, best of 5):")
    print(f"   {'case':20s} {'previous':>9s} {'current':>8s}  current status/evaluations")
    for name, gap, radial, full, dt in call_cases():
        a = best_call(lambda g=gap, s=radial, d=dt: OLD.return_map(g, s, d))
        b = best_call(lambda g=gap, s=full, d=dt: P.return_map(g, s, d))
        r = P.return_map(gap, full, dt)
        print(
            f"   {name:20s} {1e6 * a:9.1f} {1e6 * b:8.1f}  "
            f"{int(r.status[0])}/{int(r.iterations[0])}"
        )

    print("\n2. driver, us per step (thread CPU time, best of 5):")
    for key, (rows, nt, spm) in PATHS.items():
        path = np.array(rows, dtype=float)
        ts = np.union1d(np.linspace(path[0, 0], path[-1, 0], 41), path[:, 0])
        cells = []
        for name, law in (("previous map", OLD), ("current map", P), ("null map", null_law(nt))):
            c, n = per_step(law, path, ts, nt, spm)
            cells.append(f"{name} {1e6 * c:.1f}")
        print(f"   {key} at {spm:g} steps/mm ({n} steps): " + ", ".join(cells))

    print("\n3. us per step against the number of path rows (a 1-mm slide, one step per row):")
    for rows in (10, 1000, 100_000) + (() if args.quick else (1_000_000,)):
        t = np.linspace(0.0, 1.0, rows)
        path = np.column_stack([t, t, np.zeros(rows), np.full(rows, UN)])
        c, n = per_step(P, path, np.array([0.0, 1.0]), 1, 1e-6, repeats=1 if rows > 1e5 else 3)
        print(f"   {rows:8d} rows ({n} steps): {1e6 * c:.1f} us per step")

    print("\n4. batch driver (thread CPU time, one run each):")
    cases = [fig10(fn) for fn in (100, 200, 300, 400, 500, 600)]
    one = timed(lambda: run_case(cases[0]))
    seq = timed(lambda: [run_case(c) for c in cases])
    bat = timed(lambda: run_cases(cases))
    print(
        f"   Fig. 10, six curves of {run_case(cases[0]).n_steps} steps: one curve {one:.3f} s, "
        f"six one by one {seq:.3f} s, six together {bat:.3f} s "
        f"(speed-up {seq / bat:.2f}; {bat / one:.2f} times one curve)"
    )
    for n in (30, 100) + (() if args.quick else (1000,)):
        cs = [fig10(fn, 10.0) for fn in np.linspace(50.0, 700.0, n)]
        k = min(n, 30)
        per = timed(lambda cs=cs, k=k: [run_case(c) for c in cs[:k]]) / k
        bat = timed(lambda cs=cs: run_cases(cs))
        print(
            f"   {n:5d} cases of {run_case(cs[0]).n_steps} steps: one by one {per * n:.2f} s "
            f"(from {k}), together {bat:.2f} s, speed-up {per * n / bat:.1f}"
        )
    per_point()


def path_costs(n: int, nt: int, delta: float) -> float:
    """Seconds per call of the map on ``n`` points (start tractions given)."""
    rng = np.random.default_rng(0)
    fn = rng.uniform(100.0, 600.0, n)
    g = -np.expm1(-P.c_n * fn)
    mu, r = np.full(n, 70.0), np.full(n, 0.95)
    f = np.zeros((n, nt + 1))
    f[:, 0], f[:, nt] = g * r * mu, fn
    up = np.zeros((n, nt))
    up[:, 0] = 0.05
    gap = np.zeros((n, nt + 1))
    gap[:, 0] = 0.05 + f[:, 0] / P.alpha_t + delta
    gap[:, nt] = fn / P.alpha_n
    if nt == 2:
        gap[:, 1] = 0.0005
    st = InterfaceState({"up": up, "mu": mu, "r": r, "f": f}, nt)
    return best_call(lambda: P.return_map(gap, st, 0.0025), repeats=3 if n > 10**4 else 5)


def per_point() -> None:
    sizes = (1, 8, 64, 512, 4096, 100_000)
    print("\n5. one call on N points (us per call / us per point, thread CPU time):")
    print("   " + f"{'':22s}" + "".join(f"{n:>17d}" for n in sizes))
    for name, nt, delta in (
        ("elastic", 1, -0.0005),
        ("plastic 1-D", 1, 0.002),
        ("plastic 2-D turn", 2, 0.002),
    ):
        cells = []
        for n in sizes:
            a = path_costs(n, nt, delta)
            cells.append(f"{1e6 * a:9.0f}/{1e6 * a / n:<7.2f}")
        print(f"   {name:22s}" + "".join(cells))


if __name__ == "__main__":
    main()
