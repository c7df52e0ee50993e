"""gmsh builders of two boxes joined by a flat zero-thickness interface with duplicated nodes.

The builders (:func:`build_block_on_base`, 2-D, :func:`build_pad_on_plate`, 3-D) make a gmsh
model in the current gmsh session; call them on one rank (rank 0) only, or through
:func:`~subfric_dolfinx.meshing.reader.create_interface_mesh`. The nodes are duplicated with
gmsh's Crack plugin (with ``OpenBoundaryPhysicalGroup`` so that the interface ends come apart
too), the interface mesh being oriented so that the secondary side receives the new nodes;
elements lying in the interface plane (the free part of the primary's top face) keep the
primary's nodes.
The two bodies share no node: they are connected only through the interface elements.

Options beyond two uniform boxes, interface regions and graded meshes:

* Interface regions: strips ``x0 <= x <= x1`` of the interface, each a physical group of
  interface facets (a subgroup of ``interface``), e.g. two surface finishes with their own
  friction laws. The primary is cut at the strips' ends so that each strip is its own curve
  (surface); the groups carry the tags ``REGION_TAG0 + i``.
* Grading (triangles and tetrahedra): the element size is ``h`` within ``refine_radius`` of a
  point (by default the centre of the interface) and grows by ``growth`` per unit distance
  beyond, up to ``far_size``, e.g. a contact zone resolved finely inside large bodies.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ._size import check_mesh_size, estimate_cells
from .crack import duplicate_interface_nodes
from .groups import (
    BODIES,
    BOTTOM,
    INTERFACE,
    PRIMARY,
    PRIMARY_LEFT,
    PRIMARY_RIGHT,
    PRIMARY_TOP,
    PRIMARY_XMAX,
    PRIMARY_XMIN,
    PRIMARY_YMAX,
    PRIMARY_YMIN,
    SECONDARY,
    SECONDARY_LEFT,
    SECONDARY_RIGHT,
    SECONDARY_XMAX,
    SECONDARY_XMIN,
    SECONDARY_YMAX,
    SECONDARY_YMIN,
    TAGS,
    TOP,
    gmsh_module,
    group_elements,
    group_nodes,
    interface_sides,
)

__all__ = ["ModelInfo", "build_block_on_base", "build_pad_on_plate"]

_CELL_TYPES = {2: ("triangle", "quadrilateral"), 3: ("tetrahedron", "hexahedron")}
_RECOMBINED = ("quadrilateral", "hexahedron")


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
        num_cells: Number of cells per body, ``{"primary": ..., "secondary": ...}``.
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


def _segments(
    lo: float, hi: float, a: float, b: float, more: Sequence[float] = ()
) -> list[tuple[float, float]]:
    """Split [lo, hi] at a, b and ``more`` (which lie in it), dropping empty pieces."""
    cuts = sorted({lo, a, b, hi, *more})
    return [(c0, c1) for c0, c1 in itertools.pairwise(cuts) if c1 - c0 > 0.0]


def _check_cell_type(gdim: int, cell_type: str) -> None:
    if cell_type not in _CELL_TYPES[gdim]:
        raise ValueError(
            f"cell_type must be one of {_CELL_TYPES[gdim]} for a {gdim}-D model, got {cell_type!r}"
        )


def check_positive(**values: float) -> None:
    """Raise ``ValueError`` naming the first of ``values`` (name -> value) not a positive number."""
    for name, v in values.items():
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")


def _check_size(
    boxes: Sequence, h: float, cell_type: str, grading: tuple | None, n_interface, mesh_size
) -> None:
    """Refuse a mesh too large for the machine, before gmsh allocates it (:mod:`._size`)."""
    option = ("mesh_size", mesh_size) if mesh_size is not None else ("n_interface", n_interface)
    check_mesh_size(estimate_cells(boxes, h, cell_type, grading), *option)


def _interface_size(width: float, n_interface: int | None, mesh_size: float | None) -> float:
    if mesh_size is not None:
        check_positive(mesh_size=mesh_size)
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
    interface_regions: dict[str, Sequence[float]] | None = None,
    far_size: float | None = None,
    growth: float = 0.25,
    refine_center: Sequence[float] | None = None,
    refine_radius: float = 0.0,
) -> ModelInfo:
    """Build the 2-D "block on a base" model in the current gmsh session (call on one rank).

    The base (``primary``) is ``[0, base_width] x [0, base_height]``; the block (``secondary``) is
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
        interface_regions: Name -> ``[x0, x1]``: strips of the interface, each a physical group
            of interface facets (see :func:`add_region_groups`).
        far_size: Grade the mesh (triangles): the element size is ``h`` within
            ``refine_radius`` of ``refine_center`` (default: the interface's centre) and grows
            by ``growth`` per unit distance beyond, up to ``far_size``; curves are then not
            divided uniformly.
        growth: See ``far_size``.
        refine_center: See ``far_size``.
        refine_radius: See ``far_size``.

    Returns:
        Description of the model.

    Raises:
        ValueError: Invalid sizes, cell type, regions or grading.
        RuntimeError: gmsh did not produce two bodies joined only by a duplicated interface.
    """
    _check_cell_type(2, cell_type)
    check_positive(
        base_width=base_width,
        base_height=base_height,
        block_width=block_width,
        block_height=block_height,
    )
    if block_x is None:
        block_x = 0.5 * (base_width - block_width)
    if block_x < 0 or block_x + block_width > base_width * (1 + 1e-12):
        raise ValueError(
            f"the block [{block_x}, {block_x + block_width}] must lie on the base [0, {base_width}]"
        )
    h = _interface_size(block_width, n_interface, mesh_size)
    check_grading(cell_type, far_size, growth, refine_center, h, refine_radius)
    primary_box = ((0.0, 0.0), (base_width, base_height))
    secondary_box = ((block_x, base_height), (block_x + block_width, base_height + block_height))
    grading = None if far_size is None else (far_size, growth, refine_center, refine_radius)
    if far_size is not None and refine_center is None:  # the interface's centre
        grading = (far_size, growth, (block_x + 0.5 * block_width, base_height), refine_radius)
    _check_size((primary_box, secondary_box), h, cell_type, grading, n_interface, mesh_size)
    return _build(
        gdim=2,
        primary_box=primary_box,
        secondary_box=secondary_box,
        h=h,
        cell_type=cell_type,
        model_name=model_name,
        regions=check_regions(interface_regions, block_x, block_x + block_width),
        grading=None if far_size is None else (far_size, growth, refine_center, refine_radius),
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
    interface_regions: dict[str, Sequence[float]] | None = None,
    far_size: float | None = None,
    growth: float = 0.25,
    refine_center: Sequence[float] | None = None,
    refine_radius: float = 0.0,
) -> ModelInfo:
    """Build the 3-D "pad on a plate" model in the current gmsh session (call on one rank).

    The plate (``primary``) is ``[0, Lx] x [0, Ly] x [0, Lz]`` with ``plate_size = (Lx, Ly, Lz)``;
    the pad (``secondary``) is the box of size ``pad_size`` whose lower corner is
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
        interface_regions: Name -> ``[x0, x1]``: strips of the interface across its y extent,
            each a physical group of interface facets.
        far_size: Grade the mesh (tetrahedra), as in :func:`build_block_on_base`.
        growth: See ``far_size``.
        refine_center: See ``far_size``.
        refine_radius: See ``far_size``.

    Returns:
        Description of the model.

    Raises:
        ValueError: Invalid sizes, cell type, regions or grading.
        RuntimeError: gmsh did not produce two bodies joined only by a duplicated interface.
    """
    _check_cell_type(3, cell_type)
    plate = tuple(float(v) for v in plate_size)
    pad = tuple(float(v) for v in pad_size)
    if len(plate) != 3 or len(pad) != 3:
        raise ValueError("plate_size and pad_size must have three entries (x, y, z)")
    check_positive(**{f"plate_size[{i}]": v for i, v in enumerate(plate)})
    check_positive(**{f"pad_size[{i}]": v for i, v in enumerate(pad)})
    if pad_origin is None:
        pad_origin = (0.5 * (plate[0] - pad[0]), 0.5 * (plate[1] - pad[1]))
    ox, oy = (float(v) for v in pad_origin)
    for o, a, length, axis in ((ox, pad[0], plate[0], "x"), (oy, pad[1], plate[1], "y")):
        if o < 0 or o + a > length * (1 + 1e-12):
            raise ValueError(
                f"the pad [{o}, {o + a}] must lie on the plate [0, {length}] in {axis}"
            )
    h = _interface_size(pad[0], n_interface, mesh_size)
    check_grading(cell_type, far_size, growth, refine_center, h, refine_radius)
    primary_box = ((0.0, 0.0, 0.0), plate)
    secondary_box = ((ox, oy, plate[2]), (ox + pad[0], oy + pad[1], plate[2] + pad[2]))
    grading = None if far_size is None else (far_size, growth, refine_center, refine_radius)
    if far_size is not None and refine_center is None:  # the interface's centre
        centre = (ox + 0.5 * pad[0], oy + 0.5 * pad[1], plate[2])
        grading = (far_size, growth, centre, refine_radius)
    _check_size((primary_box, secondary_box), h, cell_type, grading, n_interface, mesh_size)
    return _build(
        gdim=3,
        primary_box=primary_box,
        secondary_box=secondary_box,
        h=h,
        cell_type=cell_type,
        model_name=model_name,
        regions=check_regions(interface_regions, ox, ox + pad[0]),
        grading=None if far_size is None else (far_size, growth, refine_center, refine_radius),
    )


def _build(
    *,
    gdim: int,
    primary_box: tuple[Sequence[float], Sequence[float]],
    secondary_box: tuple[Sequence[float], Sequence[float]],
    h: float,
    cell_type: str,
    model_name: str,
    regions: Sequence[tuple[str, float, float]] = (),
    grading: tuple[float, float, Sequence[float] | None, float] | None = None,
) -> ModelInfo:
    gmsh = gmsh_module()
    if not gmsh.isInitialized():
        raise RuntimeError("gmsh is not initialised: call gmsh.initialize() before a builder")
    occ = gmsh.model.occ
    (m0, m1), (s0, s1) = primary_box, secondary_box
    z_if = m1[gdim - 1]  # interface height
    scale = max(max(m1) - min(m0), max(s1) - min(s0))
    tol = 1e-7 * scale
    gmsh.model.add(model_name)

    # Primary pieces: the primary box cut along the secondary's footprint, so that the interface
    # is one face (curve) and every piece is a box (rectangle) for structured meshing.
    xs = _segments(m0[0], m1[0], s0[0], s1[0], [x for r in regions for x in r[1:]])
    ys = _segments(m0[1], m1[1], s0[1], s1[1]) if gdim == 3 else [(m0[1], m1[1])]
    pieces = []
    for x0, x1 in xs:
        if gdim == 2:
            pieces.append((2, occ.addRectangle(x0, m0[1], 0.0, x1 - x0, m1[1] - m0[1])))
        else:
            for y0, y1 in ys:
                pieces.append((3, occ.addBox(x0, y0, m0[2], x1 - x0, y1 - y0, m1[2] - m0[2])))
    # the secondary cut at the regions' ends too (boxes with four-sided faces, structured meshing)
    secondaries = []
    for x0, x1 in _segments(s0[0], s1[0], s0[0], s1[0], [x for r in regions for x in r[1:]]):
        ext = [x1 - x0, *(b - a for a, b in zip(s0[1:], s1[1:], strict=True))]
        if gdim == 2:
            secondaries.append((2, occ.addRectangle(x0, s0[1], 0.0, *ext)))
        else:
            secondaries.append((3, occ.addBox(x0, *s0[1:], *ext)))
    occ.fragment(pieces, secondaries)
    occ.synchronize()

    def com(dim: int, tag: int) -> np.ndarray:
        return np.asarray(occ.getCenterOfMass(dim, tag))[:gdim]

    def extent(dim: int, tag: int) -> np.ndarray:
        b = gmsh.model.getBoundingBox(dim, tag)
        return np.asarray(b[3:])[:gdim] - np.asarray(b[:3])[:gdim]

    # cells
    groups: dict[str, list[int]] = {PRIMARY: [], SECONDARY: []}
    for _, tag in gmsh.model.getEntities(gdim):
        groups[SECONDARY if com(gdim, tag)[-1] > z_if else PRIMARY].append(tag)
    if len(groups[SECONDARY]) != len(secondaries) or len(groups[PRIMARY]) != len(pieces):
        raise RuntimeError(f"unexpected geometry after fragment: {groups}")

    # facets, by position and normal direction
    side_names = (
        {0: (PRIMARY_LEFT, PRIMARY_RIGHT, SECONDARY_LEFT, SECONDARY_RIGHT)}
        if gdim == 2
        else {
            0: (PRIMARY_XMIN, PRIMARY_XMAX, SECONDARY_XMIN, SECONDARY_XMAX),
            1: (PRIMARY_YMIN, PRIMARY_YMAX, SECONDARY_YMIN, SECONDARY_YMAX),
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
                name = INTERFACE if inside else PRIMARY_TOP
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
    if not groups.get(INTERFACE) or (not regions and len(groups[INTERFACE]) != 1):
        raise RuntimeError(f"expected one interface entity, found {groups.get(INTERFACE)}")

    tags: dict[str, int] = {}
    for name in TAGS:
        if groups.get(name):
            dim = gdim if name in BODIES else fdim
            tags[name] = gmsh.model.addPhysicalGroup(dim, groups[name], TAGS[name], name=name)
    tags.update(add_region_groups(gmsh, gdim, groups[INTERFACE], list(regions)))
    if grading is not None:
        far, growth, centre, radius = grading
        if centre is None:
            centre = [0.5 * (s0[i] + s1[i]) for i in range(gdim - 1)] + [z_if]
        graded_mesh(gmsh, gdim, h, far, growth, centre, radius)
        split_interface_nodes(gdim, tags[INTERFACE], groups[INTERFACE])
        return model_info(model_name, gdim, cell_type, tags, h)

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

    split_interface_nodes(gdim, tags[INTERFACE], groups[INTERFACE])
    return model_info(model_name, gdim, cell_type, tags, h)


def split_interface_nodes(gdim: int, interface_tag: int, interface_entities: Sequence[int]) -> None:
    """Duplicate the interface nodes; the secondary side (above the interface) gets new nodes."""
    del interface_tag, interface_entities  # the groups are found by name
    duplicate_interface_nodes(None, {INTERFACE: ([PRIMARY], [SECONDARY])})


def model_info(model: str, gdim: int, cell_type: str, tags: dict[str, int], h: float) -> ModelInfo:
    """The :class:`ModelInfo` of the gmsh model just split at its interface, its groups checked.

    Raises:
        RuntimeError: The bodies share nodes, or the interface's sides do not match.
    """
    gmsh = gmsh_module()
    primary, secondary = group_nodes(gdim, tags[PRIMARY]), group_nodes(gdim, tags[SECONDARY])
    shared = np.intersect1d(primary, secondary)
    if shared.size:
        raise RuntimeError(f"the bodies share {shared.size} nodes after Crack (expected none)")
    sides = interface_sides(gdim, tags)
    if sides[PRIMARY] != sides[SECONDARY] or sides["neither"]:
        raise RuntimeError(f"interface sides after Crack do not match: {sides}")
    iface = group_nodes(gdim - 1, tags[INTERFACE])
    _, coords = gmsh.model.mesh.getNodesForPhysicalGroup(gdim - 1, tags[INTERFACE])
    xi = np.asarray(coords).reshape(-1, 3)[:, :gdim]
    num_cells = {b: int(sum(c.shape[0] for c in group_elements(gdim, tags[b])[1])) for b in BODIES}
    return ModelInfo(
        model=model,
        gdim=gdim,
        cell_type=cell_type,
        tags=dict(tags),
        h=h,
        interface_min=tuple(float(v) for v in xi.min(axis=0)),
        interface_max=tuple(float(v) for v in xi.max(axis=0)),
        num_cells=num_cells,
        num_interface_facets=sides[PRIMARY],
        num_interface_nodes=int(iface.size) // 2,
    )


# -- Interface regions and graded meshes


REGION_TAG0 = 100
"""Tag of the first interface region group (then 101, ...)."""


def check_regions(
    regions: Mapping[str, Sequence[float]] | None, lo: float, hi: float
) -> list[tuple[str, float, float]]:
    """Validate interface strips ``name -> (x0, x1)`` inside the interface ``[lo, hi]``.

    Returns:
        ``(name, x0, x1)`` sorted by ``x0``.

    Raises:
        ValueError: Not a mapping, a bad name (empty, a name of the builders' groups), an
            interval that is not two finite increasing numbers inside ``[lo, hi]``, overlaps.
    """
    if not regions:
        return []
    if not isinstance(regions, Mapping):
        raise ValueError(f"interface_regions must map names to [x0, x1], got {regions!r}")
    out = []
    for name, iv in regions.items():
        if not isinstance(name, str) or not name.isidentifier() or name in TAGS:
            raise ValueError(
                f"interface region name {name!r} must be an identifier other than the builders' "
                f"group names {sorted(TAGS)}"
            )
        try:
            x0, x1 = (float(v) for v in iv)
        except (TypeError, ValueError):
            raise ValueError(f"interface region {name!r}: expected [x0, x1], got {iv!r}") from None
        tol = 1e-9 * max(1.0, abs(lo), abs(hi))
        if not (math.isfinite(x0) and math.isfinite(x1) and lo - tol <= x0 < x1 <= hi + tol):
            raise ValueError(
                f"interface region {name!r}: [{x0:g}, {x1:g}] must be an increasing interval "
                f"inside the interface [{lo:g}, {hi:g}]"
            )
        out.append((name, max(x0, lo), min(x1, hi)))
    out.sort(key=lambda r: r[1])
    for (a, _, a1), (b, b0, _) in itertools.pairwise(out):
        if b0 < a1:
            raise ValueError(f"interface regions {a!r} and {b!r} overlap")
    return out


def add_region_groups(
    gmsh: Any, gdim: int, entities: Sequence[int], regions: list[tuple[str, float, float]]
) -> dict[str, int]:
    """Physical groups of the interface entities inside each strip; name -> tag.

    Raises:
        RuntimeError: A strip holds no interface entity.
    """
    tags = {}
    tol = 1e-7
    for i, (name, x0, x1) in enumerate(regions):
        scale = max(1.0, abs(x0), abs(x1))
        inside = []
        for e in entities:
            b = gmsh.model.getBoundingBox(gdim - 1, e)
            if b[0] >= x0 - tol * scale and b[3] <= x1 + tol * scale:
                inside.append(e)
        if not inside:
            raise RuntimeError(f"interface region {name!r} holds no interface entity")
        tags[name] = gmsh.model.addPhysicalGroup(gdim - 1, inside, REGION_TAG0 + i, name=name)
    return tags


def check_grading(
    cell_type: str,
    far_size: float | None,
    growth: float,
    center: Sequence[float] | None,
    h: float,
    radius: float = 0.0,
) -> None:
    """Validate the grading options (``far_size`` None: no grading).

    Raises:
        ValueError: Grading asked for structured cells, or values out of range.
    """
    if far_size is None:
        return
    if cell_type in ("quadrilateral", "hexahedron"):
        raise ValueError(f"far_size (a graded mesh) needs triangles or tetrahedra, not {cell_type}")
    for name, v in (("far_size", far_size), ("growth", growth)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")
    if not (isinstance(radius, int | float) and math.isfinite(radius) and radius >= 0):
        raise ValueError(f"refine_radius must be a finite number >= 0, got {radius!r}")
    if far_size < h:
        raise ValueError(f"far_size = {far_size!r} must be at least the interface size h = {h:g}")
    if center is not None and not all(
        isinstance(v, int | float) and math.isfinite(v) for v in center
    ):
        raise ValueError(f"refine_center must be finite coordinates, got {center!r}")


def graded_mesh(
    gmsh: Any,
    gdim: int,
    h: float,
    far_size: float,
    growth: float,
    center: Sequence[float],
    radius: float = 0.0,
) -> None:
    """Generate the mesh with sizes ``min(far_size, h + growth * max(0, |x - center| - radius))``.

    The size field and the options it needs are removed again afterwards.
    """
    c = [float(v) for v in center] + [0.0] * (3 - len(center))
    f = gmsh.model.mesh.field
    fid = f.add("MathEval")
    dist = f"Sqrt((x-({c[0]!r}))^2+(y-({c[1]!r}))^2+(z-({c[2]!r}))^2)"
    grow = f"Max(0, {dist} - {float(radius)!r})"
    f.setString(fid, "F", f"Min({far_size!r}, {h!r} + {growth!r}*{grow})")
    f.setAsBackgroundMesh(fid)
    opts = {
        "Mesh.MeshSizeMax": far_size,
        "Mesh.MeshSizeMin": 0.0,
        "Mesh.MeshSizeExtendFromBoundary": 0,
        "Mesh.MeshSizeFromPoints": 0,
        "Mesh.MeshSizeFromCurvature": 0,
        "Mesh.ElementOrder": 1,
    }
    saved = {o: gmsh.option.getNumber(o) for o in opts}
    try:
        for o, v in opts.items():
            gmsh.option.setNumber(o, v)
        gmsh.model.mesh.generate(gdim)
    finally:
        for o, v in saved.items():
            gmsh.option.setNumber(o, v)
        f.remove(fid)
