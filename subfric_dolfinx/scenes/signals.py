"""The signal guard of a run: a stop request (SIGTERM, SIGUSR1, SIGUSR2) honoured after the step.

Under ``mpirun`` (Open MPI 5), send **SIGUSR1** (or SIGUSR2) to ``mpirun``: it forwards the signal
to every rank and waits; each rank finishes its step, the run writes its checkpoint (if the scene
writes any) and stops with :class:`SceneInterrupted`. SIGTERM sent to ``mpirun`` is forwarded too,
but ``mpirun`` kills the ranks about 0.2 s later, usually before the step ends. A second signal of
the same kind acts as if no guard were installed (e.g. SIGTERM ends the process at once).
"""

from __future__ import annotations

import signal
import threading
from types import TracebackType
from typing import Any

__all__ = ["STOP_SIGNALS", "SceneInterrupted", "StopSignals"]

STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGTERM, signal.SIGUSR1, signal.SIGUSR2)
"""Signals that stop a run cleanly after the current step."""


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
    nothing), on exit it puts the previous handlers back.

    Args:
        signals: The signals to catch (default :data:`STOP_SIGNALS`).
        enabled: Install nothing when false.
    """

    def __init__(
        self, signals: tuple[signal.Signals, ...] = STOP_SIGNALS, enabled: bool = True
    ) -> None:
        self.signals = signals
        self.enabled = enabled
        self.event = threading.Event()
        self.received: signal.Signals | None = None
        self.agreed: signal.Signals | None = None  # the signal all ranks agree on
        self._previous: dict[signal.Signals, Any] = {}

    def _handler(self, signum: int, frame: Any) -> None:
        sig = signal.Signals(signum)
        if self.received == sig:  # the second one: as if there were no guard
            previous = self._previous.get(sig, signal.SIG_DFL)
            signal.signal(sig, previous)
            if callable(previous):
                previous(signum, frame)
            else:
                signal.raise_signal(sig)
            return
        self.received = sig
        self.event.set()

    def __enter__(self) -> StopSignals:
        if self.enabled and threading.current_thread() is threading.main_thread():
            for s in self.signals:
                self._previous[s] = signal.signal(s, self._handler)
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
