"""A user's bulk form of the wrong kind is refused before assembly, naming the bulk model.

A :class:`~subfric_dolfinx.fem.UFLBulk` whose residual is a bilinear form (a ``TrialFunction``
in ``F``) corrupted the heap (SIGABRT on 1 rank, SIGSEGV and an MPI abort on 2); a residual of
rank 0, a Jacobian of rank 1, a test function of another space ended in a C++ ``IndexError`` or
in a :class:`~subfric_dolfinx.fem.StepFailure` blaming the interface, and a NaN produced by the
bulk form was reported as an interface separation. Every user form is now checked (kind, rank,
arguments, the test and trial functions' space against the problem's ``V``, the mesh of its
integrals and coefficients) when the problem is built: a ``ValueError`` on every rank that
names the bulk (``UFLBulk(<its function>)``) and what is wrong; a bulk residual that is not
finite ends the step as the bulk's fault, said first. 1 and 2 ranks.
"""

import dolfinx
import pytest
import ufl
from mpi4py import MPI

from subfric_dolfinx.fem import (
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    StepControl,
    StepFailure,
    UFLBulk,
)
from tests.fem.test_bulk import user_elasticity
from tests.helpers import LAW, PROGRAM, block_problem, prefix, raised_on_every_rank


@pytest.fixture(scope="module")
def base():
    return block_problem(MPI.COMM_WORLD)


def problem(base, bulk):
    return InterfaceProblem(
        base.domain,
        LAW,
        bulk,
        PROGRAM,
        [c for c, _, _ in base.dirichlet],
        [c.condition for c, _ in base.loads],
    )


def bilinear(u, v, ctx):
    return user_elasticity(ufl.TrialFunction(ctx.V), v, ctx)


def energy(u, v, ctx):
    return ufl.inner(u, u) * ctx.dx


def no_measure(u, v, ctx):
    return ufl.inner(u, v)


def scalar_test(u, v, ctx):
    W = dolfinx.fem.functionspace(ctx.mesh, ("Lagrange", 1))
    return ufl.TestFunction(W) * ctx.dx


def p2_test(u, v, ctx):
    W = dolfinx.fem.functionspace(ctx.mesh, ("Lagrange", 2, (2,)))
    return user_elasticity(u, ufl.TestFunction(W), ctx)


def own_space_test(u, v, ctx):
    """A space built like V, but not V: its dofs are not the problem's."""
    W = dolfinx.fem.functionspace(ctx.mesh, ("Lagrange", 1, (2,)))
    return user_elasticity(u, ufl.TestFunction(W), ctx)


def other_mesh(u, v, ctx):
    other = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)
    f = dolfinx.fem.Function(dolfinx.fem.functionspace(other, ("Lagrange", 1, (2,))))
    return user_elasticity(u, v, ctx) + ufl.inner(f, v) * ctx.dx


def rank1_jacobian(u, v, du, ctx):
    return user_elasticity(u, v, ctx)


def mixed_jacobian(u, v, du, ctx):
    W = dolfinx.fem.functionspace(ctx.mesh, ("Lagrange", 2, (2,)))
    return ufl.inner(du, v) * ctx.dx + ufl.inner(ufl.TrialFunction(W), v) * ctx.dx


def scalar_jacobian(u, v, du, ctx):
    W = dolfinx.fem.functionspace(ctx.mesh, ("Lagrange", 1))
    return ufl.TrialFunction(W) * v[0] * ctx.dx


CASES = {
    "bilinear residual": (UFLBulk(bilinear), ["UFLBulk(bilinear)", "rank 2", "TrialFunction"]),
    "rank 0 residual": (UFLBulk(energy), ["UFLBulk(energy)", "rank 0"]),
    "no measure": (UFLBulk(no_measure), ["UFLBulk(no_measure)", "not a UFL form", "ctx.dx"]),
    "scalar test function": (UFLBulk(scalar_test), ["UFLBulk(scalar_test)", "another space"]),
    "P2 test function": (UFLBulk(p2_test), ["UFLBulk(p2_test)", "test function", "another space"]),
    "a copy of V": (UFLBulk(own_space_test), ["UFLBulk(own_space_test)", "another space"]),
    "other mesh": (UFLBulk(other_mesh), ["UFLBulk(other_mesh)", "another mesh"]),
    "rank 1 Jacobian": (
        UFLBulk(user_elasticity, rank1_jacobian),
        ["UFLBulk(user_elasticity)", "Jacobian J has rank 1"],
    ),
    "mixed Jacobian": (
        UFLBulk(user_elasticity, mixed_jacobian),
        ["UFLBulk(user_elasticity)", "Jacobian J", "different spaces"],
    ),
    "scalar trial function": (
        UFLBulk(user_elasticity, scalar_jacobian),
        ["UFLBulk(user_elasticity)", "trial function of its Jacobian J", "another space"],
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bulk_form_of_the_wrong_kind_is_refused_naming_the_bulk(base, case):
    bulk, words = CASES[case]
    with raised_on_every_rank(ValueError, "the bulk model", *words):
        problem(base, bulk)


def user_form(base, make_test=None, make_trial=None, degree=1):
    """A form in the user's own unknown and test (and trial) functions."""
    V = base.V
    W = dolfinx.fem.functionspace(base.mesh, ("Lagrange", degree, (2,)))
    u = dolfinx.fem.Function(W)
    v = make_test(base.mesh) if make_test else ufl.TestFunction(V)
    dx = ufl.Measure("dx", domain=base.mesh)
    F = ufl.inner(ufl.grad(u), ufl.grad(v)) * dx if make_test is None else v[0] * dx
    if make_trial is not None:
        F = ufl.inner(make_trial(V), v) * dx
    return F, u


def test_a_form_in_the_users_own_functions_of_another_space_is_refused(base):
    F, u = user_form(base, degree=2)  # the user's unknown of degree 2
    with raised_on_every_rank(ValueError, "UFLBulk(a UFL form)", "the unknown u", "another space"):
        problem(base, UFLBulk(F, u=u))
    F, u = user_form(
        base,
        make_test=lambda m: ufl.TestFunction(dolfinx.fem.functionspace(m, ("Lagrange", 1, (3,)))),
    )
    with raised_on_every_rank(ValueError, "UFLBulk(a UFL form)", "test function", "another space"):
        problem(base, UFLBulk(F, u=dolfinx.fem.Function(base.V)))
    F, _ = user_form(base, make_trial=ufl.TrialFunction)  # bilinear: refused, not assembled
    with raised_on_every_rank(ValueError, "UFLBulk(a UFL form)", "rank 2", "TrialFunction"):
        problem(base, UFLBulk(F, u=dolfinx.fem.Function(base.V)))


def nan_residual(u, v, ctx):
    """Elasticity plus a term that is NaN everywhere in a body (the root of a negative)."""
    return user_elasticity(u, v, ctx) + ufl.sqrt(-1 - ufl.inner(u, u)) * v[0] * ctx.measure(
        "secondary"
    )


def nan_jacobian(u, v, ctx):
    """Elasticity plus ``|u|``: a finite residual, a Jacobian ``u / |u|`` NaN at ``u = 0``."""
    return user_elasticity(u, v, ctx) + ufl.sqrt(ufl.inner(u, u)) * v[0] * ctx.measure("secondary")


@pytest.mark.parametrize(("form", "what"), [(nan_residual, "residual"), (nan_jacobian, "Jacobian")])
def test_a_nan_of_the_bulk_form_is_reported_as_the_bulks(base, form, what):
    p = problem(base, UFLBulk(form))
    with FrictionSolver(p, prefix("nan"), linear="lu") as solver:
        stepper = LoadStepper(solver, 0.5, control=StepControl(max_cuts=1))
        with raised_on_every_rank(
            StepFailure,
            f"the bulk model UFLBulk({form.__name__}) gave a {what} that is not finite",
            "the last converged step is 0",
            match=r"^(?!.*(SEPARATED|return map))",  # not an interface's fault
        ):
            stepper.run()
