"""Steps where nothing changes converge (issue 23, item 5). 1 and 2 ranks.

Newton's test (:mod:`subfric_dolfinx.fem.convergence`) once failed them: bodies pulled apart by
prescribed displacements and held have no force at all, so the round-off floor of the residual
was switched off (its guard against runaways compares it with the forces) and a hold step, whose
residual is at that floor from its first evaluation, could meet no test: PETSc's step-length test
then ended it (``CONVERGED_SNORM_RELATIVE``) far above ``rtol |F_0|`` and the solver counted it as
a failure, 11 times, down to a ``StepFailure``. A zero update at a residual at the floor is now a
converged step, and a state without forces keeps the floor test. The divergence test no longer
stops the overshoot of a step that closes a gap (Code_Aster's SSNV503 skate pushed onto its
frame across a 2 mm gap, both loads ramped together).
"""

import math

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx import meshing
from subfric_dolfinx.compat import SNES_DIVERGED_NAN
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
)
from subfric_dolfinx.fem.convergence import EPS, SNORM_SLACK, ScaledConvergence
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning, SlideWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import prefix

R = PETSc.SNES.ConvergedReason
MATERIALS = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}


# --------------------------------------------------------------------------------------------
# The test's decisions, on given norms


class _Snes:
    """What the test reads from a SNES: tolerances and the divergence tolerance."""

    def __init__(self, rtol=1e-9, atol=0.0, stol=1e-12, divtol=1e4):
        self.tol = (rtol, atol, stol, 30)
        self.divtol = divtol

    def getTolerances(self):
        return self.tol

    def getDivergenceTolerance(self):
        return self.divtol

    def getSolution(self):
        return None


class _Given(ScaledConvergence):
    """The test with ``S``, the forces and their being nil given instead of computed."""

    def __init__(self, scale, forces, force_free=False):
        self.floor_factor, self.stall_factor = 1.0, 100.0
        self._given = (scale, forces, force_free)
        self.start()

    def compute_scale(self, x):
        self.scale, self.forces, self.force_free = self._given
        return self.scale


def decide(test, steps, **snes):
    """Reasons at iterations 0, 1, ... for (ynorm / xnorm, |F|) per iteration."""
    s = _Snes(**snes)
    return [test(s, it, (1.0, y, f)) for it, (y, f) in enumerate(steps)]


@pytest.mark.numpy_only
def test_a_zero_update_at_the_floor_converges():
    """S = 1e16 (eps S = 2.2), forces 1e12: |F| from 50 to 10 times eps S (halved: not a
    stall) with an update of zero: converged by the step-length test, reported converged
    ("stol"). At 1e3 eps S, far above the floor and SNORM_SLACK rtol |F_0|: stuck, not
    converged (DIVERGED_LOCAL_MIN)."""
    e = EPS * 1e16
    t = _Given(1e16, 1e12)
    assert decide(t, [(0, 50 * e), (0, 10 * e)]) == [R.ITERATING, R.CONVERGED_SNORM_RELATIVE]
    assert t.by == "stol"
    t = _Given(1e16, 1e12)
    f0 = 1e6 * e
    assert 1e3 * e > SNORM_SLACK * 1e-9 * f0
    assert decide(t, [(0, f0), (0, 1e3 * e)]) == [R.ITERATING, R.DIVERGED_LOCAL_MIN]
    assert t.by is None
    # near the tolerances, as PETSc's own test with the solver's slack
    t = _Given(1e16, 1e12)
    near = 0.5 * SNORM_SLACK * 1e-9 * f0
    assert decide(t, [(0, f0), (0, near)])[-1] == R.CONVERGED_SNORM_RELATIVE


@pytest.mark.numpy_only
def test_a_state_without_forces_keeps_the_floor():
    """No load, no interface traction, reactions at round-off: the floor test applies at the
    first evaluation (0 iterations). The same residual with forces that make eps S more than
    1e-6 of them (a runaway) is not accepted."""
    e = EPS * 1e3
    t = _Given(1e3, 1e-14, force_free=True)
    assert decide(t, [(0, 0.5 * e)]) == [R.CONVERGED_FNORM_ABS] and t.by == "floor"
    t = _Given(1e3, 1e-14, force_free=False)
    assert decide(t, [(0, 0.5 * e)]) == [R.ITERATING]
    # an extrapolated first iterate (LoadStepper's predictor) is not accepted at iteration 0
    # (Krylov and LU strategies stay in step), but at the floor from iteration 1 on
    t = _Given(1e3, 1e-14, force_free=True)
    t.reference = 0.0  # extrapolated (the start's own residual: not evaluated here)
    assert decide(t, [(0, 0.5 * e), (1, 0.5 * e)]) == [R.ITERATING, R.CONVERGED_FNORM_ABS]


@pytest.mark.numpy_only
def test_the_overshoot_of_a_gap_closing_is_not_a_divergence():
    """The residuals of the SSNV503 skate's first step across its gap (221 -> 8.3e9 -> 4.9e8 ->
    142 -> 2.7e3 -> 140 -> 2.2): beyond 1e4 |F_0| twice but decreasing: Newton goes on. A
    residual that grows beyond 1e4 |F_0| at two iterations in a row diverges."""
    t = _Given(1e3, 1e3)
    steps = [(1, f) for f in (221.0, 8.3e9, 4.9e8, 142.0, 2.7e3, 140.0, 2.2)]
    assert set(decide(t, steps)) == {R.ITERATING}
    t = _Given(1e3, 1e3)
    assert decide(t, [(1, 1.0), (1, 1e6), (1, 1e7)]) == [R.ITERATING, R.ITERATING, R.DIVERGED_DTOL]
    t = _Given(1e3, 1e3)
    assert decide(t, [(1, 1.0), (1, math.nan)])[-1] == SNES_DIVERGED_NAN


# --------------------------------------------------------------------------------------------
# Runs


def block(comm, n=8):
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=n, cell_type="triangle"
    )
    return dom


def run(prob, dt, **options):
    """Run the program with the default options; the records and every step's solution."""
    xs = []
    with FrictionSolver(prob, prefix("steady"), options) as solver:
        st = LoadStepper(solver, dt, on_step=lambda rec: xs.append(solver.x.array_r.copy()))
        st.run()
    return st.records, xs


def spread(comm, a, b):
    """max |a - b| over every rank, and max |b|."""
    d = comm.allreduce(float(np.abs(a - b).max()) if a.size else 0.0, op=MPI.MAX)
    m = comm.allreduce(float(np.abs(b).max()) if b.size else 0.0, op=MPI.MAX)
    return d, m


def test_bodies_pulled_apart_and_held():
    """The block is lifted 0.1 mm off the base (its top prescribed, the base's bottom held),
    then held for 2 s: every step converges without a cut, the hold's steps in at most one
    Newton iteration; the block moves as a rigid body (every point's gap is -0.1 mm, to
    1e-9), no point carries a traction, and the hold changes nothing beyond Newton's tolerance
    (1e-9 of the displacement; measured 2e-12: the first step of the hold iterates once from
    the pull's last residual)."""
    comm = MPI.COMM_WORLD
    program = LoadingProgram([0, 1, 3], {"pull": [0, 1, 1]})
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", (0.0, 0.1), amplitude="pull")]
    prob = InterfaceProblem(block(comm), preset("sec7"), MATERIALS, program, bcs)
    records, xs = run(prob, 0.25)
    assert records[-1].t == pytest.approx(3.0)
    assert all(r.cuts == 0 for r in records)
    hold = [r for r in records if r.t > 1.0 + 1e-9]
    assert len(hold) == 8 and all(r.iterations <= 1 for r in hold), [r.iterations for r in hold]
    un = prob.interface.last_gap[:, -1]
    assert comm.allreduce(float(np.abs(un + 0.1).max()) if un.size else 0.0, MPI.MAX) < 1e-9
    tr = prob.interface.last.traction
    assert comm.allreduce(float(np.abs(tr).max()) if tr.size else 0.0, op=MPI.MAX) == 0.0
    d, m = spread(comm, xs[-1], xs[len(records) - len(hold) - 1])
    assert d <= 1e-9 * m, (d, m)


@pytest.mark.leaves_validity(PenetrationWarning, reason="a 1e5 MPa/mm penalty on the 1 mm block")
def test_a_clamped_shrink_fit_holds():
    """A 2 µm interference (initial gap -0.002 mm) between a base and a block both held at
    their far faces, held for 3 s: the first step presses the interface (every point in contact,
    a positive normal traction), each later step converges in at most one Newton iteration and
    changes nothing (1e-12 of the displacement)."""
    comm = MPI.COMM_WORLD
    program = LoadingProgram([0, 1, 4], {"c": [1, 1, 1]})
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", (0.0, 0.0))]
    law = preset("sec7").replace(alpha_n=1e5, alpha_t=1e5)
    prob = InterfaceProblem.two_bodies(
        block(comm),
        law,
        MATERIALS,
        program,
        bcs,
        interface=Interface("interface", initial_gap=-0.002),
    )
    records, xs = run(prob, 0.5)
    assert records[-1].t == pytest.approx(4.0) and all(r.cuts == 0 for r in records)
    assert all(r.iterations <= 1 for r in records[1:]), [r.iterations for r in records]
    fn = prob.interface.last.traction[:, -1]
    assert comm.allreduce(float(fn.min()) if fn.size else np.inf, op=MPI.MIN) > 0.0
    d, m = spread(comm, xs[-1], xs[0])
    assert m > 0 and d <= 1e-12 * m, (d, m)


def test_a_converged_state_converges_at_once():
    """A pressed block (300 MPa) solved to t = 1, then solved again to the same time: the
    second solve converges in at most one iteration, and so does a state without any force
    (the bodies pulled apart)."""
    from subfric_dolfinx.fem import Pressure

    comm = MPI.COMM_WORLD
    program = LoadingProgram([0, 1, 2], {"press": [0, 1, 1], "pull": [0, 0, 1]})
    bottom = Dirichlet("bottom", (0.0, 0.0))
    law = preset("sec7").replace(alpha_n=1e5, alpha_t=1e5)
    for bcs, loads in (
        ([bottom, Dirichlet("top", 0.0, component=0)], [Pressure("top", 300.0, amplitude="press")]),
        ([bottom, Dirichlet("top", (0.0, 0.1), amplitude="pull")], []),
    ):
        prob = InterfaceProblem(block(comm), law, MATERIALS, program, bcs, loads)
        t = 1.0 if loads else 2.0
        with FrictionSolver(prob, prefix("again")) as solver:
            first = solver.solve(t, t)
            assert first.converged, first
            prob.commit()
            again = solver.solve(t, 0.5)
        assert again.converged and again.iterations <= 1, again


# --------------------------------------------------------------------------------------------
# Code_Aster's SSNV503, modelling B's program: both loads ramped while the gap is open


def ssnv503_b(pt):
    """The SSNV503 skate (tests/verification/test_ssnv503.py) 2 mm above its frame on 0.01 N/mm
    springs (two lateral, one vertical), the pressure and the side load ramped together from 0."""
    from tests.verification import test_ssnv503 as ref

    s = ref.scene()
    k = 0.01
    s["initial_gap"] = 2.0
    s["program"] = {"times": [0, 1], "channels": {"pn": [0, 1], "pt": [0, pt]}}
    s["springs"] = [
        {"group": "secondary_left", "stiffness": [k / ref.HEIGHT, 0.0]},
        {"group": "secondary_right", "stiffness": [k / ref.HEIGHT, 0.0]},
        {"group": "top", "stiffness": [0.0, k / ref.WIDTH]},
    ]
    s["outputs"] = {}
    s["solver"]["dt"] = 0.05
    return s, ref


SSNV503_JOINT = "SSNV503's joint stiffness, 1e4 MPa/mm, as the benchmark gives it"


@pytest.mark.parametrize(
    "sliding",
    [
        pytest.param(
            False,
            id="0.99mu",
            marks=pytest.mark.leaves_validity(PenetrationWarning, reason=SSNV503_JOINT),
        ),
        pytest.param(  # and above mu the block slides away
            True,
            id="1.01mu",
            marks=pytest.mark.leaves_validity(
                PenetrationWarning, SlideWarning, reason=SSNV503_JOINT
            ),
        ),
    ],
)
def test_ssnv503_b_both_loads_while_the_gap_is_open(sliding):
    """The skate closes the gap within the first step (the vertical spring carries 0.02 N
    when it touches) and the run completes with default options, every step without a cut.
    There is an equilibrium at every instant while open (the springs carry the loads), so none
    is missing: the failures seen before were the divergence test stopping the first Newton
    iterate of the closing step (on the open Jacobian it lands 6e4 mm deep in the frame; Newton
    comes back in 8 iterations). Checked at the end, the skate's balance: the frame carries the
    pressure less the vertical spring's force; under 0.99 mu the interface carries the side load
    (the springs less than 1 %); under 1.01 mu it slides, the interface carries mu F_n and the
    springs the rest, Ft - mu Fn = 36 N (to 1e-5). The balances hold to 1e-9, sliding to 1e-7:
    the skate then ends 1800 mm away (36 N on 0.02 N/mm), where the residual's round-off floor
    is about 1e-4 N (measured balance error 9e-5 N of 3636 N)."""
    from subfric_dolfinx.scenes import parse_scene

    pt = 181.8 if sliding else 178.2
    s, ref = ssnv503_b(pt)
    result = run_scene(parse_scene(s), comm=MPI.COMM_WORLD)
    h = result.history
    assert h[-1]["t"] == pytest.approx(1.0) and all(r["cuts"] == 0 for r in h)
    row = h[-1]
    rel = 1e-7 if sliding else 1e-9
    assert row["F_n"] + row["S_top_y"] == pytest.approx(ref.PN * ref.WIDTH, rel=rel)
    springs = row["S_secondary_left_x"] + row["S_secondary_right_x"]
    assert row["F_t1"] - springs == pytest.approx(pt * ref.HEIGHT, rel=rel)
    if sliding:
        assert row["F_t1"] == pytest.approx(ref.MU * row["F_n"], rel=1e-9)
        # F_n is the pressure less the vertical spring's 0.02 N
        assert springs == pytest.approx(-(pt * ref.HEIGHT - ref.MU * row["F_n"]), rel=1e-5)
    else:
        assert abs(springs) < 0.01 * pt * ref.HEIGHT
