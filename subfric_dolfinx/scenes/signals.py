"""The signal guard of a run: a stop request (SIGTERM) honoured after the current step."""

from __future__ import annotations

import signal
import threading
from types import TracebackType
from typing import Any

__all__ = ["SceneInterrupted", "StopSignals"]


class SceneInterrupted(RuntimeError):
    """The run was stopped by a signal after writing a checkpoint.

    Attributes:
        t: Time of the checkpoint.
        checkpoint: Its path.
    """

    def __init__(self, message: str, t: float, checkpoint: str) -> None:
        super().__init__(message)
        self.t, self.checkpoint = t, checkpoint


class StopSignals:
    """While active, the given signals only request a stop; :meth:`requested` tells all ranks.

    A context manager: on entry it installs the handlers (main thread only; elsewhere it does
    nothing), on exit it puts the previous handlers back.

    Args:
        signals: The signals to catch (default: SIGTERM).
        enabled: Install nothing when false (e.g. a run that writes no checkpoint).
    """

    def __init__(
        self, signals: tuple[signal.Signals, ...] = (signal.SIGTERM,), enabled: bool = True
    ) -> None:
        self.signals = signals
        self.enabled = enabled
        self.event = threading.Event()
        self.received: signal.Signals | None = None
        self._previous: dict[signal.Signals, Any] = {}

    def _handler(self, signum: int, frame: Any) -> None:
        self.received = signal.Signals(signum)
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
        """Whether any rank received a stop signal (collective on the MPI communicator ``comm``)."""
        return comm.allreduce(int(self.event.is_set())) > 0
