"""The low-level readers of the MSH checks of :mod:`._msh`.

Sections, numbers (ASCII and binary) with their bounds checked before anything is allocated,
``$PhysicalNames`` and ``$Entities``, the element types, their sizes and orientations.
"""

from __future__ import annotations

import mmap
import re
import warnings
from collections.abc import Callable
from typing import Literal, cast

import numpy as np

__all__ = [
    "CHUNK",
    "ELEMENTS",
    "INT32",
    "MAX_COORDINATE",
    "MAX_LINE",
    "SECTIONS",
    "TAG_SLACK",
    "ZERO_SIZE",
    "AsciiReader",
    "BinaryReader",
    "ByteOrder",
    "ElementBlocks",
    "HeaderSections",
    "MshBytes",
    "MshFault",
    "ascii_numbers",
    "checked_ints",
    "element_problems",
    "tag_limit",
]

ByteOrder = Literal["<", ">"]
"""A binary file's byte order (numpy's notation)."""

MAX_COORDINATE = 1e100
"""Largest coordinate magnitude accepted (beyond, products of coordinates overflow)."""
ZERO_SIZE = 1e-10
"""An element whose size is below this fraction of the mean of its block has zero size."""

# gmsh element type -> (number of nodes, dimension, name)
ELEMENTS: dict[int, tuple[int, int, str]] = {
    1: (2, 1, "line"),
    2: (3, 2, "triangle"),
    3: (4, 2, "quadrilateral"),
    4: (4, 3, "tetrahedron"),
    5: (8, 3, "hexahedron"),
    6: (6, 3, "prism"),
    7: (5, 3, "pyramid"),
    8: (3, 1, "line3"),
    9: (6, 2, "triangle6"),
    10: (9, 2, "quadrilateral9"),
    11: (10, 3, "tetrahedron10"),
    12: (27, 3, "hexahedron27"),
    13: (18, 3, "prism18"),
    14: (14, 3, "pyramid14"),
    15: (1, 0, "point"),
    16: (8, 2, "quadrilateral8"),
    17: (20, 3, "hexahedron20"),
    18: (15, 3, "prism15"),
    19: (13, 3, "pyramid13"),
    20: (9, 2, "triangle9"),
    21: (10, 2, "triangle10"),
    26: (4, 1, "line4"),
    29: (20, 3, "tetrahedron20"),
    36: (16, 2, "quadrilateral16"),
}
SECTIONS = (b"PhysicalNames", b"Entities", b"Nodes", b"Elements")
_MAX_INT = 2**53  # tags are read as doubles in ASCII: exact below this
INT32 = 2**31 - 1  # gmsh keeps entity and physical tags (and format 2's tags) in an int
TAG_SLACK = 1 << 20
"""Tags beyond ``16 n + TAG_SLACK`` for ``n`` items are refused (gmsh sizes arrays by tags)."""


def tag_limit(n: int) -> int:
    """The largest tag accepted for ``n`` items."""
    return 16 * n + TAG_SLACK


_NAME = re.compile(rb'^\s*(-?\d+)\s+(-?\d+)\s+"([^"]*)"\s*$')


class MshFault(Exception):
    """A fault found (the message without the file's name)."""


class ElementBlocks:
    """Elements as read, per block.

    Its dimension, entity (v4) or elementary tag (v2), type, element tags, connectivity, and the
    physical tag of each element (v2; ``None`` in v4, where the entity has them).
    """

    def __init__(self) -> None:
        self.items: list[tuple[int, int, int, np.ndarray, np.ndarray, np.ndarray | None]] = []


_NOT_SPACE = re.compile(rb"\S")
MAX_LINE = 1 << 20
"""The longest line read as one (a section start, a count, a name): longer ones are refused
before they are copied."""


class MshBytes:
    """Sequential reading of an MSH file's bytes, every read bounded by what is left."""

    def __init__(self, data: bytes | mmap.mmap) -> None:
        self.data = data
        self.pos = 0

    def line(self) -> bytes:
        end = self.data.find(b"\n", self.pos, self.pos + MAX_LINE + 1)
        if end < 0:
            end = len(self.data)
            if end - self.pos > MAX_LINE:
                raise MshFault(f"a line of more than {MAX_LINE} bytes at byte {self.pos}")
        text = self.data[self.pos : end].rstrip(b"\r")
        self.pos = min(end + 1, len(self.data))
        return text

    def at_end(self) -> bool:
        return _NOT_SPACE.search(self.data, self.pos) is None  # (no copy of the rest)

    def body(self, name: bytes) -> bytes:
        """The text up to the line ``$End<name>`` (ASCII sections)."""
        marker = b"\n$End" + name
        end = self.data.find(marker, self.pos - 1)
        if end < 0:
            raise MshFault(f"section ${name.decode()} has no ${'End' + name.decode()} (truncated?)")
        text = self.data[self.pos : end]
        self.pos = end + 1
        return text

    def take(self, n: int, what: str) -> bytes:
        if n < 0 or self.pos + n > len(self.data):
            raise MshFault(
                f"{what}: {n} bytes needed, {len(self.data) - self.pos} left in the file "
                "(truncated, or a count too large)"
            )
        out = self.data[self.pos : self.pos + n]
        self.pos += n
        return out


def ascii_numbers(text: bytes, section: str) -> np.ndarray:
    """Every number of an ASCII section body, as doubles."""
    if not text.strip():
        return np.zeros(0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            values = np.fromstring(text, dtype=float, sep=" ")  # (bytes: no decoded copy)
    except (ValueError, DeprecationWarning, UnicodeDecodeError) as e:
        bad = next(
            (t for t in text.split() if not _is_number(t)), b"?"
        )  # only after a failure: the offending token
        raise MshFault(f"section ${section}: malformed number {bad[:40]!r}") from e
    return values


def _is_number(token: bytes) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def checked_ints(
    values: np.ndarray, what: str, *, lo: int = 0, hi: int = _MAX_INT - 1
) -> np.ndarray:
    """``values`` as integers; refused if not integral, below ``lo`` or above ``hi``."""
    if values.size and not (np.all(np.isfinite(values)) and np.all(values == np.floor(values))):
        bad = values[~(np.isfinite(values) & (values == np.floor(values)))][0]
        raise MshFault(f"{what}: {bad!r} is not an integer")
    if values.size and (values.min() < lo or values.max() > hi):
        bad = values.min() if values.min() < lo else values.max()
        raise MshFault(f"{what}: {bad:.17g} is out of range")
    return values.astype(np.int64)


class AsciiReader:
    """Reading an ASCII section's numbers in order, with bounds checks."""

    def __init__(self, values: np.ndarray, section: str) -> None:
        self.v = values
        self.i = 0
        self.section = section

    def left(self) -> int:
        return self.v.size - self.i

    def ints(self, n: int, what: str, lo: int = 0, hi: int = _MAX_INT - 1) -> np.ndarray:
        return checked_ints(self.floats(n, what), f"section ${self.section}, {what}", lo=lo, hi=hi)

    def floats(self, n: int, what: str) -> np.ndarray:
        if n < 0 or n > self.left():
            raise MshFault(
                f"section ${self.section}: {what} needs {n} numbers, {self.left()} are left "
                "(a count too large, or the section cut short)"
            )
        out = self.v[self.i : self.i + n]
        self.i += n
        return out

    def done(self) -> None:
        if self.left():
            raise MshFault(
                f"section ${self.section}: {self.left()} numbers left over after what its "
                "counts declare (a count too small)"
            )

    # (last: a method named int hides the builtin in the annotations that follow it)
    def int(self, what: str, lo: int = 0, hi: int = _MAX_INT - 1) -> int:
        return int(self.ints(1, what, lo, hi)[0])


class BinaryReader:
    """Reading binary values (the file's byte order) from a :class:`MshBytes`."""

    def __init__(self, f: MshBytes, order: ByteOrder, section: str) -> None:
        self.f, self.order, self.section = f, order, section

    def array(self, n: int, kind: str, what: str) -> np.ndarray:
        size = {"i": 4, "q": 8, "d": 8}[kind]
        if n < 0 or n > (len(self.f.data) - self.f.pos) // size:
            raise MshFault(
                f"section ${self.section}: {what} needs {n} values of {size} bytes, "
                f"{len(self.f.data) - self.f.pos} bytes are left (a count too large, or the "
                "file cut short)"
            )
        raw = self.f.take(n * size, f"section ${self.section}, {what}")
        dt = np.dtype({"i": "i4", "q": "u8", "d": "f8"}[kind]).newbyteorder(self.order)
        a = np.frombuffer(raw, dtype=dt)
        if kind == "d":
            return a.astype(float)
        if kind == "q" and a.size and a.max() >= _MAX_INT:
            raise MshFault(f"section ${self.section}, {what}: {int(a.max())} is out of range")
        return a.astype(np.int64)

    def int(self, kind: str, what: str, lo: int = 0, hi: int = _MAX_INT - 1) -> int:
        v = int(self.array(1, kind, what)[0])
        if v < lo or v > hi:
            raise MshFault(f"section ${self.section}, {what}: {v} is out of range")
        return v


# -- the sections ------------------------------------------------------------------------------


def _measure(
    etype: int, x: np.ndarray, planar: bool
) -> tuple[np.ndarray | None, str, np.ndarray | None]:
    """Signed size of each element (from its corner nodes), what it is, corner Jacobians.

    The corner Jacobians are those of quadrilaterals and hexahedra (``None`` otherwise); the size
    is ``None`` for a type not measured.
    """
    name = ELEMENTS[etype][2]
    if name.startswith("line"):
        return np.linalg.norm(x[:, 1] - x[:, 0], axis=1), "length", None
    if name.startswith("triangle"):
        a, b = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
        if planar:
            return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), "area", None
        return 0.5 * np.linalg.norm(np.cross(a, b), axis=1), "area", None
    if name.startswith("quadrilateral"):
        c = x[:, :4]
        nxt, prv = np.roll(c, -1, axis=1), np.roll(c, 1, axis=1)
        e1, e2 = nxt - c, prv - c
        if planar:
            corners = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]
            return 0.5 * (corners[:, 0] + corners[:, 2]), "area", corners
        cr = np.linalg.norm(np.cross(e1, e2), axis=2)
        return 0.5 * (cr[:, 0] + cr[:, 2]), "area", None
    if name.startswith("tetrahedron"):
        a, b, d = (x[:, i] - x[:, 0] for i in (1, 2, 3))
        return np.einsum("ij,ij->i", np.cross(a, b), d) / 6.0, "volume", None
    if name.startswith("hexahedron"):
        c = x[:, :8]
        # at each corner, the three edges to its neighbours (gmsh's node order)
        nb = [(1, 3, 4), (2, 0, 5), (3, 1, 6), (0, 2, 7)]
        nb += [(7, 5, 0), (4, 6, 1), (5, 7, 2), (6, 4, 3)]
        corners = np.stack(
            [
                np.einsum(
                    "ij,ij->i",
                    np.cross(c[:, j] - c[:, i], c[:, k] - c[:, i]),
                    c[:, m] - c[:, i],
                )
                for i, (j, k, m) in enumerate(nb)
            ],
            axis=1,
        )
        return corners.mean(axis=1), "volume", corners
    return None, "", None


class HeaderSections:
    """The sections ``$PhysicalNames`` and ``$Entities`` of :class:`._msh._Mesh`."""

    what: str
    version: int
    binary: bool
    order: ByteOrder
    names: dict[tuple[int, int], str]
    entities: dict[tuple[int, int], list[int]] | None

    # PhysicalNames (ASCII in every format)
    def physical_names(self, f: MshBytes) -> None:
        lines = f.body(b"PhysicalNames").split(b"\n")
        lines = [ln for ln in lines if ln.strip()]
        if not lines:
            raise MshFault("section $PhysicalNames is empty")
        n = checked_ints(
            ascii_numbers(lines[0], "PhysicalNames"), "section $PhysicalNames, its count"
        )
        if n.size != 1 or n[0] != len(lines) - 1:
            raise MshFault(
                f"section $PhysicalNames declares {lines[0][:20]!r} names and holds "
                f"{len(lines) - 1}"
            )
        for ln in lines[1:]:
            m = _NAME.match(ln)
            if not m or not (0 <= int(m.group(1)) <= 3 and 0 < int(m.group(2)) <= INT32):
                raise MshFault(f"section $PhysicalNames: malformed line {ln[:60]!r}")
            self.names[(int(m.group(1)), int(m.group(2)))] = m.group(3).decode(errors="replace")

    # Entities (v4)
    def entities_section(self, f: MshBytes) -> None:
        if self.version != 4:
            raise MshFault("section $Entities in a format 2 file")
        ents: dict[tuple[int, int], list[int]] = {}
        if self.binary:
            b = BinaryReader(f, self.order, "Entities")
            counts = [b.int("q", "the number of entities") for _ in range(4)]
            for dim, n in enumerate(counts):
                for _ in range(n):
                    tag = b.int("i", f"a tag of a {dim}-D entity", lo=1)
                    b.array(3 if dim == 0 else 6, "d", "a bounding box")
                    phys = b.array(b.int("q", "a number of physical tags"), "i", "physical tags")
                    bound = np.zeros(0, np.int64)
                    if dim:
                        nb = b.int("q", "a number of bounding entities")
                        bound = b.array(nb, "i", "boundary")
                    ents[(dim, tag)] = self._entity_tags(dim, tag, phys, bound, ents)
            if f.line() != b"":
                raise MshFault("section $Entities: no line end after its binary data")
        else:
            r = AsciiReader(ascii_numbers(f.body(b"Entities"), "Entities"), "Entities")
            counts = [int(c) for c in r.ints(4, "the numbers of entities")]
            if sum(counts) > r.left() // 5:
                raise MshFault(
                    f"section $Entities declares {sum(counts)} entities and holds "
                    f"{r.left()} numbers"
                )
            for dim, n in enumerate(counts):
                for _ in range(n):
                    tag = r.int(f"a tag of a {dim}-D entity", lo=1, hi=INT32)
                    r.floats(3 if dim == 0 else 6, "a bounding box")
                    n = r.int("a number of physical tags")
                    phys = r.ints(n, "physical tags", lo=-INT32, hi=INT32)
                    bound = np.zeros(0, np.int64)
                    if dim:
                        n = r.int("a number of bounding entities")
                        bound = r.ints(n, "boundary", lo=-INT32, hi=INT32)
                    ents[(dim, tag)] = self._entity_tags(dim, tag, phys, bound, ents)
            r.done()
        self.entities = ents

    @staticmethod
    def _entity_tags(
        dim: int, tag: int, phys: np.ndarray, bound: np.ndarray, ents: dict
    ) -> list[int]:
        """An entity's physical tags, its boundary checked against the entities before it."""
        if (dim, tag) in ents:
            raise MshFault(f"section $Entities: the {dim}-D entity {tag} appears twice")
        if phys.size and (np.any(phys == 0) or np.abs(phys).max() > INT32):
            raise MshFault(f"section $Entities: the {dim}-D entity {tag} has a physical tag 0")
        for t in bound:
            if (dim - 1, abs(int(t))) not in ents:
                raise MshFault(
                    f"section $Entities: the {dim}-D entity {tag} is bounded by the "
                    f"{dim - 1}-D entity {abs(int(t))}, not declared before it"
                )
        return [abs(int(p)) for p in phys]


CHUNK = 1 << 16
"""Elements whose coordinates are gathered at once (bounds the memory of the checks)."""


def element_problems(
    blocks: list, node_tags: np.ndarray, coords: np.ndarray, group: Callable[..., str]
) -> list[str]:
    """Zero-size and inverted elements of the mesh's dimension and of one below (at most 3).

    Args:
        blocks: ``(dim, entity, type, element tags, connectivity, physical tags)`` of each block.
        node_tags: The nodes' tags.
        coords: Their coordinates (n, 3).
        group: ``group(dim, entity, physical tags, i)`` names an element's physical group.
    """
    if not blocks or not node_tags.size:
        return []
    top = max(b[0] for b in blocks)
    flat = top == 2 and bool(np.all(coords[:, 2] == coords[0, 2]))
    order = np.argsort(node_tags)
    sorted_tags = node_tags[order]
    problems: list[str] = []
    for dim, ent, etype, etags, conn, phys in blocks:
        if dim not in (top, top - 1) or dim < 1:
            continue
        parts = []  # in chunks: the memory of the coordinates gathered is bounded
        for lo in range(0, max(len(conn), 1), CHUNK):
            x = coords[order[np.searchsorted(sorted_tags, conn[lo : lo + CHUNK])]]
            parts.append(_measure(etype, x, flat and dim == 2))
        first, kind, first_corners = parts[0]
        if first is None:
            continue
        # (every part of a block is of its type: all measured, all with corners or none)
        measure = np.concatenate([cast(np.ndarray, m) for m, _, _ in parts])
        corners = None
        if first_corners is not None:  # the corners' signs only
            corners = np.concatenate(
                [np.sign(cast(np.ndarray, c)).astype(np.int8) for _, _, c in parts]
            )
        del parts
        size = np.abs(measure)
        mean = float(size.mean()) if size.size else 0.0
        zero = size <= ZERO_SIZE * mean if mean > 0 else np.ones(size.shape, bool)
        for i in np.flatnonzero(zero)[:3]:
            problems.append(
                f"element {int(etags[i])} ({ELEMENTS[etype][2]}) of "
                f"{group(dim, ent, phys, i)} has zero {kind} ({size[i]:.3g})"
            )
        signed = dim == top and (dim == 3 or flat)
        if signed and size.size:
            sign = np.sign(measure)
            major = 1.0 if np.count_nonzero(sign > 0) >= np.count_nonzero(sign < 0) else -1.0
            bad = (sign == -major) & ~zero
            if corners is not None:  # quadrilaterals, hexahedra: every corner alike
                bad |= np.any(np.sign(corners) != major, axis=1) & ~zero
            for i in np.flatnonzero(bad)[:3]:
                problems.append(
                    f"element {int(etags[i])} ({ELEMENTS[etype][2]}) of "
                    f"{group(dim, ent, phys, i)} is inverted (its orientation is "
                    "opposite to the other elements of its block, or its corners disagree)"
                )
        if len(problems) >= 3:
            break
    return problems[:3]
