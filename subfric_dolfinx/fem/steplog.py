"""The load stepper's log lines: a line per long segment of the program, progress, a line per step.

:class:`~.stepping.LoadStepper` logs (:mod:`subfric_dolfinx.logs`) under its own module's logger,
``subfric_dolfinx.fem.stepping``, through a :class:`RunLog` per run: an INFO line per long segment
of the program (at least :data:`LONG_SEGMENT_STEPS` steps or
:data:`~subfric_dolfinx.logs.PROGRESS_SECONDS` of wall time: its steps, Newton iterations
mean/max, cuts, what the interface does at its end, wall time), and between them a progress line
every :data:`~subfric_dolfinx.logs.PROGRESS_SECONDS` (a run of more than :data:`SEGMENT_LINES`
segments, e.g. many cycles or a program sampled at knots, prints those only); one DEBUG line per
step (the stepper adds one per failed attempt). What the interface does is said as the fractions
of its points that slide (a traction at the law's strength,
:meth:`~subfric_dolfinx.constitutive.FrictionLaw.strength`), stick (closed, below it; the
subloading law's micro-slip included) and are open (:func:`.attempts.interface_activity`,
:func:`activity_text`).
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import logs

if TYPE_CHECKING:
    from .stepping import StepRecord

__all__ = ["LONG_SEGMENT_STEPS", "SEGMENT_LINES", "RunLog", "activity_text"]

LONG_SEGMENT_STEPS = 10
"""A segment of the program of at least this many steps gets its own log line."""
SEGMENT_LINES = 8
"""A run of more program segments than this logs progress lines only, not a line per segment."""


def activity_text(sliding: float, open_: float) -> str:
    """What the interface does, e.g. ``sliding 40 %, sticking 60 %``.

    Args:
        sliding: The fraction of its points that slide.
        open_: The fraction that are open (the others stick).
    """
    parts = [("sliding", sliding), ("sticking", 1.0 - sliding - open_), ("open", open_)]
    return ", ".join(f"{name} {100 * v:.0f} %" for name, v in parts if v > 0.0005) or "no point"


class _Tally:
    """Statistics of the steps since ``t0``, for a log line (a segment, or progress)."""

    def __init__(self, t0: float) -> None:
        self.t0 = t0
        self.iterations: list[int] = []
        self.cuts = 0
        self.line_search = 0
        self.wall = time.perf_counter()

    def add(self, rec: StepRecord) -> None:
        self.iterations.append(rec.iterations)

    def newton(self) -> str:
        its = self.iterations
        return (
            f"{len(its)} step{'s' if len(its) != 1 else ''}, Newton {np.mean(its):.2f} mean / "
            f"{max(its)} max, {self.cuts} cuts, {self.line_search} with the line search"
        )

    def seconds(self) -> float:
        return time.perf_counter() - self.wall

    def segment_line(self, t1: float, last: StepRecord) -> str:
        return (
            f"t = {self.t0:.6g} -> {t1:.6g} s: {self.newton()}; at its end {last.activity}; "
            f"{self.seconds():.2f} s"
        )

    def progress_line(self, t1: float, span: tuple[float, float], last: StepRecord) -> str:
        t_start, t_end = span
        done = 100.0 * (t1 - t_start) / (t_end - t_start) if t_end > t_start else 100.0
        return (
            f"t = {t1:.6g} s of {t_end:.6g} ({done:.0f} %): {self.newton()} since t = "
            f"{self.t0:.6g} s; {last.activity}; {self.seconds():.1f} s"
        )


class RunLog:
    """The log of one :meth:`~.stepping.LoadStepper.run` (the module docstring).

    A line per long segment of the program, progress lines between them, a DEBUG line per step.

    Args:
        t: The run's start.
        t_end: Its end.
        program: The loading program (its breakpoints ``times`` make the segments).
        tol: Times closer than this are one.
        logger: The logger the lines go to (the stepper's).
    """

    def __init__(
        self, t: float, t_end: float, program: Any, tol: float, logger: logging.Logger
    ) -> None:
        self.logger = logger
        self.segment = _Tally(t)
        self.since = _Tally(t)  # since the last line printed
        self.clock = logs.Progress()
        self.span = (t, t_end)
        inner = (program.times > t + tol) & (program.times < t_end - tol)
        self.few_segments = int(np.count_nonzero(inner)) + 1 <= SEGMENT_LINES

    def cut(self) -> None:
        """A failed attempt, cut."""
        self.segment.cuts += 1
        self.since.cuts += 1

    def line_search(self) -> None:
        """A step solved with the retry options."""
        self.segment.line_search += 1
        self.since.line_search += 1

    def step(self, rec: StepRecord, t0: float, segment_ends: bool) -> None:
        """A converged step (started at wall time ``t0``), ending a segment of the program or not.

        Only rank 0 prints: no rank needs to agree on what is printed.
        """
        logger = self.logger
        self.segment.add(rec)
        self.since.add(rec)
        if logger.isEnabledFor(logging.DEBUG):
            res = rec.residuals or (0.0,)
            logger.debug(
                "step %4d  t = %10.5g  dt = %9.3g  newton %2d  |F| %9.2e -> %9.2e  %s  (%.2f s)",
                rec.step,
                rec.t,
                rec.dt,
                rec.iterations,
                res[0],
                res[-1],
                rec.activity,
                time.perf_counter() - t0,
            )
        printed = False
        if segment_ends:
            long_ = len(self.segment.iterations) >= LONG_SEGMENT_STEPS
            if self.few_segments and (long_ or self.segment.seconds() >= self.clock.interval):
                logger.info(self.segment.segment_line(rec.t, rec))
                printed = True
            self.segment = _Tally(rec.t)
        if printed:
            self.clock.reset()
        elif self.clock.due():
            logger.info(self.since.progress_line(rec.t, self.span, rec))
            printed = True
        if printed:
            self.since = _Tally(rec.t)
