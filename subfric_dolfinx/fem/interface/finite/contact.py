"""The contact geometry of one Newton iterate of a finite-sliding interface, as one value.

At every iterate (:meth:`~.interface.SlidingInterface.update`) each secondary point is projected
along the primary's smooth normal on the facets of its reach in the current configuration (a point
may change facet inside a step), which gives its frame, its normal gap ``-gamma |n~|`` and its
convected slip from the material point it faced at the step's start (:class:`~.reach.StepStart`);
the tangential state is transported (:func:`.sliding.transport_matrix`, the identity in 2-D). The
tangent's pieces follow: the gap's derivative (:func:`.sliding.gap_operator`), the frame's turn
(2-D :func:`.sliding.frame_rate`, 3-D :class:`FrameTurn`), the nodal normals' change with the
primary's nodes (with the iterate's normals, :func:`.normals.normal_rates`), and the segments and
transfer
(:class:`~.transfer.SegmentTransfer`). :func:`contact_geometry` computes them all into one frozen
:class:`ContactGeometry`, which the return map, the forces, the tangent and the commit read.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from contextlib import AbstractContextManager as ContextManager
from typing import TYPE_CHECKING, Any

import numpy as np

from ..geometry import frames
from .normals import normal_rates
from .projection import facet_basis, normal_projection
from .search import near_pairs
from .segments import Segments
from .sides import Sides
from .sliding import (
    frame_jacobian,
    frame_rate,
    gap_operator,
    transport_angle_rates,
    transport_matrix,
)
from .transfer import Transfer

if TYPE_CHECKING:
    from .reach import Reach, ReachSearch, StepStart
    from .surface import ContactSurface
    from .transfer import SegmentTransfer

__all__ = [
    "ContactGeometry",
    "FrameTurn",
    "Projection",
    "contact_geometry",
    "current_positions",
    "project",
]


@dataclasses.dataclass(frozen=True)
class Projection:
    """Every point's projection on the nearest facet of its reach it lands on.

    Attributes:
        facet: The primary facet (index in the reach; -1: none), (npts,).
        xi: Its reference coordinates there, (npts, nt).
        normal: The smooth unit normal there, (npts, gdim).
        distance: The signed normal distance (``radius`` where a point faces nothing), (npts,).
        gamma: The distance along the interpolated (not unit) normal, (npts,).
    """

    facet: np.ndarray
    xi: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    gamma: np.ndarray


@dataclasses.dataclass(frozen=True)
class FrameTurn:
    """3-D: how each point's frame and its transport turn with the geometry (for the tangent).

    The frame ``Q = (e1, e2, -n)`` (:func:`.geometry.frames`) turns with the unit normal ``n``
    at the projection, which turns as the projection moves along the facet (the nodal normals
    held: ``dn = dn_dz dz``, ``dz = dx - sum_l N_l(xi) dy_l``) and with the nodal normals
    themselves (``dn = normal_map w``, ``w = sum_l N_l(xi) dn_l``). The transport of the
    tangential state (:func:`.sliding.transport_matrix`) is a rotation by an angle ``theta``
    that turns with ``n``, with the start point's tangent basis now (its facet's nodes) and with
    its normal now (its facet's nodal normals): :func:`.sliding.transport_angle_rates`. Zero
    where a point faces nothing (``theta``'s: where it does not move).

    Attributes:
        dn_dz: ``dn / dz``, (npts, 3, 3).
        dQ: ``dQ_ij / dn_k``, (npts, 3, 3, 3) (:func:`.sliding.frame_jacobian`).
        normal_map: ``dn / dw = (I - n n^T) / |n~|``, (npts, 3, 3).
        theta_n: ``d theta / d n``, (npts, 3).
        theta_old: ``d theta / dY_k`` for the nodes ``Y_k`` of the facet faced at the step's
            start, (npts, nfd_m, 3).
        theta_old_normal: ``d theta / dw_old``, ``w_old = sum_l N_l(xi_old) dn_l`` the change of
            the start facet's interpolated normal there, (npts, 3).
    """

    dn_dz: np.ndarray
    dQ: np.ndarray
    normal_map: np.ndarray
    theta_n: np.ndarray
    theta_old: np.ndarray
    theta_old_normal: np.ndarray

    def __post_init__(self) -> None:
        """Read-only arrays."""
        for f in dataclasses.fields(self):
            getattr(self, f.name).flags.writeable = False

    def theta_dz(self) -> np.ndarray:
        """``d theta / dz`` (npts, 3)."""
        return np.einsum("mk,mkc->mc", self.theta_n, self.dn_dz)


@dataclasses.dataclass(frozen=True)
class ContactGeometry:
    """The contact geometry of one iterate and the tangent's pieces (never changed once made).

    Attributes:
        reach: The :class:`~.reach.Reach` it was computed on (its facets' nodes and numbers).
        normals: The nodal normals of the reach's facets (the iterate's or the step's),
            (npf, nfd_m, gdim).
        xq: Current positions of the points on their contact surfaces (a point that faced the
            primary at the step's start: moved by its initial gap along its normal there,
            :func:`_at_contact_surfaces`), (npts, gdim).
        Xs: Current positions of the secondary facets' nodes, (ns, nfd_s, gdim).
        Ym: Current positions of the reach's primary facets' nodes, (npf, nfd_m, gdim).
        facet: Each point's primary facet (index in the reach; -1: none), (npts,).
        Q: Each point's frame, rows ``(e1, [e2,] -n)`` (an open point keeps its old one).
        gap: The law's gap in the frame (tangential: the total, normal: > 0 on penetration,
            the initial gap taken off), (npts, gdim).
        transport: The tangential state's transport of the step, (npts, nt, nt).
        slid_too_far: Points whose slip in the step exceeds the reach, (npts,).
        old_facet: The primary facet each moving point faced at the step's start (-1: none).
        N_old: The primary basis at that start point, (npts, nfd_m).
        segments: The segment points within each secondary facet's reach (3-D: without their
            rates; :attr:`rated_segments` with them).
        transfer: The primary-side transfer matrices of the segments.
        held_now: Whether the pattern couples each segment pair's primary facet with the facet
            point ``q`` of its secondary facet faces now, (nseg, nq).
        held_old: Likewise with the facet it faced at the step's start, (nseg, nq).
        gamma: Each point's ``gamma`` (the distance along ``n~``), (npts,).
        slip: Each point's convected slip of the step, (npts, gdim).
        iterate: Whether :attr:`normals` are the iterate's (then :attr:`normal_rates` holds
            their change with the primary's nodes).
        primary: The primary's facets' basix cell and degree.
        derivatives: Makes the tangent's pieces ``(G, Nm, turn, turn3)`` (the properties of
            these names), called once, when the tangent first asks for one of them.
        segment_rates: Makes :attr:`rated_segments`, called once, when the tangent first asks.
    """

    reach: Reach
    normals: np.ndarray
    xq: np.ndarray
    Xs: np.ndarray
    Ym: np.ndarray
    facet: np.ndarray
    Q: np.ndarray
    gap: np.ndarray
    transport: np.ndarray
    slid_too_far: np.ndarray
    old_facet: np.ndarray
    N_old: np.ndarray
    segments: Segments
    transfer: Transfer
    held_now: np.ndarray
    held_old: np.ndarray
    gamma: np.ndarray
    slip: np.ndarray
    iterate: bool
    primary: tuple[Any, int]
    derivatives: Callable[
        [], tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None, FrameTurn | None]
    ] = dataclasses.field(repr=False, compare=False)
    segment_rates: Callable[[], Segments] = dataclasses.field(repr=False, compare=False)

    def __post_init__(self) -> None:
        """Make the arrays read-only too: the value is passed on, never changed."""
        for f in dataclasses.fields(self):
            a = getattr(self, f.name)
            if isinstance(a, np.ndarray):
                a.flags.writeable = False

    @functools.cached_property
    def _derivatives(
        self,
    ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None, FrameTurn | None]:
        """``(G, Nm, turn, turn3)``, made when the tangent first asks (a residual does not)."""
        G, Nm, turn, turn3 = self.derivatives()
        for a in (G, Nm, *(turn or ())):
            a.flags.writeable = False
        return G, Nm, turn, turn3

    @property
    def G(self) -> np.ndarray:
        """The gap's derivative (:func:`.sliding.gap_operator`), (npts, gdim, gdim)."""
        return self._derivatives[0]

    @property
    def Nm(self) -> np.ndarray:
        """The primary basis at the projection, (npts, nfd_m)."""
        return self._derivatives[1]

    @property
    def turn(self) -> tuple[np.ndarray, np.ndarray] | None:
        """2-D: the frame's turn with the projection (``None`` in 3-D).

        The rate ``a`` and ``d xi / d x`` of each found point, ((nf, gdim), (nf, gdim)).
        """
        return self._derivatives[2]

    @property
    def turn3(self) -> FrameTurn | None:
        """3-D: the frame's and the transport's turn (:class:`FrameTurn`); ``None`` in 2-D."""
        return self._derivatives[3]

    @functools.cached_property
    def rated_segments(self) -> Segments:
        """:attr:`segments` with their 3-D rates (the transfer's tangent), made when first asked."""
        out = self.segment_rates()
        for f in dataclasses.fields(out):
            a = getattr(out, f.name)
            if isinstance(a, np.ndarray):
                a.flags.writeable = False
        return out

    @functools.cached_property
    def normal_rates(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The nodal normals' change with the primary's nodes (the tangent's).

        With the iterate's normals, :func:`.normals.normal_rates` of the reach's facets, made
        when the tangent first asks (a residual alone does not need them); ``None``: the normals
        are the step's (no derivative).
        """
        if not self.iterate:
            return None
        cell, degree = self.primary
        out = normal_rates(
            cell, degree, self.reach.nodes, self.reach.node_facets, self.Ym, self.normals
        )
        for a in out:
            a.flags.writeable = False
        return out

    @property
    def found(self) -> np.ndarray:
        """Whether each point faces the primary, (npts,)."""
        return self.facet >= 0

    def turn_stiffness(self, traction: np.ndarray) -> np.ndarray:
        """The forces' change ``d(Q^T f)`` with the frame's turn per ``dz``, (npts, gdim, gdim).

        2-D: ``d e1 = (a_y, -a_x) dxi``, ``d(-n) = -a dxi``; 3-D: ``dQ/dn dn_dz``
        (:class:`FrameTurn`); the tractions ``traction`` held.
        """
        K = np.zeros_like(self.G)
        if self.turn3 is not None:
            t3 = self.turn3
            return np.einsum("mi,mijk,mkl->mjl", traction, t3.dQ, t3.dn_dz)
        if self.turn is not None:
            pf = np.flatnonzero(self.found)
            a, r = self.turn
            de1 = np.stack([a[:, 1], -a[:, 0]], axis=1)
            f = traction[pf]
            turn = de1 * f[:, :1] - a * f[:, 1:]
            K[pf] = turn[:, :, None] * r[:, None, :]
        return K


def current_positions(
    sd: Sides, reach: Reach, u: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, primary facets of the reach and secondary facets' nodes at displacement ``u``."""
    s = sd.secondary
    Xs = sd.X0[s.nodes] + u[s.nodes]  # (ns, nfd, gdim)
    xq = np.einsum("qk,fkd->fqd", sd.Ns[0], Xs).reshape(-1, sd.gdim)
    return xq, reach.X0 + u[reach.nodes], Xs


def project(
    sd: Sides, reach: Reach, normals: np.ndarray, xq: np.ndarray, Ym: np.ndarray
) -> Projection:
    """Every point along the smooth normal on the nearest facet of its reach it lands on."""
    nq, nt, gdim, n = sd.nq, sd.nt, sd.gdim, sd.n_points
    # the pairs that may project on each other (:func:`.search.near_pairs`) within the reach
    pp, ff = near_pairs(xq, np.zeros(xq.shape[0]), Ym, normals, sd.radius)
    keep = reach.within(pp // nq, ff)
    pp, ff = pp[keep], ff[keep]
    m = sd.primary
    pr = normal_projection(xq[pp], Ym[ff], normals[ff], m.cell, m.degree)
    good = pr.inside & (np.abs(pr.distance) <= sd.radius)
    idx = np.flatnonzero(good)
    idx = idx[np.lexsort((np.abs(pr.distance[idx]), pp[idx]))]
    first = np.ones(idx.size, dtype=bool)
    first[1:] = pp[idx][1:] != pp[idx][:-1]
    idx = idx[first]
    p = pp[idx]
    out = Projection(
        facet=np.full(n, -1, dtype=np.int64),
        xi=np.zeros((n, nt)),
        normal=np.zeros((n, gdim)),
        # a point facing nothing is open: beyond the radius on the outer side (a distance
        # of -radius made it penetrate by the radius: pressed where it left the primary)
        distance=np.full(n, sd.radius),
        gamma=np.zeros(n),
    )
    out.facet[p] = ff[idx]
    out.xi[p] = pr.xi[idx]
    out.normal[p] = pr.normal[idx]
    out.distance[p] = pr.distance[idx]
    out.gamma[p] = pr.gamma[idx]
    return out


def contact_geometry(
    sd: Sides,
    search: ReachSearch,
    start: StepStart,
    ut_old: np.ndarray,
    u: np.ndarray,
    transfer: SegmentTransfer,
    timed: Callable[[str], ContextManager],
    normals: np.ndarray,
    iterate: bool = False,
    g0: np.ndarray | None = None,
) -> tuple[ContactGeometry, dict[str, float]]:
    """The contact geometry at the displacement ``u`` (not collective).

    Args:
        sd: The sides.
        search: The search part: the step's reach and nodal normals; it records the primary
            facet pairs the tangent needs beyond its pattern.
        start: The points' projections at the step's start.
        ut_old: The points' committed total tangential gaps, (npts, nt).
        u: The displacement at the local nodes of the reach's index map, (n, gdim).
        transfer: The transfer part (the segments and ``B``).
        timed: A context manager per timer name (the interface's timings).
        normals: The nodal normals of the reach's facets: the step's (held) or the iterate's.
        iterate: Whether ``normals`` are the iterate's: then the geometry holds their
            change with the primary's nodes (:func:`.normals.normal_rates`) for the tangent.
        g0: The points' initial gaps, (npts,) (``None``: none). A point that faced the primary
            at the step's start is measured from its contact surface, its position moved by its
            initial gap along its normal there (:func:`_at_contact_surfaces`).

    Returns:
        The geometry, and the wall times of its projections and of its segments (the cost
        tables; never in tests).
    """
    from ...timing import TIMER_PROJECTION

    reach = search.reach
    assert reach is not None  # (begin_step searched)
    t0 = time.perf_counter()
    xq, Ym, Xs = current_positions(sd, reach, u)
    with timed(TIMER_PROJECTION):
        pj = project(sd, reach, normals, xq, Ym)
        xq, pj, left = _at_contact_surfaces(sd, reach, start, normals, xq, Ym, pj, g0)
    found = pj.facet >= 0
    seconds = {"projection": time.perf_counter() - t0}
    Q = _frames(start.Q, pj.normal, found)
    gap = np.zeros((sd.n_points, sd.gdim))
    gap[:, sd.nt] = -pj.distance
    # a distance within the coordinates' round-off is a closed gap (independent meshes of one
    # surface meet at +-1e-17, which would tell contact from separation by chance)
    gap[np.abs(gap[:, sd.nt]) <= 1e-12 * sd.h, sd.nt] = 0.0
    gap[:, sd.nt] -= left
    moving = found & (start.facet >= 0)
    ds, T, N_old, theta_rates = _slip(sd, start, pj, Q, Ym, normals, moving)
    slid_too_far = np.linalg.norm(ds, axis=1) > sd.reach
    gap[:, : sd.nt] = np.einsum("mab,mb->ma", T, ut_old) + np.einsum(
        "mad,md->ma", Q[:, : sd.nt, :], ds
    )
    t1 = time.perf_counter()

    def derivatives() -> tuple[
        np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None, FrameTurn | None
    ]:
        theta = theta_rates() if theta_rates is not None else None
        return _gap_derivative(sd, pj, Q, xq, Ym, normals, ds, moving, theta)

    old_facet = np.where(moving, start.facet, -1)
    with timed(TIMER_PROJECTION):
        segments, tr, segment_rates = transfer.pairs(Xs, Ym, normals, reach, iterate)
        tr = transfer.complete(tr, pj.facet, pj.xi)
        held_now, held_old = _pattern_hold(sd, search, tr, pj.facet, old_facet, slid_too_far)
    seconds["segments"] = time.perf_counter() - t1
    geometry = ContactGeometry(
        reach=reach,
        normals=normals,
        xq=xq,
        Xs=Xs,
        Ym=Ym,
        facet=pj.facet,
        Q=Q,
        gap=gap,
        transport=T,
        slid_too_far=slid_too_far,
        old_facet=old_facet,
        N_old=N_old,
        segments=segments,
        transfer=tr,
        held_now=held_now,
        held_old=held_old,
        gamma=pj.gamma,
        slip=ds,
        iterate=iterate,
        primary=(sd.primary.cell, sd.primary.degree),
        derivatives=derivatives,
        segment_rates=segment_rates,
    )
    return geometry, seconds


def _at_contact_surfaces(
    sd: Sides,
    reach: Reach,
    start: StepStart,
    normals: np.ndarray,
    xq: np.ndarray,
    Ym: np.ndarray,
    pj: Projection,
    g0: np.ndarray | None,
) -> tuple[np.ndarray, Projection, np.ndarray]:
    """The points on their contact surfaces, their projections, and the initial gaps left.

    The initial gap ``g0`` stands for a surface the mesh does not hold: the secondary's contact
    surface is its facets moved by ``g0`` away from the primary. A point that faced the primary
    at the step's start is projected from there, its position moved by ``g0`` along its normal
    at the start (held during the step: no derivative): a closed point is then at the primary
    surface, and the primary's normals turning within the step move its projection by its
    penetration times their turn, not by its initial gap times it (a slip the bodies do not
    make). At the step's start the projection is the point's own (moved along its own
    normal), the normal gap its own minus ``g0``. Elsewhere (the point faced nothing at the
    start, or its moved position faces nothing) the point's own projection, ``g0`` subtracted
    from its normal gap.

    Returns:
        The positions projected (npts, gdim), the projections, and the initial gap still to
        subtract from each point's normal gap (npts,).
    """
    if g0 is None or not np.any(g0):
        return xq, pj, np.zeros(sd.n_points) if g0 is None else g0
    moved = (start.facet >= 0) & (g0 != 0.0)
    left = g0.copy()
    if not np.any(moved):
        return xq, pj, left
    xs = xq.copy()
    xs[moved] -= g0[moved, None] * start.Q[moved, sd.nt, :]  # + g0 n at the start
    pm = project(sd, reach, normals, xs, Ym)
    use = moved & (pm.facet >= 0)
    xs[~use] = xq[~use]
    left[use] = 0.0
    pick = {}
    for f in dataclasses.fields(Projection):
        a, b = getattr(pj, f.name).copy(), getattr(pm, f.name)
        a[use] = b[use]
        pick[f.name] = a
    return xs, Projection(**pick), left


def _frames(Q_start: np.ndarray, normal: np.ndarray, found: np.ndarray) -> np.ndarray:
    """The frames at the projections; an open point keeps its frame of the step's start."""
    Q = Q_start.copy()
    Q[found] = frames(normal[found])
    unset = ~found & (np.abs(Q).sum(axis=(1, 2)) == 0)
    if np.any(unset):
        Q[unset] = np.eye(Q.shape[-1])[None]
    return Q


def _slip(
    sd: Sides,
    start: StepStart,
    pj: Projection,
    Q: np.ndarray,
    Ym: np.ndarray,
    normals: np.ndarray,
    moving: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Callable[[], tuple[np.ndarray, ...]] | None]:
    """The convected slip of the step and the tangential state's transport.

    The slip of a ``moving`` point (facing the primary now and at the step's start) is its
    projection now minus the material point of the primary it faced at the start, where that
    point is now; 3-D: the transport carries the tangential state from the start's frame to this
    one (:func:`.sliding.transport_matrix`).

    Returns:
        The slip (npts, gdim), the transport (npts, nt, nt), the primary basis at the start
        point (npts, nfd_m) and, 3-D, what makes the transport angle's rates when the tangent
        asks (:class:`FrameTurn`'s ``theta_n``, ``theta_old``, ``theta_old_normal``; ``None``
        in 2-D).
    """
    m, n, nt = sd.primary, sd.n_points, sd.nt
    N_old = np.zeros((n, Ym.shape[1]))
    ds = np.zeros((n, sd.gdim))
    T = np.broadcast_to(np.eye(nt), (n, nt, nt)).copy()
    theta = None
    if nt == 2:
        nfm = Ym.shape[1]
        theta = tuple(np.zeros(s) for s in ((n, 3), (n, nfm, 3), (n, 3)))
    if not np.any(moving):
        return ds, T, N_old, (lambda: theta) if theta is not None else None
    pm = np.flatnonzero(moving)
    old = start.facet
    B_old = facet_basis(m.cell, m.degree, start.xi[pm], 1)
    N_old[pm] = B_old[0]
    Yo = Ym[old[pm]]
    y_old_now = np.einsum("mk,mkd->md", B_old[0], Yo)
    B_new = facet_basis(m.cell, m.degree, pj.xi[pm], 0)
    y_new = np.einsum("mk,mkd->md", B_new[0], Ym[pj.facet[pm]])
    ds[pm] = y_new - y_old_now
    if theta is not None:  # 3-D
        tan_now = np.einsum("amk,mkd->mda", B_old[1:], Yo)
        n_now = np.einsum("mk,mkd->md", B_old[0], normals[old[pm]])
        size_now = np.linalg.norm(n_now, axis=1)
        n_now /= size_now[:, None]
        n_new = -Q[pm, nt, :]
        T[pm] = transport_matrix(start.Q[pm], Q[pm], start.tangents[pm], tan_now, n_now)
        rates = theta

        def theta_rates() -> tuple[np.ndarray, ...]:
            th_n, th_t, th_nn = transport_angle_rates(
                start.Q[pm], start.tangents[pm], tan_now, n_now, n_new
            )
            rates[0][pm] = th_n
            # tangents now: y_,a = sum_k dN_k/dxi_a Y_k of the start facet
            rates[1][pm] = np.einsum("mda,amk->mkd", th_t, B_old[1:])
            P_now = np.eye(3)[None] - np.einsum("ma,mb->mab", n_now, n_now)
            rates[2][pm] = np.einsum("mk,mkc->mc", th_nn, P_now) / size_now[:, None]
            return rates

        return ds, T, N_old, theta_rates
    return ds, T, N_old, None


def _gap_derivative(
    sd: Sides,
    pj: Projection,
    Q: np.ndarray,
    xq: np.ndarray,
    Ym: np.ndarray,
    normals: np.ndarray,
    ds: np.ndarray,
    moving: np.ndarray,
    theta: tuple[np.ndarray, ...] | None,
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None, FrameTurn | None]:
    """The gap's derivative ``G``, the primary basis at the projections and the frame's turn.

    The frame turns with the projection: in the slip ``Q_t . ds`` (here, in ``G``) and in the
    forces ``Q^T f`` (:meth:`ContactGeometry.turn_stiffness`). 2-D: ``d e1 = (a_y, -a_x)
    dxi``; 3-D: :class:`FrameTurn` (with the transport angle's rates ``theta`` of
    :func:`_slip`).
    """
    m, n, gdim, nt = sd.primary, sd.n_points, sd.gdim, sd.nt
    pf = np.flatnonzero(pj.facet >= 0)
    G = np.zeros((n, gdim, gdim))
    Nm = np.zeros((n, Ym.shape[1]))
    if pf.size == 0:
        return G, Nm, None, _frame_turn(n, Ym.shape[1], pf, theta) if gdim == 3 else None
    f = pj.facet[pf]
    Gp, Nb, R = gap_operator(
        xq[pf], Ym[f], normals[f], m.cell, m.degree, pj.xi[pf], pj.gamma[pf], Q[pf]
    )
    G[pf], Nm[pf] = Gp, Nb
    # no slip measured where the point faced nothing at the step's start
    G[~moving, :nt, :] = 0.0
    if gdim != 2:
        t3 = _frame_turn(n, Ym.shape[1], pf, theta, normals[f], m, pj, R)
        for b in range(nt):  # d(e_b) . ds
            G[pf, b, :] += np.einsum("md,mdk,mkc->mc", ds[pf], t3.dQ[pf, b], t3.dn_dz[pf])
        return G, Nm, None, t3
    a, r = frame_rate(normals[f], m.cell, m.degree, pj.xi[pf]), R[:, 0, :]
    de1 = np.stack([a[:, 1], -a[:, 0]], axis=1)
    G[pf, 0, :] += np.einsum("md,md->m", de1, ds[pf])[:, None] * r
    return G, Nm, (a, r), None


def _frame_turn(
    n: int,
    nfd: int,
    pf: np.ndarray,
    theta: tuple[np.ndarray, ...] | None,
    Nn: np.ndarray | None = None,
    m: ContactSurface | None = None,
    pj: Projection | None = None,
    R: np.ndarray | None = None,
) -> FrameTurn:
    """3-D: the :class:`FrameTurn` of the ``n`` points.

    ``pf``: the points found, ``Nn`` the nodal normals of their facets, ``R`` the projection's
    ``dxi`` rows; ``theta``: the transport angle's rates of :func:`_slip`.
    """
    assert theta is not None  # (3-D: made by _slip)
    dn_dz, dQ, nmap = np.zeros((n, 3, 3)), np.zeros((n, 3, 3, 3)), np.zeros((n, 3, 3))
    if pf.size:
        assert m is not None and pj is not None and Nn is not None and R is not None
        B = facet_basis(m.cell, m.degree, pj.xi[pf], 1)
        nt_ = np.einsum("mk,mkd->md", B[0], Nn)
        size = np.linalg.norm(nt_, axis=1)
        nu = nt_ / size[:, None]
        P = (np.eye(3)[None] - np.einsum("ma,mb->mab", nu, nu)) / size[:, None, None]
        dnt = np.einsum("amk,mkd->mda", B[1:], Nn)  # (m, 3, 2)
        dn_dz[pf] = np.einsum("mde,mea,mac->mdc", P, dnt, R)
        dQ[pf] = frame_jacobian(pj.normal[pf])
        nmap[pf] = P
    return FrameTurn(dn_dz, dQ, nmap, *theta)


def _pattern_hold(
    sd: Sides,
    search: ReachSearch,
    tr: Transfer,
    facet: np.ndarray,
    old_facet: np.ndarray,
    slid_too_far: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The pattern's hold on this iterate's segment pairs; the pairs beyond it are recorded.

    The primary rows of a segment facet ``a`` of a secondary facet take the columns of the
    projection facets of its points (now and at the step's start) and of its other segment facets;
    the pattern holds the pairs of one reach that are near each other (:func:`.reach._couplings`).
    A pair beyond it is left out of the tangent (never a write outside the pattern), counted in
    the search's ``pattern_misses``, and its next step rebuilds the layout with it (unless its
    point slid farther than the reach: that step is cut anyway).

    Returns:
        For every segment pair of ``tr`` and point ``q`` of its secondary facet, whether the pattern
        couples the pair's primary facet with the facet the point faces now (``facet``) and
        faced at the step's start (``old_facet``), False where it faces none; (nseg, nq) each.
    """
    from scipy import sparse

    reach, nq = search.reach, sd.nq
    assert reach is not None  # (begin_step searched)
    nseg = tr.secondary.size
    if nseg == 0:
        return np.zeros((0, nq), dtype=bool), np.zeros((0, nq), dtype=bool)
    p = (tr.secondary[:, None] * nq + np.arange(nq)[None, :]).ravel()
    a = np.repeat(tr.primary, nq)
    now, old = facet[p], old_facet[p]
    held_now, held_old = np.zeros(p.size, dtype=bool), np.zeros(p.size, dtype=bool)
    held_now[now >= 0] = reach.holds(a[now >= 0], now[now >= 0])
    held_old[old >= 0] = reach.holds(a[old >= 0], old[old >= 0])
    live = (facet[p] >= 0) & ~slid_too_far[p]
    moved = live & (old >= 0)
    npf = max(reach.facets.size, 1)
    T = sparse.csr_matrix(
        (np.ones(nseg), (tr.secondary, tr.primary)), shape=(sd.secondary.size, npf)
    )
    TT = (T.T @ T).tocoo()  # segment facets of one secondary facet with each other
    ta, tb = TT.row.astype(np.int64), TT.col.astype(np.int64)
    a = np.concatenate([a[live], a[moved], ta])
    b = np.concatenate([now[live], old[moved], tb])
    bad = ~np.concatenate([held_now[live], held_old[moved], reach.holds(ta, tb)])
    if np.any(bad):
        search.record_misses(a[bad], b[bad])
    return held_now.reshape(nseg, nq), held_old.reshape(nseg, nq)
