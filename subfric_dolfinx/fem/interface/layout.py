"""Parallel layout with cross-interface couplings: vectors and a preallocated matrix.

The displacement index map is extended with the other side's nodes as extra ghosts (see
:func:`~.pairing.pair_interface`): owned ranges and global numbers are unchanged, so vectors and
matrices built on it are compatible with DOLFINx's own assembly (local indices of the original
dofs are a prefix of the extended local indices). The sparsity pattern holds every bulk cell's
block and every interface's couplings (:class:`Couplings`: each element's nodes with each other,
or a finite-sliding interface's rows and columns), so that assembling the Jacobian never
allocates (checked with PETSc's malloc count in the tests).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence
from typing import Any

import dolfinx
import numpy as np
from dolfinx.cpp.la import SparsityPattern
from petsc4py import PETSc

from ...compat import ghosted_index_map, petsc_vector

__all__ = ["Couplings", "ExtendedLayout", "combined_index_map", "create_matrix", "layout_of"]

#: Explicit zeros set per call of :meth:`ExtendedLayout.create_matrix` (bounds its memory: 16 MiB)
ZERO_ENTRIES = 1 << 21


@dataclasses.dataclass(frozen=True)
class Couplings:
    """Node couplings of an interface in the matrix pattern (local node indices).

    Attributes:
        blocks: ``(rows, cols)`` pairs, (k, nr) and (k, nc): for every ``i`` each node of
            ``rows[i]`` is coupled with each node of ``cols[i]`` (a node may repeat in a row).
    """

    blocks: tuple[tuple[np.ndarray, np.ndarray], ...]

    @classmethod
    def of(cls, nodes: np.ndarray | Couplings) -> Couplings:
        """``nodes`` itself, or element nodes (nf, n): each element's nodes with each other."""
        if isinstance(nodes, Couplings):
            return nodes
        nodes = np.asarray(nodes)
        return cls(((nodes, nodes),))

    @classmethod
    def rows(cls, indptr: np.ndarray, indices: np.ndarray) -> Couplings:
        """Row ``r`` coupled with ``indices[indptr[r]:indptr[r + 1]]`` (CSR), grouped by width."""
        width = np.diff(indptr)
        blocks = []
        for w in np.unique(width[width > 0]).tolist():
            r = np.flatnonzero(width == w)
            cols = indices[indptr[r][:, None] + np.arange(w)[None, :]]
            blocks.append((r[:, None].astype(np.int32), cols.astype(np.int32)))
        return cls(tuple(blocks))

    def map(self, f: Callable[[np.ndarray], np.ndarray]) -> Couplings:
        """The same couplings with every node array mapped by ``f``."""
        return Couplings(tuple((f(r), f(c)) for r, c in self.blocks))

    @property
    def entries(self) -> int:
        """Node pairs of all blocks (with repetitions)."""
        return int(sum(r.size * c.shape[1] for r, c in self.blocks))


def combined_index_map(
    V: dolfinx.fem.FunctionSpace,
    extras: list[tuple[np.ndarray, np.ndarray]],
    nodes: Sequence[tuple[dolfinx.common.IndexMap, np.ndarray | Couplings]],
) -> tuple[dolfinx.common.IndexMap, list[Couplings]]:
    """One index map for several interfaces, and their couplings in its local numbering.

    Args:
        V: The displacement space.
        extras: For each interface, its extra ghosts (global numbers) and their owners.
        nodes: For each interface, its own extended index map and its element nodes or
            :class:`Couplings` (local in it).

    Returns:
        ``V``'s index map extended with the union of the extra ghosts (first appearance order),
        and each interface's :class:`Couplings`, local in it.
    """
    imap0 = V.dofmap.index_map
    n0 = imap0.size_local + imap0.num_ghosts
    glob = np.concatenate([g for g, _ in extras]) if extras else np.zeros(0, np.int64)
    own = np.concatenate([o for _, o in extras]) if extras else np.zeros(0, np.int32)
    uniq, first = np.unique(glob, return_index=True)
    order = np.argsort(first)
    extra_g, extra_o = uniq[order], own[first[order]]
    imap = ghosted_index_map(
        V.mesh.comm,
        imap0.size_local,
        np.concatenate([imap0.ghosts, extra_g]),
        np.concatenate([imap0.owners, extra_o]),
    )
    sorter = np.argsort(extra_g)

    def remap(m: dolfinx.common.IndexMap, nd: np.ndarray) -> np.ndarray:
        nd = np.asarray(nd, dtype=np.int64)
        local = nd.copy()
        far = nd >= n0
        if np.any(far):
            g = m.local_to_global(nd[far].astype(np.int32))
            local[far] = n0 + sorter[np.searchsorted(extra_g, g, sorter=sorter)]
        return local.astype(np.int32)

    out = [Couplings.of(nd).map(functools.partial(remap, m)) for m, nd in nodes]
    return imap, out


class ExtendedLayout:
    """Vectors and matrices on a displacement space extended by interface ghosts.

    Args:
        V: The displacement space.
        index_map: Its index map extended with the interface's extra ghosts.
        element_nodes: An interface's couplings, local (extended) node indices: its element nodes
            (nf, n) (each element's nodes are coupled with each other) or :class:`Couplings`;
            or a list of those, one per interface.
    """

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        index_map: dolfinx.common.IndexMap,
        element_nodes: np.ndarray | Couplings | Sequence[np.ndarray | Couplings],
    ) -> None:
        self.V = V
        self.index_map = index_map
        self.bs = V.dofmap.bs
        self.comm = V.mesh.comm
        imap0 = V.dofmap.index_map
        self.n_owned = imap0.size_local * self.bs
        self.n_local0 = (imap0.size_local + imap0.num_ghosts) * self.bs
        if isinstance(element_nodes, (np.ndarray, Couplings)):
            element_nodes = [element_nodes]
        self.couplings = [Couplings.of(nd) for nd in element_nodes]

    def _blocks(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Every ``(rows, cols)`` block of the pattern: the bulk cells' and the interfaces'."""
        cells = np.asarray(self.V.dofmap.list)
        return [(cells, cells)] + [b for c in self.couplings for b in c.blocks]

    def create_vector(self) -> PETSc.Vec:
        """A ghosted vector whose ghosts include the interface's extra ghosts."""
        return petsc_vector(self.index_map, self.bs)

    def sparsity(self) -> SparsityPattern:
        """Bulk cell blocks plus the interfaces' couplings, finalised."""
        sp = SparsityPattern(self.comm, [self.index_map, self.index_map], [self.bs, self.bs])
        for rows, cols in self._blocks():
            for r, c in zip(rows, cols, strict=True):
                sp.insert(r, c)
        sp.finalize()
        return sp

    def create_matrix(self) -> PETSc.Mat:
        """An assembled AIJ matrix holding explicit zeros on the pattern of :meth:`sparsity`.

        The zeros fix the structure: later assemblies add into existing entries (no mallocs), and
        matrices made here share one structure (``SAME_NONZERO_PATTERN`` operations are valid).
        They are set in chunks of at most :data:`ZERO_ENTRIES` entries.
        """
        A = dolfinx.cpp.la.petsc.create_matrix(self.comm, self.sparsity())
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        bs = self.bs
        for rows, cols in self._blocks():
            if rows.size == 0 or cols.size == 0:
                continue
            rows = np.ascontiguousarray(rows, dtype=PETSc.IntType)
            cols = np.ascontiguousarray(cols, dtype=PETSc.IntType)
            nr, nc = rows.shape[1] * bs, cols.shape[1] * bs
            step = max(1, ZERO_ENTRIES // (nr * nc))
            for start in range(0, rows.shape[0], step):
                r, c = rows[start : start + step], cols[start : start + step]
                zeros = np.zeros((r.shape[0], nr, nc), dtype=PETSc.ScalarType)
                A.setValuesBlockedLocalRCV(r, c, zeros, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()
        return A


def create_matrix(V: dolfinx.fem.FunctionSpace, interfaces: Sequence[Any]) -> PETSc.Mat:
    """A matrix with every bulk cell's block and every interface's couplings preallocated.

    Assemble the bulk into it with DOLFINx (``dolfinx.fem.petsc.assemble_matrix``) and the
    interfaces with :meth:`FrictionInterface.assemble_jacobian`: neither allocates.
    """
    return layout_of(V, interfaces).create_matrix()


def layout_of(V: dolfinx.fem.FunctionSpace, interfaces: Sequence[Any]) -> ExtendedLayout:
    """The :class:`~.layout.ExtendedLayout` of all interfaces on ``V`` (collective)."""
    parts = [el.layout_parts() for el in interfaces]
    if len(parts) == 1:
        return ExtendedLayout(V, parts[0][2], parts[0][3])
    imap, nodes = combined_index_map(
        V, [(g, o) for g, o, _, _ in parts], [(m, nd) for _, _, m, nd in parts]
    )
    return ExtendedLayout(V, imap, nodes)
