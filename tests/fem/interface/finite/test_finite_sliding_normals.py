"""The primary's nodal normals of every Newton iterate (issue 35 item 1): a slide's forces do not
depend on the step.

``demos/block_sliding_far.py``'s block (meshed apart from its base, ``--n 4``) pressed and slid
3 mm, at 0.5 and at 0.25 mm a step. With the step's normals held (``normals_per_iteration``
off; on by default) the frames lag the base's deformation within a step, and the push on
the block's top changes with the step by about 1e-3 of the friction force (first order in the
step). With the normals of every iterate:

* Coulomb (rate-independent, no time error of its own): the push and the friction force at the
  common times of the two runs agree to 1e-6 of the peak friction force;
* the paper's Sec. 7 law (its recovery integrates in time): the push changes with the step as
  the friction force does, to 1e-6 of the peak: nothing beyond the law's own time error.

1 and 2 ranks. The tangent holds the normals' change with the primary's nodes
(:mod:`subfric_dolfinx.fem.interface.finite.normals`) through the projection, the gap, the frame
(3-D: and the transport's rotation) and the transfer: the interface's tangent is the derivative
of its forces (central differences, O(e^2)), 2-D and 3-D, as with the step's normals.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from demos import block_sliding_far as far
from subfric_dolfinx.constitutive import CoulombLaw, preset
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
from subfric_dolfinx.fem.interface.finite.interface import SlidingInterface
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import run_scene
from tests.contact_meshes import diagonal_slide_3d, tagged_boxes
from tests.fem.interface.finite import test_finite_sliding_tangent as tangent
from tests.helpers import everywhere

N, SLIDE = 4, 3.0
LAWS = {
    "coulomb": {"law": "coulomb", "params": {"alpha_t": 1e6, "alpha_n": 1e6, "mu_c": 0.3}},
    "sec7": {"law": "subloading", "params": {"preset": "sec7", "alpha_n": far.ALPHA_N}},
}


@pytest.fixture(scope="module")
def mesh(tmp_path_factory) -> Path:
    """The demo's mesh, slid 3 mm, written once for the module (collective)."""
    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(str(tmp_path_factory.mktemp("normals")) if comm.rank == 0 else None))
    path = root / "block.msh"
    far.write_mesh(path, N, SLIDE, comm)
    return path


def history(comm: MPI.Comm, mesh: Path, law: str, dt: float) -> dict[float, np.ndarray]:
    """Time -> (push on the block's top, friction force F_t1) of the slide at steps ``dt``."""
    s = far.scene(mesh, N, SLIDE)
    s.pop("points")
    s["law"] = LAWS[law]
    s["outputs"] = {"history": True}
    s["solver"] = {"prefix": f"nrm{int(100 * dt)}_", "dt": dt, "dt_max": dt}
    out = mesh.parent / f"{law}_{dt}"
    rows = run_scene(s, outdir=out, comm=comm).history
    return {round(r["t"], 9): np.array([r["R_top_x"], r["F_t1"]]) for r in rows}


def halving(comm, mesh, law) -> tuple[np.ndarray, np.ndarray]:
    """(push, friction) at the common times of the runs at 0.5 and at 0.25 mm a step."""
    a, b = history(comm, mesh, law, 0.5), history(comm, mesh, law, 0.25)
    common = [t for t in sorted(a) if t in b and t > 1.0]
    return np.array([a[t] for t in common]), np.array([b[t] for t in common])


@pytest.mark.parametrize("law", ["coulomb", "sec7"])
def test_a_slide_does_not_depend_on_the_step(comm, mesh, law):
    assert SlidingInterface.normals_per_iteration  # the default
    coarse, fine = halving(comm, mesh, law)
    peak = np.abs(coarse[:, 1]).max()
    assert len(coarse) >= 6 and peak > 0.0, (coarse, peak)
    if law == "coulomb":
        change = np.abs(coarse - fine).max() / peak
    else:  # the push's change beyond the friction's (the law's own time error)
        change = np.abs((coarse[:, 0] - coarse[:, 1]) - (fine[:, 0] - fine[:, 1])).max() / peak
    assert change < 1e-6, change


def test_held_normals_make_the_push_depend_on_the_step(comm, mesh, monkeypatch):
    """The reference of the test above: the step's normals held, the push changes with the
    step (the frames lag the base's deformation within the step)."""
    monkeypatch.setattr(SlidingInterface, "normals_per_iteration", False)
    coarse, fine = halving(comm, mesh, "coulomb")
    peak = np.abs(coarse[:, 1]).max()
    assert np.abs(coarse[:, 0] - fine[:, 0]).max() > 1e-4 * peak, (coarse, fine)


def secondary_rows(problem, iface) -> np.ndarray:
    """The owned dofs of the secondary facets' nodes."""
    bs = problem.V.dofmap.bs
    nodes = np.unique(iface.sides.secondary.nodes)
    nodes = nodes[nodes < problem.V.dofmap.index_map.size_local]
    return (nodes[:, None] * bs + np.arange(bs)).ravel()


@pytest.mark.parametrize("law, degree", [("coulomb", 1), ("sec7", 1), ("coulomb", 2)])
def test_2d_tangent_holds_the_normals_change(comm, law, degree):
    """test_finite_sliding_tangent's 2-D block, slid to t = 1.75 with the iterate's normals: the
    interface's tangent times a direction is its forces' central differences to O(e^2), its
    secondary rows alone (no transfer) and all of it."""
    assert SlidingInterface.normals_per_iteration  # the default
    problem = tangent.problem_2d(comm, tangent.law_of(law), degree)
    iface = problem.interfaces["contact"]
    rows = secondary_rows(problem, iface)

    def rel(d, ref):
        return np.sqrt(comm.allreduce(float(d @ d)) / comm.allreduce(float(ref @ ref)))

    with FrictionSolver(problem, linear="lu") as solver:
        records = LoadStepper(solver, 0.25, control=StepControl(dt_max=0.25)).run(t_end=1.75)
        newton = [(rec.t, rec.iterations, bool(rec.cuts or rec.retried)) for rec in records]
        x = solver.x.copy()
        v = tangent.direction(comm, problem, x)
        F = problem.create_vector()
        problem.residual(x, F)
        J = problem.create_matrix()
        J.zeroEntries()
        iface.assemble_jacobian(J)
        J.assemble()
        Jv = x.duplicate()
        J.mult(v, Jv)
        jv = Jv.array_r.copy()
        err = []
        for e in (1e-4, 1e-5):
            forces = []
            for sign in (1.0, -1.0):
                xs = x.copy()
                xs.axpy(sign * e, v)
                problem.residual(xs, F)
                forces.append(problem.interface_force.copy())
                xs.destroy()
            d = (forces[0] - forces[1]) / (2 * e)
            err.append((rel(d[rows] - jv[rows], jv[rows]), rel(d - jv, jv)))
        counts = comm.allreduce(np.bincount(iface.last.status, minlength=4))
        for w in (x, v, F, J, Jv):
            w.destroy()
    err = np.array(err)
    checks = {
        "newton": tangent.within(newton),
        "in contact": counts[0] + counts[1] > 0,
        "secondary rows exact": err[1, 0] < 1e-8,
        "O(e^2)": err[0, 0] > 30 * err[1, 0] or err[0, 0] < 1e-9,
        "whole exact": err[1, 1] < 1e-8,
        "whole O(e^2)": err[0, 1] > 30 * err[1, 1] or err[0, 1] < 1e-9,
    }
    assert everywhere(comm, all(checks.values())), (checks, err, counts, newton)


@pytest.mark.parametrize("law", ["coulomb", "sec7"])
def test_3d_tangent_holds_the_normals_change(comm, law):
    """test_finite_sliding_tangent's 3-D diagonal slide in the middle of a sliding step, with the
    iterate's normals: the whole Jacobian is the residual's derivative (central differences,
    O(e^2)): the normals' change through the projection, the gap, the frame, the transport's
    rotation and the transfer."""
    assert SlidingInterface.normals_per_iteration  # the default
    problem = diagonal_slide_3d(comm, tangent.law_of(law), 3.0, split_x=1.5)
    with FrictionSolver(problem, linear="lu") as solver:
        converged, newton = tangent.mid_step(solver, 1.75, 1.9, 0.15)
        x = solver.x.copy()
        v = tangent.direction(comm, problem, x)
        err = tangent.differences(comm, problem, x, v, [1e-4, 1e-5])
        counts = comm.allreduce(np.bincount(problem.interfaces["contact"].last.status, minlength=4))
        v.destroy()
        x.destroy()
    checks = {
        "converged": converged,
        "newton": tangent.within(newton),
        "in contact": counts[0] + counts[1] > 0,
        "exact": err[1].max() < 1e-8,
        "O(e^2)": np.all((err[0] > 30 * err[1]) | (err[0] < 1e-9)),
    }
    assert everywhere(comm, all(checks.values())), (checks, err, counts, newton)


def slide(
    comm: MPI.Comm, dim: int, law: str, dt: float, newton: list | None = None
) -> dict[float, np.ndarray]:
    """A block pressed on a plate meshed apart and slid: time -> (push on its top, the
    interface's global force on it (sum of ``w Q^T f``), the tractions' integral in each point's
    frame (F_t1 [, F_t2])), their tangential components. ``newton``: gets (t, Newton
    iterations, cuts, retried) of every step.

    2-D: test_finite_sliding_tangent's block (3 facets on 7), slid 1 mm from t = 1 to 3; 3-D: a
    2 x 2 x 2 block on a 6 x 6 x 2 plate slid by (1, 0.5) mm from t = 0.2 to 1.
    """
    laws = {
        "coulomb": CoulombLaw(alpha_t=1e6, alpha_n=1e6, mu_c=0.3),
        "sec7": dataclasses.replace(preset("sec7"), alpha_n=1e6),
    }
    nt = dim - 1
    if dim == 2:
        problem = tangent.problem_2d(comm, laws[law], 1)
    else:
        dom = tagged_boxes(
            comm, n_base=(6, 6, 2), n_block=(2, 2, 2), base_size=3.0, block_at=0.5, split_x=1.5
        )
        program = LoadingProgram([0.0, 0.2, 1.0], {"press": [0, 1, 1], "slide": [0, 0, 1.0]})
        problem = InterfaceProblem(
            dom,
            laws[law],
            {"base": Material(2.1e5, 0.3), "block": Material(7e4, 0.33)},
            program,
            [
                Dirichlet("bottom", (0.0, 0.0, 0.0)),
                Dirichlet("top", 1.0, 0, amplitude="slide"),
                Dirichlet("top", 0.5, 1, amplitude="slide"),
            ],
            [Pressure("top", 300.0, amplitude="press")],
            interfaces=[
                Interface(
                    "contact", "base", "block", kinematics="finite_sliding", search_radius=1.5
                )
            ],
        )
    iface = problem.interfaces["contact"]
    rows = {}

    def on_step(rec):
        w, f = iface.law_points.weights, iface.last.traction
        tg = np.einsum("mji,mj->mi", iface.geometry.Q, f)
        forces = comm.allreduce(np.concatenate([w @ tg[:, :nt], w @ f[:, :nt]]))
        rows[round(rec.t, 9)] = np.concatenate([problem.reactions["top"][:nt], forces])
        if newton is not None:
            newton.append((rec.t, rec.iterations, rec.cuts, rec.retried))

    with FrictionSolver(problem, f"s{dim}d{int(1000 * dt)}_", linear="lu") as solver:
        LoadStepper(solver, dt, control=StepControl(dt_max=dt), on_step=on_step).run()
    return rows


@pytest.mark.parametrize("dim, dt", [(2, 0.25), (3, 0.1)])
@pytest.mark.parametrize("law", ["coulomb", "sec7"])
def test_push_is_the_interface_force_whatever_the_step(comm, law, dim, dt):
    """The iterate's normals (``normals_per_iteration``, the default): the push on the sliding
    block equals the interface's global force on it (sum of ``w Q^T f``, not F_t1: the
    tractions' integral in each point's frame differs from it by F_n times the base's slope) at
    every step, and halving the
    step changes the push by less than 1e-6 of the peak beyond the law's own time error
    (Coulomb 2-D: none; Sec. 7, and Coulomb 3-D: the change of the tractions' integral in the
    points' frames). Coulomb's own in 3-D: its return map gives the slip increment's direction
    (the chord of the step's slip path) where the path turns in the tangent plane: on halving
    the step the friction force turns by 1.4e-4 (its size changes by 1e-5), as much on a rigid
    plate; its frame-by-frame integral turns with it."""
    assert SlidingInterface.normals_per_iteration  # the default
    nt = dim - 1
    newton: list = []
    coarse, fine = slide(comm, dim, law, dt, newton), slide(comm, dim, law, dt / 2, newton)
    start = 1.0 if dim == 2 else 0.2
    common = [t for t in sorted(coarse) if t in fine and t > start]
    a = np.array([coarse[t] for t in common])
    b = np.array([fine[t] for t in common])
    push, force, local = slice(0, nt), slice(nt, 2 * nt), slice(2 * nt, 3 * nt)
    peak = np.linalg.norm(a[:, force], axis=1).max()
    balance = max(np.abs(x[:, push] - x[:, force]).max() for x in (a, b)) / peak
    if law == "coulomb" and dim == 2:
        change = np.abs(a[:, : 2 * nt] - b[:, : 2 * nt]).max() / peak
    else:
        change = np.abs((a[:, push] - a[:, local]) - (b[:, push] - b[:, local])).max() / peak
    checks = {"steps": len(common) >= 7, "balance": balance < 1e-6, "halving": change < 1e-6}
    # Newton: every step of both runs, the press's first (the first touch) and the slide's first
    # (the program turns; Coulomb in 3-D tilts the block off 11 of its 24 points) included,
    # within 5 iterations, without a cut or a retry
    most = max(n for _, n, _, _ in newton)
    checks["newton"] = most <= tangent.NEWTON
    checks["no cut"] = not any(c or r for _, _, c, r in newton)
    assert all(checks.values()), (checks, balance, change, newton)
