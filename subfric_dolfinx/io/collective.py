"""Collective output: an I/O failure on any rank ends in the same error on every rank.

Every piece of output goes through one of two patterns:

* :func:`collective` with ``root=0``: rank 0 does the work (a CSV row, a rename, a directory)
  inside ``try``; the outcome is broadcast and every rank raises the same error, naming the file
  and the OS error.
* :func:`collective` with ``root=None``: every rank does its part (an HDF5 call through h5py's
  MPI driver, an ADIOS2 write); the ranks *agree* on the outcome before anyone goes on to the next
  collective call, so a rank that failed never leaves the others waiting in one. The message is
  that of the lowest failing rank, the same everywhere.

:func:`probe_directory` creates a directory and makes a test write in it (rank 0), so an output
directory under a regular file, on a read-only or full file system fails before the first step.
MPI-IO reports a failed write without its OS error (``MPI_ERR_OTHER``); :func:`diagnose` adds
what a test write in the file's directory says (e.g. ``[Errno 28] No space left on device``).
"""

from __future__ import annotations

import errno
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from mpi4py import MPI

from .links import refuse_links

__all__ = [
    "Failure",
    "OutputError",
    "agree",
    "collective",
    "diagnose",
    "ensure_space",
    "probe_directory",
    "reason",
]

T = TypeVar("T")

PROBE_NAME = ".subfric-probe"
PROBE_BYTES = 4096


class OutputError(RuntimeError):
    """An output file or directory could not be written (the same message on every rank).

    Attributes:
        path: The file or directory concerned.
    """

    def __init__(self, message: str, path: str | Path | None = None) -> None:
        super().__init__(message)
        self.path = None if path is None else str(path)


class Failure(Exception):
    """A failure described in plain words (its message is the reason, without a type name)."""


def reason(e: BaseException) -> str:
    """A short description of an exception.

    ``[Errno 28] No space left on device`` for an OS error (the file is named by the caller), the
    message of a :class:`Failure`, the type and message otherwise.
    """
    if isinstance(e, OSError) and e.errno is not None and e.strerror:
        return f"[Errno {e.errno}] {e.strerror}"
    if isinstance(e, Failure):
        return str(e)
    text = str(e).strip() or repr(e)
    return f"{type(e).__name__}: {text}"


def agree(comm: Any, error: Any) -> Any:
    """The error of the lowest failing rank, on every rank; ``None`` if no rank failed.

    ``error`` is any picklable description (``None``: this rank did not fail). Collective: one
    ``allreduce``, and a ``bcast`` only after a failure.
    """
    first = comm.allreduce(comm.rank if error is not None else comm.size, op=MPI.MIN)
    if first == comm.size:
        return None
    return comm.bcast(error, root=first)


def collective(
    comm: Any,
    fn: Callable[[], T],
    what: str,
    *,
    root: int | None = 0,
    error: type[Exception] = OutputError,
    path: str | Path | None = None,
    share: bool = False,
    cleanup: Callable[[], None] | None = None,
    partial: Callable[[str], None] | None = None,
) -> T | None:
    """Call ``fn()`` on ``root`` (or on every rank); if it raised anywhere, raise on every rank.

    The error raised is ``error("<what> failed: <reason>")``, the same on every rank, or the
    exception itself if ``fn`` raised an ``error`` (collective).

    Args:
        comm: The communicator.
        fn: The work.
        what: What is done, naming the file (``"writing '/out/history.csv'"``).
        root: The rank that does the work, or ``None`` for all.
        error: The exception type raised on every rank.
        path: The file, passed to :class:`OutputError` (and used by :func:`diagnose` when the
            reason carries no OS error).
        share: Broadcast the root's result to every rank (``root`` not ``None``).
        cleanup: Called on every rank after a failure, before raising (its own errors are
            ignored): e.g. closing the half-written file.
        partial: Called on every rank, with the message, when ``fn`` failed on some ranks
            only (``root`` ``None``), before ``cleanup``.

    Returns:
        ``fn()``'s result where it ran (on every rank with ``share``), ``None`` elsewhere.
    """
    result, failed = None, None
    if root is None or comm.rank == root:
        try:
            result = fn()
        except error as e:  # already the error to raise, with its full message
            failed = (True, str(e))
        except Exception as e:
            failed = (False, reason(e))
    here = failed is not None
    failed = agree(comm, failed)
    if failed is not None:
        verbatim, text = failed
        if partial is not None and root is None and comm.allreduce(int(here)) < comm.size:
            partial(text if verbatim else f"{what} failed: {text}")
        if cleanup is not None:
            try:
                cleanup()
            except Exception:
                pass
        if not verbatim:
            if path is not None and "Errno" not in text:
                text += diagnose(comm, Path(path).parent)
            text = f"{what} failed: {text}"
        raise error(text, path) if issubclass(error, OutputError) else error(text)
    if share and root is not None:
        result = comm.bcast(result, root=root)
    return result


def _test_write(directory: Path) -> None:
    probe = directory / f"{PROBE_NAME}-{os.getpid()}"
    try:
        if os.path.islink(probe):  # a planted link: removed, never written through (.links)
            probe.unlink()
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        try:
            os.write(fd, b"\0" * PROBE_BYTES)
            os.fsync(fd)
        finally:
            os.close(fd)
    finally:
        try:
            probe.unlink()
        except FileNotFoundError:
            pass


def probe_directory(comm: Any, directory: str | Path, link_ok: bool = True) -> Path:
    """Create ``directory`` (and its parents) and make a test write in it (rank 0; collective).

    Args:
        comm: The communicator.
        directory: The directory.
        link_ok: Whether ``directory`` may be a symbolic link (the output directory the user
            gave may; a subdirectory this package makes in it may not, :mod:`.links`).

    Raises:
        OutputError: On every rank, naming the directory and the OS error (a path under a
            regular file, a read-only or full file system, no permission, a link refused).
    """
    d = Path(directory)

    def probe() -> None:
        if not link_ok:
            refuse_links(d)
        if d.exists() and not d.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR))
        d.mkdir(parents=True, exist_ok=True)
        _test_write(d)

    collective(comm, probe, f"preparing the output directory {str(d)!r}", path=d / PROBE_NAME)
    return d


def diagnose(comm: Any, directory: Path) -> str:
    """What a test write in ``directory`` says (rank 0; collective).

    ``"; a test write in DIR gives [Errno 28] No space left on device"``, or the space left when
    it succeeds.
    """
    text = ""
    if comm.rank == 0:
        try:
            _test_write(directory)
            free = shutil.disk_usage(directory).free
            text = f" ({free} bytes free on the file system of {str(directory)!r})"
        except OSError as e:
            text = f"; a test write in {str(directory)!r} gives {reason(e)}"
        except Exception:
            text = ""
    return comm.bcast(text, root=0)


def ensure_space(comm: Any, directory: Path, need: int, what: str) -> None:
    """Refuse a write of about ``need`` bytes when the file system has less free (collective).

    Rank 0 looks at the file system of ``directory``.

    Used before writes that cannot recover from a full disk (ADIOS2 and DOLFINx's collective
    HDF5 writes stop a rank inside an MPI collective): the run ends in a clear error instead.

    Raises:
        OutputError: On every rank, with the free and the needed bytes.
    """

    def look() -> None:
        free = shutil.disk_usage(directory).free
        if free < need:
            raise OSError(
                errno.ENOSPC,
                f"No space left on device: {free} bytes free on the file system of "
                f"{str(directory)!r}, about {need} needed",
            )

    collective(comm, look, what, path=directory)
