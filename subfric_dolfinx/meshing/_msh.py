"""Mesh files are data: only MSH files reach gmsh.

``gmsh.merge`` decides what a file is by its name and its first line: a file that does not start
with ``$MeshFormat`` (a ``.geo`` script, or script text in a file named ``.msh``) is parsed as a
gmsh script, whose ``SystemCall`` runs a shell command, and some names (``.gz``) are handed to a
shell. :func:`open_msh` therefore opens the file once, checks its header — ``$MeshFormat``, a
version 2.x or 4.x, file type 0 (ASCII) or 1 (binary), data size 8 and, in a binary file, the
endianness integer 1 — and gives gmsh the already opened file as ``/proc/self/fd/N`` (no name to
dispatch on, and no window in which the checked file could be swapped for another). Before
that, the whole file is checked (:func:`check_msh`; format 2.2 or 4.1, ASCII or binary), since

gmsh trusts the counts of a file: the stored block mesh with its ``$Nodes`` total changed from
163 to 100 made it abort with "double free or corruption" (the process killed by SIGABRT on
every rank), a count of 1.6e11 nodes made it fail with an empty message, NaN or 1e308
coordinates went through and failed a later step. :func:`check_msh` parses every section this
package reads (``$MeshFormat``, ``$PhysicalNames``, ``$Entities``, ``$Nodes``, ``$Elements``;
any other section is refused, naming it) with its own bounds checks and numpy, and refuses,
naming the section and the number at fault:

* counts that the file's size cannot hold (checked before anything is allocated: every count is
  compared with the numbers, or bytes, left in its section), blocks that hold more nodes or
  elements than their section's total declares (gmsh sizes its arrays by it; a total larger
  than the blocks' sum is accepted: gmsh writes such files itself, e.g. after a group was
  removed), numbers left over or missing, malformed numbers, non-integral or negative tags;
* node tags that repeat or fall outside the declared range, elements that name a node that does
  not exist, element tags that repeat, an element type this package does not know or whose
  dimension is not its block's, blocks that name an entity ``$Entities`` does not declare;
* coordinates that are not finite or beyond :data:`~._msh_read.MAX_COORDINATE` in magnitude;
* elements of the mesh's dimension (and one below: the facets of groups such as the interface) of
  zero size (area, length or volume below :data:`~._msh_read.ZERO_SIZE` times the mean of their
  block), and inverted ones (whose orientation is opposite to the rest of their block; a
  quadrilateral or hexahedron whose corners do not agree), each named by its tag and physical group.

The file is mapped into memory, not copied (its pages belong to the file); ASCII numbers are
parsed with ``numpy.fromstring``, whose memory is bounded by the file's size, not by any count
in it. Before anything is read, the file's size is compared with the machine's memory
(:func:`check_file_size`: checking and reading a file takes up to :data:`MEMORY_PER_FILE_BYTE`
times its size).
"""

from __future__ import annotations

import contextlib
import mmap
import os
import re
import stat
import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import cast

import numpy as np

from ._msh_read import (
    CHUNK,
    ELEMENTS,
    INT32,
    MAX_COORDINATE,
    SECTIONS,
    TAG_SLACK,
    AsciiReader,
    BinaryReader,
    ByteOrder,
    ElementBlocks,
    HeaderSections,
    MshBytes,
    MshFault,
    ascii_numbers,
    checked_ints,
    element_problems,
    tag_limit,
)
from ._size import machine_memory
from .groups import InterfaceMeshError

__all__ = ["MEMORY_PER_FILE_BYTE", "check_file_size", "check_msh", "check_msh_header", "open_msh"]

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


MEMORY_PER_FILE_BYTE = 5
"""Memory to check a mesh file and read it with gmsh, per byte of the file: above the peak
resident memory of :func:`check_msh` and ``gmsh.merge`` (``docs/design.md``, *Mesh size
limits*)."""


def check_file_size(size: int, path: Path) -> None:
    """Refuse a mesh file whose reading would need more than the machine's memory.

    Raises:
        InterfaceMeshError: Naming the file, its size, the memory it would take and the
            machine's (before anything of it is read).
    """
    need = size * MEMORY_PER_FILE_BYTE
    have = machine_memory()
    if have and need > have:
        raise InterfaceMeshError(
            f"{path}: a mesh file of {size / 2**30:.3g} GiB; checking and reading it takes about "
            f"{MEMORY_PER_FILE_BYTE} times that ({need / 2**30:.3g} GiB), more than this "
            f"machine's {have / 2**30:.3g} GiB of memory: not read"
        )


@contextlib.contextmanager
def _mapped(fd: int, path: Path) -> Iterator[bytes | mmap.mmap]:
    """The file's bytes, mapped (pages of the file, not copies in the process's memory)."""
    size = os.fstat(fd).st_size
    if size == 0:
        yield b""
        return
    try:
        m = mmap.mmap(fd, 0, access=mmap.ACCESS_READ)
    except (OSError, ValueError) as e:
        raise InterfaceMeshError(f"{path}: cannot be read: {e}") from e
    try:
        yield m
    finally:
        try:
            m.close()
        except BufferError:  # a view of it still alive (an error's traceback): freed with it
            pass


@contextlib.contextmanager
def open_msh(path: Path) -> Iterator[str]:
    """Open an MSH file, check its header, and yield the name under which gmsh must read it.

    Raises:
        FileNotFoundError: No such file.
        InterfaceMeshError: A directory or another file that is not a regular one, too large
            for the machine's memory (:func:`check_file_size`, before reading), not an MSH file
            of format 2 or 4, damaged, or unreadable.
    """
    if not os.path.exists(path):
        raise FileNotFoundError(f"mesh file not found: {path}")
    if not path.is_file():
        kind = "a directory" if path.is_dir() else "not a regular file (a FIFO, a device, ...)"
        raise InterfaceMeshError(f"{path}: {kind}, not a mesh file")
    try:  # non-blocking: a FIFO put in the file's place does not hang the open
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise InterfaceMeshError(f"{path}: cannot be opened: {e.strerror}") from e
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise FileNotFoundError(f"mesh file not found: {path} (not a regular file)")
        check_file_size(os.fstat(fd).st_size, path)  # before anything is read
        try:
            head = os.pread(fd, 256, 0)
        except OSError as e:
            raise InterfaceMeshError(f"{path}: cannot be read: {e.strerror}") from e
        check_msh_header(head, str(path))
        with _mapped(fd, path) as data:
            check_msh(data, str(path))  # every section, before gmsh parses any
        proc = f"/proc/self/fd/{fd}"
        if os.path.exists(proc):
            yield proc
        elif path.suffix.lower() == ".msh":  # no /proc: gmsh dispatches on the name
            yield str(path)
        else:
            raise InterfaceMeshError(f"{path}: without /proc, only files named *.msh are read")
    finally:
        os.close(fd)


# -- Every section of the file, checked before gmsh parses it


class _Mesh(HeaderSections):
    def __init__(self, what: str, version: int, binary: bool, order: ByteOrder) -> None:
        self.what, self.version, self.binary, self.order = what, version, binary, order
        self.names: dict[tuple[int, int], str] = {}
        self.entities: dict[tuple[int, int], list[int]] | None = None  # v4: physical tags
        self.node_tags = np.zeros(0, dtype=np.int64)
        self.coords = np.zeros((0, 3))
        self.blocks = ElementBlocks()

    # Nodes
    def nodes(self, f: MshBytes) -> None:
        tags: list[np.ndarray] = []
        xyz: list[np.ndarray] = []
        declared = None
        if self.version == 4:
            if self.binary:
                b = BinaryReader(f, self.order, "Nodes")
                nblocks, total, lo, hi = (b.int("q", "its header") for _ in range(4))
                left = len(f.data) - f.pos
                if total > left // 32 or nblocks > left // 20:  # a tag and x, y, z per node
                    raise MshFault(
                        f"section $Nodes declares {total} nodes in {nblocks} blocks; the "
                        f"{left} bytes left in the file cannot hold them"
                    )
                for _ in range(nblocks):
                    dim = b.int("i", "an entity dimension", hi=3)
                    ent = b.int("i", "an entity tag", lo=1)
                    param = b.int("i", "the parametric flag", hi=1)
                    n = b.int("q", "a block's number of nodes")
                    self._entity(dim, ent, "$Nodes")
                    ncoord = 3 + (dim if param == 1 else 0)
                    if param not in (0, 1) or dim > 3:
                        raise MshFault(
                            f"section $Nodes: a block of dimension {dim}, parametric {param}"
                        )
                    tags.append(b.array(n, "q", "node tags"))
                    xyz.append(b.array(n * ncoord, "d", "coordinates").reshape(n, ncoord)[:, :3])
                if f.line() != b"":
                    raise MshFault("section $Nodes: no line end after its binary data")
            else:
                r = AsciiReader(ascii_numbers(f.body(b"Nodes"), "Nodes"), "Nodes")
                nblocks, total, lo, hi = (int(v) for v in r.ints(4, "its header"))
                if total > r.left() // 4 or nblocks > r.left() // 4:
                    raise MshFault(
                        f"section $Nodes declares {total} nodes in {nblocks} blocks and holds "
                        f"{r.left()} numbers (4 at least per node)"
                    )
                for _ in range(nblocks):
                    dim, ent, param, n = (int(v) for v in r.ints(4, "a block header"))
                    self._entity(dim, ent, "$Nodes")
                    if param not in (0, 1) or dim > 3:
                        raise MshFault(
                            f"section $Nodes: a block of dimension {dim}, parametric {param}"
                        )
                    ncoord = 3 + (dim if param == 1 else 0)
                    tags.append(r.ints(n, "node tags", lo=1))
                    xyz.append(r.floats(n * ncoord, "coordinates").reshape(n, ncoord)[:, :3])
                r.done()
            declared = (total, lo, hi)
        else:
            if self.binary:
                head = checked_ints(ascii_numbers(f.line(), "Nodes"), "section $Nodes, its count")
                if head.size != 1:
                    raise MshFault("section $Nodes: no count line")
                total = int(head[0])
                raw = f.take(total * 28, "section $Nodes")
                rec = np.frombuffer(
                    raw, dtype=np.dtype([("t", "i4"), ("x", "f8", 3)]).newbyteorder(self.order)
                )
                tags.append(rec["t"].astype(np.int64))
                xyz.append(rec["x"].astype(float))
                if f.line() != b"":
                    raise MshFault("section $Nodes: no line end after its binary data")
            else:
                r = AsciiReader(ascii_numbers(f.body(b"Nodes"), "Nodes"), "Nodes")
                total = r.int("its count")
                if 4 * total != r.left():
                    raise MshFault(
                        f"section $Nodes declares {total} nodes and holds {r.left()} numbers "
                        f"({4 * total} expected: a tag and x, y, z per node)"
                    )
                rows = r.floats(4 * total, "nodes").reshape(total, 4)
                tags.append(checked_ints(rows[:, 0], "section $Nodes, node tags", lo=1, hi=INT32))
                xyz.append(rows[:, 1:])
        self.node_tags = np.concatenate(tags) if tags else np.zeros(0, dtype=np.int64)
        self.coords = np.concatenate(xyz) if xyz else np.zeros((0, 3))
        n = self.node_tags.size
        if n > total or (self.version == 2 and n != total):  # fewer: gmsh writes that itself
            raise MshFault(f"section $Nodes declares {total} nodes; its blocks hold {n}")
        if n and self.node_tags.min() < 1:
            raise MshFault(f"section $Nodes: node tag {int(self.node_tags.min())} is not positive")
        if declared is not None and n:
            _, lo, hi = declared
            if self.node_tags.min() < lo or self.node_tags.max() > hi:
                raise MshFault(
                    f"section $Nodes: node tags from {int(self.node_tags.min())} to "
                    f"{int(self.node_tags.max())}, outside the declared {lo} to {hi}"
                )
        uniq, counts = np.unique(self.node_tags, return_counts=True)
        if uniq.size != n:
            raise MshFault(f"section $Nodes: node tag {int(uniq[counts > 1][0])} appears twice")
        if n and uniq[-1] > tag_limit(n):
            raise MshFault(
                f"section $Nodes: node tag {int(uniq[-1])} is far beyond the number of nodes "
                f"({n}; gmsh sizes its arrays by the largest tag: renumber the mesh)"
            )
        bad = ~np.isfinite(self.coords) | (np.abs(self.coords) > MAX_COORDINATE)
        if bad.any():
            i = int(np.flatnonzero(bad.any(axis=1))[0])
            raise MshFault(
                f"node {int(self.node_tags[i])} has coordinates {self.coords[i].tolist()}: not "
                f"finite, or beyond {MAX_COORDINATE:g} in magnitude"
            )

    def _entity(self, dim: int, ent: int, where: str) -> None:
        if self.entities is not None and (dim, ent) not in self.entities:
            raise MshFault(f"section {where}: a block names the {dim}-D entity {ent}, not declared")

    # Elements
    def elements(self, f: MshBytes) -> None:
        if self.version == 4:
            self._elements4(f)
        elif self.binary:
            self._elements2_binary(f)
        else:
            self._elements2(f)
        blocks = self.blocks.items
        tags = np.concatenate([b[3] for b in blocks]) if blocks else np.zeros(0, np.int64)
        uniq, counts = np.unique(tags, return_counts=True)
        if uniq.size != tags.size:
            raise MshFault(
                f"section $Elements: element tag {int(uniq[counts > 1][0])} appears twice"
            )
        if tags.size and uniq[-1] > tag_limit(tags.size):
            raise MshFault(
                f"section $Elements: element tag {int(uniq[-1])} is far beyond the number of "
                f"elements ({tags.size}; gmsh sizes its arrays by the largest tag: renumber the "
                "mesh)"
            )
        phys = [(b[0], int(p)) for b in blocks if b[5] is not None for p in np.unique(b[5])]
        if self.entities is not None:
            phys += [(d, p) for (d, _), ps in self.entities.items() for p in ps]
        self._one_group_per_cell(blocks)
        dims: dict[int, int] = {}
        for d, p in [*phys, *self.names]:
            if dims.setdefault(p, d) != d:
                raise MshFault(
                    f"physical tag {p} names groups of dimensions {dims[p]} and {d} (DOLFINx's "
                    "gmsh reader keys groups by their tag alone: give each group its own tag)"
                )
        big = [p for _, p in phys if p > TAG_SLACK]
        if big:
            raise MshFault(
                f"physical tag {max(big)} is beyond {TAG_SLACK} (gmsh sizes its arrays by tags)"
            )
        known = np.sort(self.node_tags)
        for _, _, etype, etags, conn, _ in blocks:
            for lo in range(0, len(conn), CHUNK):  # in chunks: bounded memory
                part = conn[lo : lo + CHUNK]
                at = np.minimum(np.searchsorted(known, part), max(known.size - 1, 0))
                missing = known[at] != part if known.size else np.ones(part.shape, bool)
                if missing.any():
                    i = np.argwhere(missing)[0]
                    raise MshFault(
                        f"element {int(etags[lo + i[0]])} ({ELEMENTS[etype][2]}) names node "
                        f"{int(part[i[0], i[1]])}, which the file does not define"
                    )

    def _one_group_per_cell(self, blocks: list) -> None:
        """Every cell in one physical group at most.

        DOLFINx's gmsh reader takes the cells of each group, so a cell in two would be read
        twice (a corrupt mesh, a crash in DOLFINx).

        Format 4: an entity of the mesh's dimension in two physical groups of it; format 2
        (physical tags per element, gmsh makes them per entity): the elements of one entity
        with different physical tags, at any dimension.
        """
        if not blocks:
            return
        top = max(b[0] for b in blocks)
        types: dict[tuple[int, int], set[int]] = {}
        for dim, ent, etype, _, _, _ in blocks:
            types.setdefault((dim, ent), set()).add(etype)
        for (dim, ent), ts in types.items():
            if len(ts) > 1:
                raise MshFault(
                    f"the {dim}-D entity {ent} holds elements of {len(ts)} types "
                    f"({', '.join(ELEMENTS[t][2] for t in sorted(ts))}); one is read"
                )
        if self.version == 4:
            for (dim, ent), ps in (self.entities or {}).items():
                if ps and (dim, ent) not in types:
                    raise MshFault(
                        f"the {dim}-D entity {ent} of physical group(s) {sorted(set(ps))} holds "
                        "no element"
                    )
                if dim == top and len(set(ps)) > 1:
                    raise MshFault(
                        f"the {dim}-D entity {ent} is in {len(set(ps))} physical groups of cells "
                        f"({sorted(set(ps))}): its cells would be read twice"
                    )
            return
        seen: dict[tuple[int, int], set[int]] = {}
        for dim, geo, _, _, _, phys in blocks:
            seen.setdefault((dim, geo), set()).update(int(p) for p in np.unique(phys))
        for (dim, geo), groups in seen.items():
            if len(groups) > 1:
                raise MshFault(
                    f"the elements of the {dim}-D entity {geo} carry different physical tags "
                    f"({sorted(groups)}): gmsh puts the whole entity in each group, and its "
                    "elements would be read more than once"
                )

    def _type(self, etype: int, dim: int | None) -> int:
        if etype not in ELEMENTS:
            raise MshFault(f"section $Elements: element type {etype} is not one this package reads")
        k, d, name = ELEMENTS[etype]
        if dim is not None and d != dim:
            raise MshFault(f"section $Elements: a block of dimension {dim} holds {name} elements")
        return k

    def _elements4(self, f: MshBytes) -> None:
        add = self.blocks.items.append
        if self.binary:
            b = BinaryReader(f, self.order, "Elements")
            nblocks, total, _, _ = (b.int("q", "its header") for _ in range(4))
            left = len(f.data) - f.pos
            if total > left // 16 or nblocks > left // 20:
                raise MshFault(
                    f"section $Elements declares {total} elements in {nblocks} blocks; the "
                    f"{left} bytes left in the file cannot hold them"
                )
            count = 0
            for _ in range(nblocks):
                dim = b.int("i", "an entity dimension", hi=3)
                ent = b.int("i", "an entity tag", lo=1)
                etype = b.int("i", "an element type")
                n = b.int("q", "a block's number of elements")
                self._entity(dim, ent, "$Elements")
                k = self._type(etype, dim)
                data = b.array(n * (1 + k), "q", "elements").reshape(n, 1 + k)
                add((dim, ent, etype, data[:, 0], data[:, 1:], None))
                count += n
            if f.line() != b"":
                raise MshFault("section $Elements: no line end after its binary data")
        else:
            r = AsciiReader(ascii_numbers(f.body(b"Elements"), "Elements"), "Elements")
            nblocks, total, _, _ = (int(v) for v in r.ints(4, "its header"))
            if total > r.left() // 2 or nblocks > r.left() // 4:
                raise MshFault(
                    f"section $Elements declares {total} elements in {nblocks} blocks and holds "
                    f"{r.left()} numbers"
                )
            count = 0
            for _ in range(nblocks):
                dim, ent, etype, n = (int(v) for v in r.ints(4, "a block header"))
                self._entity(dim, ent, "$Elements")
                k = self._type(etype, dim)
                data = r.ints(n * (1 + k), "elements", lo=1).reshape(n, 1 + k)
                add((dim, ent, etype, data[:, 0], data[:, 1:], None))
                count += n
            r.done()
        if count > total:  # fewer: gmsh writes that itself (after removing a group)
            raise MshFault(f"section $Elements declares {total} elements; its blocks hold {count}")

    def _elements2(self, f: MshBytes) -> None:
        r = AsciiReader(ascii_numbers(f.body(b"Elements"), "Elements"), "Elements")
        total = r.int("its count")
        if total > r.left() // 4:
            raise MshFault(
                f"section $Elements declares {total} elements and holds {r.left()} numbers"
            )
        by: dict[tuple[int, int], list[tuple[int, list[int], int]]] = {}
        for _ in range(total):
            tag, etype, ntags = (int(v) for v in r.ints(3, "an element's header", hi=INT32))
            k = self._type(etype, None)
            extra = r.ints(ntags, "an element's tags", hi=INT32)
            nodes = r.ints(k, "an element's nodes", lo=1, hi=INT32)
            phys = int(extra[0]) if ntags > 0 else 0
            geo = int(extra[1]) if ntags > 1 else 0
            by.setdefault((etype, geo), []).append((tag, cast(list[int], nodes.tolist()), phys))
        r.done()
        self._blocks2(by)

    def _elements2_binary(self, f: MshBytes) -> None:
        n = checked_ints(ascii_numbers(f.line(), "Elements"), "section $Elements, its count")
        if n.size != 1:
            raise MshFault("section $Elements: no count line")
        total = int(n[0])
        b = BinaryReader(f, self.order, "Elements")
        if total > (len(f.data) - f.pos) // 12:
            raise MshFault(
                f"section $Elements declares {total} elements; the file cannot hold them"
            )
        by: dict[tuple[int, int], list[tuple[int, list[int], int]]] = {}
        count = 0
        while count < total:
            etype = b.int("i", "an element type")
            nb = b.int("i", "a block's number of elements", lo=1)
            ntags = b.int("i", "a number of tags")
            k = self._type(etype, None)
            if count + nb > total:
                raise MshFault(f"section $Elements: blocks hold more than the {total} declared")
            data = b.array(nb * (1 + ntags + k), "i", "elements").reshape(nb, 1 + ntags + k)
            if data.size and data.min() < 0:
                raise MshFault(f"section $Elements: a negative tag {int(data.min())}")
            for row in data:
                phys = int(row[1]) if ntags > 0 else 0
                geo = int(row[2]) if ntags > 1 else 0
                by.setdefault((etype, geo), []).append(
                    (int(row[0]), cast(list[int], row[1 + ntags :].tolist()), phys)
                )
            count += nb
        if f.line() != b"":
            raise MshFault("section $Elements: no line end after its binary data")
        self._blocks2(by)

    def _blocks2(self, by: dict[tuple[int, int], list[tuple[int, list[int], int]]]) -> None:
        for (etype, geo), rows in by.items():
            tags = np.array([r[0] for r in rows], dtype=np.int64)
            conn = np.array([r[1] for r in rows], dtype=np.int64).reshape(len(rows), -1)
            phys = np.array([r[2] for r in rows], dtype=np.int64)
            self.blocks.items.append((ELEMENTS[etype][1], geo, etype, tags, conn, phys))

    # -- geometry -------------------------------------------------------------------------------
    def geometry(self) -> None:
        """Zero-size and inverted elements of the mesh's dimension and of one below."""
        problems = element_problems(self.blocks.items, self.node_tags, self.coords, self._group)
        if problems:
            raise MshFault("; ".join(problems[:3]))

    def _group(self, dim: int, ent: int, phys: np.ndarray | None, i: int) -> str:
        if phys is not None:  # format 2: each element its physical tag
            tags = [int(phys[i])]
        elif self.entities is not None:
            tags = self.entities.get((dim, ent), [])
        else:
            tags = []
        named = [repr(self.names[(dim, t)]) for t in tags if (dim, t) in self.names]
        if named:
            return "physical group " + ", ".join(named)
        return f"the {dim}-D entity {ent} (no named physical group)"


_HANDLERS: dict[bytes, Callable[[_Mesh, MshBytes], None]] = {
    b"PhysicalNames": _Mesh.physical_names,
    b"Entities": _Mesh.entities_section,
    b"Nodes": _Mesh.nodes,
    b"Elements": _Mesh.elements,
}


def check_msh(data: bytes | mmap.mmap, what: str) -> None:
    """Check a whole MSH file (its header already checked) before gmsh reads it.

    Args:
        data: The file's bytes.
        what: The file's name, for the message.

    Raises:
        InterfaceMeshError: Naming the file, the section and the fault (module docstring).
    """
    try:
        _check(data, what)
    except MshFault as e:
        raise InterfaceMeshError(f"{what}: damaged mesh file: {e}") from None


def _check(data: bytes | mmap.mmap, what: str) -> None:
    f = MshBytes(data)
    f.line()  # $MeshFormat
    version_line = f.line().split()
    version = int(float(version_line[0]))
    binary = version_line[1] == b"1"
    order: ByteOrder = "<"
    if binary:
        one = f.take(4, "the endianness integer")
        order = "<" if one == struct.pack("<i", 1) else ">"
        f.line()
    if f.line() != b"$EndMeshFormat":
        raise MshFault("no $EndMeshFormat after the format line")
    if version == 4 and not version_line[0].startswith(b"4.1"):
        raise MshFault(f"format {version_line[0].decode()} (4.1 is read; save as MSH 4.1 or 2.2)")
    if version == 2 and not version_line[0].startswith(b"2.2"):
        raise MshFault(f"format {version_line[0].decode()} (2.2 is read; save as MSH 4.1 or 2.2)")
    mesh = _Mesh(what, version, binary, order)
    seen: list[bytes] = []
    while not f.at_end():
        line = f.line().strip()
        if not line:
            continue
        if not line.startswith(b"$") or line.startswith(b"$End"):
            raise MshFault(f"a section start ('$Name') expected, found {line[:40]!r}")
        name = line[1:]
        if name not in SECTIONS:
            raise MshFault(
                f"section {line[:40].decode(errors='replace')} is not read by this package "
                "(only $PhysicalNames, $Entities, $Nodes and $Elements)"
            )
        if name in seen:
            raise MshFault(f"section ${name.decode()} appears twice")
        if name == b"Elements" and b"Nodes" not in seen:
            raise MshFault("section $Elements before $Nodes")
        if name in (b"Nodes", b"Elements") and version == 4 and b"Entities" not in seen:
            raise MshFault(f"section ${name.decode()} before $Entities")
        seen.append(name)
        _HANDLERS[name](mesh, f)
        end = f.line().strip()
        if end != b"$End" + name:
            raise MshFault(f"section ${name.decode()} does not end with $End{name.decode()}")
    for needed in (b"Nodes", b"Elements"):
        if needed not in seen:
            raise MshFault(f"no ${needed.decode()} section (truncated?)")
    mesh.geometry()
