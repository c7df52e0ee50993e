"""Duplicating the nodes of interface groups: two bodies meshed together become two bodies apart.

A zero-thickness interface needs the two bodies' own nodes on it. Mesh them together (fragment
the geometry so that the interface is a shared curve or surface, name the interface's facets as a
physical group) and let :func:`duplicate_interface_nodes` split them: it runs gmsh's Crack plugin
on each interface group, with the whole boundary of the interface open (the bodies come apart
along all of it, its ends included), the secondary body receiving the new nodes; then it renumbers
the nodes and elements, so that the result is readable by DOLFINx's own gmsh reader
(``dolfinx.io.gmshio`` / ``dolfinx.io.gmsh``) as well as by :func:`~.reader.read_interface_mesh`.

It works on the current gmsh model (e.g. right after your own geometry and ``generate``) or on a
``.msh`` file, written to another file::

    gmsh.model.mesh.generate(2)
    duplicate_interface_nodes(None, {"contact": ("base", "block")})
    domain = read_interface_mesh(None, comm, 2, interfaces={"contact": ("base", "block")})

    duplicate_interface_nodes("joined.msh", ["contact"], output="apart.msh")

Both sides of a duplicated interface keep the interface's physical group (each is then an exterior
facet of its own body); which side is which is told by the adjacent cell's body. Interface
regions (facet groups lying on an interface) are kept as they are.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import mmap
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ._msh import check_msh_header, open_msh
from .groups import InterfaceMeshError, gmsh_module, gmsh_session, group_elements

__all__ = ["CrackedInterface", "duplicate_interface_nodes"]


@dataclasses.dataclass(frozen=True)
class CrackedInterface:
    """What :func:`duplicate_interface_nodes` did to one interface group.

    Attributes:
        name: The interface group.
        primary: The cell groups on its primary side (they keep the original nodes).
        secondary: The cell groups on its secondary side (they receive the new nodes).
        facets: Interface elements on each side.
        new_nodes: Nodes added.
    """

    name: str
    primary: tuple[str, ...]
    secondary: tuple[str, ...]
    facets: int
    new_nodes: int


def duplicate_interface_nodes(
    source: str | os.PathLike | None,
    interfaces: str | Sequence[str] | Mapping[str, tuple[Any, Any]],
    *,
    output: str | os.PathLike | None = None,
) -> dict[str, CrackedInterface]:
    """Duplicate the nodes of interface groups (gmsh's Crack plugin), then renumber.

    Call it on one process (rank 0 under MPI; the reader then distributes the mesh).

    Args:
        source: ``None`` for the current gmsh model, or an MSH file (format 2 or 4; nothing else
            reaches gmsh), read into a model of its own and written to ``output``.
        interfaces: The interface group(s) by name; or group -> (primary, secondary), each a
            cell group or a list of cell groups (a body), the secondary receiving the new
            nodes. Without sides, the two cell groups its facets touch, the one with the larger
            physical tag being the secondary.
        output: Where to write the result (required with a file ``source``; optional with the
            current model). Written to a new file beside it, checked whole (a full disk leaves
            gmsh's file short without an error), then renamed over it: a failed write leaves no
            partial file and what was at ``output`` intact. A symbolic link, a directory or
            another file that is not a regular one at ``output`` is refused.

    Returns:
        Interface -> :class:`CrackedInterface`.

    Raises:
        FileNotFoundError: ``source`` does not exist.
        InterfaceMeshError: Not an MSH file (a directory, a FIFO, ...), an unknown group, sides
            that share a cell group, an interface that does not separate two bodies, elements
            not consistently oriented within a gmsh entity, or an ``output`` that is not a
            regular file.
        OSError: The output could not be written whole (the OS error, e.g. no space left).
    """
    if isinstance(interfaces, str):
        interfaces = [interfaces]
    sides: dict[str, tuple[Any, Any] | None] = (
        {k: v for k, v in interfaces.items()}
        if isinstance(interfaces, Mapping)
        else {k: None for k in interfaces}
    )
    if source is not None and output is None:
        raise ValueError("duplicate_interface_nodes: a file source needs an output file")
    if output is not None:
        _check_output(Path(output))
    gmsh = gmsh_module()
    with contextlib.ExitStack() as stack:
        if source is not None:
            name = stack.enter_context(open_msh(Path(source)))
            stack.enter_context(gmsh_session(f"subfric-crack-{os.getpid()}"))
            try:
                gmsh.merge(name)
            except Exception as e:
                raise InterfaceMeshError(f"gmsh could not read {source}: {e}") from e
        elif not gmsh.isInitialized() or not gmsh.model.list():
            raise InterfaceMeshError("duplicate_interface_nodes(None): no current gmsh model")
        groups = _named_groups()
        gdim = max((d for d, _ in groups.values()), default=0)
        out = {}
        for iface, given in sides.items():
            out[iface] = _crack_one(iface, given, groups, gdim)
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()
        if output is not None:
            _write(Path(output))
    return out


def _check_output(path: Path) -> None:
    """Refuse an output name that is a link, a directory or another non-regular file."""
    if path.is_symlink():
        raise InterfaceMeshError(
            f"output {str(path)!r} is a symbolic link (to {os.readlink(path)!r}): not written "
            "through; remove it, or give another name"
        )
    if os.path.lexists(path) and not path.is_file():
        kind = "a directory" if path.is_dir() else "not a regular file"
        raise InterfaceMeshError(f"output {str(path)!r} is {kind}: not written")


def _not_whole(path: Path) -> str:
    """What shows a written MSH file cut short (empty: it looks whole).

    Its header, both ``$EndNodes`` and ``$EndElements``, and a last line ``$End...``.
    """
    size = path.stat().st_size
    if size == 0:
        return "it is empty"
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
        try:
            check_msh_header(m[:256], str(path))
        except InterfaceMeshError:
            return "no MSH header"
        for marker in (b"\n$EndNodes", b"\n$EndElements"):
            if m.find(marker) < 0:
                return f"no {marker.decode().strip()}"
        tail = m[max(0, size - 256) :].rstrip()
    if not tail.rsplit(b"\n", 1)[-1].startswith(b"$End"):
        return "its last section does not end"
    return ""


def _write(path: Path) -> None:
    """Write the current model to ``path`` through a checked temporary file (see above)."""
    gmsh = gmsh_module()
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".msh", dir=path.parent or ".")
    tmp = Path(name)
    try:
        os.close(fd)
        gmsh.write(str(tmp))
        fd = os.open(tmp, os.O_RDONLY | os.O_NOFOLLOW)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        short = _not_whole(tmp)
        if short:
            free = shutil.disk_usage(tmp.parent).free
            raise OSError(
                errno.EIO,
                f"writing {str(path)!r} failed: gmsh's file is not whole ({short}); {free} bytes "
                "free on its file system",
            )
        _check_output(path)  # (again: the name may have changed meanwhile)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _named_groups() -> dict[str, tuple[int, int]]:
    gmsh = gmsh_module()
    out = {}
    for d, t in gmsh.model.getPhysicalGroups():
        name = gmsh.model.getPhysicalName(d, t)
        if name:
            out[name] = (d, t)
    return out


def _cell_groups(value: Any, groups: dict[str, tuple[int, int]], gdim: int, what: str) -> list[str]:
    names = [value] if isinstance(value, str) else list(value)
    for n in names:
        if groups.get(n, (None,))[0] != gdim:
            raise InterfaceMeshError(f"{what}: {n!r} is not a {gdim}-D physical group")
    return names


def _crack_one(
    iface: str, given: Any, groups: dict[str, tuple[int, int]], gdim: int
) -> CrackedInterface:
    """Orient the interface's entities (secondary side on the positive side) and run Crack."""
    gmsh = gmsh_module()
    fdim = gdim - 1
    if groups.get(iface, (None,))[0] != fdim:
        raise InterfaceMeshError(
            f"interface {iface!r}: not a {fdim}-D physical group; groups: {sorted(groups)}"
        )
    tag = groups[iface][1]
    cells = {n: group_elements(gdim, t)[1] for n, (d, t) in groups.items() if d == gdim}
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(ntags.max()) + 1, 3))
    x[ntags] = np.asarray(coords).reshape(-1, 3)
    n_before = ntags.size
    entities = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(fdim, tag)]
    facets = []
    for e in entities:
        etypes, _, enodes = gmsh.model.mesh.getElements(fdim, e)
        props = gmsh.model.mesh.getElementProperties(int(etypes[0]))
        conn = np.asarray(enodes[0], dtype=np.int64).reshape(-1, props[3])[:, : props[5]]
        facets.append(conn)
    if given is None:
        touch = _touching(np.concatenate(facets), cells)
        if len(touch) != 2:
            raise InterfaceMeshError(
                f"interface {iface!r}: its facets touch the cell groups {touch}, not two; give "
                "its sides (interfaces={name: (primary, secondary)})"
            )
        first, second = sorted(touch, key=lambda n: groups[n][1])
        primary, secondary = [first], [second]
    else:
        if not (isinstance(given, Sequence) and not isinstance(given, str) and len(given) == 2):
            raise InterfaceMeshError(f"interface {iface!r}: sides must be (primary, secondary)")
        primary = _cell_groups(given[0], groups, gdim, f"interface {iface!r}")
        secondary = _cell_groups(given[1], groups, gdim, f"interface {iface!r}")
        both = sorted(set(primary) & set(secondary))
        if both:
            raise InterfaceMeshError(
                f"interface {iface!r}: its sides share the cell group(s) {both}; the primary "
                "and the secondary side are two different bodies"
            )
    sec = [c for n in secondary for c in cells[n]]
    widths = {c.shape[1] for c in sec}
    if len(widths) != 1:
        raise InterfaceMeshError(f"interface {iface!r}: expected one cell type, found several")
    sec_cells = np.concatenate(sec)
    normal_z = 0.0
    for e, conn in zip(entities, facets, strict=True):
        s = _side_signs(conn, x, sec_cells, gdim)
        if np.any(s == 0):
            raise InterfaceMeshError(
                f"interface {iface!r}: {int(np.count_nonzero(s == 0))} facets of the gmsh entity "
                f"{e} touch no cell of {secondary}"
            )
        if not (np.all(s > 0) or np.all(s < 0)):
            raise InterfaceMeshError(
                f"interface {iface!r}: the elements of the gmsh entity {e} are not consistently "
                "oriented"
            )
        if gdim == 2:
            if normal_z == 0.0:  # Crack's side normal is (0, 0, NormalZ) x tangent
                normal_z = 1.0 if s[0] > 0 else -1.0
            elif (s[0] > 0) != (normal_z > 0):
                gmsh.model.mesh.reverse([(fdim, e)])
        else:  # the element normal: make it point into the secondary side
            normal_z = 1.0
            if s[0] < 0:
                gmsh.model.mesh.reverse([(fdim, e)])
    open_tag, added = _open_boundary(fdim, entities, np.concatenate(facets))
    for option, value in (
        ("Dimension", fdim),
        ("PhysicalGroup", tag),
        ("OpenBoundaryPhysicalGroup", open_tag),
        ("NormalX", 0.0),
        ("NormalY", 0.0),
        ("NormalZ", normal_z),
        ("NewPhysicalGroup", 0),
        ("DebugView", 0),
    ):
        gmsh.plugin.setNumber("Crack", option, value)
    gmsh.plugin.run("Crack")
    gmsh.model.removePhysicalGroups([(fdim - 1, open_tag)])
    if added is not None:
        gmsh.model.removeEntities([(fdim - 1, added)])
    n_after = gmsh.model.mesh.getNodes()[0].size
    return CrackedInterface(
        iface,
        tuple(primary),
        tuple(secondary),
        int(sum(f.shape[0] for f in facets)),
        int(n_after - n_before),
    )


def _open_boundary(fdim: int, entities: list[int], facets: np.ndarray) -> tuple[int, int | None]:
    """A physical group of the interface's boundary (its ends in 2-D, its edge lines in 3-D).

    The boundary entities' own elements where they have some (a model meshed here); otherwise
    (a model read from a file saved without them) a discrete entity made of the interface's
    boundary: its end nodes (2-D) or the element edges that belong to one element only (3-D).

    Returns:
        The group's tag and the discrete entity added (``None`` if none; remove it after use).
    """
    gmsh = gmsh_module()
    boundary = gmsh.model.getBoundary([(fdim, e) for e in entities], combined=True, oriented=False)
    ents = sorted({abs(t) for _, t in boundary})
    meshed = all(any(len(t) for t in gmsh.model.mesh.getElements(fdim - 1, e)[1]) for e in ents)
    if ents and meshed:
        return gmsh.model.addPhysicalGroup(fdim - 1, ents), None
    if fdim == 1:
        nodes, counts = np.unique(facets[:, :2], return_counts=True)
        ends = nodes[counts == 1]
        etype, conn = 15, ends  # points
    else:
        nv = facets.shape[1]
        edges = np.sort(np.concatenate([facets[:, [i, (i + 1) % nv]] for i in range(nv)]), axis=1)
        uniq, counts = np.unique(edges, axis=0, return_counts=True)
        etype, conn = 1, uniq[counts == 1].ravel()  # 2-node lines
    added = gmsh.model.addDiscreteEntity(fdim - 1)
    gmsh.model.mesh.addElementsByType(added, etype, [], conn.astype(np.uint64).tolist())
    return gmsh.model.addPhysicalGroup(fdim - 1, [added]), added


def _touching(facets: np.ndarray, cells: dict[str, list[np.ndarray]]) -> list[str]:
    """The cell groups with a cell holding every corner of some interface facet."""
    out = []
    for name, conns in cells.items():
        conn = np.concatenate(conns) if conns else np.zeros((0, 1), np.int64)
        if _side_signs_any(facets, conn):
            out.append(name)
    return out


def _side_signs_any(facets: np.ndarray, conn: np.ndarray) -> bool:
    nodes = np.unique(conn)
    inside = np.isin(facets, nodes).all(axis=1)
    return bool(inside.any())


def _side_signs(facets: np.ndarray, x: np.ndarray, cells: np.ndarray, gdim: int) -> np.ndarray:
    """+1/-1 per facet: whether its Crack side normal points into an adjacent cell.

    ``cells``: node lists of the secondary body's cells; 0 where none of them holds the facet.
    """
    corners = cells
    order = np.argsort(corners.ravel(), kind="stable")
    flat = corners.ravel()[order]
    owner = order // corners.shape[1]
    out = np.zeros(facets.shape[0])
    for i, f in enumerate(facets):
        lo, hi = np.searchsorted(flat, f[0]), np.searchsorted(flat, f[0], side="right")
        for c in owner[lo:hi]:
            if np.isin(f, corners[c]).all():
                d = x[corners[c]].mean(axis=0) - x[f].mean(axis=0)
                if gdim == 2:
                    t = x[f[1]] - x[f[0]]
                    n = np.array([-t[1], t[0], 0.0])
                else:
                    n = np.cross(x[f[1]] - x[f[0]], x[f[2]] - x[f[0]])
                out[i] = np.sign(n @ d)
                break
    return out
