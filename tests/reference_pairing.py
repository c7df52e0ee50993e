"""The all-gather pairing of the interface sides as it was before issue 13 (test reference).

A verbatim copy of ``subfric_dolfinx/fem/interface/pairing.py`` (now ``.../small/pairing.py``) and
of ``match_points`` at commit 4ba6b8b: every rank all-gathers the secondary facets of the whole
interface (midpoints, node numbers, owners and coordinates) and matches them with a grid hash and
Python loops. The package's pairing exchanges only what each rank needs;
``tests/fem/interface/small/test_pairing.py`` checks that it gives the same pairs, in the same
order, and ``benchmarks/pairing_scaling.py`` measures both. Since then only the names of the
pairs' fields and the messages' words changed (``master``/``slave`` became
``primary``/``secondary``).
"""

from __future__ import annotations

import basix
import dolfinx
import numpy as np
from mpi4py import MPI

from subfric_dolfinx.compat import create_submesh, ghosted_index_map
from subfric_dolfinx.fem.interface.base import InterfaceError
from subfric_dolfinx.fem.interface.geometry import basix_cell, push_forward
from subfric_dolfinx.fem.interface.small.pairing import InterfacePairs

__all__ = ["match_points", "pair_interface"]


def _adjacent_cells(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    tdim = mesh.topology.dim
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    counts = f2c.offsets[facets + 1] - f2c.offsets[facets]
    return counts, f2c.array[f2c.offsets[facets]]


def _local_facet_index(
    mesh: dolfinx.mesh.Mesh, cells: np.ndarray, facets: np.ndarray
) -> np.ndarray:
    tdim = mesh.topology.dim
    c2f = mesh.topology.connectivity(tdim, tdim - 1)
    nfc = c2f.offsets[1] - c2f.offsets[0] if c2f.offsets.size > 1 else 0
    table = c2f.array.reshape(-1, nfc)[cells]
    return np.argmax(table == facets[:, None], axis=1)


def pair_interface(
    V: dolfinx.fem.FunctionSpace,
    cell_tags: dolfinx.mesh.MeshTags,
    facet_tags: dolfinx.mesh.MeshTags,
    interface_tag: int,
    primary_tag: int,
    secondary_tag: int,
    *,
    rel_tol: float = 1e-8,
) -> InterfacePairs:
    """Pair the primary and secondary facets of an interface and extend the index map.

    Collective on the mesh communicator.

    Args:
        V: Vector Lagrange displacement space (degree 1 or 2) on the bulk mesh.
        cell_tags: Cell tags with the two bodies.
        facet_tags: Facet tags with the interface (both sides tagged ``interface_tag``).
        interface_tag: Tag of the interface facets.
        primary_tag: Cell tag of the primary body (its outward normal defines the local frame).
        secondary_tag: Cell tag of the secondary body.
        rel_tol: Matching tolerance relative to the smallest interface facet size.

    Raises:
        InterfaceError: On all ranks, naming the problem: no interface facets, facets adjacent to
            two cells (nodes not duplicated), facets adjacent to neither body, or facets without a
            partner on the other side (with their count and a coordinate).
    """
    mesh = V.mesh
    comm = mesh.comm
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    bs = V.dofmap.bs
    if bs != gdim:
        raise ValueError(f"V must be a vector space with {gdim} components, got block size {bs}")
    if V.element.needs_dof_transformations:
        raise ValueError("only Lagrange degree 1 and 2 displacement spaces are supported")
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    fmap = mesh.topology.index_map(tdim - 1)

    tagged = facet_tags.find(interface_tag)
    tagged = tagged[tagged < fmap.size_local]
    counts, cells = _adjacent_cells(mesh, tagged)

    def fail(msg: str | None) -> None:
        msgs = [m for m in comm.allgather(msg) if m]
        if msgs:
            raise InterfaceError(msgs[0])

    n_global = comm.allreduce(tagged.size)
    fail(
        None
        if n_global
        else f"no facets tagged {interface_tag} (interface): the mesh has no interface group"
    )
    two = tagged[counts != 1]
    fail(
        None
        if two.size == 0
        else f"{comm.allreduce(two.size)} interface facets have {counts[counts != 1][0]} adjacent "
        f"cells, e.g. at {_facet_midpoints(mesh, two[:1])[0].tolist()}: the interface nodes are "
        "not duplicated (each side must be an exterior facet of its own body)"
    )
    primary_cells_all = cell_tags.find(primary_tag)
    secondary_cells_all = cell_tags.find(secondary_tag)
    is_primary = np.isin(cells, primary_cells_all)
    is_secondary = np.isin(cells, secondary_cells_all)
    neither = ~(is_primary | is_secondary)
    fail(
        None
        if not neither.any()
        else f"{comm.allreduce(int(neither.sum()))} interface facets touch a cell of neither body "
        f"(tags {primary_tag}, {secondary_tag}), e.g. at "
        f"{_facet_midpoints(mesh, tagged[neither][:1])[0].tolist()}"
    )
    m_facets, m_cells = tagged[is_primary], cells[is_primary]
    s_facets, s_cells = tagged[is_secondary], cells[is_secondary]

    # The interface's own mesh: the owned primary facets. Its cells define the parametrisation
    # (vertex order) used for the quadrature points, so everything below follows submesh order.
    sub, entity_map = create_submesh(mesh, tdim - 1, m_facets)
    order = {int(f): i for i, f in enumerate(m_facets)}
    perm = np.array([order[int(f)] for f in entity_map], dtype=np.int64)
    m_facets, m_cells = m_facets[perm], m_cells[perm]
    nf = m_facets.size

    # Reference nodes of the facet Lagrange element, pushed through each submesh cell's map.
    degree = V.ufl_element().embedded_superdegree
    fcell = sub.topology.cell_type
    felem = basix.create_element(
        basix.ElementFamily.P, basix_cell(fcell), degree, basix.LagrangeVariant.gll_warped
    )
    Xn = felem.points
    node_points = push_forward(sub, Xn)  # (nf, nfd, gdim)
    nfd = Xn.shape[0]

    # Facet sizes for the tolerance (global minimum)
    dists = np.linalg.norm(node_points[:, :, None, :] - node_points[:, None, :, :], axis=-1)
    off_diagonal = ~np.eye(nfd, dtype=bool)
    h_loc = float(dists[:, off_diagonal].min()) if nf else np.inf
    h = comm.allreduce(h_loc, op=MPI.MIN)
    tol = rel_tol * (h if np.isfinite(h) else 1.0)

    dof_x = V.tabulate_dof_coordinates()[:, :gdim]
    imap = V.dofmap.index_map
    n_local_nodes = imap.size_local + imap.num_ghosts
    dofs = V.dofmap.list

    # Primary facet nodes, ordered like the reference nodes (match within the adjacent cell).
    primary_nodes = np.empty((nf, nfd), dtype=np.int32)
    lost = None
    for i in range(nf):
        cn = dofs[m_cells[i]]
        d = np.linalg.norm(dof_x[cn][None, :, :] - node_points[i][:, None, :], axis=-1)
        j = np.argmin(d, axis=1)
        if lost is None and np.any(d[np.arange(nfd), j] > tol):
            lost = node_points[i].tolist()
        primary_nodes[i] = cn[j]
    fail(None if lost is None else f"internal error: primary facet nodes not found at {lost}")

    # Secondary facets owned here: closure nodes (global index, owner, coordinates) and midpoint.
    vector_element = V.ufl_element().sub_elements[0].basix_element
    closure = vector_element.entity_closure_dofs[tdim - 1]
    lfi = _local_facet_index(mesh, s_cells, s_facets) if s_facets.size else np.zeros(0, int)
    s_nodes = (
        np.array([dofs[c][closure[lf]] for c, lf in zip(s_cells, lfi, strict=True)], dtype=np.int32)
        if s_facets.size
        else np.zeros((0, nfd), dtype=np.int32)
    )
    owners_all = np.concatenate([np.full(imap.size_local, comm.rank, np.int32), imap.owners])
    l2g = imap.local_to_global(np.arange(n_local_nodes, dtype=np.int32))
    s_mid = dof_x[s_nodes].mean(axis=1) if s_facets.size else np.zeros((0, gdim))
    s_data = (
        s_mid,
        l2g[s_nodes].astype(np.int64),
        owners_all[s_nodes],
        dof_x[s_nodes],
    )
    gathered = comm.allgather(s_data)
    all_mid = np.concatenate([g[0] for g in gathered]).reshape(-1, gdim)
    all_glob = np.concatenate([g[1] for g in gathered]).reshape(-1, nfd)
    all_own = np.concatenate([g[2] for g in gathered]).reshape(-1, nfd)
    all_x = np.concatenate([g[3] for g in gathered]).reshape(-1, nfd, gdim)

    m_mid = node_points.mean(axis=1) if nf else np.zeros((0, gdim))
    match, _ = match_points(all_mid, m_mid, tol)
    unmatched = np.flatnonzero(match < 0)
    n_unmatched = comm.allreduce(unmatched.size)
    n_secondary = comm.allreduce(s_facets.size)
    if n_unmatched or n_secondary != comm.allreduce(nf):
        example = m_mid[unmatched[0]].tolist() if unmatched.size else None
        examples = [e for e in comm.allgather(example) if e is not None]
        where = f", e.g. the primary facet at {examples[0]}" if examples else ""
        raise InterfaceError(
            f"the interface sides do not pair node to node: {comm.allreduce(nf)} primary and "
            f"{n_secondary} secondary facets, {n_unmatched} primary facets without a secondary "
            f"facet at the same place{where} (tolerance {tol:.3g})"
        )
    used = np.zeros(all_mid.shape[0], dtype=np.int64)
    np.add.at(used, match, 1)
    used = comm.allreduce(used)
    if np.any(used != 1):
        k = int(np.flatnonzero(used != 1)[0])
        raise InterfaceError(
            f"the interface sides do not pair node to node: {int(np.sum(used == 0))} secondary "
            f"facets have no primary partner and {int(np.sum(used > 1))} have several, e.g. the "
            f"secondary facet at {all_mid[k].tolist()}"
        )

    # Secondary nodes ordered like the primary's reference nodes.
    secondary_glob = np.empty((nf, nfd), dtype=np.int64)
    secondary_own = np.empty((nf, nfd), dtype=np.int32)
    bad = None
    for i in range(nf):
        k = match[i]
        d = np.linalg.norm(all_x[k][None, :, :] - node_points[i][:, None, :], axis=-1)
        j = np.argmin(d, axis=1)
        if np.any(d[np.arange(nfd), j] > tol) or len(set(j.tolist())) != nfd:
            bad = node_points[i].tolist()
            break
        secondary_glob[i], secondary_own[i] = all_glob[k][j], all_own[k][j]
    fail(
        None
        if bad is None
        else f"the interface sides do not pair node to node: the facet at {bad} has a partner "
        "whose nodes are elsewhere"
    )

    # Extend the index map: secondary nodes that are not local become extra ghosts.
    g2l = {int(g): i for i, g in enumerate(l2g)}
    flat_g, flat_o = secondary_glob.ravel(), secondary_own.ravel()
    extra: dict[int, int] = {}
    for g, o in zip(flat_g.tolist(), flat_o.tolist(), strict=True):
        if g not in g2l and g not in extra:
            extra[g] = o
    ghosts = np.concatenate([imap.ghosts, np.fromiter(extra.keys(), np.int64, len(extra))])
    owners = np.concatenate([imap.owners, np.fromiter(extra.values(), np.int32, len(extra))])
    imap_ext = ghosted_index_map(comm, imap.size_local, ghosts, owners)
    for k, g in enumerate(extra):
        g2l[g] = n_local_nodes + k
    secondary_nodes = np.array([g2l[int(g)] for g in flat_g], dtype=np.int32).reshape(nf, nfd)
    n_split = int(np.count_nonzero(np.any(secondary_own != comm.rank, axis=1)))

    return InterfacePairs(
        submesh=sub,
        facets=m_facets,
        primary_cells=m_cells,
        reference_nodes=Xn,
        node_points=node_points,
        primary_nodes=primary_nodes,
        secondary_nodes=secondary_nodes,
        index_map=imap_ext,
        n_extra_ghosts=len(extra),
        n_split=n_split,
        h_min=float(h) if np.isfinite(h) else 1.0,
    )


def _facet_midpoints(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    nodes = dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, facets)
    return mesh.geometry.x[nodes].mean(axis=1)[:, :gdim]


def match_points(
    keys: np.ndarray, queries: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """For each query point, the index of a key point within ``tol`` (or -1), and the distance.

    Hashes the keys on a grid of spacing ``4 tol`` and searches the neighbouring grid cells.
    """
    n, d = queries.shape
    out = np.full(n, -1, dtype=np.int64)
    dist = np.full(n, np.inf)
    if keys.shape[0] == 0 or n == 0:
        return out, dist
    h = 4.0 * tol
    kq = np.floor(keys / h).astype(np.int64)
    table: dict[tuple[int, ...], list[int]] = {}
    for i, k in enumerate(map(tuple, kq)):
        table.setdefault(k, []).append(i)
    qq = np.floor(queries / h).astype(np.int64)
    shifts = np.array(np.meshgrid(*[[-1, 0, 1]] * d, indexing="ij")).reshape(d, -1).T
    for i in range(n):
        best, bd = -1, np.inf
        for s in shifts:
            for j in table.get(tuple(qq[i] + s), ()):
                dd = float(np.linalg.norm(keys[j] - queries[i]))
                if dd < bd:
                    best, bd = j, dd
        if bd <= tol:
            out[i], dist[i] = best, bd
    return out, dist
