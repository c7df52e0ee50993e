"""An output directory belongs to one run at a time; a run touches only files it wrote.

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
3. reads the directory's list of the files runs of this code wrote there, the *manifest*
   :data:`MANIFEST` (JSON; written atomically: a new file renamed over). A file is this code's
   only if a manifest lists it: a name alone proves nothing (a user's ``history.csv`` is the
   user's). The names this run will write (``files``: relative, ``/`` inside, each confirmed
   inside the directory, :func:`~.paths.inside`) that are already there and not listed are
   another's: the run is refused on every rank, naming them (a symbolic link among them named
   as such), and nothing is touched;
4. for a fresh run (not a restart), moves every file the manifest lists (the earlier run's, all
   of them: ``interface_history_<name>.h5`` of another set of interfaces too) into
   ``previous_run/`` with their manifest, replacing what was there: the directory then holds
   this run's files and the user's, and the last run's files are kept one generation. A listed
   directory ending with ``/`` (``fields/``, made by the run for its files) is emptied of the
   listed names only, and removed if that leaves it empty (the user's files in it stay where
   they are). ``previous_run/`` is
   deleted only if this code made it (it holds the mark :data:`PREVIOUS_MARK`) and everything
   in it is listed by its manifest, or if it is empty: one the user made, one with a file of
   the user's anywhere in it, or a regular file by that name is never deleted, the run is
   refused naming it. A restart continues the files it finds (the interface history is cut
   back to the restart time). Files no manifest lists are left alone;
5. writes the manifest: this run's names (with the listed names still there, on a restart),
   before any of them is written, so that a killed run's files are known as its own; when the
   run ends it is written again with the names that exist.

A directory a library writes as a whole (ADIOS2's ``.bp``) is listed as one name while the run
lasts (everything in it is the run's: a killed run's), and with its files when the run ends.

No file is ever created, truncated or written through a symbolic link (:mod:`.links`): the lock
is opened with ``O_NOFOLLOW`` (a link there is refused, naming it), a listed name that is now a
link is moved to ``previous_run/`` as a link, a link named ``previous_run`` is removed (not
what it points to), the manifest is read with ``O_NOFOLLOW`` (a link there is ignored, and
replaced by the new manifest).
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from .collective import Failure, OutputError, collective, probe_directory
from .links import open_nofollow
from .paths import inside

__all__ = [
    "LOCK_NAME",
    "MANIFEST",
    "PREVIOUS",
    "PREVIOUS_MARK",
    "OutputDirectory",
    "read_manifest",
    "write_manifest",
]

LOCK_NAME = ".subfric.lock"
PREVIOUS = "previous_run"
PREVIOUS_MARK = ".made-by-subfric-dolfinx"
"""An empty file in ``previous_run/``: this code made the directory (and may replace it)."""
MANIFEST = ".subfric-files.json"
"""The list of the files runs of this code wrote in a directory (see the module docstring)."""
MANIFEST_BYTES = 1 << 20
"""A manifest longer than this is not read (not one of ours)."""
_SHOWN = 5


def read_manifest(directory: str | Path) -> list[str] | None:
    """The names a directory's manifest lists (``None``: no manifest of ours there).

    A missing, unreadable, oversized or malformed manifest, or a symbolic link by its name, is
    no manifest: its names are not trusted.
    """
    try:
        fd = open_nofollow(Path(directory) / MANIFEST, os.O_RDONLY)
    except OSError:
        return None
    try:
        data = os.read(fd, MANIFEST_BYTES + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    if len(data) > MANIFEST_BYTES:
        return None
    try:
        doc = json.loads(data)
    except ValueError:
        return None
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    out = []
    for f in files:
        try:
            inside(directory, f, resolve=False)
        except OutputError:  # never a name outside the directory
            continue
        out.append(f)
    return list(dict.fromkeys(out))


def write_manifest(directory: str | Path, names: Sequence[str]) -> None:
    """Write a directory's manifest atomically (a new file, synced, renamed over the old one)."""
    d = Path(directory)
    text = json.dumps({"written_by": "subfric-dolfinx", "files": list(names)}, indent=1) + "\n"
    tmp = d / f"{MANIFEST}.{os.getpid()}.tmp"
    fd = open_nofollow(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        os.write(fd, text.encode())
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, d / MANIFEST)


def _is_dir(p: Path) -> bool:
    return p.is_dir() and not p.is_symlink()


def _describe(directory: Path, names: Sequence[str]) -> str:
    shown = []
    for n in names[:_SHOWN]:
        p = directory / n
        shown.append(f"{n} (a symbolic link to {os.readlink(p)!r})" if p.is_symlink() else n)
    return ", ".join(shown) + (", ..." if len(names) > _SHOWN else "")


def _unlisted(directory: Path, ignore: Sequence[str], listed: Sequence[str]) -> list[str]:
    """What lies in ``directory`` that ``listed`` does not account for (relative names).

    A listed name is the run's with everything in it, unless it ends with ``/`` (a directory
    the run made for its files: then only the listed names in it are).
    """
    containers = {n[:-1] for n in listed if n.endswith("/")}
    files = {n for n in listed if not n.endswith("/")}
    out: list[str] = []

    def walk(rel: str) -> None:
        for n in sorted(os.listdir(directory / rel if rel else directory)):
            name = f"{rel}/{n}" if rel else n
            if name in containers and _is_dir(directory / name):
                walk(name)
            elif name not in files:
                out.append(name)

    walk("")
    return [n for n in out if n not in ignore]


def _expand(directory: Path, names: Sequence[str]) -> list[str]:
    """``names``, every directory among them (``.bp``) listed with what it holds.

    So a file put in it later is known as another's.
    """
    out: list[str] = []
    for n in names:
        p = directory / n
        if n.endswith("/") or not _is_dir(p):
            out.append(n)
            continue
        out.append(n + "/")
        for root, dirs, files in os.walk(p):  # never follows a link
            rel = Path(root).relative_to(directory).as_posix()
            out += [f"{rel}/{d}/" for d in sorted(dirs)] + [f"{rel}/{f}" for f in sorted(files)]
    return out


class OutputDirectory:
    """The output directory of a run, locked for it (collective context manager).

    Args:
        path: The directory (created).
        comm: The run's communicator.
        fresh: A new run (not a restart): the files of earlier runs are moved to
            ``previous_run/``.
        files: The names this run may write in the directory (relative, ``/`` inside; temporary
            names included): recorded in its manifest before they are written. A name ending
            with ``/`` is a directory the run makes for its files (``fields/``): only the names
            listed in it are the run's.

    Attributes:
        moved: Names moved aside (on rank 0; empty elsewhere).

    Raises:
        OutputError: On every rank: the directory is not usable (the OS error named), another
            run holds it, it holds files this run would write that no run of this code wrote
            (named), or ``previous_run/`` holds files this code did not write (named).
    """

    def __init__(
        self, path: str | Path, comm: Any, fresh: bool = True, files: Sequence[str] = ()
    ) -> None:
        self.path = Path(path)
        self.comm = comm
        self.fresh = fresh
        self.files = list(dict.fromkeys(files))
        for name in self.files:
            inside(self.path, name, resolve=False)
        self.moved: list[str] = []
        self._listed: list[str] = []
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
        try:
            collective(
                self.comm,
                self._prepare,
                f"preparing the output directory {str(self.path)!r}",
                path=self.path / MANIFEST,
            )
        except OutputError:
            self._unlock()
            self.comm.Barrier()
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

    def _prepare(self) -> None:
        """Refuse another's files, move the earlier run's aside, write the manifest (rank 0)."""
        reserved = (LOCK_NAME, PREVIOUS, MANIFEST)  # never the run's files, whatever is listed
        listed = [n for n in read_manifest(self.path) or [] if n.split("/")[0] not in reserved]
        known = {n.rstrip("/") for n in listed}
        theirs = [
            n
            for n in self.files
            if os.path.lexists(self.path / n)
            and n.rstrip("/") not in known
            and not (n.endswith("/") and _is_dir(self.path / n))
        ]
        if theirs:
            raise Failure(
                f"it holds {_describe(self.path, theirs)}, which this run would write and no "
                f"run of this code wrote (not in its {MANIFEST}): not touched; move "
                f"{'it' if len(theirs) == 1 else 'them'} away, or give another output directory"
            )
        if self.fresh:
            self._move_aside(listed)
            listed = []
        for n in self.files:  # none leads outside, through a link in the directory
            inside(self.path, n)
        self._listed = list(dict.fromkeys([*listed, *self.files]))
        if self._listed or os.path.lexists(self.path / MANIFEST):
            write_manifest(self.path, self._listed)

    def _move_aside(self, listed: list[str]) -> None:
        """Move the listed files that exist to ``previous_run/`` (rank 0).

        A listed directory ending with ``/`` is emptied of the listed names in it only (and
        removed if that leaves it empty); one that is a link now is moved as a link.
        """
        found: list[str] = []
        for n in listed:  # a name under a listed name that is no directory now: not followed
            parts = n.rstrip("/").split("/")
            if any(not _is_dir(self.path.joinpath(*parts[:i])) for i in range(1, len(parts))):
                continue
            p = self.path / n
            if n.endswith("/"):
                if p.is_symlink():
                    found.append(n.rstrip("/"))
            elif os.path.lexists(p):
                found.append(n)
        if not found:
            return
        prev = self.path / PREVIOUS
        self._clear_previous(prev)
        prev.mkdir()
        os.close(open_nofollow(prev / PREVIOUS_MARK, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        made: list[str] = []
        for n in found:
            parts = n.split("/")
            for i in range(1, len(parts)):
                sub = "/".join(parts[:i]) + "/"
                if sub not in made:
                    (prev / sub).mkdir(exist_ok=True)
                    made.append(sub)
            os.replace(self.path / n, prev / n)
        write_manifest(prev, [*made, *found])
        emptied = sorted((n for n in listed if n.endswith("/")), key=len, reverse=True)
        for c in emptied:
            try:
                (self.path / c).rmdir()
            except OSError:  # the user's files in it, a link, or not there
                pass
        self.moved = found

    @staticmethod
    def _clear_previous(prev: Path) -> None:
        """Delete the ``previous_run/`` this code made, or refuse naming what is not its own."""
        if prev.is_symlink():  # the link goes, never what it points to
            prev.unlink()
            return
        if not os.path.lexists(prev):
            return
        if not prev.is_dir():
            raise Failure(
                f"{str(prev)!r} is a file this code did not write: not deleted; move or rename "
                "it, or give another output directory"
            )
        names = os.listdir(prev)
        if not names:
            prev.rmdir()
            return
        listed = read_manifest(prev) if PREVIOUS_MARK in names else None
        foreign = _unlisted(prev, [PREVIOUS_MARK, MANIFEST], listed or [])
        if PREVIOUS_MARK not in names:
            raise Failure(
                f"{str(prev)!r} was not made by this code (no {PREVIOUS_MARK} in it; it holds "
                f"{_describe(prev, foreign)}): not deleted; move or rename it, or give another "
                "output directory"
            )
        if foreign:
            raise Failure(
                f"{str(prev)!r} holds files this code did not write ("
                f"{_describe(prev, foreign)}): not deleted; move or rename it, or give another "
                "output directory"
            )
        shutil.rmtree(prev)  # never follows a link inside (the links themselves go)

    def _record(self) -> None:
        """Write the manifest again with the names that exist (rank 0, at the end).

        A directory a library wrote (``.bp``) is listed with what is in it now.
        """
        if not self._listed:
            return
        there = _expand(self.path, [n for n in self._listed if os.path.lexists(self.path / n)])
        if there != self._listed:
            write_manifest(self.path, there)

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
            if self.comm.rank == 0 and self._fd is not None:
                try:
                    self._record()
                except OSError:  # the manifest written at the start lists them all
                    pass
            self._unlock()
        finally:
            self.comm.Barrier()
