"""The interface in the user's own loop (issue 21 item 4): DOLFINx's own nonlinear solver and a
hand-written time loop give ``FrictionSolver`` + ``LoadStepper``'s history to round-off.

``demos/user_loop.py`` runs both on the suite's ranks; with the block pushed at its left flank,
whose Dirichlet condition holds an interface node, the interface's rows and columns of that node
are left to DOLFINx's lifting (:meth:`~subfric_dolfinx.fem.FrictionInterface.assemble_residual`
with ``bcs``), and the history is still the same.
"""

import pytest

from demos import user_loop
from tests.helpers import everywhere


@pytest.mark.parametrize("push", ["top", "slave_left"])
def test_dolfinx_newton_and_a_hand_written_loop_give_the_solvers_history(comm, push):
    mine = user_loop.run(comm, 8, 0.1, push)
    ref = user_loop.reference(comm, 8, 0.1, push)
    diff = {k: user_loop.difference(mine, ref, k) for k in ("F_t1", "F_n", "mu")}
    assert everywhere(comm, all(d < 1e-11 for d in diff.values())), diff
    assert everywhere(comm, max(abs(r["F_t1"]) for r in mine) > 0.05 * mine[-1]["F_n"])
