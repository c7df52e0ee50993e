"""The matrix pattern of a finite-sliding interface holds what its tangent writes, not all pairs.

The pattern couples each secondary facet's nodes with each other and with its reach's primary nodes,
and primary facets of one reach only where they are near enough to meet in one row of the
tangent (``reach._couplings``): the all-pairs pattern of a reach (every secondary facet's nodes
with every primary node of its reach, primary with primary) grows as the square of the reach's
width and took 19.5 GB at 184k dofs. The matrices are created with ``NEW_NONZERO_ALLOCATION_ERR``:
a tangent entry outside the pattern raises, so a sliding run over several facets that finishes
shows the pattern covers the tangent, and ``pattern_misses`` that no entry was left out. A
pattern made too small (no primary facet pairs) must leave the entries out, rebuild and give the
same forces.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx.fem.interface.finite.reach import ReachSearch
from subfric_dolfinx.fem.interface.layout import Couplings, ExtendedLayout
from tests.helpers import run_finite_pad

pytestmark = pytest.mark.three_ranks

N, STEPS = 6, 12  # 1/6 mm facets; press in 2, to +0.5 mm in 4, back to -0.5 mm in 6
REACH = 0.2  # mm: the largest slide of a step is 1/6 mm


def nnz(A: PETSc.Mat) -> int:
    return int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"])


def interface_of(problem):
    """The problem's only interface (finite-sliding)."""
    (it,) = problem.interfaces.values()
    return it


def layout_nnz(problem, couplings) -> int:
    """Nonzeros of the bulk and ``couplings`` on the interface's index map."""
    A = ExtendedLayout(problem.V, interface_of(problem).index_map, couplings).create_matrix()
    try:
        return nnz(A)
    finally:
        A.destroy()


def all_pairs(problem) -> np.ndarray:
    """The all-pairs pattern of the interface's current reach (the former one): element nodes."""
    it = interface_of(problem)
    s, reach = it.sides.secondary.nodes, it.search.reach
    elems = [
        np.unique(np.concatenate([s[f], reach.nodes[reach.idx[a:b]].ravel()]))
        for f, (a, b) in enumerate(zip(reach.ptr[:-1], reach.ptr[1:], strict=True))
    ]
    width = max((e.size for e in elems), default=s.shape[1])
    padded = [np.pad(e, (0, width - e.size), mode="edge") for e in elems]
    return np.array(padded, dtype=np.int32).reshape(-1, width)


def run(comm: MPI.Comm):
    """(step, [t, F_t1, F_n, Newton]) of the 12-step program, the interface and the nonzeros
    the interface adds to the bulk's pattern: its own and the all-pairs pattern's."""

    def sizes(pad):
        bulk = layout_nnz(pad.problem, Couplings(()))
        own = nnz(pad.solver.J) - bulk
        return pad, (own, layout_nnz(pad.problem, all_pairs(pad.problem)) - bulk)

    rows, (pad, added) = run_finite_pad(comm, N, STEPS, REACH, sizes)
    return rows, interface_of(pad.problem), added


def test_the_pattern_is_what_the_tangent_writes(comm, monkeypatch):
    rows, it, (n_new, n_all) = run(comm)
    assert rows.shape == (STEPS, 4)
    assert it.layout_version >= 2  # the pad slid 0.5 mm both ways: beyond its first reach
    assert comm.allreduce(it.search.pattern_misses) == 0  # no tangent entry left out (none raised)
    # n = 6: 194,706 against 311,814 (the reach is 3 x 0.2 mm + the facet on a 2 mm plate; the
    # all-pairs pattern grows as its square, this one as (reach + 2 facets)^2)
    assert n_new < 0.7 * n_all, (n_new, n_all)
    # no primary facet pairs at all: the primary rows' couplings are left out, then rebuilt
    monkeypatch.setattr(ReachSearch, "pattern_margin", -1e9)
    small, it_small, _ = run(comm)
    assert comm.allreduce(it_small.search.pattern_misses) > 0
    assert it_small.layout_version > it.layout_version
    peak = np.abs(rows[:, 1]).max()
    np.testing.assert_allclose(small[:, :3], rows[:, :3], rtol=0, atol=1e-6 * peak)
