"""Cost of the finite-sliding search and projection against a step's time (issue 22 item 7).

A 3-D block (tetrahedra) pressed on a plate and slid across it with a finite-sliding interface
(sides meshed apart, 3 : 2), P1 or P2. For every step: the step's wall time, the search at its
start (normals, exchange, reach, re-projection at the start; ``SlidingInterface.begin_step``),
and per Newton iteration the points' projection and the segments with the transfer. Printed,
never asserted (timings depend on the machine's load).

    ./run exec python3 benchmarks/finite_sliding_cost.py [--n 24] [--degree 1] [--steps 6]
    ./run exec mpirun -n 2 python3 -m mpi4py benchmarks/finite_sliding_cost.py
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
)
from subfric_dolfinx.loading import LoadingProgram
from tests.contact_meshes import tagged_boxes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=24, help="plate facets along a side (block: 2/3)")
    ap.add_argument("--degree", type=int, default=1)
    ap.add_argument("--steps", type=int, default=6, help="sliding steps")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    nb = max(2 * a.n // 3 // 3, 1)  # the block is a third of the plate, meshed 3 : 2
    dom = tagged_boxes(
        comm,
        n_base=(a.n, a.n, 2),
        n_block=(nb, nb, 2),
        base_size=3.0,
        block_at=0.5,
        split_x=1.5,
    )
    law = preset("sec7")
    program = LoadingProgram([0.0, 1.0, 2.0], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    steel = Material(2.1e5, 0.3)
    t0 = time.perf_counter()
    problem = InterfaceProblem(
        dom,
        law,
        {"base": steel, "block": steel},
        program,
        [
            Dirichlet("bottom", (0.0, 0.0, 0.0)),
            Dirichlet("top", 1.0, 0, amplitude="slide"),
            Dirichlet("top", 0.0, 1),
        ],
        [Pressure("top", 300.0, amplitude="press")],
        interfaces=[
            Interface("contact", "base", "block", kinematics="finite_sliding", search_radius=1.5)
        ],
        settings=ProblemSettings(degree=a.degree),
    )
    setup = time.perf_counter() - t0
    iface = problem.interfaces["contact"]
    dofs = problem.global_dofs
    rows = []
    last = [time.perf_counter()]

    def on_step(rec):
        now = time.perf_counter()
        s = iface.search_seconds
        rows.append(
            (
                rec.t,
                rec.iterations,
                now - last[0],
                s["search"],
                s["projection"],
                s["segments"],
                iface.layout_version,
            )
        )
        last[0] = now

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 1.0 / a.steps, on_step=on_step).run()
    if comm.rank == 0:
        print(f"{dofs} dofs, {comm.size} rank(s), P{a.degree}, setup {setup:.2f} s")
        print("   t   newton  step s  search s  proj s/it  segm s/it  search+proj share  layout")
        for t, it, step, se, pr, sg, lv in rows:
            share = (se + max(it, 1) * (pr + sg)) / step
            print(
                f"{t:5.2f} {it:6d} {step:8.3f} {se:9.4f} {pr:10.4f} {sg:10.4f} "
                f"{100 * share:12.1f} %  {lv:6d}"
            )
        print("per-step max over the run:", np.array(rows)[:, 3:6].max(axis=0))


if __name__ == "__main__":
    main()
