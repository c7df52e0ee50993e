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


@pytest.mark.parametrize("push", ["top", "secondary_left"])
def test_dolfinx_newton_and_a_hand_written_loop_give_the_solvers_history(comm, push):
    mine = user_loop.run(comm, 8, 0.1, push)
    ref = user_loop.reference(comm, 8, 0.1, push)
    diff = {k: user_loop.difference(mine, ref, k) for k in ("F_t1", "F_n", "mu")}
    assert everywhere(comm, all(d < 1e-11 for d in diff.values())), diff
    assert everywhere(comm, max(abs(r["F_t1"]) for r in mine) > 0.05 * mine[-1]["F_n"])


def test_the_dolfinx_solver_is_freed_without_the_garbage_collector(comm):
    """``dolfinx_newton`` makes no reference cycle: its DOLFINx problem dies when the solver is
    dropped (a cycle left 0.11's ``NonlinearProblem.__del__``, a collective SNES destroy, to each
    rank's collector, at different moments: ``demos/user_loop.py`` hung on 2 ranks), and
    ``destroy`` frees the PETSc objects at once, on every rank."""
    import gc
    import weakref

    from subfric_dolfinx import compat
    from subfric_dolfinx.fem import FrictionInterface, create_matrix

    domain, V, u, F, J, bcs, p, _slide = user_loop.model(comm, 4)
    iface = FrictionInterface.from_mesh(V, domain, user_loop.law())
    A = create_matrix(V, [iface])

    def make():
        return compat.dolfinx_newton(
            F,
            u,
            bcs,
            J,
            A,
            add_residual=lambda x, b: iface.assemble_residual(b, x, bcs=bcs),
            add_jacobian=lambda x, mat: iface.assemble_jacobian(mat, x, bcs=bcs),
            prefix="freed_",
        )

    gc.disable()
    try:
        solver = make()
        alive = [weakref.ref(o) for o in solver._objects]
        del solver
        assert everywhere(comm, all(r() is None for r in alive)), "a reference cycle keeps it"
        with make() as solver:
            p.value = 1.0
            its, converged = solver.solve()
        assert everywhere(comm, converged and its >= 1)
        with pytest.raises(RuntimeError, match="destroyed"):
            solver.solve()
        solver.destroy()  # idempotent
    finally:
        gc.enable()
        iface.destroy()
        A.destroy()
