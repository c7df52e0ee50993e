"""An HDF5 file opened on all ranks with h5py's MPI driver, every call agreed between ranks.

h5py's MPI driver (``driver="mpio"``, Debian's ``python3-h5py-mpi``) lets every rank write its own
slab of a dataset: memory stays local to each rank. Its calls are of two kinds: metadata calls
(open, create a dataset, resize, write an attribute, flush, close) must be made by all ranks with
the same arguments; data transfers are independent (each rank writes or reads its own selection,
possibly empty). The rules followed here hold on a full file system with Open MPI 5 (OMPIO and
ROMIO) and HDF5 1.14 and 2.2:

* data transfers are *independent*, never collective: a collective MPI-IO write that fails on one
  rank leaves the other inside ``MPI_File_write_at_all`` (a hang); an independent one returns the
  error on the rank where it happened;
* after every call the ranks agree on the outcome (:func:`~.collective.agree`) before anyone makes
  the next collective call; after a failure every rank closes the file (errors ignored) and
  raises the same error;
* a metadata call that failed on some ranks only (which HDF5's arguments, the same on every rank,
  make unlikely: a local fault such as memory) leaves the ranks with different metadata: no
  rank can close the file then (the close hangs, and so does the implicit close at exit).
  Every rank then prints the error and the job ends with ``MPI_Abort`` (exit 1): a clear error
  instead of a hang;
* datasets are created with ``fill_time="never"`` (every byte is written by its owner), so
  creating one writes nothing;
* a full disk must not strike inside a collective call either: HDF5 writes its metadata during
  ``flush`` and ``close``, where a rank that fails leaves the other inside ``MPI_File_sync``
  (a hang). So before the calls that make a file grow, rank 0 *reserves* the disk
  blocks they will need (:meth:`ParallelH5.reserve`: ``fallocate`` with ``FALLOC_FL_KEEP_SIZE``
  beyond the end of the file, an estimate with a margin): a full disk fails there, on rank 0
  alone and before any HDF5 call, and every rank raises. The blocks left unused beyond the end
  are given back when the file is closed (:meth:`ParallelH5.close` trims it);
* closing a file after a failure writes its dirty metadata too, and HDF5 2.2 (Debian sid) aborts
  the process (an assertion in its metadata cache, ``H5C_apply_candidate_list``) when that write
  finds the disk full, where HDF5 1.14 returned an error. So a file opened for writing keeps a
  *spare*: rank 0 allocates :data:`SPARE` bytes in a hidden file beside it
  (``.<name>.spare``) before HDF5 opens it, and deletes it before closing after a failure (and
  after every close), so that the close always finds room. A disk too full for the spare fails
  before the file is opened.

With a serial h5py (no MPI) one rank still works (the default driver); more ranks are refused
with a clear error.
"""

from __future__ import annotations

import ctypes
import errno
import os
import sys
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any, TypeVar, overload

from .collective import OutputError, collective, reason
from .links import open_nofollow, refuse_links

__all__ = ["MARGIN", "SPARE", "ParallelH5"]

MARGIN = 64 << 10
"""Bytes reserved beyond the estimate of what a group of calls writes (metadata, B-tree nodes)."""

SPARE = 64 << 10
"""Bytes kept free for the close of a file opened for writing (see the module's docstring)."""

T = TypeVar("T")


_fallocate: Callable[[int, int, int, int], int] | None
try:
    _libc = ctypes.CDLL(None, use_errno=True)
    _fn = _libc.fallocate
    _fn.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong]
    _fn.restype = ctypes.c_int
    _fallocate = _fn
except (OSError, AttributeError):  # no Linux fallocate: no reservation
    _fallocate = None
KEEP_SIZE = 1  # FALLOC_FL_KEEP_SIZE


def preallocate(path: Path, nbytes: int) -> None:
    """Allocate disk blocks for ``nbytes`` beyond the end of ``path`` without changing its size.

    Raises:
        OSError: ``ENOSPC`` when the file system has not that much room (other refusals of
            ``fallocate``: nothing is reserved).
    """
    fd = open_nofollow(path, os.O_WRONLY)
    try:
        if _fallocate is None:
            return
        if _fallocate(fd, KEEP_SIZE, os.fstat(fd).st_size, int(nbytes)) != 0:
            e = ctypes.get_errno()
            if e not in (errno.EINVAL, errno.EOPNOTSUPP, errno.ENOSYS):
                raise OSError(e, os.strerror(e))
    finally:
        os.close(fd)


def spare_path(path: Path) -> Path:
    """The hidden file that holds the spare of ``path``."""
    return path.with_name(f".{path.name}.spare")


def make_spare(path: Path, nbytes: int) -> None:
    """Allocate ``nbytes`` of disk in :func:`spare_path`.

    The spare is created, or replaced if a killed run left it; never opened through a link.

    Raises:
        OSError: ``ENOSPC`` when the file system has not that much room.
    """
    spare = spare_path(path)
    fd = open_nofollow(spare, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        if _fallocate is not None and _fallocate(fd, 0, 0, int(nbytes)) != 0:
            e = ctypes.get_errno()
            if e not in (errno.EINVAL, errno.EOPNOTSUPP, errno.ENOSYS):
                raise OSError(e, os.strerror(e))
    except BaseException:
        os.close(fd)
        fd = -1
        spare.unlink(missing_ok=True)
        raise
    finally:
        if fd >= 0:
            os.close(fd)


def drop_spare(path: Path) -> None:
    """Delete the spare of ``path`` (if any): its blocks are free again."""
    try:
        spare_path(path).unlink(missing_ok=True)
    except OSError:
        pass


def trim(path: Path) -> None:
    """Give back the blocks reserved beyond the end of ``path``.

    A shrinking truncate frees every block past the new end: grow by one byte, shrink back.
    """
    fd = open_nofollow(path, os.O_WRONLY)
    try:
        size = os.fstat(fd).st_size
        os.ftruncate(fd, size + 1)
        os.ftruncate(fd, size)
    finally:
        os.close(fd)


def _open(path: Path, mode: str, comm: Any) -> Any:
    import h5py

    if mode != "r":  # HDF5 cannot be told O_NOFOLLOW (.links)
        refuse_links(path)
    if h5py.get_config().mpi:
        return h5py.File(path, mode, driver="mpio", comm=comm)
    if comm.size == 1:
        return h5py.File(path, mode)
    raise RuntimeError(
        f"this h5py has no MPI support and cannot open a file on {comm.size} ranks "
        "(install Debian's python3-h5py-mpi, or run on one rank)"
    )


class ParallelH5:
    """An HDF5 file open on every rank of ``comm``; a context manager (closes on exit).

    Args:
        path: The file.
        mode: h5py's mode (``"r"``, ``"w"``, ``"a"``, ``"r+"``).
        comm: The communicator (all its ranks take part in every call).
        what: What is being done, naming the file, for the messages
            (``"writing the checkpoint '/out/checkpoint.h5'"``).
        error: The exception raised on every rank when a call fails.
        open_hint: Added to the message when opening fails (e.g. ``"not a readable HDF5 file"``).

    Raises:
        error: Opening failed on some rank (on every rank).
    """

    def __init__(
        self,
        path: str | Path,
        mode: str,
        comm: Any,
        what: str,
        error: type[Exception] = OutputError,
        open_hint: str = "",
    ) -> None:
        self.path = Path(path)
        self.comm = comm
        self.what = what
        self.error = error
        self.f: Any = None
        self._spare = mode != "r"
        try:
            if self._spare:
                self.call(lambda _: make_spare(self.path, SPARE), root=0)
            self.f = self.call(lambda _: _open(self.path, mode, comm), hint=open_hint, meta=True)
        except error:
            raise
        except Exception as e:  # a bug, not an I/O error: still on every rank
            raise error(f"{what} failed: {reason(e)}") from None

    @overload
    def call(
        self, fn: Callable[[Any], T], *, root: None = None, meta: bool = False, hint: str = ""
    ) -> T: ...

    @overload
    def call(
        self, fn: Callable[[Any], T], *, root: int, meta: bool = False, hint: str = ""
    ) -> T | None: ...

    def call(
        self,
        fn: Callable[[Any], T],
        *,
        root: int | None = None,
        meta: bool = False,
        hint: str = "",
    ) -> T | None:
        """Call ``fn(file)`` and agree on the outcome; after a failure anywhere, close and raise.

        Args:
            fn: The calls: HDF5 metadata calls (``meta``: open, create, resize, attributes,
                flush, close; on every rank), or independent transfers (each rank its own slab,
                or ``root`` alone), never both.
            root: The only rank calling ``fn`` (independent transfers only).
            meta: ``fn`` makes collective metadata calls: a failure on some ranks only ends
                the job (see the module's docstring).
            hint: Added to the message after a failure.

        Returns:
            ``fn``'s result where it ran (``None`` elsewhere).

        Raises:
            error: If ``fn`` failed on any rank: on every rank, after closing the file.
        """
        return collective(
            self.comm,
            lambda: fn(self.f),
            self.what + (f" ({hint})" if hint else ""),
            root=root,
            error=self.error,
            path=self.path,
            cleanup=self.abort,
            partial=self._diverged if meta else None,
        )

    def _diverged(self, message: str) -> None:
        """A metadata call failed on some ranks only: print the error, end the job."""
        sys.stderr.write(
            f"{self.error.__name__}: {message}; the "
            "file's metadata now differ between the ranks and no rank can close it: ending "
            "the job (MPI_Abort)\n"
        )
        sys.stderr.flush()
        self.comm.Barrier()
        self.comm.Abort(1)

    def reserve(self, nbytes: int) -> None:
        """Allocate ``nbytes + MARGIN`` bytes beyond the end of the file (rank 0; collective).

        They are for the calls up to the next flush; a full disk raises here. File systems
        without ``fallocate`` (glibc then writes zeros) or refusing it (``EINVAL``,
        ``EOPNOTSUPP``) get no reservation.
        """
        self.call(lambda f: preallocate(self.path, int(nbytes) + MARGIN), root=0)

    def size(self) -> int:
        """The file's size on disk now (rank 0; other ranks get 0)."""
        if self.comm.rank != 0:
            return 0
        try:
            return self.path.stat().st_size
        except OSError:
            return 0

    def abort(self) -> None:
        """Close the file after a failure, on every rank, ignoring errors (collective).

        The spare is deleted first, so that the metadata HDF5 writes while closing find room.
        """
        f, self.f = self.f, None
        if self._spare and self.comm.rank == 0:
            drop_spare(self.path)
        if f is None:
            return
        try:
            f.close()
        except Exception:
            pass
        try:  # a close that failed may leave the id open: close it for good, or h5py's
            # finaliser would try again at exit (after MPI_Finalize)
            if f.id.valid:
                f.id.close()
        except Exception:
            pass
        if self.comm.rank == 0:
            try:
                trim(self.path)
            except Exception:
                pass
        # every rank returns with the file in its final state (trimmed, spare deleted)
        self.comm.Barrier()

    def close(self) -> None:
        """Flush and close the file, trim what it did not use (collective).

        A failure is raised on every rank.
        """
        if self.f is None:
            return
        try:
            self.call(lambda f: f.close(), meta=True)
        finally:
            self.abort()  # trims, deletes the spare; ends with a barrier

    def __enter__(self) -> ParallelH5:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
