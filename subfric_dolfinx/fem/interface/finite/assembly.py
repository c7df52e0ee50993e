"""Forces and tangent of a finite-sliding interface (part of :class:`~.interface.SlidingInterface`).

The slave nodes receive ``int N_s t`` by the slave facets' rule, the master nodes ``-B t`` of the
segment transfer (:mod:`.transfer`). The tangent is assembled as dense blocks, one per point
(slave rows) and one per point and master facet of its slave facet's segments (master rows),
whose columns are the point's slave facet nodes and its master facet's nodes:
``d t = Q^T D G (sum_k N_k du_k - sum_l N_l(xi) du_l)`` with ``G`` the gap's derivative
(:func:`.sliding.gap_operator`).
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..base import stiffen_separated
from .transfer import transfer_tangent

__all__ = ["SlidingAssembly"]


class SlidingAssembly:
    """The assembly part of :class:`~.interface.SlidingInterface` (the interface's attributes).

    Attributes:
        transfer_in_tangent: Whether the tangent holds the transfer's change with the geometry,
            ``dB t`` (2-D and 3-D): then the 2-D tangent is the residual's derivative, the 3-D
            one but for the frame's turn within an iteration
            (``tests/fem/interface/test_finite_sliding_tangent.py``), and Newton converges
            quadratically at the end of a step (without it linearly). On by default: fewer
            Newton iterations per sliding step (``benchmarks/finite_sliding_newton.py``).
    """

    transfer_in_tangent = True
    #: Master facet pairs the tangent needed beyond the pattern (:meth:`_pattern_check`), run total
    pattern_misses = 0

    def _pattern_check(self, slid_too_far: np.ndarray) -> None:
        """The pattern's hold on this iterate's segment pairs; record the pairs beyond it.

        The master rows of a segment facet ``a`` of a slave facet take the columns of the
        projection facets of its points (now and at the step's start) and of its other segment
        facets; the pattern holds the pairs of one reach that are near each other
        (:meth:`~.reach.ReachSearch._couple`). A pair beyond it is left out of the tangent
        (:meth:`_point_blocks`: never a write outside the pattern), counted in
        :attr:`pattern_misses`, and the next :meth:`begin_step` rebuilds the layout with it
        (unless its point slid farther than the reach: that step is cut anyway).

        The membership is evaluated here once per iterate (:meth:`update`) and kept for the
        tangent: ``_held_now`` and ``_held_old`` (nseg, nq), for every segment pair of
        ``_transfer`` and point ``q`` of its slave facet, whether the pattern couples the pair's
        master facet with the facet the point faces now (``_facet``) and faced at the step's
        start (``_old_facet``), False where it faces none; :meth:`_blocks` passes them to
        :meth:`_point_blocks`.
        """
        from scipy import sparse

        tr, nq = self._transfer, self.nq
        nseg = tr.slave.size
        if nseg == 0:
            self._held_now = self._held_old = np.zeros((0, nq), dtype=bool)
            return
        p = (tr.slave[:, None] * nq + np.arange(nq)[None, :]).ravel()
        a = np.repeat(tr.master, nq)
        now, old = self._facet[p], self._old_facet[p]
        held_now, held_old = np.zeros(p.size, dtype=bool), np.zeros(p.size, dtype=bool)
        held_now[now >= 0] = self._holds(a[now >= 0], now[now >= 0])
        held_old[old >= 0] = self._holds(a[old >= 0], old[old >= 0])
        self._held_now, self._held_old = held_now.reshape(nseg, nq), held_old.reshape(nseg, nq)
        live = self._found[p] & ~slid_too_far[p]
        moved = live & (old >= 0)
        npf = max(self.pf_global.size, 1)
        T = sparse.csr_matrix((np.ones(nseg), (tr.slave, tr.master)), shape=(self.slave.size, npf))
        TT = (T.T @ T).tocoo()  # segment facets of one slave facet with each other
        ta, tb = TT.row.astype(np.int64), TT.col.astype(np.int64)
        a = np.concatenate([a[live], a[moved], ta])
        b = np.concatenate([now[live], old[moved], tb])
        bad = ~np.concatenate([held_now[live], held_old[moved], self._holds(ta, tb)])
        if np.any(bad):
            g = self.pf_global
            new = set(zip(g[a[bad]].tolist(), g[b[bad]].tolist(), strict=True)) - self._missed
            self.pattern_misses += len(new)
            self._missed |= new

    def _global_tractions(self) -> np.ndarray:
        return np.einsum("mji,mj->mi", self._Q, self.last.traction)  # Q^T f, (npts, gdim)

    def forces(self) -> np.ndarray:
        """The owned interface forces of the last iterate (collective: a reverse scatter)."""
        from ...timing import TIMER_INTERFACE

        with self._time(TIMER_INTERFACE):
            s, nq, gdim = self.slave, self.nq, self.gdim
            tg = self._global_tractions().reshape(s.size, nq, gdim)
            w = self.weights.reshape(s.size, nq)

            def add(local: np.ndarray) -> None:
                b = local.reshape(-1, self.bs)
                Rs = np.einsum("fq,qk,fqd->fkd", w, self.Ns[0], tg)
                np.add.at(b[:, :gdim], s.nodes.ravel(), Rs.reshape(-1, gdim))
                tr = self._transfer
                if tr.slave.size:
                    Rm = np.einsum("plq,pqd->pld", tr.B, tg[tr.slave])
                    np.add.at(b[:, :gdim], self.pf_nodes[tr.master].ravel(), -Rm.reshape(-1, gdim))

            self.force = self._sum_to_owners(add)
            self.round_off = self._round_off(w)
        return self.force

    def _round_off(self, w: np.ndarray) -> np.ndarray:
        """Per dof, the size of the forces' round-off over ``EPS`` (collective).

        The gap is a difference of positions, so its round-off is ``EPS |x|``, not ``EPS |u|``:
        the forces carry ``EPS |D| |x|`` (``D`` the law's tangent), which the convergence test's
        floor must know (:class:`~subfric_dolfinx.fem.convergence.ScaledConvergence`).
        """
        s, nq, gdim = self.slave, self.nq, self.gdim
        D = np.abs(self.last.tangent).reshape(-1, gdim * gdim).max(axis=1, initial=0.0)
        m = (D * (np.linalg.norm(self._xq, axis=1) + self.h)).reshape(s.size, nq)

        def add(local: np.ndarray) -> None:
            b = local.reshape(-1, self.bs)
            Rs = np.einsum("fq,qk,fq->fk", w, np.abs(self.Ns[0]), m)
            np.add.at(b, s.nodes.ravel(), np.repeat(Rs.reshape(-1, 1), self.bs, axis=1))
            tr = self._transfer
            if tr.slave.size:
                Rm = np.einsum("plq,pq->pl", np.abs(tr.B), m[tr.slave])
                np.add.at(
                    b, self.pf_nodes[tr.master].ravel(), np.repeat(Rm.reshape(-1, 1), self.bs, 1)
                )

        return self._sum_to_owners(add)

    def _blocks(
        self,
        separated_stiffness: float = 0.0,
        frictionless: bool = False,
        keep_contact: bool = False,
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Tangent blocks ``(rows, cols, values)``: local (extended) node indices, dense values.

        ``separated_stiffness``: points without stiffness get this fraction of the law's contact
        stiffness (:func:`~.base.stiffen_separated`). ``frictionless``: the law's tangent
        keeps only the normal traction's change with the normal gap (:func:`_frictionless`).
        ``keep_contact``: points without stiffness that were in contact at the step's start get
        their normal stiffness there (:attr:`start_normal`).
        """
        s, nq, gdim = self.slave, self.nq, self.gdim
        found = self._found
        tangent = stiffen_separated(self.last.tangent, self.law, separated_stiffness)
        D = tangent.reshape(-1, gdim, gdim)
        if frictionless:
            D = _frictionless(D, self.nt)
        if keep_contact and self.start_normal is not None:
            D = _kept_in_contact(D, self.start_normal, self.nt)
        # Q^T D G + the frame's turn (2-D), (npts, gdim, gdim)
        M = np.einsum("mai,mab,mbj->mij", self._Q, D, self._G) + self._K
        pts = np.flatnonzero(found)
        f_of, q_of = pts // nq, pts % nq
        cols = np.concatenate([s.nodes[f_of], self.pf_nodes[self._facet[pts]]], axis=1)
        C = np.concatenate([self.Ns[0][q_of], -self._Nm[pts]], axis=1)  # (np, nfs + nfm)
        out = self._point_blocks(pts, cols, C, M[pts], self._held_now)
        # the convected slip's own master nodes: d(Q_t ds) holds Q_t (N(xi) dY - N(xi_0) dY_0)
        # besides the projection's move (in G): the master stretched between the two points
        mv = np.flatnonzero(found & (self._old_facet >= 0))
        if mv.size:
            E = self._Q[mv].copy()
            E[:, self.nt, :] = 0.0
            Mt = np.einsum("mai,mab,mbj->mij", self._Q[mv], D[mv], E)
            fm, fo = self._facet[mv], self._old_facet[mv]
            out += self._point_blocks(mv, self.pf_nodes[fm], self._Nm[mv], Mt, self._held_now)
            out += self._point_blocks(mv, self.pf_nodes[fo], -self._N_old[mv], Mt, self._held_old)
        if self.transfer_in_tangent:  # the transfer's change with the geometry
            ps, pm, vb = transfer_tangent(
                self._segments,
                self.projector,
                self._global_tractions().reshape(s.size, nq, gdim),
                self._Xs,
                self.X0[s.nodes],
                s.degree,
                self._Ym,
                self.pf_normals,
                self.master.degree,
                s.cell,
                self.master.cell,
            )
            held = self._self_held[pm]  # (a, a): in the pattern unless pattern_margin < 0
            ps, pm, vb = ps[held], pm[held], vb[held]
            if ps.size:
                out.append(
                    (self.pf_nodes[pm], np.concatenate([s.nodes[ps], self.pf_nodes[pm]], 1), vb)
                )
        return out

    def _point_blocks(
        self, pts: np.ndarray, cols: np.ndarray, C: np.ndarray, M: np.ndarray, held: np.ndarray
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Blocks of ``d t_p = M_p sum_j C_pj dX_j`` (global traction of the points ``pts``).

        Rows: the slave facet's nodes (``w N_k(q)``) and the master nodes of its segment pairs
        (``-B_lq``); columns ``cols`` (np, nc) with coefficients ``C`` (np, nc), which hold the
        nodes of one master facet per point (and maybe the slave facet's); ``M`` (np, gdim,
        gdim). ``held`` (nseg, nq): whether the pattern couples each segment pair's master facet
        with the master facet of point ``q``'s columns (``_held_now`` for the facet it faces,
        ``_held_old`` for the one it faced at the step's start: :meth:`_pattern_check`); a
        segment pair's master rows where it does not are left out.
        """
        s, nq, gdim = self.slave, self.nq, self.gdim
        nfs, nfm = s.nodes.shape[1], self.pf_nodes.shape[1]
        f_of, q_of = pts // nq, pts % nq
        ncol = cols.shape[1] * gdim
        vs = np.einsum("p,pk,pj,pab->pkajb", self.weights[pts], self.Ns[0][q_of], C, M)
        out = [(s.nodes[f_of], cols, vs.reshape(pts.size, nfs * gdim, ncol))]
        tr = self._transfer
        if tr.slave.size:
            # master rows of pair (s, f'): -B_lq C_j M for every point q of s in pts
            where = np.full(self.n_points, -1, dtype=np.int64)
            where[pts] = np.arange(pts.size)
            pair, qq = np.nonzero(where.reshape(s.size, nq)[tr.slave] >= 0)
            at = where[tr.slave[pair] * nq + qq]
            keep = held[pair, qq]
            pair, qq, at = pair[keep], qq[keep], at[keep]
            vm = -np.einsum("pl,pj,pab->plajb", tr.B[pair, :, qq], C[at], M[at])
            out.append(
                (self.pf_nodes[tr.master[pair]], cols[at], vm.reshape(pair.size, nfm * gdim, ncol))
            )
        return out

    def _add_tangent(
        self,
        A: PETSc.Mat,
        constrained: np.ndarray | None,
        separated_stiffness: float = 0.0,
        frictionless: bool = False,
        keep_contact: bool = False,
    ) -> None:
        """Add the tangent of the last iterate to ``A``, block by block (:meth:`_blocks`).

        ``A`` must hold this interface's pattern (the problem's :meth:`create_matrix` after the
        last :attr:`layout_version`). The rows and columns of ``constrained`` dofs are left out.
        ``separated_stiffness``: in this Jacobian only, found points without stiffness get this
        fraction of the law's contact stiffness (the retry of a failed step). ``frictionless``:
        in this Jacobian only, the law's tangent without its tangential stiffness (the first
        iteration of a step where the loading program turns:
        :class:`~subfric_dolfinx.fem.stepping.LoadStepper`'s ``predictor``); the geometric terms
        are kept. ``keep_contact``: in this Jacobian only, points separated here that were in
        contact at the step's start keep their normal stiffness of the start (the first
        iteration of every step: an extrapolated start that opens a few points by a round-off of
        the base's moving indentation would otherwise let them go in the first Newton step).
        """
        mask = constrained.reshape(-1, self.bs) if constrained is not None else None
        gl = self.index_map.local_to_global
        for rows, cols, vals in self._blocks(separated_stiffness, frictionless, keep_contact):
            if rows.shape[0] == 0:
                continue
            if mask is not None:
                mr = mask[rows].reshape(rows.shape[0], -1)
                mc = mask[cols].reshape(cols.shape[0], -1)
                vals = vals.copy()
                vals[mr[:, :, None] | mc[:, None, :]] = 0.0
            R = gl(rows.ravel().astype(np.int32)).reshape(rows.shape).astype(PETSc.IntType)
            Cc = gl(cols.ravel().astype(np.int32)).reshape(cols.shape).astype(PETSc.IntType)
            A.setValuesBlockedRCV(R, Cc, vals, addv=PETSc.InsertMode.ADD_VALUES)

    def _lifting(self, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``K (g - x)`` over the constrained dofs (owned rows; collective), block by block."""
        we = self._extended(dofs, values).reshape(-1, self.bs)

        def add(local: np.ndarray) -> None:
            acc = local.reshape(-1, self.bs)
            for rows, cols, vals in self._blocks():
                if rows.shape[0] == 0:  # a rank without points or segments: nothing to add
                    continue
                lift = np.einsum("pij,pj->pi", vals, we[cols].reshape(cols.shape[0], -1))
                np.add.at(acc, rows.ravel(), lift.reshape(-1, self.bs))

        return self._sum_to_owners(add)


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
