"""The per-step search of a finite-sliding interface: the reach of every secondary facet.

At the start of every step (the last converged configuration) :class:`ReachSearch` (the search
part of :class:`~.interface.SlidingInterface`) computes the primary's averaged nodal normals, runs
the parallel search (:func:`.search.exchange_facets`) and finds, for every secondary facet, the
primary facets it may face during the step: the candidates within the secondary facet's size plus
``reach``. The primary facets of the reach travel with their nodes' global numbers and owners, which
become extra ghosts of the displacement's index map; the matrix pattern couples every secondary
facet's nodes with those of its reach, and the primary facets of a reach near enough to each other
to meet in one row of the tangent (:func:`_couplings`). Both are one :class:`Reach` value, rebuilt
only when a secondary facet needs a primary facet outside its current reach (then with three times
the reach, so that a sliding body rebuilds every couple of facets, not every step);
:attr:`ReachSearch.layout_version` counts the rebuilds. Each step also gives the points'
projections at its start (:class:`StepStart`), from which their slip of the step is measured.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, cast

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ....compat import ghosted_index_map, petsc_vector
from ..geometry import frames
from ..layout import Couplings
from .contact import current_positions, project
from .projection import facet_basis
from .search import exchange_facets, near_pairs
from .sides import Sides
from .surface import nodal_normals

__all__ = ["Reach", "ReachSearch", "StepStart"]


def _ints(a: np.ndarray) -> list[int]:
    """An integer array's values as Python ints (numpy's stubs cannot know ``tolist``'s type)."""
    return cast(list[int], a.tolist())


@dataclasses.dataclass(frozen=True)
class Reach:
    """The primary facets the secondary facets may face until the next rebuild, and the layout.

    Attributes:
        index_map: The displacement's index map with the reach's primary nodes as extra ghosts.
        extra_ghosts: The extra ghosts (global node numbers), (ne,).
        extra_owners: Their owners, (ne,).
        nodes: The reach's primary facets' nodes, local in :attr:`index_map`, (npf, nfd_m).
        facets: Their global facet numbers (sorted), (npf,).
        X0: Their nodes' reference positions, (npf, nfd_m, gdim).
        ptr: CSR offsets of each secondary facet's reach in :attr:`idx`, (ns + 1,).
        idx: The reach's primary facets (indices in :attr:`facets`) of each secondary facet.
        pairs: The (secondary facet, primary facet global number) pairs of the reach.
        keys: The primary facet pairs the pattern couples (``a * npf + b``, sorted).
        couplings: The pattern's node couplings (:class:`~..layout.Couplings`).
        node_facets: The number of primary facets around each local node of :attr:`index_map`
            (every rank's facets).
    """

    index_map: dolfinx.common.IndexMap
    extra_ghosts: np.ndarray
    extra_owners: np.ndarray
    nodes: np.ndarray
    facets: np.ndarray
    X0: np.ndarray
    ptr: np.ndarray
    idx: np.ndarray
    pairs: frozenset
    keys: np.ndarray
    couplings: Couplings
    node_facets: np.ndarray

    def holds(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether the pattern couples the nodes of primary facets ``a`` and ``b`` (indices)."""
        keys = np.asarray(a, dtype=np.int64) * max(self.facets.size, 1) + b
        k = self.keys
        pos = np.minimum(np.searchsorted(k, keys), max(k.size - 1, 0))
        return (k[pos] == keys) if k.size else np.zeros(keys.shape, dtype=bool)

    @functools.cached_property
    def _pair_keys(self) -> np.ndarray:
        """The reach's (secondary facet, primary facet index) pairs as sorted keys."""
        npf = max(self.facets.size, 1)
        owner = np.repeat(np.arange(self.ptr.size - 1), np.diff(self.ptr))
        return np.unique(owner * npf + self.idx)

    @functools.cached_property
    def node_keys(self) -> np.ndarray:
        """The node pairs of :attr:`couplings` as sorted keys ``row * n + col`` (``n`` nodes)."""
        n = self.index_map.size_local + self.index_map.num_ghosts
        keys = [
            (r.astype(np.int64)[:, :, None] * n + c[:, None, :]).ravel()
            for r, c in self.couplings.blocks
        ]
        return np.unique(np.concatenate(keys)) if keys else np.zeros(0, dtype=np.int64)

    def holds_nodes(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Whether the pattern couples the local nodes ``rows`` and ``cols`` (:attr:`couplings`)."""
        n = self.index_map.size_local + self.index_map.num_ghosts
        keys = np.asarray(rows, dtype=np.int64) * n + cols
        k = self.node_keys
        if k.size == 0:
            return np.zeros(keys.shape, dtype=bool)
        pos = np.minimum(np.searchsorted(k, keys), k.size - 1)
        return k[pos] == keys

    def within(self, secondary: np.ndarray, primary: np.ndarray) -> np.ndarray:
        """Whether each (secondary facet, primary facet index) pair is in the secondary's reach."""
        keys = np.asarray(secondary, dtype=np.int64) * max(self.facets.size, 1) + primary
        k = self._pair_keys
        if k.size == 0:
            return np.zeros(keys.shape, dtype=bool)
        pos = np.minimum(np.searchsorted(k, keys), k.size - 1)
        return k[pos] == keys


@dataclasses.dataclass(frozen=True)
class StepStart:
    """Each point's projection at the step's start (the last converged configuration).

    The material point of the primary each point faces there is where its slip of the step is
    measured from (also for a point that was open and may close in the step).

    Attributes:
        facet: The primary facet (index in the reach; -1: none), (npts,).
        xi: Its reference coordinates there, (npts, nt).
        Q: The frames there; a point facing nothing keeps its committed one, (npts, gdim, gdim).
        tangents: The primary's tangent basis there (where ``facet >= 0``), (npts, gdim, nt).
        normal_stiffness: ``d f_n / d g_n`` of every point at the step's first evaluation (its
            start: the last converged configuration with the step's Dirichlet values; ``None``
            before it), for the step's first Jacobian.
        normal_gap: The law's normal gap of every point at that evaluation (``None`` before
            it), which an extrapolated start keeps where it would open a point
            (:meth:`~.interface.SlidingInterface.start_correction`).
    """

    facet: np.ndarray
    xi: np.ndarray
    Q: np.ndarray
    tangents: np.ndarray
    normal_stiffness: np.ndarray | None = None
    normal_gap: np.ndarray | None = None


class ReachSearch:
    """The search part of a :class:`~.interface.SlidingInterface`: its reach, layout and normals.

    Args:
        sides: The interface's sides.

    Attributes:
        reach: The current :class:`Reach` (``None`` before the first step).
        normals: The step's nodal normals of the reach's primary facets (held during the step),
            (npf, nfd_m, gdim).
        layout_version: Grows every time the pattern and ghosts are rebuilt.
        pattern_misses: Primary facet pairs the tangent needed beyond the pattern (run total).
        x_ext: A vector of the extended layout (the displacement at the reach's nodes).
        b_ext: A vector of the extended layout (contributions summed to their owners).
    """

    #: The margin of the primary facet pairs the pattern couples, in largest facet sizes ``h``.
    pattern_margin = 1.0

    def __init__(self, sides: Sides) -> None:
        self.sides = sides
        imap0 = sides.imap0
        self._owners0 = np.concatenate(
            [np.full(imap0.size_local, sides.comm.rank, np.int32), imap0.owners]
        )
        self._global0 = imap0.local_to_global(np.arange(sides.n_local0, dtype=np.int32))
        self.reach: Reach | None = None
        self.normals: np.ndarray = np.zeros((0, 0, sides.gdim))
        self.layout_version = 0
        self.pattern_misses = 0
        # primary facet pairs (global numbers) a tangent needed beyond the pattern since it was
        # built (:meth:`record_misses`): the next search rebuilds with them
        self._missed: set[tuple[int, int]] = set()
        self.x_ext: PETSc.Vec | None = None
        self.b_ext: PETSc.Vec | None = None
        # work vectors of an index map and block size (:meth:`_vector`)
        self._vectors: dict[tuple[int, int], tuple[dolfinx.common.IndexMap, Any]] = {}

    def _vector(self, index_map: dolfinx.common.IndexMap, bs: int) -> Any:
        """A work vector of ``index_map`` with block size ``bs``, made once per map.

        Its values are the caller's to overwrite (making one costs more than an iteration's
        projections).
        """
        key = (id(index_map), bs)
        held = self._vectors.get(key)
        if held is None or held[0] is not index_map:
            held = (index_map, dolfinx.la.vector(index_map, bs))
            self._vectors[key] = held
        return held[1]

    def displacement(self, owned: np.ndarray) -> np.ndarray:
        """The displacement at every local node of the extended map (collective)."""
        gdim, bs = self.sides.gdim, self.sides.bs
        assert self.x_ext is not None  # (made with the reach; None once destroyed)
        self.x_ext.array_w[: self.sides.n_owned] = owned
        self.x_ext.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with self.x_ext.localForm() as xl:
            return xl.array_r.reshape(-1, bs)[:, :gdim].copy()

    def begin_step(
        self, x_committed: np.ndarray, facet_old: np.ndarray, Q_old: np.ndarray
    ) -> StepStart:
        """Search the primary facets near the secondary points at the last converged configuration.

        Collective. Rebuilds the pattern and ghosts where a secondary facet needs a primary facet
        beyond its reach (all ranks together: :attr:`layout_version` grows).

        Args:
            x_committed: The committed displacement (owned values).
            facet_old: The points' committed primary facets (global numbers; -1: none).
            Q_old: The points' committed frames.

        Returns:
            The points' projections at the step's start (their frames: ``Q_old`` where a point
            faces nothing, the identity where it never faced the primary).
        """
        self._search(x_committed, facet_old)
        return self._start(x_committed, Q_old)

    def _search(self, x_committed: np.ndarray, facet_old: np.ndarray) -> None:
        """The search of :meth:`begin_step`: the reach and the step's nodal normals."""
        sd = self.sides
        xs = self._positions0(x_committed)
        m, s = sd.primary, sd.secondary
        normals = nodal_normals(m, xs, sd.imap0, self._vector(sd.imap0, sd.gdim))
        cs = xs[s.nodes].mean(axis=1)
        rs = np.linalg.norm(xs[s.nodes] - cs[:, None], axis=-1).max(axis=1, initial=0.0)
        rs_max = float(sd.comm.allreduce(rs.max(initial=0.0), MPI.MAX))  # over every rank
        pad = sd.radius + 3.0 * sd.reach + rs_max
        cand = exchange_facets(
            sd.comm,
            cs,
            m.cell,
            m.degree,
            xs[m.nodes],
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
        si, fi = near_pairs(cs, rs + sd.reach, cx, cn, sd.radius)
        need: set[tuple[int, int]] = set(zip(_ints(si), _ints(cf[fi]), strict=True))
        need |= {(p // sd.nq, f) for p, f in enumerate(_ints(facet_old)) if f >= 0}
        rebuild = self.reach is None or not need <= self.reach.pairs or bool(self._missed)
        if sd.comm.allreduce(rebuild, op=MPI.LOR):
            si, fi = near_pairs(cs, rs + 3.0 * sd.reach, cx, cn, sd.radius)
            known = set(cf.tolist())
            pairs = {
                p
                for p in set(zip(si.tolist(), cf[fi].tolist(), strict=True)) | need
                if p[1] in known
            }
            self._build(pairs, cx, cg, co, cf, x_committed, 2.0 * rs_max)
            assert self.reach is not None  # (built)
            self.normals = np.zeros((self.reach.facets.size, *cn.shape[1:]))
        assert self.reach is not None  # (built above if there was none)
        # the nodal normals of this step (held during it) on the reach's facets
        pos = {g: i for i, g in enumerate(cf.tolist())}
        rows = np.array([pos.get(g, -1) for g in self.reach.facets.tolist()], dtype=np.int64)
        hit = rows >= 0
        normals = self.normals.copy()
        normals[hit] = cn[rows[hit]]
        self.normals = normals

    def current_normals(self, u: np.ndarray) -> np.ndarray:
        """The nodal normals of the reach's facets at the displacement ``u`` (collective).

        ``u``: the displacement at the local nodes of the reach's index map (:meth:`displacement`).
        Returns (npf, nfd_m, gdim), like :attr:`normals`.
        """
        sd = self.sides
        x = sd.X0 + u[: sd.n_local0]
        assert self.reach is not None  # (searched)
        imap = self.reach.index_map
        return nodal_normals(sd.primary, x, imap, self._vector(imap, sd.gdim))[self.reach.nodes]

    def _positions0(self, u_owned: np.ndarray) -> np.ndarray:
        """Current positions of the displacement space's local nodes (collective: ghost update)."""
        sd = self.sides
        v = self._vector(sd.imap0, sd.bs)
        v.array[: sd.n_owned] = u_owned
        v.scatter_forward()
        return sd.X0 + v.array.reshape(-1, sd.bs)[:, : sd.gdim]

    def _build(self, pairs, cx, cg, co, cf, x_committed: np.ndarray, diam: float) -> None:
        """The reach of ``pairs``, its extended ghosts and vectors (collective).

        ``diam``: the largest secondary facet diameter over every rank (twice its largest distance
        from a node to the facet's centre) in the configuration of the search.
        """
        sd = self.sides
        ns = sd.secondary.size
        pf_global = np.array(sorted({f for _, f in pairs}), dtype=np.int64)
        row = {g: i for i, g in enumerate(cf.tolist())}
        rows = np.array([row[g] for g in _ints(pf_global)], dtype=np.int64)
        index_map, extra_g, extra_o, nodes = self._extended_map(cg[rows], co[rows])
        self._vectors = {k: v for k, v in self._vectors.items() if v[0] is sd.imap0}
        for v in (self.x_ext, self.b_ext):
            if v is not None:
                v.destroy()
        self.x_ext = petsc_vector(index_map, sd.bs)
        self.b_ext = petsc_vector(index_map, sd.bs)
        # reference positions of the reach's primary nodes: current minus displacement
        u = self.displacement(x_committed)
        # the reach of each secondary facet (CSR)
        fpos = {g: i for i, g in enumerate(_ints(pf_global))}
        by_s: list[list[int]] = [[] for _ in range(ns)]
        for sf, g in sorted(pairs):
            by_s[sf].append(fpos[g])
        ptr = np.concatenate([[0], np.cumsum([len(b) for b in by_s])]).astype(np.int64)
        idx = np.array([i for b in by_s for i in b], dtype=np.int64)
        keys, couplings = _couplings(
            sd, ptr, idx, nodes, pf_global, index_map, cx[rows], diam, self._missed_pairs(fpos)
        )
        self._missed = set()
        self.reach = Reach(
            index_map=index_map,
            extra_ghosts=extra_g,
            extra_owners=extra_o,
            nodes=nodes,
            facets=pf_global,
            X0=cx[rows] - u[nodes],
            ptr=ptr,
            idx=idx,
            pairs=frozenset(pairs),
            keys=keys,
            couplings=couplings,
            node_facets=self._node_facets(index_map),
        )
        self.layout_version += 1

    def _extended_map(
        self, gnodes: np.ndarray, owners: np.ndarray
    ) -> tuple[dolfinx.common.IndexMap, np.ndarray, np.ndarray, np.ndarray]:
        """The index map with the primary nodes ``gnodes`` that are not local as extra ghosts.

        Returns:
            The map, the extra ghosts and their owners, and ``gnodes`` as local nodes of the map.
        """
        sd = self.sides
        g0 = self._global0
        order = np.argsort(g0)
        pos = np.searchsorted(g0, gnodes, sorter=order)
        pos = np.minimum(pos, g0.size - 1)
        local = order[pos] if g0.size else np.zeros_like(gnodes)
        found = (g0[local] == gnodes) if g0.size else np.zeros(gnodes.shape, dtype=bool)
        extra_g, inv = np.unique(gnodes[~found], return_inverse=True)
        extra_o = np.zeros(extra_g.size, dtype=np.int32)
        extra_o[inv] = owners[~found]
        index_map = ghosted_index_map(
            sd.comm,
            sd.imap0.size_local,
            np.concatenate([sd.imap0.ghosts, extra_g]),
            np.concatenate([sd.imap0.owners, extra_o]),
        )
        nodes = np.where(found, local, 0).astype(np.int64)
        nodes[~found] = sd.n_local0 + inv
        return index_map, extra_g, extra_o, nodes.astype(np.int32)

    def _node_facets(self, index_map: dolfinx.common.IndexMap) -> np.ndarray:
        """The number of primary facets around each local node of ``index_map`` (collective)."""
        v = dolfinx.la.vector(index_map, 1)
        v.array[:] = 0.0
        np.add.at(v.array, self.sides.primary.nodes.ravel(), 1.0)
        v.scatter_reverse(dolfinx.la.InsertMode.add)
        v.scatter_forward()
        return np.rint(v.array).astype(np.int64)

    def _missed_pairs(self, fpos: dict[int, int]) -> list[tuple[int, int]]:
        """The pairs a step needed beyond the pattern (:meth:`record_misses`) within the reach."""
        return [(fpos[x], fpos[y]) for x, y in self._missed if x in fpos and y in fpos]

    def _start(self, x_committed: np.ndarray, Q_old: np.ndarray) -> StepStart:
        """Each point's projection at the step's start (the last converged configuration)."""
        sd = self.sides
        u = self.displacement(x_committed)
        assert self.reach is not None  # (searched)
        xq, Ym, _ = current_positions(sd, self.reach, u)
        pj = project(sd, self.reach, self.normals, xq, Ym)
        found = pj.facet >= 0
        Q = Q_old.copy()
        Q[found] = frames(pj.normal[found])
        unset = np.abs(Q).sum(axis=(1, 2)) == 0
        Q[unset] = np.eye(sd.gdim)[None]
        tangents = np.zeros((sd.n_points, sd.gdim, sd.nt))
        pf = np.flatnonzero(found)
        m = sd.primary
        B = facet_basis(m.cell, m.degree, pj.xi[pf], 1)
        tangents[pf] = np.einsum("amk,mkd->mda", B[1:], Ym[pj.facet[pf]])
        return StepStart(pj.facet, pj.xi, Q, tangents)

    def record_misses(self, a: np.ndarray, b: np.ndarray) -> None:
        """Record the primary facet pairs ``a``, ``b`` (indices) a tangent needed beyond it.

        The next :meth:`begin_step` rebuilds the layout with them.
        """
        assert self.reach is not None  # (searched)
        g = self.reach.facets
        new = set(zip(g[a].tolist(), g[b].tolist(), strict=True)) - self._missed
        self.pattern_misses += len(new)
        self._missed |= new

    def layout_parts(self) -> tuple[np.ndarray, np.ndarray, dolfinx.common.IndexMap, Couplings]:
        """Extra ghosts, their owners, the extended index map and the pattern's couplings."""
        r = self.reach
        assert r is not None  # (searched)
        return r.extra_ghosts, r.extra_owners, r.index_map, r.couplings

    def destroy(self) -> None:
        """Free the PETSc vectors (safe to call more than once)."""
        for v in (self.x_ext, self.b_ext):
            if v is not None:
                v.destroy()
        self.x_ext = self.b_ext = None


def _couplings(
    sd: Sides,
    ptr: np.ndarray,
    idx: np.ndarray,
    nodes: np.ndarray,
    facets: np.ndarray,
    index_map: dolfinx.common.IndexMap,
    Ym: np.ndarray,
    diam: float,
    missed: list[tuple[int, int]],
) -> tuple[np.ndarray, Couplings]:
    """The primary facet pairs the pattern couples (keys) and its node couplings.

    What the tangent can write (:mod:`.assembly`) while the layout stands: secondary rows of a facet
    ``s`` x its own nodes and those of the primary facets its points project on, now and at the
    step's start (both in ``s``'s reach); primary rows of the facets ``a`` of ``s``'s segments (in
    the reach) x ``s``'s nodes, and x the nodes of a primary facet ``b`` of the reach: a
    projection facet of a point of ``s`` (now or at the step's start) or another segment facet of
    ``s`` (the transfer's change with the geometry). ``a`` and ``b`` then hold projections of
    points of ``s`` at most ``s``'s diameter apart, plus the point's slip in the step (at most
    ``reach``, else the step fails). So the pattern couples every secondary facet's nodes with each
    other and with its reach's nodes (both ways), and the nodes of the primary facets ``a``, ``b``
    of one reach whose bounding boxes (at the rebuild) are at most ``reach + diam(s) + h`` apart
    (``h`` the largest facet size: the deformation until the next rebuild and the turn of the
    normals), and the ``missed`` pairs a step needed beyond it. Not all pairs of the reach (it is
    3 reaches + the facet wide: hundreds of primary nodes per secondary facet in 3-D). A pair the
    tangent needs beyond this (:meth:`.contact.ContactGeometry`'s hold) is left out of it for the
    step and forces a rebuild at the next step with the pair.

    Args:
        sd: The sides.
        ptr: The reach's CSR offsets per secondary facet.
        idx: The reach's primary facets per secondary facet.
        nodes: The reach's primary facets' nodes (local in ``index_map``).
        facets: Their global numbers.
        index_map: The extended index map.
        Ym: The nodes' positions of the reach's primary facets, (npf, nfd_m, gdim).
        diam: The largest secondary facet diameter over every rank.
        missed: Primary facet pairs (indices) a step needed beyond the last pattern.
    """
    from scipy import sparse

    s = sd.secondary
    ns, npf = s.size, facets.size
    n_nodes = index_map.size_local + index_map.num_ghosts
    R = sparse.csr_matrix((np.ones(idx.size), idx, ptr), shape=(ns, npf))
    nfs, nfm = s.nodes.shape[1], nodes.shape[1]
    S = sparse.csr_matrix(
        (np.ones(ns * nfs), s.nodes.ravel(), np.arange(ns + 1) * nfs), shape=(ns, n_nodes)
    )
    P = sparse.csr_matrix(
        (np.ones(npf * nfm), nodes.ravel(), np.arange(npf + 1) * nfm), shape=(npf, n_nodes)
    )
    # primary facet pairs sharing a reach, within reach + diam(s) + h (bounding boxes)
    C = (R.T @ R).tocoo()
    a, b = C.row.astype(np.int64), C.col.astype(np.int64)
    lo, hi = Ym.min(axis=1), Ym.max(axis=1)
    gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo[a] - hi[b], lo[b] - hi[a])), axis=1)
    near = gap <= sd.reach + diam + ReachSearch.pattern_margin * sd.h
    a, b = a[near], b[near]
    if missed:
        ea, eb = np.array(missed, dtype=np.int64).T
        a, b = np.concatenate([a, ea, eb]), np.concatenate([b, eb, ea])
    keys = np.unique(a * max(npf, 1) + b)
    A = sparse.csr_matrix((np.ones(a.size), (a, b)), shape=(npf, npf))
    SR = S + R @ P  # each secondary facet's nodes and its reach's
    G = (S.T @ SR + (P.T @ A) @ P).tocsr()
    G = (G + G.T).tocsr()
    G.sum_duplicates()
    G.sort_indices()
    return keys, Couplings.rows(G.indptr, G.indices)
