"""The per-step search of a finite-sliding interface: the reach of every slave facet.

At the start of every step (the last converged configuration) :class:`ReachSearch` (a part of
:class:`~.interface.SlidingInterface`) computes the master's averaged nodal normals, runs the
parallel search (:func:`.search.exchange_facets`) and finds, for every slave facet, the master
facets it may face during the step: the candidates within the slave facet's size plus ``reach``. The
master facets of the reach travel with their nodes' global numbers and owners, which become extra
ghosts of the displacement's index map; the matrix pattern couples every slave facet's nodes with
those of its reach, and the master facets of a reach near enough to each other to meet in one row of
the tangent (:meth:`ReachSearch._couple`). Both are rebuilt only when a slave facet needs a master
facet outside its current reach (then with three times the reach, so that a sliding body rebuilds
every couple of facets, not every step); :attr:`layout_version` counts the rebuilds.
"""

from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ....compat import ghosted_index_map, petsc_vector
from ..geometry import frames
from ..layout import Couplings
from .projection import facet_basis
from .search import exchange_facets, near_pairs
from .surface import facet_measures, nodal_normals

__all__ = ["ReachSearch", "surface_size"]


def surface_size(surface, x_nodes: np.ndarray, comm: MPI.Comm) -> float:
    """The largest facet size (length, or the square root of the area) over every rank."""
    fdim = x_nodes.shape[1] - 1
    local = float(facet_measures(surface, x_nodes).max(initial=0.0)) ** (1.0 / fdim)
    return comm.allreduce(local, op=MPI.MAX)


def _near(points, extent, X, Nn, radius) -> tuple[np.ndarray, np.ndarray]:
    """:func:`.search.near_pairs`, also without points or facets."""
    if points.shape[0] == 0 or X.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return near_pairs(points, extent, X, Nn, radius)


class ReachSearch:
    """The search part of :class:`~.interface.SlidingInterface` (the interface's attributes).

    Attributes:
        pattern_margin: The margin of the master facet pairs the pattern couples, in largest
            facet sizes ``h`` (:meth:`_couple`).
    """

    pattern_margin = 1.0

    def begin_step(self) -> bool:
        """Search the master facets near the slave points at the last converged configuration.

        Collective. Rebuilds the pattern and ghosts where a slave facet needs a master facet
        beyond its reach (all ranks together).

        Returns:
            Whether the layout was rebuilt (:attr:`layout_version` grew).
        """
        from ...timing import TIMER_SEARCH

        t0 = time.perf_counter()
        with self._time(TIMER_SEARCH):
            rebuild = self._search()
        self.search_seconds["search"] = time.perf_counter() - t0
        return rebuild

    def _search(self) -> bool:
        """:meth:`begin_step` without its timer."""
        xs = self._positions0(self._x_committed)
        m, s = self.master, self.slave
        normals = nodal_normals(m, xs, self.imap0)
        Ym = xs[m.nodes]
        cs = xs[s.nodes].mean(axis=1)
        rs = np.linalg.norm(xs[s.nodes] - cs[:, None], axis=-1).max(axis=1, initial=0.0)
        rs_max = float(self.comm.allreduce(rs.max(initial=0.0), MPI.MAX))  # over every rank
        pad = self.radius + 3.0 * self.reach + rs_max
        cand = exchange_facets(
            self.comm,
            cs,
            m.cell,
            m.degree,
            Ym,
            normals[m.nodes],
            self._global0[m.nodes],
            self._owners0[m.nodes],
            m.global_facets,
            pad,
        )
        # one row per facet (a rank receives each facet once; its own may come back too)
        _, first = np.unique(cand.global_facets, return_index=True)
        cx, cn = cand.x[first], cand.normals[first]
        cg, co, cf = cand.global_nodes[first], cand.owners[first], cand.global_facets[first]
        si, fi = _near(cs, rs + self.reach, cx, cn, self.radius)
        need = set(zip(si.tolist(), cf[fi].tolist(), strict=True))
        need |= {(p // self.nq, f) for p, f in enumerate(self.facet_old.tolist()) if f >= 0}
        have = self._pattern_pairs
        rebuild = have is None or not need <= have or bool(self._missed)
        rebuild = bool(self.comm.allreduce(rebuild, op=MPI.LOR))
        if rebuild:
            si, fi = _near(cs, rs + 3.0 * self.reach, cx, cn, self.radius)
            known = set(cf.tolist())
            pairs = {
                p
                for p in set(zip(si.tolist(), cf[fi].tolist(), strict=True)) | need
                if p[1] in known
            }
            self._build(pairs, cx, cn, cg, co, cf, 2.0 * rs_max)
        # the nodal normals of this step (held during it) on the reach's facets
        pos = {g: i for i, g in enumerate(cf.tolist())}
        rows = np.array([pos.get(g, -1) for g in self.pf_global.tolist()], dtype=np.int64)
        hit = rows >= 0
        self.pf_normals[hit] = cn[rows[hit]]
        self._begin_kinematics()
        return rebuild

    def _build(self, pairs, cx, cn, cg, co, cf, diam: float) -> None:
        """Pattern, master facets of the reach and the extended ghosts (collective).

        ``diam``: the largest slave facet diameter over every rank (twice its largest distance
        from a node to the facet's centre) in the configuration of the search.
        """
        ns = self.slave.size
        pf_global = np.array(sorted({f for _, f in pairs}), dtype=np.int64)
        row = {g: i for i, g in enumerate(cf.tolist())}
        rows = np.array([row[g] for g in pf_global.tolist()], dtype=np.int64)
        gnodes, owners = cg[rows], co[rows]
        # extended ghosts: the master nodes that are not local
        order = np.argsort(self._global0)
        pos = np.searchsorted(self._global0, gnodes, sorter=order)
        pos = np.minimum(pos, self._global0.size - 1)
        local = order[pos] if self._global0.size else np.zeros_like(gnodes)
        found = (
            (self._global0[local] == gnodes)
            if self._global0.size
            else np.zeros(gnodes.shape, dtype=bool)
        )
        extra_g, inv = np.unique(gnodes[~found], return_inverse=True)
        extra_o = np.zeros(extra_g.size, dtype=np.int32)
        extra_o[inv] = owners[~found]
        self.index_map = ghosted_index_map(
            self.comm,
            self.imap0.size_local,
            np.concatenate([self.imap0.ghosts, extra_g]),
            np.concatenate([self.imap0.owners, extra_o]),
        )
        self.extra_ghosts, self.extra_owners = extra_g, extra_o
        nodes = np.where(found, local, 0).astype(np.int64)
        nodes[~found] = self.n_local0 + inv
        self.pf_nodes = nodes.astype(np.int32)  # (npf, nfd_m), local in the extended map
        self.pf_global = pf_global
        self.pf_normals = cn[rows].copy()
        for v in ("x_ext", "b_ext", "_work"):
            old = getattr(self, v)
            if old is not None:
                old.destroy()
        self.x_ext = petsc_vector(self.index_map, self.bs)
        self.b_ext = petsc_vector(self.index_map, self.bs)
        self._work = None
        # reference positions of the reach's master nodes: current minus displacement
        self.x_ext.array_w[: self.n_owned] = self._x_committed
        self.x_ext.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with self.x_ext.localForm() as xl:
            u = xl.array_r.reshape(-1, self.bs)[:, : self.gdim]
            self.pf_X0 = cx[rows] - u[self.pf_nodes]
        # the reach of each slave facet (CSR) and the pattern's element nodes
        fpos = {g: i for i, g in enumerate(pf_global.tolist())}
        by_s: list[list[int]] = [[] for _ in range(ns)]
        for sf, g in sorted(pairs):
            by_s[sf].append(fpos[g])
        self.reach_ptr = np.concatenate([[0], np.cumsum([len(b) for b in by_s])]).astype(np.int64)
        self.reach_idx = np.array([i for b in by_s for i in b], dtype=np.int64)
        self._pattern_pairs = set(pairs)
        self._couple(cx[rows], diam)
        gl = self.index_map.local_to_global
        self._global_slave = (
            gl(self.slave.nodes.ravel().astype(np.int32))
            .reshape(self.slave.nodes.shape)
            .astype(PETSc.IntType)
        )
        self._global_pf = (
            gl(self.pf_nodes.ravel()).reshape(self.pf_nodes.shape).astype(PETSc.IntType)
        )
        self.layout_version += 1

    def _couple(self, Ym: np.ndarray, diam: float) -> None:
        """The pattern's node couplings (:attr:`couplings`) and master facet pairs (:meth:`_holds`).

        What the tangent can write (:mod:`.assembly`) while the layout stands: slave
        rows of a facet ``s`` x its own nodes and those of the master facets its points project
        on, now and at the step's start (both in ``s``'s reach); master rows of the facets ``a``
        of ``s``'s segments (in the reach) x ``s``'s nodes, and x the nodes of a master facet
        ``b`` of the reach: a projection facet of a point of ``s`` (now or at the step's start)
        or another segment facet of ``s`` (the transfer's change with the geometry). ``a`` and
        ``b`` then hold projections of points of ``s`` at most ``s``'s diameter apart, plus the
        point's slip in the step (at most ``reach``, else the step fails). So the pattern couples
        every slave facet's nodes with each other and with its reach's nodes (both ways), and
        the nodes of the master facets ``a``, ``b`` of one reach whose bounding boxes (at the
        rebuild) are at most ``reach + diam(s) + h`` apart (``h`` the largest facet size: the
        deformation until the next rebuild and the turn of the normals). Not all pairs of the
        reach (it is 3 reaches + the facet wide: hundreds of master nodes per slave facet in 3-D).
        A pair the tangent needs beyond this (:meth:`_pattern_check`) is left out of it for
        the step and forces a rebuild at the next step with the pair.

        ``Ym``: the nodes' positions of the reach's master facets, (npf, nfd_m, gdim); ``diam``:
        the largest slave facet diameter over every rank (:meth:`_search` reduced it already).
        """
        from scipy import sparse

        s = self.slave
        ns, npf = s.size, self.pf_global.size
        n_nodes = self.index_map.size_local + self.index_map.num_ghosts
        R = sparse.csr_matrix(
            (np.ones(self.reach_idx.size), self.reach_idx, self.reach_ptr), shape=(ns, npf)
        )
        nfs, nfm = s.nodes.shape[1], self.pf_nodes.shape[1]
        S = sparse.csr_matrix(
            (np.ones(ns * nfs), s.nodes.ravel(), np.arange(ns + 1) * nfs), shape=(ns, n_nodes)
        )
        P = sparse.csr_matrix(
            (np.ones(npf * nfm), self.pf_nodes.ravel(), np.arange(npf + 1) * nfm),
            shape=(npf, n_nodes),
        )
        # master facet pairs sharing a reach, within reach + diam(s) + h (bounding boxes)
        C = (R.T @ R).tocoo()
        a, b = C.row.astype(np.int64), C.col.astype(np.int64)
        lo, hi = Ym.min(axis=1), Ym.max(axis=1)
        gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo[a] - hi[b], lo[b] - hi[a])), axis=1)
        near = gap <= self.reach + diam + self.pattern_margin * self.h
        a, b = a[near], b[near]
        # pairs a step needed beyond it (:meth:`_pattern_check`), where both are in the reach
        missed = self._missed
        if missed:
            fpos = {g: i for i, g in enumerate(self.pf_global.tolist())}
            extra = [(fpos[x], fpos[y]) for x, y in missed if x in fpos and y in fpos]
            if extra:
                ea, eb = np.array(extra, dtype=np.int64).T
                a, b = np.concatenate([a, ea, eb]), np.concatenate([b, eb, ea])
        self._missed = set()
        self._pattern_keys = np.unique(a * max(npf, 1) + b)
        # each master facet with itself (the transfer's change): all unless pattern_margin < 0
        self._self_held = self._holds(np.arange(npf), np.arange(npf))
        A = sparse.csr_matrix((np.ones(a.size), (a, b)), shape=(npf, npf))
        SR = S + R @ P  # each slave facet's nodes and its reach's
        G = (S.T @ SR + (P.T @ A) @ P).tocsr()
        G = (G + G.T).tocsr()
        G.sum_duplicates()
        G.sort_indices()
        self.couplings = Couplings.rows(G.indptr, G.indices)

    def _holds(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether the pattern couples the nodes of master facets ``a`` and ``b`` (pf indices)."""
        keys = np.asarray(a, dtype=np.int64) * max(self.pf_global.size, 1) + b
        k = self._pattern_keys
        pos = np.minimum(np.searchsorted(k, keys), max(k.size - 1, 0))
        return (k[pos] == keys) if k.size else np.zeros(keys.shape, dtype=bool)

    def _begin_kinematics(self) -> None:
        """Each point's projection at the step's start (the last converged configuration).

        The material point of the master each point faces there is where its slip of the step
        is measured from (also for a point that was open and may close in the step).
        """
        u = self._local_displacement(self._x_committed)
        xq, Ym, _ = self._current(u)
        pj = self._project(xq, Ym)
        found = pj["facet"] >= 0
        self.pf_old = pj["facet"]
        self.xi_old = pj["xi"]
        self.Q_old[found] = frames(pj["normal"][found])
        unset = np.abs(self.Q_old).sum(axis=(1, 2)) == 0
        self.Q_old[unset] = np.eye(self.gdim)[None]
        pf = np.flatnonzero(found)
        m = self.master
        B = facet_basis(m.cell, m.degree, self.xi_old[pf], 1)
        self.tan_old[pf] = np.einsum("amk,mkd->mda", B[1:], Ym[self.pf_old[pf]])
