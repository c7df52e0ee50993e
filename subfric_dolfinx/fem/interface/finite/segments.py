"""Integration points on the overlap of secondary facets with the primary facets they face.

A secondary facet of a non-matching interface faces pieces of several primary facets. Integrals of a
secondary field against the primary's shape functions, ``int_secondary lambda(x) N_m(pi(x)) dA``
with ``pi`` the normal projection on the primary (:mod:`.projection`), are exact only if the
secondary facet is cut where ``pi`` crosses from one primary facet to the next (a Gauss rule across
the kink of ``N_m o pi`` makes an error of the order of a percent of the primary nodal forces on a 3
: 2 mesh, and a patch test then fails). This module makes the cut (``docs/model.md`` §11):

* The preimage of a primary vertex ``k`` is where the line ``x_k + s n_k`` (its nodal normal) meets
  the secondary facet; it is found by the same normal projection, of ``x_k`` on the secondary facet
  with the constant normal ``n_k``.
* 2-D: the preimages of a primary segment's two vertices bound an interval of the secondary facet's
  reference coordinate; clipped to ``[0, 1]``, it is exactly the part of the secondary facet that
  projects on that primary segment (the primary vertices' normals are shared by the neighbouring
  segments: the intervals tile the secondary facet).
* 3-D: the preimages of a primary facet's vertices make a polygon in the secondary facet's reference
  coordinates, clipped by the reference cell (Sutherland-Hodgman, all pairs at once) and cut into
  triangles from its first vertex. Exact for flat surfaces; on curved ones the preimage of a
  primary edge is a slightly curved line, replaced by its chord (as the auxiliary-plane segmentation
  of mortar methods does).

Every piece gets a Gauss rule (exact for ``N_s N_m`` products of flat facets), whose points are
projected on their primary facet.
"""

from __future__ import annotations

import dataclasses
from typing import Any, cast

import basix
import numpy as np

from .projection import (
    FacetProjection,
    facet_basis,
    normal_projection,
    parametric_normal,
    projection_jacobian,
    ray_start,
)
from .search import near_pairs

__all__ = [
    "DeferredRates",
    "Segments",
    "clip_to_reference",
    "overlap_points",
    "overlap_points_later",
]


@dataclasses.dataclass
class Segments:
    """Integration points of the overlaps of secondary facets with primary facets.

    Attributes:
        secondary: Secondary facet of each point (index into the secondary arrays given), (np,).
        primary: Primary facet of each point (index into the primary arrays given), (np,).
        xi_secondary: Reference coordinates on the secondary facet, (np, fdim).
        xi_primary: Reference coordinates of the point's projection on the primary facet.
        weight: Quadrature weight times the secondary facet's surface Jacobian (the points integrate
            over the secondary surface, current or reference, see :func:`overlap_points`), (np,).
        converged: Whether the projection on the primary facet was found.
        bounds: 2-D only (else ``None``): the ends ``(lo, hi)`` of the point's piece of its
            secondary facet (reference coordinate), (np, 2); the point is at
            ``lo + unit (hi - lo)``.
        bound_vertex: 2-D only: the primary facet's vertex (0 or 1) whose preimage makes each
            end, or -1 where the secondary facet's own end does, (np, 2).
        unit: 2-D only: the point's coordinate on its piece, in [0, 1], (np,).
        xi_rate: 3-D with ``rates`` only (else ``None``): the derivative of ``xi_secondary`` with
            respect to the secondary facet's nodes then the primary facet's (node-major, ``gdim``
            components each), the measure's nodes held, (np, fdim, (nfd_s + nfd_m) gdim).
        weight_rate: 3-D with ``rates`` only: the derivative of ``weight``, likewise,
            (np, (nfd_s + nfd_m) gdim).
    """

    secondary: np.ndarray
    primary: np.ndarray
    xi_secondary: np.ndarray
    xi_primary: np.ndarray
    weight: np.ndarray
    converged: np.ndarray
    bounds: np.ndarray | None = None
    bound_vertex: np.ndarray | None = None
    unit: np.ndarray | None = None
    xi_rate: np.ndarray | None = None
    weight_rate: np.ndarray | None = None

    @property
    def size(self) -> int:
        """Number of points."""
        return int(self.secondary.size)

    def take(self, keep: np.ndarray) -> Segments:
        """The points ``keep`` (a mask or indices) only."""
        values: list[Any] = [None if v is None else v[keep] for v in dataclasses.astuple(self)]
        return Segments(*values)


def _polygon_order(cell: basix.CellType) -> list[int]:
    """Vertex indices of a reference cell in cyclic order (basix's quadrilateral is a tensor)."""
    return [0, 1, 3, 2] if cell == basix.CellType.quadrilateral else [0, 1, 2]


_ON_PLANE = 1e-12  # reference coordinates: a preimage's round-off is far below


def _snap(d: np.ndarray) -> np.ndarray:
    """Signed distances to a clipping plane, zero within round-off of it."""
    return np.where(np.abs(d) <= _ON_PLANE, 0.0, d)


def _planes(cell: basix.CellType) -> list[tuple[np.ndarray, float]]:
    """The half-planes ``a . x >= b`` of a reference triangle or square."""
    planes = [(np.array([1.0, 0.0]), 0.0), (np.array([0.0, 1.0]), 0.0)]
    if cell == basix.CellType.triangle:
        planes.append((np.array([-1.0, -1.0]), -1.0))  # 1 - x - y >= 0
    else:
        planes += [(np.array([-1.0, 0.0]), -1.0), (np.array([0.0, -1.0]), -1.0)]
    return planes


def _beyond_a_plane(poly: np.ndarray, cell: basix.CellType) -> np.ndarray:
    """Whether each polygon's vertices are all beyond one half-plane of the reference cell.

    Beyond by more than the round-off :func:`clip_to_reference` snaps to the plane: such a
    polygon clips to nothing. ``poly`` (n, k, 2), every row's ``k`` vertices its own.
    """
    out = np.zeros(poly.shape[0], dtype=bool)
    for a, b in _planes(cell):
        out |= np.all(poly @ a - b < -_ON_PLANE, axis=1)
    return out


def clip_to_reference(
    poly: np.ndarray,
    count: np.ndarray,
    cell: basix.CellType,
    rates: np.ndarray | None = None,
) -> tuple[np.ndarray, ...]:
    """Clip polygons by a reference triangle or square (Sutherland-Hodgman, all at once).

    Args:
        poly: Vertices of each polygon in cyclic order, (n, kmax, 2) (rows beyond ``count``
            ignored).
        count: Vertices of each polygon, (n,).
        cell: ``triangle`` or ``quadrilateral``.
        rates: Derivatives of the vertices with respect to ``m`` parameters, (n, kmax, 2, m):
            carried through the clipping (a vertex cut on an edge moves along it and with its
            ends; the cell's corners do not move).

    Returns:
        The clipped polygons (n, kmax + number of half-planes, 2) and their vertex counts (fewer
        than 3: empty); with ``rates``, their derivatives too (n, kmax + half-planes, 2, m).
    """
    planes = _planes(cell)
    n, kmax = poly.shape[:2]
    size = kmax + len(planes)
    cur = np.zeros((n, size, 2))
    cur[:, :kmax] = poly
    cur_r = None
    if rates is not None:
        cur_r = np.zeros((n, size, 2, rates.shape[-1]))
        cur_r[:, :kmax] = rates
    cnt = count.astype(np.int64).copy()
    rows = np.arange(n)
    for a, b in planes:  # keep a . x >= b
        out = np.zeros_like(cur)
        out_r = None if cur_r is None else np.zeros_like(cur_r)
        oc = np.zeros(n, dtype=np.int64)
        for i in range(size):
            live = i < cnt
            if not np.any(live):
                break
            nxt = (i + 1) % np.maximum(cnt, 1)
            p = cur[:, i]
            q = cur[rows, nxt]
            # a vertex within round-off of the plane is on it: an edge along the plane (meshes
            # whose edges coincide) crosses nowhere, else its cut's rate is a ratio of round-offs
            dp, dq = _snap(p @ a - b), _snap(q @ a - b)
            keep_p = live & (dp >= 0)
            out[rows[keep_p], oc[keep_p]] = p[keep_p]
            if out_r is not None:
                assert cur_r is not None  # (out_r is made with it)
                out_r[rows[keep_p], oc[keep_p]] = cur_r[keep_p, i]
            oc += keep_p
            cross = live & ((dp >= 0) != (dq >= 0))
            den = np.where(cross, dp - dq, 1.0)
            t = np.where(cross, dp / den, 0.0)
            x = p + t[:, None] * (q - p)
            out[rows[cross], oc[cross]] = x[cross]
            if out_r is not None and np.any(cross):
                assert cur_r is not None  # (out_r is made with it)
                c = np.flatnonzero(cross)
                rp, rq = cur_r[c, i], cur_r[c, nxt[c]]  # (nc, 2, m)
                ddp, ddq = np.einsum("a,nam->nm", a, rp), np.einsum("a,nam->nm", a, rq)
                dt = (dp[c, None] * ddq - dq[c, None] * ddp) / den[c, None] ** 2
                out_r[c, oc[c]] = (
                    rp + t[c, None, None] * (rq - rp) + (q[c] - p[c])[:, :, None] * dt[:, None]
                )
            oc += cross
        cur, cnt, cur_r = out, oc, out_r
    return (cur, cnt) if cur_r is None else (cur, cnt, cur_r)


def _quadrature(cell: basix.CellType, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The Gauss rule of basix: its points and weights (basix annotates them ArrayLike)."""
    X, w = basix.make_quadrature(cell, degree)
    return cast(np.ndarray, X), cast(np.ndarray, w)


def overlap_points(
    secondary_x: np.ndarray,
    secondary_cell: basix.CellType,
    secondary_degree: int,
    primary_x: np.ndarray,
    primary_normals: np.ndarray,
    primary_cell: basix.CellType,
    primary_degree: int,
    radius: float,
    *,
    degree: int | None = None,
    secondary_measure_x: np.ndarray | None = None,
    rates: bool = False,
    normal_rates: bool = False,
) -> Segments:
    """Integration points of every secondary facet's overlap with the primary facets.

    Not collective. The steps: the candidate pairs (``_candidate_pairs``), the preimages of their
    primary vertices on the secondary facets (``_vertex_preimages``), the pieces of the secondary
    facets they bound with a Gauss rule on each (2-D ``_interval_pieces``, 3-D
    ``_polygon_pieces``), and the points weighed and projected on their primary facets
    (``_segment_points``).

    Args:
        secondary_x: Current positions of the secondary facets' nodes, (ns, nfd_s, gdim).
        secondary_cell: Their basix cell.
        secondary_degree: Their Lagrange degree.
        primary_x: Current positions of the primary facets' nodes (e.g. the candidates of
            :func:`.search.exchange_facets`), (nm, nfd_m, gdim).
        primary_normals: Their nodal normals, (nm, nfd_m, gdim).
        primary_cell: Their basix cell.
        primary_degree: Their Lagrange degree.
        radius: Largest distance between the surfaces at which a pair is considered.
        degree: Degree of the Gauss rule on each piece; default ``2 p`` (simplices) or ``4 p``
            (quadrilaterals, whose ``N_s N_m`` products are of degree ``2 p`` per direction).
        secondary_measure_x: Node positions whose surface Jacobian weighs the points, e.g. the
            reference ones, so that the pieces of a secondary facet sum to the measure its own
            quadrature uses (geometrically linear bodies); default ``secondary_x``.
        rates: 3-D: also the points' ``xi_rate`` and ``weight_rate`` (their change with the
            secondary and primary nodes, through the preimages, the clipping and the fan triangles;
            the nodal normals and ``secondary_measure_x``, which must be given, held). 2-D
            segments carry their ``bounds`` instead (:func:`.transfer.transfer_tangent`).
        normal_rates: 3-D with ``rates``: the rates also with the primary facet's nodal normals
            (``nfd_m`` more columns after the primary's nodes: the preimages move along them).
    """
    segments, later = overlap_points_later(
        secondary_x,
        secondary_cell,
        secondary_degree,
        primary_x,
        primary_normals,
        primary_cell,
        primary_degree,
        radius,
        degree=degree,
        secondary_measure_x=secondary_measure_x,
        rates=rates,
        normal_rates=normal_rates,
    )
    return segments if later is None else later.attach(segments)


def overlap_points_later(
    secondary_x: np.ndarray,
    secondary_cell: basix.CellType,
    secondary_degree: int,
    primary_x: np.ndarray,
    primary_normals: np.ndarray,
    primary_cell: basix.CellType,
    primary_degree: int,
    radius: float,
    *,
    degree: int | None = None,
    secondary_measure_x: np.ndarray | None = None,
    rates: bool = False,
    normal_rates: bool = False,
) -> tuple[Segments, DeferredRates | None]:
    """:func:`overlap_points` with the 3-D rates made later, when a tangent asks for them.

    The same arguments. Returns the points without their rates, and with ``rates`` in 3-D
    (points found) what makes them (:class:`DeferredRates`; ``None`` otherwise): a residual
    needs the points alone.
    """
    fdim = secondary_x.shape[2] - 1
    rates = bool(rates) and fdim == 2
    if rates and secondary_measure_x is None:
        raise ValueError(
            "overlap_points: rates need secondary_measure_x (the measure's nodes held)"
        )
    degree = _gauss_degree(secondary_cell, secondary_degree, primary_degree, degree)
    empty = _no_points(fdim), None
    if secondary_x.shape[0] == 0 or primary_x.shape[0] == 0:
        return empty
    si, mi, within = _candidate_pairs(secondary_x, primary_x, primary_normals, radius)
    if si.size == 0:
        return empty
    secondary = _Facets(secondary_x, secondary_cell, secondary_degree)
    primary = _Facets(primary_x, primary_cell, primary_degree)
    pre = _vertex_preimages(secondary, primary, primary_normals, si, mi, within)
    later = None
    if fdim == 1:
        pieces: _Pieces | None = _interval_pieces(pre, degree)
    else:
        nfd_m = primary_x.shape[1]
        rows = np.flatnonzero(~_beyond_a_plane(pre.xi, secondary.cell))
        pieces = _polygon_pieces(pre, rows, secondary, degree)
        if rates and pieces is not None:
            assert secondary_measure_x is not None  # (checked above)
            later = DeferredRates(
                pre, rows, secondary, nfd_m, degree, normal_rates, secondary_measure_x
            )
    if pieces is None or pieces.secondary.size == 0:
        return empty
    points = _segment_points(pieces, secondary, primary, primary_normals, secondary_measure_x)
    return points, later


@dataclasses.dataclass(frozen=True)
class DeferredRates:
    """What the 3-D segment points' rates are made from (:func:`overlap_points_later`).

    Calling it makes ``xi_rate`` and ``weight_rate`` of :class:`Segments` for every point the
    segments had when made (the same numbers ``overlap_points(..., rates=True)`` gives them).

    Attributes:
        pre: The preimages.
        rows: The facing pairs whose polygons were clipped.
        secondary: The secondary facets.
        nfd_m: The primary facets' node count.
        degree: The Gauss rule's degree on each piece.
        normal_rates: Whether the rates have the primary's nodal normals' columns.
        measure_x: The nodes whose surface Jacobian weighs the points.
    """

    pre: _Preimages
    rows: np.ndarray
    secondary: _Facets
    nfd_m: int
    degree: int
    normal_rates: bool
    measure_x: np.ndarray

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        """``xi_rate`` (np, fdim, m) and ``weight_rate`` (np, m) of every point."""
        pre, sec = self.pre, self.secondary
        poly_r = _preimage_rates(
            pre, sec.cell, sec.degree, self.nfd_m, self.normal_rates, self.rows
        )
        count = np.full(self.rows.size, len(pre.order))
        clipped, cnt, clipped_r = clip_to_reference(pre.xi[self.rows], count, sec.cell, poly_r)
        pieces = _fan_pieces(pre, self.rows, clipped, cnt, self.degree, clipped_r)
        assert pieces is not None and pieces.xi_rate is not None  # (the points' pieces again)
        assert pieces.weight_rate is not None  # (made with xi_rate)
        fdim = pieces.xi.shape[-1]
        m = pieces.xi_rate.shape[-1]
        xi_s = pieces.xi.reshape(-1, fdim)
        Yj = self.measure_x[np.repeat(pieces.secondary, pieces.xi.shape[1])]
        jac = _measure(sec.cell, sec.degree, xi_s, Yj)
        xi_rate = pieces.xi_rate.reshape(-1, fdim, m)
        grad = _measure_rate(sec.cell, sec.degree, xi_s, Yj)  # d jac / d xi, (np, fdim)
        weight_rate = pieces.weight_rate.reshape(-1, m) * jac[:, None] + pieces.weight.reshape(
            -1, 1
        ) * np.einsum("ma,mac->mc", grad, xi_rate)
        return xi_rate, weight_rate

    def attach(self, segments: Segments) -> Segments:
        """``segments`` (all the points made with this) with their rates."""
        xi_rate, weight_rate = self()
        return dataclasses.replace(segments, xi_rate=xi_rate, weight_rate=weight_rate)


@dataclasses.dataclass(frozen=True)
class _Facets:
    """One side's facets, as :func:`overlap_points` takes them.

    Attributes:
        x: Current positions of their nodes, (n, nfd, gdim).
        cell: Their basix cell.
        degree: Their Lagrange degree.
    """

    x: np.ndarray
    cell: basix.CellType
    degree: int


@dataclasses.dataclass(frozen=True)
class _Preimages:
    """The preimages of the candidate pairs' primary vertices on their secondary facets.

    A primary vertex is shared by the candidate facets around it: each distinct (secondary facet,
    vertex position, vertex normal) is projected once, in :attr:`unique`.

    Attributes:
        order: The primary facet's vertices (its local nodes) in cyclic order, (nv,).
        unique: The distinct projections (the vertex along its normal on the secondary facet).
        back: The row of :attr:`unique` of each candidate (pair, vertex), pair-major, (npair nv,).
        x: The distinct rows' vertex positions, (nu, gdim).
        normal: Their nodal normals, (nu, gdim).
        nodes: Their secondary facets' nodes, (nu, nfd_s, gdim).
        facing: Whether each candidate pair faces: its preimages all found, one at least within
            the search radius, (npair,).
        secondary: The secondary facet of each facing pair, (nf,).
        primary: Its primary facet, (nf,).
        xi: The preimages of each facing pair's vertices, in :attr:`order`, (nf, nv, fdim).
    """

    order: list[int]
    unique: FacetProjection
    back: np.ndarray
    x: np.ndarray
    normal: np.ndarray
    nodes: np.ndarray
    facing: np.ndarray
    secondary: np.ndarray
    primary: np.ndarray
    xi: np.ndarray


@dataclasses.dataclass(frozen=True)
class _Pieces:
    """The Gauss points of the pieces of the secondary facets, on the secondary facets.

    Attributes:
        secondary: The secondary facet of each piece, (npiece,).
        primary: The primary facet it faces, (npiece,).
        xi: The points' reference coordinates on the secondary facet, (npiece, nq, fdim).
        weight: Their weights (of the reference facet), (npiece, nq).
        bounds: 2-D only: the per-point arrays ``bounds``, ``bound_vertex`` and ``unit`` of
            :class:`Segments`; else empty.
        xi_rate: 3-D with rates only: the derivative of :attr:`xi`, (npiece, nq, fdim, m).
        weight_rate: 3-D with rates only: the derivative of :attr:`weight`, (npiece, nq, m).
    """

    secondary: np.ndarray
    primary: np.ndarray
    xi: np.ndarray
    weight: np.ndarray
    bounds: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    xi_rate: np.ndarray | None = None
    weight_rate: np.ndarray | None = None


def _gauss_degree(
    secondary_cell: basix.CellType, secondary_degree: int, primary_degree: int, degree: int | None
) -> int:
    """The Gauss rule's degree on each piece.

    ``degree`` if given, else ``2 p`` (simplices) or ``4 p`` (quadrilaterals), ``p`` the larger of
    the two sides' degrees.
    """
    if degree is not None:
        return degree
    p = max(secondary_degree, primary_degree)
    return 4 * p if secondary_cell == basix.CellType.quadrilateral else 2 * p


def _no_points(fdim: int) -> Segments:
    """No integration point (facets of dimension ``fdim``)."""
    return Segments(
        *(np.zeros(0, dtype=np.int64),) * 2,
        np.zeros((0, fdim)),
        np.zeros((0, fdim)),
        np.zeros(0),
        np.zeros(0, dtype=bool),
    )


def _candidate_pairs(
    secondary_x: np.ndarray, primary_x: np.ndarray, primary_normals: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidate pairs: the secondary facets whose centres are near primary facets.

    Returns:
        The pairs' secondary facets and primary facets, (npair,) each, and the distance within
        which a pair faces: ``radius`` plus round-off of its secondary facet's size, (npair,).
    """
    cs = secondary_x.mean(axis=1)
    rs = np.linalg.norm(secondary_x - cs[:, None], axis=-1).max(axis=1) * 1.1
    si, mi = near_pairs(cs, rs, primary_x, primary_normals, radius)
    return si, mi, radius + 1e-12 * rs[si]


def _vertex_preimages(
    secondary: _Facets,
    primary: _Facets,
    primary_normals: np.ndarray,
    si: np.ndarray,
    mi: np.ndarray,
    within: np.ndarray,
) -> _Preimages:
    """The preimages of the candidate pairs' primary vertices, along their nodal normals.

    Args:
        secondary: The secondary facets.
        primary: The primary facets.
        primary_normals: Their nodal normals, (nm, nfd_m, gdim).
        si: The candidate pairs' secondary facets, (npair,).
        mi: Their primary facets, (npair,).
        within: The distance within which each pair faces (:func:`_candidate_pairs`), (npair,).
    """
    gdim = secondary.x.shape[2]
    fdim = gdim - 1
    order = _polygon_order(primary.cell) if fdim == 2 else [0, 1]
    nv = len(order)
    xv = primary.x[mi][:, order].reshape(-1, gdim)
    nvv = primary_normals[mi][:, order].reshape(-1, gdim)
    nfd_s = secondary.x.shape[1]
    # each (secondary facet, vertex position and normal) once (row by row, the same numbers)
    sv = np.repeat(si, nv)
    _, first, back = np.unique(
        np.column_stack([sv.astype(float), xv, nvv]),
        axis=0,
        return_index=True,
        return_inverse=True,
    )
    back = back.reshape(-1)
    xu, nu, Ys = xv[first], nvv[first], secondary.x[sv[first]]
    # preimages may lie far outside a secondary facet much smaller than the primary's: start from
    # the line's intersection with the secondary vertices' line (plane), let Newton go anywhere
    unique = normal_projection(
        xu,
        Ys,
        np.repeat(nu[:, None, :], nfd_s, axis=1),
        secondary.cell,
        secondary.degree,
        xi0=ray_start(secondary.cell, xu, Ys, nu),
        margin=np.inf,
    )
    facing = unique.converged[back].reshape(-1, nv).all(axis=1) & (
        np.abs(unique.distance[back].reshape(-1, nv)) <= within[:, None]
    ).any(axis=1)
    return _Preimages(
        order=order,
        unique=unique,
        back=back,
        x=xu,
        normal=nu,
        nodes=Ys,
        facing=facing,
        secondary=si[facing],
        primary=mi[facing],
        xi=unique.xi[back].reshape(-1, nv, fdim)[facing],
    )


def _interval_pieces(pre: _Preimages, degree: int) -> _Pieces:
    """2-D: the interval between a primary segment's vertices' preimages, clipped to ``[0, 1]``.

    Each piece keeps its ends, and which primary vertex makes each (-1: the secondary facet's own
    end), for the transfer's tangent (:attr:`Segments.bounds`).
    """
    ends = pre.xi[:, :, 0]  # the two vertices' preimages
    v_lo, v_hi = np.argmin(ends, axis=1), np.argmax(ends, axis=1)
    rows = np.arange(ends.shape[0])
    lo = np.clip(ends[rows, v_lo], 0.0, 1.0)
    hi = np.clip(ends[rows, v_hi], 0.0, 1.0)
    vertex = np.stack(
        [
            np.where(ends[rows, v_lo] > 0.0, v_lo, -1),
            np.where(ends[rows, v_hi] < 1.0, v_hi, -1),
        ],
        axis=1,
    )
    keep = hi - lo > 1e-12
    lo, hi, vertex = lo[keep], hi[keep], vertex[keep]
    X, w = _quadrature(basix.CellType.interval, degree)
    nq = X.shape[0]
    return _Pieces(
        secondary=pre.secondary[keep],
        primary=pre.primary[keep],
        xi=(lo[:, None] + (hi - lo)[:, None] * X[None, :, 0])[..., None],  # (npair, nq, 1)
        weight=(hi - lo)[:, None] * w[None, :],
        bounds={
            "bounds": np.repeat(np.stack([lo, hi], axis=1), nq, axis=0),
            "bound_vertex": np.repeat(vertex, nq, axis=0),
            "unit": np.tile(X[:, 0], lo.size),
        },
    )


def _polygon_pieces(
    pre: _Preimages, rows: np.ndarray, secondary: _Facets, degree: int
) -> _Pieces | None:
    """3-D: the polygon of a primary facet's vertices' preimages, clipped by the reference cell.

    Args:
        pre: The preimages.
        rows: The facing pairs to clip (the others' polygons are beyond a side of the
            reference cell: they clip to nothing).
        secondary: The secondary facets.
        degree: The Gauss rule's degree.

    Returns:
        The fan triangles' points (:func:`_fan_pieces`), ``None`` if no polygon is left.
    """
    count = np.full(rows.size, len(pre.order))
    clipped, cnt = clip_to_reference(pre.xi[rows], count, secondary.cell)
    return _fan_pieces(pre, rows, clipped, cnt, degree)


def _fan_pieces(
    pre: _Preimages,
    rows: np.ndarray,
    clipped: np.ndarray,
    cnt: np.ndarray,
    degree: int,
    clipped_r: np.ndarray | None = None,
) -> _Pieces | None:
    """The clipped polygons cut into triangles from their first vertex, a Gauss rule on each.

    Args:
        pre: The preimages (the pairs of the polygons).
        rows: The facing pairs (of ``pre``) the polygons are of, (nf,).
        clipped: The clipped polygons, (nf, k, 2) (:func:`clip_to_reference`).
        cnt: Their vertex counts, (nf,).
        degree: The Gauss rule's degree.
        clipped_r: The vertices' rates, (nf, k, 2, m), if the points' rates are wanted.

    Returns:
        The points of the triangles of a positive area, ``None`` if there is none.
    """
    X, w = _quadrature(basix.CellType.triangle, degree)
    xs_l, ws_l, pair_l, xr_l, wr_l = [], [], [], [], []
    for k in range(1, clipped.shape[1] - 1):  # fan triangle (0, k, k + 1)
        has = cnt >= k + 2
        if not np.any(has):
            break
        v0, v1, v2 = clipped[has, 0], clipped[has, k], clipped[has, k + 1]
        J = np.stack([v1 - v0, v2 - v0], axis=-1)  # (n, 2, 2)
        det = np.linalg.det(J)
        area = np.abs(det)
        big = area > 1e-14
        idx = np.flatnonzero(has)[big]
        xs_l.append(v0[big, None, :] + np.einsum("nab,qb->nqa", J[big], X))
        ws_l.append(area[big, None] * w[None, :])
        pair_l.append(idx)
        if clipped_r is not None:
            r0, r1, r2 = (clipped_r[idx, j] for j in (0, k, k + 1))  # (n, 2, m)
            xr, wr = _triangle_rates(r0, r1, r2, J[big], det[big], X, w)
            xr_l.append(xr)
            wr_l.append(wr)
    if not pair_l:
        return None
    pair = rows[np.concatenate(pair_l)]
    return _Pieces(
        secondary=pre.secondary[pair],
        primary=pre.primary[pair],
        xi=np.concatenate(xs_l),
        weight=np.concatenate(ws_l),
        xi_rate=np.concatenate(xr_l) if clipped_r is not None else None,
        weight_rate=np.concatenate(wr_l) if clipped_r is not None else None,
    )


def _triangle_rates(
    r0: np.ndarray,
    r1: np.ndarray,
    r2: np.ndarray,
    J: np.ndarray,
    det: np.ndarray,
    X: np.ndarray,
    w: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The derivatives of a fan triangle's Gauss points and weights (reference facet).

    Args:
        r0: The derivatives of the triangle's first vertex, (n, 2, m).
        r1: Of its second vertex, likewise.
        r2: Of its third vertex, likewise.
        J: Its map's Jacobian (columns: its edges from the first vertex), (n, 2, 2).
        det: Its determinant, (n,).
        X: The Gauss points on the reference triangle, (nq, 2).
        w: Their weights, (nq,).

    Returns:
        The points' derivatives (n, nq, 2, m) and the weights' (n, nq, m).
    """
    dJ = np.stack([r1 - r0, r2 - r0], axis=2)  # (n, 2, 2, m)
    ddet = (
        dJ[:, 0, 0] * J[:, 1, 1, None]
        + J[:, 0, 0, None] * dJ[:, 1, 1]
        - dJ[:, 0, 1] * J[:, 1, 0, None]
        - J[:, 0, 1, None] * dJ[:, 1, 0]
    )
    xr = r0[:, None] + X[None, :, None, 0, None] * dJ[:, None, :, 0]
    xr += X[None, :, None, 1, None] * dJ[:, None, :, 1]
    wr = np.sign(det)[:, None, None] * ddet[:, None, :] * w[None, :, None]
    return xr, wr


def _segment_points(
    pieces: _Pieces,
    secondary: _Facets,
    primary: _Facets,
    primary_normals: np.ndarray,
    measure_x: np.ndarray | None,
) -> Segments:
    """The pieces' points, weighed by the secondary surface and projected on their primary facet.

    Args:
        pieces: The pieces and their Gauss points.
        secondary: The secondary facets.
        primary: The primary facets.
        primary_normals: Their nodal normals, (nm, nfd_m, gdim).
        measure_x: The nodes whose surface Jacobian weighs the points (default: the current
            ones).
    """
    fdim = pieces.xi.shape[-1]
    nq = pieces.xi.shape[1]
    si_q, mi_q = np.repeat(pieces.secondary, nq), np.repeat(pieces.primary, nq)
    xi_s = pieces.xi.reshape(-1, fdim)
    B = facet_basis(secondary.cell, secondary.degree, xi_s, 1)
    Ys = secondary.x[si_q]
    y = np.einsum("mk,mkd->md", B[0], Ys)
    Yj = Ys if measure_x is None else measure_x[si_q]
    jac = _measure(secondary.cell, secondary.degree, xi_s, Yj, B)
    ws = pieces.weight
    extra = pieces.bounds
    # start from the ray along the primary facet's mean normal through its vertex plane (exact
    # on flat facets)
    Ym, Nm = primary.x[mi_q], primary_normals[mi_q]
    start = ray_start(primary.cell, y, Ym, Nm.sum(axis=1))
    proj = normal_projection(y, Ym, Nm, primary.cell, primary.degree, xi0=start)
    return Segments(
        secondary=si_q,
        primary=mi_q,
        xi_secondary=xi_s,
        xi_primary=proj.xi,
        weight=ws.reshape(-1) * jac,
        converged=proj.converged,
        **extra,
    )


def _preimage_rates(
    pre: _Preimages,
    secondary_cell: basix.CellType,
    secondary_degree: int,
    nfd_m: int,
    normals: bool = False,
    rows: np.ndarray | None = None,
) -> np.ndarray:
    """Derivatives of the primary vertices' preimages on the secondary facets (3-D).

    ``d xi = A^-1 (dx_v - sum_k N_k dX_k)`` (:func:`.projection.projection_jacobian`, the
    vertex's normal held) for the distinct projections ``pre.unique`` (``pre.back`` maps the
    (pair, vertex) rows to them, ``pre.facing`` keeps the pairs). Returns (npair, nv, fdim, m),
    ``m`` the secondary facet's nodes then the primary facet's (``nfd_m``) [then, with
    ``normals``, the primary facet's nodal normals: ``d xi = -gamma A^-1 dn_v``], ``gdim``
    components each. ``rows``: those facing pairs only (indices among them; default all).
    """
    Ys, order, back = pre.nodes, pre.order, pre.back
    ok = np.flatnonzero(pre.facing)
    if rows is not None:
        ok = ok[rows]
    nfd_s, gdim = Ys.shape[1], Ys.shape[2]
    fdim, nv = gdim - 1, len(order)
    sel = back.reshape(-1, nv)[ok]  # the distinct projections of these pairs' vertices
    u, inv = np.unique(sel, return_inverse=True)
    Ainv, N = projection_jacobian(
        pre.x[u],
        Ys[u],
        np.repeat(pre.normal[u, None, :], nfd_s, axis=1),
        secondary_cell,
        secondary_degree,
        pre.unique.xi[u],
        pre.unique.gamma[u],
    )
    inv = inv.reshape(-1)
    D = Ainv[:, :fdim, :][inv].reshape(-1, nv, fdim, gdim)
    Nk = N[inv].reshape(-1, nv, nfd_s)
    R = np.zeros((D.shape[0], nv, fdim, nfd_s + nfd_m * (2 if normals else 1), gdim))
    R[:, :, :, :nfd_s, :] = -Nk[:, :, None, :, None] * D[:, :, :, None, :]
    gam = pre.unique.gamma[sel]
    for j, v in enumerate(order):
        R[:, j, :, nfd_s + v, :] += D[:, j]
        if normals:  # along the vertex's normal: d xi = D (-gamma dn_v)
            R[:, j, :, nfd_s + nfd_m + v, :] += -gam[:, j, None, None] * D[:, j]
    return R.reshape(D.shape[0], nv, fdim, -1)


def _measure(
    cell: basix.CellType,
    degree: int,
    xi: np.ndarray,
    Y: np.ndarray,
    B: np.ndarray | None = None,
) -> np.ndarray:
    """The surface Jacobian ``|p|`` of facets with nodes ``Y`` (m, nfd, gdim) at ``xi``, (m,).

    ``B``: the basis and its first derivatives there, if made already.
    """
    if B is None:
        B = facet_basis(cell, degree, xi, 1)
    dy = np.matmul(B[1:].transpose(1, 0, 2), Y).transpose(0, 2, 1)
    return cast(np.ndarray, np.linalg.norm(parametric_normal(dy), axis=1))


def _measure_rate(cell: basix.CellType, degree: int, xi: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``d |X_,1 x X_,2| / d xi`` of surface facets with nodes ``Y`` (m, nfd, 3), (m, 2)."""
    B = facet_basis(cell, degree, xi, 2)  # values, d1, d2, d11, d12, d22
    V = np.matmul(B[1:6].transpose(1, 0, 2), Y)  # (m, 5, 3)
    T, H = V[:, :2], V[:, 2:]  # d1, d2; d11, d12, d22
    n = np.cross(T[:, 0], T[:, 1])
    jac = np.linalg.norm(n, axis=1)
    out = np.zeros((xi.shape[0], 2))
    for a, (h1, h2) in enumerate(((0, 1), (1, 2))):  # d T_1 / d xi_a, d T_2 / d xi_a
        dn = np.cross(H[:, h1], T[:, 1]) + np.cross(T[:, 0], H[:, h2])
        out[:, a] = np.einsum("md,md->m", n, dn) / jac
    return out
