"""Newton iterations of finite sliding: the transfer's derivative in the tangent, the predictor.

The largest term of the finite-sliding tangent beyond the law's and the projection's is the change
of the master-side transfer ``B`` with the geometry, ``dB t`` (the master's nodal forces moving
with the slave facets). In 2-D it is available (``SlidingAssembly.transfer_in_tangent``, on by
default): the tangent is then the residual's derivative
(``tests/fem/interface/test_finite_sliding_tangent.py``); 3-D leaves it out. The load stepper starts
each step from the last one's extrapolated increment (``LoadStepper(predictor=...)``, on by default
with finite sliding). This benchmark prints Newton's iterations per sliding step:

* 2-D, without ``dB t`` and without the predictor (the package before both), then with the
  predictor without ``dB t``, and with both (the default);
* 3-D, the package's tangent (without ``dB t``) against the same plus ``dB t`` by central
  differences of the master-side forces with the tractions held (one column per interface dof:
  serial, small problems only).

Cases:

* ``far``: the scene of ``demos/block_sliding_far.py`` (``--n 8``: the block's 8 elements on the
  base's 1.3 times larger ones, the Sec. 7 law at 300 MPa) shortened to ``--slide`` mm, at the
  demo's step (0.8 of the block's element, 1 mm) and at a quarter of it;
* ``3d``: a deformable block pressed at 300 MPa and slid diagonally along (0.5, 0.25) mm on a
  deformable plate (tetrahedra, 2 x 2 facets on 6 x 6), in steps of 0.0625 of the slide.

Printed, never asserted.

    ./run exec python3 benchmarks/finite_sliding_newton.py [--slide 10] [--cases far 3d]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import FrictionSolver, LoadStepper
from subfric_dolfinx.fem.interface import finite_assembly

OUT = Path(__file__).resolve().parents[1] / "scratch" / "finite_sliding_newton"


def transfer_derivative(iface, eps: float = 1e-7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``d(-B t)/du`` with the tractions held, by central differences (1 rank).

    Returns the rows (all owned dofs), the columns (the interface nodes' dofs) and the dense block.
    """
    x0 = iface._x_at_update.copy()
    nodes = np.unique(np.concatenate([iface.slave.nodes.ravel(), iface.pf_nodes.ravel()]))
    cols = (nodes[:, None] * iface.bs + np.arange(iface.gdim)).ravel()
    s, nq, gdim = iface.slave, iface.nq, iface.gdim
    held = iface._global_tractions().reshape(s.size, nq, gdim).copy()
    n_nodes = iface.n_owned // iface.bs

    def master_forces() -> np.ndarray:
        tr = iface._transfer
        b = np.zeros((n_nodes, iface.bs))
        Rm = np.einsum("plq,pqd->pld", tr.B, held[tr.slave])
        np.add.at(b[:, :gdim], iface.pf_nodes[tr.master].ravel(), -Rm.reshape(-1, gdim))
        return b.ravel()

    J = np.zeros((iface.n_owned, cols.size))
    for k, c in enumerate(cols):
        for sign in (1.0, -1.0):
            x = x0.copy()
            x[c] += sign * eps
            iface.update(x)
            J[:, k] += sign * master_forces() / (2 * eps)
    iface.update(x0)
    iface.forces()
    return np.arange(iface.n_owned), cols, J


@contextlib.contextmanager
def without_predictor() -> Iterator[None]:
    """Every load stepper starts Newton from the last converged state."""
    original = LoadStepper._predict
    LoadStepper._predict = lambda self, target, dt: None
    try:
        yield
    finally:
        LoadStepper._predict = original


@contextlib.contextmanager
def transfer_derivative_2d(on: bool) -> Iterator[None]:
    """The 2-D tangent with (``on``) or without the exact ``dB t`` in the block."""
    before = finite_assembly.SlidingAssembly.transfer_in_tangent
    finite_assembly.SlidingAssembly.transfer_in_tangent = on
    try:
        yield
    finally:
        finite_assembly.SlidingAssembly.transfer_in_tangent = before


@contextlib.contextmanager
def with_transfer_derivative() -> Iterator[list[float]]:
    """Add ``dB t`` to every finite-sliding Jacobian in the block (patched; serial).

    Yields a list that receives, per Jacobian, the largest entry the interface's pattern has no
    room for, over the largest entry (it is left out).
    """
    original = finite_assembly.SlidingAssembly.assemble_jacobian
    lost: list[float] = []

    def assemble_jacobian(self, A, x=None, *, bcs=None, separated_stiffness=0.0):
        original(self, A, x, bcs=bcs, separated_stiffness=separated_stiffness)
        rows, cols, J = transfer_derivative(self)
        A.assemble()
        big = np.abs(J).max(initial=0.0)
        keep = np.flatnonzero(np.abs(J).max(axis=1) > 1e-12 * big)
        pattern = [A.getRow(int(r))[0] for r in rows[keep]]
        worst = 0.0
        for r, have in zip(rows[keep], pattern, strict=True):
            inside = np.isin(cols, have)
            worst = max(worst, np.abs(J[r, ~inside]).max(initial=0.0))
            A.setValues(
                [int(r)], cols[inside].astype(PETSc.IntType), J[r, inside],
                addv=PETSc.InsertMode.ADD_VALUES,
            )  # fmt: skip
        lost.append(worst / big if big > 0 else 0.0)

    finite_assembly.SlidingAssembly.assemble_jacobian = assemble_jacobian
    try:
        yield lost
    finally:
        finite_assembly.SlidingAssembly.assemble_jacobian = original


def far(slide: float, dt: float | None) -> tuple[list[int], list[int]]:
    """block_sliding_far's scene: Newton iterations and cuts of the sliding steps."""
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
    res = run_scene(sc, outdir=OUT, comm=comm)
    rows = [r for r in res.history if r["t"] > 1.0 + 1e-9]
    return [int(r["newton"]) for r in rows], [int(r["cuts"]) for r in rows]


def diagonal_3d() -> tuple[list[int], list[int]]:
    """The 3-D diagonal slide: Newton iterations and cuts of the sliding steps."""
    from tests.contact_meshes import diagonal_slide_3d

    law = dataclasses.replace(preset("sec7"), alpha_n=1e6)
    problem = diagonal_slide_3d(MPI.COMM_WORLD, law, 2.0)
    with FrictionSolver(problem, linear="lu") as solver:
        records = LoadStepper(solver, 0.0625, dt_max=0.0625).run()
    rows = [r for r in records if r.t > 1.0 + 1e-9]
    return [r.iterations for r in rows], [r.cuts for r in rows]


def summary(name: str, newton: list[int], cuts: list[int]) -> str:
    n = np.array(newton)
    return (
        f"{name:38s} {n.size:3d} steps, Newton mean {n.mean():5.2f}, max {n.max():2d}, "
        f"<= 5 in {np.mean(n <= 5):4.0%} of the steps, {sum(cuts)} cuts; per step {newton}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--slide", type=float, default=10.0, help="slide of far (mm)")
    ap.add_argument("--cases", nargs="+", default=["far", "3d"], choices=["far", "3d"])
    a = ap.parse_args()
    if MPI.COMM_WORLD.size != 1:
        raise SystemExit("serial only (the derivative by central differences is local)")
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
        print(lines[-1], flush=True)

    for name, run in runs:
        if name.startswith("3-D"):
            attempt(f"{name}: package tangent", run)
            with with_transfer_derivative() as lost:
                attempt(f"{name}: + dB t (central differences)", run)
            lines[-1] += f" (largest entry outside the pattern: {max(lost, default=0):.1e})"
        else:
            with transfer_derivative_2d(False), without_predictor():
                attempt(f"{name}: without dB t, without predictor", run)
            with transfer_derivative_2d(False):
                attempt(f"{name}: without dB t", run)
            with transfer_derivative_2d(True):
                attempt(f"{name}: + dB t (transfer_in_tangent)", run)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
