"""Adaptive load stepping through a loading program.

:class:`LoadStepper` advances a :class:`~subfric_dolfinx.fem.solver.FrictionSolver` through its
problem's loading program: steps end on every breakpoint (a reversal or the start of a hold is never
stepped over) and on requested stop times; a failed step is undone (displacement and interface
state) and retried with a smaller step; easy steps let the step grow; state is committed only after
convergence. After too many cuts it raises :class:`StepFailure` naming the time and the last
converged step, with that state intact.

Logging (:mod:`subfric_dolfinx.logs`): one INFO line per segment of the program (steps, Newton
iterations mean/max, cuts, plastic fraction, wall time), one DEBUG line per step and per failed
attempt.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from .solver import FrictionSolver

__all__ = ["LoadStepper", "StepFailure", "StepRecord"]

logger = logging.getLogger(__name__)


class StepFailure(RuntimeError):
    """A step could not be solved even after the allowed cuts.

    Attributes:
        t: Time the failed step aimed at.
        last_t: Time of the last converged step (its state is intact).
        last_step: Index of the last converged step.
        reason: What failed (SNES reason, failed return-map points).
    """

    def __init__(self, message: str, t: float, last_t: float, last_step: int, reason: str) -> None:
        super().__init__(message)
        self.t, self.last_t, self.last_step, self.reason = t, last_t, last_step, reason


@dataclasses.dataclass
class StepRecord:
    """One converged step."""

    step: int
    t: float
    dt: float
    iterations: int
    cuts: int
    residuals: list[float]
    counts: dict[str, int]

    @property
    def plastic_fraction(self) -> float:
        """Fraction of the interface points that slid plastically in the step."""
        c = self.counts
        n = sum(c.get(k, 0) for k in ("ELASTIC", "PLASTIC", "SEPARATED", "JUMP", "FAILED"))
        return (c.get("PLASTIC", 0) + c.get("JUMP", 0)) / n if n else 0.0


class _Segment:
    """Statistics of the steps since the last breakpoint, for the segment's log line."""

    def __init__(self, t0: float) -> None:
        self.t0 = t0
        self.iterations: list[int] = []
        self.cuts = 0
        self.wall = time.perf_counter()

    def line(self, t1: float, last: StepRecord) -> str:
        its = self.iterations
        return (
            f"t = {self.t0:.6g} -> {t1:.6g} s: {len(its)} steps, Newton {np.mean(its):.2f} mean / "
            f"{max(its)} max, {self.cuts} cuts, plastic {100 * last.plastic_fraction:.0f} %, "
            f"{time.perf_counter() - self.wall:.2f} s"
        )


class LoadStepper:
    """Adaptive load stepping through a loading program.

    Args:
        solver: The solver (its problem holds the program).
        dt: Initial step.
        dt_min: Smallest step before giving up.
        dt_max: Largest step.
        cut: Factor applied to the step after a failure.
        grow: Factor applied after ``easy_steps`` consecutive steps with at most
            ``easy_iterations`` Newton iterations.
        max_cuts: Consecutive cuts allowed before :class:`StepFailure`.
        on_step: Called with the :class:`StepRecord` after each converged step (after commit).
    """

    def __init__(
        self,
        solver: FrictionSolver,
        dt: float,
        *,
        dt_min: float | None = None,
        dt_max: float | None = None,
        cut: float = 0.5,
        grow: float = 1.5,
        easy_iterations: int = 4,
        easy_steps: int = 2,
        max_cuts: int = 10,
        on_step: Callable[[StepRecord], None] | None = None,
    ) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt = {dt!r} must be finite and > 0")
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
        self.t = self.program.t_start
        self.step = 0
        self.records: list[StepRecord] = []
        self.easy = 0  # consecutive easy steps (drives the growth of dt)
        self._x_converged = solver.x.copy()

    def restore(self, t: float, step: int, dt: float, easy: int = 0) -> None:
        """Continue from a restored state: ``problem.u`` and the interface state must hold it."""
        self.t, self.step, self.dt, self.easy = float(t), int(step), float(dt), int(easy)
        n = self.problem.layout.n_owned
        self.solver.x.array_w[:] = self.problem.u.x.array[:n]
        self._x_converged.array_w[:] = self.solver.x.array_r

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

        cuts = 0
        tol = 1e-12 * max(1.0, abs(t_end))
        segment = _Segment(self.t)
        while self.t < t_end - tol:
            breakpoint_ = min(self.program.next_breakpoint(self.t), t_end)
            nb = min(next_stop(self.t), t_end)
            target = min(self.t + self.dt, nb)
            # do not leave a sliver before a breakpoint
            if nb - target < 0.25 * self.dt:
                target = nb
            dt = target - self.t
            t0 = time.perf_counter()
            r = self.solver.solve(target, dt)
            if not r["converged"]:
                self.solver.x.array_w[:] = self._x_converged.array_r
                self.problem.revert()
                cuts += 1
                segment.cuts += 1
                why = f"SNES reason {r['reason']}"
                if self.solver.failed_points.size:
                    why += f", return map failed at {self.solver.failed_points.size} points"
                logger.debug("  step to t = %.6g (dt %.3g) failed: %s; cutting", target, dt, why)
                self.dt = dt * self.cut
                self.easy = 0
                if cuts > self.max_cuts or self.dt < self.dt_min:
                    raise StepFailure(
                        f"no convergence at t = {target:.6g} with dt = {dt:.3g} ({why}; "
                        f"{cuts} failed attempt(s) since the last converged step, smallest step "
                        f"allowed {self.dt_min:.3g}); the last converged step is "
                        f"{self.step} at t = {self.t:.6g}, whose state is kept",
                        target,
                        self.t,
                        self.step,
                        why,
                    )
                continue
            self.problem.commit()
            self._x_converged.array_w[:] = self.solver.x.array_r
            self.problem.u.x.array[: self.problem.layout.n_owned] = self.solver.x.array_r
            self.problem.u.x.scatter_forward()
            self.step += 1
            self.t = target
            rec = StepRecord(
                self.step, target, dt, r["iterations"], cuts, r["residuals"], r["counts"]
            )
            self.records.append(rec)
            segment.iterations.append(r["iterations"])
            if logger.isEnabledFor(logging.DEBUG):
                c, res = r["counts"], r["residuals"] or [0.0]
                logger.debug(
                    "step %4d  t = %10.5g  dt = %9.3g  newton %2d  |F| %9.2e -> %9.2e  "
                    "plastic %.0f %%  sep %d  (%.2f s)",
                    self.step, target, dt, r["iterations"], res[0], res[-1],
                    100 * rec.plastic_fraction, c.get("SEPARATED", 0), time.perf_counter() - t0,
                )  # fmt: skip
            if target >= breakpoint_ - tol:
                logger.info(segment.line(target, rec))
                segment = _Segment(target)
            cuts = 0
            self.easy = self.easy + 1 if r["iterations"] <= self.easy_iterations else 0
            if self.easy >= self.easy_steps:
                self.dt = min(self.dt * self.grow, self.dt_max)
                self.easy = 0
            if self.on_step is not None:  # last: the stepper's state is that of the next step
                self.on_step(rec)
        return self.records
