"""Pairing of the two sides of a zero-thickness interface, across MPI ranks.

The interface facets carry one facet tag on both sides (the nodes are duplicated, so each side is an
exterior facet of its own body); the side is told by the body tag of the adjacent cell. For every
owned primary facet this module finds the secondary facet at the same place, possibly on another
rank, and the secondary facet's displacement nodes, ordered like the primary's. Memory and
communication are local: every rank all-gathers only the bounding box of its primary facets (two
points per rank) and sends each of its secondary facets (midpoint, node numbers, owners and
coordinates) to the ranks whose box holds it (``MPI_Alltoallv``); a rank thus receives the secondary
facets near its own primary facets, never the whole interface. The midpoints are matched with a k-d
tree (``scipy.spatial.cKDTree``), the nodes of a pair by vectorised nearest-point searches, and the
owners learn how many primary facets took each of their secondary facets (each must be taken once).

The displacement space's index map is then extended with the secondary nodes that are not local as
extra ghosts, so that one ghost update brings the other side's values and one reverse update sends
the interface contributions to their owners, and the matrix sparsity can include the cross-interface
couplings (see :mod:`.layout`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import cast

import basix
import dolfinx
import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from ....compat import create_submesh, ghosted_index_map
from ..base import InterfaceError, Received, exchange_rows
from ..geometry import basix_cell, push_forward

__all__ = ["InterfacePairs", "pair_interface"]


@dataclasses.dataclass
class InterfacePairs:
    """Paired interface facets owned by this rank, in the order of the submesh cells.

    Attributes:
        submesh: Mesh of the owned primary interface facets (the interface's own mesh).
        facets: Parent facet of each submesh cell (local index in the bulk mesh).
        primary_cells: Primary cell adjacent to each facet.
        reference_nodes: Points of the facet Lagrange element (reference coordinates).
        node_points: Physical position of each reference node of each facet, (nf, nfd, gdim).
        primary_nodes: Local (block) indices of the primary facet's displacement nodes, ordered
            like ``reference_nodes``, (nf, nfd).
        secondary_nodes: Same for the secondary facet, as local indices in ``index_map``, (nf, nfd).
        index_map: The displacement index map extended with the non-local secondary nodes as ghosts.
        n_extra_ghosts: Number of nodes added to the ghosts of the displacement index map.
        n_split: Number of this rank's pairs whose secondary facet is owned by another rank.
        h_min: Smallest distance between two nodes of an interface facet, over all ranks.
        n_received: Number of secondary facets this rank received from other ranks to pair its
            primary facets (the size of the exchange: the secondary facets near this rank's primary
            facets that other ranks own).
        extra_ghosts: Global (block) numbers of the nodes added to the ghosts, in the order of
            ``index_map``'s extra ghosts.
        extra_owners: Their owning ranks.

    The primary side's outward normal defines the frame.
    """

    submesh: dolfinx.mesh.Mesh
    facets: np.ndarray
    primary_cells: np.ndarray
    reference_nodes: np.ndarray
    node_points: np.ndarray
    primary_nodes: np.ndarray
    secondary_nodes: np.ndarray
    index_map: dolfinx.common.IndexMap
    n_extra_ghosts: int
    n_split: int
    h_min: float
    n_received: int = 0
    extra_ghosts: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int64))
    extra_owners: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))


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
    primary_tag: int | Sequence[int],
    secondary_tag: int | Sequence[int],
    *,
    rel_tol: float = 1e-8,
    name: str = "interface",
) -> InterfacePairs:
    """Pair the primary and secondary facets of an interface and extend the index map.

    Collective on the mesh communicator. The steps: the interface's facets of each side
    (:func:`_sides`); the owned primary facets' own mesh and the nodes of their Lagrange element
    (:func:`_primary_facets`); the matching tolerance from the smallest node distance; the primary
    facets' displacement nodes; the secondary facets sent to the ranks whose primary facets may
    face them and matched by their midpoints, each taken once (:func:`_match_secondary`); their
    nodes ordered like the primary's (:func:`_secondary_nodes`); the index map extended with
    those another rank owns.

    Args:
        V: Vector Lagrange displacement space (degree 1 or 2) on the bulk mesh.
        cell_tags: Cell tags with the two bodies.
        facet_tags: Facet tags with the interface (both sides tagged ``interface_tag``).
        interface_tag: Tag of the interface facets.
        primary_tag: Cell tag(s) of the primary body: its outward normal defines the local
            frame. A body of several cell groups has several tags.
        secondary_tag: Cell tag(s) of the secondary body.
        rel_tol: Matching tolerance relative to the smallest interface facet size.
        name: The interface's name, for messages.

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
    primary, secondary = _sides(
        mesh, cell_tags, facet_tags, interface_tag, _tags(primary_tag), _tags(secondary_tag), name
    )
    sub, m_facets, m_cells, Xn, node_points = _primary_facets(V, *primary)
    nf, nfd = m_facets.size, Xn.shape[0]

    # Facet sizes for the tolerance (global minimum)
    h_loc = np.inf
    for i in range(nfd if nf else 0):  # one pair of nodes at a time: memory O(nf)
        for i2 in range(i + 1, nfd):
            d_ij = np.linalg.norm(node_points[:, i] - node_points[:, i2], axis=-1)
            h_loc = min(h_loc, float(d_ij.min()))
    h = comm.allreduce(h_loc, op=MPI.MIN)
    tol = rel_tol * (h if np.isfinite(h) else 1.0)

    dof_x = V.tabulate_dof_coordinates()[:, :gdim]
    imap = V.dofmap.index_map

    # Primary facet nodes, ordered like the reference nodes (match within the adjacent cell).
    cell_nodes = V.dofmap.list[m_cells]
    j, far = _nearest(dof_x[cell_nodes], node_points, tol)
    primary_nodes = np.take_along_axis(cell_nodes, j, axis=1).astype(np.int32)
    lost = node_points[far[0]].tolist() if far.size else None
    _fail(
        comm, None if lost is None else f"internal error: primary facet nodes not found at {lost}"
    )

    cand, match = _match_secondary(V, dof_x, *secondary, node_points, tol, name)
    secondary_glob, secondary_own = _secondary_nodes(comm, cand, match, node_points, tol, name)

    # Extend the index map: secondary nodes that are not local become extra ghosts (in the order in
    # which they first appear).
    secondary_nodes, extra_g, extra_o = _local_indices(
        imap, secondary_glob.ravel(), secondary_own.ravel()
    )
    ghosts = np.concatenate([imap.ghosts, extra_g])
    owners = np.concatenate([imap.owners, extra_o])
    imap_ext = ghosted_index_map(comm, imap.size_local, ghosts, owners)
    secondary_nodes = secondary_nodes.reshape(nf, nfd)
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
        n_extra_ghosts=extra_g.size,
        n_split=n_split,
        h_min=float(h) if np.isfinite(h) else 1.0,
        n_received=int(np.count_nonzero(cand.source != comm.rank)),
        extra_ghosts=extra_g.astype(np.int64),
        extra_owners=extra_o.astype(np.int32),
    )


def _fail(comm: MPI.Comm, msg: str | None) -> None:
    """Raise :class:`InterfaceError` on every rank with the first rank's message, if any has one.

    Collective.
    """
    msgs = [m for m in comm.allgather(msg) if m]
    if msgs:
        raise InterfaceError(msgs[0])


def _sides(
    mesh: dolfinx.mesh.Mesh,
    cell_tags: dolfinx.mesh.MeshTags,
    facet_tags: dolfinx.mesh.MeshTags,
    interface_tag: int,
    m_tags: np.ndarray,
    s_tags: np.ndarray,
    name: str,
) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The owned interface facets of each side with their adjacent cells (collective).

    Returns:
        ``(primary facets, their cells)``, ``(secondary facets, their cells)``.

    Raises:
        InterfaceError: On every rank: no facet tagged ``interface_tag``, facets with two
            adjacent cells, sides sharing a cell tag, facets touching neither body.
    """
    comm = mesh.comm
    tagged = facet_tags.find(interface_tag)
    tagged = tagged[tagged < mesh.topology.index_map(mesh.topology.dim - 1).size_local]
    counts, cells = _adjacent_cells(mesh, tagged)
    n_global = comm.allreduce(tagged.size)
    _fail(
        comm,
        None
        if n_global
        else f"no facets tagged {interface_tag} ({name}): the mesh has no interface group",
    )
    two = tagged[counts != 1]
    n_two = comm.allreduce(two.size)  # (on every rank: a collective)
    _fail(
        comm,
        None
        if two.size == 0
        else f"{n_two} {name} facets have {counts[counts != 1][0]} adjacent "
        f"cells, e.g. at {_facet_midpoints(mesh, two[:1])[0].tolist()}: the interface nodes are "
        "not duplicated (each side must be an exterior facet of its own body)",
    )
    primary_cells_all = np.concatenate([cell_tags.find(t) for t in m_tags])
    secondary_cells_all = np.concatenate([cell_tags.find(t) for t in s_tags])
    is_primary = np.isin(cells, primary_cells_all)
    is_secondary = np.isin(cells, secondary_cells_all)
    neither = ~(is_primary | is_secondary)
    both = np.intersect1d(m_tags, s_tags)
    _fail(
        comm,
        None
        if both.size == 0
        else f"{name}: the two sides share the cell tag(s) {both.tolist()}; an interface joins "
        "two different bodies",
    )
    n_neither = comm.allreduce(int(neither.sum()))  # (on every rank: a collective)
    _fail(
        comm,
        None
        if not neither.any()
        else f"{n_neither} {name} facets touch a cell of neither body "
        f"(tags {_show(m_tags)}, {_show(s_tags)}), e.g. at "
        f"{_facet_midpoints(mesh, tagged[neither][:1])[0].tolist()}",
    )
    return (tagged[is_primary], cells[is_primary]), (tagged[is_secondary], cells[is_secondary])


def _primary_facets(
    V: dolfinx.fem.FunctionSpace, m_facets: np.ndarray, m_cells: np.ndarray
) -> tuple[dolfinx.mesh.Mesh, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The interface's own mesh (the owned primary facets) and its Lagrange element's nodes.

    Its cells define the parametrisation (vertex order) used for the quadrature points, so
    everything after follows submesh order.

    Returns:
        The submesh, the primary facets and their cells in its order, the reference nodes of the
        facet Lagrange element and their positions on each facet, (nf, nfd, gdim).
    """
    mesh = V.mesh
    sub, entity_map = create_submesh(mesh, mesh.topology.dim - 1, m_facets)
    sorter = np.argsort(m_facets)
    perm = sorter[np.searchsorted(m_facets, np.asarray(entity_map), sorter=sorter)]
    m_facets, m_cells = m_facets[perm], m_cells[perm]
    # Reference nodes of the facet Lagrange element, pushed through each submesh cell's map.
    degree = V.ufl_element().embedded_superdegree
    felem = basix.create_element(
        basix.ElementFamily.P,
        basix_cell(sub.topology.cell_type),
        degree,
        basix.LagrangeVariant.gll_warped,
    )
    Xn = cast(np.ndarray, felem.points)  # (basix annotates an ArrayLike)
    return sub, m_facets, m_cells, Xn, push_forward(sub, Xn)


def _match_secondary(
    V: dolfinx.fem.FunctionSpace,
    dof_x: np.ndarray,
    s_facets: np.ndarray,
    s_cells: np.ndarray,
    node_points: np.ndarray,
    tol: float,
    name: str,
) -> tuple[Received, np.ndarray]:
    """The secondary facets near this rank's primary facets, and the one each primary faces.

    Collective. Each owned secondary facet (its closure nodes: coordinates, global numbers,
    owners) goes to the ranks whose primary facets' bounding box, grown by the tolerance, holds
    its midpoint (:func:`_exchange_secondary_facets`); the midpoints are matched with a k-d tree,
    and the owners count how many primary facets took each of their secondary facets.

    Returns:
        The candidates received (rows: midpoint, nodes' coordinates, global numbers, owners,
        the facet's index at its owner) and each primary facet's candidate.

    Raises:
        InterfaceError: On every rank: a primary facet without a secondary facet at its place,
            other numbers of facets on the two sides, a secondary facet taken by no primary facet
            or by several.
    """
    mesh = V.mesh
    comm = mesh.comm
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    imap, dofs = V.dofmap.index_map, V.dofmap.list
    nf, nfd = node_points.shape[:2]
    # Secondary facets owned here: closure nodes (global index, owner, coordinates) and midpoint.
    vector_element = V.ufl_element().sub_elements[0].basix_element
    closure = np.asarray(vector_element.entity_closure_dofs[tdim - 1], dtype=np.int32)
    lfi = _local_facet_index(mesh, s_cells, s_facets) if s_facets.size else np.zeros(0, int)
    s_nodes = (
        dofs[s_cells[:, None], closure[lfi]].astype(np.int32)
        if s_facets.size
        else np.zeros((0, nfd), dtype=np.int32)
    )
    owners_all = np.concatenate([np.full(imap.size_local, comm.rank, np.int32), imap.owners])
    s_x = dof_x[s_nodes]
    s_mid = s_x.mean(axis=1) if s_facets.size else np.zeros((0, gdim))
    m_mid = node_points.mean(axis=1) if nf else np.zeros((0, gdim))

    # Each secondary facet goes to the ranks whose primary facets' bounding box (grown by the
    # tolerance) holds its midpoint: a rank receives the secondary facets near its own primary
    # facets.
    cand = _exchange_secondary_facets(
        comm,
        m_mid,
        s_mid,
        [
            s_x,
            imap.local_to_global(s_nodes.ravel()).reshape(s_nodes.shape).astype(np.int64),
            owners_all[s_nodes],
            np.arange(s_facets.size, dtype=np.int32),
        ],
        2.0 * tol,
    )
    c_mid, c_index = cand.rows[0], cand.rows[4]
    match: np.ndarray = np.full(nf, -1, dtype=np.int64)
    if nf and c_mid.shape[0]:
        d, k = cKDTree(c_mid).query(m_mid)
        match = np.where(d <= tol, k, -1)
    unmatched = np.flatnonzero(match < 0)
    n_unmatched = comm.allreduce(unmatched.size)
    n_secondary = comm.allreduce(s_facets.size)
    if n_unmatched or n_secondary != comm.allreduce(nf):
        example = m_mid[unmatched[0]].tolist() if unmatched.size else None
        examples = [e for e in comm.allgather(example) if e is not None]
        where = f", e.g. the primary facet at {examples[0]}" if examples else ""
        raise InterfaceError(
            f"the {name} sides do not pair node to node: {comm.allreduce(nf)} primary and "
            f"{n_secondary} secondary facets, {n_unmatched} primary facets without a secondary "
            f"facet at the same place{where} (tolerance {tol:.3g})"
        )
    # How many primary facets took each secondary facet: counted where matched, summed by its owner.
    times = np.bincount(match, minlength=c_mid.shape[0])
    taken = np.flatnonzero(times)
    back = exchange_rows(comm, cand.source[taken], [c_index[taken], times[taken]])
    used = np.zeros(s_facets.size, dtype=np.int64)
    np.add.at(used, back.rows[0], back.rows[1])
    n_none = comm.allreduce(int(np.sum(used == 0)))
    n_several = comm.allreduce(int(np.sum(used > 1)))
    if n_none or n_several:
        k = np.flatnonzero(used != 1)
        example = s_mid[k[0]].tolist() if k.size else None
        examples = [e for e in comm.allgather(example) if e is not None]
        raise InterfaceError(
            f"the {name} sides do not pair node to node: {n_none} secondary facets have no primary "
            f"partner and {n_several} have several, e.g. the secondary facet at {examples[0]}"
        )
    return cand, match


def _secondary_nodes(
    comm: MPI.Comm,
    cand: Received,
    match: np.ndarray,
    node_points: np.ndarray,
    tol: float,
    name: str,
) -> tuple[np.ndarray, np.ndarray]:
    """The matched secondary facets' nodes, ordered like the primary's reference nodes.

    Collective (the check).

    Returns:
        Their global (block) numbers and owners, (nf, nfd) each.

    Raises:
        InterfaceError: On every rank: a matched facet whose nodes are not at the primary's.
    """
    nf = node_points.shape[0]
    c_x, c_glob, c_own = cand.rows[1], cand.rows[2], cand.rows[3]
    j, far = _nearest(c_x[match], node_points, tol)
    twice = np.flatnonzero(np.any(np.diff(np.sort(j, axis=1), axis=1) == 0, axis=1))
    first = min(far[0] if far.size else nf, twice[0] if twice.size else nf)
    _fail(
        comm,
        None
        if first == nf
        else f"the {name} sides do not pair node to node: the facet at "
        f"{node_points[first].tolist()} has a partner whose nodes are elsewhere",
    )
    return np.take_along_axis(c_glob[match], j, axis=1), np.take_along_axis(c_own[match], j, axis=1)


def _tags(tag: int | Sequence[int]) -> np.ndarray:
    return np.unique(np.atleast_1d(np.asarray(tag, dtype=np.int32)))


def _show(tags: np.ndarray) -> str:
    return str(int(tags[0])) if tags.size == 1 else str(tags.tolist())


def _exchange_secondary_facets(
    comm: MPI.Comm,
    m_mid: np.ndarray,
    s_mid: np.ndarray,
    data: list[np.ndarray],
    pad: float,
) -> Received:
    """Send each secondary facet (midpoint and ``data`` rows) to the ranks that may pair it.

    Those are the ranks whose primary facet midpoints have a bounding box that, grown by ``pad``,
    holds the secondary facet's midpoint (this rank included). Only the boxes are all-gathered (two
    points per rank).

    Returns:
        The candidates: their source rank, and rows ``[midpoint, *data]``.
    """
    gdim = s_mid.shape[1]
    box = np.empty(2 * gdim)
    box[:gdim] = m_mid.min(axis=0) - pad if m_mid.size else np.inf
    box[gdim:] = m_mid.max(axis=0) + pad if m_mid.size else -np.inf
    boxes = np.empty((comm.size, 2 * gdim))
    comm.Allgather(box, boxes)
    inside = np.all(
        (s_mid[:, None, :] >= boxes[None, :, :gdim]) & (s_mid[:, None, :] <= boxes[None, :, gdim:]),
        axis=2,
    )
    facet, rank = np.nonzero(inside)
    return exchange_rows(comm, rank.astype(np.int32), [s_mid[facet]] + [a[facet] for a in data])


def _nearest(
    candidates: np.ndarray, points: np.ndarray, tol: float, chunk: int = 512
) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``points[i]`` (nf, n, gdim), the nearest of ``candidates[i]`` (nf, m, gdim).

    Returns:
        The indices (nf, n) into the candidates (the first of equally near ones), and the rows
        ``i`` (ascending) with a point farther than ``tol`` from every candidate.
    """
    nf, n = points.shape[:2]
    j = np.empty((nf, n), dtype=np.int64)
    far = []
    for s in range(0, nf, chunk):
        d = np.linalg.norm(
            candidates[s : s + chunk, None, :, :] - points[s : s + chunk, :, None, :], axis=-1
        )
        jj = np.argmin(d, axis=2)
        j[s : s + chunk] = jj
        dmin = np.take_along_axis(d, jj[..., None], axis=2)[..., 0]
        far.append(s + np.flatnonzero(np.any(dmin > tol, axis=1)))
    return j, np.concatenate(far) if far else np.zeros(0, dtype=np.int64)


def _local_indices(
    imap: dolfinx.common.IndexMap, glob: np.ndarray, owner: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local indices of global node numbers, the nodes not local becoming extra ghosts.

    Returns:
        The local indices in the index map extended with the extra ghosts, and the extra ghosts'
        global numbers and owners, in the order in which they first appear in ``glob``.
    """
    start = imap.local_range[0]
    n_local = imap.size_local + imap.num_ghosts
    local = np.full(glob.size, -1, dtype=np.int64)
    owned = (glob >= start) & (glob < start + imap.size_local)
    local[owned] = glob[owned] - start
    ghosts = imap.ghosts
    if ghosts.size:
        sorter = np.argsort(ghosts)
        pos = np.minimum(np.searchsorted(ghosts, glob, sorter=sorter), ghosts.size - 1)
        hit = ~owned & (ghosts[sorter[pos]] == glob)
        local[hit] = imap.size_local + sorter[pos[hit]]
    rest = np.flatnonzero(local < 0)
    uniq, first, inverse = np.unique(glob[rest], return_index=True, return_inverse=True)
    order = np.argsort(first)  # first appearance
    rank_of = np.empty_like(order)
    rank_of[order] = np.arange(order.size)
    local[rest] = n_local + rank_of[inverse.reshape(-1)]
    return (
        local.astype(np.int32),
        uniq[order].astype(np.int64),
        owner[rest][first[order]].astype(np.int32),
    )


def _facet_midpoints(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> np.ndarray:
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    nodes = dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, facets)
    return mesh.geometry.x[nodes].mean(axis=1)[:, :gdim]
