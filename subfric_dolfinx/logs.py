"""The package's log: one logger, a handler printing on rank 0, the rank of a serial program.

Under ``mpirun``, a numpy-only program finds its rank with :func:`launcher_rank`; a child process
started from a rank gets :func:`singleton_environment` so that it does not join the job.

Every module logs to a child of the ``subfric_dolfinx`` logger (``logging.getLogger(__name__)``).
As a library, the package installs no output handler of its own and prints nothing but its
warnings; a program (a script, a notebook) calls :func:`show_progress` once to see a line per
load step, or :func:`configure` for another level::

    from subfric_dolfinx import logs
    logs.show_progress(MPI.COMM_WORLD)                 # a progress line per step, on rank 0
    logs.configure(verbosity=0, comm=MPI.COMM_WORLD)   # -1 warnings, 0 info, 1 debug

Levels: INFO for the run's size and summary, a line per long segment of the loading program and a
progress line every :data:`PROGRESS_SECONDS` (less often as a long run goes on:
:data:`PROGRESS_SPREAD`), DEBUG for one line per load step and per failed
attempt.

**Warnings about the model's validity** (a penetration or a slide the small-sliding interface no
longer describes, a law's ``mu_s`` that looks like a friction coefficient) are not log records:
they go through :func:`warn`, i.e. :func:`warnings.warn` with a :class:`SubfricWarning` category,
so that every user sees them in a plain script without configuring anything, and the standard
filters apply (``warnings.simplefilter("error", SubfricWarning)`` makes them errors, ``"ignore"``
silences them). Under MPI every rank evaluates the filters alike (an ``"error"`` filter raises on
every rank, never on one alone) and rank 0 shows the warning: one line per job, not one per rank.
"""

from __future__ import annotations

import logging
import os
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

__all__ = [
    "LOGGER_NAME",
    "PROGRESS_SECONDS",
    "PROGRESS_SPREAD",
    "OutputWarning",
    "OverhangWarning",
    "PenetrationWarning",
    "Progress",
    "SlideWarning",
    "SubfricWarning",
    "UnitsWarning",
    "configure",
    "launcher_rank",
    "level_for",
    "show_progress",
    "singleton_environment",
    "warn",
]

LOGGER_NAME = "subfric_dolfinx"
logging.getLogger(LOGGER_NAME).addHandler(logging.NullHandler())


def level_for(verbosity: int) -> int:
    """Logging level of a verbosity: <= -1 WARNING, 0 INFO, >= 1 DEBUG."""
    if verbosity <= -1:
        return logging.WARNING
    return logging.INFO if verbosity == 0 else logging.DEBUG


class _Handler(logging.StreamHandler):
    """The package's own handler (:func:`configure` replaces it, and no other)."""

    _subfric = True


class _RankFilter(logging.Filter):
    def __init__(self, rank: int) -> None:
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        return self.rank == 0


def configure(
    verbosity: int = 0, comm: Any = None, stream: TextIO | None = None
) -> logging.Handler:
    """Print the package's log on rank 0 of ``comm`` (all processes print if ``comm`` is None).

    Calling it again replaces the handler it installed before.

    Args:
        verbosity: -1 (warnings only), 0 (info: a line per segment and the summary), 1 (debug:
            a line per step).
        comm: MPI communicator; only its rank 0 prints.
        stream: Where to print (default ``sys.stdout``).

    Returns:
        The installed handler.
    """
    logger = logging.getLogger(LOGGER_NAME)
    for h in list(logger.handlers):
        if getattr(h, "_subfric", False):
            logger.removeHandler(h)
    handler = _Handler(stream or sys.stdout)
    handler.setFormatter(logging.Formatter("%(message)s"))
    handler.addFilter(_RankFilter(0 if comm is None else comm.rank))
    logger.addHandler(handler)
    logger.setLevel(level_for(verbosity))
    logger.propagate = False
    return handler


def show_progress(comm: Any = None, stream: TextIO | None = None) -> logging.Handler:
    """Print a progress line per converged load step on rank 0 of ``comm``: the library's log.

    For a script or a notebook that calls the library (``run_scene``, ``LoadStepper.run``,
    ``run_case``): each step's number, time, step size, Newton iterations, residuals, what the
    interface does and the elapsed time, each failed attempt, and the run's size and summary.
    ``configure(1, comm, stream)``; ``configure(0, comm)`` prints a line per long segment of the
    program instead, ``logs.configure(-1)`` warnings only.

    Args:
        comm: MPI communicator; only its rank 0 prints (``None``: every process prints).
        stream: Where to print (default ``sys.stdout``).

    Returns:
        The installed handler.
    """
    return configure(1, comm, stream)


PROGRESS_SECONDS = 10.0
"""A long run prints a progress line at most this often (wall seconds): the FE load stepping
(INFO, when no other line came in between) and the material-point driver's command line."""

PROGRESS_SPREAD = 3.0
"""Later progress lines come further apart: the gap after a line is at least the time the run had
taken at that line over ``PROGRESS_SPREAD`` (and :data:`PROGRESS_SECONDS`), so the number of
progress lines grows with the logarithm of the run's length: 12 in 7 minutes, 19 in an hour."""


class Progress:
    """A clock that says when the next progress line is due.

    A line ``interval`` s after the last one at the earliest, and not before the time elapsed at
    the last line over :data:`PROGRESS_SPREAD`: lines at 10, 20, 30, 40, 53, 71, 95 ... s (an
    ``interval`` of 0: a line at every call).

    Args:
        interval: Seconds between two lines at least (default :data:`PROGRESS_SECONDS`).
    """

    def __init__(self, interval: float | None = None) -> None:
        self.interval = float(PROGRESS_SECONDS if interval is None else interval)
        self.start = self.last = time.monotonic()

    def due(self) -> bool:
        """True (and the clock restarts) when the next line's time has come."""
        now = time.monotonic()
        spread = (self.last - self.start) / PROGRESS_SPREAD if self.interval > 0.0 else 0.0
        gap = max(self.interval, spread)  # an interval of 0: a line at every call
        if now - self.last < gap:
            return False
        self.last = now
        return True

    def reset(self) -> None:
        """Another line was just printed: the next progress line is due ``interval`` from now."""
        self.last = time.monotonic()

    @property
    def elapsed(self) -> float:
        """Seconds since the clock was made."""
        return time.monotonic() - self.start


class SubfricWarning(UserWarning):
    """A result the model may not describe: it is used outside what it was made for."""


class PenetrationWarning(SubfricWarning):
    """The normal penalty lets the bodies interpenetrate more than the contact can tolerate."""


class SlideWarning(SubfricWarning):
    """A slide longer than the small-sliding interface (pairs fixed at the reference) describes."""


class OverhangWarning(SubfricWarning):
    """A finite-sliding contact leaves its primary surface: a pressed secondary facet past it."""


class OutputWarning(UserWarning):
    """An output file written with less than it could hold (a VTX file without its units)."""


class UnitsWarning(SubfricWarning):
    """A parameter that looks given in another unit: a friction coefficient as ``mu_s`` (MPa)."""


_PACKAGE_DIR = str(Path(__file__).resolve().parent)


def warn(message: str, category: type[Warning] = SubfricWarning, comm: Any = None) -> None:
    """Issue a warning once per MPI job: the filters act on every rank, rank 0 shows it.

    The warning is attributed to the first frame outside this package (the user's call, e.g.
    ``run_scene(...)`` or ``stepper.run()``). Every rank of ``comm`` must call it with the same
    message (it is not collective: nothing is communicated), so that a filter that turns it into
    an error raises on every rank.

    Args:
        message: The text.
        category: A :class:`SubfricWarning` subclass.
        comm: MPI communicator (``None``: this process alone shows it).
    """
    where: dict[str, Any] = (
        {"skip_file_prefixes": (_PACKAGE_DIR,)} if sys.version_info >= (3, 12) else {}
    )
    with warnings.catch_warnings(record=True) as caught:  # the user's filters still apply
        warnings.warn(message, category, stacklevel=2, **where)
    if comm is not None and comm.rank != 0:
        return
    for w in caught:
        show: Callable[..., None] = warnings.showwarning
        if _swallowed():  # what showwarning was before logging took it over
            show = getattr(logging, "_warnings_showwarning", None) or _to_stderr
        show(w.message, w.category, w.filename, w.lineno, w.file, w.line)


def _to_stderr(message: Any, category: Any, filename: str, lineno: int, *_: Any) -> None:
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno))


def _swallowed() -> bool:
    """Would :func:`warnings.showwarning` drop a warning?

    True when it is logging's (after ``logging.captureWarnings(True)``, which FFCx 0.9 calls when
    it is imported) and no handler but a ``NullHandler`` would receive the ``py.warnings`` record
    (logging adds one to that logger): every warning of a DOLFINx 0.9 program vanishes then.
    """
    if getattr(warnings.showwarning, "__module__", None) != "logging":
        return False
    logger: logging.Logger | None = logging.getLogger("py.warnings")
    while logger is not None:
        if any(not isinstance(h, logging.NullHandler) for h in logger.handlers):
            return False
        logger = logger.parent if logger.propagate else None
    return True


_LAUNCHED = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK")
_RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK")


def launcher_rank() -> int:
    """This process's rank when an MPI launcher started it, else 0; MPI is not initialised.

    The numpy-only programs (the material-point driver, the calibration, their demos) have
    nothing to distribute: under ``mpirun -n N`` rank 0 computes and writes, and the others
    return at once instead of writing the same files side by side. The rank is read from the
    launcher's environment (Open MPI, MPICH/Hydra, PMIx), so mpi4py is not needed.
    """
    if not any(k in os.environ for k in _LAUNCHED):
        return 0
    for k in _RANK_VARIABLES:
        value = os.environ.get(k, "")
        if value.isdigit():
            return int(value)
    return 0


_LAUNCHER_PREFIXES = ("OMPI_", "PMI_", "PMIX_", "PRTE_", "HYDRA_")
_LAUNCHER_KEEP = {
    "OMPI_ALLOW_RUN_AS_ROOT",
    "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
    "OMPI_MCA_btl",
    "PRTE_MCA_hwloc_default_binding_policy",
    "PRTE_MCA_bindto",
    "OMPI_MCA_mpi_yield_when_idle",
}


def singleton_environment() -> dict[str, str]:
    """This process's environment without the variables of the MPI job that started it.

    A child started from an MPI rank would otherwise try to join the parent's job; without them
    it starts as an MPI singleton (or as its own ``mpirun``). Open MPI's settings that are not
    about the job (running as root, the transport, binding to cores, yielding when idle) are kept.
    """
    return {
        k: v
        for k, v in os.environ.items()
        if k in _LAUNCHER_KEEP or not k.startswith(_LAUNCHER_PREFIXES)
    }
