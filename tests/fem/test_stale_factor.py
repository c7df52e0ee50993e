"""A reused factor outlives a change of a finite-sliding problem's pattern (``"reuse"``).

Where an interface pairs again as the bodies move, its pattern is rebuilt when a point slides
beyond its reach; the factor of a former Jacobian is still an operator of the right size and
preconditions the new Jacobian like any stale factor, until the refresh rules ask for a new one.
In 3-D it is the factor of a compact copy of the Jacobian (its entries alone); in 2-D a new
pattern refreshes (a copy on the new pattern). Each run takes the
Newton iterations of ``"lu"`` at every step (one more at the first) and gives its history
within 1e-8 of the peak, with fewer factorisations than Newton iterations; a Krylov solve that
fails with such a factor is repeated with fresh ones. 1 and 2 ranks.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from benchmarks import finite_cost
from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepControl
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.logs import OverhangWarning
from tests.helpers import leaves_validity, prefix

PAD_N, BLOCK_N = 6, 20
PAD_REACH, BLOCK_REACH = 0.2, 0.02  # mm: a rebuilt pattern while the bodies slide


def run(comm, case: str, linear: str, options=None):
    """Per step ``(t, F_t1, F_n, Newton, layout changed, refreshed, retried)``, the solver's
    linear stats and whether the SNES's preconditioning matrix is the strategy's compact copy."""
    n, reach = (PAD_N, PAD_REACH) if case == "pad" else (BLOCK_N, BLOCK_REACH)
    problem, solver, dt = finite_cost.build(comm, case, n, "finite_sliding", True, linear, reach)
    if options:
        solver.destroy()
        solver = FrictionSolver(problem, prefix(linear), options, linear=linear)
    rows: list[list[float]] = []
    seen = {"layout": problem.layout_version, "refreshes": 0, "retries": 0}

    def on_step(rec):
        s = interface_summary(problem)
        now = {
            "layout": problem.layout_version,
            "refreshes": solver.linear.refreshes,
            "retries": solver.linear.retries,
        }
        moved = [now[k] != seen[k] for k in ("layout", "refreshes", "retries")]
        seen.update(now)
        rows.append([rec.t, s["F_t1"], s["F_n"], rec.iterations, *moved])

    # the block slides past the end of its base (its points beyond open)
    overhang = leaves_validity(OverhangWarning) if case == "block" else contextlib.nullcontext()
    try:
        with overhang:
            LoadStepper(solver, dt, control=StepControl(dt_max=dt), on_step=on_step).run()
        compact = solver.linear.compact
        _, P = solver.snes.getKSP().getOperators()
        is_copy = compact is not None and compact.P is not None and P.handle == compact.P.handle
        return np.array(rows), solver.linear.stats, is_copy
    finally:
        solver.destroy()
        problem.destroy()


_LU: dict[str, np.ndarray] = {}


def lu_rows(comm, case: str) -> np.ndarray:
    """The rows of ``case``'s run with ``"lu"`` (made once per process: the reference)."""
    if case not in _LU:
        _LU[case] = run(comm, case, "lu")[0]
    return _LU[case]


def same_newton(rows: np.ndarray, lu: np.ndarray) -> bool:
    """The Newton iterations of LU at every step; one allowed difference: the first step,
    which LU ends at the tolerance's edge, takes a Krylov solve (its first iterations exact to
    1 % of Newton's target) one more (so does the run without a kept factor)."""
    its, its_lu = rows[:, 3].astype(int).tolist(), lu[:, 3].astype(int).tolist()
    return len(its) == len(its_lu) and its[1:] == its_lu[1:] and its[0] - its_lu[0] in (0, 1)


@pytest.mark.parametrize("case", ["pad", "block"])
def test_the_factor_outlives_a_new_pattern(comm, case):
    lu = lu_rows(comm, case)
    rows, stats, is_copy = run(comm, case, "reuse")
    assert is_copy == (case == "pad")  # 3-D: the compact copy is factorised
    changed, refreshed = rows[:, 4].astype(bool), rows[:, 5].astype(bool)
    assert changed.sum() >= 1
    if case == "pad":  # a step on a new pattern with the old factor
        assert np.any(changed & ~refreshed), rows[:, 3:]
    else:  # 2-D: every new pattern refreshes
        assert np.all(refreshed[changed]), rows[:, 3:]
    assert stats["refreshes"] < rows[:, 3].sum() / 2 and stats["retries"] == 0
    assert same_newton(rows, lu)
    peak = np.abs(lu[:, 1:3]).max()
    np.testing.assert_allclose(rows[:, :3], lu[:, :3], rtol=0, atol=1e-8 * peak)


@pytest.mark.parametrize("case", ["pad", "block"])
def test_a_stale_factor_that_fails_is_refreshed(comm, case):
    """GMRES limited to 3 iterations: a stale factor fails (in 3-D also one kept across a new
    pattern); the Newton solve is repeated with fresh factors and the run equals LU's."""
    lu = lu_rows(comm, case)
    rows, stats, _ = run(comm, case, "reuse", {"ksp_max_it": 3})
    changed, retried = rows[:, 4].astype(bool), rows[:, 6].astype(bool)
    assert stats["retries"] > 0, rows[:, 3:]
    assert np.any(changed & retried) or case == "block", rows[:, 3:]
    assert same_newton(rows, lu)
    peak = np.abs(lu[:, 1:3]).max()
    np.testing.assert_allclose(rows[:, :3], lu[:, :3], rtol=0, atol=1e-8 * peak)
