"""Parallel layout with cross-interface couplings: vectors and a preallocated matrix.

The displacement index map is extended with the other side's nodes as extra ghosts (see
:func:`~.pairing.pair_interface`): owned ranges and global numbers are unchanged, so vectors and
matrices built on it are compatible with DOLFINx's own assembly (local indices of the original
dofs are a prefix of the extended local indices). The sparsity pattern holds every bulk cell's
block and every interface element's master-slave block, so that assembling the Jacobian never
allocates (checked with PETSc's malloc count in the tests).
"""

from __future__ import annotations

import dolfinx
import numpy as np
from dolfinx.cpp.la import SparsityPattern
from petsc4py import PETSc

from ...compat import ghosted_index_map, petsc_vector

__all__ = ["ExtendedLayout", "combined_index_map"]


def combined_index_map(
    V: dolfinx.fem.FunctionSpace,
    extras: list[tuple[np.ndarray, np.ndarray]],
    nodes: list[tuple[dolfinx.common.IndexMap, np.ndarray]],
) -> tuple[dolfinx.common.IndexMap, list[np.ndarray]]:
    """One index map for several interfaces, and their element nodes in its local numbering.

    Args:
        V: The displacement space.
        extras: For each interface, its extra ghosts (global numbers) and their owners.
        nodes: For each interface, its own extended index map and its element nodes (local in it).

    Returns:
        ``V``'s index map extended with the union of the extra ghosts (first appearance order),
        and each interface's element nodes, local in it (one array per interface: widths may
        differ between interfaces).
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
    out = []
    for m, nd in nodes:
        nd = np.asarray(nd, dtype=np.int64)
        local = nd.copy()
        far = nd >= n0
        if np.any(far):
            g = m.local_to_global(nd[far].astype(np.int32))
            local[far] = n0 + sorter[np.searchsorted(extra_g, g, sorter=sorter)]
        out.append(local.astype(np.int32))
    return imap, out


class ExtendedLayout:
    """Vectors and matrices on a displacement space extended by interface ghosts.

    Args:
        V: The displacement space.
        index_map: Its index map extended with the interface's extra ghosts.
        element_nodes: Local (extended) node indices of each interface element, (nf, n), or one
            such array per interface (each element's nodes are coupled with each other).
    """

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        index_map: dolfinx.common.IndexMap,
        element_nodes: np.ndarray | list[np.ndarray],
    ) -> None:
        self.V = V
        self.index_map = index_map
        self.bs = V.dofmap.bs
        self.comm = V.mesh.comm
        imap0 = V.dofmap.index_map
        self.n_owned = imap0.size_local * self.bs
        self.n_local0 = (imap0.size_local + imap0.num_ghosts) * self.bs
        if isinstance(element_nodes, np.ndarray):
            element_nodes = [element_nodes]
        self.element_nodes = list(element_nodes)

    def create_vector(self) -> PETSc.Vec:
        """A ghosted vector whose ghosts include the interface's extra ghosts."""
        return petsc_vector(self.index_map, self.bs)

    def sparsity(self) -> SparsityPattern:
        """Bulk cell blocks plus interface master-slave blocks, finalised."""
        sp = SparsityPattern(self.comm, [self.index_map, self.index_map], [self.bs, self.bs])
        cells = self.V.dofmap.list
        for c in range(cells.shape[0]):
            row = cells[c]
            sp.insert(row, row)
        for nodes in self.element_nodes:
            for row in nodes:
                sp.insert(row, row)
        sp.finalize()
        return sp

    def create_matrix(self) -> PETSc.Mat:
        """An assembled AIJ matrix holding explicit zeros on the pattern of :meth:`sparsity`.

        The zeros fix the structure: later assemblies add into existing entries (no mallocs), and
        matrices made here share one structure (``SAME_NONZERO_PATTERN`` operations are valid).
        """
        A = dolfinx.cpp.la.petsc.create_matrix(self.comm, self.sparsity())
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        bs = self.bs
        for blocks in (self.V.dofmap.list, *self.element_nodes):
            blocks = np.ascontiguousarray(blocks, dtype=PETSc.IntType)
            n = blocks.shape[1] * bs if blocks.size else 0
            for start in range(0, blocks.shape[0], 4096):
                chunk = blocks[start : start + 4096]
                zeros = np.zeros((chunk.shape[0], n, n), dtype=PETSc.ScalarType)
                A.setValuesBlockedLocalRCV(chunk, chunk, zeros, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()
        return A
