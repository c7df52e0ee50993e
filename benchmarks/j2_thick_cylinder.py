"""The J2 bulk law on Hill's thick cylinder, finer than the test, and the return map's speed.

1. **Hill's tube** (``tests/fem/test_j2_fe.py``'s set-up: a = 1, b = 2, plane strain ``u_z = 0`` in
   axisymmetric mode, P2 triangles, perfectly plastic, the inner radius displaced): for
   ``nu`` in 0.49, 0.499, 0.4999 and 20 to 160 elements through the wall, the pressure against
   Hill's closed form (for ``nu = 1/2``) at u_a = 1.5, 2, 3 u_y (partly plastic) and 6 u_y (the
   limit pressure), relative to the limit pressure ``p_L = 2 k ln(b/a)``, and Newton's
   iterations (full Newton, LU; a step whose Newton fails is halved, the state reverted). The
   difference to Hill scales with ``1 - 2 nu`` (the closed form's incompressibility), not with
   the mesh. Measured: -2.8e-3, -2.8e-4, -2.8e-5 p_L for the three nu from 40 elements on;
   the limit pressure within 1e-7 at 160 elements; at 20 elements and nu = 0.4999 the
   displacement formulation stiffens (+1.3e-4, +3.1e-4 at the limit).
2. **Throughput** of ``j2_return_map`` at 1e4, 1e5, 1e6 points (from a hardened state, 83 %
   loading plastically), thread CPU time, best of 3: about 2 million points a second.

Run: ``./run exec python3 benchmarks/j2_thick_cylinder.py`` (one rank; no timing is asserted
anywhere).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from subfric_dolfinx.constitutive import J2Material, J2State
from tests.fem.test_j2_fe import (
    P_LIMIT,
    cylinder,
    first_yield,
    hill,
    pressure,
)


def advance(nw, bulk, ua_from: float, ua_to: float, atol: float) -> int:
    """Move the inner radius from ua_from to ua_to; the Newton iterations of all steps.

    A step whose Newton fails is halved (the state reverted, the displacement reset).
    """
    its, todo = 0, [ua_to]
    ua = ua_from
    while todo:
        u0 = nw.u.x.array.copy()
        try:
            norms = nw.solve({"ra": todo[-1]}, rtol=1e-14, atol=atol)
        except RuntimeError:
            bulk.revert()
            nw.u.x.array[:] = u0
            todo.append(0.5 * (ua + todo[-1]))
            continue
        bulk.commit()
        its += len(norms) - 1
        ua = todo.pop()
    return its


def hill_table() -> None:
    print("Hill's tube: (p - p_Hill) / p_L at u_a / u_y = 1.5, 2, 3; (p - p_L) / p_L at 6")
    print(f"{'nu':>7} {'n':>4} {'1.5':>9} {'2':>9} {'3':>9} {'6':>9}  Newton")
    for nu in (0.49, 0.499, 0.4999):
        for nr in (20, 40, 80, 160):
            mat, bulk, nw, _ = cylinder(MPI.COMM_WORLD, nr=nr, nu=nu)
            u_y = first_yield(mat)
            force = P_LIMIT * 2 * math.pi
            errs, its = [], []
            ua = 0.0
            for f in (1.5, 2.0, 3.0, 6.0):
                its.append(advance(nw, bulk, ua, f * u_y, 1e-9 * force))
                ua = f * u_y
                _, ph, _ = hill(ua, mat.G)
                errs.append((pressure(nw) - ph) / P_LIMIT)
            print(f"{nu:7.4f} {nr:4d} " + " ".join(f"{e:9.1e}" for e in errs) + f"  {its}")


def throughput() -> None:
    mat = J2Material(E=200e3, nu=0.3, sigma_y=250.0, H_iso=1e3, H_kin=2e3)
    print("j2_return_map throughput (thread CPU time, best of 3)")
    for n in (10_000, 100_000, 1_000_000):
        rng = np.random.default_rng(0)
        ey = mat.sigma_y / mat.E
        state = J2State.zeros(n)
        for _ in range(3):
            state = mat.return_map(rng.normal(size=(n, 6)) * 2 * ey, state).state
        centre = state.plastic_strain + state.backstress / (2 * mat.G)
        strain = centre + rng.normal(size=(n, 6)) * rng.uniform(0.3, 2.0, size=(n, 1)) * ey
        best = math.inf
        for _ in range(3):
            t0 = time.thread_time()
            res = mat.return_map(strain, state)
            best = min(best, time.thread_time() - t0)
        share = np.count_nonzero(res.plastic) / n
        rate = n / best / 1e6
        print(f"  {n:>9d} points: {best:.3f} s, {rate:.2f} M points/s ({share:.0%} plastic)")


if __name__ == "__main__":
    throughput()
    hill_table()
