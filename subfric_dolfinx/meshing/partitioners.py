"""Deterministic cell partitioners: bodies apart, pairs together, or every body spread evenly.

:func:`body_partitioner` makes them; :func:`bisection_parts` is the recursive coordinate
bisection the ``"balanced"`` kind cuts each body's cells with.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import dolfinx
import dolfinx.cpp
import dolfinx.graph
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from ..compat import adjacency_list, default_partitioner
from .groups import BODIES, INTERFACE, gmsh_module, group_nodes

__all__ = ["PARTITIONER_KINDS", "Partitioner", "body_partitioner"]

#: Kinds understood by :func:`body_partitioner`.
PARTITIONER_KINDS: tuple[str, ...] = ("default", "bodies", "together", "balanced")

Partitioner = Callable[[MPI.Comm, int, list, list], Any]


def _gmsh_node_data(
    tdim: int, bodies: Mapping[str, Sequence[str]], interfaces: Sequence[str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-node data of the current gmsh model, indexed by node tag - 1.

    Returns:
        Body (its index in ``bodies``, -1 none), coordinates, and whether the node is on an
        interface.
    """
    gmsh = gmsh_module()
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
    body = np.full(x.shape[0], -1, dtype=np.int32)
    for i, (name, groups) in enumerate(bodies.items()):
        for g in groups:
            if named.get(g, (None,))[0] != tdim:
                raise RuntimeError(
                    f"body_partitioner: the gmsh model has no {tdim}-D group {g!r} (body {name!r})"
                )
            body[group_nodes(tdim, named[g][1]) - 1] = i
    iface = np.zeros(x.shape[0], dtype=bool)
    for g in interfaces:
        if named.get(g, (None,))[0] == tdim - 1:
            iface[group_nodes(tdim - 1, named[g][1]) - 1] = True
    return body, x, iface


def bisection_parts(points: np.ndarray, nparts: int) -> npt.NDArray[np.int32]:
    """Recursive coordinate bisection of ``points`` (rows) into ``nparts`` parts of equal count.

    Each set is cut across the coordinate along which it spreads most, into two sets whose sizes
    are in the ratio of the parts each gets (``nparts // 2`` and the rest); ties in a coordinate
    keep the rows' order. Deterministic: the same points give the same parts on every process.

    Returns:
        The part (``0 .. nparts - 1``) of each row; part sizes differ by at most one row per cut.
    """
    parts = np.zeros(points.shape[0], dtype=np.int32)

    def cut(rows: np.ndarray, first: int, count: int) -> None:
        if count <= 1 or rows.size == 0:
            parts[rows] = first
            return
        pts = points[rows]
        axis = int(np.argmax(np.ptp(pts, axis=0)))
        left = count // 2
        order = rows[np.argsort(pts[:, axis], kind="stable")]
        k = (rows.size * left + count // 2) // count
        cut(order[:k], first, left)
        cut(order[k:], first + left, count - left)

    cut(np.arange(points.shape[0]), 0, nparts)
    return parts


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
    return adjacency_list(data, offsets)


def body_partitioner(
    kind: str,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    *,
    bodies: Mapping[str, Sequence[str]] | None = None,
    interfaces: Sequence[str] | None = None,
) -> Partitioner:
    """Cell partitioner for ``gmshio.model_to_mesh``/``read_from_msh``/``read_interface_mesh``.

    Kinds:

    * ``"default"``: DOLFINx's graph partitioner (``create_cell_partitioner(ghost_mode)``).
    * ``"bodies"``: the cells of body ``i`` on rank ``i % size``: with two bodies on 2 ranks the
      first (``primary``) on rank 0, the second on rank 1, so every interface pair is split across
      ranks.
    * ``"together"``: cells are cut into slabs of equal cell count along x, a cell touching an
      interface with a facet being placed by that facet's smallest x, so that the two cells of an
      interface pair (whose facets have the same vertex coordinates) land on the same rank.
    * ``"balanced"``: every body spread evenly over the ranks, and within it the cells with a
      facet on an interface spread evenly too: each body's interface cells, and apart from them
      its other cells, are cut by recursive coordinate bisection of their centres
      (:func:`bisection_parts`) into one part per rank. The interfaces' work (the law's points,
      a finite-sliding interface's search and projection) is then shared by every rank, where
      DOLFINx's graph partitioner, which balances cells only, may leave a small body and its whole
      interface on one rank.

    The custom kinds look up each cell's body and node coordinates in the current gmsh model on
    the ranks that hold cells (rank 0 when gmshio converts a model), by the physical names of the
    bodies' cell groups and of the interfaces. They ghost cells across shared facets when
    ``ghost_mode`` is ``GhostMode.shared_facet``.

    Args:
        kind: One of :data:`PARTITIONER_KINDS`.
        ghost_mode: Ghosting of the partitioned mesh (``none`` or ``shared_facet``).
        bodies: Body -> its cell groups, in order (default: ``primary``, ``secondary``);
            :func:`~.reader.read_interface_mesh` passes the mesh's.
        interfaces: The interface groups (default: ``interface``).

    Returns:
        A callable ``(comm, nparts, cell_types, cells) -> AdjacencyList_int32`` giving the
        destination ranks of each local cell (owner first, then ghost ranks).

    Raises:
        ValueError: Unknown kind or unsupported ghost mode.
    """
    if kind not in PARTITIONER_KINDS:
        raise ValueError(f"partitioner kind must be one of {PARTITIONER_KINDS}, got {kind!r}")
    if kind == "default":
        return default_partitioner(ghost_mode)
    if ghost_mode not in (dolfinx.mesh.GhostMode.none, dolfinx.mesh.GhostMode.shared_facet):
        raise ValueError(f"body_partitioner({kind!r}) supports GhostMode.none and shared_facet")
    the_bodies = dict(bodies) if bodies else {b: (b,) for b in BODIES}
    the_interfaces = list(interfaces) if interfaces is not None else [INTERFACE]

    def partition(comm: MPI.Comm, nparts: int, cell_types: list, cells: list):
        cell_type = cell_types[0]
        nv = dolfinx.cpp.mesh.cell_num_entities(cell_type, 0)
        conn = np.asarray(cells[0], dtype=np.int64).reshape(-1, nv)
        if conn.shape[0] == 0:
            return adjacency_list(np.empty(0, dtype=np.int32), np.zeros(1, dtype=np.int32))
        owner: npt.NDArray[np.int32] = np.zeros(conn.shape[0], dtype=np.int32)
        if nparts > 1:
            tdim = dolfinx.mesh.cell_dim(cell_type)
            body, x, iface = _gmsh_node_data(tdim, the_bodies, the_interfaces)
            nfv = dolfinx.cpp.mesh.cell_num_entities(
                dolfinx.cpp.mesh.cell_entity_type(cell_type, tdim - 1, 0), 0
            )
            if kind in ("bodies", "balanced"):
                cell_body = body[conn]
                if np.any(cell_body < 0):
                    raise RuntimeError("body_partitioner: a cell has nodes outside every body")
                # a node shared by two bodies (tied) counts for the first: the cell's most
                # frequent body is its own
                nb = len(the_bodies)
                votes = (cell_body[:, :, None] == np.arange(nb)[None, None, :]).sum(axis=1)
                of_body = np.argmax(votes, axis=1)
                if kind == "bodies":
                    owner = (of_body % nparts).astype(np.int32)
                else:
                    centre = x[conn].mean(axis=1)
                    at_iface = iface[conn].sum(axis=1) >= nfv
                    for b in range(nb):
                        for group in (at_iface, ~at_iface):
                            rows = np.flatnonzero((of_body == b) & group)
                            owner[rows] = bisection_parts(centre[rows], nparts)
            else:
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
        return adjacency_list(owner.reshape(-1, 1))

    return partition
