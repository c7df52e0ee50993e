"""Transfer of the secondary points' tractions to the primary nodes of a non-matching interface.

The friction law runs at the secondary facets' quadrature points (the internal variables stay with
these material points). The secondary nodes receive ``int N_s t dA`` by the facet's own rule, as
for a matching interface. The primary nodes must receive ``-int (N_m o pi) t dA`` of the same
traction field, and that integral is exact only on the segments of :mod:`.segments`, whose points
are not the law's points. The traction field is therefore the field ``lambda_h`` of the facet's
Lagrange space ``P_p`` whose moments are the secondary nodal forces,
``int N_k lambda_h dA = sum_q w_q N_k(q) t_q`` for every ``N_k`` (the integral by the facet's
mass matrix, :func:`facet_mass`), integrated exactly over the segments against the
primary's shape functions (``docs/model.md`` §11). So the primary nodal forces are ``-B t`` with,
per secondary facet ``s`` and primary facet ``m``,

    B_lq = sum_{segment points of (s, m)} w N_m,l(xi_m) L_q(xi_s),
    L_q(xi) = sum_kj N_k(xi) (M^-1)_kj w_q N_j(q),   M = int N N^T dA.

A uniform traction is then transmitted exactly (the non-matching patch test; ``sum_q L_q = 1``:
the mass matrix's rows sum to the rule's integrals of the basis) and so is every traction of ``P_p``
that the rule integrates exactly against ``N_k`` (Gauss points; P2 nodal points: a linear one);
on a matching interface ``B_lq = w_q N_l(q)``, today's element, with either rule. Where the
segments do not cover a secondary facet (it overhangs the primary surface), the share they miss goes
to the primary where each point projects (:func:`complete_transfer`). With a nodal
rule the ``L_q`` are the dual basis functions of mortar methods (``int L_q N_j = w_q
delta_qj``). The rule's own mass ``sum_q w_q N(q) N(q)^T`` in place of ``M`` is the same for
Gauss points on flat facets, but for nodal points it is the lumped mass: ``lambda_h`` was then
the interpolant of the point values and the primary got the consistent-mass forces, not the
secondary's (visibly off the small-sliding pressures on coinciding nodes in ``demos/hertz.py
--meshed-apart``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, cast

import basix
import numpy as np
from scipy import sparse

from ...kinematics import point_weight
from .projection import facet_basis, lagrange_element
from .segments import Segments, overlap_points_later
from .sides import Sides

if TYPE_CHECKING:
    from .contact import ContactGeometry
    from .points import SlidingPoints
    from .reach import Reach

__all__ = [
    "SegmentTransfer",
    "Transfer",
    "complete_transfer",
    "facet_mass",
    "l2_projector",
    "transfer_matrices",
    "transfer_tangent",
]


class SegmentTransfer:
    """The transfer part of a :class:`~.interface.SlidingInterface` (the module docstring).

    The secondary tractions go to the primary nodes through the segments of each secondary
    facet's reach.

    Args:
        sides: The interface's sides.
        points: Its law's points (their weights on the reference secondary surface).
        mode: The modelling mode. Axisymmetric: the field projected is the traction times
            ``2 pi r`` at the points (the reference ``r``, as the secondary weights), whose segment
            integrals are the primary's forces.

    Attributes:
        projector: ``P`` of :func:`l2_projector` for the secondary facets, (ns, nfd_s, nq): the
            primary forces by the segments are those the secondary nodes get by the rule (the exact
            mass; with a nodal rule the dual basis, where the rule's lumped one gave the
            consistent mass).
        in_tangent: Whether the tangent holds the transfer's change with the geometry, ``dB t``
            (2-D and 3-D): then the 2-D tangent is the residual's derivative, the 3-D one but
            for the frame's turn within an iteration
            (``tests/fem/interface/finite/test_finite_sliding_tangent.py``), and Newton converges
            quadratically at the end of a step (without it linearly). On by default: fewer
            Newton iterations per sliding step (``benchmarks/finite_sliding_newton.py``).
    """

    in_tangent = True

    def __init__(self, sides: Sides, points: SlidingPoints, mode: str | None) -> None:
        s = sides.secondary
        self.sides = sides
        self.secondary_X0 = sides.X0[s.nodes]  # the positions that weigh the segments' points
        self.weights = points.weights  # what the secondary nodes receive of each point's traction
        pw = point_weight(points.points, mode or "3d").reshape(points.facet_weights.shape)
        self.projector = (
            l2_projector(
                sides.Ns[0], points.facet_weights, facet_mass(s.cell, s.degree, self.secondary_X0)
            )
            * pw[:, None, :]
        )

    def pairs(
        self,
        Xs: np.ndarray,
        Ym: np.ndarray,
        normals: np.ndarray,
        reach: Reach,
        normal_rates: bool = False,
    ) -> tuple[Segments, Transfer, Callable[[], Segments]]:
        """The segments of the secondary facets within their reach and their transfer matrices.

        Args:
            Xs: Current positions of the secondary facets' nodes, (ns, nfd_s, gdim).
            Ym: Current positions of the reach's primary facets' nodes, (npf, nfd_m, gdim).
            normals: Their nodal normals (the step's or the iterate's), likewise.
            reach: The step's reach: a pair beyond a secondary facet's reach is left out.
            normal_rates: Whether the tangent takes the normals' change (the iterate's): the
                3-D segments' rates then have their columns too.

        Returns:
            The segments (3-D: without their rates), their transfer, and what gives the
            segments with their rates (:attr:`in_tangent`; made when called: a residual does
            not need them).
        """
        s, m = self.sides.secondary, self.sides.primary
        seg, later = overlap_points_later(
            Xs,
            s.cell,
            s.degree,
            Ym,
            normals,
            m.cell,
            m.degree,
            self.sides.radius,
            secondary_measure_x=self.secondary_X0,
            rates=self.in_tangent,
            normal_rates=normal_rates,
        )
        keep = seg.converged.copy()
        if seg.size:
            keep &= reach.within(seg.secondary, seg.primary)
        taken = seg.take(keep)

        def rated() -> Segments:
            return taken if later is None else later.attach(seg).take(keep)

        tr = transfer_matrices(taken, self.projector, s.cell, s.degree, m.cell, m.degree)
        return taken, tr, rated

    def complete(self, tr: Transfer, facet: np.ndarray, xi: np.ndarray) -> Transfer:
        """The transfer with the share the segments miss given where the points project.

        :func:`complete_transfer`: the primary's forces are the secondary's, whatever a secondary
        facet's overhang past the primary surface.

        Args:
            tr: The segments' transfer (:meth:`pairs`).
            facet: Each point's primary facet (index in the reach; -1: none), (npts,).
            xi: Its reference coordinates there, (npts, fdim).
        """
        m = self.sides.primary
        return complete_transfer(tr, self.weights, facet, xi, m.cell, m.degree)

    def tangent(
        self,
        segments: Segments,
        tractions: np.ndarray,
        Xs: np.ndarray,
        Ym: np.ndarray,
        normals: np.ndarray,
        with_normals: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The change of the primary forces with the geometry (:func:`transfer_tangent`)."""
        s, m = self.sides.secondary, self.sides.primary
        return transfer_tangent(
            segments,
            self.projector,
            tractions,
            Xs,
            self.secondary_X0,
            s.degree,
            Ym,
            normals,
            m.degree,
            s.cell,
            m.cell,
            with_normals=with_normals,
        )

    def complement_tangent(
        self,
        g: ContactGeometry,
        tractions: np.ndarray,
        normal_parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The complement's change with the geometry, the tractions held (tangent blocks).

        The complement of :func:`complete_transfer` puts ``-c_q N_l(xi_q) t_q`` on the primary
        facet point ``q`` projects on. Its change with the tractions is in the points' blocks
        (its pairs are the transfer's); here the rest: ``-c_q t_q dN_l/dxi dxi_q``, with ``dxi_q``
        the projection's (:func:`.projection.projection_jacobian`, the nodal normals held), and
        ``-N_l(xi_q) dc_q t_q`` with ``dc_q = -sum_l dB_lq`` the segments' change
        (:func:`transfer_tangent` of the point's traction alone, its rows summed). Only where
        the share is more than a round-off of the segments' sums (``1e-9 w_q``).

        Args:
            g: The iterate's geometry (its transfer completed).
            tractions: The points' tractions, global components, (ns, nq, gdim).
            normal_parts: With the iterate's normals, a list the change with the nodal normals
                is appended to: ``(row facets, normal facets, d(forces)/dn)`` per pair
                ((k,), (k,), (k, nfm * gdim, nfm * gdim)), chained with the normals' change by
                the assembly.

        Returns:
            Blocks ``(rows, cols, values)``: local (extended) node indices, dense values.
        """
        from .projection import projection_jacobian

        tr, sd = g.transfer, self.sides
        s, m = sd.secondary, sd.primary
        nq, gdim, fdim = sd.nq, sd.gdim, sd.gdim - 1
        if tr.complement == 0 or tr.points is None:
            return []
        assert tr.share is not None and tr.xi is not None  # (given with the points)
        nodes, pattern = g.reach.nodes, g.reach.holds
        big = np.abs(tr.share) > 1e-9 * self.weights[tr.points]
        pts, xi, c = tr.points[big], tr.xi[big], tr.share[big]
        if pts.size == 0:
            return []
        f_of, q_of = pts // nq, pts % nq
        fm = g.facet[pts]
        t = tractions[f_of, q_of]  # (k, gdim)
        out = []
        # -c t dN/dxi dxi, dxi = R (sum_k N_k(q) dX_k - sum_l N_l(xi) dY_l)
        x, Y, Nn = g.xq[pts], g.Ym[fm], g.normals[fm]
        B = facet_basis(m.cell, m.degree, xi, 1)
        nt = np.einsum("mk,mkd->md", B[0], Nn)
        gam = np.einsum("md,md->m", x - np.einsum("mk,mkd->md", B[0], Y), nt) / np.einsum(
            "md,md->m", nt, nt
        )
        Ainv, N = projection_jacobian(x, Y, Nn, m.cell, m.degree, xi, gam)
        R = Ainv[:, :fdim, :]
        C = np.concatenate([sd.Ns[0][q_of], -N], axis=1)  # (k, nfs + nfm)
        vals = -np.einsum("m,md,aml,mae,mj->mldje", c, t, B[1:], R, C)
        keep = pattern(fm, fm)
        k, nfm = int(np.count_nonzero(keep)), N.shape[1]
        if k:
            cols = np.concatenate([s.nodes[f_of], nodes[fm]], axis=1)[keep]
            out.append((nodes[fm[keep]], cols, vals[keep].reshape(k, nfm * gdim, -1)))
            if normal_parts is not None:  # dxi = R (-gamma sum_l N_l dn_l) besides
                vn = -np.einsum("m,md,aml,mae,mj->mldje", c, t, B[1:], R, -gam[:, None] * N)
                normal_parts.append((fm[keep], fm[keep], vn[keep].reshape(k, nfm * gdim, -1)))
        # -N_l(xi) dc_q t_q: the segments of the points' secondary facets, one point at a time
        rated = g.rated_segments
        seg = rated.take(np.isin(rated.secondary, f_of))
        if seg.size == 0:
            return out
        for q in np.unique(q_of):
            tq = np.zeros_like(tractions)
            tq[:, q] = tractions[:, q]
            rates = normal_parts is not None
            ps, pm, vb = self.tangent(seg, tq, g.Xs, g.Ym, g.normals, rates)
            if ps.size == 0:
                continue
            dct = vb.reshape(ps.size, nfm, gdim, -1).sum(axis=1)  # d(c_q) t_q, (np, gdim, nc)
            nxy = (s.nodes.shape[1] + nfm) * gdim
            dct, dcn = dct[:, :, :nxy], dct[:, :, nxy:]
            mine = np.flatnonzero(q_of == q)
            order = np.argsort(ps, kind="stable")
            lo = np.searchsorted(ps[order], f_of[mine], "left")
            n = np.searchsorted(ps[order], f_of[mine], "right") - lo
            i = np.repeat(mine, n)
            j = order[np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + np.repeat(lo, n)]
            held = pattern(fm[i], pm[j])
            i, j = i[held], j[held]
            if i.size == 0:
                continue
            v = -np.einsum("ml,mdc->mldc", N[i], dct[j]).reshape(i.size, nfm * gdim, -1)
            cols = np.concatenate([s.nodes[ps[j]], nodes[pm[j]]], axis=1)
            out.append((nodes[fm[i]], cols, v))
            if normal_parts is not None:
                vn = -np.einsum("ml,mdc->mldc", N[i], dcn[j]).reshape(i.size, nfm * gdim, -1)
                normal_parts.append((fm[i], pm[j], vn))
        return out


def l2_projector(N: np.ndarray, w: np.ndarray, mass: np.ndarray | None = None) -> np.ndarray:
    """The facet-wise projection of the points' values on the facet's Lagrange space.

    ``lambda_h = sum_j c_j N_j`` with ``int N_k lambda_h = sum_q w_q N_k(q) t_q`` for every
    ``N_k``: the field whose moments are the secondary nodal forces of the points' values, with the
    facets' mass matrices ``M = int N N^T`` (``mass``; the module's account). Each row of ``M``
    is made to sum to the rule's ``sum_q w_q N_k(q)`` by its diagonal, so that a uniform field
    is reproduced exactly also on curved facets, where neither integral is exact (on flat ones
    they agree). Without ``mass``: the rule's own ``sum_q w_q N(q) N(q)^T``, the same for a
    Gauss rule of degree ``2 p``, but for a nodal rule the lumped mass (the interpolant).

    Args:
        N: The facet basis at the quadrature points, (nq, nfd).
        w: Quadrature weights times surface Jacobian of each facet, (nf, nq).
        mass: The facets' mass matrices (:func:`facet_mass`), (nf, nfd, nfd).

    Returns:
        ``P`` (nf, nfd, nq): the coefficients of ``lambda_h`` in the basis are ``P t`` for point
        values ``t`` (nq,).

    Raises:
        ValueError: The rule does not determine a field of the space (fewer points than nodes,
            or a singular mass matrix).
    """
    nq, nfd = N.shape
    if nq < nfd:
        raise ValueError(f"{nq} quadrature points cannot determine a field of {nfd} nodes")
    rhs = np.einsum("fq,qj->fjq", w, N)
    if mass is None:
        M = np.einsum("fq,qk,qj->fkj", w, N, N)
    else:
        M = mass.copy()
        idx = np.arange(nfd)
        M[:, idx, idx] += rhs.sum(axis=2) - M.sum(axis=2)
    try:
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError as e:
        raise ValueError("the facet mass matrix of the quadrature rule is singular") from e


def facet_mass(cell: basix.CellType, degree: int, X: np.ndarray) -> np.ndarray:
    """The mass matrices ``int N N^T dA`` of facets with node positions ``X``.

    By the Gauss rule of degree ``2 p`` (the interface's ``"gauss"`` rule: exact on flat facets,
    whose surface Jacobian is constant).

    Args:
        cell: The facets' basix cell.
        degree: Their Lagrange degree.
        X: Their node positions, (nf, nfd, gdim).

    Returns:
        (nf, nfd, nfd).
    """
    from .projection import parametric_normal

    Xg, wg = basix.make_quadrature(cell, 2 * degree)
    Xg, wg = cast(np.ndarray, Xg), cast(np.ndarray, wg)  # (basix annotates ArrayLikes)
    B = facet_basis(cell, degree, Xg, 1)
    jac = np.linalg.norm(parametric_normal(np.einsum("aqk,fkd->fqda", B[1:], X)), axis=-1)
    return np.einsum("fq,qk,qj->fkj", jac * wg[None, :], B[0], B[0])


@dataclasses.dataclass
class Transfer:
    """Primary-side transfer matrices of secondary facets, one per (secondary, primary) pair.

    Attributes:
        secondary: Secondary facet of each pair, (npair,).
        primary: Primary facet of each pair, (npair,).
        B: ``B_lq`` of each pair, (npair, nfd_m, nq): the primary nodal force of the pair is
            ``-B t`` for the tractions ``t`` (nq, gdim) at the secondary facet's points.
        uncovered: The fraction of each secondary facet's measure the segments do not cover (the
            part beyond the primary surface), (ns,); ``None`` until :func:`complete_transfer`.
        points: The points of the pairs at the end that carry the complement of
            :func:`complete_transfer`, one pair each (``B`` nonzero in the point's column only),
            (nc,); ``None`` until then.
        xi: Those points' reference coordinates on their primary facets, (nc, fdim).
        share: Their shares ``c_q`` given so, (nc,).
    """

    secondary: np.ndarray
    primary: np.ndarray
    B: np.ndarray
    uncovered: np.ndarray | None = None
    points: np.ndarray | None = None
    xi: np.ndarray | None = None
    share: np.ndarray | None = None

    @property
    def complement(self) -> int:
        """The number of pairs at the end that carry the complement (0 before it)."""
        return 0 if self.points is None else int(self.points.size)


def complete_transfer(
    tr: Transfer,
    weights: np.ndarray,
    facet: np.ndarray,
    xi: np.ndarray,
    primary_cell: basix.CellType,
    primary_degree: int,
) -> Transfer:
    """The transfer with each point's missing share given to the primary where it projects.

    The secondary nodes receive ``w_q t_q`` of every point (``weights``); the segments give the
    primary ``sum_l B_lq t_q``, the integral of ``L_q`` over the part of the secondary facet they
    cover, which is ``w_q`` only where they cover the whole facet. Where a secondary facet overhangs
    the primary surface (or a quadrature's round-off leaves a little), the rest ``c_q = w_q -
    sum_l B_lq`` of a point that faces the primary goes to the primary facet it projects on, by
    the primary's basis there: ``B_lq += c_q N_l(xi_q)`` on that pair. Then the primary's forces
    are the secondary's to round-off, whatever the overhang (a point facing nothing is open: no
    traction). Not collective.

    Args:
        tr: The segments' transfer (:func:`transfer_matrices`).
        weights: The points' weights (the secondary's, ``2 pi r`` included), (ns * nq,).
        facet: Each point's primary facet (index in the primary arrays; -1: none), (ns * nq,).
        xi: Its reference coordinates there, (ns * nq, fdim).
        primary_cell: The primary facets' basix cell.
        primary_degree: Their Lagrange degree.

    Returns:
        ``tr`` with one more pair per point that faces the primary and whose share is not
        all given (:attr:`Transfer.complement` of them, at the end), and the uncovered fractions.
    """
    nq = tr.B.shape[2]
    ns = weights.size // nq
    w = weights.reshape(ns, nq)
    covered = np.zeros((ns, nq))
    if tr.secondary.size:
        np.add.at(covered, tr.secondary, tr.B.sum(axis=1))
    c = w - covered
    area = w.sum(axis=1)
    uncovered = np.divide(c.sum(axis=1), area, out=np.zeros(ns), where=area > 0)
    # a share below the round-off of the segments' sums is given already
    pts = np.flatnonzero((facet >= 0) & (np.abs(c).reshape(-1) > 1e-13 * np.abs(w).reshape(-1)))
    f_of, q_of = pts // nq, pts % nq
    share = c[f_of, q_of]
    N = facet_basis(primary_cell, primary_degree, xi[pts])[0]  # (np, nfd_m)
    Bc = np.zeros((pts.size, N.shape[1], nq))
    Bc[np.arange(pts.size), :, q_of] = share[:, None] * N
    return Transfer(
        np.concatenate([tr.secondary, f_of]),
        np.concatenate([tr.primary, facet[pts]]),
        np.concatenate([tr.B, Bc]),
        uncovered,
        pts,
        xi[pts].copy(),
        share,
    )


def transfer_matrices(
    segments: Segments,
    projector: np.ndarray,
    secondary_cell: basix.CellType,
    secondary_degree: int,
    primary_cell: basix.CellType,
    primary_degree: int,
) -> Transfer:
    """The matrices ``B`` of every pair of facets the segments join (not collective).

    Args:
        segments: The segment points (:func:`.segments.overlap_points`).
        projector: ``P`` of :func:`l2_projector` for the secondary facets, (ns, nfd_s, nq).
        secondary_cell: The secondary facets' basix cell.
        secondary_degree: Their Lagrange degree.
        primary_cell: The primary facets' basix cell.
        primary_degree: Their Lagrange degree.
    """
    nq = projector.shape[2]
    if segments.size == 0:
        nfd_m = lagrange_element(primary_cell, primary_degree).dim
        z = np.zeros(0, dtype=np.int64)
        return Transfer(z, z.copy(), np.zeros((0, nfd_m, nq)))
    key = segments.secondary.astype(np.int64) * (int(segments.primary.max()) + 1) + segments.primary
    pairs, pair_of = np.unique(key, return_inverse=True)
    Ns = facet_basis(secondary_cell, secondary_degree, segments.xi_secondary)[0]  # (np, nfd_s)
    Nm = facet_basis(primary_cell, primary_degree, segments.xi_primary)[0]  # (np, nfd_m)
    L = np.einsum("pk,pkq->pq", Ns, projector[segments.secondary])  # (np, nq)
    B = np.zeros((pairs.size, Nm.shape[1], nq))
    contrib = segments.weight[:, None, None] * Nm[:, :, None] * L[:, None, :]
    np.add.at(B, pair_of.reshape(-1), contrib)
    first = np.zeros(pairs.size, dtype=np.int64)
    first[pair_of.reshape(-1)[::-1]] = np.arange(segments.size)[::-1]
    return Transfer(segments.secondary[first], segments.primary[first], B)


def transfer_tangent(
    segments: Segments,
    projector: np.ndarray,
    tractions: np.ndarray,
    secondary_x: np.ndarray,
    secondary_ref_x: np.ndarray,
    secondary_degree: int,
    primary_x: np.ndarray,
    primary_normals: np.ndarray,
    primary_degree: int,
    secondary_cell: basix.CellType = basix.CellType.interval,
    primary_cell: basix.CellType = basix.CellType.interval,
    *,
    with_normals: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The change of the primary nodal forces ``-B t`` with the geometry, the tractions held.

    ``B`` (:func:`transfer_matrices`) moves with the nodes through the segments
    (:func:`.segments.overlap_points`): the pieces of the secondary facet (2-D: the preimages of the
    primary vertices on the secondary facet, along the vertices' fixed nodal normals; 3-D: the
    polygons of those preimages clipped by the secondary facet, cut into fan triangles), their
    points on the secondary facet and their projections on the primary facet (along the primary's
    smooth normal), and their weights. Each is differentiated through
    :func:`.projection.projection_jacobian` (the nodal normals held, or also their own
    change with ``with_normals``); an end where the secondary facet's own end cuts the piece does
    not move. 2-D reads the pieces'
    ``bounds``; 3-D the segments' ``xi_rate`` and ``weight_rate`` (``overlap_points(...,
    rates=True)``).

    Args:
        segments: The segment points, with their 2-D ``bounds``, ``bound_vertex`` and ``unit``,
            or their 3-D ``xi_rate`` and ``weight_rate``.
        projector: ``P`` of :func:`l2_projector`, (ns, nfd_s, nq).
        tractions: The tractions at the secondary facets' points, global components (ns, nq, gdim).
        secondary_x: Current positions of the secondary facets' nodes, (ns, nfd_s, gdim).
        secondary_ref_x: Their positions that weigh the points (``secondary_measure_x``), likewise.
        secondary_degree: The secondary facets' Lagrange degree.
        primary_x: Current positions of the primary facets' nodes, (nm, nfd_m, gdim).
        primary_normals: Their nodal normals, (nm, nfd_m, gdim).
        primary_degree: The primary facets' Lagrange degree.
        secondary_cell: The secondary facets' basix cell (3-D: triangle or quadrilateral).
        primary_cell: The primary facets' basix cell.
        with_normals: Also the change with the primary facet's nodal normals (the pieces'
            ends are the vertices' preimages along them, the points are projected along their
            interpolation): ``nfd_m`` more columns, ``d(-B t)/dn`` of the facet's nodes (3-D:
            the segments' rates must have them, ``overlap_points(..., normal_rates=True)``).

    Returns:
        Secondary facet and primary facet of each pair (the order of :func:`transfer_matrices`), and
        the blocks ``d(-B t)/dX`` (npair, nfd_m * gdim, (nfd_s + nfd_m [+ nfd_m]) * gdim): rows
        the primary facet's nodes, columns the secondary facet's nodes then the primary facet's
        (node-major) [then its nodal normals].
    """
    from .projection import projection_jacobian

    gdim = secondary_x.shape[2]
    fdim = gdim - 1
    nfs, nfm = secondary_x.shape[1], primary_x.shape[1]
    ncol = nfs + nfm + (nfm if with_normals else 0)
    if segments.size == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z.copy(), np.zeros((0, nfm * gdim, ncol * gdim))
    sl, ma = segments.secondary, segments.primary
    Xs, Ym, Nm = secondary_x[sl], primary_x[ma], primary_normals[ma]
    npt = sl.size
    if fdim == 1:
        dxs, dw = _piece_rates_2d(segments, Xs, Ym, Nm, secondary_ref_x, secondary_degree, ncol)
    else:
        if segments.xi_rate is None:
            raise ValueError("transfer_tangent: 3-D segments need their rates (rates=True)")
        assert segments.weight_rate is not None  # (made with xi_rate)
        # the rates may have the normals' columns the tangent does not take (at the end)
        dxs = segments.xi_rate.reshape(npt, fdim, -1, gdim)[:, :, :ncol]
        dw = segments.weight_rate.reshape(npt, -1, gdim)[:, :ncol]
        if dxs.shape[2] < ncol:
            raise ValueError("transfer_tangent: the segments' rates lack the normals' columns")
    w = segments.weight
    # the point's projection on the primary facet
    Bs = facet_basis(secondary_cell, secondary_degree, segments.xi_secondary, 1)  # values, d/dxi_a
    Bs_m = np.ascontiguousarray(Bs.transpose(1, 0, 2))  # (npt, 1 + fdim, nfs): per point
    y = np.matmul(Bs_m[:, :1], Xs)[:, 0]
    dy_xi = np.matmul(Bs_m[:, 1:], Xs).transpose(0, 2, 1)  # (npt, gdim, fdim)
    xim = segments.xi_primary
    Bm = facet_basis(primary_cell, primary_degree, xim, 1)
    nt = np.einsum("mk,mkd->md", Bm[0], Nm)
    gam = np.einsum("md,md->m", y - np.einsum("mk,mkd->md", Bm[0], Ym), nt) / np.einsum(
        "md,md->m", nt, nt
    )
    Ainv, _ = projection_jacobian(y, Ym, Nm, primary_cell, primary_degree, xim, gam)
    Dm = Ainv[:, :fdim, :]  # (npt, fdim, gdim)
    dxm = np.zeros((npt, fdim, ncol, gdim))
    dxm[:, :, :nfs, :] = Bs[0][:, None, :, None] * Dm[:, :, None, :]
    dxm[:, :, nfs : nfs + nfm, :] = -Bm[0][:, None, :, None] * Dm[:, :, None, :]
    if with_normals:  # A d(xi, gamma) = ... - sum_l N_l gamma dn_l
        dxm[:, :, nfs + nfm :, :] = -(gam[:, None] * Bm[0])[:, None, :, None] * Dm[:, :, None, :]
    dxm += np.matmul(np.matmul(Dm, dy_xi), dxs.reshape(npt, fdim, -1)).reshape(dxm.shape)
    # the traction field at the point and its rate along the secondary facet, (npt, 1 + fdim,
    # gdim): lam, then lam_,a
    lam_all = np.matmul(np.matmul(Bs_m, projector[sl]), tractions[sl])
    lam, dlam = lam_all[:, 0], lam_all[:, 1:]
    # d(-w N_l lam) = -(dw N_l lam + w N_l,a dxi_m,a lam + w N_l lam,a dxi_s,a): a sum of
    # 1 + 2 fdim outer products per point, one batched product (rows (l, d), columns (c, e))
    wB1 = (w[:, None, None] * Bm[1:].transpose(1, 2, 0))[:, :, None, :]  # (npt, nfm, 1, fdim)
    left = np.concatenate(
        [
            (Bm[0][:, :, None] * lam[:, None, :])[..., None],
            wB1 * lam[:, None, :, None],
            (w[:, None] * Bm[0])[:, :, None, None] * dlam.transpose(0, 2, 1)[:, None],
        ],
        axis=3,
    ).reshape(npt, nfm * gdim, 1 + 2 * fdim)
    right = np.concatenate([dw[:, None], dxm, dxs], axis=1).reshape(npt, 1 + 2 * fdim, -1)
    blocks = -np.matmul(left, right)  # (npt, nfm * gdim, ncol * gdim)
    key = sl.astype(np.int64) * (int(ma.max()) + 1) + ma
    pairs, pair_of = np.unique(key, return_inverse=True)
    pair_of = pair_of.reshape(-1)
    # the points' sum per pair (a sparse sum: np.add.at is slow on wide rows)
    S = sparse.csr_matrix((np.ones(npt), (pair_of, np.arange(npt))), shape=(pairs.size, npt))
    out = np.asarray(S @ blocks.reshape(npt, -1))
    first = np.zeros(pairs.size, dtype=np.int64)
    first[pair_of[::-1]] = np.arange(npt)[::-1]
    return sl[first], ma[first], out.reshape(pairs.size, nfm * gdim, ncol * gdim)


def _piece_rates_2d(
    segments: Segments,
    Xs: np.ndarray,
    Ym: np.ndarray,
    Nm: np.ndarray,
    secondary_ref_x: np.ndarray,
    secondary_degree: int,
    ncol: int,
) -> tuple[np.ndarray, np.ndarray]:
    """2-D: the points' ``d xi_s`` (npt, 1, ncol, gdim) and ``d w`` (npt, ncol, gdim).

    From the pieces' ends: the preimages of the primary vertices (``bound_vertex``), fixed where
    the secondary facet's own end cuts the piece.
    """
    from .projection import projection_jacobian

    cell = basix.CellType.interval
    npt, nfs, gdim = Xs.shape
    sl = segments.secondary
    bounds, bound_vertex, unit = segments.bounds, segments.bound_vertex, segments.unit
    assert bounds is not None and bound_vertex is not None and unit is not None  # (2-D's)
    # the pieces' ends: d(end) = c . dX over the columns (npt, 2, ncol, gdim)
    dend = np.zeros((npt, 2, ncol, gdim))
    for e in (0, 1):
        vert = bound_vertex[:, e]
        moving = np.flatnonzero(vert >= 0)
        if moving.size == 0:
            continue
        v = vert[moving]
        xv = Ym[moving, v]
        nv = np.repeat(Nm[moving, v][:, None, :], nfs, axis=1)
        xi = bounds[moving, e][:, None]
        Ns = facet_basis(cell, secondary_degree, xi)[0]
        gam = np.einsum("md,md->m", xv - np.einsum("mk,mkd->md", Ns, Xs[moving]), nv[:, 0])
        Ainv, Ns = projection_jacobian(xv, Xs[moving], nv, cell, secondary_degree, xi, gam)
        D = Ainv[:, 0, :]  # d xi = D . (dx_v - sum_k N_k dX_k)
        dend[moving, e, :nfs, :] = -Ns[:, :, None] * D[:, None, :]
        dend[moving, e, nfs + v, :] += D
        if ncol > nfs + Ym.shape[1]:  # along the vertex's normal: d xi = D . (-gamma dn_v)
            dend[moving, e, nfs + Ym.shape[1] + v, :] += -gam[:, None] * D
    dxs = (1.0 - unit)[:, None, None] * dend[:, 0] + unit[:, None, None] * dend[:, 1]
    span = bounds[:, 1] - bounds[:, 0]
    # the point's weight: span * w * |X_ref,xi|(xi_s)
    Bs = facet_basis(cell, secondary_degree, segments.xi_secondary, 2)  # values, d/dxi, d2/dxi2
    t = np.einsum("mk,mkd->md", Bs[1], secondary_ref_x[sl])
    t2 = np.einsum("mk,mkd->md", Bs[2], secondary_ref_x[sl])
    jac_rate = np.einsum("md,md->m", t, t2) / np.einsum("md,md->m", t, t)  # d ln|t| / dxi
    dw = segments.weight[:, None, None] * (
        (dend[:, 1] - dend[:, 0]) / span[:, None, None] + jac_rate[:, None, None] * dxs
    )
    return dxs[:, None], dw
