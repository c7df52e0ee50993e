"""Uniform refinement of a mesh of bodies joined by duplicated-node interfaces, on the ranks.

:func:`refine_interface_mesh` refines every cell ``k`` times with DOLFINx's ``refine`` (Plaza's
algorithm: every edge split at its midpoint), each refined cell on its parent's rank: the fine mesh
is made where the coarse one lies, and no rank holds more of it than its share. The cell and facet
tags follow (``transfer_meshtag``), and so do the interface subgroups (their facets' children,
found through the same transfer) and the node groups (vertices stay vertices).

Each side of an interface is refined on its own: its two sides share no vertex, edge or facet
(the nodes are duplicated), so each side splits its own edges. Both sides split an interface edge
at the midpoint of the same two coordinates, so the new nodes pair one to one as the old ones do
(the midpoint of two coinciding pairs of points is the same number on both sides), and a
triangular facet split at its three edges' midpoints has one subdivision: the sides' facets pair
as before. The refined mesh is checked as a read one is: every group's number of entities (the
coarse one times 2^dim) and every interface's two sides.

In 3-D Plaza's refinement splits a face from its longest edge (a tie broken by the vertices'
global indices, which differ between the sides): the tetrahedra are refined under an affine map
that leaves no two edges of a face equally long, so that both sides split their faces alike
(:func:`_refine_simplices`).

Simplices only (triangles, tetrahedra): DOLFINx refines no quadrilaterals or hexahedra.
"""

from __future__ import annotations

import dolfinx
import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from ..compat import refine_uniform
from .groups import InterfaceMeshError
from .interface_mesh import InterfaceMesh
from .reader import check_group_counts, find_sides

__all__ = ["MAX_REFINE", "refine_interface_mesh"]

MAX_REFINE = 8
"""The most refinements asked at once (each multiplies the cells by 4 in 2-D, 8 in 3-D)."""


def refine_interface_mesh(domain: InterfaceMesh, times: int = 1) -> InterfaceMesh:
    """The mesh refined uniformly ``times`` times, with its groups (collective).

    Args:
        domain: The mesh (e.g. :func:`~.reader.read_interface_mesh` or
            :func:`~.partitioned.read_partitioned_mesh`), read with ghost mode none (the
            default): DOLFINx transfers tags only on such meshes.
        times: How many times (0: ``domain`` itself).

    Returns:
        A new mesh with the same groups, bodies, interfaces and node groups.

    Raises:
        InterfaceMeshError: ``times`` not in ``[0, MAX_REFINE]``, cells that are not simplices,
            a mesh with ghost cells, or a refined group that lost entities (on every rank).
    """
    if isinstance(times, bool) or not isinstance(times, int) or not 0 <= times <= MAX_REFINE:
        raise InterfaceMeshError(
            f"refine: expected an integer from 0 to {MAX_REFINE}, got {times!r}"
        )
    cell = domain.mesh.topology.cell_type
    if times and cell not in (dolfinx.mesh.CellType.triangle, dolfinx.mesh.CellType.tetrahedron):
        raise InterfaceMeshError(
            f"refine: DOLFINx refines triangles and tetrahedra only, the mesh has {cell.name} cells"
        )
    for _ in range(times):
        domain = _refine_once(domain)
    return domain


def _owned_counts(domain: InterfaceMesh) -> dict[str, tuple[int, int]]:
    """Name -> (dimension, global number of entities) of the tagged groups (collective)."""
    mesh, tdim = domain.mesh, domain.tdim
    items = [(n, t) for n, t in sorted(domain.tags.items()) if domain.dims.get(n, tdim) >= tdim - 1]
    local = np.zeros(len(items), dtype=np.int64)
    for i, (name, tag) in enumerate(items):
        dim = domain.dims.get(name, tdim)
        tags = domain.cell_tags if dim == tdim else domain.facet_tags
        local[i] = np.count_nonzero(tags.find(tag) < mesh.topology.index_map(dim).size_local)
    total = np.zeros_like(local)
    mesh.comm.Allreduce(local, total, op=MPI.SUM)
    return {
        name: (domain.dims.get(name, tdim), int(n))
        for (name, _), n in zip(items, total, strict=True)
    }


def _facet_centroids(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    """Centroids (mean of the vertices) of local facets, (n, gdim)."""
    gdim, fdim = mesh.geometry.dim, mesh.topology.dim - 1
    if facets.size == 0:
        return np.zeros((0, gdim))
    nv = fdim + 1  # simplices
    geo = dolfinx.mesh.entities_to_geometry(mesh, fdim, facets.astype(np.int32), False)
    return mesh.geometry.x[geo[:, :nv]][..., :gdim].mean(axis=1)


def _subgroup_tags(domain: InterfaceMesh) -> tuple[list[str], dolfinx.mesh.MeshTags]:
    """Facet tags of the interface subgroups: 1 + the subgroup's index, on its local facets."""
    mesh, tdim = domain.mesh, domain.tdim
    names = sorted(domain.interface_groups)
    primary = [domain.interface_facets("primary", interface=i) for i in domain.interfaces]
    facets = np.unique(np.concatenate(primary or [np.zeros(0, np.int32)])).astype(np.int32)
    value = np.zeros(facets.size, dtype=np.int32)
    if names and facets.size:
        from scipy.spatial import cKDTree

        c = _facet_centroids(mesh, facets)
        extent = float(np.ptp(mesh.geometry.x, axis=0).max()) if mesh.geometry.x.size else 1.0
        tol = 1e-9 * max(extent, 1.0)
        tree = cKDTree(c)
        for k, name in enumerate(names, start=1):
            pts = np.asarray(domain.interface_groups[name], dtype=float).reshape(-1, c.shape[1])
            for hits in tree.query_ball_point(pts, tol):
                value[np.asarray(hits, dtype=np.int64)] = k
    keep = value > 0
    mesh.topology.create_connectivity(tdim - 1, 0)
    return names, dolfinx.mesh.meshtags(mesh, tdim - 1, facets[keep], value[keep])


_SHEAR = np.array([[1.0, 0.1234, 0.0567], [0.0, 1.0891, 0.0345], [0.0, 0.0, 0.9173]])
"""The affine map under which tetrahedra are refined (:func:`_refine_simplices`)."""


def _refine_simplices(mesh: dolfinx.mesh.Mesh) -> tuple[dolfinx.mesh.Mesh, np.ndarray, np.ndarray]:
    """Refine every cell once; in 3-D under an affine map that breaks ties of edge lengths.

    Plaza's refinement splits a tetrahedron's face from its longest edge, and breaks a tie of
    lengths by the global index of the opposite vertex: the two sides of an interface, whose
    duplicated vertices have different indices, would split a face with two equal edges
    differently (their facets no longer pairing). Under a generic affine map no two edges of a
    face have equal lengths (they are not parallel), so the choice is the geometry's alone, the
    same on both sides; affine maps keep midpoints, and the refined mesh is mapped back (the
    coordinates then carry the round-off of the map, the same bits on both sides).
    """
    if mesh.topology.dim != 3:
        return refine_uniform(mesh)
    x = mesh.geometry.x
    saved = x.copy()
    try:
        x[:, :3] = saved[:, :3] @ _SHEAR.T
        fine, parent_cell, parent_facet = refine_uniform(mesh)
    finally:
        x[:] = saved
    xf = fine.geometry.x
    xf[:, :3] = np.linalg.solve(_SHEAR, xf[:, :3].T).T
    return fine, parent_cell, parent_facet


def _refine_once(domain: InterfaceMesh) -> InterfaceMesh:
    mesh, tdim = domain.mesh, domain.tdim
    cmap = mesh.topology.index_map(tdim)
    if mesh.comm.allreduce(cmap.num_ghosts, op=MPI.SUM):
        raise InterfaceMeshError(
            "refine: the mesh has ghost cells; read it with ghost mode none (the default)"
        )
    counts = _owned_counts(domain)
    mesh.topology.create_entities(1)
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    names: list[str] = []
    sub: dolfinx.mesh.MeshTags | None = None
    if domain.interface_groups:
        names, sub = _subgroup_tags(domain)
    fine, parent_cell, parent_facet = _refine_simplices(mesh)
    fine.topology.create_connectivity(tdim - 1, tdim)
    ct = dolfinx.mesh.transfer_meshtag(domain.cell_tags, fine, parent_cell)
    ft = dolfinx.mesh.transfer_meshtag(domain.facet_tags, fine, parent_cell, parent_facet)
    groups: dict[str, np.ndarray] = {}
    if sub is not None:
        st = dolfinx.mesh.transfer_meshtag(sub, fine, parent_cell, parent_facet)
        owned = st.indices < fine.topology.index_map(tdim - 1).size_local
        c = _facet_centroids(fine, st.indices[owned])
        for k, name in enumerate(names, start=1):
            parts = fine.comm.allgather(c[st.values[owned] == k])
            allc = np.concatenate(parts) if parts else np.zeros((0, fine.geometry.dim))
            groups[name] = allc[np.lexsort(allc.T[::-1])] if allc.size else allc
    ct.name, ft.name = domain.cell_tags.name, domain.facet_tags.name
    out = InterfaceMesh(
        mesh=fine,
        cell_tags=ct,
        facet_tags=ft,
        tags=dict(domain.tags),
        dims=dict(domain.dims),
        interface_groups=groups or dict(domain.interface_groups),
        node_groups=dict(domain.node_groups),
        topology=domain.topology,
    )
    what = "refined mesh"
    check_group_counts(
        out, {n: (d, c * 2**d) for n, (d, c) in counts.items()}, what
    )  # a d-simplex splits into 2^d
    for iface in out.interfaces:
        find_sides(out, iface, what)
    if out.interfaces:
        out.num_interface_facets = out._counts[next(iter(out.interfaces))]
    return out
