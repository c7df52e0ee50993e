"""A factorisation of a Jacobian whose pattern is wider than its entries takes a compact copy.

A finite-sliding interface's pattern holds every pairing until its next search; a factorisation
of the matrix as stored orders and fills that whole pattern. In 3-D ``"lu"`` factorises a copy
that holds the entries alone (:class:`subfric_dolfinx.fem.linear.CompactCopy`): its values are
the matrix's, a later matrix whose entries it holds keeps its pattern (PETSc keeps the symbolic
factorisation), one with an entry beyond it makes a new copy. A finite-sliding run with it takes
the Newton iterations and gives the history of the run that factorises the matrix as stored, to
round-off, with fewer entries in the factor (a 2-D problem factorises its matrix as stored);
1 and 2 ranks.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from benchmarks import finite_cost
from subfric_dolfinx.fem.linear import CompactCopy, nonzeros
from subfric_dolfinx.fem.problem import InterfaceProblem
from tests.helpers import run_finite_pad

N, STEPS, REACH = 6, 12, 0.2  # tests/fem/interface/finite/test_finite_sliding_pattern.py's pad


def banded(comm, values: dict[int, float]) -> PETSc.Mat:
    """A matrix of 5 rows per rank whose pattern holds the offsets -2..2 of the diagonal.

    ``values``: offset -> value (the diagonal 4, the other stored offsets explicit zeros).
    """
    n = 5 * comm.size
    A = PETSc.Mat().createAIJ([n, n], nnz=5, comm=comm)
    r0, r1 = A.getOwnershipRange()
    for i in range(r0, r1):
        for k in range(-2, 3):
            if 0 <= i + k < n:
                v = 4.0 + i if k == 0 else values.get(k, 0.0) * (1 + 0.1 * i)
                A.setValue(i, i + k, v)
    A.assemble()
    return A


def entries(A: PETSc.Mat) -> dict[tuple[int, int], float]:
    """The stored entries of the owned rows, (row, column) -> value."""
    indptr, cols, vals = A.getValuesCSR()
    r0 = A.getOwnershipRange()[0]
    return {
        (r0 + i, int(c)): float(v)
        for i in range(indptr.size - 1)
        for c, v in zip(
            cols[indptr[i] : indptr[i + 1]], vals[indptr[i] : indptr[i + 1]], strict=True
        )
    }


def test_the_copy_holds_the_entries_and_keeps_its_pattern(comm):
    J1 = banded(comm, {-1: -1.0, 1: -1.5})  # offsets +-2 stored as zeros
    J2 = banded(comm, {-1: -2.0, 1: -0.5})  # the same entries, other values
    J3 = banded(comm, {-1: -2.0, 1: -0.5, 2: 0.25})  # one offset more
    c = CompactCopy()
    try:
        assert c.update(J1) and c.patterns == 1
        assert c.P is not None
        held = entries(c.P)
        assert held == {k: v for k, v in entries(J1).items() if v != 0.0}
        assert {k[1] - k[0] for k in held} == {-1, 0, 1}
        first = c.P
        assert not c.update(J2) and c.patterns == 1 and c.P is first  # the same pattern
        assert entries(c.P) == {k: v for k, v in entries(J2).items() if v != 0.0}
        assert not c.update(J1) and c.P is first  # fewer entries: held too
        assert c.update(J3) and c.patterns == 2 and c.P is not first  # one beyond: a new copy
        assert entries(c.P) == {k: v for k, v in entries(J3).items() if v != 0.0}
        # its factor solves the matrix's equations
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(J3, c.P)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        b = J3.createVecLeft()
        b.setArray(np.arange(1.0, 1.0 + b.getLocalSize()) + b.getOwnershipRange()[0])
        x = J3.createVecRight()
        ksp.solve(b, x)
        r = b.duplicate()
        J3.mult(x, r)
        r.axpy(-1.0, b)
        assert r.norm() <= 1e-13 * b.norm()
        ksp.destroy()
    finally:
        c.destroy()
        for A in (J1, J2, J3):
            A.destroy()


def test_nonzeros_keep_the_diagonal(comm):
    A = banded(comm, {1: 1.0})
    r0 = A.getOwnershipRange()[0]
    A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
    A.zeroRows([r0], diag=0.0)  # a zero diagonal entry (on every rank)
    indptr, cols, vals = nonzeros(A)
    assert cols[indptr[0] : indptr[1]].tolist() == [r0]  # the zero diagonal kept, alone
    assert vals[indptr[0]] == 0.0
    assert np.all(vals[indptr[1] :] != 0.0)
    A.destroy()


def run(comm):
    """(t, F_t1, F_n, Newton) per step of the pad meshed apart, and the solver's factor size."""

    def factor(pad):
        F = pad.solver.snes.getKSP().getPC().getFactorMatrix()
        compact = pad.solver.linear.compact
        return F.getMumpsInfog(29), None if compact is None else compact.patterns

    rows, (size, patterns) = run_finite_pad(comm, N, STEPS, REACH, factor)
    return rows, size, patterns


def test_a_finite_sliding_run_factorises_the_compact_copy(comm, monkeypatch):
    rows, size, patterns = run(comm)
    _, block, _ = finite_cost.build(comm, "block", 6, "finite_sliding", linear="lu")
    assert block.strategy == "lu" and block.linear.compact is None  # 2-D: the matrix as stored
    block.destroy()
    assert patterns is not None  # finite sliding: the pattern is wider than the entries
    assert 1 <= patterns < rows[:, 3].sum()  # the symbolic factorisation kept within steps
    monkeypatch.setattr(InterfaceProblem, "compact_factor", property(lambda self: False))
    stored, stored_size, none = run(comm)
    assert none is None
    assert size < 0.9 * stored_size, (size, stored_size)
    np.testing.assert_array_equal(rows[:, 3], stored[:, 3])
    peak = np.abs(stored[:, 1:3]).max()
    np.testing.assert_allclose(rows[:, :3], stored[:, :3], rtol=0, atol=1e-10 * peak)
