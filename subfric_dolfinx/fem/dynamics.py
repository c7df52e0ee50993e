"""Inertia of the bodies: implicit generalised-alpha time integration (Chung and Hulbert, 1993).

A problem given :class:`Dynamics` settings (:class:`~.conditions.ProblemSettings`' ``dynamics``)
solves, at each step from ``t_n`` to ``t_{n+1} = t_n + dt``, the equation of motion::

    M a_{n+1-am} + C v_{n+1-af} + (1 - af) G(u_{n+1}, t_{n+1}) + af G(u_n, t_n) = 0

on the free rows, with ``G(u, t) = F_bulk(u) + sum_i R_i(u) - f_ext(t)`` the quasi-static residual
(:class:`~.problem.InterfaceProblem`: bodies, interfaces, loads), ``M`` the consistent mass
matrix ``int rho v . du dx`` (times ``2 pi r`` in axisymmetric mode), ``C = alpha_M M + alpha_K
K`` Rayleigh damping (``K`` the bodies' stiffness at rest), ``x_{n+1-a} = (1 - a) x_{n+1} + a
x_n`` and Newmark's relations::

    u_{n+1} = u_n + dt v_n + dt^2 ((1/2 - beta) a_n + beta a_{n+1})
    v_{n+1} = v_n + dt ((1 - gamma) a_n + gamma a_{n+1})

The parameters follow from the spectral radius at infinite frequency ``rho_inf`` in [0, 1]
(:func:`coefficients`): ``am = (2 rho_inf - 1) / (rho_inf + 1)``, ``af = rho_inf / (rho_inf +
1)``, ``gamma = 1/2 - am + af``, ``beta = (1 - am + af)^2 / 4``. ``rho_inf = 1`` is Newmark's
average acceleration (``am = af = 1/2``, ``beta = 1/4``, ``gamma = 1/2``: no numerical
dissipation, the energy of a linear system is conserved exactly); smaller values damp the high
frequencies (``rho_inf = 0``: asymptotic annihilation).

The interfaces enter through ``G`` as in the quasi-static problem: their law is integrated over
the step to ``u_{n+1}`` (the return map, its recovery over ``dt``), and the force of the step's
start is the converged one of the last step; the mixing ``(1 - af) G_{n+1} + af G_n`` is the
generalised-trapezoidal form of the method (the forces, not the displacements, at the
intermediate time), which keeps each law a function of the end-of-step state. Dirichlet rows
stay ``u - g(t_{n+1})``; the velocity and acceleration of their dofs follow from Newmark's
relations. The initial acceleration is consistent with the initial state: ``M a_0 = -G(u_0,
t_0) - C v_0`` (free rows; 0 on the Dirichlet ones), one linear solve with ``M`` before the first
step.

Units (MPa, mm, s): density in tonne/mm^3 (steel: 7.85e-9), so that ``rho a`` is in N/mm^3 (MPa/
mm); velocities in mm/s, accelerations in mm/s^2; ``alpha_M`` in 1/s, ``alpha_K`` in s.

Energy accounts (:attr:`Inertia.energy`, one row per converged step in the history), all in
mJ (N mm; per unit thickness in plane strain and plane stress, over the revolution in
axisymmetric mode):

* ``E_kinetic`` ``= v M v / 2``;
* ``E_strain``: the bodies' strain energy ``u K u / 2`` (``K`` with the springs; a nonlinear
  bulk: the work done on it, stored and dissipated) plus the interfaces' elastic energy
  ``sum w (|f_t|^2 / (2 alpha_t) + f_n^2 / (2 alpha_n))`` at their points;
* ``W_external``: the work of the loads and of the supports (the reactions on the prescribed
  displacements), each step's ``du . f_{n+1-af}``;
* ``D_friction``: the work of the plastic slip, ``sum w f_t,{n+1} . (up_{n+1} - up_n)`` at the
  interfaces' points (the return map's own dissipation);
* ``D_damping``: the Rayleigh damping's work ``du . C v_{n+1-af}``;
* ``D_numerical``: the integrator's dissipation: each force's work over the step minus the
  change of the energy it stands for (inertia: ``du . M a_{n+1-am} - dE_kinetic``; the bodies:
  ``du . K u_{n+1-af} - dE``, ``(1/2 - af) du K du``; the interfaces: their forces' work minus
  their elastic energy's change and ``D_friction``);
* ``E_balance`` ``= W_external - (E_kinetic + E_strain - E_0) - D_friction - D_damping -
  D_numerical`` (``E_0`` the initial energy): what Newton's residual left, ``-sum du . R``
  over the free rows; zero to Newton's tolerance.

The interfaces' elastic energy and friction dissipation are those of a penalty law, ``f_t =
alpha_t (ubar_t - up)`` and ``f_n = alpha_n ubar_n`` in contact (every law of the package); a
law without ``alpha_t``, ``alpha_n`` or the variable ``up`` gives ``NaN`` for them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from ..meshing.topology import ROLES
from .kinematics import weight

if TYPE_CHECKING:
    from .problem import InterfaceProblem

__all__ = ["ENERGY_COLUMNS", "INTERFACE_FORCES", "Dynamics", "Inertia", "coefficients"]

INTERFACE_FORCES = ("mixed", "end")
"""How the interfaces' forces enter a step's equation (:attr:`Dynamics.interface_forces`)."""

ENERGY_COLUMNS = (
    "E_kinetic",
    "E_strain",
    "W_external",
    "D_friction",
    "D_damping",
    "D_numerical",
    "E_balance",
)
"""The energy accounts of a dynamic run, in this order (mJ; module docstring)."""


@dataclasses.dataclass(frozen=True)
class Dynamics:
    """The settings of a dynamic problem (inertia, damping, initial velocity).

    Attributes:
        density: Body or cell-group name -> its density (tonne/mm^3, > 0; steel 7.85e-9);
            every cell of the mesh must get one (a group's value wins over its body's); keyed
            as the problem's materials (``primary``/``secondary``, or ``master``/``slave``,
            name the first interface's bodies).
        rho_inf: The spectral radius at infinite frequency, in [0, 1] (1: Newmark's average
            acceleration, no numerical dissipation).
        alpha_m: Rayleigh damping's mass coefficient (1/s, >= 0).
        alpha_k: Rayleigh damping's stiffness coefficient (s, >= 0), on the bodies' stiffness
            at rest (with the springs).
        initial_velocity: Body or cell-group name -> its initial velocity (a vector of
            ``gdim`` components, mm/s); bodies not named start at rest.
        gravity: A body force ``rho g`` per unit volume, ``g`` (mm/s^2, ``gdim`` components),
            constant in time; ``None``: none.
        interface_forces: ``"mixed"`` (the default): the interfaces' forces enter the step's
            equation as the bodies' do, ``(1 - af) R(u_{n+1}) + af R(u_n)`` (average
            acceleration conserves an elastic interface's energy exactly); ``"end"``: at the
            step's end alone, ``R(u_{n+1})``, which never gains energy where a contact closes
            or opens within a step (impacts, chatter: the mixed form's trapezoid there can
            create energy without bound, ``D_numerical < 0``), at the price of dissipating an
            elastic interface's energy by ``alpha du^2 / 2`` a step.
    """

    density: Mapping[str, float]
    rho_inf: float = 1.0
    alpha_m: float = 0.0
    alpha_k: float = 0.0
    initial_velocity: Mapping[str, Sequence[float]] = dataclasses.field(default_factory=dict)
    gravity: Sequence[float] | None = None
    interface_forces: str = "mixed"

    def __post_init__(self) -> None:
        if not self.density:
            raise ValueError("dynamics: no density given (body name -> tonne/mm^3)")
        for name, rho in self.density.items():
            if not (isinstance(rho, int | float) and math.isfinite(rho) and rho > 0):
                raise ValueError(f"dynamics: the density of {name!r} must be > 0, got {rho!r}")
        if not (isinstance(self.rho_inf, int | float) and 0.0 <= self.rho_inf <= 1.0):
            raise ValueError(f"dynamics: rho_inf must be in [0, 1], got {self.rho_inf!r}")
        if self.interface_forces not in INTERFACE_FORCES:
            raise ValueError(
                f"dynamics: interface_forces must be one of {list(INTERFACE_FORCES)}, got "
                f"{self.interface_forces!r}"
            )
        for key in ("alpha_m", "alpha_k"):
            v = getattr(self, key)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"dynamics: {key} must be >= 0, got {v!r}")
        vectors = [("gravity", self.gravity)] if self.gravity is not None else []
        vectors += [(f"initial_velocity[{k!r}]", v) for k, v in self.initial_velocity.items()]
        for what, v in vectors:
            arr = np.asarray(v, dtype=float)
            if arr.ndim != 1 or not np.all(np.isfinite(arr)):
                raise ValueError(f"dynamics: {what} must be a vector of numbers, got {v!r}")


def coefficients(rho_inf: float) -> tuple[float, float, float, float]:
    """Chung and Hulbert's ``(am, af, beta, gamma)`` for the spectral radius ``rho_inf``.

    Second-order accurate, unconditionally stable for linear problems, with the least
    low-frequency dissipation for a given high-frequency one.
    """
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 - am + af
    beta = 0.25 * (1.0 - am + af) ** 2
    return am, af, beta, gamma


def _penalties(law: Any, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Each point's ``(alpha_t, alpha_n)`` (a regional law: its point's law's), or ``None``."""
    laws = getattr(law, "laws", None)
    region = getattr(law, "region", None)
    try:
        if laws is not None and region is not None and len(region) == n:
            at = np.array([float(la.alpha_t) for la in laws])[region]
            an = np.array([float(la.alpha_n) for la in laws])[region]
            return at, an
        return np.full(n, float(law.alpha_t)), np.full(n, float(law.alpha_n))
    except (AttributeError, TypeError, ValueError):
        return None


class Inertia:
    """The inertia terms of a problem: mass, damping, the generalised-alpha state and energies.

    Made by :class:`~.problem.InterfaceProblem` when its settings have ``dynamics``; it adds its
    terms to the problem's residual and Jacobian, keeps the committed velocity and acceleration
    (:attr:`velocity`, :attr:`acceleration`, owned values in the displacement's layout) and the
    energy accounts (:attr:`energy`).

    Args:
        problem: The problem (its space, bodies, loads and interfaces are built).
        settings: The :class:`Dynamics` settings.

    Raises:
        ValueError: A density or initial velocity for a group the mesh lacks, cells without a
            density, a vector of the wrong size.
    """

    def __init__(self, problem: InterfaceProblem, settings: Dynamics) -> None:
        self.problem = problem
        self.settings = settings
        self.am, self.af, self.beta, self.gamma = coefficients(float(settings.rho_inf))
        self.at_end = settings.interface_forces == "end"
        V = problem.V
        mesh = problem.mesh
        ctx = problem.bulk_context
        gdim = problem.gdim
        tdim = mesh.topology.dim
        cell_tags = problem.domain.cell_tags
        # the density per cell: bodies first, then their groups (a group's value wins)
        Q = dolfinx.fem.functionspace(mesh, ("DG", 0))
        self.rho = dolfinx.fem.Function(Q, name="density")
        n_cells = mesh.topology.index_map(tdim).size_local
        groups = ctx.bodies()
        # keyed as the materials: bodies, cell groups, or the first interface's sides' roles
        given = problem.topology.materials(dict(settings.density))
        given = {k: v for k, v in given.items() if k in ctx.tags or k not in ROLES}
        unknown = [k for k in given if k not in ctx.tags]
        if unknown:
            raise ValueError(
                f"dynamics: density for {unknown}, which the mesh lacks; its bodies and groups "
                f"are {sorted(ctx.tags)}"
            )
        cell_dof = np.asarray(Q.dofmap.list).reshape(-1)  # DG0: one dof per cell

        def owned_cells(tags: Sequence[int]) -> np.ndarray:
            cells = cell_tags.indices[np.isin(cell_tags.values, tags)]
            return cells[cells < n_cells]

        order = [k for k in given if k in groups] + [k for k in given if k not in groups]
        for key in order:
            self.rho.x.array[cell_dof[owned_cells(ctx.tags[key])]] = float(given[key])
        self.rho.x.scatter_forward()
        without_here = [
            key
            for key, tags in ctx.tags.items()
            if np.any(self.rho.x.array[cell_dof[owned_cells(tags)]] <= 0.0)
        ]
        without = sorted({k for part in problem.comm.allgather(without_here) for k in part})
        if without:
            raise ValueError(
                f"dynamics: no density for {without} (give every body its density, tonne/mm^3)"
            )
        w = weight(mesh, problem.mode)
        du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        self._m_form = dolfinx.fem.form(self.rho * ufl.inner(du, v) * w * ufl.dx)
        n = problem.layout.n_owned
        self.n_owned = n
        # body force rho g (constant)
        self.f_gravity = np.zeros(n)
        if settings.gravity is not None:
            g = np.asarray(settings.gravity, dtype=float)
            if g.size != gdim:
                raise ValueError(f"dynamics: gravity has {g.size} components, the mesh {gdim}")
            gc = dolfinx.fem.Constant(mesh, PETSc.ScalarType(tuple(g)))
            L = dolfinx.fem.form(self.rho * ufl.inner(gc, v) * w * ufl.dx)
            b = dolfinx.fem.petsc.assemble_vector(L)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self.f_gravity = b.array_r[:n].copy()
            b.destroy()
        # initial velocity by body (dofs of its cells)
        self.velocity = np.zeros(n)
        bs = V.dofmap.bs
        velocities = problem.topology.materials(dict(settings.initial_velocity))
        velocities = {k: v for k, v in velocities.items() if k in ctx.tags or k not in ROLES}
        for key, vel in velocities.items():
            if key not in ctx.tags:
                raise ValueError(
                    f"dynamics: initial velocity for {key!r}, which the mesh lacks; its bodies "
                    f"and groups are {sorted(ctx.tags)}"
                )
            vv = np.asarray(vel, dtype=float)
            if vv.size != gdim:
                raise ValueError(
                    f"dynamics: the initial velocity of {key!r} has {vv.size} components, the "
                    f"mesh {gdim}"
                )
            cells = cell_tags.indices[np.isin(cell_tags.values, ctx.tags[key])]
            blocks = np.unique(np.asarray(V.dofmap.list)[cells].reshape(-1))
            blocks = blocks[blocks * bs < n]
            for c in range(gdim):
                self.velocity[blocks * bs + c] = vv[c]
        self.acceleration = np.zeros(n)
        self.displacement = np.zeros(n)  # u_n
        # the prescribed dofs move as prescribed: their velocity the program's (its first
        # segment's slope), whatever a body's initial velocity says
        self.velocity[problem.bc_dofs] = self._prescribed_velocity(problem.program.t_start)
        self.force = np.zeros(n)  # G(u_n, t_n), every row (before the Dirichlet rows)
        self.interface_force = np.zeros(n)  # the interfaces' forces at u_n
        self.started = False
        self.t_n = float(problem.t)  # the time of the committed state
        self.dt = 0.0
        self.M: PETSc.Mat | None = None
        self.C: PETSc.Mat | None = None
        self._va = problem.create_vector()
        self._vb = problem.create_vector()
        self._static = False
        self._x1: np.ndarray | None = None
        self._g1: np.ndarray | None = None
        self._f1: np.ndarray | None = None
        self._rows_dirichlet: np.ndarray | None = None
        # the energy accounts (cumulative ones, and the initial energy)
        self.e0 = 0.0
        self.sums = dict.fromkeys(("W_external", "D_friction", "D_damping", "D_numerical"), 0.0)
        self.sums["W_bulk"] = 0.0  # a nonlinear bulk: the work done on it
        self.energy: dict[str, float] = {}
        self.build_matrices()

    def _prescribed_velocity(self, t: float) -> np.ndarray:
        """The velocity of the Dirichlet dofs (owned) just after ``t``, by a forward difference.

        The loading program is piecewise linear: the difference over a small fraction of the
        segment after ``t`` is its slope (a :class:`~.conditions.DirichletField` of the user's:
        its derivative to that difference's accuracy).
        """
        p = self.problem
        times = np.asarray(p.program.times, dtype=float)
        later = times[times > t]
        span = float(later[0] - t) if later.size else 1.0
        h = 1e-6 * span
        _, g0 = p.dirichlet_values(t)
        _, g1 = p.dirichlet_values(t + h)
        return (g1 - g0) / h

    # ------------------------------------------------------------------------------------------
    def build_matrices(self) -> None:
        """The mass (and damping) matrix on the problem's current pattern (collective)."""
        for name in ("M", "C"):
            old = getattr(self, name, None)
            if old is not None:
                old.destroy()
        p = self.problem
        self.M = p.layout.create_matrix()
        dolfinx.fem.petsc.assemble_matrix(self.M, self._m_form)
        self.M.assemble()
        self.C = None
        s = self.settings
        if s.alpha_m > 0.0 or s.alpha_k > 0.0:
            self.C = p.layout.create_matrix()
            self.C.assemble()
            same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
            if s.alpha_m > 0.0:
                self.C.axpy(float(s.alpha_m), self.M, structure=same)
            if s.alpha_k > 0.0:
                self.C.axpy(float(s.alpha_k), p.K_scale, structure=same)

    def _dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(self.problem.comm.allreduce(float(a @ b), op=MPI.SUM))

    def _mult(self, A: PETSc.Mat, x: np.ndarray) -> np.ndarray:
        self._va.array_w[:] = x
        A.mult(self._va, self._vb)
        return self._vb.array_r.copy()

    def _external(self, t: float) -> np.ndarray:
        """The loads at ``t`` (owned), with the body force."""
        p = self.problem
        f = self.f_gravity.copy()
        for c, vec in p.loads:
            f += p.program.amplitude(c.amplitude, t) * vec.array_r
        return f

    def _interface_energy(self) -> tuple[float, float]:
        """The interfaces' elastic energy and this step's plastic-slip work (collective).

        At their last evaluation; the plastic slip's increment from the committed state.
        ``NaN`` where a law has no penalties or no ``up`` (the same on every rank: the laws are).
        """
        elastic = plastic = 0.0
        known = True
        for iface in self.problem.interfaces.values():
            pts = iface.law_points
            names = {v.name for v in iface.law.variables}
            w = np.asarray(pts.weights, dtype=float).reshape(-1)
            pen = _penalties(iface.law, w.size)
            if pen is None or "up" not in names:
                known = False
                continue
            last = pts.last
            if last is None or w.size == 0:
                continue
            nt = int(pts.nt)
            t = np.asarray(last.traction, dtype=float).reshape(w.size, nt + 1)
            at, an = pen
            elastic += float(
                np.sum(w * (np.sum(t[:, :nt] ** 2, axis=1) / (2 * at) + t[:, nt] ** 2 / (2 * an)))
            )
            new = np.asarray(pts.state.new["up"], dtype=float).reshape(w.size, nt)
            old = np.asarray(pts.state.old["up"], dtype=float).reshape(w.size, nt)
            plastic += float(np.sum(w * np.sum(t[:, :nt] * (new - old), axis=1)))
        total = self.problem.comm.allreduce(np.array([elastic, plastic]), op=MPI.SUM)
        if not known:
            return math.nan, math.nan
        return float(total[0]), float(total[1])

    def _strain(self, x: np.ndarray) -> float:
        """The bodies' strain energy ``x K x / 2`` (a linear bulk), else the work done on them."""
        if self.problem.linear_bulk:
            return 0.5 * self._dot(x, self._mult(self.problem.K, x))
        return self.sums["W_bulk"]

    # ------------------------------------------------------------------------------------------
    def begin_step(self, t: float, dt: float) -> None:
        """Before a step to ``t`` (the problem's ``set_step``): the initial state at the first.

        Collective.
        """
        if not self.started:
            self.started = True
            self.start()
        self.dt = float(dt)

    def start(self) -> None:
        """The initial state's forces, consistent acceleration and energy (collective).

        The problem's ``u`` and time are the initial ones (its interfaces' committed state).
        """
        p = self.problem
        n = self.n_owned
        self.t_n = float(p.t)
        x = p.create_vector()
        x.array_w[:] = p.u.x.array[:n]
        F = p.create_vector()
        self._static = True
        try:
            p.set_step(p.t, 0.0)
            p.residual(x, F)
        finally:
            self._static = False
        p.revert()
        self.displacement = x.array_r.copy()
        self.force = self._g1.copy() if self._g1 is not None else np.zeros(n)
        self.interface_force = self._f1.copy() if self._f1 is not None else np.zeros(n)
        e_if, _ = self._interface_energy()
        # M a0 = -G0 - C v0 on the free rows, a0 = 0 on the Dirichlet ones
        rhs = -self.force
        if self.C is not None:
            rhs = rhs - self._mult(self.C, self.velocity)
        rhs[p.bc_dofs] = 0.0
        assert self.M is not None  # built with the problem
        A = self.M.duplicate(copy=True)
        A.zeroRowsColumns(p.bc_rows, diag=1.0)
        ksp = PETSc.KSP().create(p.comm)
        try:
            ksp.setOperators(A)
            ksp.setType("cg")
            ksp.getPC().setType("jacobi")
            ksp.setTolerances(rtol=1e-14, atol=0.0, max_it=10_000)
            b = p.create_vector()
            b.array_w[:] = rhs
            a = p.create_vector()
            ksp.solve(b, a)
            self.acceleration = a.array_r.copy()
            for vec in (a, b):
                vec.destroy()
        finally:
            ksp.destroy()
            A.destroy()
        for vec in (x, F):
            vec.destroy()
        kinetic = 0.5 * self._dot(self.velocity, self._mult(self.M, self.velocity))
        strain = self._strain(self.displacement) + e_if
        self.e0 = kinetic + strain
        self.energy = {
            "E_kinetic": kinetic,
            "E_strain": strain,
            **{k: 0.0 for k in ENERGY_COLUMNS[2:]},
        }
        self._e_if = e_if

    def _rates(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Acceleration and velocity at ``t_n + dt`` for the displacement ``x`` (Newmark)."""
        dt, b, g = self.dt, self.beta, self.gamma
        a1 = (x - self.displacement - dt * self.velocity) / (b * dt * dt) - (
            0.5 / b - 1.0
        ) * self.acceleration
        v1 = self.velocity + dt * ((1.0 - g) * self.acceleration + g * a1)
        return a1, v1

    def predicted_increment(self, dt: float) -> np.ndarray:
        """The increment ``dt v_n + dt^2 a_n / 2`` (owned): a start for Newton's iteration."""
        return dt * self.velocity + 0.5 * dt * dt * self.acceleration

    def residual(self, x: np.ndarray, Fa: np.ndarray) -> None:
        """Turn the quasi-static residual ``Fa = G(x, t_{n+1})`` (owned, every row) into the step's.

        Called by the problem's residual before its Dirichlet rows are set.
        """
        p = self.problem
        if self.settings.gravity is not None:
            Fa -= self.f_gravity
        self._x1 = np.array(x, dtype=float)
        self._g1 = Fa.copy()
        self._f1 = np.array(p.interface_force, dtype=float)
        if self._static:
            return
        a1, v1 = self._rates(self._x1)
        am, af = self.am, self.af
        Fa *= 1.0 - af
        Fa += af * self.force
        if self.at_end:  # the interfaces' forces at the step's end alone
            Fa += af * (self._f1 - self.interface_force)
        Fa += self._mult(self.M, (1.0 - am) * a1 + am * self.acceleration)
        if self.C is not None:
            Fa += self._mult(self.C, (1.0 - af) * v1 + af * self.velocity)
        self._rows_dirichlet = Fa[p.bc_dofs].copy()

    def bulk_jacobian(self, J: PETSc.Mat) -> None:
        """Scale the bodies' assembled Jacobian, before the interfaces add theirs (``"end"``)."""
        if self.at_end:
            J.scale(1.0 - self.af)

    def jacobian(self, J: PETSc.Mat) -> None:
        """Turn the assembled quasi-static Jacobian into the step's (before the Dirichlet rows)."""
        dt, b, g, am, af = self.dt, self.beta, self.gamma, self.am, self.af
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        if not self.at_end:
            J.scale(1.0 - af)
        J.axpy((1.0 - am) / (b * dt * dt), self.M, structure=same)
        if self.C is not None:
            J.axpy((1.0 - af) * g / (b * dt), self.C, structure=same)

    def commit(self) -> None:
        """Accept the step: the velocity, acceleration and forces at its end, and the energies.

        Collective; before the interfaces commit (their plastic slip's increment is read).
        """
        if self._x1 is None or self._g1 is None or self._f1 is None:
            return
        p = self.problem
        x1 = self._x1
        a1, v1 = self._rates(x1)
        am, af = self.am, self.af
        du = x1 - self.displacement
        f_ext1 = self._external(p.t)
        f_ext0 = self._external(self.t_n)
        bulk1 = self._g1 + f_ext1 - self._f1
        bulk0 = self.force + f_ext0 - self.interface_force
        d = p.bc_dofs
        support = 0.0
        if self._rows_dirichlet is not None:
            support = float(du[d] @ self._rows_dirichlet)
        support = float(p.comm.allreduce(support, op=MPI.SUM))
        w_ext = self._dot(du, (1.0 - af) * f_ext1 + af * f_ext0) + support
        inertia = self._dot(du, self._mult(self.M, (1.0 - am) * a1 + am * self.acceleration))
        kin0 = self.energy["E_kinetic"]
        kin1 = 0.5 * self._dot(v1, self._mult(self.M, v1))
        damping = 0.0
        if self.C is not None:
            damping = self._dot(du, self._mult(self.C, (1.0 - af) * v1 + af * self.velocity))
        w_bulk = self._dot(du, (1.0 - af) * bulk1 + af * bulk0)
        w_if = self._dot(
            du, self._f1 if self.at_end else (1.0 - af) * self._f1 + af * self.interface_force
        )
        e_if1, friction = self._interface_energy()
        if p.linear_bulk:
            u_b0 = self.energy["E_strain"] - self._e_if
            u_b1 = self._strain(x1)
        else:
            u_b0 = self.sums["W_bulk"]
            self.sums["W_bulk"] += w_bulk
            u_b1 = self.sums["W_bulk"]
        numerical = (inertia - (kin1 - kin0)) + (w_bulk - (u_b1 - u_b0))
        numerical += w_if - (e_if1 - self._e_if) - friction
        s = self.sums
        s["W_external"] += w_ext
        s["D_friction"] += friction
        s["D_damping"] += damping
        s["D_numerical"] += numerical
        strain = u_b1 + e_if1
        balance = s["W_external"] - (kin1 + strain - self.e0)
        balance -= s["D_friction"] + s["D_damping"] + s["D_numerical"]
        self.energy = {
            "E_kinetic": kin1,
            "E_strain": strain,
            "W_external": s["W_external"],
            "D_friction": s["D_friction"],
            "D_damping": s["D_damping"],
            "D_numerical": s["D_numerical"],
            "E_balance": balance,
        }
        self._e_if = e_if1
        self.t_n = float(p.t)
        self.displacement = x1.copy()
        self.velocity = v1
        self.acceleration = a1
        self.force = self._g1.copy()
        self.interface_force = self._f1.copy()
        self._x1 = self._g1 = self._f1 = None

    # ------------------------------------------------------------------------------------------
    def saved_state(self) -> dict[str, Any]:
        """The committed state a restart needs: owned vectors and the energy accounts."""
        return {
            "velocity": self.velocity.copy(),
            "acceleration": self.acceleration.copy(),
            "force": self.force.copy(),
            "interface_force": self.interface_force.copy(),
            "accounts": {
                "started": bool(self.started),
                "t_n": float(self.t_n),
                "e0": float(self.e0),
                "e_if": float(getattr(self, "_e_if", 0.0)),
                "sums": dict(self.sums),
                "energy": dict(self.energy),
            },
        }

    def restore_state(self, vectors: Mapping[str, np.ndarray], accounts: Mapping[str, Any]) -> None:
        """Take :meth:`saved_state`'s values back (the problem's ``u`` already restored)."""
        n = self.n_owned
        self.velocity = np.array(vectors["velocity"][:n], dtype=float)
        self.acceleration = np.array(vectors["acceleration"][:n], dtype=float)
        self.force = np.array(vectors["force"][:n], dtype=float)
        self.interface_force = np.array(vectors["interface_force"][:n], dtype=float)
        self.displacement = np.array(self.problem.u.x.array[:n], dtype=float)
        self.started = bool(accounts.get("started", True))
        self.t_n = float(accounts.get("t_n", self.problem.t))
        self.e0 = float(accounts.get("e0", 0.0))
        self._e_if = float(accounts.get("e_if", 0.0))
        self.sums.update({k: float(v) for k, v in dict(accounts.get("sums", {})).items()})
        self.energy = {k: float(v) for k, v in dict(accounts.get("energy", {})).items()}
        self._x1 = self._g1 = self._f1 = None

    def destroy(self) -> None:
        """Free the PETSc objects (safe to call more than once)."""
        for name in ("M", "C", "_va", "_vb"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)
