"""Independently meshed bodies for the contact search tests, built from numpy arrays.

Each body has its own nodes (nothing is shared across the contact surface, whose two sides need not
match). Cells are tagged 1 (the primary body) and 2 (the secondary body), the contact facets of both
sides 3. The mesh is made on rank 0 and distributed by DOLFINx's partitioner, or, with
``split_x``, by a partitioner that puts the cells whose centre has ``x < split_x`` on rank 0 and
the others on rank 1 (on 2 ranks), so that a body slides across the partition boundary.
"""

from __future__ import annotations

import dataclasses

import basix.ufl
import dolfinx
import numpy as np
from mpi4py import MPI

from subfric_dolfinx.compat import adjacency_list, create_mesh

PRIMARY, SECONDARY, CONTACT = 1, 2, 3


@dataclasses.dataclass
class Bodies:
    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags


def _grid(x0, x1, y0, y1, nx, ny):
    """Nodes and triangles (two per rectangle, alternating diagonals) of a structured grid."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)

    def node(i, j):
        return i * (ny + 1) + j

    tris = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)
            if (i + j) % 2:
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    return pts, np.array(tris, dtype=np.int64)


def _box(lo, hi, n):
    """Nodes and tetrahedra (six per hexahedron) of a structured box."""
    axes = [np.linspace(lo[k], hi[k], n[k] + 1) for k in range(3)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)

    def node(i, j, k):
        return (i * (n[1] + 1) + j) * (n[2] + 1) + k

    tets = []
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                v = [node(i + a, j + b, k + c) for c in (0, 1) for b in (0, 1) for a in (0, 1)]
                # Kuhn split of the cube (v0 .. v7 in binary order x, y, z)
                for p in ([1, 3], [3, 2], [2, 6], [6, 4], [4, 5], [5, 1]):
                    tets.append([v[0], v[p[0]], v[p[1]], v[7]])
    return X, np.array(tets, dtype=np.int64)


def _partitioner(x, split_x):
    def partition(comm, nparts, cell_types, cells):
        # the cells' vertices (their input numbers) only, also for a curved mesh
        nv = dolfinx.cpp.mesh.cell_num_entities(cell_types[0], 0)
        conn = np.asarray(cells[0], dtype=np.int64).reshape(-1, nv)
        owner = np.zeros(conn.shape[0], dtype=np.int32)
        if nparts > 1 and conn.shape[0]:
            owner[x[conn, 0].mean(axis=1) >= split_x] = 1
        return adjacency_list(owner.reshape(-1, 1))

    return partition


def _assemble(comm, parts, cell_name, gdim, contact, split_x, geometry_degree=1):
    """One mesh of the bodies ``parts`` [(nodes, cells, tag)], with tags."""
    xs, cs, tags, off = [], [], [], 0
    for pts, cells, tag in parts:
        xs.append(pts)
        cs.append(cells + off)
        tags.append(np.full(cells.shape[0], tag, dtype=np.int32))
        off += pts.shape[0]
    x, cells = np.concatenate(xs), np.concatenate(cs)
    if comm.rank != 0:
        cells, xloc = np.zeros((0, cells.shape[1]), dtype=np.int64), np.zeros((0, gdim))
    else:
        xloc = x
    element = basix.ufl.element("Lagrange", cell_name, geometry_degree, shape=(gdim,))
    part = _partitioner(x, split_x) if split_x is not None else None
    mesh = create_mesh(comm, cells, xloc, element, partitioner=part)
    tdim = mesh.topology.dim
    # cell tags from the input cell index of each local cell
    cmap = mesh.topology.index_map(tdim)
    n_local = cmap.size_local + cmap.num_ghosts
    orig = np.asarray(mesh.topology.original_cell_index)[:n_local]
    all_tags = np.concatenate(tags)
    cell_tags = dolfinx.mesh.meshtags(
        mesh, tdim, np.arange(n_local, dtype=np.int32), all_tags[orig].astype(np.int32)
    )
    mesh.topology.create_connectivity(tdim - 1, tdim)
    facets = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, contact)
    facet_tags = dolfinx.mesh.meshtags(
        mesh, tdim - 1, np.sort(facets).astype(np.int32), np.full(facets.size, CONTACT, np.int32)
    )
    return Bodies(mesh, cell_tags, facet_tags)


def block_on_base(
    comm: MPI.Comm,
    *,
    length: float = 10.0,
    depth: float = 1.0,
    width: float = 1.0,
    height: float = 1.0,
    x0: float = 0.0,
    n_base: int = 20,
    n_block: int = 3,
    split_x: float | None = None,
) -> Bodies:
    """A base ``[0, length] x [-depth, 0]`` (primary) and a block ``[x0, x0 + width] x
    [0, height]`` (secondary), meshed with ``n_base`` and ``n_block`` elements along x."""
    base = _grid(0.0, length, -depth, 0.0, n_base, 2)
    block = _grid(x0, x0 + width, 0.0, height, n_block, 2)
    return _assemble(
        comm,
        [(*base, PRIMARY), (*block, SECONDARY)],
        "triangle",
        2,
        lambda x: np.isclose(x[1], 0.0),
        split_x,
    )


def annuli(
    comm: MPI.Comm,
    *,
    r0: float = 0.5,
    radius: float = 1.0,
    r2: float = 1.5,
    n_inner: int = 16,
    n_outer: int = 24,
    split_x: float | None = None,
    geometry_degree: int = 1,
) -> Bodies:
    """A shaft (annulus ``r0 <= r <= radius``, primary) in a hub (``radius <= r <= r2``, secondary),
    with ``n_inner`` and ``n_outer`` segments around: two polygons inscribed in the circle of
    ``radius``, meshed independently; with ``geometry_degree=2``, curved triangles whose edges
    are the images of straight lines of the (angle, radius) plane (the contact facets are arcs
    through three points of the circle)."""

    def ring(ra, rb, n):
        pts, tris = _grid(0.0, 1.0, ra, rb, n, 2)

        def polar(q):
            t, r = 2 * np.pi * q[:, 0], q[:, 1]
            return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)

        # close the ring: the nodes at t = 2 pi are those at t = 0
        last = np.flatnonzero(np.isclose(pts[:, 0], 1.0))
        first = np.flatnonzero(np.isclose(pts[:, 0], 0.0))
        remap = np.arange(pts.shape[0])
        remap[last] = first
        keep = np.setdiff1d(np.arange(pts.shape[0]), last)
        new = -np.ones(pts.shape[0], dtype=np.int64)
        new[keep] = np.arange(keep.size)
        xy, cells = polar(pts[keep]), new[remap[tris]]
        if geometry_degree == 1:
            return xy, cells
        # edge nodes (basix order: edge i opposite vertex i), one per edge of the closed ring
        mids, index, extra = [], {}, []
        for tri, tri_c in zip(tris, cells, strict=True):
            row = []
            for a, b in ((1, 2), (0, 2), (0, 1)):
                key = tuple(sorted((tri_c[a], tri_c[b])))
                if key not in index:
                    index[key] = xy.shape[0] + len(mids)
                    mids.append(0.5 * (pts[tri[a]] + pts[tri[b]]))
                row.append(index[key])
            extra.append(row)
        return np.concatenate([xy, polar(np.array(mids))]), np.concatenate(
            [cells, np.array(extra, dtype=np.int64)], axis=1
        )

    inner = ring(r0, radius, n_inner)
    outer = ring(radius, r2, n_outer)
    return _assemble(
        comm,
        [(*inner, PRIMARY), (*outer, SECONDARY)],
        "triangle",
        2,
        lambda x: np.isclose(np.hypot(x[0], x[1]), radius),
        split_x,
        geometry_degree,
    )


def block_on_plate(
    comm: MPI.Comm,
    *,
    size: tuple[float, float] = (4.0, 2.0),
    block: tuple[float, float] = (1.0, 1.0),
    x0: tuple[float, float] = (0.5, 0.5),
    n_plate: tuple[int, int] = (8, 4),
    n_block: tuple[int, int] = (3, 3),
    split_x: float | None = None,
) -> Bodies:
    """3-D: a plate ``[0, Lx] x [0, Ly] x [-0.5, 0]`` (primary) and a block on it (secondary),
    tets."""
    plate = _box((0.0, 0.0, -0.5), (size[0], size[1], 0.0), (*n_plate, 1))
    blk = _box((x0[0], x0[1], 0.0), (x0[0] + block[0], x0[1] + block[1], 0.5), (*n_block, 1))
    return _assemble(
        comm,
        [(*plate, PRIMARY), (*blk, SECONDARY)],
        "tetrahedron",
        3,
        lambda x: np.isclose(x[2], 0.0),
        split_x,
    )


@dataclasses.dataclass
class TaggedBodies:
    """Two independently meshed bodies with named groups, as :class:`InterfaceProblem` takes."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    tags: dict[str, int]
    bodies: dict[str, tuple[str, ...]]
    interfaces: dict


def _quads(x0, x1, y0, y1, nx, ny):
    """Nodes and quadrilaterals (basix's tensor order) of a structured grid."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    q = [
        [i * (ny + 1) + j, (i + 1) * (ny + 1) + j, i * (ny + 1) + j + 1, (i + 1) * (ny + 1) + j + 1]
        for i in range(nx)
        for j in range(ny)
    ]
    return pts, np.array(q, dtype=np.int64)


def tagged_blocks(
    comm: MPI.Comm,
    *,
    base: tuple[float, float, float, float] = (0.0, 1.0, -1.0, 0.0),
    block: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0),
    n_base: tuple[int, int] = (3, 2),
    n_block: tuple[int, int] = (2, 2),
    cell: str = "triangle",
    split_x: float | None = None,
) -> TaggedBodies:
    """A base (``x0, x1, y0, y1``, body ``base``) under a block (body ``block``), meshed apart.

    Groups: ``base``, ``block`` (cells), ``contact`` (the base's top and the block's bottom,
    y = 0), ``bottom`` (the base's), ``top`` (the block's), ``base_left`` (the base's facets on
    x = the block's left end), ``block_left``, ``block_right`` (the block's ends).
    """
    grid = _grid if cell == "triangle" else _quads
    parts = [(*grid(*base, *n_base), 1), (*grid(*block, *n_block), 2)]
    bodies = _assemble(comm, parts, cell, 2, lambda x: np.isclose(x[1], 0.0), split_x)
    mesh = bodies.mesh
    tdim = mesh.topology.dim
    groups = {
        "contact": (3, lambda x: np.isclose(x[1], 0.0)),
        "bottom": (4, lambda x: np.isclose(x[1], base[2])),
        "top": (5, lambda x: np.isclose(x[1], block[3])),
        "base_left": (6, lambda x: np.isclose(x[0], block[0]) & (x[1] <= 1e-12)),
        "block_left": (7, lambda x: np.isclose(x[0], block[0]) & (x[1] >= -1e-12)),
        "block_right": (8, lambda x: np.isclose(x[0], block[1]) & (x[1] >= -1e-12)),
    }
    ents, vals = [], []
    for tag, where in groups.values():
        f = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, where)
        ents.append(f)
        vals.append(np.full(f.size, tag, np.int32))
    ents, vals = np.concatenate(ents), np.concatenate(vals)
    order = np.lexsort((vals, ents))
    facet_tags = dolfinx.mesh.meshtags(mesh, tdim - 1, ents[order].astype(np.int32), vals[order])
    tags = {"base": 1, "block": 2, **{k: v[0] for k, v in groups.items()}}
    return TaggedBodies(
        mesh, bodies.cell_tags, facet_tags, tags, {"base": ("base",), "block": ("block",)}, {}
    )


def tagged_annuli(comm: MPI.Comm, **kw) -> TaggedBodies:
    """:func:`annuli` with named groups: bodies ``shaft`` and ``hub``, facets ``contact`` (both
    sides), ``outer`` (the hub's outer circle) and ``inner`` (the shaft's bore)."""
    bodies = annuli(comm, **kw)
    mesh = bodies.mesh
    tdim = mesh.topology.dim
    r0, radius, r2 = kw.get("r0", 0.5), kw.get("radius", 1.0), kw.get("r2", 1.5)
    ents, vals = [], []
    for tag, r in ((3, radius), (4, r2), (5, r0)):
        f = dolfinx.mesh.locate_entities_boundary(
            mesh, tdim - 1, lambda x, r=r: np.isclose(np.hypot(x[0], x[1]), r)
        )
        ents.append(f)
        vals.append(np.full(f.size, tag, np.int32))
    ents, vals = np.concatenate(ents), np.concatenate(vals)
    order = np.argsort(ents)
    facet_tags = dolfinx.mesh.meshtags(mesh, tdim - 1, ents[order].astype(np.int32), vals[order])
    tags = {"shaft": PRIMARY, "hub": SECONDARY, "contact": 3, "outer": 4, "inner": 5}
    return TaggedBodies(
        mesh, bodies.cell_tags, facet_tags, tags, {"shaft": ("shaft",), "hub": ("hub",)}, {}
    )


def tagged_boxes(
    comm: MPI.Comm,
    *,
    n_base: tuple[int, int, int] = (3, 3, 1),
    n_block: tuple[int, int, int] = (2, 2, 1),
    base_size: float = 1.0,
    block_at: float = 0.0,
    split_x: float | None = None,
) -> TaggedBodies:
    """3-D: a box ``[0, base_size]^2 x [-1, 0]`` (``base``) under a unit box (``block``) at
    ``(block_at, block_at)``, tets, meshed apart; facets ``contact`` (z = 0, both), ``bottom``,
    ``top`` and the planes ``x0`` and ``y0`` (x = 0, y = 0, both bodies)."""
    base = _box((0.0, 0.0, -1.0), (base_size, base_size, 0.0), n_base)
    a = block_at
    blk = _box((a, a, 0.0), (a + 1.0, a + 1.0, 1.0), n_block)
    bodies = _assemble(
        comm, [(*base, 1), (*blk, 2)], "tetrahedron", 3, lambda x: np.isclose(x[2], 0.0), split_x
    )
    mesh = bodies.mesh
    tdim = mesh.topology.dim
    groups = {
        "contact": (3, lambda x: np.isclose(x[2], 0.0)),
        "bottom": (4, lambda x: np.isclose(x[2], -1.0)),
        "top": (5, lambda x: np.isclose(x[2], 1.0)),
        "x0": (6, lambda x: np.isclose(x[0], 0.0)),
        "y0": (7, lambda x: np.isclose(x[1], 0.0)),
    }
    ents, vals = [], []
    for tag, where in groups.values():
        f = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, where)
        ents.append(f)
        vals.append(np.full(f.size, tag, np.int32))
    ents, vals = np.concatenate(ents), np.concatenate(vals)
    order = np.lexsort((vals, ents))
    facet_tags = dolfinx.mesh.meshtags(mesh, tdim - 1, ents[order].astype(np.int32), vals[order])
    tags = {"base": 1, "block": 2, **{k: v[0] for k, v in groups.items()}}
    return TaggedBodies(
        mesh, bodies.cell_tags, facet_tags, tags, {"base": ("base",), "block": ("block",)}, {}
    )


def diagonal_slide_3d(
    comm: MPI.Comm, law, slide_end: float, *, split_x: float | None = None, degree: int = 1
):
    """The 3-D diagonal slide: an aluminium block (2 x 2 facets, :func:`tagged_boxes` at 0.5)
    pressed at 300 MPa on a steel plate (6 x 6 facets, 3 mm) from t = 0 to 1, then its top moved
    by (0.5, 0.25) mm until ``slide_end``; one finite-sliding interface (search radius 0.5 mm).

    The problem of ``tests/fem/interface/finite/test_finite_sliding_tangent.py`` (``split_x``
    1.5: across the partition boundary) and of ``benchmarks/finite_sliding_newton.py``'s 3-D case.
    """
    from subfric_dolfinx.fem import (
        Dirichlet,
        Interface,
        InterfaceProblem,
        Material,
        Pressure,
        ProblemSettings,
    )
    from subfric_dolfinx.loading import LoadingProgram

    dom = tagged_boxes(
        comm, n_base=(6, 6, 1), n_block=(2, 2, 1), base_size=3.0, block_at=0.5, split_x=split_x
    )
    program = LoadingProgram([0.0, 1.0, slide_end], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    return InterfaceProblem(
        dom,
        law,
        {"base": Material(2.1e5, 0.3), "block": Material(7e4, 0.33)},
        program,
        [
            Dirichlet("bottom", (0.0, 0.0, 0.0)),
            Dirichlet("top", 0.5, 0, amplitude="slide"),
            Dirichlet("top", 0.25, 1, amplitude="slide"),
        ],
        [Pressure("top", 300.0, amplitude="press")],
        interfaces=[
            Interface("contact", "base", "block", kinematics="finite_sliding", search_radius=0.5)
        ],
        settings=ProblemSettings(degree=degree),
    )
