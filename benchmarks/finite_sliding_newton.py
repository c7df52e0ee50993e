"""Newton iterations of finite sliding: the transfer's derivative in the tangent, the predictor.

The largest term of the finite-sliding tangent beyond the law's and the projection's is the change
of the primary-side transfer ``B`` with the geometry, ``dB t`` (the primary's nodal forces moving
with the secondary facets; ``SegmentTransfer.in_tangent``, on by default, 2-D and 3-D): the
2-D tangent is then the residual's derivative, the 3-D one but for the frame's turn
(``tests/fem/interface/finite/test_finite_sliding_tangent.py``). The load stepper starts each step
from the last one's extrapolated increment, and where the program turns (nothing to extrapolate)
from the bodies the program's Dirichlet values carry along (a frictionless first Newton
iteration where they carry none; ``LoadStepper(predictor=...)``, on by default). This
benchmark prints Newton's iterations per sliding step (the slide's first step included):

* 2-D, without ``dB t`` and without the predictor (the package before both), then with the
  predictor without ``dB t``, and with both (the default);
* 3-D, without ``dB t`` and with it (the default), both with the predictor.

Cases:

* ``far``: the scene of ``demos/block_sliding_far.py`` (``--n 8``: the block's 8 elements on the
  base's 1.3 times larger ones, the Sec. 7 law at 300 MPa) shortened to ``--slide`` mm, at the
  demo's step (0.8 of the block's element, 1 mm) and at a quarter of it;
* ``3d``: a deformable block pressed at 300 MPa and slid diagonally along (0.5, 0.25) mm on a
  deformable plate (tetrahedra, 2 x 2 facets on 6 x 6), in steps of 0.0625 of the slide.

Printed, never asserted.

    ./run exec [mpirun -n 2] python3 benchmarks/finite_sliding_newton.py [--slide 10]
        [--cases far 3d]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepControl
from subfric_dolfinx.fem.interface.finite.transfer import SegmentTransfer

OUT = Path(__file__).resolve().parents[1] / "scratch" / "finite_sliding_newton"


@contextlib.contextmanager
def without_predictor() -> Iterator[None]:
    """Every load stepper made with ``predictor=False`` (the steps start on the law's tangent)."""
    original = LoadStepper.__init__

    def init(self, *args, **kwargs):
        original(self, *args, **{**kwargs, "predictor": False})

    LoadStepper.__init__ = init
    try:
        yield
    finally:
        LoadStepper.__init__ = original


@contextlib.contextmanager
def transfer_derivative(on: bool) -> Iterator[None]:
    """The tangent with (``on``) or without ``dB t`` in the block."""
    before = SegmentTransfer.in_tangent
    SegmentTransfer.in_tangent = on
    try:
        yield
    finally:
        SegmentTransfer.in_tangent = before


@contextlib.contextmanager
def counted_attempts() -> Iterator[list[tuple[float, int]]]:
    """Every solve's ``(t, iterations)``: a failed attempt and its retry count both."""
    original = FrictionSolver.solve
    seen: list[tuple[float, int]] = []

    def solve(self, t, dt, **kwargs):
        r = original(self, t, dt, **kwargs)
        seen.append((t, r.iterations))
        return r

    FrictionSolver.solve = solve
    try:
        yield seen
    finally:
        FrictionSolver.solve = original


def all_attempts(seen: list[tuple[float, int]], times: list[float]) -> list[int]:
    """Newton iterations of every attempt at each step (failed attempts included)."""
    return [sum(n for t, n in seen if abs(t - tt) <= 1e-9 * max(1.0, tt)) for tt in times]


def far(slide: float, dt: float | None) -> tuple[list[int], list[int], list[int]]:
    """block_sliding_far's scene: per sliding step, Newton, cuts, every attempt's Newton."""
    from demos import block_sliding_far as demo
    from subfric_dolfinx.scenes import run_scene

    comm = MPI.COMM_WORLD
    mesh = OUT / "far.msh"
    demo.write_mesh(mesh, 8, slide, comm)
    sc = demo.scene(mesh, 8, slide)
    if dt is not None:
        sc["solver"]["dt"] = sc["solver"]["dt_max"] = dt
    sc["outputs"] = {"history": True}
    sc.pop("points")
    with counted_attempts() as seen:
        res = run_scene(sc, outdir=OUT, comm=comm)
    rows = [r for r in res.history if r["t"] > 1.0 + 1e-9]
    total = all_attempts(seen, [r["t"] for r in rows])
    return [int(r["newton"]) for r in rows], [int(r["cuts"]) for r in rows], total


def diagonal_3d() -> tuple[list[int], list[int], list[int]]:
    """The 3-D diagonal slide: per sliding step, Newton, cuts, every attempt's Newton."""
    from tests.contact_meshes import diagonal_slide_3d

    law = dataclasses.replace(preset("sec7"), alpha_n=1e6)
    problem = diagonal_slide_3d(MPI.COMM_WORLD, law, 2.0)
    with counted_attempts() as seen, FrictionSolver(problem, linear="lu") as solver:
        records = LoadStepper(solver, 0.0625, control=StepControl(dt_max=0.0625)).run()
    rows = [r for r in records if r.t > 1.0 + 1e-9]
    total = all_attempts(seen, [r.t for r in rows])
    return [r.iterations for r in rows], [r.cuts for r in rows], total


def summary(name: str, newton: list[int], cuts: list[int], total: list[int]) -> str:
    n = np.array(newton)
    extra = "" if total == newton else f"; with the failed attempts {total}"
    return (
        f"{name:38s} {n.size:3d} steps, Newton mean {n.mean():5.2f}, max {n.max():2d}, "
        f"<= 5 in {np.mean(n <= 5):4.0%} of the steps, {sum(cuts)} cuts; per step {newton}"
        f"{extra}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--slide", type=float, default=10.0, help="slide of far (mm)")
    ap.add_argument("--cases", nargs="+", default=["far", "3d"], choices=["far", "3d"])
    a = ap.parse_args()
    runs = []
    if "far" in a.cases:
        for dt, label in ((None, "the demo's step, 1 mm"), (0.25, "0.25 mm steps")):
            runs.append((f"far {a.slide:g} mm, {label}", lambda dt=dt: far(a.slide, dt)))
    if "3d" in a.cases:
        runs.append(("3-D diagonal slide", diagonal_3d))
    lines = []

    def attempt(label: str, run) -> None:
        try:
            lines.append(summary(label, *run()))
        except Exception as e:  # a failed run is a result here
            lines.append(f"{label}: {type(e).__name__}: {str(e)[:160]}")
        if MPI.COMM_WORLD.rank == 0:
            print(lines[-1], flush=True)

    for name, run in runs:
        if name.startswith("3-D"):
            with transfer_derivative(False):
                attempt(f"{name}: without dB t", run)
            with transfer_derivative(True):
                attempt(f"{name}: + dB t (in_tangent)", run)
        else:
            with transfer_derivative(False), without_predictor():
                attempt(f"{name}: without dB t, without predictor", run)
            with transfer_derivative(False):
                attempt(f"{name}: without dB t", run)
            with transfer_derivative(True):
                attempt(f"{name}: + dB t (in_tangent)", run)
    if MPI.COMM_WORLD.rank == 0:
        print("\n".join(lines))


if __name__ == "__main__":
    main()
