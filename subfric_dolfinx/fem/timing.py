"""Wall time per section of a run: the problem's own timers and PETSc's linear-solver events."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator

from mpi4py import MPI
from petsc4py import PETSc

__all__ = [
    "LINEAR_EVENTS",
    "TIMER_BULK",
    "TIMER_INTERFACE",
    "TIMER_PROJECTION",
    "TIMER_RETURN_MAP",
    "TIMER_SEARCH",
    "TIMER_SETUP",
    "Timings",
    "event_time",
    "event_times",
    "format_breakdown",
    "timing_breakdown",
]

TIMER_SETUP = "setup"
TIMER_BULK = "bulk assembly"
TIMER_RETURN_MAP = "return map"
TIMER_INTERFACE = "interface assembly"
# Finite sliding (nested in the sections above, not added to them): the per-step search
# (normals, exchange, reach, the projections at the step's start) and the per-iteration
# projections with the segments of the transfer.
TIMER_SEARCH = "contact search"
TIMER_PROJECTION = "contact projection"


class Timings:
    """Accumulated wall time per section (``time.perf_counter``)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}

    @contextlib.contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        """Time the enclosed block under ``name``."""
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0
            self.calls[name] = self.calls.get(name, 0) + 1


# Linear-solver sections of the breakdown and the PETSc log events they come from. With SNES in
# PETSc 3.22 the factorisation (PCSetUp, reached through KSPSetUp) is logged outside KSPSolve, so
# the two do not overlap; with a direct solver the factorisation is usually the larger.
LINEAR_EVENTS = {"factorisation": "PCSetUp", "linear solve": "KSPSolve"}


def event_time(name: str) -> float:
    """Cumulative seconds of a PETSc log event in this process (``nan`` without logging)."""
    try:
        return float(PETSc.Log.Event(name).getPerfInfo()["time"])
    except Exception:  # logging not started
        return float("nan")


def event_times() -> dict[str, float]:
    """Current cumulative time of every event of :data:`LINEAR_EVENTS` (a starting point)."""
    return {e: event_time(e) for e in LINEAR_EVENTS.values()}


def timing_breakdown(problem, start: dict[str, float] | None = None) -> dict[str, float]:
    """Wall seconds per section of a run, maximum over ranks (collective).

    Set-up, bulk assembly, return map and interface assembly come from the problem's timers; the
    factorisation and the linear solve are PETSc's ``PCSetUp`` and ``KSPSolve`` events (``nan``
    unless logging was started with ``PETSc.Log.begin()`` before the run). PETSc's events are
    cumulative over the process: with ``start`` (from :func:`event_times`, e.g. a solver's
    ``event_start``) only the time since then is counted, so several runs in one process each get
    their own numbers.
    """
    out = {
        k: problem.timings.seconds.get(k, 0.0)
        for k in (TIMER_SETUP, TIMER_BULK, TIMER_RETURN_MAP, TIMER_INTERFACE)
    }
    for section, event in LINEAR_EVENTS.items():
        out[section] = event_time(event) - (start or {}).get(event, 0.0)
    return {k: problem.comm.allreduce(v, op=MPI.MAX) for k, v in out.items()}


def format_breakdown(breakdown: dict[str, float], total: float | None = None) -> str:
    """A one-table text of :func:`timing_breakdown` (plus the total wall time if given)."""
    lines = ["timing breakdown (s, max over ranks):"]
    for k, v in breakdown.items():
        lines.append(f"  {k:20s} {v:9.3f}")
    if total is not None:
        lines.append(f"  {'total run':20s} {total:9.3f}")
    return "\n".join(lines)
