"""Wall time of a finite-sliding run against the small-sliding run of the same mesh (issue 35).

One mesh whose interface nodes coincide, one program, one law; the interface once small sliding
(node-to-node pairs made once) and once finite sliding (paired in the current configuration at
every Newton iteration: search per step, projections, segments and the transfer per iteration,
the iterate's nodal normals). Cases:

* ``block``: 2-D, ``tests.contact_meshes.tagged_blocks`` (a 1 x 1 block on a 1 x 1 base, P1
  triangles, ``n`` along a side, the interface's nodes coinciding), 10,404 dofs at ``--n 50``:
  pressed at 300 MPa in 4 steps, slid 0.1 mm (5 elements) in 8 (its points past the base's
  end open);
* ``pad``: 3-D, ``benchmarks/fe_scaling.py``'s pad on a plate (hexahedra, ``n`` along the pad's
  side; for finite sliding the boxes meshed apart with the same nodes, the primary surface the
  plate's whole top), 37,206 dofs at ``--n 16``, its 24-step program (press in 4, slide to +0.5
  mm in 8, back to -0.5 mm in 12).

Both kinds on the same partition: by default every body cut evenly over the ranks (the pad:
``meshing.body_partitioner("balanced")``, the block: both bodies cut at x = 0.5), so that the
interface's work is shared (``--partition graph``: DOLFINx's graph partitioner, which may put
the pad and its whole interface on one rank). Both with the Sec. 7 law and a stiff normal
penalty (``alpha_n`` 1e6 MPa/mm, as the finite-sliding demos take), one linear strategy:
``reuse`` (MUMPS LU refreshed by the package's cost rule: what ``auto`` takes for the
finite-sliding run at these sizes), or ``--linear lu`` (a factorisation every Newton
iteration), ``auto``, ``gamg``. Prints, per kind: dofs,
steps, Newton iterations, wall time of the stepping (the problem's set-up apart) and its sections
(bulk and interface assembly, return map, contact search and projection, factorisation and
linear solve, max over ranks), then the ratio finite / small.
Timings depend on the machine's load: printed, never asserted.

    ./run exec mpirun -n 2 python3 benchmarks/finite_cost.py [--case block pad] [--n N]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from benchmarks import fe_scaling
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    StepControl,
)
from subfric_dolfinx.fem.timing import (
    TIMER_PROJECTION,
    TIMER_SEARCH,
    event_times,
    timing_breakdown,
)
from subfric_dolfinx.loading import LoadingProgram
from tests.contact_meshes import tagged_blocks

KINDS = ("small_sliding", "finite_sliding")
ALPHA_N = 1e6
"""The normal penalty (MPa/mm) of both runs (the finite-sliding demos' stiff one)."""


def build(
    comm: MPI.Comm,
    case: str,
    n: int,
    kind: str,
    balanced: bool = True,
    linear: str = "reuse",
    reach: float | None = None,
) -> tuple[Any, Any, float]:
    """The case's problem, its solver and step, the interface of the kind ``kind`` (collective).

    ``balanced``: both bodies, and so the interface, cut evenly over the ranks (the pad:
    ``meshing.body_partitioner("balanced")``; the block: both bodies cut at x = 0.5), else
    DOLFINx's graph partitioner; ``linear`` the solver's linear strategy; ``reach`` a finite
    sliding interface's (``Interface.reach``; default its own). The caller destroys the solver.
    """
    law = dataclasses.replace(preset("sec7"), alpha_n=ALPHA_N)
    if case == "pad":
        part = "balanced" if balanced else "default"
        pad = fe_scaling.build_pad(
            comm, n, linear, 24, kind, reach=reach, alpha_n=ALPHA_N, partitioner=part
        )
        return pad.problem, pad.solver, 10.0
    dom = tagged_blocks(
        comm,
        base=(0.0, 1.0, -1.0, 0.0),
        n_base=(n, n),
        n_block=(n, n),
        split_x=0.5 if balanced else None,
    )
    program = LoadingProgram([0.0, 1.0, 3.0], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    problem = InterfaceProblem(
        dom,
        law,
        {"base": Material(2.1e5, 0.3), "block": Material(7.0e4, 0.33)},
        program,
        [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.1, 0, amplitude="slide")],
        [Pressure("top", 300.0, amplitude="press")],
        interfaces=[Interface("contact", "base", "block", kinematics=kind, reach=reach)],
    )
    return problem, FrictionSolver(problem, f"{kind[:2]}_", linear=linear), 0.25


def run(
    comm: MPI.Comm, case: str, n: int, kind: str, balanced: bool = True, linear: str = "reuse"
) -> dict:
    """One run: its dofs, steps, Newton iterations, wall time and sections."""
    problem, solver, dt = build(comm, case, n, kind, balanced, linear)
    newton = []
    try:
        start = event_times()
        comm.Barrier()
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the small kind's slide warning: the comparison's
            LoadStepper(
                solver,
                dt,
                control=StepControl(dt_max=dt),
                on_step=lambda rec: newton.append(rec.iterations),
            ).run()
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        sections = timing_breakdown(problem, start)
    finally:
        solver.destroy()
    sections.pop("setup", None)
    for name in (TIMER_SEARCH, TIMER_PROJECTION):
        sections[name] = comm.allreduce(problem.timings.seconds.get(name, 0.0), op=MPI.MAX)
    return {
        "dofs": problem.global_dofs,
        "steps": len(newton),
        "newton": sum(newton),
        "max newton": max(newton),
        "wall": wall,
        **sections,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", nargs="+", default=["block", "pad"], choices=["block", "pad"])
    ap.add_argument("--n", type=int, default=None, help="elements along the interface")
    ap.add_argument(
        "--linear",
        choices=["reuse", "lu", "auto", "gamg"],
        default="reuse",
        help="the linear strategy of both runs (default: MUMPS LU refreshed by the cost rule)",
    )
    ap.add_argument(
        "--partition",
        choices=["balanced", "graph"],
        default="balanced",
        help="every body cut evenly over the ranks (default), or DOLFINx's graph partitioner",
    )
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    PETSc.Log.begin()
    for case in a.case:
        n = a.n or {"block": 50, "pad": 16}[case]
        balanced = a.partition == "balanced"
        out = {kind: run(comm, case, n, kind, balanced, a.linear) for kind in KINDS}
        if comm.rank == 0:
            keys = list(out[KINDS[0]])
            print(
                f"\n{case}, n = {n}, {comm.size} rank(s), partition: {a.partition}, "
                f"linear: {a.linear}"
            )
            print(f"  {'':22s} {'small':>10s} {'finite':>10s}")
            for k in keys:
                s, f = out["small_sliding"][k], out["finite_sliding"][k]
                print(
                    f"  {k:22s} {s:10.3f} {f:10.3f}"
                    if isinstance(s, float)
                    else f"  {k:22s} {s:10d} {f:10d}"
                )
            ratio = out["finite_sliding"]["wall"] / out["small_sliding"]["wall"]
            print(f"  finite / small wall time: {ratio:.2f}", flush=True)


if __name__ == "__main__":
    main()
