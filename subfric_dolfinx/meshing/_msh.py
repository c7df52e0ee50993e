"""Mesh files are data: only MSH files reach gmsh.

``gmsh.merge`` decides what a file is by its name and its first line: a file that does not start
with ``$MeshFormat`` (a ``.geo`` script, or script text in a file named ``.msh``) is parsed as a
gmsh script, whose ``SystemCall`` runs a shell command, and some names (``.gz``) are handed to a
shell. :func:`open_msh` therefore opens the file once, checks its header — ``$MeshFormat``, a
version 2.x or 4.x, file type 0 (ASCII) or 1 (binary), data size 8 and, in a binary file, the
endianness integer 1 — and gives gmsh the already opened file as ``/proc/self/fd/N`` (no name to
dispatch on, and no window in which the checked file could be swapped for another). Before
that, every section of the file is checked (:mod:`._msh_check`): gmsh trusts the counts of a
file, and a damaged one could crash it.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import struct
from collections.abc import Iterator
from pathlib import Path

from ._msh_check import check_msh
from .groups import InterfaceMeshError

__all__ = ["check_msh_header", "open_msh"]

_VERSION = re.compile(rb"^[24](\.[0-9]+)?$")
_ONE = (struct.pack("<i", 1), struct.pack(">i", 1))


def _line(head: bytes, start: int) -> tuple[bytes, int]:
    """The line of ``head`` from ``start`` (without the line end) and the start of the next."""
    end = head.find(b"\n", start)
    if end < 0:
        return head[start:].rstrip(b"\r"), len(head)
    return head[start:end].rstrip(b"\r"), end + 1


def check_msh_header(head: bytes, what: str) -> None:
    """Raise :class:`InterfaceMeshError` unless ``head`` starts an MSH file (format 2 or 4).

    ``head`` holds the first bytes of the file; ASCII and binary files are accepted.

    Args:
        head: At least the first 64 bytes of the file (all of it if shorter).
        what: The file's name, for the message.
    """
    refuse = (
        f"{what}: not an MSH mesh file (format 2 or 4, ASCII or binary); only MSH files are "
        "read, since gmsh runs anything else (e.g. a .geo script) as code"
    )
    first, pos = _line(head, 0)
    if first != b"$MeshFormat":
        raise InterfaceMeshError(f"{refuse}: the file does not start with '$MeshFormat'")
    fmt, pos = _line(head, pos)
    parts = fmt.split()
    if len(parts) != 3:
        raise InterfaceMeshError(f"{refuse}: malformed format line {fmt[:40]!r}")
    version, kind, size = parts
    if not _VERSION.match(version):
        raise InterfaceMeshError(f"{refuse}: format version {version[:16]!r} is not 2.x or 4.x")
    if kind not in (b"0", b"1"):
        raise InterfaceMeshError(
            f"{refuse}: file type {kind[:16]!r} is not 0 (ASCII) or 1 (binary)"
        )
    if size != b"8":
        raise InterfaceMeshError(f"{refuse}: data size {size[:16]!r} is not 8")
    if kind == b"1":
        if head[pos : pos + 4] not in _ONE:
            raise InterfaceMeshError(f"{refuse}: a binary file without the endianness integer 1")
        pos += 4
        if head[pos : pos + 1] == b"\n":
            pos += 1
    end, _ = _line(head, pos)
    if end != b"$EndMeshFormat":
        raise InterfaceMeshError(f"{refuse}: '$EndMeshFormat' does not follow the format line")


def _read_all(fd: int, path: Path) -> bytes:
    size = os.fstat(fd).st_size
    chunks, pos = [], 0
    while pos < size:
        try:
            chunk = os.pread(fd, min(size - pos, 1 << 26), pos)
        except OSError as e:
            raise InterfaceMeshError(f"{path}: cannot be read: {e.strerror}") from e
        if not chunk:
            break
        chunks.append(chunk)
        pos += len(chunk)
    return b"".join(chunks)


@contextlib.contextmanager
def open_msh(path: Path) -> Iterator[str]:
    """Open an MSH file, check its header, and yield the name under which gmsh must read it.

    Raises:
        FileNotFoundError: Not a regular file.
        InterfaceMeshError: Not an MSH file of format 2 or 4, or unreadable.
    """
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    try:  # non-blocking: a FIFO put in the file's place does not hang the open
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise InterfaceMeshError(f"{path}: cannot be opened: {e.strerror}") from e
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise FileNotFoundError(f"mesh file not found: {path} (not a regular file)")
        try:
            head = os.pread(fd, 256, 0)
        except OSError as e:
            raise InterfaceMeshError(f"{path}: cannot be read: {e.strerror}") from e
        check_msh_header(head, str(path))
        check_msh(_read_all(fd, path), str(path))  # every section, before gmsh parses any
        proc = f"/proc/self/fd/{fd}"
        if os.path.exists(proc):
            yield proc
        elif path.suffix.lower() == ".msh":  # no /proc: gmsh dispatches on the name
            yield str(path)
        else:
            raise InterfaceMeshError(f"{path}: without /proc, only files named *.msh are read")
    finally:
        os.close(fd)
