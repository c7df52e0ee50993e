"""Node groups (gmsh physical points, or points added by coordinates) and nearest vertices.

A :class:`NodeGroup` holds the coordinates of its nodes and, for each, the body whose cells hold
it: the interface's nodes are duplicated, so a coordinate alone does not say which copy is meant.
:func:`locate_node_group` finds the mesh vertices of a group on this rank (owned and ghost),
:func:`nearest_vertex` the vertex nearest to a point over all ranks, the same on every partition.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import dolfinx
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from .groups import InterfaceMeshError

__all__ = ["NodeGroup", "body_vertices", "locate_node_group", "nearest_vertex", "node_groups"]


@dataclasses.dataclass(frozen=True)
class NodeGroup:
    """The nodes of a group: coordinates ``x`` (n, 3) and the body holding each (``None``: any).

    Attributes:
        x: Node coordinates, (n, 3).
        bodies: For each node, the name of the body (cell group) whose cells hold it, or ``None``
            (any cell: a node off the interface needs no body).
    """

    x: np.ndarray
    bodies: tuple[str | None, ...]

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float).reshape(-1, 3)
        object.__setattr__(self, "x", x)
        if len(self.bodies) != x.shape[0]:
            raise ValueError(f"{len(self.bodies)} bodies for {x.shape[0]} nodes")


def node_groups(
    gdim: int, names: dict[str, int], bodies: dict[str, tuple[int, ...]]
) -> dict[str, NodeGroup]:
    """The named physical groups of points of the current gmsh model (call on one rank).

    Args:
        gdim: Dimension of the cells.
        names: Physical name -> tag of the model.
        bodies: Body name -> the tags of its cell groups.
    """
    from .groups import body_nodes as nodes_of
    from .groups import gmsh_module

    gmsh = gmsh_module()
    body_nodes = {b: nodes_of(gdim, t) for b, t in bodies.items()}
    out: dict[str, NodeGroup] = {}
    for d, t in gmsh.model.getPhysicalGroups(0):
        name = gmsh.model.getPhysicalName(d, t)
        if not name or names.get(name) != t:
            continue
        tags, coords = gmsh.model.mesh.getNodesForPhysicalGroup(0, t)
        tags = np.asarray(tags, dtype=np.int64)
        owner = tuple(
            next((b for b, nodes in body_nodes.items() if np.isin(n, nodes)), None) for n in tags
        )
        out[name] = NodeGroup(np.asarray(coords, dtype=float).reshape(-1, 3), owner)
    return out


def body_vertices(mesh: dolfinx.mesh.Mesh, cells: npt.NDArray[np.int32] | None) -> np.ndarray:
    """Local vertices (owned and ghost) of ``cells`` (all vertices when ``None``)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 0)
    if cells is None:
        vmap = mesh.topology.index_map(0)
        return np.arange(vmap.size_local + vmap.num_ghosts, dtype=np.int32)
    return dolfinx.mesh.compute_incident_entities(mesh.topology, cells, tdim, 0)


def _vertex_coordinates(mesh: dolfinx.mesh.Mesh, vertices: np.ndarray) -> np.ndarray:
    if vertices.size == 0:
        return np.zeros((0, 3))
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    geo = dolfinx.mesh.entities_to_geometry(mesh, 0, vertices.astype(np.int32), False)
    return mesh.geometry.x[geo.reshape(-1)]


def _tolerance(mesh: dolfinx.mesh.Mesh) -> float:
    """A millionth of the mesh's extent (the same on every rank)."""
    from mpi4py import MPI

    x = mesh.geometry.x
    lo = x.min(axis=0) if x.size else np.full(3, np.inf)
    hi = x.max(axis=0) if x.size else np.full(3, -np.inf)
    mesh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    mesh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    return 1e-6 * float(np.linalg.norm(hi - lo))


def locate_node_group(domain: Any, name: str, group: NodeGroup | None = None) -> np.ndarray:
    """Local vertices (owned and ghost) of the node group ``name`` of ``domain`` (collective).

    Args:
        domain: The mesh with its tags (an :class:`~.reader.InterfaceMesh`).
        name: The group's name (in messages).
        group: The group, if not ``domain.node_groups[name]``.

    Raises:
        InterfaceMeshError: A node of the group is not a vertex of its body on any rank.
    """
    from mpi4py import MPI

    mesh = domain.mesh
    group = domain.node_groups[name] if group is None else group
    tol = _tolerance(mesh)
    n_owned = mesh.topology.index_map(0).size_local
    found: list[np.ndarray] = []
    counts = np.zeros(group.x.shape[0], dtype=np.int64)
    cache: dict[str | None, tuple[np.ndarray, np.ndarray]] = {}
    for i, (x, body) in enumerate(zip(group.x, group.bodies, strict=True)):
        if body not in cache:
            cells = None if body is None else _body_cells(domain, body)
            verts = body_vertices(mesh, cells)
            cache[body] = (verts, _vertex_coordinates(mesh, verts))
        verts, xv = cache[body]
        hit = verts[np.linalg.norm(xv - x, axis=1) <= tol] if verts.size else verts
        found.append(hit)
        counts[i] = np.count_nonzero(hit < n_owned)
    total = mesh.comm.allreduce(counts, op=MPI.SUM)
    missing = np.flatnonzero(total == 0)
    if missing.size:
        x = tuple(float(v) for v in group.x[missing[0], : mesh.geometry.dim])
        body = group.bodies[missing[0]]
        where = f" of the body {body!r}" if body else ""
        raise InterfaceMeshError(
            f"node group {name!r}: no mesh vertex{where} at {x} ({missing.size} of "
            f"{group.x.shape[0]} nodes not found)"
        )
    return np.unique(np.concatenate(found)).astype(np.int32) if found else np.zeros(0, np.int32)


def _body_cells(domain: Any, body: str) -> np.ndarray:
    """The local cells of a body (or cell group) of ``domain``."""
    if hasattr(domain, "body_cells"):
        return domain.body_cells(body)
    return domain.cell_tags.find(domain.tags[body])


def nearest_vertex(
    mesh: dolfinx.mesh.Mesh, x: npt.ArrayLike, cells: npt.NDArray[np.int32] | None = None
) -> tuple[np.ndarray, float]:
    """The vertex of ``cells`` (all cells if ``None``) nearest to ``x``, over all ranks.

    Ties are broken by the coordinates (lexicographically), so the answer does not depend on the
    partition. Collective.

    Returns:
        The vertex's coordinates (3,) and its distance to ``x``.

    Raises:
        InterfaceMeshError: No vertex at all (empty ``cells`` on every rank).
    """
    p = np.zeros(3)
    xa = np.asarray(x, dtype=float).ravel()
    p[: xa.size] = xa
    verts = body_vertices(mesh, cells)
    verts = verts[verts < mesh.topology.index_map(0).size_local]
    xv = _vertex_coordinates(mesh, verts)
    best = None
    if xv.shape[0]:
        d2 = np.sum((xv - p) ** 2, axis=1)
        cand = np.flatnonzero(d2 == d2.min())
        order = np.lexsort(xv[cand].T[::-1])
        i = cand[order[0]]
        best = (float(d2[i]), tuple(float(v) for v in xv[i]))
    allbest = [b for b in mesh.comm.allgather(best) if b is not None]
    if not allbest:
        raise InterfaceMeshError("no mesh vertex to choose from (empty group of cells)")
    d2, xb = min(allbest)
    return np.asarray(xb), float(np.sqrt(d2))
