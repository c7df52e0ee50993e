"""The bodies' law as a hook (issue 21 item 2): modes of the built-in elasticity, a user's UFL
residual, a bulk with state committed, reverted and checkpointed.

* Every mode (plane strain, plane stress, axisymmetric, 3-D) on two bodies of one material
  pressed through a sticking interface: uniaxial stress, whose displacement is linear in the
  coordinates and so exact for P1 (in axisymmetric mode too: ``u_r / r`` is constant). Every dof
  against the closed form (the interface's compliance ``p / alpha_n`` included), and the
  interface's normal resultant against ``p A`` (axisymmetric: ``A = pi R^2``, the ``2 pi r``
  weight of the interface).
* :class:`~subfric_dolfinx.fem.UFLBulk`: the user's own elasticity residual in UFL (assembled at
  every iterate, or once with ``linear=True``, or as a form in the user's own unknown) gives the
  fast path's history.
* A bulk with quadrature-point state (the largest ``|eps_xx|`` of every cell over the converged
  steps): its forms reach the problem, ``update`` precedes each residual, ``commit`` after a
  converged step only (the state is the maximum over the converged steps, computed apart),
  ``revert`` restores, and a checkpoint carries the state to a differently partitioned problem.
"""

import numpy as np
import pytest
import ufl

from subfric_dolfinx.compat import interpolation_points
from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    FrictionSolver,
    InterfaceProblem,
    LinearElasticity,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
    UFLBulk,
)
from subfric_dolfinx.io import interface_summary, restore_checkpoint, write_checkpoint
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from tests.helpers import LAW, PROGRAM, SEC7_PENALTY, block_problem, column, everywhere

E, NU, P, ALPHA = 1.0e5, 0.3, 50.0, 1.0e6
STICK = CoulombLaw(alpha_t=ALPHA, alpha_n=ALPHA, mu_c=0.5)
RAMP = LoadingProgram([0.0, 1.0], {"press": [0.0, 1.0]})


def exact(mode: str, x: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Uniaxial compression ``p`` along the last axis, the upper body moved by ``p / alpha_n``."""
    gdim = 3 if mode == "3d" else 2
    lateral, axial = NU * P / E, -P / E  # plane stress, axisymmetric, 3-D
    if mode == "plane_strain":
        lateral, axial = NU * (1 + NU) * P / E, -(1 - NU**2) * P / E
    u = lateral * x[:, :gdim].copy()
    u[:, -1] = axial * x[:, gdim - 1] - np.where(upper, P / ALPHA, 0.0)
    return u


@pytest.mark.parametrize("mode", ["plane_strain", "plane_stress", "axisymmetric", "3d"])
def test_every_mode_against_uniaxial_stress(comm, mode):
    dom, bcs = column(mode, comm)
    problem = InterfaceProblem(
        dom,
        STICK,
        {"primary": Material(E, NU), "secondary": Material(E, NU)},
        RAMP,
        bcs,
        [Pressure("top", P, amplitude="press")],
        settings=ProblemSettings(mode=mode),
    )
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 1.0).run()
    V = problem.V
    gdim = problem.gdim
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    upper_cells = dom.body_cells("secondary")
    upper = np.zeros(n, dtype=bool)
    owned = V.dofmap.list[upper_cells].ravel()
    upper[owned[owned < n]] = True
    u = problem.u.x.array[: n * gdim].reshape(n, gdim)
    err = np.abs(u - exact(mode, x, upper)).max(initial=0.0)
    scale = P / E
    area = np.pi if mode == "axisymmetric" else 1.0
    s = interface_summary(problem)
    checks = {
        "displacement": err < 1e-9 * scale,
        "F_n": abs(s["F_n"] - P * area) < 1e-9 * P * area,
        "area": abs(s["area"] - area) < 1e-12 * area,
        "reaction": abs(abs(problem.reactions["bottom"][gdim - 1]) - P * area) < 1e-8 * P * area,
    }
    assert everywhere(comm, all(checks.values())), (checks, err, s["F_n"])


def history(problem, steps_to=None):
    out = []
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(
            solver, 0.25, on_step=lambda r: out.append(interface_summary(problem)["F_t1"])
        ).run(steps_to)
    return np.array(out)


def user_elasticity(u, v, ctx):
    """Plane-strain elasticity of the block problem's two bodies, as a user writes it."""
    out = 0
    for body, (E_, nu) in {"primary": (2.1e5, 0.3), "secondary": (7.0e4, 0.33)}.items():
        lam, mu = E_ * nu / ((1 + nu) * (1 - 2 * nu)), E_ / (2 * (1 + nu))
        eps = ufl.sym(ufl.grad(u))
        sig = 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(2)
        out = out + ufl.inner(sig, ufl.sym(ufl.grad(v))) * ctx.measure(body)
    return out


def with_bulk(comm, bulk, partitioner=None, base=None):
    p = base or block_problem(comm, partitioner=partitioner)
    return InterfaceProblem(
        p.domain,
        LAW,
        bulk,
        PROGRAM,
        [c for c, _, _ in p.dirichlet],
        [c.condition for c, _ in p.loads],
    )


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_users_ufl_residual_gives_the_fast_paths_history(comm):
    t_end = 3.0
    ref = history(block_problem(comm), t_end)
    peak = np.abs(ref).max()
    runs = {"assembled at every iterate": UFLBulk(user_elasticity)}
    runs["linear (assembled once)"] = UFLBulk(user_elasticity, linear=True)
    out = {k: history(with_bulk(comm, b), t_end) for k, b in runs.items()}
    # a form in the user's own unknown and test function, with its Jacobian
    p = block_problem(comm)
    import dolfinx

    u_user = dolfinx.fem.Function(p.V)
    v_user, du_user = ufl.TestFunction(p.V), ufl.TrialFunction(p.V)

    class Ctx:
        @staticmethod
        def measure(body):
            return ufl.Measure("dx", domain=p.mesh, subdomain_data=p.domain.cell_tags)(
                p.domain.tag(body)
            )

    F = user_elasticity(u_user, v_user, Ctx)
    J = ufl.derivative(F, u_user, du_user)
    out["a form in the user's u, with J"] = history(
        with_bulk(comm, UFLBulk(F, J, u=u_user), base=p), t_end
    )
    diffs = {k: float(np.abs(h - ref).max() / peak) for k, h in out.items()}
    assert everywhere(comm, all(d < 1e-10 for d in diffs.values())), diffs


class MaxStrain:
    """Elasticity, and the largest ``|eps_xx|`` of every cell over the converged steps (DG0)."""

    linear = False

    def __init__(self, materials):
        self.elastic = LinearElasticity(materials)
        self.updates = 0

    def forms(self, u, v, du, ctx):
        import dolfinx

        V0 = dolfinx.fem.functionspace(ctx.mesh, ("DG", 0))
        self.old, self.new = dolfinx.fem.Function(V0), dolfinx.fem.Function(V0)
        self.n = ctx.mesh.topology.index_map(ctx.mesh.topology.dim).size_local
        self.expr = dolfinx.fem.Expression(
            abs(ufl.sym(ufl.grad(u))[0, 0]), interpolation_points(V0)
        )
        F, _ = self.elastic.forms(u, v, du, ctx)
        return F, None

    def update(self, u):
        self.updates += 1
        self.new.interpolate(self.expr)
        np.maximum(self.new.x.array, self.old.x.array, out=self.new.x.array)

    def commit(self):
        self.old.x.array[:] = self.new.x.array

    def revert(self):
        self.new.x.array[:] = self.old.x.array

    def saved_state(self):
        return {"emax": self.old.x.array[: self.n].copy()}

    def restore_state(self, data):
        self.old.x.array[: self.n] = data["emax"]
        self.old.x.scatter_forward()
        self.revert()


def by_cell(problem, values):
    """(original cell index, value) over all ranks, sorted by the index."""
    mesh = problem.mesh
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    idx = np.asarray(mesh.topology.original_cell_index[:n])
    pairs = np.concatenate(mesh.comm.allgather(np.column_stack([idx, values[:n]])))
    return pairs[np.argsort(pairs[:, 0])]


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_bulk_with_state_is_updated_committed_reverted_and_checkpointed(comm, shared_tmp):
    import dolfinx

    bulk = MaxStrain({"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)})
    problem = with_bulk(comm, bulk)
    V0 = bulk.old.function_space
    probe = dolfinx.fem.Function(V0)
    expr = dolfinx.fem.Expression(abs(ufl.sym(ufl.grad(problem.u))[0, 0]), interpolation_points(V0))
    seen = np.zeros_like(probe.x.array)
    rows = []

    def on_step(rec):
        probe.interpolate(expr)
        np.maximum(seen, probe.x.array, out=seen)
        rows.append(interface_summary(problem)["F_t1"])

    with FrictionSolver(problem, linear="lu") as solver:
        stepper = LoadStepper(solver, 0.25, on_step=on_step)
        stepper.run(3.0)
        committed = bulk.old.x.array.copy()
        # a failed iterate changes the trial state only, and revert restores it
        x = solver.x.copy()
        x.scale(50.0)
        problem.residual(x, solver.F)
        moved = not np.array_equal(bulk.new.x.array, committed)
        problem.revert()
        reverted = np.array_equal(bulk.new.x.array, committed)
        write_checkpoint(shared_tmp / "ck.h5", problem, stepper, [{"F_t1": v} for v in rows])
    ref = history(block_problem(comm), 3.0)
    checks = {
        "updates": bulk.updates > len(rows),
        "max over converged steps": np.array_equal(committed, seen),
        "moved": comm.allreduce(int(moved)) > 0,
        "reverted": reverted,
        "history": np.abs(np.array(rows) - ref).max() < 1e-10 * np.abs(ref).max(),
    }
    # the state restored into a problem partitioned otherwise (one body per rank), by cell
    other = MaxStrain(bulk.elastic.materials)
    p3 = with_bulk(comm, other, partitioner="bodies")
    with FrictionSolver(p3) as s3:
        restore_checkpoint(shared_tmp / "ck.h5", p3, LoadStepper(s3, 0.25))
    a, b = by_cell(problem, committed), by_cell(p3, other.old.x.array)
    checks["restored by cell"] = np.array_equal(a, b)
    checks["trial = committed"] = np.array_equal(other.new.x.array, other.old.x.array)
    assert everywhere(comm, all(bool(v) for v in checks.values())), checks
