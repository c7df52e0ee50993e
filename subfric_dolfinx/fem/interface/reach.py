"""The per-step search of a finite-sliding interface: the reach of every slave facet.

At the start of every step (the last converged configuration) :class:`ReachSearch` (a part of
:class:`~.finite.SlidingInterface`) computes the master's averaged nodal normals, runs the parallel
search (:func:`.search.exchange_facets`) and finds, for every slave facet, the master facets it
may face during the step: the candidates within the slave facet's size plus ``reach``. The
master facets of the reach travel with their nodes' global numbers and owners, which become
extra ghosts of the displacement's index map; the matrix pattern couples every slave facet's
nodes with those of its reach. Both are rebuilt only when a slave facet needs a master facet
outside its current reach (then with three times the reach, so that a sliding body rebuilds
every couple of facets, not every step); :attr:`layout_version` counts the rebuilds.
"""

from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ...compat import ghosted_index_map, petsc_vector
from .geometry import frames
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
    """The search part of :class:`~.finite.SlidingInterface` (the interface's attributes)."""

    def begin_step(self) -> bool:
        """Search the master facets near the slave points at the last converged configuration.

        Collective. Rebuilds the pattern and ghosts where a slave facet needs a master facet
        beyond its reach (all ranks together).

        Returns:
            Whether the layout was rebuilt (:attr:`layout_version` grew).
        """
        from ..timing import TIMER_SEARCH

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
        pad = (
            self.radius
            + 3.0 * self.reach
            + float(self.comm.allreduce(rs.max(initial=0.0), MPI.MAX))
        )
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
        have = getattr(self, "_pattern_pairs", None)
        rebuild = have is None or not need <= have
        rebuild = bool(self.comm.allreduce(rebuild, op=MPI.LOR))
        if rebuild:
            si, fi = _near(cs, rs + 3.0 * self.reach, cx, cn, self.radius)
            known = set(cf.tolist())
            pairs = {
                p
                for p in set(zip(si.tolist(), cf[fi].tolist(), strict=True)) | need
                if p[1] in known
            }
            self._build(pairs, cx, cn, cg, co, cf, xs)
        # the nodal normals of this step (held during it) on the reach's facets
        pos = {g: i for i, g in enumerate(cf.tolist())}
        rows = np.array([pos.get(g, -1) for g in self.pf_global.tolist()], dtype=np.int64)
        hit = rows >= 0
        self.pf_normals[hit] = cn[rows[hit]]
        self._begin_kinematics()
        return rebuild

    def _build(self, pairs, cx, cn, cg, co, cf, xs) -> None:
        """Pattern, master facets of the reach and the extended ghosts (collective)."""
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
        for v in ("x_ext", "b_ext", "_mask_ext"):
            old = getattr(self, v)
            if old is not None:
                old.destroy()
        self.x_ext = petsc_vector(self.index_map, self.bs)
        self.b_ext = petsc_vector(self.index_map, self.bs)
        self._mask_ext = None
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
        elems = [
            np.unique(np.concatenate([self.slave.nodes[sf], self.pf_nodes[b].ravel()]))
            if b
            else self.slave.nodes[sf].astype(np.int64)
            for sf, b in enumerate(by_s)
        ]
        width = max((e.size for e in elems), default=self.slave.nodes.shape[1])
        padded = np.zeros((ns, width), dtype=np.int32)
        for i, e in enumerate(elems):
            padded[i, : e.size] = e
            padded[i, e.size :] = e[0]
        self.element_nodes = padded
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

