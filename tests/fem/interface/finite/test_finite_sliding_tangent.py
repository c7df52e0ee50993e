"""The finite-sliding tangent against central differences of the whole problem's residual.

A deformable block pressed and dragged along a deformable base meshed apart (3 facets on 7 across
the interface, 2-D, P1 and P2; 2 x 2 on 6 x 6, 3-D), across the partition boundary on 2 ranks,
evaluated in the middle of a sliding step (the step's Newton solution, not committed: the points
slide, statuses inside their regimes). For a direction ``v`` of the size of the step's slide
(0.1 mm, zero on the Dirichlet dofs) the assembled Jacobian's ``J v`` is compared with
``(F(x + e v) - F(x - e v)) / 2e`` of the assembled residual (bulk, loads, Dirichlet rows and the
interface), and the interface's own tangent with the central differences of its forces
(relative errors, whole / interface):

* 2-D, with the transfer's change (``SegmentTransfer.in_tangent``, the default): the
  residual's derivative, O(e^2) down to round-off. Measured at e = 1e-4 and 1e-5 (1 rank):
  Coulomb P1 9.8e-12 and 6.9e-12 / 8.1e-11 and 1.4e-12; Sec. 7 P1 9.5e-9 and 9.6e-11 / 4.7e-8
  and 4.7e-10; Coulomb P2 5.0e-11 and 1.3e-11 / 9.8e-10 and 9.5e-12. Without it the transfer's
  part remains: 4.5e-5 / 3.7e-4, 4.2e-5 / 2.1e-4, 1.1e-4 / 2.1e-3;
* 3-D, with the transfer's change (the default, through the clipped preimage polygons) and
  the frame's turn (its rows and the transport's rotation, ``contact.FrameTurn``): the residual's
  derivative too, O(e^2) down to round-off: measured 2.0e-8, 2.0e-10 and 2.6e-11 of the whole
  ``J v`` at e = 1e-4, 1e-5 and 1e-6 (Sec. 7 P1; the interface's 2.0e-7, 2.0e-9, 2.1e-11). The
  transfer's part alone (``J v`` with ``dB t`` minus without, against the differences of the
  interface forces with ``B`` live minus with ``B`` held at ``x``): O(e^2), 1.1e-6 and 1.1e-8
  at e = 1e-4 and 1e-5 (Sec. 7 P1; Coulomb P1 3.5e-7 and 3.5e-9; Sec. 7 P2 4.3e-6 and 4.3e-8);
  without ``dB t`` 5.7e-5 / 5.8e-4.

Every step of the runs that lead there (the press's first, a first touch, and the slide's first,
where the program turns, included) and the mid-step solve take at most :data:`NEWTON` Newton
iterations, without a cut or a retry.

``benchmarks/finite_sliding_newton.py`` prints Newton's iterations with and without ``dB t``.
"""

import dataclasses

import numpy as np
import pytest

from subfric_dolfinx.constitutive import CoulombLaw, preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
    StepControl,
)
from subfric_dolfinx.fem.interface.finite import transfer
from subfric_dolfinx.fem.interface.finite.transfer import SegmentTransfer
from subfric_dolfinx.loading import LoadingProgram
from tests.contact_meshes import diagonal_slide_3d, tagged_blocks
from tests.helpers import everywhere

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)


def problem_2d(comm, law, degree, base_end=4.0, initial_gap=None, press_down=None, more=()):
    """The block pressed by 300 MPa on its top and slid; ``press_down``: pressed instead by
    moving its top down by this much (mm); ``more``: more Dirichlet conditions."""
    dom = tagged_blocks(
        comm,
        base=(0.0, base_end, -1.0, 0.0),
        block=(1.0, 2.0, 0.0, 1.0),
        n_base=(7, 2),
        n_block=(3, 2),
        split_x=2.0,
    )
    program = LoadingProgram([0.0, 1.0, 3.0], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 1.0, 0, amplitude="slide"), *more]
    loads = [Pressure("top", 300.0, amplitude="press")]
    if press_down is not None:
        bcs.append(Dirichlet("top", -press_down, 1, amplitude="press"))
        loads = []
    return InterfaceProblem(
        dom,
        law,
        {"base": Material(2.1e5, 0.3), "block": Material(7e4, 0.33)},
        program,
        bcs,
        loads,
        interfaces=[
            Interface(
                "contact", "base", "block", kinematics="finite_sliding", initial_gap=initial_gap
            )
        ],
        settings=ProblemSettings(degree=degree),
    )


NEWTON = 5
"""Newton iterations allowed in every step of a finite-sliding run (the press's first, a first
touch, and the slide's first, where the program turns, included)."""


def mid_step(solver, t_stop, t, dt):
    """The problem advanced to ``t_stop`` and solved (not committed) for the step to ``t``.

    Returns:
        Whether the step converged, and ``(t, Newton iterations, cut or retried)`` of every step
        (the stepper's, then this one).
    """
    records = LoadStepper(solver, 0.25, control=StepControl(dt_max=0.25)).run(t_end=t_stop)
    r = solver.solve(t, dt)
    newton = [(rec.t, rec.iterations, bool(rec.cuts or rec.retried)) for rec in records]
    return bool(r.converged), [*newton, (t, r.iterations, False)]


def within(newton) -> bool:
    """Whether every step of ``newton`` (:func:`mid_step`) took at most :data:`NEWTON` Newton
    iterations, none cut or retried."""
    return all(n <= NEWTON and not again for _, n, again in newton)


def differences(comm, problem, x, v, eps):
    """Relative differences ``|J v - (F(x + e v) - F(x - e v)) / 2e| / |J v|`` for each ``e``.

    Returns:
        (len(eps), 2): of the whole problem (``F`` the residual, ``J`` the Jacobian) and of the
        interface alone (its forces and its tangent).
    """
    iface = problem.interfaces["contact"]
    F = problem.create_vector()
    problem.residual(x, F)
    J, Ji = problem.create_matrix(), problem.create_matrix()
    problem.jacobian(x, J)
    Ji.zeroEntries()
    iface.assemble_jacobian(Ji)
    Ji.assemble()
    Jv, Jiv = x.duplicate(), x.duplicate()
    J.mult(v, Jv)
    Ji.mult(v, Jiv)
    Fp, Fm = x.duplicate(), x.duplicate()

    def rel(d, ref):
        return np.sqrt(comm.allreduce(float(d @ d)) / comm.allreduce(float(ref @ ref)))

    out = []
    for e in eps:
        xp, xm = x.copy(), x.copy()
        xp.axpy(e, v)
        xm.axpy(-e, v)
        problem.residual(xp, Fp)
        fp = problem.interface_force.copy()
        problem.residual(xm, Fm)
        fm = problem.interface_force.copy()
        d = (Fp.array_r - Fm.array_r) / (2 * e) - Jv.array_r
        di = (fp - fm) / (2 * e) - Jiv.array_r
        out.append((rel(d, Jv.array_r), rel(di, Jiv.array_r)))
        for w in (xp, xm):
            w.destroy()
    for w in (F, Fp, Fm, Jv, Jiv, J, Ji):
        w.destroy()
    return np.array(out)


def law_of(name):
    if name == "coulomb":
        return CoulombLaw(alpha_t=1e6, alpha_n=1e6, mu_c=0.3)
    return dataclasses.replace(preset("sec7"), alpha_n=1e6)


def direction(comm, problem, x):
    """A direction of the size of the step's slide (0.1 mm), zero on the Dirichlet dofs."""
    rng = np.random.default_rng(7 + comm.rank)
    v = x.duplicate()
    v.array_w[:] = rng.uniform(-0.1, 0.1, v.array_r.size)
    v.array_w[problem.dirichlet_values(problem.t)[0]] = 0.0
    return v


def mid_step_differences(comm, problem, also=None):
    """The central differences at e = 1e-4 and 1e-5 (:func:`differences`) in the middle of a
    sliding step (:func:`mid_step`: to 1.75, solved to 1.9) along :func:`direction`.

    ``also(x, v)``: more at the same point (e.g. with a term of the tangent left out).

    Returns:
        Whether the step converged, the Newton iterations of every step (:func:`mid_step`), the
        differences and what ``also`` gave (``None``: none).
    """
    with FrictionSolver(problem, linear="lu") as solver:
        converged, newton = mid_step(solver, 1.75, 1.9, 0.15)
        x = solver.x.copy()
        v = direction(comm, problem, x)
        try:
            err = differences(comm, problem, x, v, [1e-4, 1e-5])
            more = also(x, v) if also is not None else None
        finally:
            v.destroy()
            x.destroy()
    return converged, newton, err, more


@pytest.mark.parametrize("law, degree", [("coulomb", 1), ("sec7", 1), ("coulomb", 2)])
def test_2d_tangent_is_the_residual_derivative(comm, monkeypatch, law, degree):
    problem = problem_2d(comm, law_of(law), degree)

    def without_transfer_change(x, v):
        monkeypatch.setattr(SegmentTransfer, "in_tangent", False)
        return differences(comm, problem, x, v, [1e-5])[0]

    converged, newton, err, without = mid_step_differences(comm, problem, without_transfer_change)
    counts = comm.allreduce(np.bincount(problem.interfaces["contact"].last.status, minlength=4))
    checks = {
        "converged": converged,
        "newton": within(newton),
        "in contact": counts[0] + counts[1] > 0,  # sticking or slipping points
        "exact": err[1].max() < 1e-8,
        "O(e^2)": np.all((err[0] > 30 * err[1]) | (err[0] < 1e-9)),
        "without dB t": without[1] > 1e-5,
    }
    assert everywhere(comm, all(checks.values())), (checks, err, without, counts, newton)


@pytest.mark.parametrize("law", ["coulomb", "sec7"])
def test_2d_tangent_with_an_initial_gap(comm, law):
    """An initial gap (0.1 um plus a parabola, closed by the press: the block's contact surface
    is not its mesh's): the points that faced the base at the step's start are projected from their
    contact surfaces (moved by ``g0`` along the step's start normal), and the tangent is still
    the residual's derivative; the law's normal gaps are those of the contact surfaces."""

    def g0(x):
        return 0.0001 + 0.0005 * (x[0] - 1.5) ** 2

    # pressed by its top's displacement: under a pressure, the block held only sideways floats
    # on its open interface (a singular Jacobian until it touches)
    problem = problem_2d(comm, law_of(law), 1, initial_gap=g0, press_down=0.005)
    iface = problem.interfaces["contact"]
    converged, newton, err, _ = mid_step_differences(comm, problem)
    g, pts = iface.geometry, iface.law_points
    raw = np.einsum("qk,fkd->fqd", iface.sides.Ns[0], g.Xs).reshape(-1, 2)
    # the contact surface: the point moved by g0 along the normal it faced at the step's start
    moved = np.abs(np.einsum("md,md->m", g.xq - raw, iface.start.Q[:, 1]) + pts.g0)
    closed = comm.allreduce(int(np.count_nonzero(g.found & (g.gap[:, 1] > 0))))
    checks = {
        "converged": converged,
        "newton": within(newton),
        "in contact": closed > 0,
        "on their contact surfaces": bool(np.all(moved[iface.start.facet >= 0] < 1e-12)),
        "exact": err[1].max() < 1e-8,
        "O(e^2)": np.all((err[0] > 30 * err[1]) | (err[0] < 1e-9)),
    }
    assert everywhere(comm, all(checks.values())), (checks, err, closed, newton)


def test_2d_tangent_past_the_end_of_the_base(comm, monkeypatch):
    """The block's end facet overhangs the base's end (its points still on it): the complement
    of the transfer (the share the segments miss, given where the points project) and its change
    with the geometry (and with the iterate's nodal normals) are in the tangent, which is still
    the residual's derivative."""
    problem = problem_2d(comm, law_of("coulomb"), 1, base_end=2.42)
    iface = problem.interfaces["contact"]

    def without_complement_change(x, v):
        monkeypatch.setattr(SegmentTransfer, "complement_tangent", lambda *a: [])
        return differences(comm, problem, x, v, [1e-5])[0]

    converged, newton, err, without = mid_step_differences(comm, problem, without_complement_change)
    complement = comm.allreduce(iface.geometry.transfer.complement)
    checks = {
        "converged": converged,
        "newton": within(newton),
        "overhangs": complement > 0,
        "exact": err[1].max() < 1e-8,
        "O(e^2)": np.all((err[0] > 30 * err[1]) | (err[0] < 1e-9)),
        "without the complement's change": without[1] > 1e-6,
    }
    assert everywhere(comm, all(checks.values())), (checks, err, without, complement, newton)


def interface_rates(problem, x, v, eps, held=None):
    """The interface forces' central differences ``(f(x + e v) - f(x - e v)) / 2e`` for each ``e``
    (owned values); with ``held``, the primary-side transfer ``B`` held at it."""
    F = problem.create_vector()
    out = []
    with pytest.MonkeyPatch.context() as mp:
        if held is not None:
            mp.setattr(transfer, "transfer_matrices", lambda *a, **k: held)
        for e in eps:
            fs = []
            for sign in (1.0, -1.0):
                xs = x.copy()
                xs.axpy(sign * e, v)
                problem.residual(xs, F)
                fs.append(problem.interface_force.copy())
                xs.destroy()
            out.append((fs[0] - fs[1]) / (2 * e))
    F.destroy()
    return out


def interface_jv(problem, x, v):
    """The interface's own tangent at ``x`` times ``v`` (owned values)."""
    F = problem.create_vector()
    problem.residual(x, F)
    Ji = problem.create_matrix()
    Ji.zeroEntries()
    problem.interfaces["contact"].assemble_jacobian(Ji)
    Ji.assemble()
    y = x.duplicate()
    Ji.mult(v, y)
    out = y.array_r.copy()
    for w in (F, Ji, y):
        w.destroy()
    return out


def test_3d_tangent_holds_the_transfer_change(comm, monkeypatch):
    problem = diagonal_slide_3d(comm, law_of("sec7"), 3.0, split_x=1.5)
    with FrictionSolver(problem, linear="lu") as solver:
        converged, newton = mid_step(solver, 1.75, 1.9, 0.15)
        x = solver.x.copy()
        iface = problem.interfaces["contact"]
        v = direction(comm, problem, x)
        err = differences(comm, problem, x, v, [1e-4, 1e-5])
        counts = comm.allreduce(np.bincount(iface.last.status, minlength=4))
        # the transfer's part alone: d(-B t) by differences of the forces with B live and held
        eps = [1e-4, 1e-5]
        live = interface_rates(problem, x, v, eps)
        F = problem.create_vector()
        problem.residual(x, F)
        F.destroy()
        held = interface_rates(problem, x, v, eps, iface.geometry.transfer)
        on = interface_jv(problem, x, v)
        monkeypatch.setattr(SegmentTransfer, "in_tangent", False)
        off = interface_jv(problem, x, v)
        without = differences(comm, problem, x, v, [1e-5])[0]
        monkeypatch.undo()
        v.destroy()
        x.destroy()

    def rel(d, ref):
        return np.sqrt(comm.allreduce(float(d @ d)) / comm.allreduce(float(ref @ ref)))

    part = np.array([rel((a - b) - (on - off), on - off) for a, b in zip(live, held, strict=True)])
    checks = {
        "converged": converged,
        "newton": within(newton),
        "in contact": counts[0] + counts[1] > 0,
        "dB t exact": part[1] < 1e-6,
        "dB t O(e^2)": part[0] > 30 * part[1] or part[0] < 1e-9,
        "exact": err[1].max() < 1e-8,
        "O(e^2)": np.all((err[0] > 30 * err[1]) | (err[0] < 1e-9)),
        "without dB t": without[1] > 5 * err[-1, 1],
    }
    assert everywhere(comm, all(checks.values())), (checks, part, err, without, counts, newton)


def carried_nodes(comm, problem, carried):
    """The owned nodes' carried translations (n, 2) and their coordinates (n, 2)."""
    n = problem.V.dofmap.index_map.size_local
    x = problem.V.tabulate_dof_coordinates()[:n, :2]
    return carried.reshape(-1, 2)[:n], x


@pytest.mark.parametrize("case", ["slide", "press", "held end"])
def test_a_turn_starts_from_the_bodies_the_program_carries(comm, case):
    """Where the program turns, and at a run's first step, the stepper's start translates each
    body whose Dirichlet dofs all change alike in a component by that change
    (``LoadStepper._carried``): at the slide's first step the block by its top's slide in x (its
    top's y is free under the pressure), the base (held) not at all; at the first step of the
    press by the top's displacement the block in y; with the block's end held in x beside its
    top's slide, the block's Dirichlet values do not change alike: nothing is carried."""
    press = 0.005 if case == "press" else None
    held = [Dirichlet("block_left", 0.0, 0)] if case == "held end" else []
    problem = problem_2d(comm, law_of("coulomb"), 1, press_down=press, more=held)
    with FrictionSolver(problem, linear="lu") as solver:
        stepper = LoadStepper(solver, 0.25, control=StepControl(dt_max=0.25))
        if case == "press":
            carried = stepper._carried(0.25)
        else:
            stepper.run(t_end=1.0)
            carried = stepper._carried(1.25)
    if case == "held end":
        assert everywhere(comm, carried is None), carried
        return
    assert carried is not None
    u, x = carried_nodes(comm, problem, carried)
    expected = np.array([0.125, 0.0]) if case == "slide" else np.array([0.0, -0.00125])
    block = np.all(np.isclose(u, expected, rtol=0, atol=1e-15), axis=1)
    still = np.all(u == 0.0, axis=1)
    checks = {
        "block or nothing": bool(np.all(block | still)),
        "inside the block": bool(np.all(block[x[:, 1] > 1e-9])),
        "inside the base": bool(np.all(still[x[:, 1] < -1e-9])),
        # the block's nodes, every one (P1: 4 x 3)
        "all the block": comm.allreduce(int(block.sum())) == 12,
    }
    assert everywhere(comm, all(checks.values())), (checks, u[~(block | still)])
