"""The signal guard of a run: a stop signal is a request, honoured at a safe point.

While the guard is active (an FE run, from the output directory's creation to its last close),
a signal never raises anything: the handler only counts it.

* The **first** stop signal requests a stop after the current step: every rank finishes the
  step, the run writes its checkpoint (if the scene writes any) and stops with
  :class:`SceneInterrupted`.
* A **second** one (of any of these kinds; a third changes nothing) stops sooner: at the next
  evaluation of the residual (within a Newton iteration), on every rank, the step is abandoned
  and its state reverted to the last converged step; the checkpoint of that state is written
  and the run stops with :class:`SceneInterrupted` too. Nothing is raised inside PETSc's
  callbacks: the solver ends its solve (a function-domain error every rank agrees on), and the
  stepper raises :class:`~subfric_dolfinx.fem.StepInterrupted` outside them.

Under ``mpirun`` (Open MPI 5), send **SIGUSR1** (or SIGUSR2) to ``mpirun``: it forwards the signal
to every rank and waits. ``mpirun`` does not forward SIGINT or SIGTERM: it ends the job itself
(SIGCONT and SIGTERM to the ranks, SIGKILL 0.25 s later; Ctrl-C at a terminal likewise),
leaving the last checkpoint readable (it is written to a temporary file, then renamed; a
temporary file cut short is refused as incomplete). :mod:`.launch` runs ``mpirun`` so that
SIGTERM and SIGINT reach the ranks as SIGUSR1. For a single process
(``python3 demos/x.py``, a script calling :func:`~.runner.run_scene`), Ctrl-C is a clean stop like
SIGUSR1.
"""

from __future__ import annotations

import signal
import threading
from types import TracebackType
from typing import Any

__all__ = ["STOP_SIGNALS", "SceneInterrupted", "StopSignals", "guard_active", "note_stop"]

STOP_SIGNALS: tuple[signal.Signals, ...] = (
    signal.SIGTERM,
    signal.SIGINT,
    signal.SIGUSR1,
    signal.SIGUSR2,
)
"""Signals that stop a run cleanly (after the current step; the second one sooner)."""

_ACTIVE: list[StopSignals] = []  # guards whose handlers are installed (main thread)
_PENDING: list[int] = []  # stop signals noted while no guard was active (see note_stop)


def guard_active() -> bool:
    """Whether a :class:`StopSignals` guard has its handlers installed in this process."""
    return bool(_ACTIVE)


def note_stop(signum: int) -> None:
    """Note a stop signal received while no guard is active (a handler of the command line).

    The next guard to become active counts it as its own: a signal that arrives just before a
    guard takes over is not lost.
    """
    _PENDING.append(int(signum))


class SceneInterrupted(RuntimeError):
    """The run was stopped by a signal (after writing a checkpoint, if the scene writes any).

    Attributes:
        t: Time of the last converged step (``None`` if stopped outside the load stepping).
        checkpoint: Path of the checkpoint written, or ``None``.
    """

    def __init__(self, message: str, t: float | None, checkpoint: str | None) -> None:
        super().__init__(message)
        self.t, self.checkpoint = t, checkpoint


class StopSignals:
    """While active, the given signals only request a stop; :meth:`requested` tells all ranks.

    A context manager: on entry it installs the handlers (main thread only; elsewhere it does
    nothing), on exit it puts the previous handlers back. The handler never raises.

    Args:
        signals: The signals to catch (default :data:`STOP_SIGNALS`).
        enabled: Install nothing when false.

    Attributes:
        count: Stop signals received on this rank.
        received: The first one.
    """

    def __init__(
        self, signals: tuple[signal.Signals, ...] = STOP_SIGNALS, enabled: bool = True
    ) -> None:
        self.signals = signals
        self.enabled = enabled
        self.event = threading.Event()
        self.count = 0
        self.received: signal.Signals | None = None
        self.agreed: signal.Signals | None = None  # the signal all ranks agree on
        self._previous: dict[signal.Signals, Any] = {}

    def _handler(self, signum: int, frame: Any) -> None:
        self.count += 1
        if self.received is None:
            self.received = signal.Signals(signum)
        self.event.set()

    @property
    def urgent(self) -> bool:
        """Whether this rank received a second stop signal (stop within the step).

        Local; :class:`~subfric_dolfinx.fem.FrictionSolver` makes it collective.
        """
        return self.count >= 2

    def __enter__(self) -> StopSignals:
        if self.enabled and threading.current_thread() is threading.main_thread():
            for s in self.signals:
                self._previous[s] = signal.signal(s, self._handler)
            _ACTIVE.append(self)
            while _PENDING:
                self._handler(_PENDING.pop(0), None)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        for s, previous in self._previous.items():
            signal.signal(s, previous)
        self._previous.clear()
        if self in _ACTIVE:
            _ACTIVE.remove(self)

    def requested(self, comm: Any) -> bool:
        """Whether any rank received a stop signal (collective on the MPI communicator ``comm``).

        The signal (the largest number received on any rank) is then in :attr:`agreed`.
        """
        sig = comm.allreduce(int(self.received or 0) if self.event.is_set() else 0, op=_max(comm))
        if sig:
            self.agreed = signal.Signals(sig)
        return sig > 0

    @property
    def name(self) -> str:
        """Name of the agreed signal (``"a signal"`` before one was agreed on)."""
        return self.agreed.name if self.agreed is not None else "a signal"


def _max(comm: Any) -> Any:
    from mpi4py import MPI  # a communicator exists: MPI is loaded already

    return MPI.MAX
