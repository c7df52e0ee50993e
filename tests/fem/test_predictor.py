"""The load stepper's predictor (issues 22 and 25; on by default with finite sliding, asked for
here on a small-sliding block): Newton's first iterate extrapolated from the last step's
increment where the loading program goes straight on. Fewer Newton iterations, the same
solution (to Newton's tolerance: against a run at a 1000 times tighter tolerance), never across a
reversal, a change of rate or a hold. The increment is in the checkpoint: a restart continues
as the run that wrote it (the restart tests of ``test_checkpoint.py`` and
``test_finite_sliding_scenes.py``, with the predictor on by default). 1 and 2 ranks."""

import itertools

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.fem import FrictionSolver, LoadStepper, NewtonStart, StepControl
from subfric_dolfinx.fem import stepping as stepping_module
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from tests.helpers import SEC7_PENALTY, block_problem, prefix

# press (knot at 0.4 on the line), slide (knot at 1.2 on the line), at half the rate (knot at 1.8
# on the line), back, hold
PROGRAM = LoadingProgram(
    [0, 0.4, 1.0, 1.2, 1.4, 1.8, 2.2, 3.0, 3.4],
    {
        "press": [0, 0.4, 1, 1, 1, 1, 1, 1, 1],
        "slide": [0, 0, 0, 0.2, 0.4, 0.6, 0.8, 0.0, 0.0],
    },
)


def run(predictor, rtol=1e-9, curved=None):
    """Per step: (t, Newton iterations, whether the first iterate was extrapolated, F_t1, F_n).

    ``curved``: a list that gets, per step, whether the predictor added the curvature."""
    problem = block_problem(MPI.COMM_WORLD, program=PROGRAM)
    rows = []
    with FrictionSolver(problem, prefix("pred"), {"snes_rtol": rtol}, linear="lu") as solver:
        flags = []
        real = solver.solve

        def solve(*a, **k):
            flags.append(k.get("predictor") is not None)
            return real(*a, **k)

        solver.solve = solve

        def on_step(rec):
            s = interface_summary(problem)
            rows.append((rec.t, rec.iterations, flags[-1], s["F_t1"], s["F_n"]))

        stepper = LoadStepper(
            solver, 0.1, control=StepControl(dt_max=0.1), predictor=predictor, on_step=on_step
        )
        if curved is not None:
            real_curvature = stepper._curvature

            def curvature(*a):
                c = real_curvature(*a)
                curved.append(c is not None)
                return c

            stepper._curvature = curvature
        stepper.run()
    return rows


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_the_predictor_saves_newton_iterations_and_changes_nothing_else():
    plain, pred, tight = run(False), run(True), run(False, rtol=1e-12)
    t = [r[0] for r in plain]
    assert [r[0] for r in pred] == t == [r[0] for r in tight]
    n_plain, n_pred = sum(r[1] for r in plain), sum(r[1] for r in pred)
    assert n_pred < 0.85 * n_plain, (n_pred, n_plain)
    ref = np.array([r[3:] for r in tight])
    peak = np.abs(ref).max(axis=0)
    err = {
        name: np.abs(np.array([r[3:] for r in rows]) - ref).max(axis=0) / peak
        for name, rows in (("plain", plain), ("pred", pred))
    }
    # (F_t1, F_n) against the tight run, measured on 1 and 2 ranks: plain (1.2e-7, 9e-13),
    # predicted (3.9e-8, 1e-12): Newton's tolerance is relative to the first residual, which
    # the predictor makes smaller; it is never less accurate than the plain run
    assert np.all(err["plain"] < 3e-7), err
    print("ERR", err, n_pred, n_plain)
    assert np.all(err["pred"] <= np.maximum(err["plain"], 1e-11)), err
    assert not any(r[2] for r in plain)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_the_predictor_is_used_only_where_the_program_goes_straight_on():
    rows = run(True)
    predicted = {round(r[0], 9): r[2] for r in rows}

    def at(t):
        return predicted[round(t, 9)]

    assert not at(0.1)  # the first step: no increment yet
    assert at(0.2) and at(0.5) and at(1.0)  # pressing (the knot at 0.4 is on the same line)
    assert not at(1.1)  # the press ends, the slide starts: another direction
    assert at(1.2) and at(1.3) and at(1.4)  # knots on the same straight line (1.2)
    assert not at(1.5)  # half the rate
    assert at(1.6) and at(1.9) and at(2.2)  # the knot at 1.8 is on the same line
    assert not at(2.3)  # the reversal
    assert at(2.4) and at(3.0)
    assert not any(at(t) for t in (3.1, 3.2, 3.3, 3.4))  # a hold: nothing the program moves


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_the_curvature_only_on_a_straight_stretch_where_it_is_small(monkeypatch):
    """The predictor adds the second difference of the last two increments only where the
    program went straight over the last three steps (never at the first two steps after a
    knot that turns it), and only below ``CURVATURE_FRACTION`` of the last increment (on the
    block: the press from its third step and the return take it, the slide's steps do not).
    Against the run that never takes it: no more Newton iterations, and the history as close
    to the tight run as the plain predictor's bound (Newton's tolerance)."""
    curved: list[bool] = []
    rows, tight = run(True, curved=curved), run(False, rtol=1e-12)
    predicted = [r for r in rows if r[2]]
    assert len(curved) == len(predicted)  # asked once per extrapolated step
    took = {round(r[0], 9) for r, c in zip(predicted, curved, strict=True) if c}
    assert took, curved
    for t in (0.1, 0.2, 1.1, 1.2, 1.5, 1.6, 2.3, 2.4, 3.1, 3.2, 3.3, 3.4):
        assert round(t, 9) not in took, (t, sorted(took))
    monkeypatch.setattr(stepping_module, "CURVATURE_FRACTION", 0.0)
    linear = run(True)
    assert sum(r[1] for r in rows) <= sum(r[1] for r in linear)
    ref = np.array([r[3:] for r in tight])
    peak = np.abs(ref).max(axis=0)
    for got in (rows, linear):
        assert np.all(np.abs(np.array([r[3:] for r in got]) - ref).max(axis=0) < 3e-7 * peak)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_small_sliding_keeps_the_law_tangent_at_the_first_iteration():
    """How a step starts (``NewtonStart``: the program turns, the stepper extrapolates), which
    the stepper tells every step's first Jacobian whatever the interfaces' kinds, leaves a
    small-sliding interface's Jacobian alone: the same with every start."""
    problem = block_problem(MPI.COMM_WORLD, program=PROGRAM)
    asked = []
    with FrictionSolver(problem, prefix("predj"), linear="lu") as solver:
        real = solver.solve

        def solve(*a, **k):
            asked.append(k.get("start"))
            return real(*a, **k)

        solver.solve = solve
        LoadStepper(solver, 0.1, control=StepControl(dt_max=0.1)).run(t_end=1.4)
        J, Js = problem.create_matrix(), problem.create_matrix()
        problem.jacobian(solver.x, J)
        diffs = []
        for turns, extrapolating in itertools.product((False, True), repeat=2):
            problem.jacobian(solver.x, Js, 0.0, NewtonStart(turns, extrapolating))
            Js.axpy(-1.0, J)
            diffs.append(Js.norm())
        size = J.norm()
        J.destroy()
        Js.destroy()
    kinds = {i.kinematics for i in problem.interfaces.values()}
    assert kinds == {"small_sliding"} and len(asked) > 10, (kinds, asked)
    assert all(isinstance(s, NewtonStart) and s.extrapolating for s in asked), asked
    assert diffs == [0.0] * 4 and size > 0.0, (diffs, size)
