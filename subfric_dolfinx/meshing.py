"""Meshes of two elastic bodies joined by a zero-thickness interface with duplicated nodes.

Layout of a model (2-D "block on a base", 3-D "pad on a plate")::

            +-----------+            <- "top"          (slave)
            |   slave   |
    +-------+-----------+-------+    <- "interface" (block bottom) and "master_top" (free parts)
    |          master           |
    +---------------------------+    <- "bottom"       (master)

The two bodies touch along a flat interface (the slave's bottom face, which may be only part of the
master's top face). Every interface node exists twice, at the same coordinates, once per body, and
the bodies share no node at all (the interface ends are detached too): the bodies are connected
only through the interface elements built on top of this mesh.

Physical groups, by name (the names are module constants; integer tags are in :data:`TAGS`):

* ``master`` (cells): the base / plate, the body whose outward normal on the interface defines
  the interface frame; ``slave`` (cells): the block / pad.
* ``interface`` (facets): carried by *both* sides, each side being an exterior facet of its own
  body. Tell the sides apart by the body of the adjacent cell
  (:meth:`InterfaceMesh.interface_facets`), never by assumption.
* ``bottom``: bottom of the master (y = 0 in 2-D, z = 0 in 3-D); ``top``: top of the slave;
  ``master_top``: free part of the master's top face (only when the slave is narrower).
* 2-D sides: ``master_left``/``master_right`` (x = x_min / x_max of the master) and
  ``slave_left``/``slave_right``.
* 3-D sides: ``master_xmin``, ``master_xmax``, ``master_ymin``, ``master_ymax`` and
  ``slave_xmin``, ``slave_xmax``, ``slave_ymin``, ``slave_ymax``.

The builders (:func:`build_block_on_base`, :func:`build_pad_on_plate`) make a gmsh model in the
current gmsh session; call them on one rank (rank 0) only. The nodes are duplicated with gmsh's
Crack plugin (with ``OpenBoundaryPhysicalGroup`` so that the interface ends come apart too), the
interface mesh being oriented so that the slave side receives the new nodes; elements lying in the
interface plane (the free part of the master's top face) keep the master's nodes.

:func:`read_interface_mesh` reads a ``.msh`` file or the current gmsh model into DOLFINx,
collectively, with checks whose failures are raised on all ranks; :func:`create_interface_mesh`
builds and reads in one call; :func:`body_partitioner` gives deterministic cell distributions for
tests (one body per rank, or each interface pair on one rank).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import dolfinx
import dolfinx.cpp
import dolfinx.graph
import dolfinx.io.gmshio
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = [
    "BODIES",
    "BOTTOM",
    "BOUNDARY_GROUPS_2D",
    "BOUNDARY_GROUPS_3D",
    "INTERFACE",
    "MASTER",
    "MASTER_LEFT",
    "MASTER_RIGHT",
    "MASTER_TOP",
    "MASTER_XMAX",
    "MASTER_XMIN",
    "MASTER_YMAX",
    "MASTER_YMIN",
    "PARTITIONER_KINDS",
    "REQUIRED_GROUPS",
    "SLAVE",
    "SLAVE_LEFT",
    "SLAVE_RIGHT",
    "SLAVE_XMAX",
    "SLAVE_XMIN",
    "SLAVE_YMAX",
    "SLAVE_YMIN",
    "TAGS",
    "TOP",
    "InterfaceMesh",
    "InterfaceMeshError",
    "ModelInfo",
    "body_partitioner",
    "build_block_on_base",
    "build_pad_on_plate",
    "create_interface_mesh",
    "read_interface_mesh",
]

# --- physical-group names ------------------------------------------------------------------------
MASTER = "master"
SLAVE = "slave"
INTERFACE = "interface"
BOTTOM = "bottom"
TOP = "top"
MASTER_TOP = "master_top"
MASTER_LEFT = "master_left"
MASTER_RIGHT = "master_right"
SLAVE_LEFT = "slave_left"
SLAVE_RIGHT = "slave_right"
MASTER_XMIN = "master_xmin"
MASTER_XMAX = "master_xmax"
MASTER_YMIN = "master_ymin"
MASTER_YMAX = "master_ymax"
SLAVE_XMIN = "slave_xmin"
SLAVE_XMAX = "slave_xmax"
SLAVE_YMIN = "slave_ymin"
SLAVE_YMAX = "slave_ymax"

#: The two bodies (cell groups), master first.
BODIES: tuple[str, str] = (MASTER, SLAVE)
#: Groups :func:`read_interface_mesh` requires by default.
REQUIRED_GROUPS: tuple[str, ...] = (MASTER, SLAVE, INTERFACE)
#: Boundary facet groups of the 2-D builder (``master_top`` only when the block is narrower).
BOUNDARY_GROUPS_2D: tuple[str, ...] = (
    BOTTOM, TOP, MASTER_TOP, MASTER_LEFT, MASTER_RIGHT, SLAVE_LEFT, SLAVE_RIGHT,
)  # fmt: skip
#: Boundary facet groups of the 3-D builder (``master_top`` only when the pad is smaller).
BOUNDARY_GROUPS_3D: tuple[str, ...] = (
    BOTTOM, TOP, MASTER_TOP, MASTER_XMIN, MASTER_XMAX, MASTER_YMIN, MASTER_YMAX,
    SLAVE_XMIN, SLAVE_XMAX, SLAVE_YMIN, SLAVE_YMAX,
)  # fmt: skip
#: Integer tags the builders give the groups (files may use others: look tags up by name).
TAGS: dict[str, int] = {
    MASTER: 1, SLAVE: 2, INTERFACE: 3, BOTTOM: 4, TOP: 5, MASTER_TOP: 6,
    MASTER_LEFT: 7, MASTER_RIGHT: 8, SLAVE_LEFT: 9, SLAVE_RIGHT: 10,
    MASTER_XMIN: 11, MASTER_XMAX: 12, MASTER_YMIN: 13, MASTER_YMAX: 14,
    SLAVE_XMIN: 15, SLAVE_XMAX: 16, SLAVE_YMIN: 17, SLAVE_YMAX: 18,
}  # fmt: skip
#: Kinds understood by :func:`body_partitioner`.
PARTITIONER_KINDS: tuple[str, ...] = ("default", "bodies", "together")

_CELL_TYPES = {2: ("triangle", "quadrilateral"), 3: ("tetrahedron", "hexahedron")}
_RECOMBINED = ("quadrilateral", "hexahedron")


class InterfaceMeshError(ValueError):
    """A mesh does not describe two bodies joined by a duplicated-node interface."""


# --- gmsh session helpers ------------------------------------------------------------------------
def _gmsh():
    try:
        import gmsh
    except ModuleNotFoundError as e:  # pragma: no cover - gmsh is installed where tests run
        raise ModuleNotFoundError(
            "subfric_dolfinx.meshing needs the gmsh Python module (pip extra 'mesh')", name="gmsh"
        ) from e
    return gmsh


@contextlib.contextmanager
def _gmsh_session(model_name: str | None) -> Iterator[Any]:
    """Initialise gmsh if needed and, if ``model_name`` is given, work in a fresh model.

    On exit the fresh model is removed, the previously current model restored, and gmsh finalised
    if it was initialised here.
    """
    gmsh = _gmsh()
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Verbosity", 2)
    previous = gmsh.model.getCurrent() if not own else None
    try:
        if model_name is not None:
            gmsh.model.add(model_name)
        yield gmsh
    finally:
        if model_name is not None and gmsh.isInitialized():
            gmsh.model.setCurrent(model_name)
            gmsh.model.remove()
            if previous:
                gmsh.model.setCurrent(previous)
        if own and gmsh.isInitialized():
            gmsh.finalize()


# --- builders -------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ModelInfo:
    """Description of a model made by a builder.

    Attributes:
        model: Name of the gmsh model.
        gdim: Geometric (= topological) dimension of the bodies.
        cell_type: DOLFINx cell-type name of the cells.
        tags: Physical-group name -> integer tag, for the groups present.
        h: Element size along the interface.
        interface_min: Lower corner of the interface's bounding box.
        interface_max: Upper corner of the interface's bounding box.
        num_cells: Number of cells per body, ``{"master": ..., "slave": ...}``.
        num_interface_facets: Number of interface facets on each side.
        num_interface_nodes: Number of interface nodes on each side.
    """

    model: str
    gdim: int
    cell_type: str
    tags: dict[str, int]
    h: float
    interface_min: tuple[float, ...]
    interface_max: tuple[float, ...]
    num_cells: dict[str, int]
    num_interface_facets: int
    num_interface_nodes: int


def _segments(lo: float, hi: float, a: float, b: float) -> list[tuple[float, float]]:
    """Split [lo, hi] at a and b (which lie in it), dropping empty pieces."""
    cuts = sorted({lo, a, b, hi})
    return [(c0, c1) for c0, c1 in itertools.pairwise(cuts) if c1 - c0 > 0.0]


def _check_cell_type(gdim: int, cell_type: str) -> None:
    if cell_type not in _CELL_TYPES[gdim]:
        raise ValueError(
            f"cell_type must be one of {_CELL_TYPES[gdim]} for a {gdim}-D model, got {cell_type!r}"
        )


def _positive(**values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")


def _interface_size(width: float, n_interface: int | None, mesh_size: float | None) -> float:
    if mesh_size is not None:
        _positive(mesh_size=mesh_size)
        n_interface = max(1, round(width / mesh_size))
    if n_interface is None or int(n_interface) != n_interface or n_interface < 1:
        raise ValueError(f"n_interface must be a positive integer, got {n_interface!r}")
    return width / int(n_interface)


def build_block_on_base(
    *,
    base_width: float = 2.0,
    base_height: float = 0.5,
    block_width: float = 1.0,
    block_height: float = 0.5,
    block_x: float | None = None,
    n_interface: int | None = 8,
    mesh_size: float | None = None,
    cell_type: str = "triangle",
    model_name: str = "block_on_base",
) -> ModelInfo:
    """Build the 2-D "block on a base" model in the current gmsh session (call on one rank).

    The base (``master``) is ``[0, base_width] x [0, base_height]``; the block (``slave``) is
    ``[block_x, block_x + block_width] x [base_height, base_height + block_height]``. The interface
    is the block's bottom edge. Every curve is divided uniformly into ``round(length / h)``
    elements with ``h = block_width / n_interface``; quadrilateral meshes are structured,
    triangle meshes are unstructured inside.

    Args:
        base_width: Width of the base.
        base_height: Height of the base.
        block_width: Width of the block, at most ``base_width``.
        block_height: Height of the block.
        block_x: Left end of the block (default: centred on the base).
        n_interface: Number of elements along the interface.
        mesh_size: Element size; if given it sets ``n_interface = round(block_width / mesh_size)``.
        cell_type: ``"triangle"`` or ``"quadrilateral"``.
        model_name: Name of the gmsh model added to the session (it becomes the current model).

    Returns:
        Description of the model.

    Raises:
        ValueError: Invalid sizes or cell type.
        RuntimeError: gmsh did not produce two bodies joined only by a duplicated interface.
    """
    _check_cell_type(2, cell_type)
    _positive(
        base_width=base_width, base_height=base_height,
        block_width=block_width, block_height=block_height,
    )  # fmt: skip
    if block_x is None:
        block_x = 0.5 * (base_width - block_width)
    if block_x < 0 or block_x + block_width > base_width * (1 + 1e-12):
        raise ValueError(
            f"the block [{block_x}, {block_x + block_width}] must lie on the base [0, {base_width}]"
        )
    h = _interface_size(block_width, n_interface, mesh_size)
    return _build(
        gdim=2,
        master_box=((0.0, 0.0), (base_width, base_height)),
        slave_box=((block_x, base_height), (block_x + block_width, base_height + block_height)),
        h=h,
        cell_type=cell_type,
        model_name=model_name,
    )


def build_pad_on_plate(
    *,
    plate_size: Sequence[float] = (2.0, 2.0, 0.5),
    pad_size: Sequence[float] = (1.0, 1.0, 0.5),
    pad_origin: Sequence[float] | None = None,
    n_interface: int | None = 4,
    mesh_size: float | None = None,
    cell_type: str = "tetrahedron",
    model_name: str = "pad_on_plate",
) -> ModelInfo:
    """Build the 3-D "pad on a plate" model in the current gmsh session (call on one rank).

    The plate (``master``) is ``[0, Lx] x [0, Ly] x [0, Lz]`` with ``plate_size = (Lx, Ly, Lz)``;
    the pad (``slave``) is the box of size ``pad_size`` whose lower corner is
    ``(pad_origin[0], pad_origin[1], Lz)``. The interface is the pad's bottom face. Every curve is
    divided uniformly into ``length / h`` (rounded) elements with ``h = pad_size[0] / n_interface``;
    hexahedral meshes are structured, tetrahedral meshes unstructured inside.

    Args:
        plate_size: Plate extents (x, y, z).
        pad_size: Pad extents (x, y, z); the footprint must fit on the plate.
        pad_origin: (x, y) of the pad's lower corner (default: centred on the plate).
        n_interface: Number of elements along the pad's x side.
        mesh_size: Element size; if given it sets ``n_interface = round(pad_size[0] / mesh_size)``.
        cell_type: ``"tetrahedron"`` or ``"hexahedron"``.
        model_name: Name of the gmsh model added to the session (it becomes the current model).

    Returns:
        Description of the model.

    Raises:
        ValueError: Invalid sizes or cell type.
        RuntimeError: gmsh did not produce two bodies joined only by a duplicated interface.
    """
    _check_cell_type(3, cell_type)
    plate = tuple(float(v) for v in plate_size)
    pad = tuple(float(v) for v in pad_size)
    if len(plate) != 3 or len(pad) != 3:
        raise ValueError("plate_size and pad_size must have three entries (x, y, z)")
    _positive(**{f"plate_size[{i}]": v for i, v in enumerate(plate)})
    _positive(**{f"pad_size[{i}]": v for i, v in enumerate(pad)})
    if pad_origin is None:
        pad_origin = (0.5 * (plate[0] - pad[0]), 0.5 * (plate[1] - pad[1]))
    ox, oy = (float(v) for v in pad_origin)
    for o, a, length, axis in ((ox, pad[0], plate[0], "x"), (oy, pad[1], plate[1], "y")):
        if o < 0 or o + a > length * (1 + 1e-12):
            raise ValueError(
                f"the pad [{o}, {o + a}] must lie on the plate [0, {length}] in {axis}"
            )
    h = _interface_size(pad[0], n_interface, mesh_size)
    return _build(
        gdim=3,
        master_box=((0.0, 0.0, 0.0), plate),
        slave_box=((ox, oy, plate[2]), (ox + pad[0], oy + pad[1], plate[2] + pad[2])),
        h=h,
        cell_type=cell_type,
        model_name=model_name,
    )


def _build(
    *,
    gdim: int,
    master_box: tuple[Sequence[float], Sequence[float]],
    slave_box: tuple[Sequence[float], Sequence[float]],
    h: float,
    cell_type: str,
    model_name: str,
) -> ModelInfo:
    gmsh = _gmsh()
    if not gmsh.isInitialized():
        raise RuntimeError("gmsh is not initialised: call gmsh.initialize() before a builder")
    occ = gmsh.model.occ
    (m0, m1), (s0, s1) = master_box, slave_box
    z_if = m1[gdim - 1]  # interface height
    scale = max(max(m1) - min(m0), max(s1) - min(s0))
    tol = 1e-7 * scale
    gmsh.model.add(model_name)

    # Master pieces: the master box cut along the slave's footprint, so that the interface is one
    # face (curve) and every piece is a box (rectangle) for structured meshing.
    xs = _segments(m0[0], m1[0], s0[0], s1[0])
    ys = _segments(m0[1], m1[1], s0[1], s1[1]) if gdim == 3 else [(m0[1], m1[1])]
    pieces = []
    for x0, x1 in xs:
        if gdim == 2:
            pieces.append((2, occ.addRectangle(x0, m0[1], 0.0, x1 - x0, m1[1] - m0[1])))
        else:
            for y0, y1 in ys:
                pieces.append((3, occ.addBox(x0, y0, m0[2], x1 - x0, y1 - y0, m1[2] - m0[2])))
    ext = [b - a for a, b in zip(s0, s1, strict=True)]
    if gdim == 2:
        slave = (2, occ.addRectangle(s0[0], s0[1], 0.0, *ext))
    else:
        slave = (3, occ.addBox(*s0, *ext))
    occ.fragment(pieces, [slave])
    occ.synchronize()

    def com(dim: int, tag: int) -> np.ndarray:
        return np.asarray(occ.getCenterOfMass(dim, tag))[:gdim]

    def extent(dim: int, tag: int) -> np.ndarray:
        b = gmsh.model.getBoundingBox(dim, tag)
        return np.asarray(b[3:])[:gdim] - np.asarray(b[:3])[:gdim]

    # cells
    groups: dict[str, list[int]] = {MASTER: [], SLAVE: []}
    for _, tag in gmsh.model.getEntities(gdim):
        groups[SLAVE if com(gdim, tag)[-1] > z_if else MASTER].append(tag)
    if len(groups[SLAVE]) != 1 or len(groups[MASTER]) != len(pieces):
        raise RuntimeError(f"unexpected geometry after fragment: {groups}")

    # facets, by position and normal direction
    side_names = (
        {0: (MASTER_LEFT, MASTER_RIGHT, SLAVE_LEFT, SLAVE_RIGHT)}
        if gdim == 2
        else {
            0: (MASTER_XMIN, MASTER_XMAX, SLAVE_XMIN, SLAVE_XMAX),
            1: (MASTER_YMIN, MASTER_YMAX, SLAVE_YMIN, SLAVE_YMAX),
        }
    )
    fdim = gdim - 1
    for _, tag in gmsh.model.getEntities(fdim):
        c, e = com(fdim, tag), extent(fdim, tag)
        normal_axis = int(np.argmin(np.abs(e)))
        top_axis = gdim - 1
        name = None
        if normal_axis == top_axis:
            if abs(c[-1] - m0[-1]) < tol:
                name = BOTTOM
            elif abs(c[-1] - s1[-1]) < tol:
                name = TOP
            elif abs(c[-1] - z_if) < tol:
                inside = all(s0[i] - tol < c[i] < s1[i] + tol for i in range(gdim - 1))
                name = INTERFACE if inside else MASTER_TOP
        else:
            ax = normal_axis
            lower = c[-1] < z_if
            lo, hi = (m0[ax], m1[ax]) if lower else (s0[ax], s1[ax])
            names = side_names[ax]
            if abs(c[ax] - lo) < tol:
                name = names[0] if lower else names[2]
            elif abs(c[ax] - hi) < tol:
                name = names[1] if lower else names[3]
        if name is not None:
            groups.setdefault(name, []).append(tag)
    if len(groups.get(INTERFACE, [])) != 1:
        raise RuntimeError(f"expected one interface entity, found {groups.get(INTERFACE)}")

    tags: dict[str, int] = {}
    for name in TAGS:
        if groups.get(name):
            dim = gdim if name in BODIES else fdim
            tags[name] = gmsh.model.addPhysicalGroup(dim, groups[name], TAGS[name], name=name)

    # Discretisation: uniform, fixed on every curve; structured cells for quads/hexes.
    for _, tag in gmsh.model.getEntities(1):
        n = max(1, math.floor(occ.getMass(1, tag) / h + 0.5))  # round half up
        gmsh.model.mesh.setTransfiniteCurve(tag, n + 1)
    if cell_type in _RECOMBINED:
        for _, tag in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(tag)
            gmsh.model.mesh.setRecombine(2, tag)
        for _, tag in gmsh.model.getEntities(3):
            gmsh.model.mesh.setTransfiniteVolume(tag)
    saved = {o: gmsh.option.getNumber(o) for o in ("Mesh.MeshSizeMax", "Mesh.ElementOrder")}
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    try:
        gmsh.model.mesh.generate(gdim)
    finally:
        for option, value in saved.items():
            gmsh.option.setNumber(option, value)

    _crack(gdim, tags[INTERFACE], groups[INTERFACE][0])
    return _model_info(model_name, gdim, cell_type, tags, h)


def _crack(gdim: int, interface_tag: int, interface_entity: int) -> None:
    """Duplicate the interface nodes; the slave side (above the interface) gets the new nodes."""
    gmsh = _gmsh()
    fdim = gdim - 1
    _, etags, enodes = gmsh.model.mesh.getElements(fdim, interface_entity)
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(ntags.max()) + 1, 3))
    x[ntags] = np.asarray(coords).reshape(-1, 3)
    el = x[np.asarray(enodes[0]).reshape(len(etags[0]), -1)]
    normal_z = 1.0
    if gdim == 2:
        # Crack's side normal is (0, 0, NormalZ) x tangent = (0, NormalZ * t_x, 0): make it +y.
        tx = el[:, 1, 0] - el[:, 0, 0]
        if not (np.all(tx > 0) or np.all(tx < 0)):
            raise RuntimeError("interface line elements are not consistently oriented")
        normal_z = 1.0 if tx[0] > 0 else -1.0
    else:
        # Crack's side normal is the element normal: make it +z (reverse the interface mesh if not).
        nz = np.cross(el[:, 1] - el[:, 0], el[:, 2] - el[:, 0])[:, 2]
        if not (np.all(nz > 0) or np.all(nz < 0)):
            raise RuntimeError("interface surface elements are not consistently oriented")
        if nz[0] < 0:
            gmsh.model.mesh.reverse([(fdim, interface_entity)])
    boundary = gmsh.model.getBoundary([(fdim, interface_entity)], combined=True, oriented=False)
    open_tag = gmsh.model.addPhysicalGroup(fdim - 1, sorted({abs(t) for _, t in boundary}))
    for option, value in (
        ("Dimension", fdim), ("PhysicalGroup", interface_tag),
        ("OpenBoundaryPhysicalGroup", open_tag), ("NormalX", 0.0), ("NormalY", 0.0),
        ("NormalZ", normal_z), ("NewPhysicalGroup", 0), ("DebugView", 0),
    ):  # fmt: skip
        gmsh.plugin.setNumber("Crack", option, value)
    gmsh.plugin.run("Crack")
    gmsh.model.removePhysicalGroups([(fdim - 1, open_tag)])
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()


def _group_nodes(dim: int, tag: int) -> np.ndarray:
    gmsh = _gmsh()
    nodes, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
    return np.unique(np.asarray(nodes, dtype=np.int64))


def _group_elements(dim: int, tag: int) -> tuple[list[int], list[np.ndarray]]:
    """Element types and (num_elements, num_nodes) node arrays of a physical group."""
    gmsh = _gmsh()
    types: list[int] = []
    conns: list[np.ndarray] = []
    for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        etypes, _, enodes = gmsh.model.mesh.getElements(dim, int(entity))
        for t, n in zip(etypes, enodes, strict=True):
            nn = gmsh.model.mesh.getElementProperties(int(t))[3]
            types.append(int(t))
            conns.append(np.asarray(n, dtype=np.int64).reshape(-1, nn))
    return types, conns


def _model_info(model: str, gdim: int, cell_type: str, tags: dict[str, int], h: float) -> ModelInfo:
    gmsh = _gmsh()
    master, slave = _group_nodes(gdim, tags[MASTER]), _group_nodes(gdim, tags[SLAVE])
    shared = np.intersect1d(master, slave)
    if shared.size:
        raise RuntimeError(f"the bodies share {shared.size} nodes after Crack (expected none)")
    sides = _interface_sides(gdim, tags)
    if sides[MASTER] != sides[SLAVE] or sides["neither"]:
        raise RuntimeError(f"interface sides after Crack do not match: {sides}")
    iface = _group_nodes(gdim - 1, tags[INTERFACE])
    _, coords = gmsh.model.mesh.getNodesForPhysicalGroup(gdim - 1, tags[INTERFACE])
    xi = np.asarray(coords).reshape(-1, 3)[:, :gdim]
    num_cells = {b: int(sum(c.shape[0] for c in _group_elements(gdim, tags[b])[1])) for b in BODIES}
    return ModelInfo(
        model=model,
        gdim=gdim,
        cell_type=cell_type,
        tags=dict(tags),
        h=h,
        interface_min=tuple(float(v) for v in xi.min(axis=0)),
        interface_max=tuple(float(v) for v in xi.max(axis=0)),
        num_cells=num_cells,
        num_interface_facets=sides[MASTER],
        num_interface_nodes=int(iface.size) // 2,
    )


def _interface_sides(tdim: int, tags: dict[str, int]) -> dict[str, int]:
    """Count interface elements whose nodes all belong to the master, to the slave, or neither."""
    master, slave = _group_nodes(tdim, tags[MASTER]), _group_nodes(tdim, tags[SLAVE])
    counts = {MASTER: 0, SLAVE: 0, "neither": 0}
    for conn in _group_elements(tdim - 1, tags[INTERFACE])[1]:
        in_m = np.isin(conn, master).all(axis=1)
        in_s = np.isin(conn, slave).all(axis=1)
        counts[MASTER] += int(np.count_nonzero(in_m & ~in_s))
        counts[SLAVE] += int(np.count_nonzero(in_s & ~in_m))
        counts["neither"] += int(np.count_nonzero(in_m == in_s))
    return counts


# --- partitioners ---------------------------------------------------------------------------------
_Partitioner = Callable[[MPI.Comm, int, list, list], Any]


def _gmsh_node_data(tdim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-node data of the current gmsh model, indexed by node tag - 1.

    Returns:
        Body (0 master, 1 slave, -1 none), coordinates, and whether the node is on the interface.
    """
    gmsh = _gmsh()
    if not gmsh.isInitialized():
        raise RuntimeError(
            "body_partitioner needs the gmsh model being converted to be current on the ranks "
            "that hold cells (use it with gmshio.model_to_mesh/read_from_msh or "
            "read_interface_mesh)"
        )
    named = {gmsh.model.getPhysicalName(d, t): (d, t) for d, t in gmsh.model.getPhysicalGroups()}
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    ntags = np.asarray(ntags, dtype=np.int64)
    x = np.zeros((int(ntags.max()), 3))
    x[ntags - 1] = np.asarray(coords).reshape(-1, 3)
    body = np.full(x.shape[0], -1, dtype=np.int8)
    for i, name in enumerate(BODIES):
        if named.get(name, (None,))[0] != tdim:
            raise RuntimeError(f"body_partitioner: the gmsh model has no {tdim}-D group {name!r}")
        body[_group_nodes(tdim, named[name][1]) - 1] = i
    iface = np.zeros(x.shape[0], dtype=bool)
    if named.get(INTERFACE, (None,))[0] == tdim - 1:
        iface[_group_nodes(tdim - 1, named[INTERFACE][1]) - 1] = True
    return body, x, iface


def _ghost_destinations(
    conn: np.ndarray, cell_type: dolfinx.mesh.CellType, owner: np.ndarray
) -> dolfinx.cpp.graph.AdjacencyList_int32:
    """Destinations [owner, ghost ranks...] with cells ghosted across shared facets."""
    tdim = dolfinx.mesh.cell_dim(cell_type)
    fv = dolfinx.cpp.mesh.get_entity_vertices(cell_type, tdim - 1)
    fv = np.asarray(fv.array).reshape(fv.num_nodes, -1)
    nf = fv.shape[0]
    facets = np.sort(conn[:, fv], axis=2).reshape(-1, fv.shape[1])
    _, fid = np.unique(facets, axis=0, return_inverse=True)
    fid = fid.reshape(-1)
    cell = np.repeat(np.arange(conn.shape[0]), nf)
    order = np.argsort(fid, kind="stable")
    fid, cell = fid[order], cell[order]
    same = np.flatnonzero(fid[1:] == fid[:-1])
    c0, c1 = cell[same], cell[same + 1]
    cross = owner[c0] != owner[c1]
    pairs = np.concatenate(
        [np.stack([c0[cross], owner[c1[cross]]], 1), np.stack([c1[cross], owner[c0[cross]]], 1)]
    )
    pairs = np.unique(pairs, axis=0) if pairs.size else np.empty((0, 2), dtype=np.int64)
    counts = 1 + np.bincount(pairs[:, 0], minlength=conn.shape[0])
    offsets = np.zeros(conn.shape[0] + 1, dtype=np.int32)
    np.cumsum(counts, out=offsets[1:])
    data = np.empty(offsets[-1], dtype=np.int32)
    data[offsets[:-1]] = owner
    # ghosts follow the owner, in the order of the sorted pairs
    start = np.zeros(conn.shape[0], dtype=np.int64)
    for c, r in pairs:
        start[c] += 1
        data[offsets[c] + start[c]] = r
    return dolfinx.graph.adjacencylist(data, offsets)


def body_partitioner(
    kind: str, ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none
) -> _Partitioner:
    """Cell partitioner for ``gmshio.model_to_mesh``/``read_from_msh``/``read_interface_mesh``.

    Kinds:

    * ``"default"``: DOLFINx's graph partitioner (``create_cell_partitioner(ghost_mode)``).
    * ``"bodies"``: all master cells on rank 0, all slave cells on rank 1 (rank 0 on one rank),
      so on 2 ranks every interface pair is split across ranks.
    * ``"together"``: cells are cut into slabs of equal cell count along x, a cell touching the
      interface with a facet being placed by that facet's smallest x, so that the two cells of an
      interface pair (whose facets have the same vertex coordinates) land on the same rank.

    The custom kinds look up each cell's body and node coordinates in the current gmsh model on
    the ranks that hold cells (rank 0 when gmshio converts a model), by the physical names
    ``master``/``slave``/``interface``. They ghost cells across shared facets when ``ghost_mode``
    is ``GhostMode.shared_facet``.

    Args:
        kind: One of :data:`PARTITIONER_KINDS`.
        ghost_mode: Ghosting of the partitioned mesh (``none`` or ``shared_facet``).

    Returns:
        A callable ``(comm, nparts, cell_types, cells) -> AdjacencyList_int32`` giving the
        destination ranks of each local cell (owner first, then ghost ranks).

    Raises:
        ValueError: Unknown kind or unsupported ghost mode.
    """
    if kind not in PARTITIONER_KINDS:
        raise ValueError(f"partitioner kind must be one of {PARTITIONER_KINDS}, got {kind!r}")
    if kind == "default":
        return dolfinx.mesh.create_cell_partitioner(ghost_mode)
    if ghost_mode not in (dolfinx.mesh.GhostMode.none, dolfinx.mesh.GhostMode.shared_facet):
        raise ValueError(f"body_partitioner({kind!r}) supports GhostMode.none and shared_facet")

    def partition(comm: MPI.Comm, nparts: int, cell_types: list, cells: list):
        cell_type = cell_types[0]
        nv = dolfinx.cpp.mesh.cell_num_entities(cell_type, 0)
        conn = np.asarray(cells[0], dtype=np.int64).reshape(-1, nv)
        if conn.shape[0] == 0:
            return dolfinx.graph.adjacencylist(
                np.empty(0, dtype=np.int32), np.zeros(1, dtype=np.int32)
            )
        owner = np.zeros(conn.shape[0], dtype=np.int32)
        if nparts > 1:
            tdim = dolfinx.mesh.cell_dim(cell_type)
            body, x, iface = _gmsh_node_data(tdim)
            if kind == "bodies":
                cell_body = body[conn]
                if np.any(cell_body != cell_body[:, :1]) or np.any(cell_body < 0):
                    raise RuntimeError("body_partitioner: a cell has nodes outside its body")
                owner[cell_body[:, 0] == 1] = 1
            else:
                nfv = dolfinx.cpp.mesh.cell_num_entities(
                    dolfinx.cpp.mesh.cell_entity_type(cell_type, tdim - 1, 0), 0
                )
                on_iface = iface[conn]
                xc = x[conn, 0]
                key = np.where(
                    on_iface.sum(axis=1) >= nfv,
                    np.where(on_iface, xc, np.inf).min(axis=1),
                    xc.min(axis=1),
                )
                cuts = np.sort(key)[(np.arange(1, nparts) * key.size) // nparts]
                owner = np.searchsorted(cuts, key, side="right").astype(np.int32)
        if ghost_mode == dolfinx.mesh.GhostMode.shared_facet and nparts > 1:
            return _ghost_destinations(conn, cell_type, owner)
        return dolfinx.graph.adjacencylist(owner.reshape(-1, 1))

    return partition


# --- reading -------------------------------------------------------------------------------------
@dataclasses.dataclass
class InterfaceMesh:
    """A DOLFINx mesh of two bodies joined by a duplicated-node interface.

    Attributes:
        mesh: The mesh.
        cell_tags: Cell tags (physical-group tags of the bodies).
        facet_tags: Facet tags (physical-group tags of the facet groups).
        tags: Physical-group name -> integer tag (the names of the file or model).
        num_interface_facets: Global number of interface facets on each side.
    """

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    tags: dict[str, int]
    num_interface_facets: int = 0
    _sides: dict[str, npt.NDArray[np.int32]] = dataclasses.field(default_factory=dict, repr=False)

    @property
    def gdim(self) -> int:
        """Geometric dimension."""
        return self.mesh.geometry.dim

    @property
    def tdim(self) -> int:
        """Topological dimension."""
        return self.mesh.topology.dim

    def tag(self, name: str) -> int:
        """Integer tag of the physical group ``name``.

        Raises:
            KeyError: No group of that name (the message lists the groups present).
        """
        try:
            return self.tags[name]
        except KeyError:
            raise KeyError(f"no physical group {name!r}; groups: {sorted(self.tags)}") from None

    def body_cells(self, body: str) -> npt.NDArray[np.int32]:
        """Local indices (owned and ghost) of the cells of ``body`` ("master" or "slave")."""
        return self.cell_tags.find(self.tag(body))

    def facets(self, name: str) -> npt.NDArray[np.int32]:
        """Local indices (owned and ghost) of the facets of the facet group ``name``."""
        return self.facet_tags.find(self.tag(name))

    def interface_facets(self, side: str, *, owned_only: bool = False) -> npt.NDArray[np.int32]:
        """Local indices of the interface facets on ``side``'s body (``"master"`` or ``"slave"``).

        The side of a facet is the body of its (unique) adjacent cell.

        Args:
            side: ``"master"`` or ``"slave"``.
            owned_only: Only facets owned by this rank.
        """
        if side not in BODIES:
            raise ValueError(f"side must be one of {BODIES}, got {side!r}")
        f = self._sides[side]
        if owned_only:
            f = f[f < self.mesh.topology.index_map(self.tdim - 1).size_local]
        return f

    def interface_side_tags(self) -> dolfinx.mesh.MeshTags:
        """Facet tags marking each local interface facet with the tag of its side's body.

        Use as ``ufl.Measure("ds", domain=mesh, subdomain_data=...)`` and integrate over one side
        with ``ds(tags["master"])`` or ``ds(tags["slave"])``.
        """
        f = np.concatenate([self._sides[MASTER], self._sides[SLAVE]])
        v = np.concatenate(
            [
                np.full(self._sides[MASTER].size, self.tag(MASTER), dtype=np.int32),
                np.full(self._sides[SLAVE].size, self.tag(SLAVE), dtype=np.int32),
            ]
        )
        order = np.argsort(f)
        return dolfinx.mesh.meshtags(self.mesh, self.tdim - 1, f[order], v[order])


_ERRORS: dict[str, type[Exception]] = {
    "FileNotFoundError": FileNotFoundError,
    "InterfaceMeshError": InterfaceMeshError,
    "RuntimeError": RuntimeError,
    "ValueError": ValueError,
}


def _raise_collectively(comm: MPI.Comm, error: tuple[str, str] | None, root: int = 0) -> None:
    """Broadcast ``error`` (class name, message) from ``root`` and raise it on every rank."""
    error = comm.bcast(error, root=root)
    if error is not None:
        raise _ERRORS.get(error[0], InterfaceMeshError)(error[1])


def _describe_groups(groups: dict[tuple[int, int], str]) -> str:
    if not groups:
        return "none"
    return ", ".join(f"{n or '(unnamed)'!r} (dim {d}, tag {t})" for (d, t), n in groups.items())


def _inspect_current_model(gdim: int, required: Sequence[str], what: str) -> dict[str, int]:
    """Check the current gmsh model; return name -> tag. Raises InterfaceMeshError."""
    gmsh = _gmsh()
    groups = {(d, t): gmsh.model.getPhysicalName(d, t) for d, t in gmsh.model.getPhysicalGroups()}
    dims = {d for d, t in groups if any(c.size for c in _group_elements(d, t)[1])}
    tdim = max(dims, default=-1)
    if tdim != gdim:
        raise InterfaceMeshError(
            f"{what}: expected a {gdim}-D mesh (cells of topological dimension {gdim} for "
            f"gdim={gdim}), found cells of topological dimension {tdim} "
            f"(physical groups: {_describe_groups(groups)})"
        )
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.asarray(coords).reshape(-1, 3)
    if gdim == 2 and x.size and np.abs(x[:, 2]).max() > 1e-12 * max(1.0, np.abs(x).max()):
        raise InterfaceMeshError(
            f"{what}: expected a planar mesh (z = 0) for gdim=2, found z in "
            f"[{x[:, 2].min():g}, {x[:, 2].max():g}]"
        )
    names: dict[str, int] = {}
    for (_, t), n in groups.items():
        if not n:
            continue  # unnamed groups are read by gmshio but not addressable by name
        if n in names:
            raise InterfaceMeshError(f"{what}: physical name {n!r} is used by several groups")
        names[n] = t
    for n in required:
        if n not in names:
            raise InterfaceMeshError(
                f"{what}: required physical group {n!r} not found; physical groups found: "
                f"{_describe_groups(groups)}"
            )
    for n in (MASTER, SLAVE, INTERFACE):
        want = gdim - 1 if n == INTERFACE else gdim
        found = [d for (d, t), m in groups.items() if m == n]
        if found and found[0] != want:
            raise InterfaceMeshError(
                f"{what}: physical group {n!r} must have dimension {want}, found dimension "
                f"{found[0]}"
            )
    types = {t for d, tg in groups if d == gdim for t in _group_elements(d, tg)[0]}
    if len(types) != 1:
        tnames = sorted(gmsh.model.mesh.getElementProperties(t)[0] for t in types)
        raise InterfaceMeshError(f"{what}: expected one cell type, found {tnames}")
    if MASTER in names and SLAVE in names:
        tags = {MASTER: names[MASTER], SLAVE: names[SLAVE]}
        shared = np.intersect1d(_group_nodes(gdim, tags[MASTER]), _group_nodes(gdim, tags[SLAVE]))
        if shared.size:
            p = gmsh.model.mesh.getNode(int(shared[0]))[0][:gdim]
            raise InterfaceMeshError(
                f"{what}: the bodies {MASTER!r} and {SLAVE!r} share {shared.size} nodes (e.g. at "
                f"{tuple(float(v) for v in p)}); the interface nodes must be duplicated, e.g. with "
                "gmsh's Crack plugin and OpenBoundaryPhysicalGroup"
            )
        if INTERFACE in names:
            tags[INTERFACE] = names[INTERFACE]
            sides = _interface_sides(gdim, tags)
            if sides["neither"]:
                raise InterfaceMeshError(
                    f"{what}: {sides['neither']} {INTERFACE!r} facets do not belong to the "
                    f"boundary of exactly one body"
                )
            if sides[MASTER] != sides[SLAVE]:
                raise InterfaceMeshError(
                    f"{what}: the two sides of the {INTERFACE!r} group have different numbers "
                    f"of facets: {sides[MASTER]} on the {MASTER!r} side, {sides[SLAVE]} on the "
                    f"{SLAVE!r} side"
                )
    if ntags.size and not np.array_equal(np.sort(ntags), np.arange(1, ntags.size + 1)):
        # e.g. right after the Crack plugin: gmshio needs contiguous node tags
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()
    return names


def read_interface_mesh(
    source: str | os.PathLike | None,
    comm: MPI.Comm,
    gdim: int,
    *,
    partitioner: str | _Partitioner | None = None,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    required: Sequence[str] = REQUIRED_GROUPS,
) -> InterfaceMesh:
    """Read two bodies joined by a duplicated-node interface into DOLFINx (collective).

    Rank 0 reads and checks the gmsh data; every failure is raised on all ranks.

    Args:
        source: Path of a ``.msh`` file, or ``None`` for the current gmsh model of rank 0 (its
            node tags are renumbered if they have gaps, as after the Crack plugin).
        comm: Communicator of the mesh.
        gdim: Expected geometric (= topological) dimension, 2 or 3.
        partitioner: A partitioner callable, a kind of :func:`body_partitioner`, or ``None`` for
            DOLFINx's default partitioner.
        ghost_mode: Ghost mode for the default partitioner or a :func:`body_partitioner` kind.
        required: Physical groups that must be present.

    Returns:
        The mesh, its tags, the name -> tag dictionary, and the interface sides.

    Raises:
        FileNotFoundError: ``source`` does not exist.
        InterfaceMeshError: Wrong dimension, a required group missing, several cell types,
            bodies sharing nodes, interface sides with different numbers of facets, interface
            facets that are not exterior facets of exactly one body, group elements that are
            not entities of the mesh (which gmshio would drop silently).
    """
    if gdim not in (2, 3):
        raise ValueError(f"gdim must be 2 or 3, got {gdim!r}")
    if isinstance(partitioner, str):
        partitioner = body_partitioner(partitioner, ghost_mode)
    elif partitioner is None and comm.size > 1:
        partitioner = dolfinx.mesh.create_cell_partitioner(ghost_mode)
    what = "current gmsh model" if source is None else str(source)
    error: tuple[str, str] | None = None
    names: dict[str, int] = {}
    counts: dict[str, tuple[int, int]] = {}  # name -> (dimension, number of elements)
    model = None
    with contextlib.ExitStack() as stack:
        if comm.rank == 0:
            try:
                gmsh = _gmsh()
                if source is None:
                    if not gmsh.isInitialized() or not gmsh.model.list():
                        raise InterfaceMeshError(
                            "read_interface_mesh(None): no current gmsh model on rank 0"
                        )
                else:
                    path = Path(source)
                    if not path.is_file():
                        raise FileNotFoundError(f"mesh file not found: {path}")
                    stack.enter_context(_gmsh_session(f"subfric-read-{os.getpid()}"))
                    try:
                        gmsh.merge(str(path))
                    except Exception as e:
                        raise InterfaceMeshError(f"gmsh could not read {path}: {e}") from e
                names = _inspect_current_model(gdim, required, what)
                for d, t in gmsh.model.getPhysicalGroups():
                    if d >= gdim - 1:
                        n = sum(c.shape[0] for c in _group_elements(d, t)[1])
                        name = gmsh.model.getPhysicalName(d, t)
                        if name:
                            counts[name] = (d, n)
                model = gmsh.model
            except (FileNotFoundError, InterfaceMeshError) as e:
                error = (type(e).__name__, str(e))
            except Exception as e:  # anything else, e.g. from gmsh: report on all ranks
                error = ("InterfaceMeshError", f"{what}: {type(e).__name__}: {e}")
        _raise_collectively(comm, error)
        names = comm.bcast(names, root=0)
        counts = comm.bcast(counts, root=0)
        mesh, ct, ft = dolfinx.io.gmshio.model_to_mesh(
            model, comm, 0, gdim=gdim, partitioner=partitioner
        )
    imesh = InterfaceMesh(mesh=mesh, cell_tags=ct, facet_tags=ft, tags=names)
    _check_group_counts(imesh, counts, what)
    if INTERFACE in names:
        _find_sides(imesh, what)
    else:
        empty = np.empty(0, dtype=np.int32)
        imesh._sides = {MASTER: empty, SLAVE: empty}
    return imesh


def _check_group_counts(
    imesh: InterfaceMesh, counts: dict[str, tuple[int, int]], what: str
) -> None:
    """Check that every cell and facet of the gmsh groups made it into the DOLFINx tags.

    gmshio silently drops tagged facets that are not facets of the mesh cells, e.g. boundary
    elements that use the other body's copy of a duplicated node.
    """
    mesh, tdim = imesh.mesh, imesh.tdim
    items = sorted(counts.items())
    local = np.zeros(len(items), dtype=np.int64)
    for i, (name, (dim, _)) in enumerate(items):
        tags = imesh.cell_tags if dim == tdim else imesh.facet_tags
        found = tags.find(imesh.tags[name])
        local[i] = np.count_nonzero(found < mesh.topology.index_map(dim).size_local)
    total = np.zeros_like(local)
    mesh.comm.Allreduce(local, total, op=MPI.SUM)
    lost = [
        f"{name!r}: {n - int(k)} of {n}"
        for (name, (_, n)), k in zip(items, total, strict=True)
        if int(k) != n
    ]
    if lost:
        raise InterfaceMeshError(
            f"{what}: elements of physical groups are not entities of the DOLFINx mesh "
            f"({', '.join(lost)}); boundary elements must use the nodes of their own body"
        )


def _find_sides(imesh: InterfaceMesh, what: str) -> None:
    """Split the interface facets by the body of the adjacent cell, with collective checks."""
    mesh, comm, tdim = imesh.mesh, imesh.mesh.comm, imesh.tdim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    imap = mesh.topology.index_map(tdim)
    cell_value = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int32)
    cell_value[imesh.cell_tags.indices] = imesh.cell_tags.values
    facets = imesh.facet_tags.find(imesh.tag(INTERFACE))
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
    body = cell_value[cells] if facets.size else np.empty(0, dtype=np.int32)
    nf_owned = mesh.topology.index_map(tdim - 1).size_local
    owned = facets < nf_owned
    sides = {b: facets[body == imesh.tags.get(b, -99)] for b in BODIES}
    local = np.array(
        [
            np.count_nonzero(owned),
            np.count_nonzero(owned & ~np.isin(facets, exterior)),  # exterior: owned only
            np.count_nonzero(owned & (body == imesh.tags.get(MASTER, -99))),
            np.count_nonzero(owned & (body == imesh.tags.get(SLAVE, -99))),
        ],
        dtype=np.int64,
    )
    total = np.zeros_like(local)
    comm.Allreduce(local, total, op=MPI.SUM)
    n_owned, n_interior, n_master, n_slave = (int(v) for v in total)
    if n_interior:
        raise InterfaceMeshError(
            f"{what}: {n_interior} {INTERFACE!r} facets are interior facets (shared by two "
            "cells); the interface nodes must be duplicated"
        )
    if n_master != n_slave or n_master + n_slave != n_owned:
        raise InterfaceMeshError(
            f"{what}: the two sides of the {INTERFACE!r} group have different numbers of facets: "
            f"{n_master} on the {MASTER!r} side, {n_slave} on the {SLAVE!r} side"
            + (
                f", {n_owned - n_master - n_slave} next to neither body"
                if n_master + n_slave != n_owned
                else ""
            )
        )
    imesh._sides = sides
    imesh.num_interface_facets = n_master


def create_interface_mesh(
    builder: Callable[..., ModelInfo],
    comm: MPI.Comm,
    *,
    partitioner: str | _Partitioner | None = None,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    **kwargs: Any,
) -> tuple[InterfaceMesh, ModelInfo]:
    """Build a model with ``builder(**kwargs)`` on rank 0 and read it into DOLFINx (collective).

    gmsh is initialised on rank 0 if needed (and finalised afterwards); the model is removed from
    the session once read. A builder failure is raised on all ranks.

    Args:
        builder: :func:`build_block_on_base`, :func:`build_pad_on_plate`, or alike.
        comm: Communicator of the mesh.
        partitioner: As in :func:`read_interface_mesh`.
        ghost_mode: As in :func:`read_interface_mesh`.
        **kwargs: Passed to ``builder``.

    Returns:
        The mesh and the builder's model description (the same on all ranks).
    """
    error: tuple[str, str] | None = None
    info: ModelInfo | None = None
    with contextlib.ExitStack() as stack:
        if comm.rank == 0:
            try:
                gmsh = stack.enter_context(_gmsh_session(None))
                stack.callback(_remove_new_models, gmsh, gmsh.model.list(), gmsh.model.getCurrent())
                info = builder(**kwargs)
            except Exception as e:
                error = (type(e).__name__, f"{getattr(builder, '__name__', builder)}: {e}")
        _raise_collectively(comm, error)
        info = comm.bcast(info, root=0)
        imesh = read_interface_mesh(
            None, comm, info.gdim, partitioner=partitioner, ghost_mode=ghost_mode
        )
    return imesh, info


def _remove_new_models(gmsh: Any, before: Sequence[str], current: str) -> None:
    """Remove the gmsh models not in ``before`` and make ``current`` current again."""
    if not gmsh.isInitialized():
        return
    for name in set(gmsh.model.list()) - set(before):
        gmsh.model.setCurrent(name)
        gmsh.model.remove()
    if current in gmsh.model.list():
        gmsh.model.setCurrent(current)
