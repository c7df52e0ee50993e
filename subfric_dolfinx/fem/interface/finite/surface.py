"""One side of a contact interface as a surface mesh: its facets, their nodes, smooth normals.

A contact surface is the set of exterior facets of one body carrying an interface tag. Each facet
is described by the displacement space's nodes on it, in the order of the facet's Lagrange element
(vertices, then edges, then the interior), so that its current shape is the interpolation of the
nodes' current positions ``X_k + u_k`` (:mod:`.projection`): straight or flat facets for P1,
curved ones for P2 (and exact on a mesh with degree-2 geometry, whose P2 nodes lie on the curved
facets).

Averaged nodal normals make the surface's normal field continuous (``docs/model.md`` §11): at every
node, the sum over the facets around it of the facet's area times its unit outward normal at that
node, normalised. For a polygon inscribed in a circle they are radial at the vertices (the two
chords weigh the same). Facets around a node may be owned by several ranks: the contributions are
summed on the node's owner (a reverse scatter of a DOLFINx vector) and the normalised normals
sent back to every rank that has the node (a forward scatter), also to the extra ghosts of an
extended index map.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import cast

import basix
import dolfinx
import dolfinx.la
import numpy as np

from ..geometry import basix_cell, quadrature_rule
from .projection import facet_basis, parametric_normal

__all__ = ["ContactSurface", "contact_surface", "facet_measures", "nodal_normals"]


@dataclasses.dataclass
class ContactSurface:
    """The facets of one body on an interface that this rank owns.

    Attributes:
        cell: The facets' basix cell (interval, triangle or quadrilateral).
        degree: Degree of the displacement space (the facets' Lagrange degree).
        facets: Local indices of the facets in the bulk mesh, (nf,).
        cells: The body's cell adjacent to each facet, (nf,).
        nodes: Local (block) indices of each facet's displacement nodes, in the order of the
            facet's Lagrange element, (nf, nfd).
        orientation: +1 where the facet's parametric normal (``y_,0`` rotated, or
            ``y_,0 x y_,1``) points out of the body, -1 where it points in, (nf,).
        global_facets: Global indices of the facets (unique over the ranks for the mesh's
            partition), (nf,).
    """

    cell: basix.CellType
    degree: int
    facets: np.ndarray
    cells: np.ndarray
    nodes: np.ndarray
    orientation: np.ndarray
    global_facets: np.ndarray

    @property
    def size(self) -> int:
        """Number of facets."""
        return int(self.facets.size)


@functools.cache
def _facet_dof_table(cell: basix.CellType, degree: int) -> np.ndarray:
    """Cell-local dofs of each facet of ``cell``, in the order of the facet's Lagrange element.

    Vertices in the order of the reference cell's facet, then the facet's edges in the facet's
    own edge order (each edge found by its two vertices), then the facet's interior dofs.
    """
    e = basix.create_element(basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.gll_warped)
    topo = basix.topology(cell)
    tdim = len(topo) - 1
    fcell = basix.CellType[basix.cell.subentity_types(cell)[tdim - 1][0].name]
    ftopo = basix.topology(fcell)
    rows = []
    for lf, fv in enumerate(topo[tdim - 1]):
        dofs = [d for v in fv for d in e.entity_dofs[0][v]]
        if tdim == 3:
            cell_edges = {frozenset(vs): i for i, vs in enumerate(topo[1])}
            for a, b in ftopo[1]:
                dofs += e.entity_dofs[1][cell_edges[frozenset((fv[a], fv[b]))]]
        dofs += e.entity_dofs[tdim - 1][lf]
        rows.append(dofs)
    return np.asarray(rows, dtype=np.int32)


def contact_surface(
    V: dolfinx.fem.FunctionSpace,
    cell_tags: dolfinx.mesh.MeshTags,
    facet_tags: dolfinx.mesh.MeshTags,
    facet_tag: int,
    body_tags: int | list[int],
) -> ContactSurface:
    """The owned facets tagged ``facet_tag`` whose cell belongs to the body (cell tags).

    Not collective. Facets with two adjacent cells (interior facets) are left out: a contact
    surface is a body's boundary.

    Args:
        V: The vector Lagrange displacement space (degree 1 or 2).
        cell_tags: Cell tags of the bodies.
        facet_tags: Facet tags.
        facet_tag: Tag of the interface's facets (on this body's side).
        body_tags: Cell tag(s) of the body.
    """
    mesh = V.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    fmap = mesh.topology.index_map(tdim - 1)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    c2f = mesh.topology.connectivity(tdim, tdim - 1)
    facets = facet_tags.find(facet_tag)
    facets = facets[facets < fmap.size_local]
    counts = f2c.offsets[facets + 1] - f2c.offsets[facets]
    facets = facets[counts == 1]
    cells = f2c.array[f2c.offsets[facets]]
    body = np.concatenate([cell_tags.find(t) for t in np.atleast_1d(body_tags)])
    mine = np.isin(cells, body)
    facets, cells = facets[mine].astype(np.int32), cells[mine].astype(np.int32)

    ccell = basix_cell(mesh.topology.cell_type)
    degree = V.ufl_element().embedded_superdegree
    fcell = basix.CellType[basix.cell.subentity_types(ccell)[tdim - 1][0].name]
    nfc = c2f.offsets[1] - c2f.offsets[0] if c2f.offsets.size > 1 else 0
    if facets.size:
        table = c2f.array.reshape(-1, nfc)[cells]
        lfi = np.argmax(table == facets[:, None], axis=1)
        nodes = V.dofmap.list[cells[:, None], _facet_dof_table(ccell, degree)[lfi]]
    else:
        nodes = np.zeros((0, _facet_dof_table(ccell, degree).shape[1]), dtype=np.int32)
    surface = ContactSurface(
        cell=fcell,
        degree=degree,
        facets=facets,
        cells=cells,
        nodes=nodes.astype(np.int32),
        orientation=np.ones(facets.size),
        global_facets=fmap.local_to_global(facets).astype(np.int64),
    )
    # Orientation: the parametric normal at the facet's centre against the direction from the
    # cell's centre (mean of its nodes) to the facet's centre.
    x = V.tabulate_dof_coordinates()[:, : mesh.geometry.dim]
    if facets.size:
        centre = np.full((1, tdim - 1), 1.0 / tdim if fcell == basix.CellType.triangle else 0.5)
        B = facet_basis(fcell, degree, centre, 1)[:, 0]
        Y = x[surface.nodes]
        y = np.einsum("k,fkd->fd", B[0], Y)
        n = parametric_normal(np.einsum("ak,fkd->fda", B[1:], Y))
        out = x[V.dofmap.list[cells]].mean(axis=1)
        surface.orientation = np.where(np.einsum("fd,fd->f", n, y - out) < 0.0, -1.0, 1.0)
    return surface


def facet_measures(surface: ContactSurface, x_nodes: np.ndarray) -> np.ndarray:
    """Length (2-D) or area (3-D) of each facet at node positions ``x_nodes`` (n_nodes, gdim)."""
    X, w = quadrature_rule(surface.cell, max(surface.degree, 1), "gauss")
    B = facet_basis(surface.cell, surface.degree, X, 1)
    Y = x_nodes[surface.nodes]
    dy = np.einsum("aqk,fkd->fqda", B[1:], Y)
    return np.linalg.norm(parametric_normal(dy), axis=-1) @ w


def nodal_normals(
    surface: ContactSurface,
    x_nodes: np.ndarray,
    index_map: dolfinx.common.IndexMap,
    vec: dolfinx.la.Vector | None = None,
) -> np.ndarray:
    """Averaged unit outward normals at the surface's nodes (collective).

    Args:
        surface: The contact surface (its ``nodes`` are local indices of ``index_map``).
        x_nodes: Current positions of the local nodes of ``index_map`` that the surface uses,
            (n >= max node + 1, gdim).
        index_map: The displacement's index map, possibly extended with extra ghosts: the
            normals are returned at all its local nodes (owned, ghosts, extra ghosts).
        vec: A vector of ``index_map`` with block size ``gdim`` to work in (its values are
            overwritten; made anew by default).

    Returns:
        (size_local + num_ghosts, gdim): the unit normal at every node of the surface (on any
        rank's facet), zeros elsewhere.
    """
    gdim = x_nodes.shape[1]
    if vec is None:
        vec = dolfinx.la.vector(index_map, gdim)
    acc = vec.array.reshape(-1, gdim)
    acc[:] = 0.0
    if surface.size:
        B = facet_basis(surface.cell, surface.degree, _element_points(surface), 1)
        Y = x_nodes[surface.nodes]
        n = parametric_normal(np.einsum("ank,fkd->fnda", B[1:], Y))  # at each node
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        n *= (surface.orientation * facet_measures(surface, x_nodes))[:, None, None]
        np.add.at(acc, surface.nodes.ravel(), n.reshape(-1, gdim))
    vec.scatter_reverse(dolfinx.la.InsertMode.add)
    own = acc[: index_map.size_local]
    norm = np.linalg.norm(own, axis=1)
    nz = norm > 0
    own[nz] /= norm[nz, None]
    vec.scatter_forward()
    return acc.copy()


def _element_points(surface: ContactSurface) -> np.ndarray:
    e = basix.create_element(
        basix.ElementFamily.P, surface.cell, surface.degree, basix.LagrangeVariant.gll_warped
    )
    return cast(np.ndarray, e.points)  # (basix annotates an ArrayLike)
