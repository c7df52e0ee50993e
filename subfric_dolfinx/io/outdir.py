"""An output directory belongs to one run at a time, and holds that run's files only.

:class:`OutputDirectory` (a context manager, collective) prepares a run's output directory before
the first step:

1. creates it and makes a test write (:func:`~.collective.probe_directory`): a directory under a
   regular file, on a read-only or full file system fails here, on every rank;
2. takes the lock ``.subfric.lock`` in it (``fcntl.flock``, held by rank 0 for the whole run and
   released when the run ends, however it ends; the kernel releases it if the process dies): a
   second run into the same directory is refused on every rank, naming the directory and the
   process holding it. The lock file is removed when the run ends, and every rank waits for
   that (a barrier): when the context exits, on any rank, the directory is in its final state
   (without the barrier a rank could list it before rank 0 had removed the lock). A killed run
   leaves the lock file unlocked: the next run takes it); a run that locked a file another run
   removed meanwhile sees that the name no longer leads to it and starts again;
3. for a fresh run (not a restart), moves the files an earlier run of this code wrote there
   (:data:`RUN_FILES`: ``history.csv`` and its units, ``interface_history.h5``,
   ``checkpoint.h5``, the ``fields`` directory, a stale ``checkpoint.h5.tmp``) into
   ``previous_run/``, replacing what was there: the directory then holds this run's files only,
   and the last run's files are kept one generation. ``previous_run/`` is deleted only if this
   code made it (it holds the mark :data:`PREVIOUS_MARK`, written when it was made) and it holds
   nothing but such names, or if it is empty: one the user made (no mark: e.g. a directory
   of the user's earlier results under that name), one that holds other files (the user's, at
   its top or in its ``fields/``, e.g. a ParaView state saved beside the fields), or
   a regular file by that name is never deleted, the run is refused naming it (a
   ``previous_run/`` made by a version of this code before the mark is refused too: move it
   or delete it). A restart continues the files it finds (the interface history is cut back to
   the restart time). Other files are left alone.

No file is ever created, truncated or written through a symbolic link (:mod:`.links`): the lock
is opened with ``O_NOFOLLOW`` (a link there is refused, naming it), a link named like a run's
file is moved to ``previous_run/`` as a link, a link named ``previous_run`` is removed (not what
it points to).
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
from pathlib import Path
from types import TracebackType
from typing import Any

from .collective import Failure, OutputError, collective, probe_directory
from .links import open_nofollow

__all__ = ["LOCK_NAME", "PREVIOUS", "PREVIOUS_MARK", "RUN_FILES", "OutputDirectory"]

LOCK_NAME = ".subfric.lock"
PREVIOUS = "previous_run"
PREVIOUS_MARK = ".made-by-subfric-dolfinx"
"""An empty file in ``previous_run/``: this code made the directory (and may replace it)."""
RUN_FILES = (
    "history.csv",
    "history.csv-metadata.json",
    "interface_history.h5",
    "checkpoint.h5",
    "checkpoint.h5.tmp",
    "fields",
)
"""Names this code writes in an output directory (moved aside by a fresh run)."""

FIELD_NAMES = re.compile(
    r"(displacement|stress|interface(_points)?(_.+)?)\.(bp|xdmf|h5)|units\.json|\..+\.spare"
)
"""Names this code writes in ``fields/`` (VTX, XDMF and their HDF5 files; a killed run's spare)."""


class OutputDirectory:
    """The output directory of a run, locked for it (collective context manager).

    Args:
        path: The directory (created).
        comm: The run's communicator.
        fresh: A new run (not a restart): earlier files are moved to ``previous_run/``.

    Attributes:
        moved: Names moved aside (on rank 0; empty elsewhere).

    Raises:
        OutputError: On every rank: the directory is not usable (the OS error named), or
            another run holds it.
    """

    def __init__(self, path: str | Path, comm: Any, fresh: bool = True) -> None:
        self.path = Path(path)
        self.comm = comm
        self.fresh = fresh
        self.moved: list[str] = []
        self._fd: int | None = None

    def __enter__(self) -> OutputDirectory:
        probe_directory(self.comm, self.path)
        holder = collective(
            self.comm,
            self._lock,
            f"locking the output directory {str(self.path)!r}",
            path=self.path / LOCK_NAME,
            share=True,
        )
        if holder is not None:
            raise OutputError(
                f"the output directory {str(self.path)!r} is in use by another run ({holder}); "
                "give each run its own directory",
                self.path,
            )
        if self.fresh:
            try:
                collective(
                    self.comm,
                    self._move_aside,
                    f"moving the earlier run's files in {str(self.path)!r} to {PREVIOUS}/",
                    path=self.path / PREVIOUS,
                )
            except OutputError:
                self._unlock()
                raise
        return self

    def _lock(self) -> str | None:
        """Take the lock (rank 0); a description of the holder when another run has it."""
        path = self.path / LOCK_NAME
        while True:
            fd = open_nofollow(path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                try:
                    who = os.pread(fd, 200, 0).decode(errors="replace").strip()
                finally:
                    os.close(fd)
                return who or "unknown process"
            except BaseException:
                os.close(fd)
                raise
            try:  # the run that held it may have removed it after we opened it
                here, mine = os.stat(path), os.fstat(fd)
                if (here.st_dev, here.st_ino) == (mine.st_dev, mine.st_ino):
                    break
            except FileNotFoundError:
                pass
            os.close(fd)
        self._fd = fd
        try:  # who holds it, for the message of a refused run (best effort)
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pid {os.getpid()} on {os.uname().nodename}\n".encode(), 0)
        except OSError:
            pass
        return None

    def _move_aside(self) -> None:
        found = [n for n in RUN_FILES if os.path.lexists(self.path / n)]
        if not found:
            return
        prev = self.path / PREVIOUS
        if prev.is_symlink():  # the link goes, never what it points to
            prev.unlink()
        elif prev.is_dir():
            names = set(os.listdir(prev))
            foreign = sorted(names - set(RUN_FILES) - {PREVIOUS_MARK})
            fields = prev / "fields"
            if fields.is_dir() and not fields.is_symlink():  # a link is removed, not followed
                inside = os.listdir(fields)
                foreign += sorted(f"fields/{n}" for n in inside if not FIELD_NAMES.fullmatch(n))
            if foreign:
                raise Failure(
                    f"{str(prev)!r} holds files this code did not write ({', '.join(foreign[:3])}"
                    f"{', ...' if len(foreign) > 3 else ''}): not deleted; move or rename it, "
                    "or give another output directory"
                )
            if names and PREVIOUS_MARK not in names:
                raise Failure(
                    f"{str(prev)!r} was not made by this code (no {PREVIOUS_MARK} in it): not "
                    "deleted; move or rename it, or give another output directory"
                )
            shutil.rmtree(prev)  # never follows a link inside (the links themselves go)
        elif os.path.lexists(prev):
            raise Failure(
                f"{str(prev)!r} is a file this code did not write: not deleted; move or rename "
                "it, or give another output directory"
            )
        prev.mkdir()
        os.close(open_nofollow(prev / PREVIOUS_MARK, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        for n in found:
            os.replace(self.path / n, prev / n)
        self.moved = found

    def _unlock(self) -> None:
        """Remove the lock file, then release the lock (rank 0).

        In that order, no run can take a lock on a file about to disappear without seeing it
        (see :meth:`_lock`).
        """
        if self._fd is not None:
            fd, self._fd = self._fd, None
            try:
                (self.path / LOCK_NAME).unlink(missing_ok=True)
            except OSError:  # e.g. the directory became read-only: the lock is released anyway
                pass
            try:
                fcntl.flock(fd, fcntl.LOCK_UN)
            finally:
                os.close(fd)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Unlock (rank 0), then wait for every rank: the directory is final on each one.

        Also while an error unwinds: this package raises its errors on every rank (collective
        errors), so every rank comes here.
        """
        try:
            self._unlock()
        finally:
            self.comm.Barrier()
