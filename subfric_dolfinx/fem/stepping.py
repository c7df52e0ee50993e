"""Adaptive load stepping through a loading program.

:class:`LoadStepper` advances a :class:`~subfric_dolfinx.fem.solver.FrictionSolver` through its
problem's loading program: steps end on every breakpoint (a reversal or the start of a hold is never
stepped over) and on requested stop times; a failed step is undone (displacement and interface
state), tried again with a backtracking line search (:data:`RETRY_OPTIONS`: Newton with full steps
can cycle on the switch between open and closed contact) and, if that fails too, retried with a
smaller step; easy steps let the step grow; state is committed only after convergence. Within a
straight stretch of the loading program, Newton starts from the last step's increment
extrapolated to the new step (``predictor``; the increment is in the checkpoint). With
``hold_dt``, a hold of the program (a segment where no channel changes: time passes, nothing moves)
is crossed in steps of ``hold_dt`` (the subloading return map integrates the recovery of a hold
exactly, whatever the step: docs/model.md §6.7), and the step outside holds is kept for after it.
After too many cuts it raises :class:`StepFailure` naming the time, the last converged step,
whose state is intact, and what the return map saw at the failed attempt (status counts, the
worst point, where).
A step that converges at once costs nothing extra.

Its log lines (a line per long segment of the program, progress, a DEBUG line per step and per
failed attempt) are made by :mod:`.steplog`. Warnings about the model's validity (penetration,
slide) are issued when a run ends (:class:`~.validity.ValidityWatch`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

from ..constitutive import Status
from .attempts import SLIDING_FRACTION, AttemptReport, describe_attempt, interface_activity
from .interface import NewtonStart
from .solver import FrictionSolver, SolveResult
from .steplog import RunLog, activity_text
from .validity import ValidityWatch

__all__ = [
    "FIRST_TOUCH_OPTIONS",
    "MAX_STEPS",
    "PREDICTOR_FORCE_RATIO",
    "RETRY_OPTIONS",
    "RETRY_SEPARATED_STIFFNESS",
    "SLIDING_FRACTION",
    "TURN_OPTIONS",
    "LoadStepper",
    "StepControl",
    "StepFailure",
    "StepInterrupted",
    "StepRecord",
    "StepperMemory",
    "describe_attempt",
    "interface_activity",
]


PREDICTOR_FORCE_RATIO = 1e3
"""A step's increment is extrapolated (``predictor``) only where its converged state's forces
exceed its last residual this many times (:meth:`LoadStepper._forces_resolved`)."""

CURVATURE_FRACTION = 1e-3
"""The predictor adds the path's curvature (the quadratic through the last three converged
states) only where it is at most this fraction of the last increment (2-norms over the ranks):
:meth:`LoadStepper._curvature`."""

RETRY_OPTIONS: dict[str, Any] = {"snes_linesearch_type": "l2"}
"""Options of the second attempt at a step whose first attempt failed (before it is cut).

The l2 line search (minimising the residual norm along the Newton direction) solves the cases
where Newton with full steps cycles: the unloaded slide followed by a pressure, the literal Sec. 7
set (``tests/fem/test_reliability.py``); a backtracking line search (``bt``) solves the first but
not the second."""

TURN_OPTIONS: dict[str, Any] | None = {
    "snes_linesearch_type": "cp",
    "snes_linesearch_maxlambda": 2.0,
}
"""Options of the first attempt at a step that starts from bodies carried along by the program
(:meth:`LoadStepper._carried`: where it turns, or at a run's first step, with a finite-sliding
interface); ``None``: the solver's own.

Where the friction's moment tilts a sliding body off part of its base within the step, Newton's
full steps open its trailing points one ring an iteration (the penalty's linear step keeps the
next ring in contact); the critical-point line search lengthens those steps beyond the full
one (``docs/model.md`` §12). PETSc 3.25 caps its step length at ``maxlambda`` (1 by default: no
longer than Newton's); 3.22 neither caps it nor knows the option."""

FIRST_TOUCH_OPTIONS: dict[str, Any] = {"snes_linesearch_type": "l2"}
"""Options of the first attempt at a run's first step with a finite-sliding interface where no
body is carried (a first touch from the state at rest: :meth:`LoadStepper._first_touch`)."""

RETRY_SEPARATED_STIFFNESS = 1e-6
"""In the retry of a failed step, points without stiffness keep this fraction of the contact
stiffness in the Jacobian (:func:`~.problem.stiffen_separated`; the residual is unchanged).

A body whose interface points are all separated, with no support in some direction, makes the
Jacobian singular: the unloaded slide of the ``sec7`` block lets it tip about its one touching
point (any such position is an equilibrium without load), and the pressure that follows then
finds every point separated and the linear solve fails at every step size. With this fraction
the Newton step exists and closes the gap (``tests/fem/test_reliability.py``: every strategy,
``sec7`` and ``sec7-literal``). 1e-6 of ``alpha_n`` is far below any body's stiffness (no effect on
a converged step's Newton path where the Jacobian is regular) and far enough above round-off for
GAMG's set-up (``docs/design.md``, *Separated points in the Jacobian*)."""

MAX_STEPS = 1_000_000
"""Default limit of the converged steps of a run (:class:`LoadStepper`'s ``max_steps``; scenes:
``solver.max_steps``), like the material-point driver's ``MAX_TOTAL_STEPS``: a million FE steps
is days of computing."""

logger = logging.getLogger(__name__)


class StepFailure(RuntimeError):
    """A step could not be solved even after the allowed cuts.

    Attributes:
        t: Time the failed step aimed at.
        last_t: Time of the last converged step (its state is intact).
        last_step: Index of the last converged step.
        reason: What failed (SNES reason, failed return-map points).
        attempt: What the return map saw at the last iterate of the failed attempt
            (:func:`describe_attempt`), the same on every rank; ``None`` if none (``max_steps``).
    """

    def __init__(
        self,
        message: str,
        t: float,
        last_t: float,
        last_step: int,
        reason: str,
        attempt: AttemptReport | None = None,
    ) -> None:
        super().__init__(message)
        self.t, self.last_t, self.last_step, self.reason = t, last_t, last_step, reason
        self.attempt = attempt


class StepInterrupted(RuntimeError):
    """A step abandoned because the solver's ``interrupt`` asked for it (a second stop signal).

    The last converged state is in place.

    Attributes:
        t: Time the abandoned step aimed at.
        last_t: Time of the last converged step (its state is intact).
        last_step: Index of the last converged step.
    """

    def __init__(self, message: str, t: float, last_t: float, last_step: int) -> None:
        super().__init__(message)
        self.t, self.last_t, self.last_step = t, last_t, last_step


@dataclasses.dataclass
class StepRecord:
    """One converged step.

    ``energy``: a dynamic problem's energy accounts at the step's end (mJ;
    :data:`~.dynamics.ENERGY_COLUMNS`, :class:`~.dynamics.Inertia`), empty for a quasi-static one.
    """

    step: int
    t: float
    dt: float
    iterations: int
    cuts: int
    residuals: list[float]
    counts: dict[str, int]
    retried: bool = False  # solved with the retry options (:data:`RETRY_OPTIONS`)
    sliding: float = 0.0  # fraction of the points sliding at the end (:func:`interface_activity`)
    open: float = 0.0  # fraction of the points open at the end
    energy: dict[str, float] = dataclasses.field(default_factory=dict)

    @property
    def plastic_fraction(self) -> float:
        """Fraction of the interface points on the (subloading) surface in the step.

        With the subloading law this includes the micro-slip of points far below the strength
        (e.g. the whole interface while it is pressed): :attr:`sliding` says what slides.
        """
        c = self.counts
        n = sum(c.get(s.name, 0) for s in Status)
        return (c.get(Status.PLASTIC.name, 0) + c.get(Status.JUMP.name, 0)) / n if n else 0.0

    @property
    def activity(self) -> str:
        """What the interface does at the end of the step, e.g. ``sliding 40 %, sticking 60 %``."""
        return activity_text(self.sliding, self.open)


def _why(r: SolveResult, solver: FrictionSolver) -> str:
    why = f"SNES reason {r.reason}"
    if r.error:
        why += f" ({' '.join(r.error.split())[:300]})"
    if r.linear_failure:
        why += f": {r.linear_failure}"
    if solver.failed_points.size:
        why += f", return map failed at {solver.failed_points.size} points"
    return why


def _options_text(options: Mapping[str, Any] | None) -> str:
    return ", ".join(f"-{k} {v}" for k, v in (options or {}).items())


@dataclasses.dataclass(frozen=True)
class StepControl:
    """How :class:`LoadStepper`'s step length adapts: its bounds, cuts and growth.

    Attributes:
        dt_min: Smallest step before giving up; ``None``: ``dt * cut ** max_cuts``.
        dt_max: Largest step; ``None``: the initial step.
        cut: Factor applied to the step after a failure.
        grow: Factor applied after ``easy_steps`` consecutive steps with at most
            ``easy_iterations`` Newton iterations.
        easy_iterations: See ``grow``.
        easy_steps: See ``grow`` (and :class:`LoadStepper`'s ``sticky_retry``).
        max_cuts: Consecutive cuts allowed before :class:`StepFailure`.
        hold_dt: Step in the holds of the program (segments where every channel is constant),
            instead of the adaptive ``dt`` (cut on failure like any step; ``dt`` outside holds is
            untouched); ``None``: holds are stepped like the rest.
        max_steps: Converged steps at most (:data:`MAX_STEPS` by default): the run stops with
            :class:`StepFailure` when it has made that many and is not at its end.
    """

    dt_min: float | None = None
    dt_max: float | None = None
    cut: float = 0.5
    grow: float = 1.5
    easy_iterations: int = 4
    easy_steps: int = 2
    max_cuts: int = 10
    hold_dt: float | None = None
    max_steps: int = MAX_STEPS


@dataclasses.dataclass(frozen=True)
class StepperMemory:
    """What decides a :class:`LoadStepper`'s next steps beyond the problem's state.

    A checkpoint stores it (:func:`~subfric_dolfinx.io.write_checkpoint`) and a restart gives it
    back (:meth:`LoadStepper.restore`), so that the restarted run takes the steps the
    uninterrupted run takes, with the same first guesses.

    Attributes:
        t: Time of the last converged step.
        step: Index of the last converged step.
        dt: The step outside holds that the next step starts from.
        easy: Consecutive easy steps so far (the growth of ``dt``, :class:`StepControl`).
        hold_step: The step of the current hold after a cut (``None``: ``hold_dt``).
        keep_retry: Whether the current segment's steps start with the retry options
            (``sticky_retry``).
        retry_run: Consecutive converged steps started with the retry options.
        increment: The last converged step's displacement increment (owned values; the
            predictor's), ``None`` if none or without the predictor.
        increment_dt: Its step length (0 without an increment).
    """

    t: float
    step: int
    dt: float
    easy: int = 0
    hold_step: float | None = None
    keep_retry: bool = False
    retry_run: int = 0
    increment: np.ndarray | None = None
    increment_dt: float = 0.0


class LoadStepper:
    """Adaptive load stepping through a loading program.

    Args:
        solver: The solver (its problem holds the program).
        dt: Initial step.
        control: How the step length adapts (:class:`StepControl`); ``None``: its defaults.
        on_step: Called with the :class:`StepRecord` after each converged step (after commit).
        retry_options: Solver options of a second attempt at a failed step, before it is cut
            (default :data:`RETRY_OPTIONS`, a line search); ``None``: cut at once.
        sticky_retry: Once a step needed the retry, start the following steps of the same
            segment of the program (up to the next breakpoint) with the retry options; after
            ``easy_steps`` such steps in a row, the next step tries the solver's own options
            first again (the retry stays its fallback), and stays with them if they converge:
            a line search costs Newton its quadratic rate (more iterations a step than
            ``easy_iterations``), so a segment kept on it would never let the step grow back
            after a cut.
        keep_records: Keep every step's :class:`StepRecord` in :attr:`records` (under a kilobyte
            a step); ``False``: the last one only (a run that keeps its own history,
            as scenes do).
        predictor: Start Newton at the converged displacement plus the last step's increment
            scaled to this step (``dt / dt_last``; linear extrapolation, as Abaqus/Standard's
            default) where the program's channels go on as they went during the last step:
            every channel's change over the step is ``dt / dt_last`` times its last change (to
            1e-9) and one of them changes. A reversal, a change of rate or a hold (what moves
            there is not the program's doing) is never extrapolated over; knots on a straight
            line are. Newton's relative tolerance stays that of the start without the
            extrapolation (:meth:`FrictionSolver.solve`'s ``predictor``: an exact
            extrapolation has a residual of round-off, against which no relative target is
            reachable). The retry of a failed attempt (with a line search) starts from the
            converged displacement. Where the program went straight over the last three steps
            of one length, with interfaces paired once, the second difference of the last two
            increments is added where it is small (:meth:`_curvature`: the quadratic through
            the last three converged states). The increment is in the checkpoint (a restart
            repeats the path; the one before is not: writing a checkpoint drops it in the run
            that wrote it too, :meth:`forget_curvature`). ``False``: every step starts from the
            converged displacement (with the new Dirichlet values). Only Newton's path changes,
            not the equations: fewer Newton iterations a step (``docs/design.md``, *The
            predictor*).
            With finite sliding, a step started from the converged state evaluates the law at a
            zero slip increment, with its stick (elastic) tangent: the first iterate shears the
            block instead of sliding it, its points open and close, the second overshoots, and
            Newton needs about twice the iterations of the extrapolated start
            (``docs/model.md`` §12). With finite
            sliding, where the program turns (nothing to extrapolate: the slide's first step, a
            reversal) each body that the program's Dirichlet values move alike is carried along
            by them (:meth:`_carried`: the step starts slipping), on the line search of
            :data:`TURN_OPTIONS`; where no body moves so, the step's first Newton iteration is
            frictionless. The first Jacobian of every step keeps the points that were in contact
            at the step's start in contact, which saves the slide's first step a failed attempt:
            every step's first Jacobian is told how it starts (:class:`~.interface.NewtonStart`,
            :meth:`FrictionSolver.solve`'s ``start``) and each interface's kind decides.
    """

    def __init__(
        self,
        solver: FrictionSolver,
        dt: float,
        *,
        control: StepControl | None = None,
        on_step: Callable[[StepRecord], None] | None = None,
        retry_options: Mapping[str, Any] | None = RETRY_OPTIONS,
        sticky_retry: bool = True,
        keep_records: bool = True,
        predictor: bool = True,
    ) -> None:
        c = control or StepControl()
        dt_min, dt_max, cut, grow = c.dt_min, c.dt_max, c.cut, c.grow
        easy_iterations, easy_steps, max_cuts = c.easy_iterations, c.easy_steps, c.max_cuts
        hold_dt, max_steps = c.hold_dt, c.max_steps
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt = {dt!r} must be finite and > 0")
        if hold_dt is not None and not (math.isfinite(hold_dt) and hold_dt > 0):
            raise ValueError(f"hold_dt = {hold_dt!r} must be finite and > 0")
        self.solver = solver
        self.problem = solver.problem
        self.program = self.problem.program
        self.dt = float(dt)
        self.dt_max = float(dt_max) if dt_max is not None else self.dt
        self.dt_min = float(dt_min) if dt_min is not None else self.dt * cut**max_cuts
        self.cut, self.grow = cut, grow
        self.easy_iterations, self.easy_steps = easy_iterations, easy_steps
        self.max_cuts = max_cuts
        self.on_step = on_step
        self.retry_options = dict(retry_options) if retry_options else None
        self.sticky_retry = sticky_retry
        self.hold_dt = float(hold_dt) if hold_dt is not None else None
        if not (isinstance(max_steps, int | float) and max_steps >= 1):
            raise ValueError(f"max_steps = {max_steps!r} must be >= 1")
        self.max_steps = max_steps
        self._hold_step: float | None = None  # the hold's step after a cut (until its end)
        self._keep_retry = False
        self._retry_run = 0  # consecutive converged steps started with the retry options
        self.retries = 0  # steps whose first attempt failed and the retry converged (run)
        self.line_search_steps = 0  # steps solved with the retry options (run)
        self.t = self.program.t_start
        self.step = 0
        self.records: list[StepRecord] = []
        self.keep_records = keep_records
        self.easy = 0  # consecutive easy steps (drives the growth of dt)
        assert solver.x is not None  # (a live solver: None once destroyed)
        self._x_converged = solver.x.copy()
        self.predictor = bool(predictor)
        self._bodies: list[np.ndarray] | None = None  # each body's owned dofs (:meth:`_carried`)
        # the last converged step's displacement increment and its length (the predictor's)
        self.increment: np.ndarray | None = None
        self.increment_dt = 0.0
        # the increment of the step before it (the curvature's; not in the checkpoint)
        self._before: np.ndarray | None = None
        self._before_dt = 0.0
        # penetration (and, small sliding, slide) of every interface, warned at the end: a watch
        # per interface, the first's here
        self.watches = {n: ValidityWatch(self.problem, n) for n in self.problem.interfaces}
        self.validity = next(iter(self.watches.values()), None)

    def _channels(self, t: float) -> np.ndarray:
        return np.array([self.program.amplitude(c, t) for c in sorted(self.program.channels)])

    def _predict(self, target: float, dt: float) -> np.ndarray | None:
        """The increment added to Newton's start: the last step's, scaled to this one.

        Only if the program goes on as it went during the last step ``(t - increment_dt, t)``
        (the same on every rank: the program decides); else ``None``. A dynamic problem's:
        ``dt v + dt^2 a / 2`` from its committed velocity and acceleration
        (:meth:`~.dynamics.Inertia.predicted_increment`), at every step but the first.
        """
        dynamics = getattr(self.problem, "dynamics", None)
        if self.predictor and dynamics is not None and dynamics.started:
            return dynamics.predicted_increment(dt)  # the motion's own extrapolation
        if not self.predictor or self.increment is None or self.increment_dt <= 0.0:
            return None
        ratio = dt / self.increment_dt
        change = self._channels(target) - self._channels(self.t)
        last = ratio * (self._channels(self.t) - self._channels(self.t - self.increment_dt))
        scale = max(float(np.abs(change).max(initial=0.0)), float(np.abs(last).max(initial=0.0)))
        if scale > 0.0 and np.all(np.abs(change - last) <= 1e-9 * scale):
            curvature = self._curvature(dt, change)
            if curvature is not None:
                return self.increment + curvature
            return ratio * self.increment
        return None

    def _curvature(self, dt: float, change: np.ndarray) -> np.ndarray | None:
        """The second difference of the last two increments, where the predictor adds it.

        Only with interfaces paired once (small sliding: a slide that crosses the primary's
        nodes has kinks, no parabola), where the last three steps and this one are of one
        length and the program went straight over the two steps before as it goes in this one
        (``change``: its channels' change in this step), and where the second difference is at
        most :data:`CURVATURE_FRACTION` of the last increment (2-norms over the ranks: a path
        bending faster, e.g. a contact area growing under a press, is extrapolated linearly).
        The same decision on every rank (collective where the program goes straight).
        """
        before = self._before
        if before is None or self.increment is None or self.problem.repairs:
            return None
        h = self.increment_dt
        if abs(dt - h) > 1e-12 * h or abs(self._before_dt - h) > 1e-12 * h:
            return None
        t = self.t
        older = self._channels(t - h) - self._channels(t - 2.0 * h)
        scale = max(float(np.abs(change).max(initial=0.0)), float(np.abs(older).max(initial=0.0)))
        if not (scale > 0.0 and np.all(np.abs(change - older) <= 1e-9 * scale)):
            return None
        second = self.increment - before
        sums = self.problem.comm.allreduce(
            np.array([second @ second, self.increment @ self.increment]), op=MPI.SUM
        )
        if not sums[1] > 0.0 or math.sqrt(sums[0]) > CURVATURE_FRACTION * math.sqrt(sums[1]):
            return None
        return second

    def forget_curvature(self) -> None:
        """Extrapolate linearly at the next step (without the curvature).

        A checkpoint keeps the last increment, not the one before: written now, a restart from
        it continues as this run does.
        """
        self._before = None

    def _forces_resolved(self, r: SolveResult) -> bool:
        """Whether the converged state's forces stand above Newton's error (collective).

        The forces: the interface's, the reactions and the loads; Newton's error: the step's
        last residual. Where they are not :data:`PREDICTOR_FORCE_RATIO` times larger (an
        unloaded body touching or floating: every position of it is an equilibrium to within
        the residual), the step's increment is not the response to anything: it is the part
        of the linear solves' round-off and of Newton's tolerance the state kept, and
        extrapolating it carries that on from step to step (identical runs on several ranks,
        whose direct solver rounds differently from run to run, then parted). Such a step's
        increment is not extrapolated (a zero one is kept).
        """
        p = self.problem
        res = float(r.residuals[-1]) if r.residuals else 0.0
        own = getattr(p, "interface_force", None)
        interface = float(own @ own) if own is not None else 0.0
        forces = math.sqrt(p.comm.allreduce(interface, op=MPI.SUM))
        for v in getattr(p, "reactions", {}).values():
            forces += float(np.linalg.norm(v))
        for c, f in getattr(p, "loads", []):
            forces += abs(p.program.amplitude(c.amplitude, p.t)) * f.norm()
        return forces > PREDICTOR_FORCE_RATIO * res

    def _turns(self, target: float) -> bool:
        """Whether the step to ``target`` starts a new direction of the program.

        A last step whose increment is known (``predictor``) and a channel that changes in this
        step: where :meth:`_predict` has nothing to extrapolate, the step's
        :class:`~.interface.NewtonStart` says the program turns. The same on every rank: the
        program decides.
        """
        if not self.predictor or self.increment is None:
            return False
        change = self._channels(target) - self._channels(self.t)
        return bool(np.abs(change).max(initial=0.0) > 0.0)

    def _carried(self, target: float) -> np.ndarray | None:
        """Each body carried along by its Dirichlet values' change: a step's start.

        Where the program turns or at a run's first step (nothing to extrapolate), with a
        finite-sliding interface: a body whose Dirichlet dofs all change alike in a component
        over the step (the same nonzero change on every one of them) is translated by that
        change in that component. The start of a slide the program drives: its interface
        points start the step slipping, with their slip tangent and the friction's force,
        instead of on a frictionless first iterate; of a press by a displacement: the body
        starts the step where the open interface's first iterate would take it, in the other
        one. The same on every rank; ``None`` where no body moves so (a motion driven by
        loads, or none).
        """
        if self._bodies is None:
            self._bodies = _body_dofs(self.problem)
        dofs, now = self.problem.dirichlet_values(target)
        _, before = self.problem.dirichlet_values(self.t)
        change = now - before
        comm = self.problem.comm
        bs = self.problem.V.dofmap.bs
        assert self.solver.x is not None  # (a live solver)
        out = np.zeros(self.solver.x.getLocalSize())
        moved = False
        for own in self._bodies:
            for c in range(bs):
                component = own[own % bs == c]
                d = change[np.isin(dofs, component)]
                lo = comm.allreduce(float(d.min(initial=np.inf)), op=MPI.MIN)
                hi = comm.allreduce(float(d.max(initial=-np.inf)), op=MPI.MAX)
                if not math.isfinite(lo) or hi == 0.0 or hi - lo > 1e-12 * abs(hi):
                    continue
                out[component] = hi
                moved = True
        return out if moved else None

    def _undo(self) -> None:
        """Back to the last converged state (displacement and interface trial state)."""
        assert self.solver.x is not None  # (a live solver)
        self.solver.x.array_w[:] = self._x_converged.array_r
        self.problem.revert()

    def memory(self) -> StepperMemory:
        """What decides the next steps (:class:`StepperMemory`; the increment is not copied)."""
        inc = self.increment if self.predictor and self.increment is not None else None
        return StepperMemory(
            t=self.t,
            step=self.step,
            dt=self.dt,
            easy=self.easy,
            hold_step=self._hold_step,
            keep_retry=self._keep_retry,
            retry_run=self._retry_run,
            increment=inc,
            increment_dt=self.increment_dt if inc is not None else 0.0,
        )

    def restore(self, memory: StepperMemory) -> None:
        """Continue from a restored state: ``problem.u`` and the interface state must hold it.

        ``memory``: the stepper's (:meth:`memory`) at the restored step; its ``increment`` may
        hold ghost values beyond the owned ones. The step outside holds is at most ``dt_max``
        (which a restart may change).
        """
        m = memory
        self.t, self.step, self.easy = float(m.t), int(m.step), int(m.easy)
        self.dt = min(float(m.dt), self.dt_max)
        self._hold_step = None if m.hold_step is None else float(m.hold_step)
        self._keep_retry, self._retry_run = bool(m.keep_retry), int(m.retry_run)
        n = self.problem.layout.n_owned
        assert self.solver.x is not None  # (a live solver)
        self.solver.x.array_w[:] = self.problem.u.x.array[:n]
        self._x_converged.array_w[:] = self.solver.x.array_r
        inc = m.increment
        self.increment = None if inc is None else np.array(inc[:n], dtype=float)
        self.increment_dt = float(m.increment_dt) if inc is not None else 0.0
        self._before = None

    def run(self, t_end: float | None = None, stops: Sequence[float] = ()) -> list[StepRecord]:
        """Advance to ``t_end`` (default: the end of the program).

        Steps end on every breakpoint of the program and on every time in ``stops`` (e.g. the
        times of requested snapshots).

        Raises:
            StepFailure: After ``max_cuts`` consecutive cuts, or below ``dt_min``; the last
                converged state is in place (displacement and interface state).
        """
        t_end = self.program.t_end if t_end is None else float(t_end)
        stops_arr = np.sort(np.asarray(stops, dtype=float))

        def next_stop(t: float) -> float:
            nb = self.program.next_breakpoint(t)
            later = stops_arr[stops_arr > t + 1e-12 * max(1.0, abs(t))]
            return min(nb, float(later[0])) if later.size else nb

        try:
            return self._run(t_end, next_stop)
        finally:  # however the run ends: a large penetration or slide seen is said (once)
            for watch in self.watches.values():
                watch.warn()

    def _check_interrupted(self, r: SolveResult, target: float) -> None:
        """If the solver's ``interrupt`` stopped the solve: undo the step, raise StepInterrupted.

        On every rank: the solver agreed on it.
        """
        if not r.interrupted:
            return
        self._undo()
        raise StepInterrupted(
            f"the step to t = {target:.6g} was abandoned on request; the last converged step "
            f"is {self.step} at t = {self.t:.6g}, whose state is kept",
            target,
            self.t,
            self.step,
        )

    def _run(self, t_end: float, next_stop: Callable[[float], float]) -> list[StepRecord]:
        """Step to ``t_end``: the loop of :meth:`run`.

        Each pass attempts the next step (:meth:`_next_target`, :meth:`_attempt`). A failed
        attempt is undone and the step cut (:meth:`_cut_step`, which raises
        :class:`StepFailure` beyond the cuts allowed); a converged one is committed and recorded
        (:meth:`_accept`), logged (:class:`~.steplog.RunLog`), ends the program's segment where
        it reaches a breakpoint (the segment's retry and hold memory is forgotten) and lets the
        step grow (:meth:`_grow_step`); ``on_step`` comes last.
        """
        tol = 1e-12 * max(1.0, abs(t_end))
        log = RunLog(self.t, t_end, self.program, tol, logger)
        cuts = 0  # failed attempts since the last converged step
        while self.t < t_end - tol:
            self._check_max_steps(t_end)
            target, hold, breakpoint_ = self._next_target(t_end, next_stop)
            dt = target - self.t
            t0 = time.perf_counter()
            r, first, retried = self._attempt(target, dt)
            if not r.converged:
                cuts += 1
                log.cut()
                self._cut_step(r, target, dt, hold, cuts, retried)
                continue
            if retried:
                log.line_search()
            rec = self._accept(r, target, dt, cuts, first, retried)
            ends = target >= breakpoint_ - tol
            log.step(rec, t0, ends)
            if ends:  # a new segment starts with the solver's own options
                self._keep_retry, self._retry_run, self._hold_step = False, 0, None
            cuts = 0
            if not hold:  # the step outside holds grows on easy steps
                self._grow_step(r.iterations)
            if self.on_step is not None:  # last: the stepper's state is that of the next step
                self.on_step(rec)
        return self.records

    def _check_max_steps(self, t_end: float) -> None:
        """Raise :class:`StepFailure` where the run has made ``max_steps`` steps already."""
        if self.step >= self.max_steps:
            raise StepFailure(
                f"the run reached max_steps = {self.max_steps:g} steps at t = {self.t:.6g} "
                f"(of {t_end:.6g}); its state is kept: raise max_steps, or dt",
                self.t,
                self.t,
                self.step,
                "max_steps",
            )

    def _next_target(
        self, t_end: float, next_stop: Callable[[float], float]
    ) -> tuple[float, bool, float]:
        """The next step's end, whether the step is in a hold, and the program's next breakpoint.

        The step (``dt``; in a hold with ``hold_dt``, the hold's step) ends at the next stop (a
        breakpoint, a requested time, ``t_end``) if it would reach it, or leave less than a
        quarter of itself before it (no sliver).
        """
        breakpoint_ = min(self.program.next_breakpoint(self.t), t_end)
        nb = min(next_stop(self.t), t_end)
        hold = self.hold_dt is not None and self.program.is_hold(self.t)
        size = self.dt
        if hold and self.hold_dt is not None:  # (hold: hold_dt is given)
            size = self._hold_step or self.hold_dt
        target = min(self.t + size, nb)
        # do not leave a sliver before a breakpoint
        if nb - target < 0.25 * size:
            target = nb
        return target, hold, breakpoint_

    def _attempt(
        self, target: float, dt: float
    ) -> tuple[SolveResult, Mapping[str, Any] | None, bool]:
        """Solve the step to ``target``, retried once with the retry options if it fails.

        The first attempt takes the solver's own options, or the retry options in a segment
        kept on them (``sticky_retry``, for ``easy_steps`` steps), and starts from the
        predictor's extrapolation where there is one; the retry starts from the converged state.

        Returns:
            The last attempt's result, the first attempt's options (``None``: the solver's own)
            and whether the retry options were used.

        Raises:
            StepInterrupted: The solver's ``interrupt`` stopped an attempt (undone).
        """
        # the solver's own options again after easy_steps steps on the retry's (see sticky_retry)
        keep = self._keep_retry and self._retry_run < self.easy_steps
        first = self.retry_options if keep else None
        stiff = RETRY_SEPARATED_STIFFNESS if first is not None else 0.0
        predicted = self._predict(target, dt)
        turns = predicted is None and self._turns(target) and self._finite()
        touch = first is None and self._first_touch()
        carried = None
        if turns or (touch and self.predictor):
            carried = predicted = self._carried(target)
        options = first
        if first is None and carried is not None and TURN_OPTIONS:
            options = TURN_OPTIONS
        elif touch:
            options = FIRST_TOUCH_OPTIONS
        r = self.solver.solve(
            target,
            dt,
            options=options,
            separated_stiffness=stiff,
            predictor=predicted,
            start=NewtonStart(turns=turns and carried is None, extrapolating=self.predictor),
        )
        self._check_interrupted(r, target)
        retried = first is not None
        if not r.converged and not retried and self.retry_options is not None:
            logger.debug(
                "  step to t = %.6g (dt %.3g) failed: %s; again with %s",
                target,
                dt,
                _why(r, self.solver),
                _options_text(self.retry_options),
            )
            self._undo()  # the retry starts from the converged state
            r = self.solver.solve(
                target,
                dt,
                options=self.retry_options,
                separated_stiffness=RETRY_SEPARATED_STIFFNESS,
            )
            self._check_interrupted(r, target)
            retried = True
            self._keep_retry = self.sticky_retry and bool(r.converged)
            self._retry_run = 0
        return r, first, retried

    def _first_touch(self) -> bool:
        """Whether this step is a first touch: a run's first step with finite sliding.

        A run's first step with an interface re-paired in the current configuration (finite
        sliding), the same on every rank: it starts from the carried bodies
        (:meth:`_carried`) on :data:`TURN_OPTIONS` where the program moves one, else on
        :data:`FIRST_TOUCH_OPTIONS`, without the retry's stiffness of separated points.
        From the state at rest, the first Newton iterate is taken on the tangent of an open
        interface: a body brought to touch moves into the other by up to the step's approach,
        far beyond the penetration of the solution, the next tractions are many times the
        solution's and, with friction, points that stick at the solution start to slip; with
        full steps Newton may then cycle between their two slip directions (a stiff tangential
        penalty's stick region is far narrower than the bodies' shift under the friction). The
        line search shortens the steps that cross it (``docs/model.md`` §12).
        """
        return self.step == 0 and self.increment is None and self._finite()

    def _finite(self) -> bool:
        """Whether the problem has an interface re-paired in the current configuration."""
        return self.problem.repairs

    def _cut_step(
        self, r: SolveResult, target: float, dt: float, hold: bool, cuts: int, retried: bool
    ) -> None:
        """After a failed step: back to the converged state, and the step cut (collective).

        The hold's step in a hold, else ``dt`` (whose growth starts again).

        Raises:
            StepFailure: ``cuts`` beyond ``max_cuts`` or the cut step below ``dt_min``, naming
                why the step failed and what the return map saw (:func:`describe_attempt`).
        """
        why = _why(r, self.solver)
        attempt = describe_attempt(self.problem)  # before the undo (collective)
        fault = getattr(self.problem, "bulk_fault", None)
        bulk = fault() if fault is not None else None  # collective
        if bulk is not None:  # the bodies' law, not the interface: said first
            why = f"{bulk}; {why}"
        self._undo()
        if r.linear_failure:  # not the model's doing: said at every cut, whatever the log level
            logger.warning(
                "step to t = %.6g (dt %.3g): %s; cutting the step", target, dt, r.linear_failure
            )
        logger.debug(
            "  step to t = %.6g (dt %.3g) failed: %s; %s; cutting",
            target,
            dt,
            why,
            attempt.text,
        )
        if hold:
            self._hold_step = dt * self.cut
        else:
            self.dt = dt * self.cut
            self.easy = 0
        if cuts > self.max_cuts or dt * self.cut < self.dt_min:
            tried = f" (and with {_options_text(self.retry_options)})" if retried else ""
            raise StepFailure(
                f"no convergence at t = {target:.6g} with dt = {dt:.3g}{tried} ({why}; "
                f"{cuts} failed attempt(s) since the last converged step, smallest step "
                f"allowed {self.dt_min:.3g}); the last converged step is "
                f"{self.step} at t = {self.t:.6g}, whose state is kept"
                + (f"; {attempt.text}" if bulk is None else ""),
                target,
                self.t,
                self.step,
                why,
                attempt,
            )

    def _accept(
        self,
        r: SolveResult,
        target: float,
        dt: float,
        cuts: int,
        first: Mapping[str, Any] | None,
        retried: bool,
    ) -> StepRecord:
        """Commit the converged step to ``target`` and record it (collective).

        The retry's memory (``sticky_retry``) and counters, the problem's commit, the validity
        watches, the predictor's increment (:meth:`_keep_increment`), the converged
        displacement, the step's :class:`StepRecord` (kept in :attr:`records`).
        """
        if first is not None:
            self._retry_run += 1
        elif not retried:  # the solver's own options converged: the segment is back on them
            self._keep_retry = False
        if retried:
            self.line_search_steps += 1
            self.retries += int(first is None)
        self.problem.commit()
        dynamics = getattr(self.problem, "dynamics", None)
        for watch in self.watches.values():
            watch.track(target)
        sliding, open_ = interface_activity(self.problem)
        self._keep_increment(r, dt)
        assert self.solver.x is not None  # (a live solver)
        self._x_converged.array_w[:] = self.solver.x.array_r
        self.problem.u.x.array[: self.problem.layout.n_owned] = self.solver.x.array_r
        self.problem.u.x.scatter_forward()
        self.step += 1
        self.t = target
        rec = StepRecord(
            self.step,
            target,
            dt,
            r.iterations,
            cuts,
            list(r.residuals),
            dict(r.counts),
            retried,
            sliding,
            open_,
            dict(dynamics.energy) if dynamics is not None else {},
        )
        if not self.keep_records:
            self.records.clear()
        self.records.append(rec)
        return rec

    def _keep_increment(self, r: SolveResult, dt: float) -> None:
        """Keep the converged step's displacement increment for the predictor (collective).

        In one array kept from step to step; zero where the step's forces were not resolved
        (:meth:`_forces_resolved`: nothing determined that motion). Nothing without the
        predictor.
        """
        if not self.predictor:
            return
        assert self.solver.x is not None  # (a live solver)
        x: np.ndarray = self.solver.x.array_r
        x0 = self._x_converged.array_r
        if self.increment is None or self.increment.shape != x.shape:
            self._before = None
            self.increment = np.empty_like(x)
        else:  # the last increment becomes the one before (the curvature's)
            if self._before is None or self._before.shape != x.shape:
                self._before = np.empty_like(x)
            self._before[:] = self.increment
            self._before_dt = self.increment_dt
        np.subtract(x, x0, out=self.increment)
        self.increment_dt = dt
        if not self._forces_resolved(r):  # nothing determined this motion
            self.increment[:] = 0.0

    def _grow_step(self, iterations: int) -> None:
        """Count an easy step (at most ``easy_iterations``); after ``easy_steps``, grow ``dt``."""
        self.easy = self.easy + 1 if iterations <= self.easy_iterations else 0
        if self.easy >= self.easy_steps:
            self.dt = min(self.dt * self.grow, self.dt_max)
            self.easy = 0


def _body_dofs(problem: Any) -> list[np.ndarray]:
    """The owned dofs (local, unrolled) of each body that shares no node with another one.

    The same bodies in the same order on every rank (collective; an array may be empty here).
    """
    V = problem.V
    bs = V.dofmap.bs
    n = V.dofmap.index_map.size_local
    cells = problem.domain.cell_tags
    dofmap = np.asarray(V.dofmap.list)
    nodes = []
    for body in sorted(problem.topology.bodies):
        tags = [problem.tags[g] for g in problem.topology.bodies[body]]
        d = np.unique(dofmap[cells.indices[np.isin(cells.values, tags)]].ravel())
        nodes.append(d[d < n])
    count = np.zeros(n, dtype=np.int64)
    for d in nodes:
        count[d] += 1
    out = []
    for d in nodes:
        shared = problem.comm.allreduce(int(np.any(count[d] > 1)), op=MPI.MAX)
        if not shared:
            out.append((d[:, None] * bs + np.arange(bs)).ravel())
    return out
