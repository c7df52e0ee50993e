"""Bodies joined by frictional zero-thickness interfaces: the residual and the consistent Jacobian.

The residual is ``F(u) = F_bulk(u) - f_ext(t) + sum_i R_i(u)``: ``F_bulk`` the bodies' own law (a
:mod:`.bulk` model: by default linear elasticity, whose stiffness ``K`` is assembled once, in the
modelling mode of :mod:`.kinematics`; springs ``k_i u_i v_i`` on their facets join ``K``),
``f_ext`` the tractions, pressures, point forces and the springs' moving ends, each scaled by its
loading channel (:mod:`.boundary`), and ``R_i`` the forces of each interface
(:class:`~.interface.FrictionInterface`, the friction law's return map). Dirichlet rows are
replaced by ``u - g(t)`` and the Jacobian rows by identity rows, which keeps the Jacobian exact (no
symmetric elimination, no lifting).

The interfaces' return maps run in :meth:`InterfaceProblem.residual`; their consistent tangents
are reused by :meth:`InterfaceProblem.jacobian` at the same iterate. A bulk model with state is
updated there too, and committed or reverted with the interfaces (:meth:`InterfaceProblem.commit`,
:meth:`InterfaceProblem.revert`).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import cast

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from ..compat import petsc_vector
from ..constitutive import FrictionLaw, J2Material
from ..loading import LoadingProgram
from ..meshing.topology import ROLES
from .bodies import resolve_interfaces
from .boundary import check_groups, dirichlet_dofs, load_vectors, spring_forms
from .bulk import BulkContext, BulkModel, LinearElasticity, bulk_forms, bulk_name
from .conditions import (
    Dirichlet,
    DirichletField,
    Interface,
    Material,
    PointForce,
    Pressure,
    ProblemSettings,
    Spring,
    Traction,
    channels,
)
from .dynamics import Inertia
from .interface import BaseInterface, InterfaceError, NewtonStart
from .interface.base import stiffen_separated
from .interface.kinds import make_interface
from .interface.layout import layout_of
from .kinematics import check_axisymmetric, check_mode, weight
from .plasticity import J2Bulk
from .timing import TIMER_BULK, TIMER_SETUP, Timings

__all__ = ["InterfaceProblem", "stiffen_separated"]

logger = logging.getLogger(__name__)


class InterfaceProblem:
    """Residual and Jacobian of bodies joined by frictional interfaces.

    It owns PETSc matrices and vectors: :meth:`destroy` frees them, as leaving a ``with`` block
    does (``with InterfaceProblem(...) as problem:``), like :class:`~.solver.FrictionSolver`.
    Two bodies and the one interface between them: :meth:`two_bodies`.

    Args:
        domain: The bulk mesh with its tags, e.g. a :class:`~subfric_dolfinx.meshing.InterfaceMesh`
            (anything with ``mesh``, ``cell_tags``, ``facet_tags`` and ``tags``, name -> tag; a
            mesh of :mod:`subfric_dolfinx.meshing` also knows its
            :class:`~subfric_dolfinx.meshing.Topology`); its interface nodes must be duplicated.
        law: The friction law (a :class:`~subfric_dolfinx.constitutive.FrictionLaw`) of every
            interface that does not give its own.
        materials: The bodies' law: body or cell-group name -> :class:`Material` (the built-in
            linear elasticity) or :class:`~subfric_dolfinx.constitutive.J2Material` (a body
            with J2 plasticity: the bodies then run through a :class:`~.plasticity.J2Bulk`); the
            keys ``primary``/``secondary``, or their input aliases ``master``/``slave``, name
            the first interface's bodies. Or a bulk model
            (:mod:`.bulk`: a :class:`~.bulk.BulkModel`, e.g. a :class:`~.bulk.UFLBulk` or
            :class:`~.plasticity.J2Bulk`).
        program: Loading program whose channels the conditions refer to.
        dirichlet: Prescribed displacements (on facet, cell or node groups).
        loads: Tractions, pressures, point forces and elastic supports (:class:`Spring`).
        interfaces: The interfaces one by one (:class:`Interface`: group, sides, law, initial gap,
            regions); ``None``: those of the mesh with ``law``.
        settings: Degree, interface quadrature and modelling mode (:class:`ProblemSettings`).

    Attributes:
        topology: The problem's :class:`~subfric_dolfinx.meshing.Topology` (its bodies, and its
            interfaces with their sides and kinds).
        specs: The interfaces as given, every setting resolved (:class:`Interface`).
        interfaces: Interface name -> its interface, of either kind
            (:class:`~.interface.BaseInterface`).
        interface: The first interface's law points (:class:`~.interface.protocol.LawPoints`: its
            :class:`~.interface.InterfaceElements` with small sliding, its
            :class:`~.interface.finite.points.SlidingPoints` with finite sliding), the only one
            of a two-body problem.
        law: The first interface's law.

    Raises:
        InterfaceError: A required physical group is missing (named), or an interface is unusable.
    """

    def __init__(
        self,
        domain,
        law: FrictionLaw | None,
        materials: Mapping[str, Material | J2Material] | BulkModel,
        program: LoadingProgram,
        dirichlet: Sequence[Dirichlet | DirichletField] = (),
        loads: Sequence[Traction | Pressure | PointForce | Spring] = (),
        *,
        interfaces: Sequence[Interface] | None = None,
        settings: ProblemSettings | None = None,
    ) -> None:
        settings = settings or ProblemSettings()
        springs = [c for c in loads if isinstance(c, Spring)]
        surface = [c for c in loads if not isinstance(c, Spring)]
        bulk = None if isinstance(materials, Mapping) else materials
        given = materials if isinstance(materials, Mapping) else {}
        self.timings = Timings()
        mesh = domain.mesh
        self.domain = domain
        self.mesh = mesh
        self.comm = mesh.comm
        self.program = program
        self.tags = dict(domain.tags)
        gdim = mesh.geometry.dim
        self.mode = check_mode(settings.mode or ("3d" if gdim == 3 else "plane_strain"), gdim)
        if self.mode == "axisymmetric":
            check_axisymmetric(mesh)  # r >= 0 everywhere (collective)
        self.topology, self.specs = resolve_interfaces(
            domain, law, interfaces, quadrature=settings.quadrature
        )
        body_tags = self.topology.body_tags(self.tags)
        self._check_conditions(dirichlet, surface, springs)
        degree = settings.degree
        if degree not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got {degree!r}")
        self.gdim = gdim
        V = dolfinx.fem.functionspace(mesh, ("Lagrange", degree, (gdim,)))
        self.V = V
        self.u = dolfinx.fem.Function(V, name="displacement")
        self.materials = self.topology.materials(
            given if bulk is None else getattr(bulk, "materials", {})
        )
        if bulk is None and any(isinstance(m, J2Material) for m in self.materials.values()):
            known = set(body_tags) | set(self.topology.bodies)
            bulk = J2Bulk({k: m for k, m in self.materials.items() if k in known or k not in ROLES})
        with self.timings(TIMER_SETUP):
            self._make_interfaces(body_tags)
        self._make_bulk(bulk, body_tags, surface, springs)
        self._make_dirichlet(dirichlet)

        self.t = program.t_start
        self.dt = 0.0
        self._x_at_update: np.ndarray | None = None
        self._bulk_work = self.create_vector() if not self.linear_bulk else None
        self._bulk_fault: tuple[int, int] | None = None  # (non-finite entries, first) here
        self._bulk_fault_jacobian = False  # the bulk's Jacobian was not finite (every rank)
        self.interface_force: np.ndarray = np.zeros(self.layout.n_owned)  # the interfaces' sum
        # the interfaces' forces' round-off beyond the displacement's (the convergence test)
        self.interface_round_off: np.ndarray | None = None
        self.reactions: dict[str, np.ndarray] = {}
        # the bodies' inertia (a dynamic problem), adding its terms to the residual and Jacobian
        self.dynamics: Inertia | None = None
        if settings.dynamics is not None:
            self.dynamics = Inertia(self, settings.dynamics)

    def _check_conditions(
        self,
        dirichlet: Sequence[Dirichlet | DirichletField],
        surface: Sequence[Traction | Pressure | PointForce],
        springs: Sequence[Spring],
    ) -> None:
        """Refuse conditions on groups the mesh lacks or on unknown channels; their groups' kinds.

        Sets :attr:`group_kinds` (group -> facet, cell or node group).

        Raises:
            InterfaceError: A point force's body is not a group of the mesh (named).
            LoadingError: A condition's amplitude names a channel the program lacks.
        """
        needed = [c.body for c in surface if isinstance(c, PointForce) and c.body is not None]
        missing = [g for g in dict.fromkeys(needed) if g not in self.tags]
        if missing:
            raise InterfaceError(
                f"the mesh lacks the physical group(s) {missing}; it has {sorted(self.tags)}"
            )
        gdim = self.mesh.geometry.dim
        for c in [*dirichlet, *surface, *springs]:
            n = gdim if isinstance(c, Traction | PointForce | Spring) else 1
            for ch in channels(c.amplitude, n, f"{type(c).__name__} on {c.group!r}"):
                self.program.amplitude(ch, self.program.t_start)  # unknown channel -> LoadingError
        self.group_kinds = check_groups(self.domain, [*dirichlet, *surface, *springs])

    def _make_interfaces(self, body_tags: Mapping[str, tuple[int, ...]]) -> None:
        """Each interface of :attr:`specs`, of its kind, and the layout they make (collective).

        Sets :attr:`interfaces`, the first interface's :attr:`pairs`, :attr:`interface` and
        :attr:`law`, and :attr:`layout`.
        """
        domain = self.domain
        self.interfaces: dict[str, BaseInterface] = {}
        groups = getattr(domain, "interface_groups", None) or {}
        for spec in self.specs:
            assert spec.primary is not None and spec.secondary is not None  # (resolved)
            self.interfaces[spec.group] = make_interface(
                spec,
                self.V,
                domain.cell_tags,
                domain.facet_tags,
                self.tags[spec.group],
                body_tags[spec.primary],
                body_tags[spec.secondary],
                groups,
                self.mode,
                self.timings,
            )
        first = next(iter(self.interfaces.values()))
        self.pairs = first.pairs  # None with finite sliding (no fixed pairs)
        self.interface = first.law_points
        self.law = first.law
        self.layout = layout_of(self.V, list(self.interfaces.values()))
        self._layout_versions = self._versions()
        self.layout_version = 0

    def _make_bulk(
        self,
        bulk: BulkModel | None,
        body_tags: Mapping[str, tuple[int, ...]],
        surface: Sequence[Traction | Pressure | PointForce],
        springs: Sequence[Spring],
    ) -> None:
        """The bodies' law, the springs, the bulk matrices and the load vectors (collective).

        The built-in linear elasticity (assembled once) where ``bulk`` is ``None``, else the
        user's bulk model (its residual and Jacobian assembled at every iterate).

        Raises:
            ValueError: The bulk's forms cannot be made (e.g. a body without a material).
        """
        mesh, V, domain = self.mesh, self.V, self.domain
        du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=mesh, subdomain_data=domain.cell_tags)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=domain.facet_tags)
        self.bulk = bulk if bulk is not None else LinearElasticity(self.materials)
        self.bulk_context = BulkContext(
            mesh=mesh, V=V, mode=self.mode, dx=dx, tags=body_tags, groups=self.topology.bodies
        )
        try:
            F_bulk, J_bulk = bulk_forms(self.bulk, self.u, v, du, self.bulk_context)
        except ValueError as e:  # e.g. a body without a material
            raise ValueError(str(e)) from None
        self.linear_bulk = bool(getattr(self.bulk, "linear", False))
        w = weight(mesh, self.mode)
        a_springs, spring_loads, self.spring_forces = spring_forms(V, domain, springs, ds, w)
        self.springs = list(springs)
        self._a_linear = J_bulk if self.linear_bulk else None
        if isinstance(a_springs, ufl.Form):
            self._a_linear = a_springs if self._a_linear is None else self._a_linear + a_springs
        if self._a_linear is not None:
            self._a_linear = dolfinx.fem.form(self._a_linear)
        self._F_form = self._J_form = None
        self.bulk_force: np.ndarray | None = None  # owned F_bulk(u) at the last residual
        if not self.linear_bulk:
            self._F_form = dolfinx.fem.form(F_bulk)
            self._J_form = dolfinx.fem.form(J_bulk)
        self.K: PETSc.Mat | None = None  # (None once destroyed)
        self.K_scale: PETSc.Mat | None = None
        with self.timings(TIMER_BULK):
            self._build_matrices()
            # Load vectors, one per condition and channel (scaled by the channel at run time).
            self.loads = load_vectors(V, domain, surface, ds, w) + spring_loads

    def _make_dirichlet(self, dirichlet: Sequence[Dirichlet | DirichletField]) -> None:
        """The Dirichlet dofs (owned, unrolled) with their reference values, per condition.

        Sets :attr:`dirichlet` (condition, dofs, values), the dofs of each Dirichlet group (its
        reactions), :attr:`bc_dofs` and their global rows :attr:`bc_rows`.
        """
        V = self.V
        tdim = self.mesh.topology.dim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)
        bs = V.dofmap.bs
        self.dirichlet = [
            (c, *dirichlet_dofs(V, self.domain, c, self.group_kinds[c.group])) for c in dirichlet
        ]
        # the dofs of each Dirichlet group (all its conditions, e.g. one per component)
        self._reaction_dofs = {
            g: np.unique(np.concatenate([d for c, d, _ in self.dirichlet if c.group == g]))
            for g in sorted({c.group for c, _, _ in self.dirichlet})
        }
        self.bc_dofs = (
            np.unique(np.concatenate([d for _, d, _ in self.dirichlet]))
            if self.dirichlet
            else np.zeros(0, np.int32)
        )
        rstart = V.dofmap.index_map.local_range[0] * bs
        self.bc_rows = (self.bc_dofs + rstart).astype(PETSc.IntType)

    @classmethod
    def two_bodies(
        cls,
        domain,
        law: FrictionLaw | None,
        materials: Mapping[str, Material] | BulkModel,
        program: LoadingProgram,
        dirichlet: Sequence[Dirichlet | DirichletField] = (),
        loads: Sequence[Traction | Pressure | PointForce | Spring] = (),
        *,
        interface: Interface | None = None,
        settings: ProblemSettings | None = None,
    ) -> InterfaceProblem:
        """Two bodies joined by one interface.

        Args:
            domain: As in :class:`InterfaceProblem`.
            law: The interface's friction law (unless ``interface`` gives its own).
            materials: As in :class:`InterfaceProblem`.
            program: As in :class:`InterfaceProblem`.
            dirichlet: As in :class:`InterfaceProblem`.
            loads: As in :class:`InterfaceProblem`.
            interface: The interface: its group, sides (``None``: the mesh's) and own settings
                (initial gap, regions, ...); ``None``: the mesh's only interface (a mesh that
                knows none: the classic layout's group ``interface`` between the cell groups
                ``primary`` and ``secondary``).
            settings: As in :class:`InterfaceProblem`.

        Raises:
            InterfaceError: The mesh has several interfaces and ``interface`` names none.
        """
        if interface is None:
            known = list(getattr(getattr(domain, "topology", None), "interfaces", None) or {})
            if len(known) > 1:
                raise InterfaceError(
                    f"the mesh has {len(known)} interfaces {known}: name the one of the two "
                    "bodies (two_bodies(..., interface=Interface(group))), or give them all "
                    "(InterfaceProblem(..., interfaces=[Interface(...), ...]))"
                )
        interfaces = None if interface is None else [interface]
        return cls(
            domain,
            law,
            materials,
            program,
            dirichlet,
            loads,
            interfaces=interfaces,
            settings=settings,
        )

    # ------------------------------------------------------------------------------------------
    def _versions(self) -> tuple[int, ...]:
        return tuple(i.layout_version for i in self.interfaces.values())

    def _build_matrices(self) -> None:
        """The bulk stiffness (and scale) on the current layout's pattern (collective)."""
        for name in ("K", "K_scale"):
            old = getattr(self, name, None)
            if old is not None:
                old.destroy()
        self.K = self.layout.create_matrix()
        if self._a_linear is not None:
            dolfinx.fem.petsc.assemble_matrix(self.K, self._a_linear)
        self.K.assemble()
        self.K_scale = self.K  # |K_scale| |u|: the size of the bulk forces (convergence)
        if not self.linear_bulk:
            assert self._J_form is not None  # (a nonlinear bulk's)
            self.K_scale = self.layout.create_matrix()
            self.bulk.update(self.u)  # the tangent at u (then reverted)
            dolfinx.fem.petsc.assemble_matrix(self.K_scale, self._J_form)
            self.K_scale.assemble()
            self.K_scale.axpy(1.0, self.K, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            self.bulk.revert()
        self.K.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        dynamics = getattr(self, "dynamics", None)  # (not made yet when the problem is built)
        if dynamics is not None:
            dynamics.build_matrices()

    def set_step(self, t: float, dt: float) -> None:
        """Set the time at the end of the step and the step length (drives recovery).

        Collective. Finite-sliding interfaces search from the last converged configuration;
        when one rebuilds its pattern, the layout and the bulk matrices are rebuilt and
        :attr:`layout_version` grows (a solver then re-creates its matrices).
        """
        if self.dynamics is not None:  # the first step: the initial state's forces
            self.dynamics.begin_step(t, dt)
        self.t, self.dt = float(t), float(dt)
        self._x_at_update = None
        self._bulk_fault = None
        self._bulk_fault_jacobian = False
        for iface in self.interfaces.values():
            iface.set_step(dt)
        versions = self._versions()
        if versions != self._layout_versions:
            self._layout_versions = versions
            with self.timings(TIMER_BULK):
                self.layout = layout_of(self.V, list(self.interfaces.values()))
                self._build_matrices()
            self.layout_version += 1

    def dirichlet_values(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Owned Dirichlet dofs (local, unrolled, sorted) and their values at ``t``.

        Where conditions share a dof (e.g. along an edge of two faces), the later one wins.
        """
        val = np.zeros(self.bc_dofs.size)
        for c, dofs, vals in self.dirichlet:
            pos = np.searchsorted(self.bc_dofs, dofs)
            if isinstance(c, DirichletField):
                val[pos] = np.asarray(c.function(vals, t), dtype=float).reshape(-1)
            else:
                val[pos] = vals * self.program.amplitude(c.amplitude, t)
        return self.bc_dofs, val

    def apply_dirichlet(self, x: PETSc.Vec) -> None:
        """Set the Dirichlet values of the current time in ``x`` (owned part)."""
        idx, val = self.dirichlet_values(self.t)
        x.array[idx] = val

    def correct_start(self, x: PETSc.Vec) -> None:
        """Let each interface change the extrapolated start ``x`` (collective; owned values).

        :meth:`~.interface.BaseInterface.start_correction` of every interface in turn, each at
        the start its predecessors left; the Dirichlet values are the caller's to set again.
        """
        for iface in self.interfaces.values():
            change = iface.start_correction(x)
            if change is not None:
                x.array_w[:] += change

    def _update(self, x: PETSc.Vec) -> bool:
        """Evaluate the interfaces (and a bulk with state) at ``x``; whether all succeeded here."""
        ok = True
        for iface in self.interfaces.values():
            ok = bool(iface.update(x).converged) and ok
        if not self.linear_bulk:
            with self.timings(TIMER_BULK):
                n = self.layout.n_owned
                self.u.x.array[:n] = x.array_r
                self.u.x.scatter_forward()
                self.bulk.update(self.u)
        self._x_at_update = x.array_r.copy()
        return ok

    def residual(self, x: PETSc.Vec, F: PETSc.Vec) -> bool:
        """Assemble ``F(x)``; return False if a return map failed at some point of this rank."""
        ok = self._update(x)
        assert self.K is not None  # (None once destroyed)
        with self.timings(TIMER_BULK):
            if self.linear_bulk:
                self.K.mult(x, F)
            else:
                with F.localForm() as fl:
                    fl.set(0.0)
                dolfinx.fem.petsc.assemble_vector(F, self._F_form)
                F.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                self.bulk_force = bulk_force = F.array_r.copy()
                bad = ~np.isfinite(bulk_force)
                if bad.any() and np.isfinite(x.array_r).all():  # the bulk's own doing
                    self._bulk_fault = (int(bad.sum()), int(np.argmax(bad)))
                    ok = False
                self.K.multAdd(x, F, F)
            for c, f in self.loads:
                F.axpy(-self.program.amplitude(c.amplitude, self.t), f)
        ifaces = list(self.interfaces.values())
        force = ifaces[0].forces()
        if len(ifaces) > 1:
            force = force.copy()
            for iface in ifaces[1:]:
                force += iface.forces()
        offs = [i.round_off for i in ifaces if i.round_off is not None]
        self.interface_round_off = cast(np.ndarray, sum(offs)) if offs else None
        self.interface_force = force
        Fa = F.array_w
        Fa += force
        if self.dynamics is not None:  # the step's equation of motion
            self.dynamics.residual(x.array_r, Fa)
        # reactions: forces at Dirichlet dofs before the rows are replaced
        self.reactions = self._reactions(Fa)
        idx, val = self.dirichlet_values(self.t)
        Fa[idx] = x.array_r[idx] - val
        return ok

    def jacobian(
        self,
        x: PETSc.Vec,
        J: PETSc.Mat,
        separated_stiffness: float = 0.0,
        start: NewtonStart | None = None,
    ) -> None:
        """Assemble the Jacobian at ``x`` (reusing the tangent of the last residual there).

        ``separated_stiffness``: in this Jacobian only (not the residual), points without
        stiffness (separated beyond the contact band, failed) get this fraction of the law's
        contact stiffness (:func:`stiffen_separated`); 0: the exact tangent.
        ``start``: the first Jacobian of a step, how its Newton iteration starts
        (:class:`~.interface.NewtonStart`: each interface's kind decides what its tangent makes
        of it; :class:`~.stepping.LoadStepper`'s ``predictor``); ``None``: a later iteration.
        """
        if self._x_at_update is None or not np.array_equal(self._x_at_update, x.array_r):
            self._update(x)
        assert self.K is not None  # (None once destroyed)
        with self.timings(TIMER_BULK):
            same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN  # (one layout: one structure)
            if self.linear_bulk:  # the bulk's tangent is K, assembled once: its values copied
                self.K.copy(J, structure=same)
            else:
                assert self._J_form is not None  # (a nonlinear bulk's)
                J.zeroEntries()
                dolfinx.fem.petsc.assemble_matrix(J, self._J_form)
                J.assemble()
                if not np.isfinite(J.norm()):  # collective: the bulk's tangent alone so far
                    self._bulk_fault_jacobian = True
                J.axpy(1.0, self.K, structure=same)
        if self.dynamics is not None:
            self.dynamics.bulk_jacobian(J)
        for iface in self.interfaces.values():
            iface.assemble_jacobian(J, separated_stiffness=separated_stiffness, start=start)
        J.assemble()
        if self.dynamics is not None:
            self.dynamics.jacobian(J)
        J.zeroRows(self.bc_rows, diag=1.0)

    @property
    def compact_factor(self) -> bool:
        """Whether a factorisation takes a compact copy of the Jacobian, its entries alone.

        The matrix pattern holds couplings beyond the Jacobian's entries where an interface
        pairs again as the bodies move: every pairing it may take until its next search. In 3-D
        a factorisation (the linear strategies ``"lu"`` and ``"reuse"``) then takes a compact
        copy of the Jacobian (:class:`~.linear.CompactCopy`): there the reach's couplings join
        the bodies across a surface, a separator of the factorisation, and fill it; along a
        2-D interface's line they add little to the factor (the copy only costs symbolic
        factorisations), so a 2-D problem factorises its matrix as stored.
        """
        return self.gdim == 3 and self.repairs

    @property
    def repairs(self) -> bool:
        """Whether an interface pairs its points again as the bodies move (finite sliding)."""
        return any(not i.fixed_pairs for i in self.interfaces.values())

    @property
    def global_dofs(self) -> int:
        """The number of displacement dofs over all ranks (not collective: the index map's)."""
        return self.V.dofmap.index_map.size_global * self.V.dofmap.bs

    def bulk_fault(self) -> str | None:
        """What the bulk model's residual or Jacobian gave that was not finite in this attempt.

        Collective; the same text on every rank (``None``: nothing), naming the bulk model, the
        number of entries and where the first one is.
        """
        here = None
        if self._bulk_fault is not None:
            n, i = self._bulk_fault
            bs = self.V.dofmap.bs
            x = self.V.tabulate_dof_coordinates()[i // bs, : self.gdim]
            here = (n, tuple(float(c) for c in x))
        found = [f for f in self.comm.allgather(here) if f is not None]
        if found:
            total = sum(n for n, _ in found)
            where = ", ".join(f"{c:.4g}" for c in found[0][1])
            return (
                f"{bulk_name(self.bulk)} gave a residual that is not finite (NaN or inf) at "
                f"{total} dof(s), the first at x = ({where}), from a finite displacement"
            )
        if self._bulk_fault_jacobian:
            return f"{bulk_name(self.bulk)} gave a Jacobian that is not finite (NaN or inf)"
        return None

    def failed_points(self) -> np.ndarray:
        """Indices of the points where the last return maps failed (all interfaces, this rank)."""
        out, offset = [], 0
        for iface in self.interfaces.values():
            last = iface.last
            if last is not None:
                out.append(np.asarray(last.failed_indices) + offset)
                offset += last.status.size
        return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)

    def status_counts(self) -> dict[str, int]:
        """Return-map statuses at the last evaluation, over every interface and rank."""
        total: dict[str, int] = {}
        for iface in self.interfaces.values():
            if iface.last is None:
                return {}
            for k, v in iface.last.counts().items():
                total[k] = total.get(k, 0) + v
        return {k: self.comm.allreduce(v) for k, v in total.items()}

    def _reactions(self, Fa: np.ndarray) -> dict[str, np.ndarray]:
        """Reaction force of every Dirichlet group (collective).

        The residual summed over the owned dofs of all conditions on the group, each dof once.
        """
        bs = self.V.dofmap.bs
        groups = self._reaction_dofs
        if not groups:
            return {}
        loc = np.zeros((len(groups), bs))
        for i, dofs in enumerate(groups.values()):
            np.add.at(loc[i], dofs % bs, Fa[dofs])
        tot = self.comm.allreduce(loc)
        return {k: tot[i] for i, k in enumerate(groups)}

    # ------------------------------------------------------------------------------------------
    def commit(self) -> None:
        """Accept the trial state of the interfaces and of the bulk (after a converged step).

        Collective.
        """
        if self.dynamics is not None:  # before the interfaces: it reads their slip increment
            self.dynamics.commit()
        for iface in self.interfaces.values():
            iface.commit()
        self.bulk.commit()

    def revert(self) -> None:
        """Reject the trial state of the interfaces and of the bulk (after a failed step)."""
        for iface in self.interfaces.values():
            iface.revert()
        self.bulk.revert()
        self._x_at_update = None

    def resume(self) -> None:
        """Continue from a restored state (:attr:`u` and every interface's committed state).

        Collective: a finite-sliding interface searches from it at the next step.
        """
        n = self.layout.n_owned
        for iface in self.interfaces.values():
            iface.resume(self.u.x.array[:n])
        self._x_at_update = None

    def create_matrix(self) -> PETSc.Mat:
        """A Jacobian matrix with the interface couplings preallocated."""
        return self.layout.create_matrix()

    def create_vector(self) -> PETSc.Vec:
        """A solution/residual vector (the displacement space's own layout)."""
        return petsc_vector(self.V.dofmap.index_map, self.V.dofmap.bs)

    def destroy(self) -> None:
        """Free the PETSc objects (safe to call more than once; the problem is unusable after).

        The bulk stiffness (and its scale), the work and load vectors and every interface's
        vectors; matrices and vectors handed out by :meth:`create_matrix` and
        :meth:`create_vector` are the caller's.
        """
        if getattr(self, "K_scale", None) is getattr(self, "K", None):
            self.K_scale = None  # the same matrix as K (a linear bulk)
        for name in ("K", "K_scale", "_bulk_work"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)
        for _, f in getattr(self, "loads", []):
            f.destroy()
        self.loads = []
        for iface in getattr(self, "interfaces", {}).values():
            iface.destroy()
        dynamics = getattr(self, "dynamics", None)
        if dynamics is not None:
            dynamics.destroy()

    def __enter__(self) -> InterfaceProblem:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()
