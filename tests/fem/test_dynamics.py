"""Inertia (fem/dynamics.py): generalised-alpha steps checked against closed forms.

* a free fall under a constant body force is ``u = g t^2 / 2`` exactly (Newmark's relations are
  exact for a constant acceleration, and the initial acceleration is consistent), in every mode,
  with both kinematics, for average acceleration and a dissipative ``rho_inf``;
* average acceleration conserves a linear system's energy (kinetic + strain, the interface's
  penalty included) to round-off over 1,000 steps, and its accounts balance to Newton's
  tolerance; ``rho_inf < 1`` dissipates, and the accounts still balance;
* a step load on a strip (1-D-like bar): the wave reaches the free end at ``L / c`` and comes
  back to the loaded end at ``2 L / c``, within 1 %, ``c = sqrt(E / rho)`` (``nu = 0``) or the
  P-wave speed ``sqrt((lambda + 2 mu) / rho)`` (sides on rollers, plane strain);
* an impact of two free bodies: momentum conserved exactly (no external force), energy bounded,
  no NaN; a stiff interface's steps are cut and recover;
* a checkpoint holds the velocity and acceleration: a restarted run continues as the
  uninterrupted one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    ProblemSettings,
    StepControl,
    Traction,
)
from subfric_dolfinx.fem.dynamics import ENERGY_COLUMNS, Dynamics, coefficients
from subfric_dolfinx.loading import LoadingProgram
from tests.contact_meshes import tagged_blocks, tagged_boxes

E, RHO = 1000.0, 1e-6  # MPa, tonne/mm^3: c = sqrt(E / rho) = 31623 mm/s
GLUED = CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=1e3)  # sticks: no friction dissipation
# a soft interface of the clamped stack, pre-compressed by OVERLAP: its preload (0.1 MPa) keeps
# it closed, the bodies (E / h = 1000 MPa/mm) take little of the overlap
SOFT, OVERLAP = CoulombLaw(alpha_t=10.0, alpha_n=10.0, mu_c=1e3), 1e-2


def program(t_end: float) -> LoadingProgram:
    return LoadingProgram([0.0, t_end], {})


def run(problem: InterfaceProblem, dt: float, t_end: float | None = None, **kw):
    with FrictionSolver(problem, linear="lu") as solver:
        stepper = LoadStepper(solver, dt, control=StepControl(dt_max=dt), **kw)
        return stepper.run(t_end)


def owned_coordinates(problem: InterfaceProblem) -> np.ndarray:
    """Coordinates of the owned dofs, (n_owned, 3), unrolled as the owned values."""
    bs = problem.V.dofmap.bs
    n = problem.layout.n_owned // bs
    x = problem.V.tabulate_dof_coordinates()[:n]
    return np.repeat(x, bs, axis=0)


# -- rigid-body motion -------------------------------------------------------------------------
CASES = [
    ("plane_strain", "small_sliding", 1.0),
    ("plane_strain", "finite_sliding", 1.0),
    ("plane_strain", "small_sliding", 0.5),
    ("axisymmetric", "small_sliding", 1.0),
    ("3d", "small_sliding", 0.8),
]


@pytest.mark.parametrize(("mode", "kind", "rho_inf"), CASES)
def test_a_free_fall_is_exact(mode, kind, rho_inf):
    """Two bodies joined by an interface, no support, a constant body force ``rho g``: every dof
    follows ``u = g t^2 / 2`` (to 1e-9 of it), the velocity ``g t``; nothing strains, the
    interface carries nothing. Newmark's relations are exact for a constant acceleration, and
    the first step starts from the consistent ``a_0 = M^-1 f = g``."""
    comm = MPI.COMM_WORLD
    if mode == "3d":
        dom = tagged_boxes(comm, n_base=(2, 2, 1), n_block=(2, 2, 1))
        g = np.array([300.0, -200.0, -9810.0])
    else:
        dom = tagged_blocks(comm, n_base=(2, 2), n_block=(2, 2), split_x=0.5)
        g = np.array([0.0, -9810.0]) if mode == "axisymmetric" else np.array([300.0, -9810.0])
    dt, n = 1e-3, 8
    dyn = Dynamics({"base": 2 * RHO, "block": RHO}, rho_inf=rho_inf, gravity=tuple(g))
    problem = InterfaceProblem(
        dom,
        GLUED,
        {"base": Material(E, 0.3), "block": Material(E, 0.2)},
        program(n * dt),
        interfaces=[Interface("contact", "base", "block", kinematics=kind)],
        settings=ProblemSettings(mode=mode, dynamics=dyn),
    )
    with problem:
        records = run(problem, dt)
        assert len(records) == n
        t = records[-1].t
        gdim = problem.gdim
        u = problem.u.x.array[: problem.layout.n_owned].reshape(-1, gdim)
        exact = 0.5 * g * t**2
        assert np.allclose(u, exact, rtol=0, atol=1e-9 * np.abs(exact).max())
        v = problem.dynamics.velocity.reshape(-1, gdim)
        assert np.allclose(v, g * t, rtol=0, atol=1e-9 * np.abs(g * t).max())
        a = problem.dynamics.acceleration.reshape(-1, gdim)
        assert np.allclose(a, g, rtol=0, atol=1e-8 * np.abs(g).max())
        # the energy: kinetic = work of gravity, nothing strained
        en = records[-1].energy
        assert en["E_kinetic"] == pytest.approx(en["W_external"], rel=1e-9)
        assert abs(en["E_strain"]) <= 1e-9 * en["E_kinetic"]


# -- energy ------------------------------------------------------------------------------------
def clamped_stack(t_end: float, dynamics: bool = True, **kw) -> InterfaceProblem:
    """A block on a base, clamped at the base's bottom and the block's top, the interface
    pre-compressed (an initial overlap) and sticking, the block given a velocity: a linear
    system in free vibration (the contact stays closed, nothing slides). ``kw``: the
    :class:`Dynamics` settings beyond the densities and the velocity."""
    dom = tagged_blocks(MPI.COMM_WORLD, n_base=(2, 2), n_block=(2, 2), split_x=0.5)
    dyn = Dynamics({"base": RHO, "block": RHO}, initial_velocity={"block": (20.0, -30.0)}, **kw)
    return InterfaceProblem(
        dom,
        SOFT,
        {"base": Material(E, 0.3), "block": Material(E, 0.3)},
        program(t_end),
        [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", (0.0, 0.0))],
        interfaces=[
            Interface("contact", "base", "block", initial_gap=-OVERLAP, intended_compliance=True)
        ],
        settings=ProblemSettings(dynamics=dyn if dynamics else None),
    )


def test_average_acceleration_conserves_energy():
    """1,000 steps of average acceleration (rho_inf = 1) on a linear system: kinetic + strain
    energy stays its initial value to 1e-8 (relative), the numerical dissipation is zero to
    1e-8, no external work, no friction; the accounts balance to Newton's tolerance. (About 40
    periods of the block's first mode: its energy moves between kinetic and strain.)"""
    dt, n = 2e-6, 1000
    with clamped_stack(n * dt) as problem:
        records = run(problem, dt)
        assert len(records) == n
        e0 = problem.dynamics.e0
        total = np.array([r.energy["E_kinetic"] + r.energy["E_strain"] for r in records])
        kinetic = np.array([r.energy["E_kinetic"] for r in records])
        assert kinetic.max() - kinetic.min() > 0.3 * e0  # the energy does move
        assert np.abs(total - e0).max() <= 1e-8 * e0
        for key in ("D_numerical", "W_external", "D_friction", "D_damping", "E_balance"):
            assert max(abs(r.energy[key]) for r in records) <= 1e-8 * e0, key


def test_numerical_dissipation_is_accounted():
    """rho_inf = 0.5 dissipates: the total energy decreases and D_numerical grows by as much
    (not step by step: generalised-alpha dissipates a modified energy, not this one,
    monotonically); the balance holds to Newton's tolerance."""
    dt, n = 2e-6, 200
    with clamped_stack(n * dt, rho_inf=0.5) as problem:
        records = run(problem, dt)
        e0 = problem.dynamics.e0
        last = records[-1].energy
        assert last["D_numerical"] > 1e-4 * e0
        lost = e0 - (last["E_kinetic"] + last["E_strain"])
        assert lost == pytest.approx(last["D_numerical"], rel=1e-6)
        assert max(abs(r.energy["E_balance"]) for r in records) <= 1e-8 * e0


def test_rayleigh_damping_is_accounted():
    """Rayleigh damping (average acceleration, no numerical dissipation): the energy lost is
    D_damping's, to Newton's tolerance."""
    dt, n = 2e-6, 200
    with clamped_stack(n * dt, alpha_m=2e3, alpha_k=1e-7) as problem:
        records = run(problem, dt)
        e0 = problem.dynamics.e0
        last = records[-1].energy
        lost = e0 - (last["E_kinetic"] + last["E_strain"])
        assert last["D_damping"] > 1e-3 * e0
        assert lost == pytest.approx(last["D_damping"], rel=1e-7)
        assert abs(last["D_numerical"]) <= 1e-8 * e0


def test_generalised_alpha_coefficients():
    """Chung and Hulbert's parameters: rho_inf = 1 is average acceleration; rho_inf = 0
    annihilates at infinite frequency (am = -1, af = 0, beta = 1, gamma = 3/2)."""
    assert coefficients(1.0) == pytest.approx((0.5, 0.5, 0.25, 0.5))
    assert coefficients(0.0) == pytest.approx((-1.0, 0.0, 1.0, 1.5))


# -- waves -------------------------------------------------------------------------------------
def line(t: np.ndarray, u: np.ndarray, t0: float, t1: float) -> tuple[float, float]:
    """Slope and intercept of the least-squares line through ``u(t)`` on ``[t0, t1]``."""
    m = (t >= t0) & (t <= t1)
    slope, intercept = np.polyfit(t[m], u[m], 1)
    return float(slope), float(intercept)


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_a_step_wave_in_a_bar(nu):
    """A strip of length L (two layers along it, their interface open: two bars side by side,
    plane strain, one element across), a step traction sigma on its left end at t = 0, its right
    end free. ``nu = 0``: ``c = sqrt(E / rho)`` (the bar's speed, also the P-wave speed);
    ``nu = 0.3`` with every dof on rollers (uniaxial strain): ``c = sqrt((lambda + 2 mu) /
    rho)``. In the 1-D solution the free end stays still until ``L / c`` and then moves at
    ``2 v0`` (``v0 = sigma / (rho c)``); the loaded end moves at ``v0`` until the reflection
    comes back at ``2 L / c``, then at ``3 v0``. Each time is where the lines fitted to the
    end's displacement before and after it cross (the front, smeared over a few elements by the
    mesh's dispersion, leaves these lines unchanged: momentum): both within 1 % of ``L / c``
    and ``2 L / c``; behind the front the velocity is ``v0`` (2 %)."""
    comm = MPI.COMM_WORLD
    L, h, n = 40.0, 1.0, 80
    modulus = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))  # lambda + 2 mu (E when nu = 0)
    c = math.sqrt(modulus / RHO)
    sigma = 1.0
    v0 = sigma / (RHO * c)
    T = L / c
    dt = 0.5 * (L / n) / c
    dom = tagged_blocks(
        comm,
        base=(0.0, L, -h, 0.0),
        block=(0.0, L, 0.0, h),
        n_base=(n, 1),
        n_block=(n, 1),
        cell="quadrilateral",
    )
    bcs = []
    if nu:  # every dof on rollers: uniaxial strain
        bcs = [Dirichlet("base", 0.0, component=1), Dirichlet("block", 0.0, component=1)]
    loads = [Traction("block_left", (sigma, 0.0)), Traction("base_left", (sigma, 0.0))]
    rows: list[tuple[float, float, float, float]] = []
    with InterfaceProblem(
        dom,
        GLUED,
        {"base": Material(E, nu), "block": Material(E, nu)},
        program(2.6 * T),
        bcs,
        loads,
        interfaces=[Interface("contact", "base", "block", initial_gap=0.01)],
        settings=ProblemSettings(dynamics=Dynamics({"base": RHO, "block": RHO})),
    ) as problem:
        x = owned_coordinates(problem)
        comp = np.arange(x.shape[0]) % 2 == 0
        at_left = comp & np.isclose(x[:, 0], 0.0)
        at_right = comp & np.isclose(x[:, 0], L)
        n_owned = problem.layout.n_owned

        def mean(values: np.ndarray, mask: np.ndarray) -> float:
            s = comm.allreduce(float(values[mask].sum()))
            return s / comm.allreduce(int(mask.sum()))

        def on_step(rec) -> None:
            u = problem.u.x.array[:n_owned]
            v = problem.dynamics.velocity
            rows.append((rec.t, mean(u, at_left), mean(u, at_right), mean(v, at_left)))

        run(problem, dt, on_step=on_step)
    t, left, right, v_left = (np.array(col) for col in zip(*rows, strict=True))
    slope, intercept = line(t, right, 1.3 * T, 1.9 * T)
    arrival = -intercept / slope
    a0, b0 = line(t, left, 0.4 * T, 1.8 * T)
    a1, b1 = line(t, left, 2.2 * T, 2.6 * T)
    back = (b1 - b0) / (a0 - a1)
    assert arrival == pytest.approx(T, rel=1e-2)
    assert back == pytest.approx(2 * T, rel=1e-2)
    assert slope / v0 == pytest.approx(2.0, rel=2e-2)
    assert a0 / v0 == pytest.approx(1.0, rel=2e-2) and a1 / v0 == pytest.approx(3.0, rel=2e-2)
    plateau = (t > 0.5 * T) & (t < 0.9 * T)
    assert np.median(v_left[plateau]) / v0 == pytest.approx(1.0, rel=2e-2)


# -- impact ------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["small_sliding", "finite_sliding"])
def test_an_impact_conserves_momentum(kind):
    """Two free bodies, the block moving down onto the base across an initial gap: they meet,
    bounce and part. No external force: the total momentum ``1 . M v`` stays its initial value
    (to 1e-9); no NaN; the energy stays bounded (at most 10 % above the initial: the contact's
    closing within a step is not integrated exactly, D_numerical says by how much) and the
    accounts balance."""
    comm = MPI.COMM_WORLD
    dom = tagged_blocks(comm, n_base=(2, 2), n_block=(2, 2), split_x=0.5)
    v0 = np.array([5.0, -200.0])
    law = CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.3)
    dyn = Dynamics({"base": RHO, "block": RHO}, rho_inf=0.9, initial_velocity={"block": v0})
    dt, t_end = 2e-6, 4e-4
    with InterfaceProblem(
        dom,
        law,
        {"base": Material(E, 0.3), "block": Material(E, 0.3)},
        program(t_end),
        interfaces=[Interface("contact", "base", "block", kinematics=kind, initial_gap=2e-3)],
        settings=ProblemSettings(dynamics=dyn),
    ) as problem:
        M = problem.dynamics.M
        ones = problem.create_vector()
        w = problem.create_vector()

        def momentum() -> np.ndarray:
            w.array_w[:] = problem.dynamics.velocity
            out = ones.duplicate()
            M.mult(w, out)
            p = out.array_r.reshape(-1, 2).sum(axis=0)
            out.destroy()
            return np.array(comm.allreduce(p))

        p0 = momentum()
        records = run(problem, dt)
        p1 = momentum()
        ones.destroy()
        w.destroy()
        e0 = problem.dynamics.e0
        energies = np.array(
            [[r.energy[k] for k in ("E_kinetic", "E_strain", "E_balance")] for r in records]
        )
        assert np.all(np.isfinite(energies))
        assert np.abs(p1 - p0).max() <= 1e-9 * np.abs(p0).max()
        assert (energies[:, 0] + energies[:, 1]).max() <= 1.1 * e0
        assert np.abs(energies[:, 2]).max() <= 1e-8 * e0
        touched = max(r.energy["E_strain"] for r in records)
        assert touched > 0.05 * e0  # they did meet


# -- checkpoints -------------------------------------------------------------------------------
def test_a_restart_continues_the_run(shared_tmp):
    """A checkpoint written halfway holds the velocity, the acceleration and the step's start
    forces: a run restarted from it ends where the uninterrupted run ends (displacement,
    velocity and the energy accounts to 1e-9); a quasi-static problem refuses it."""
    from subfric_dolfinx.io import CheckpointError, restore_checkpoint, write_checkpoint

    comm = MPI.COMM_WORLD
    dt, n = 2e-6, 20
    path = shared_tmp / "dyn.h5"
    with clamped_stack(n * dt, rho_inf=0.8) as problem:
        with FrictionSolver(problem, linear="lu") as solver:
            stepper = LoadStepper(solver, dt, control=StepControl(dt_max=dt))

            def on_step(rec) -> None:
                if rec.step == n // 2:
                    rows = [{"t": r.t} for r in stepper.records]
                    write_checkpoint(path, problem, stepper, rows)

            stepper.on_step = on_step
            records = stepper.run()
        u_ref = problem.u.x.array[: problem.layout.n_owned].copy()
        v_ref = problem.dynamics.velocity.copy()
        e_ref = records[-1].energy
    with clamped_stack(n * dt, rho_inf=0.8) as problem:
        with FrictionSolver(problem, linear="lu") as solver:
            stepper = LoadStepper(solver, dt, control=StepControl(dt_max=dt))
            restore_checkpoint(path, problem, stepper)
            assert stepper.step == n // 2
            records = stepper.run()
        u = problem.u.x.array[: problem.layout.n_owned]
        scale = comm.allreduce(float(np.abs(u_ref).max(initial=0.0)), op=MPI.MAX)
        vscale = comm.allreduce(float(np.abs(v_ref).max(initial=0.0)), op=MPI.MAX)
        assert np.abs(u - u_ref).max(initial=0.0) <= 1e-9 * scale
        assert np.abs(problem.dynamics.velocity - v_ref).max(initial=0.0) <= 1e-9 * vscale
        for key, value in e_ref.items():
            assert records[-1].energy[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    # a quasi-static problem does not take a dynamic run's checkpoint
    with clamped_stack(n * dt, dynamics=False) as static:
        with FrictionSolver(static, linear="lu") as solver:
            with pytest.raises(CheckpointError, match="dynamic run"):
                restore_checkpoint(path, static, LoadStepper(solver, dt))


# -- stability (issue 38 item 6) -----------------------------------------------------------------
def test_a_stiff_impact_cuts_its_steps_and_recovers():
    """A block thrown onto a base held at its bottom, a stiff contact (alpha_n = 1e8 MPa/mm,
    500 times the bodies' E / h), the interfaces' forces at the steps' ends: steps are cut where
    the contact closes and the run recovers to its end; no NaN; the energy never exceeds the
    initial one (no external work: the support is fixed; to 1e-9) and the accounts balance.
    (The mixed form gains energy here: D_numerical < 0, the note's numbers.)"""
    comm = MPI.COMM_WORLD
    dom = tagged_blocks(comm, n_base=(2, 2), n_block=(2, 2), split_x=0.5)
    law = CoulombLaw(alpha_t=1e8, alpha_n=1e8, mu_c=0.3)
    dyn = Dynamics(
        {"base": RHO, "block": RHO},
        rho_inf=0.8,
        initial_velocity={"block": (5.0, -200.0)},
        interface_forces="end",
    )
    dt, t_end = 1e-5, 4e-4
    with InterfaceProblem(
        dom,
        law,
        {"base": Material(E, 0.3), "block": Material(E, 0.3)},
        program(t_end),
        [Dirichlet("bottom", (0.0, 0.0))],
        interfaces=[
            Interface("contact", "base", "block", initial_gap=2e-3, intended_compliance=True)
        ],
        settings=ProblemSettings(dynamics=dyn),
    ) as problem:
        records = run(problem, dt, retry_options=None)
        e0 = problem.dynamics.e0
    assert records[-1].t == pytest.approx(t_end)
    assert sum(r.cuts for r in records) > 0
    energy = np.array([[r.energy[k] for k in ENERGY_COLUMNS] for r in records])
    assert np.all(np.isfinite(energy))
    total = energy[:, 0] + energy[:, 1]
    assert total.max() <= e0 * (1 + 1e-9)
    assert np.abs(energy[:, -1]).max() <= 1e-8 * e0
    assert max(r.energy["E_strain"] for r in records) > 0.05 * e0  # they did meet


def test_grazing_layers_stay_bounded():
    """Two layers of a bar touching along it (gap 0, stiff contact), a step load on their end:
    the contact's points open and close as the waves pass. With the interfaces' forces at the
    steps' ends, average acceleration stays bounded: the energy never exceeds the external work
    by more than 1 % of it, and the accounts balance. (With the mixed form it grows without
    bound here: the note's numbers.)"""
    comm = MPI.COMM_WORLD
    L, h, n = 20.0, 1.0, 40
    c = math.sqrt(E / RHO)
    dom = tagged_blocks(
        comm, base=(0.0, L, -h, 0.0), block=(0.0, L, 0.0, h), n_base=(n, 1), n_block=(n, 1)
    )
    loads = [Traction("block_left", (1.0, 0.0)), Traction("base_left", (1.0, 0.0))]
    dyn = Dynamics({"base": RHO, "block": RHO}, interface_forces="end")
    with InterfaceProblem(
        dom,
        GLUED,
        {"base": Material(E, 0.0), "block": Material(E, 0.0)},
        program(2.5 * L / c),
        [],
        loads,
        interfaces=[Interface("contact", "base", "block")],
        settings=ProblemSettings(dynamics=dyn),
    ) as problem:
        records = run(problem, 0.5 * (L / n) / c)
        e0 = problem.dynamics.e0
    energy = np.array([[r.energy[k] for k in ENERGY_COLUMNS] for r in records])
    assert np.all(np.isfinite(energy))
    work = energy[:, 2]
    assert work.max() > 0
    gained = energy[:, 0] + energy[:, 1] - e0 - work
    assert gained.max() <= 1e-2 * work.max()
    assert np.abs(energy[:, -1]).max() <= 1e-8 * work.max()


# -- FE against the spring-slider -----------------------------------------------------------------
# one rank: the costliest test of the file; the 2-rank leg checks the same integrator on the cases
# above (closed forms on 2 ranks)
@pytest.mark.serial
def test_a_block_pulled_through_a_spring_slips_as_the_slider():
    """A stiff block (E = 1e8 MPa, 10 mm wide, 0.1 mm high: its tilting moment changes f_n by
    0.3 %) of mass 1 tonne/mm^2 per unit interface area on a fixed base, the stick-slip law of
    the material-point checks, pressed by 300 MPa (the initial overlap f_n / alpha_n: the normal
    direction starts in equilibrium) and pulled at V = 0.3 mm/s through a spring of 50 MPa/mm per
    unit interface area on its left end (Spring: 50 * 10 / 0.1 MPa/mm on the 0.1 mm end). Its
    limit cycle (the last full cycle of 12 s from a rested contact, between velocity peaks)
    against the spring-slider's rate equations integrated by solve_ivp
    (tests/driver/slider_reference.py, independent of the package): period and stress drop
    within 2 %. Average acceleration, the mixed interface term, dt = T_spring / 400, the
    slider test's step. Through the slip events: no NaN, the friction's dissipation never
    decreases, the energy accounts balance (1e-4 of the external work: Newton's relative
    tolerance, 1e-9 of each step's first residual, summed over 5,455 steps)."""
    from subfric_dolfinx.constitutive import SubloadingLaw
    from subfric_dolfinx.fem import Pressure, Spring
    from tests.driver import slider_reference as ref

    comm = MPI.COMM_WORLD
    V, t_end, k, FN, MASS = 0.3, 12.0, 50.0, 300.0, 1.0
    w, h = 10.0, 0.1
    law = SubloadingLaw(**ref.STICK_SLIP_LAW)
    dom = tagged_blocks(
        comm,
        base=(0.0, w, -h, 0.0),
        block=(0.0, w, 0.0, h),
        n_base=(4, 1),
        n_block=(4, 1),
        cell="quadrilateral",
    )
    spring = Spring("block_left", stiffness=(k * w / h, 0.0), u0=(1.0, 0.0), amplitude="drive")
    rows: list[tuple[float, float, float]] = []
    energies: list[list[float]] = []
    with InterfaceProblem(
        dom,
        law,
        {"base": Material(1e8, 0.0), "block": Material(1e8, 0.0)},
        LoadingProgram([0.0, t_end], {"drive": [0.0, V * t_end]}),
        [Dirichlet("base", (0.0, 0.0))],
        [Pressure("top", FN), spring],
        interfaces=[
            Interface(
                "contact",
                "base",
                "block",
                initial_gap=-FN / law.alpha_n,
                intended_compliance=True,  # the slider's alpha_n, its normal compliance
            )
        ],
        settings=ProblemSettings(dynamics=Dynamics({"base": 1.0, "block": MASS / h})),
    ) as problem:
        x = owned_coordinates(problem)
        block = (np.arange(x.shape[0]) % 2 == 0) & (x[:, 1] > 1e-9)
        pts = problem.interfaces["contact"].law_points
        wts = np.asarray(pts.weights, dtype=float).reshape(-1)

        def on_step(rec) -> None:
            v = problem.dynamics.velocity
            vs = comm.allreduce(float(v[block].sum())) / comm.allreduce(int(block.sum()))
            last = pts.last.traction if pts.last is not None else np.zeros((0, 2))
            tr = np.asarray(last, dtype=float).reshape(wts.size, 2)
            ft = comm.allreduce(float(wts @ tr[:, 0])) / comm.allreduce(float(wts.sum()))
            rows.append((rec.t, vs, abs(ft)))
            energies.append([rec.energy[key] for key in ENERGY_COLUMNS])

        run(problem, 2 * np.pi * np.sqrt(MASS / k) / 400, on_step=on_step)
    t, v, f = (np.array(col) for col in zip(*rows, strict=True))

    def cycle(t: np.ndarray, v: np.ndarray, f: np.ndarray) -> tuple[float, float]:
        i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] > 2 * V)) + 1
        a, b = i[-2], i[-1]
        return float(t[b] - t[a]), float(f[a : b + 1].max() - f[a : b + 1].min())

    names = ("alpha_t", "mu_s", "mu_k", "kappa", "xi", "u_tilde", "c_n")
    p = ref.Params(**{n: getattr(law, n) for n in names}, f_n=FN, mass=MASS, velocity=V)
    o = ref.integrate_ode(p, k, t_end, max_step=0.01)
    assert o.status == 0
    period_ref, drop_ref = cycle(o.t, o.y[1], law.alpha_t * (o.y[0] - o.y[2]))
    period, drop = cycle(t, v, f)
    assert period == pytest.approx(period_ref, rel=0.02)
    assert drop == pytest.approx(drop_ref, rel=0.02)
    # the slip events (item 6): no NaN, the friction dissipates, the accounts balance
    e = np.array(energies)
    assert np.all(np.isfinite(e))
    friction, balance = e[:, ENERGY_COLUMNS.index("D_friction")], e[:, -1]
    assert np.diff(friction).min() >= -1e-9 * friction[-1] and friction[-1] > 0
    assert np.abs(balance).max() <= 1e-4 * np.abs(e[:, 2]).max()
