"""Search of the primary facets that secondary points project on (current configuration, MPI ranks).

Each rank has its secondary points (those of the secondary facets it owns) and owns some primary
facets; a point may project on a facet of another rank, and as the bodies slide that changes. Every
step (``docs/model.md`` §11):

1. :func:`exchange_facets`: every rank covers its points with a few boxes (a k-d split of the
   points, at most ``max_boxes`` leaves, each grown by the search radius) and all-gathers only the
   boxes (``2 gdim max_boxes`` numbers per rank). Every rank sends each of its primary facets whose
   bounding box meets a rank's box to that rank (``MPI_Alltoallv``): a rank receives the primary
   facets near its own points, never the whole surface. A facet travels with its nodes' current
   positions and nodal normals, their global numbers and owners (to ghost their displacements)
   and the facet's global number.
2. :func:`find_projections`: every point is projected (:func:`.projection.normal_projection`) on
   the candidate facets within reach (a k-d tree of the facets' centres); of the projections that
   fall on their facet, the nearest (smallest ``|distance|``) is kept. A point whose projection
   lies on no facet (beyond the surface's edge) or farther than the radius has none.

The result does not depend on the partition: every facet within the radius of a point reaches the
point's rank, so 1 and 2 ranks find the same projections (ties, a point projecting exactly on an
edge two facets share, give the same point and normal from either facet).
"""

from __future__ import annotations

import dataclasses

import basix
import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from ..base import exchange_rows
from .projection import normal_projection

__all__ = [
    "Candidates",
    "PointProjections",
    "exchange_facets",
    "find_projections",
    "near_pairs",
    "point_boxes",
]


@dataclasses.dataclass
class Candidates:
    """Primary facets that may be reached by this rank's points (its own and received ones).

    Attributes:
        cell: The facets' basix cell.
        degree: Their Lagrange degree.
        x: Current positions of each facet's nodes, (nc, nfd, gdim).
        normals: Nodal normals at those nodes, (nc, nfd, gdim).
        global_nodes: Global (block) numbers of the nodes in the displacement's index map,
            (nc, nfd).
        owners: Owning rank of each node, (nc, nfd).
        global_facets: Global facet numbers, (nc,).
        source: The rank each facet came from (this rank for its own), (nc,).
        rank: This rank.
    """

    cell: basix.CellType
    degree: int
    x: np.ndarray
    normals: np.ndarray
    global_nodes: np.ndarray
    owners: np.ndarray
    global_facets: np.ndarray
    source: np.ndarray
    rank: int

    @property
    def size(self) -> int:
        """Number of candidate facets."""
        return int(self.global_facets.size)

    @property
    def n_received(self) -> int:
        """Number of candidate facets received from other ranks."""
        return int(np.count_nonzero(self.source != self.rank))


def point_boxes(points: np.ndarray, max_boxes: int, pad: float) -> np.ndarray:
    """Boxes covering ``points`` (m, gdim): a k-d split into at most ``max_boxes`` leaves.

    The leaf with the largest extent is split at its median along its longest side until there
    are ``max_boxes`` leaves or no leaf has two points.

    Returns:
        (nb, 2, gdim): lower and upper corners, grown by ``pad``; no box for no points.
    """
    gdim = points.shape[1]
    if points.shape[0] == 0:
        return np.zeros((0, 2, gdim))
    leaves = [np.arange(points.shape[0])]
    while len(leaves) < max_boxes:
        extents = [np.ptp(points[ix], axis=0).max() if ix.size > 1 else -1.0 for ix in leaves]
        k = int(np.argmax(extents))
        if extents[k] <= 0.0:
            break
        ix = leaves.pop(k)
        axis = int(np.argmax(np.ptp(points[ix], axis=0)))
        order = ix[np.argsort(points[ix, axis], kind="stable")]
        half = order.size // 2
        leaves += [order[:half], order[half:]]
    lo = np.array([points[ix].min(axis=0) for ix in leaves]) - pad
    hi = np.array([points[ix].max(axis=0) for ix in leaves]) + pad
    return np.stack([lo, hi], axis=1)


def exchange_facets(
    comm: MPI.Comm,
    points: np.ndarray,
    cell: basix.CellType,
    degree: int,
    x: np.ndarray,
    normals: np.ndarray,
    global_nodes: np.ndarray,
    owners: np.ndarray,
    global_facets: np.ndarray,
    radius: float,
    *,
    max_boxes: int = 16,
) -> Candidates:
    """Bring to every rank the primary facets near its points (collective).

    Args:
        comm: The mesh communicator.
        points: This rank's secondary points, current positions (m, gdim).
        cell: The primary facets' basix cell.
        degree: Their Lagrange degree.
        x: Current positions of the nodes of this rank's primary facets, (nf, nfd, gdim).
        normals: Their nodal normals, (nf, nfd, gdim).
        global_nodes: Their global node numbers, (nf, nfd).
        owners: Their owners, (nf, nfd).
        global_facets: The facets' global numbers, (nf,).
        radius: The search radius: a facet is sent to a rank if its bounding box comes within
            ``radius`` of one of the rank's points (through the boxes, so a few farther ones too).
        max_boxes: Boxes per rank.

    Returns:
        The candidate facets of this rank, ordered by source rank.
    """
    gdim = points.shape[1]
    boxes = point_boxes(points, max_boxes, radius)
    counts = np.array(comm.allgather(boxes.shape[0]), dtype=np.int64)
    flat = np.ascontiguousarray(boxes.reshape(-1))
    all_boxes = np.empty(int(counts.sum()) * 2 * gdim)
    width = 2 * gdim
    displs = np.concatenate([[0], np.cumsum(counts * width)[:-1]])
    comm.Allgatherv(flat, [all_boxes, (counts * width, displs)])
    all_boxes = all_boxes.reshape(-1, 2, gdim)
    box_rank = np.repeat(np.arange(comm.size, dtype=np.int32), counts)
    nf = x.shape[0]
    if nf and all_boxes.shape[0]:
        flo, fhi = x.min(axis=1), x.max(axis=1)
        meets = np.all(
            (flo[:, None, :] <= all_boxes[None, :, 1, :])
            & (fhi[:, None, :] >= all_boxes[None, :, 0, :]),
            axis=2,
        )  # (nf, nboxes)
        per_rank = np.zeros((nf, comm.size), dtype=bool)
        for r in range(comm.size):
            sel = box_rank == r
            if np.any(sel):
                per_rank[:, r] = meets[:, sel].any(axis=1)
        facet, rank = np.nonzero(per_rank)
    else:
        facet = rank = np.zeros(0, dtype=np.int64)
    got = exchange_rows(
        comm,
        rank.astype(np.int32),
        [
            x[facet],
            normals[facet],
            np.asarray(global_nodes, dtype=np.int64)[facet],
            np.asarray(owners, dtype=np.int32)[facet],
            np.asarray(global_facets, dtype=np.int64)[facet],
        ],
    )
    cx, cn, cg, co, cf = got.rows
    return Candidates(cell, degree, cx, cn, cg, co, cf, got.source, comm.rank)


@dataclasses.dataclass
class PointProjections:
    """The projection of every point on the candidate facets.

    Attributes:
        facet: Index of the facet in the candidates, -1 where the point has none, (m,).
        xi: Reference coordinates on it, (m, fdim) (0 where none).
        point: The projection, (m, gdim).
        normal: Unit smooth normal there, (m, gdim).
        distance: Signed distance along it (< 0: the point is behind the surface), (m,).
        gamma: Coefficient of the unnormalised normal (see :mod:`.projection`), (m,).
    """

    facet: np.ndarray
    xi: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    gamma: np.ndarray

    @property
    def found(self) -> np.ndarray:
        """Whether each point has a projection."""
        return self.facet >= 0


def near_pairs(
    points: np.ndarray, extent: np.ndarray, X: np.ndarray, Nn: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (point, facet) that may project on each other within ``radius``.

    A point ``x = y + gamma n~`` with ``y`` on facet ``f`` and ``|gamma n~| <= radius`` is, from
    the facet's centre ``c`` and mean normal ``n_f``, within the facet's in-plane extent plus
    ``radius`` times the sine of the largest angle of its nodal normals to ``n_f`` along ``n_f``'s
    plane, and within its out-of-plane extent plus ``radius`` along ``n_f``; ``extent`` grows
    both for objects of that size (a secondary facet's nodes around its centre).

    Args:
        points: Positions (m, gdim).
        extent: Size of the object at each point (0 for points), (m,).
        X: Facet nodes, (nc, nfd, gdim).
        Nn: Their nodal normals, (nc, nfd, gdim).
        radius: Largest normal distance.

    Returns:
        The point and facet indices of the candidate pairs (none without points or facets).
    """
    if points.shape[0] == 0 or X.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    c = X.mean(axis=1)
    nf = Nn.sum(axis=1)
    nf /= np.maximum(np.linalg.norm(nf, axis=1, keepdims=True), 1e-300)
    r = X - c[:, None, :]
    rn = np.einsum("fkd,fd->fk", r, nf)
    a = np.linalg.norm(r - rn[..., None] * nf[:, None, :], axis=-1).max(axis=1) * 1.1
    b = np.abs(rn).max(axis=1)
    tilt = Nn - np.einsum("fkd,fd->fk", Nn, nf)[..., None] * nf[:, None, :]
    dev = np.linalg.norm(tilt, axis=-1).max(axis=1)
    e = float(extent.max(initial=0.0))
    inplane = a + e + 1.5 * dev * (radius + b + e) + 1e-12 * (a + radius)
    normal = radius + b + e + 1e-12 * (a + radius)
    # every (point, centre) pair within the largest bound, as arrays (no list per point), in
    # the order of the points, then the facets
    near = cKDTree(points).sparse_distance_matrix(
        cKDTree(c), float(np.hypot(inplane, normal).max()), output_type="ndarray"
    )
    order = np.lexsort((near["j"], near["i"]))
    p, f = near["i"][order].astype(np.int64), near["j"][order].astype(np.int64)
    d = points[p] - c[f]
    dn = np.einsum("pd,pd->p", d, nf[f])
    dt = np.linalg.norm(d - dn[:, None] * nf[f], axis=1)
    grow = extent[p] - e  # the bounds above used the largest extent
    keep = (dt <= inplane[f] + grow * (1 + 1.5 * dev[f])) & (np.abs(dn) <= normal[f] + grow)
    return p[keep], f[keep]


def find_projections(
    points: np.ndarray,
    candidates: Candidates,
    radius: float,
    *,
    x: np.ndarray | None = None,
    normals: np.ndarray | None = None,
    inside_tol: float = 1e-10,
) -> PointProjections:
    """Project every point on the nearest candidate facet it projects onto (not collective).

    Args:
        points: Current positions of the points, (m, gdim).
        candidates: The facets (from :func:`exchange_facets`).
        radius: Largest ``|distance|`` kept.
        x: Current node positions of the candidates if they moved since the exchange (e.g. in a
            Newton iteration), (nc, nfd, gdim); default ``candidates.x``.
        normals: Their nodal normals likewise; default ``candidates.normals``.
        inside_tol: Tolerance (reference coordinates) of a projection lying on its facet.
    """
    m, gdim = points.shape
    fdim = gdim - 1
    X = candidates.x if x is None else x
    Nn = candidates.normals if normals is None else normals
    out = PointProjections(
        facet=np.full(m, -1, dtype=np.int64),
        xi=np.zeros((m, fdim)),
        point=np.zeros((m, gdim)),
        normal=np.zeros((m, gdim)),
        distance=np.full(m, np.inf),
        gamma=np.zeros(m),
    )
    nc = X.shape[0]
    if m == 0 or nc == 0:
        return out
    p, f = near_pairs(points, np.zeros(m), X, Nn, radius)
    if p.size == 0:
        return out
    pr = normal_projection(
        points[p], X[f], Nn[f], candidates.cell, candidates.degree, inside_tol=inside_tol
    )
    good = pr.inside & (np.abs(pr.distance) <= radius)
    p, f = p[good], f[good]
    idx = np.flatnonzero(good)
    # the nearest per point: sort by (point, |distance|) and take each point's first
    order = np.lexsort((np.abs(pr.distance[idx]), p))
    p, f, idx = p[order], f[order], idx[order]
    first = np.concatenate([[True], p[1:] != p[:-1]]) if p.size else np.zeros(0, dtype=bool)
    p, f, idx = p[first], f[first], idx[first]
    out.facet[p] = f
    out.xi[p] = pr.xi[idx]
    out.point[p] = pr.point[idx]
    out.normal[p] = pr.normal[idx]
    out.distance[p] = pr.distance[idx]
    out.gamma[p] = pr.gamma[idx]
    return out
