"""Forces and tangent of a finite-sliding interface (the assembly part of its interface).

The secondary nodes receive ``int N_s t`` by the secondary facets' rule, the primary nodes ``-B t``
of the segment transfer (:mod:`.transfer`). The tangent is assembled as dense blocks, one per point
(secondary rows) and one per point and primary facet of its secondary facet's segments (primary
rows), whose columns are the point's secondary facet nodes and its primary facet's nodes:
``d t = Q^T D G (sum_k N_k du_k - sum_l N_l(xi) du_l)`` with ``G`` the gap's derivative
(:func:`.sliding.gap_operator`). The part through the iterate's nodal normals, which
depend on the nodes of every facet around them, is summed per node as a product of sparse
operators (:class:`_NormalChain`) rather than expanded in dense blocks per point. Everything of
the iterate comes in one :class:`~.contact.ContactGeometry`.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from ....constitutive import FrictionLaw
from ..base import NewtonStart, stiffen_separated
from .contact import ContactGeometry
from .points import SlidingPoints
from .sides import Sides
from .transfer import SegmentTransfer

__all__ = ["Block", "SlidingAssembly"]

#: A dense tangent block: rows and columns (local nodes of the extended map) and its values.
Block = tuple[np.ndarray, np.ndarray, np.ndarray]


class SlidingAssembly:
    """The assembly part of a :class:`~.interface.SlidingInterface`: its forces and tangent.

    Args:
        sides: The interface's sides.
        points: Its law's points (their weights).
        transfer: Its transfer part (the primary side and the transfer's change).
    """

    def __init__(self, sides: Sides, points: SlidingPoints, transfer: SegmentTransfer) -> None:
        self.sides = sides
        self.points = points
        self.transfer = transfer

    @staticmethod
    def global_tractions(g: ContactGeometry, traction: np.ndarray) -> np.ndarray:
        """The points' tractions in global components, ``Q^T f``, (npts, gdim)."""
        return np.einsum("mji,mj->mi", g.Q, traction)

    def add_forces(self, local: np.ndarray, g: ContactGeometry, traction: np.ndarray) -> None:
        """Add the forces of the tractions ``traction`` to the local values ``local``."""
        sd = self.sides
        s, nq, gdim = sd.secondary, sd.nq, sd.gdim
        tg = self.global_tractions(g, traction).reshape(s.size, nq, gdim)
        w = self.points.weights.reshape(s.size, nq)
        b = local.reshape(-1, sd.bs)
        Rs = np.einsum("fq,qk,fqd->fkd", w, sd.Ns[0], tg)
        np.add.at(b[:, :gdim], s.nodes.ravel(), Rs.reshape(-1, gdim))
        tr = g.transfer
        if tr.secondary.size:
            Rm = np.einsum("plq,pqd->pld", tr.B, tg[tr.secondary])
            np.add.at(b[:, :gdim], g.reach.nodes[tr.primary].ravel(), -Rm.reshape(-1, gdim))

    def add_round_off(self, local: np.ndarray, g: ContactGeometry, tangent: np.ndarray) -> None:
        """Add, per dof, the size of the forces' round-off over ``EPS`` to ``local``.

        The gap is a difference of positions, so its round-off is ``EPS |x|``, not ``EPS |u|``:
        the forces carry ``EPS |D| |x|`` (``D`` the law's ``tangent``), which the convergence
        test's floor must know (:class:`~subfric_dolfinx.fem.convergence.ScaledConvergence`).
        """
        sd = self.sides
        s, nq, gdim, bs = sd.secondary, sd.nq, sd.gdim, sd.bs
        w = self.points.weights.reshape(s.size, nq)
        D = np.abs(tangent).reshape(-1, gdim * gdim).max(axis=1, initial=0.0)
        m = (D * (np.linalg.norm(g.xq, axis=1) + sd.h)).reshape(s.size, nq)
        b = local.reshape(-1, bs)
        Rs = np.einsum("fq,qk,fq->fk", w, np.abs(sd.Ns[0]), m)
        np.add.at(b, s.nodes.ravel(), np.repeat(Rs.reshape(-1, 1), bs, axis=1))
        tr = g.transfer
        if tr.secondary.size:
            Rm = np.einsum("plq,pq->pl", np.abs(tr.B), m[tr.secondary])
            np.add.at(b, g.reach.nodes[tr.primary].ravel(), np.repeat(Rm.reshape(-1, 1), bs, 1))

    def law_tangent(
        self,
        tangent: np.ndarray,
        law: FrictionLaw,
        separated_stiffness: float = 0.0,
        start: NewtonStart | None = None,
        start_normal: np.ndarray | None = None,
    ) -> np.ndarray:
        """The law's tangents of the points as this Jacobian takes them, (npts, gdim, gdim).

        Args:
            tangent: The return map's consistent tangents.
            law: The law (its contact stiffness).
            separated_stiffness: Points without stiffness get this fraction of the law's contact
                stiffness (:func:`~..base.stiffen_separated`).
            start: The first Newton iteration of a step: where the loading program turns, only
                the normal traction's change with the normal gap is kept (:func:`_frictionless`:
                the first iterate lets the interface slide instead of shearing the bodies on
                the stick tangent of a zero slip increment); where the stepper extrapolates,
                points without stiffness that were in contact at the step's start get their
                normal stiffness there (``start_normal``: an extrapolated start that opens a few
                points by a round-off of the base's moving indentation would otherwise let them
                go in the first Newton step). The geometric terms are kept.
            start_normal: ``d f_n / d g_n`` of every point at the step's first evaluation.
        """
        gdim, nt = self.sides.gdim, self.sides.nt
        D = stiffen_separated(tangent, law, separated_stiffness).reshape(-1, gdim, gdim)
        if start is not None and start.turns:
            D = _frictionless(D, nt)
        if start is not None and start.extrapolating and start_normal is not None:
            D = _kept_in_contact(D, start_normal, nt)
        return D

    def blocks(
        self, g: ContactGeometry, D: np.ndarray, traction: np.ndarray
    ) -> tuple[list[Block], sparse.csr_matrix | None]:
        """The tangent: dense blocks, and the part through the iterate's nodal normals.

        Args:
            g: The iterate's geometry.
            D: The law's tangents as this Jacobian takes them (:meth:`law_tangent`).
            traction: The points' tractions (the frame's turn and the transfer's change).

        Returns:
            Blocks ``(rows, cols, values)`` (local (extended) node indices, dense values), and
            with the iterate's normals their chain (:class:`_NormalChain`): a sparse matrix over
            the local dofs of the extended map (``None`` with the step's normals).
        """
        sd = self.sides
        s, nq, gdim, nt = sd.secondary, sd.nq, sd.gdim, sd.nt
        found, nodes = g.found, g.reach.nodes
        # Q^T D G + the frame's turn, (npts, gdim, gdim)
        M = np.einsum("mai,mab,mbj->mij", g.Q, D, g.G) + g.turn_stiffness(traction)
        spin = None
        if g.turn3 is not None:  # 3-D: + the transport's turn Q^T h dtheta/dz
            spin = _transport_spin(g, D, traction)
            M += np.einsum("mi,mc->mic", spin, g.turn3.theta_dz())
        pts = np.flatnonzero(found)
        f_of, q_of = pts // nq, pts % nq
        cols = np.concatenate([s.nodes[f_of], nodes[g.facet[pts]]], axis=1)
        C = np.concatenate([sd.Ns[0][q_of], -g.Nm[pts]], axis=1)  # (np, nfs + nfm)
        out = self._point_blocks(g, pts, cols, C, M[pts], g.held_now)
        chain = None
        if g.normal_rates is not None:  # the iterate's nodal normals move with the nodes
            chain = _NormalChain(g, s.nodes, self.points.weights, sd.Ns[0])
            Mw = _normal_sensitivity(g, pts, D, traction, M, spin)
            chain.add_points(pts, g.facet[pts], g.Nm[pts], Mw)
            mv = np.flatnonzero(found & (g.old_facet >= 0))
            if spin is not None and mv.size:  # the transport's turn with the start's normal
                assert g.turn3 is not None  # (3-D)
                Mo = np.einsum("mi,mc->mic", spin[mv], g.turn3.theta_old_normal[mv])
                chain.add_points(mv, g.old_facet[mv], g.N_old[mv], Mo)
        # the convected slip's own primary nodes: d(Q_t ds) holds Q_t (N(xi) dY - N(xi_0) dY_0)
        # besides the projection's move (in G): the primary stretched between the two points
        mv = np.flatnonzero(found & (g.old_facet >= 0))
        if mv.size:
            E = g.Q[mv].copy()
            E[:, nt, :] = 0.0
            Mt = np.einsum("mai,mab,mbj->mij", g.Q[mv], D[mv], E)
            fm, fo = g.facet[mv], g.old_facet[mv]
            out += self._point_blocks(g, mv, nodes[fm], g.Nm[mv], Mt, g.held_now)
            out += self._point_blocks(g, mv, nodes[fo], -g.N_old[mv], Mt, g.held_old)
            if spin is not None:  # the transport's turn with the start point's tangents now
                assert g.turn3 is not None  # (3-D)
                E = g.turn3.theta_old[mv][:, :, None, :]
                out += self._matrix_blocks(g, mv, nodes[fo], E, spin[mv][:, :, None], fo)
        if self.transfer.in_tangent:  # the transfer's change with the geometry
            tg = self.global_tractions(g, traction).reshape(s.size, nq, gdim)
            rates = g.normal_rates is not None
            ps, pm, vb = self.transfer.tangent(g.rated_segments, tg, g.Xs, g.Ym, g.normals, rates)
            held = g.reach.holds(pm, pm)  # (a, a): in the pattern unless pattern_margin < 0
            ps, pm, vb = ps[held], pm[held], vb[held]
            nxy = (s.nodes.shape[1] + nodes.shape[1]) * gdim
            if ps.size:
                cols = np.concatenate([s.nodes[ps], nodes[pm]], 1)
                out.append((nodes[pm], cols, np.ascontiguousarray(vb[:, :, :nxy])))
            if chain is not None and ps.size:
                chain.add_forces(pm, pm, vb[:, :, nxy:])
            normal_parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = (
                [] if rates else None
            )
            out += self.transfer.complement_tangent(g, tg, normal_parts)  # where it overhangs
            for rf, nf, vn in normal_parts or []:
                assert chain is not None  # (with the iterate's normals)
                chain.add_forces(rf, nf, vn)
        return out, None if chain is None else chain.matrix()

    def _matrix_blocks(
        self,
        g: ContactGeometry,
        pts: np.ndarray,
        cols: np.ndarray,
        E: np.ndarray,
        M: np.ndarray,
        col_facet: np.ndarray,
    ) -> list[Block]:
        """Blocks of ``d t_p = M_p sum_j E_pj dX_j`` with matrix coefficients ``E`` (np, nc, 2, 2).

        As :meth:`_point_blocks`; the columns' facet ``col_facet`` (per point) may be outside the
        point's secondary facet's reach, whose secondary rows are then left out, and a segment
        pair's primary rows are left out where the pattern does not couple its primary facet
        with it.
        """
        sd = self.sides
        s, nq, gdim = sd.secondary, sd.nq, sd.gdim
        nodes = g.reach.nodes
        nfs, nfm = s.nodes.shape[1], nodes.shape[1]
        f_of, q_of = pts // nq, pts % nq
        ncol = cols.shape[1] * gdim
        ME = np.einsum("pax,pjxc->pajc", M, E)  # (two operands: a C loop, not a nested one)
        wN = self.points.weights[pts, None] * sd.Ns[0][q_of]
        vs = wN[:, :, None, None, None] * ME[:, None]
        mine = g.reach.within(f_of, col_facet)
        out = [(s.nodes[f_of[mine]], cols[mine], vs[mine].reshape(-1, nfs * gdim, ncol))]
        tr = g.transfer
        if tr.secondary.size:
            where = np.full(sd.n_points, -1, dtype=np.int64)
            where[pts] = np.arange(pts.size)
            pair, qq = np.nonzero(where.reshape(s.size, nq)[tr.secondary] >= 0)
            at = where[tr.secondary[pair] * nq + qq]
            keep = g.reach.holds(tr.primary[pair], col_facet[at])
            pair, qq, at = pair[keep], qq[keep], at[keep]
            vm = -tr.B[pair, :, qq][:, :, None, None, None] * ME[at][:, None]
            out.append((nodes[tr.primary[pair]], cols[at], vm.reshape(pair.size, nfm * gdim, ncol)))
        return out

    def _point_blocks(
        self,
        g: ContactGeometry,
        pts: np.ndarray,
        cols: np.ndarray,
        C: np.ndarray,
        M: np.ndarray,
        held: np.ndarray,
    ) -> list[Block]:
        """Blocks of ``d t_p = M_p sum_j C_pj dX_j`` (global traction of the points ``pts``).

        Rows: the secondary facet's nodes (``w N_k(q)``) and the primary nodes of its segment pairs
        (``-B_lq``); columns ``cols`` (np, nc) with coefficients ``C`` (np, nc), which hold the
        nodes of one primary facet per point (and maybe the secondary facet's); ``M`` (np, gdim,
        gdim). ``held`` (nseg, nq): whether the pattern couples each segment pair's primary facet
        with the primary facet of point ``q``'s columns (the geometry's ``held_now`` for the
        facet it faces, ``held_old`` for the one it faced at the step's start); a segment pair's
        primary rows where it does not are left out.
        """
        sd = self.sides
        s, nq, gdim = sd.secondary, sd.nq, sd.gdim
        nodes = g.reach.nodes
        nfs, nfm = s.nodes.shape[1], nodes.shape[1]
        f_of, q_of = pts // nq, pts % nq
        ncol = cols.shape[1] * gdim
        CM = C[:, None, :, None] * M[:, :, None, :]  # (np, gdim, nc, gdim): C_j M
        wN = self.points.weights[pts][:, None] * sd.Ns[0][q_of]
        vs = wN[:, :, None, None, None] * CM[:, None]
        out = [(s.nodes[f_of], cols, vs.reshape(pts.size, nfs * gdim, ncol))]
        tr = g.transfer
        if tr.secondary.size:
            # primary rows of pair (s, f'): -B_lq C_j M for every point q of s in pts
            where = np.full(sd.n_points, -1, dtype=np.int64)
            where[pts] = np.arange(pts.size)
            pair, qq = np.nonzero(where.reshape(s.size, nq)[tr.secondary] >= 0)
            at = where[tr.secondary[pair] * nq + qq]
            keep = held[pair, qq]
            pair, qq, at = pair[keep], qq[keep], at[keep]
            vm = -(tr.B[pair, :, qq][:, :, None, None, None] * CM[at][:, None])
            out.append((nodes[tr.primary[pair]], cols[at], vm.reshape(pair.size, nfm * gdim, ncol)))
        return out


class _NormalChain:
    """The tangent through the iterate's nodal normals, as a product of sparse operators.

    The forces change with the nodal normals ``n_k`` of the primary nodes, which change with the
    nodes of the facets around them (:func:`.normals.normal_rates`):
    ``dF = (F T + V) Dn dY``. ``T`` (points x nodal normals): each point's traction per normal,
    ``d t_p = M_p sum_l N_pl dn_l`` over the nodes ``l`` of a primary facet
    (:meth:`add_points`); ``F`` (dofs x points): where the points' tractions go, the secondary
    facet's nodes ``w N_k(q)`` and the primary nodes of its segment pairs ``-B_lq`` (as the
    forces); ``V`` (dofs x nodal normals): the transfer's own change with the normals
    (:meth:`add_forces`); ``Dn`` (nodal normals x nodes): the normals' change, once per node.
    Summed per node rather than expanded per point, the product's entries are inserted once.
    Those the pattern does not couple (:meth:`.reach.Reach.holds_nodes`) are left out.

    Args:
        g: The iterate's geometry (its :attr:`~.contact.ContactGeometry.normal_rates`).
        secondary: The secondary facets' nodes (local), (ns, nfd_s).
        weights: The points' weights, (npts,).
        Ns: The secondary facets' basis at their points, (nq, nfd_s).
    """

    def __init__(
        self, g: ContactGeometry, secondary: np.ndarray, weights: np.ndarray, Ns: np.ndarray
    ) -> None:
        self.g = g
        self.secondary = secondary
        self.weights = weights
        self.Ns = Ns
        self.gdim = g.Ym.shape[2]
        imap = g.reach.index_map
        self.n = imap.size_local + imap.num_ghosts  # local nodes of the extended map
        self._T: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._V: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add_points(self, pts: np.ndarray, facet: np.ndarray, N: np.ndarray, M: np.ndarray) -> None:
        """``d t_p = M_p sum_l N_pl dn_l``: the nodal normals of the primary facet ``facet_p``.

        Args:
            pts: The points, (np,).
            facet: Each one's primary facet (index in the reach), (np,).
            N: The primary basis there, (np, nfd_m).
            M: ``d t / d w`` per ``w = sum_l N_l dn_l``, global components, (np, gdim, gdim).
        """
        d = np.arange(self.gdim)
        rows = pts[:, None, None, None] * self.gdim + d[None, None, :, None]
        cols = self.g.reach.nodes[facet][:, :, None, None] * self.gdim + d[None, None, None, :]
        vals = N[:, :, None, None] * M[:, None, :, :]
        rows, cols = np.broadcast_arrays(rows, cols)
        self._T.append((rows.ravel(), cols.ravel(), vals.ravel()))

    def add_forces(self, rows: np.ndarray, normals: np.ndarray, values: np.ndarray) -> None:
        """The change of the forces on the nodes of the facets ``rows`` with the nodal normals.

        Args:
            rows: The row facets (index in the reach), (k,).
            normals: The facets whose nodal normals the columns are, (k,).
            values: ``d(forces)/dn``, (k, nfd_m * gdim, nfd_m * gdim), node-major.
        """
        nodes, gd = self.g.reach.nodes, self.gdim
        d = np.arange(gd)
        r = (nodes[rows][:, :, None] * gd + d).reshape(rows.size, -1)
        c = (nodes[normals][:, :, None] * gd + d).reshape(normals.size, -1)
        r, c = np.broadcast_arrays(r[:, :, None], c[:, None, :])
        self._V.append((r.ravel(), c.ravel(), values.ravel()))

    def _forces(self) -> sparse.csr_matrix:
        """``F``: the points' tractions to the nodal forces (dofs x points' components)."""
        g, gd, nq = self.g, self.gdim, self.Ns.shape[0]
        npts = self.weights.size
        d = np.arange(gd)
        # the secondary facets' nodes: w_p N_k(q_p)
        p = np.flatnonzero(g.found)
        sec = self.secondary[p // nq]  # (np, nfs)
        wN = self.weights[p, None] * self.Ns[p % nq]
        r = [(sec[:, :, None] * gd + d).ravel()]
        c = [np.broadcast_to((p[:, None, None] * gd + d), (*sec.shape, gd)).ravel()]
        v = [np.repeat(wN.ravel(), gd)]
        tr = g.transfer
        if tr.secondary.size:  # the primary nodes of the segment pairs: -B_lq
            rn = g.reach.nodes[tr.primary][:, :, None, None] * gd + d  # (npair, nfm, 1, gd)
            cp = (tr.secondary[:, None] * nq + np.arange(nq))[:, None, :, None] * gd + d
            rn, cp = np.broadcast_arrays(rn, cp)  # (npair, nfm, nq, gd)
            r.append(rn.ravel())
            c.append(cp.ravel())
            v.append(np.repeat(-tr.B.ravel(), gd))
        return sparse.csr_matrix(
            (np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
            shape=(self.n * gd, npts * gd),
        )

    def _rates(self) -> sparse.csr_matrix:
        """``Dn``: the nodal normals' change with the nodes (normals' x nodes' components)."""
        g, gd = self.g, self.gdim
        assert g.normal_rates is not None  # (with the iterate's normals)
        facets, Dn = g.normal_rates
        nodes = g.reach.nodes
        nfd = nodes.shape[1]
        # one (facet, slot) per node: its normal's rate is the same from every facet around it
        K, first = np.unique(nodes.ravel(), return_index=True)
        f, l_ = first // nfd, first % nfd
        fa = facets[f, l_]  # (nK, A)
        ok = fa >= 0
        k_of, a_of = np.nonzero(ok)
        d = np.arange(gd)
        r = K[k_of][:, None, None, None] * gd + d[None, None, :, None]  # (m, nfd, gd, gd)
        c = nodes[fa[k_of, a_of]][:, :, None, None] * gd + d[None, None, None, :]
        r, c = np.broadcast_arrays(r, c)
        v = Dn[f[k_of], l_[k_of], a_of]  # (m, nfd, gd, gd)
        return sparse.csr_matrix(
            (v.ravel(), (r.ravel(), c.ravel())), shape=(self.n * gd, self.n * gd)
        )

    def matrix(self) -> sparse.csr_matrix:
        """``(F T + V) Dn`` over the local dofs, the pattern's entries (canonical CSR)."""
        gd, n = self.gdim, self.n
        npts = self.weights.size
        Rn = sparse.csr_matrix((n * gd, n * gd))
        if self._T:
            r, c, v = (np.concatenate(a) for a in zip(*self._T, strict=True))
            T = sparse.csr_matrix((v, (r, c)), shape=(npts * gd, n * gd))
            Rn = self._forces() @ T
        if self._V:
            r, c, v = (np.concatenate(a) for a in zip(*self._V, strict=True))
            Rn = Rn + sparse.csr_matrix((v, (r, c)), shape=(n * gd, n * gd))
        out = (Rn @ self._rates()).tocoo()
        keep = self.g.reach.holds_nodes(out.row // gd, out.col // gd)
        return sparse.csr_matrix(
            (out.data[keep], (out.row[keep], out.col[keep])), shape=(n * gd, n * gd)
        )


_J = np.array([[0.0, 1.0], [-1.0, 0.0]])  # e1 = J n (2-D frames)
# the turn of a 3-D frame's tangential components by d theta: (v1, v2, vn) -> (-v2, v1, 0)
_SPIN = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


def _transport_spin(g: ContactGeometry, D: np.ndarray, traction: np.ndarray) -> np.ndarray:
    """3-D: ``d t / d theta`` (global) of the transport's rotation by ``theta``, (npts, 3).

    The committed state (total tangential gap and the law's tangential variables) is carried by
    the rotation ``T(theta)`` (:func:`.sliding.transport_matrix`); the law being isotropic in
    the tangent plane (``t(R g, R s) = R t(g, s)``), turning all of them by ``d theta`` turns
    the traction but for the step's own slip ``Q_t ds``, which does not turn:
    ``dt = (J f - D J (Q_t ds)) d theta`` in the frame, ``Q^T`` of it in global components.
    """
    local_slip = np.zeros_like(traction)
    local_slip[:, :2] = np.einsum("mad,md->ma", g.Q[:, :2, :], g.slip)
    h = np.einsum("ab,mb->ma", _SPIN, traction) - np.einsum("mab,bc,mc->ma", D, _SPIN, local_slip)
    return np.einsum("mai,ma->mi", g.Q, h)


def _normal_sensitivity(
    g: ContactGeometry,
    pts: np.ndarray,
    D: np.ndarray,
    traction: np.ndarray,
    M: np.ndarray,
    spin: np.ndarray | None,
) -> np.ndarray:
    """``d t`` (global) of the points ``pts`` per ``w = sum_l N_l(xi) dn_l``, (np, gdim, gdim).

    The projection moves as for ``dx = -gamma w`` (``M``: the tangent's per ``dz``); the
    normal gap changes by ``-gamma n . w`` besides; the frame turns by ``dn = (I - n n^T) w /
    |n~|``, in the slip ``Q_t . ds`` and in the forces ``Q^T f``, and 3-D in the transport
    (``spin``: :func:`_transport_spin`).
    """
    f0 = g.facet[pts]
    gam, ds, f = g.gamma[pts], g.slip[pts], traction[pts]
    if g.turn3 is not None:
        assert spin is not None  # (3-D)
        t3 = g.turn3
        P, dQ, n = t3.normal_map[pts], t3.dQ[pts], -g.Q[pts, 2, :]
        X = np.zeros((pts.size, 3, 3))
        X[:, :2, :] = np.einsum("pd,pbdk,pkc->pbc", ds, dQ[:, :2], P)
        X[:, 2, :] = -gam[:, None] * n
        Kd = np.einsum("pi,pijk,pkc->pjc", f, dQ, P)
        Kd += np.einsum("pi,pk,pkc->pic", spin[pts], t3.theta_n[pts], P)
    else:
        nt_ = np.einsum("pl,pld->pd", g.Nm[pts], g.normals[f0])
        size = np.linalg.norm(nt_, axis=1)
        n = nt_ / size[:, None]
        P = np.eye(2)[None] - np.einsum("pa,pb->pab", n, n)
        X = np.zeros((pts.size, 2, 2))
        X[:, 0, :] = np.einsum("pa,ab,pbc->pc", ds, _J, P) / size[:, None]
        X[:, 1, :] = -gam[:, None] * n
        Kd = (
            np.einsum("ab,pbc->pac", _J, P) * f[:, 0, None, None] - P * f[:, 1, None, None]
        ) / size[:, None, None]
    QDX = np.einsum("pai,pab,pbj->pij", g.Q[pts], D[pts], X)
    return -gam[:, None, None] * M[pts] + QDX + Kd


def _frictionless(D: np.ndarray, nt: int) -> np.ndarray:
    """The law's tangents ``D`` (npts, gdim, gdim) with only ``d f_n / d g_n`` left.

    The tangent of a frictionless contact: a Newton step on it lets the interface slide freely
    and keeps its points closed where they are pressed.
    """
    out = np.zeros_like(D)
    out[:, nt, nt] = D[:, nt, nt]
    return out


def _kept_in_contact(D: np.ndarray, start_normal: np.ndarray, nt: int) -> np.ndarray:
    """``D`` with ``start_normal`` as ``d f_n / d g_n`` where a point has no stiffness (open)."""
    reopened = ~D.any(axis=(1, 2)) & (start_normal > 0.0)
    if not reopened.any():
        return D
    out = D.copy()
    out[reopened, nt, nt] = start_normal[reopened]
    return out
