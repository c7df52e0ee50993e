"""Elastic supports (issue 16, item 2): a block held by springs against closed forms, the
springs' stiffness in the Jacobian (Newton takes one iteration on a linear step; finite
differences), the springs' force on the body, and the rigid-body mode of a block held only by
friction removed by weak springs, with the error they introduce. 1 and 2 ranks."""

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import CoulombLaw, Status
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    Spring,
    StepControl,
    StepFailure,
    Traction,
)
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning, SlideWarning
from tests.helpers import everywhere, jacobian_against_differences, prefix

MATERIALS = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
COULOMB = CoulombLaw(alpha_t=1e4, alpha_n=1e4, mu_c=0.3)


def block(comm, n=8):
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=n, cell_type="triangle"
    )
    return dom


def displacement_of(prob, body):
    """Owned displacement values (n, gdim) of the dofs of a body's cells."""
    V = prob.V
    cells = prob.domain.cell_tags.find(prob.tags[body])
    blocks = V.dofmap.list[cells].ravel()
    blocks = np.unique(blocks[blocks < V.dofmap.index_map.size_local])
    return prob.u.x.array.reshape(-1, prob.gdim)[blocks]


def test_a_block_pulled_off_its_base_and_held_by_springs_moves_by_force_over_stiffness():
    """Springs (k_x, k_y) on the block's top and a traction t on the same face, pulling the block
    off the base (the interface opens): the block translates by ``t_i / k_i = F_i / (k_i A)``
    everywhere, unstressed; the springs' end moved by ``u0`` adds ``u0``. The springs' force on
    the block is ``-F``; the base, clamped as a whole body (a cell group), carries nothing. Once
    the interface is open the problem is linear: moving the springs' end takes one Newton
    iteration (the first step starts from the closed interface and takes more)."""
    comm = MPI.COMM_WORLD
    k = np.array([150.0, 400.0])  # MPa/mm
    t = np.array([3.0, 5.0])  # MPa, up and to the right
    u0 = np.array([0.002, -0.001])
    program = LoadingProgram([0, 1, 2], {"pull": [0, 1, 1], "end": [0, 0, 1]})
    prob = InterfaceProblem(
        block(comm),
        COULOMB,
        MATERIALS,
        program,
        [Dirichlet("primary", (0.0, 0.0))],
        [*[Traction("top", t, amplitude="pull")], *[Spring("top", k, u0=u0, amplitude="end")]],
    )
    rows = []

    def on_step(rec):
        forces = prob.spring_forces(prob.u.x.array, program, rec.t)
        reactions = prob.reactions["primary"].copy()
        rows.append(
            (
                rec,
                displacement_of(prob, "secondary"),
                displacement_of(prob, "primary"),
                forces,
                reactions,
            )
        )

    with FrictionSolver(prob, prefix("spring")) as solver:
        LoadStepper(solver, 1.0, on_step=on_step).run()
    width = 1.0  # the block's top face: 1 mm wide, unit thickness (plane strain)
    F = t * width
    for (rec, us, um, forces, reactions), end in zip(rows, (0.0, 1.0), strict=True):
        expected = F / (k * width) + end * u0
        assert np.allclose(us, expected, rtol=1e-9, atol=1e-14), (us.min(0), us.max(0), expected)
        assert np.all(um == 0.0)  # every dof of the base is held
        assert rec.iterations == 1 or end == 0.0
        assert np.allclose(forces["top"], -F, rtol=1e-9)
        assert np.allclose(reactions, 0.0, atol=1e-9)
    s = interface_summary(prob)
    assert s["F_n"] == 0.0  # open


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm block"
)
def test_spring_stiffness_is_in_the_jacobian():
    """A pressed block held sideways by springs, Coulomb friction sticking: every step after the
    first is linear (closed, elastic), and full Newton takes one iteration; the Jacobian at a
    perturbed state equals central differences of the residual."""
    comm = MPI.COMM_WORLD
    springs = [Spring("secondary_left", (2.0, 0.0)), Spring("secondary_right", (2.0, 0.0))]
    _, prob = sheared_block(comm, 10.0, springs, shear=(0.0, 0.0, 1.0, -1.0))
    with FrictionSolver(prob, prefix("sjac")) as solver:
        stepper = LoadStepper(solver, 0.5)
        stepper.run()
        its = [r.iterations for r in stepper.records]
        assert its[2:] == [1] * (len(its) - 2), its
        assert stepper.records[-1].counts.get(Status.ELASTIC.name, 0) > 0
        x = solver.x.copy()
        rng = np.random.default_rng(comm.rank)
        x.array_w[:] += 1e-6 * rng.standard_normal(x.array_r.size)
        J = prob.create_matrix()
        prob.jacobian(x, J)
        err, nrm = jacobian_against_differences(prob, x, J, rng, 1e-8)
        assert err <= 1e-6 * nrm, (err, nrm)


def sheared_block(comm, q, springs=(), shear=(0.0, 0.0, 1.0)):
    """The block pressed by 100 MPa (t = 0 -> 1), then sheared by ``q`` MPa on its left flank
    times ``shear`` (the channel at t = 0, 1, 2, ...), with ``springs``: (program, problem)."""
    times = list(range(len(shear)))
    press = [0.0] + [1.0] * (len(shear) - 1)
    program = LoadingProgram(times, {"press": press, "shear": list(shear)})
    return program, InterfaceProblem(
        block(comm),
        COULOMB,
        MATERIALS,
        program,
        [Dirichlet("bottom", (0.0, 0.0))],
        [
            *[
                Pressure("top", 100.0, amplitude="press"),
                Traction("secondary_left", (q, 0.0), "shear"),
            ],
            *springs,
        ],
    )


@pytest.mark.leaves_validity(
    PenetrationWarning,
    SlideWarning,
    reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm block, which slides away",
)
def test_a_sliding_block_has_an_equilibrium_only_with_springs():
    """A block pressed with P = 100 N and pushed sideways with Q = 35 N > mu P = 30 N (Coulomb):
    without support it has no equilibrium (the step fails); with springs on its sides (2 N/mm
    each, spread over the 0.5 mm high sides) it slides until they carry ``Q - mu P`` = 5 N,
    exactly, and the interface carries ``mu P``."""
    comm = MPI.COMM_WORLD
    _, prob = sheared_block(comm, 70.0)
    with FrictionSolver(prob, prefix("nospring")) as solver:
        with pytest.raises(StepFailure):
            LoadStepper(solver, 1.0, control=StepControl(max_cuts=2)).run()
    k = 2.0 / 0.5
    program, prob = sheared_block(
        comm, 70.0, [Spring("secondary_left", (k, 0.0)), Spring("secondary_right", (k, 0.0))]
    )
    with FrictionSolver(prob, prefix("withspring")) as solver:
        LoadStepper(solver, 1.0).run()
    s = interface_summary(prob)
    forces = prob.spring_forces(prob.u.x.array, program, 2.0)
    assert forces["secondary_left"][0] + forces["secondary_right"][0] == pytest.approx(
        -5.0, rel=1e-8
    )
    assert s["F_t1"] == pytest.approx(30.0, rel=1e-8)
    assert s["F_n"] == pytest.approx(100.0, rel=1e-8)
    ux = displacement_of(prob, "secondary")[:, 0]
    assert everywhere(comm, ux.size == 0 or ux.min() > 0.5)  # slid by about 5 N / 8 N/mm


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm block"
)
@pytest.mark.parametrize("k", [1e-3, 1e-2])
def test_weak_springs_take_a_share_of_the_load_proportional_to_their_stiffness(k):
    """Weak springs (``k`` MPa/mm on the block's sides) added so that a block held by friction
    has an equilibrium if it slides take a share of the load while it sticks: the shear the
    interface sees is ``Q`` minus the springs' force ``k A u_x`` per side, an error proportional
    to ``k`` (measured: 1.9e-7 Q at k = 1e-3 MPa/mm, 1.9e-6 Q at 1e-2, with the block's
    ``u_x`` about 1e-3 mm); Q = 10 N is below mu P = 30 N."""
    comm = MPI.COMM_WORLD
    q = 20.0
    program, prob = sheared_block(
        comm, q, [Spring("secondary_left", (k, k)), Spring("secondary_right", (k, k))]
    )
    with FrictionSolver(prob, prefix("weak")) as solver:
        LoadStepper(solver, 1.0).run()
    s = interface_summary(prob)
    forces = prob.spring_forces(prob.u.x.array, program, 2.0)
    carried = abs(forces["secondary_left"][0] + forces["secondary_right"][0])
    Q = q * 0.5
    assert 1e-5 * k < carried / Q < 1e-3 * k
    assert abs(s["F_t1"] - Q) == pytest.approx(carried, rel=1e-3, abs=1e-12 * Q)
