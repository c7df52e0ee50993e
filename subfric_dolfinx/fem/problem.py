"""Two linear-elastic bodies joined by a frictional zero-thickness interface.

The residual is ``F(u) = K u - f_ext(t) + R_int(u)`` with ``K`` the bulk stiffness assembled once
from UFL (small strain, plane strain in 2-D; one material per body; springs ``k_i u_i v_i`` on
their facets), ``f_ext`` the tractions, pressures, point forces and the springs' moving ends, each
scaled by its loading channel (:mod:`.boundary`), and ``R_int`` the interface forces from the
friction law's return map. Dirichlet rows are replaced by ``u - g(t)`` and the Jacobian rows by
identity rows, which keeps the Jacobian exact (no symmetric elimination, no lifting).

The interface's return map runs in :meth:`InterfaceProblem.residual`; its consistent tangent is
reused by :meth:`InterfaceProblem.jacobian` at the same iterate.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from ..compat import petsc_vector
from ..constitutive import FrictionLaw
from ..loading import LoadingProgram
from .boundary import check_groups, dirichlet_dofs, load_vectors, spring_forms
from .conditions import (
    Dirichlet,
    DirichletField,
    Material,
    PointForce,
    Pressure,
    Spring,
    Traction,
    channels,
)
from .interface import ExtendedLayout, InterfaceElements, InterfaceError, pair_interface
from .interface.regions import element_regions
from .timing import TIMER_BULK, TIMER_INTERFACE, TIMER_RETURN_MAP, TIMER_SETUP, Timings

__all__ = ["PENETRATION_WARNING", "InterfaceProblem", "stiffen_separated"]

logger = logging.getLogger(__name__)

PENETRATION_WARNING = 0.1
"""A penetration ``ubar_n`` beyond this fraction of the interface element size is warned about
(once per run, naming the largest): the penalty is too soft for the mesh, and the geometrically
linear model (pairs and frames fixed at the reference geometry) no longer describes the contact."""


class InterfaceProblem:
    """Residual and Jacobian of two elastic bodies with a frictional interface.

    Args:
        domain: The bulk mesh with its tags, e.g. a :class:`~subfric_dolfinx.meshing.InterfaceMesh`
            (anything with ``mesh``, ``cell_tags``, ``facet_tags`` and ``tags``, name -> tag);
            its interface nodes must be duplicated.
        law: The friction law (a :class:`~subfric_dolfinx.constitutive.FrictionLaw`).
        materials: Body name (``master``/``slave``) -> :class:`Material`.
        program: Loading program whose channels the conditions refer to.
        dirichlet: Prescribed displacements (on facet, cell or node groups).
        loads: Tractions, pressures and point forces.
        springs: Elastic supports (:class:`Spring`).
        degree: Displacement degree (1 or 2).
        quadrature: Interface quadrature, ``"gauss"`` or ``"nodal"``.
        names: Group names of ``interface``, ``master`` and ``slave`` if not these.
        initial_gap: Initial normal gap ``g0`` of the interface (mm, > 0 open): a number or a
            function of the coordinates ``x`` (gdim, n) (see
            :class:`~.interface.InterfaceElements`).
        regions: Interface regions: name of a subgroup of the interface (see
            :attr:`~subfric_dolfinx.meshing.InterfaceMesh.interface_groups`) -> its law; ``law``
            holds elsewhere. :attr:`law` is then a
            :class:`~subfric_dolfinx.constitutive.RegionalLaw`.

    Raises:
        InterfaceError: A required physical group is missing (named), or the interface is unusable.
    """

    def __init__(
        self,
        domain,
        law: FrictionLaw,
        materials: Mapping[str, Material],
        program: LoadingProgram,
        dirichlet: Sequence[Dirichlet | DirichletField] = (),
        loads: Sequence[Traction | Pressure | PointForce] = (),
        *,
        springs: Sequence[Spring] = (),
        degree: int = 1,
        quadrature: str = "gauss",
        names: Mapping[str, str] | None = None,
        initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None,
        regions: Mapping[str, FrictionLaw] | None = None,
    ) -> None:
        self.timings = Timings()
        mesh, cell_tags, facet_tags = domain.mesh, domain.cell_tags, domain.facet_tags
        self.domain = domain
        self.mesh = mesh
        self.comm = mesh.comm
        self.law = law
        self.program = program
        self.materials = dict(materials)
        self.tags = dict(domain.tags)
        nm = {"interface": "interface", "master": "master", "slave": "slave", **(names or {})}
        needed = [nm["interface"], nm["master"], nm["slave"]]
        needed += [c.body for c in loads if isinstance(c, PointForce) and c.body is not None]
        missing = [g for g in dict.fromkeys(needed) if g not in self.tags]
        if missing:
            raise InterfaceError(
                f"the mesh lacks the physical group(s) {missing}; it has {sorted(self.tags)}"
            )
        gdim = mesh.geometry.dim
        for c in [*dirichlet, *loads, *springs]:
            n = gdim if isinstance(c, Traction | PointForce | Spring) else 1
            for ch in channels(c.amplitude, n, f"{type(c).__name__} on {c.group!r}"):
                program.amplitude(ch, program.t_start)  # unknown channel -> LoadingError
        self.group_kinds = check_groups(domain, [*dirichlet, *loads, *springs])
        if degree not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got {degree!r}")
        tdim = mesh.topology.dim
        self.gdim = gdim
        V = dolfinx.fem.functionspace(mesh, ("Lagrange", degree, (gdim,)))
        self.V = V
        self.u = dolfinx.fem.Function(V, name="displacement")

        with self.timings(TIMER_SETUP):
            self.pairs = pair_interface(
                V,
                cell_tags,
                facet_tags,
                self.tags[nm["interface"]],
                self.tags[nm["master"]],
                self.tags[nm["slave"]],
            )
            by_region = None
            if regions:
                groups = getattr(domain, "interface_groups", None) or {}
                by_region = (element_regions(self.pairs, groups, list(regions)), dict(regions))
            self.interface = InterfaceElements(
                self.pairs, V, law, quadrature, initial_gap=initial_gap, regions=by_region
            )
            self.law = self.interface.law
            self.layout = ExtendedLayout(V, self.pairs.index_map, self.interface.nodes)

        # Bulk stiffness from UFL, one material per body.
        du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)

        def eps(w):
            return ufl.sym(ufl.grad(w))

        a = 0
        for body in ("master", "slave"):
            if nm[body] not in materials and body not in materials:
                raise ValueError(f"no material given for the {body} body")
            mat = materials.get(nm[body], materials.get(body))
            lam = mat.E * mat.nu / ((1 + mat.nu) * (1 - 2 * mat.nu))
            mu = mat.E / (2 * (1 + mat.nu))
            sig = 2 * mu * eps(du) + lam * ufl.tr(eps(du)) * ufl.Identity(gdim)
            a = a + ufl.inner(sig, eps(v)) * dx(self.tags[nm[body]])
        a_springs, spring_loads, self.spring_forces = spring_forms(V, domain, springs, ds)
        a = a + a_springs
        self.springs = list(springs)
        with self.timings(TIMER_BULK):
            self.K = self.layout.create_matrix()
            dolfinx.fem.petsc.assemble_matrix(self.K, dolfinx.fem.form(a))
            self.K.assemble()
            # Load vectors, one per condition and channel (scaled by the channel at run time).
            self.loads = load_vectors(V, domain, loads, ds) + spring_loads

        # Dirichlet dofs (owned, unrolled) with their reference values.
        mesh.topology.create_connectivity(tdim - 1, tdim)
        bs = V.dofmap.bs
        self.dirichlet = [
            (c, *dirichlet_dofs(V, domain, c, self.group_kinds[c.group])) for c in dirichlet
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
        self.K.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)

        self.x_ext = self.layout.create_vector()
        self.b_ext = self.layout.create_vector()
        self.t = program.t_start
        self.dt = 0.0
        self._x_at_update: np.ndarray | None = None
        self.reactions: dict[str, np.ndarray] = {}
        self.penetration: dict | None = None  # the largest beyond the warning, see commit
        self._penetration_warned = False
        self._h_points: np.ndarray | None = None

    # ------------------------------------------------------------------------------------------
    def set_step(self, t: float, dt: float) -> None:
        """Set the time at the end of the step and the step length (drives recovery)."""
        self.t, self.dt = float(t), float(dt)
        self._x_at_update = None

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

    def _update_interface(self, x: PETSc.Vec):
        with self.timings(TIMER_INTERFACE):
            xa = self.x_ext.array_w
            xa[: self.layout.n_owned] = x.array_r
            self.x_ext.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with self.timings(TIMER_RETURN_MAP):
            with self.x_ext.localForm() as xl:
                res = self.interface.update(xl.array_r, self.dt)
        self._x_at_update = x.array_r.copy()
        return res

    def residual(self, x: PETSc.Vec, F: PETSc.Vec) -> bool:
        """Assemble ``F(x)``; return False if the return map failed at some point."""
        res = self._update_interface(x)
        with self.timings(TIMER_BULK):
            self.K.mult(x, F)
            for c, f in self.loads:
                F.axpy(-self.program.amplitude(c.amplitude, self.t), f)
        with self.timings(TIMER_INTERFACE):
            with self.b_ext.localForm() as bl:
                bl.set(0.0)
                self.interface.add_residual(bl.array_w, res.traction)
            self.b_ext.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            Fa = F.array_w
            Fa += self.b_ext.array_r[: self.layout.n_owned]
            # reactions: forces at Dirichlet dofs before the rows are replaced
            self.reactions = self._reactions(Fa)
            idx, val = self.dirichlet_values(self.t)
            Fa[idx] = x.array_r[idx] - val
        return res.converged

    def jacobian(self, x: PETSc.Vec, J: PETSc.Mat, separated_stiffness: float = 0.0) -> None:
        """Assemble the Jacobian at ``x`` (reusing the tangent of the last residual there).

        ``separated_stiffness``: in this Jacobian only (not the residual), points without
        stiffness (separated beyond the contact band, failed) get this fraction of the law's
        contact stiffness (:func:`stiffen_separated`); 0: the exact tangent.
        """
        if self._x_at_update is None or not np.array_equal(self._x_at_update, x.array_r):
            self._update_interface(x)
        res = self.interface.last
        with self.timings(TIMER_BULK):
            J.zeroEntries()
            J.axpy(1.0, self.K, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        with self.timings(TIMER_INTERFACE):
            tangent = stiffen_separated(res.tangent, self.law, separated_stiffness)
            Ke = self.interface.element_matrices(tangent)
            nodes = self.interface.nodes.astype(PETSc.IntType)
            if nodes.shape[0]:
                J.setValuesBlockedLocalRCV(nodes, nodes, Ke, addv=PETSc.InsertMode.ADD_VALUES)
            J.assemble()
            J.zeroRows(self.bc_rows, diag=1.0)

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
        """Accept the interface's trial state (after a converged step; collective).

        Also tracks the largest penetration ``ubar_n`` relative to the interface element size
        over the run (:attr:`penetration`, see :meth:`warn_penetration`).
        """
        self.interface.commit()
        self._track_penetration()

    def _track_penetration(self) -> None:
        el = self.interface
        if self._h_points is None:  # element size at each point: length (2-D), sqrt(area) (3-D)
            size = el.weights.sum(axis=1) ** (1.0 / max(self.gdim - 1, 1))
            self._h_points = np.repeat(size, el.nq)
        un = el.last_gap[:, el.nt] if el.last_gap.size else np.zeros(0)
        ratio = un / self._h_points if un.size else un
        i = int(np.argmax(ratio)) if ratio.size else -1
        local = float(ratio[i]) if ratio.size else -np.inf
        largest = self.comm.allreduce(local, op=MPI.MAX)
        known = self.penetration["ratio"] if self.penetration else PENETRATION_WARNING
        if not largest > known * (1.0 + 1e-3):  # one number per step, details when it grows
            return
        mine = None
        if local == largest:
            x = el.points.reshape(-1, self.gdim)[i]
            mine = {
                "ratio": largest,
                "ubar_n": float(un[i]),
                "h": float(self._h_points[i]),
                "x": tuple(float(v) for v in x),
                "f_n": float(el.last.traction[i, el.nt]),
                "t": self.t,
            }
        self.penetration = next(p for p in self.comm.allgather(mine) if p is not None)

    def warn_penetration(self) -> None:
        """Warn once (log; rank 0 prints) if a penetration was large: name the largest, where, when.

        Large: beyond :data:`PENETRATION_WARNING` times the interface element size. Not
        collective (:meth:`commit` gathered it): safe while an error unwinds. The load stepper
        calls it when its run ends, however it ends.
        """
        pen = self.penetration
        if pen is None or self._penetration_warned:
            return
        self._penetration_warned = True
        where = ", ".join(f"{v:.6g}" for v in pen["x"])
        logger.warning(
            "large penetration: ubar_n up to %.4g mm (at (%s), t = %.6g, f_n = %.4g MPa), %.3g "
            "times the interface element size there (%.4g mm; warned beyond %g): the normal "
            "penalty is soft for this mesh, and the small-sliding interface is no longer "
            "accurate",
            pen["ubar_n"], where, pen["t"], pen["f_n"], pen["ratio"], pen["h"],
            PENETRATION_WARNING,
        )  # fmt: skip

    def revert(self) -> None:
        """Reject the interface's trial state (after a failed step)."""
        self.interface.revert()

    def create_matrix(self) -> PETSc.Mat:
        """A Jacobian matrix with the interface couplings preallocated."""
        return self.layout.create_matrix()

    def create_vector(self) -> PETSc.Vec:
        """A solution/residual vector (the displacement space's own layout)."""
        return petsc_vector(self.V.dofmap.index_map, self.V.dofmap.bs)


def stiffen_separated(tangent: np.ndarray, law: FrictionLaw, fraction: float) -> np.ndarray:
    """The tangent with ``fraction`` of the contact stiffness at points that have none.

    A point separated beyond the contact band (or failed) has a zero tangent: where every point
    of a body's interface is so, and no support holds the body in some direction, the Jacobian
    is singular (a block pulled sideways without load may tip about its one touching point, then
    a pressure finds it floating: a failed linear solve). A Newton step on a Jacobian where such
    points keep ``fraction * diag(alpha_t, ..., alpha_n)`` exists, and leaves the undetermined
    motions alone where nothing pushes them; the residual, hence the converged solution, is
    unchanged. Used by :class:`~.stepping.LoadStepper` in the retry of a failed step
    (:data:`~.stepping.RETRY_SEPARATED_STIFFNESS`).

    Args:
        tangent: Consistent tangents (N, m, m).
        law: The law (its ``alpha_t``, ``alpha_n``; the largest over regions).
        fraction: Fraction of the contact stiffness; 0 returns ``tangent`` itself.
    """
    if not fraction or tangent.shape[0] == 0:
        return tangent
    free = ~tangent.reshape(tangent.shape[0], -1).any(axis=1)
    if not free.any():
        return tangent
    m = tangent.shape[-1]
    diag = np.full(m, float(law.alpha_t))
    diag[-1] = float(law.alpha_n)
    out = tangent.copy()
    out[free] = fraction * np.diag(diag)
    return out
