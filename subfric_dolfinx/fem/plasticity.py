"""J2 plasticity in the bodies: a bulk model with its state at the quadrature points (DOLFINx).

:class:`J2Bulk` gives every body a material: :class:`~subfric_dolfinx.constitutive.J2Material`
(small-strain J2 plasticity with linear isotropic and kinematic hardening, the numpy return map of
:mod:`subfric_dolfinx.constitutive.j2`) or :class:`~subfric_dolfinx.constitutive.LinearElastic`.
It implements the bulk-model protocol of the problem (``forms``, ``update``, ``commit``,
``revert``, ``state``, ``restore``):

* the stress, the consistent tangent and the state (plastic strain, backstress, equivalent
  plastic strain ``p``; committed copies with the suffix ``_old``) are DOLFINx functions in
  Quadrature spaces of the mesh (:attr:`J2Bulk.functions`); only the points of the J2 bodies'
  owned cells are used;
* the residual is ``int sigma_q : eps(v) w dx`` over the J2 bodies (``w`` the mode's weight:
  ``2 pi r`` in axisymmetric mode) plus ``int sigma_e(u) : eps(v) w dx`` over the elastic ones,
  the Jacobian ``int (C_q : eps(du)) : eps(v) w dx`` (``C_q`` the consistent tangent) plus the
  elastic part. The strain at the points is a DOLFINx ``Expression`` of ``u``;
* ``update(u)`` runs the return map from the committed state at every J2 point (a new iterate),
  ``commit()`` keeps the trial state, ``revert()`` restores the committed one.

Tensors are Mandel vectors: 6 components in 3-D, and in the plane-strain and axisymmetric modes
the 4 that are not zero, ``(11, 22, 33, sqrt2 12)`` (``33`` the out-of-plane or hoop component).
Modes: ``"3d"``, ``"plane_strain"``, ``"axisymmetric"``; in ``"plane_stress"`` only elastic bodies
are accepted (J2 in plane stress needs its own return map, with ``sigma_33 = 0`` at each point:
not provided).

Quadrature: degree ``2 (k - 1)`` (at least 1) for a degree-``k`` displacement on affine simplices
in 3-D and plane strain, ``2 k`` otherwise (axisymmetric, quadrilaterals, hexahedra, curved
cells); ``quadrature_degree`` overrides it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import basix
import basix.ufl
import dolfinx
import dolfinx.fem
import numpy as np
import ufl
from mpi4py import MPI

from ..compat import coordinate_element, eval_expression
from ..constitutive.j2 import J2Material, J2State, LinearElastic
from .kinematics import check_mode, elastic_stress, strain, weight

__all__ = ["J2Bulk", "PlasticityError", "mandel_strain"]

_PLANE = (0, 1, 2, 5)  # the Mandel components of a plane or axisymmetric state
STATE_NAMES = J2State.NAMES


class PlasticityError(ValueError):
    """A bad bulk set-up or restore (raised on every rank)."""


def mandel_strain(u, mode: str):
    """The small strain of ``u`` as a Mandel vector (UFL): 6 components in 3-D, else 4."""
    e = strain(u, mode)
    r2 = np.sqrt(2.0)
    if mode == "3d":
        return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], r2 * e[1, 2], r2 * e[0, 2], r2 * e[0, 1]])
    return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], r2 * e[0, 1]])


@dataclasses.dataclass
class _Body:
    name: str
    material: J2Material
    cells: np.ndarray  # owned cells
    points: np.ndarray  # Quadrature dofs (point indices), cell by cell


class J2Bulk:
    """J2 plasticity (or linear elasticity) per body, state at the quadrature points.

    Args:
        materials: Body (or cell group) name -> :class:`~subfric_dolfinx.constitutive.J2Material`
            or :class:`~subfric_dolfinx.constitutive.LinearElastic`; every body of the problem
            needs one (a cell group takes its own entry if it has one, else its body's).
        quadrature_degree: Degree of the quadrature rule of the J2 bodies (see module docstring).

    Attributes:
        functions: Quadrature functions (after :meth:`forms`): ``stress``, ``tangent``,
            ``plastic_strain``, ``backstress``, ``p`` (trial state) and ``plastic_strain_old``,
            ``backstress_old``, ``p_old`` (committed state).
        points: Physical coordinates of the J2 points this rank owns, (n, gdim), in the order
            of :meth:`at_points`.
        n_components: 6 (3-D) or 4.
        plastic_points: Number of J2 points (all ranks) that yielded at the last update.
        failed_points: Number of points (all ranks) the return map could not integrate at the
            last update (non-finite strain): they carry zero stress.
    """

    linear = False  # the residual is not linear in u: assembled at every iterate

    def __init__(
        self,
        materials: Mapping[str, J2Material | LinearElastic],
        *,
        quadrature_degree: int | None = None,
    ) -> None:
        for body, mat in materials.items():
            if not isinstance(mat, J2Material | LinearElastic):
                raise TypeError(
                    f"the material of body {body!r} must be a J2Material or LinearElastic, "
                    f"got {type(mat).__name__}"
                )
        if quadrature_degree is not None and (
            isinstance(quadrature_degree, bool)
            or not isinstance(quadrature_degree, int)
            or quadrature_degree < 1
        ):
            raise ValueError(
                f"quadrature_degree must be an integer >= 1, got {quadrature_degree!r}"
            )
        self.materials = dict(materials)
        self.quadrature_degree = quadrature_degree
        self.functions: dict[str, dolfinx.fem.Function] = {}
        self.points = np.zeros((0, 0))
        self.n_components = 0
        self.plastic_points = 0
        self.failed_points = 0
        self._bodies: list[_Body] = []
        self._exprs: dict[int, tuple[Any, dolfinx.fem.Expression]] = {}
        self._mesh: dolfinx.mesh.Mesh | None = None  # (set by forms)
        self._mode = ""
        self._X: np.ndarray = np.zeros((0, 0))
        self._comm = MPI.COMM_SELF
        self._n_owned_cells = 0
        self._owned_points = np.zeros(0, dtype=np.int32)

    # ------------------------------------------------------------------------------------
    def forms(self, u, v, du, ctx) -> tuple[ufl.Form, ufl.Form]:
        """The residual ``F(u; v)`` and its Jacobian; sets up the Quadrature spaces (once).

        Args:
            u: The displacement (a Function of ``ctx.V``).
            v: Test function of ``ctx.V``.
            du: Trial function of ``ctx.V``.
            ctx: The problem's bulk context (``mesh``, ``V``, ``mode``, ``dx``, ``tags``).

        Raises:
            PlasticityError: A body without a material or a material for an unknown body, bodies
                sharing a cell tag, J2 in plane stress.
            ValueError: An unknown mode, or one that does not fit the mesh.
        """
        mesh = ctx.mesh
        mode = check_mode(ctx.mode, mesh.geometry.dim)
        groups = self._groups(ctx)
        j2 = [g for g, (mat, _) in groups.items() if isinstance(mat, J2Material)]
        if j2 and mode == "plane_stress":
            raise PlasticityError(
                f"J2 plasticity in plane stress needs its own return map (sigma_zz = 0 at every "
                f"point), which is not provided: bodies {j2}; use 'plane_strain', "
                f"'axisymmetric' or '3d', or LinearElastic materials"
            )
        self._mesh, self._mode, self._comm = mesh, mode, mesh.comm
        wt = weight(mesh, mode)
        F: Any = 0
        J: Any = 0
        for mat, ts in groups.values():
            if isinstance(mat, LinearElastic):
                dxb = ctx.dx(ts[0] if len(ts) == 1 else ts)
                sig = elastic_stress(strain(u, mode), mat.E, mat.nu, mode)
                F += ufl.inner(sig, strain(v, mode)) * wt * dxb
                dsig = elastic_stress(strain(du, mode), mat.E, mat.nu, mode)
                J += ufl.inner(dsig, strain(v, mode)) * wt * dxb
        self._setup_points(
            ctx, {g: (mat, ts) for g, (mat, ts) in groups.items() if isinstance(mat, J2Material)}
        )
        if j2:
            fn = self.functions
            dxq = ctx.dx(tuple(t for g in j2 for t in groups[g][1]))
            ev, edu = mandel_strain(v, mode), mandel_strain(du, mode)
            F += ufl.dot(fn["stress"], ev) * wt * dxq
            J += ufl.dot(ufl.dot(fn["tangent"], edu), ev) * wt * dxq
        return F, J

    def _groups(self, ctx) -> dict[str, tuple[J2Material | LinearElastic, tuple[int, ...]]]:
        """Cell group -> (its material, its tags).

        A group takes its own entry of :attr:`materials` if it has one, else its body's.
        """
        tags = {name: tuple(int(t) for t in np.atleast_1d(ts)) for name, ts in ctx.tags.items()}
        bodies = dict(getattr(ctx, "groups", None) or {}) or {name: (name,) for name in tags}
        if not bodies:
            raise PlasticityError("no bodies: the context's tags are empty")
        out: dict[str, tuple[J2Material | LinearElastic, tuple[int, ...]]] = {}
        missing = []
        for body, names in bodies.items():
            for g in names:
                mat = self.materials.get(g, self.materials.get(body))
                if mat is None:
                    missing.append(body if g == body else f"{body} (cell group {g})")
                elif g not in out:
                    out[g] = (mat, tags[g])
        unknown = sorted(set(self.materials) - set(tags) - set(bodies))
        if missing or unknown:
            raise PlasticityError(
                f"every body needs a material: bodies without one: {missing}; materials for "
                f"unknown bodies: {unknown} (bodies: {sorted(bodies)})"
            )
        seen: dict[int, str] = {}
        for g, (_, ts) in out.items():
            for t in ts:
                if t in seen:
                    raise PlasticityError(f"bodies {seen[t]!r} and {g!r} share cell tag {t}")
                seen[t] = g
        return out

    def _degree(self, V: dolfinx.fem.FunctionSpace) -> int:
        if self.quadrature_degree is not None:
            return self.quadrature_degree
        k = V.ufl_element().embedded_superdegree
        mesh = V.mesh
        simplex = mesh.topology.cell_name() in ("interval", "triangle", "tetrahedron")
        affine = coordinate_element(mesh).degree == 1
        if simplex and affine and self._mode != "axisymmetric":
            return max(2 * (k - 1), 1)
        return 2 * k

    def _setup_points(self, ctx, j2: dict[str, tuple[J2Material, tuple[int, ...]]]) -> None:
        mesh, mode = ctx.mesh, self._mode
        tdim = mesh.topology.dim
        self._n_owned_cells = mesh.topology.index_map(tdim).size_local
        if not j2:
            return
        nc = 6 if mode == "3d" else 4
        self.n_components = nc
        cname = mesh.topology.cell_name()
        deg = self._degree(ctx.V)
        X, w = basix.make_quadrature(basix.CellType[cname], deg)
        X = np.asarray(X)  # (basix annotates an ArrayLike; it is an array: no copy)
        self._X = X

        def space(shape):
            qe = basix.ufl.quadrature_element(cname, value_shape=shape, points=X, weights=w)
            return dolfinx.fem.functionspace(mesh, qe)

        Qs, Qv, Qt = space(()), space((nc,)), space((nc, nc))
        F = dolfinx.fem.Function
        fn = {"stress": F(Qv, name="stress"), "tangent": F(Qt, name="tangent")}
        for name in STATE_NAMES:
            Q = Qs if name == "p" else Qv
            fn[name] = F(Q, name=name)
            fn[name + "_old"] = F(Q, name=name + "_old")
        self.functions = fn
        n_owned = self._n_owned_cells
        cell_tags = ctx.dx.subdomain_data()
        nq = X.shape[0]
        for Q in (Qv, Qt):
            if not np.array_equal(Q.dofmap.list, Qs.dofmap.list):
                raise RuntimeError("unexpected layout of the blocked Quadrature spaces")
        self._bodies = []
        for g, (mat, ts) in j2.items():
            cells = np.unique(np.concatenate([cell_tags.find(t) for t in ts]))
            cells = cells[cells < n_owned].astype(np.int32)
            pts = Qs.dofmap.list[cells].reshape(-1)
            if pts.size != cells.size * nq:
                raise RuntimeError("unexpected layout of the Quadrature space")
            self._bodies.append(_Body(g, mat, cells, pts))
        # the owned cells' points, cell by cell (the layout of state() and restore())
        self._owned_points = Qs.dofmap.list[:n_owned].reshape(-1)
        # the elastic tangent where nothing has happened yet
        tangent = fn["tangent"].x.array.reshape(-1, nc, nc)
        for body in self._bodies:
            tangent[body.points] = self._reduce_tangent(body.material.elastic_tangent())
        gdim = mesh.geometry.dim
        xexpr = dolfinx.fem.Expression(ufl.SpatialCoordinate(mesh), X)
        xs = [eval_expression(xexpr, mesh, b.cells, gdim).reshape(-1, gdim) for b in self._bodies]
        self.points = np.concatenate(xs) if xs else np.zeros((0, gdim))

    # ------------------------------------------------------------------------------------
    def _widen(self, a: np.ndarray) -> np.ndarray:
        """(n, nc) -> (n, 6) Mandel."""
        if self.n_components == 6:
            return np.array(a)
        out = np.zeros((a.shape[0], 6))
        out[:, _PLANE] = a
        return out

    def _narrow(self, a: np.ndarray) -> np.ndarray:
        return a if self.n_components == 6 else a[:, _PLANE]

    def _reduce_tangent(self, C: np.ndarray) -> np.ndarray:
        return C if self.n_components == 6 else C[..., _PLANE, :][..., _PLANE]

    def _arrays(self, suffix: str) -> dict[str, np.ndarray]:
        nc = self.n_components
        return {
            k: self.functions[k + suffix].x.array.reshape((-1, nc) if k != "p" else (-1,))
            for k in STATE_NAMES
        }

    def _expression(self, u) -> dolfinx.fem.Expression:
        key = id(u)
        if key not in self._exprs or self._exprs[key][0] is not u:
            self._exprs[key] = (u, dolfinx.fem.Expression(mandel_strain(u, self._mode), self._X))
        return self._exprs[key][1]

    def update(self, u: dolfinx.fem.Function) -> None:
        """The return map at every J2 point for the iterate ``u`` (collective).

        Reads the committed state, writes the trial state, the stress and the tangent.
        """
        plastic = failed = 0
        if self._bodies:
            nc = self.n_components
            expr = self._expression(u)
            old, new = self._arrays("_old"), self._arrays("")
            stress = self.functions["stress"].x.array.reshape(-1, nc)
            tangent = self.functions["tangent"].x.array.reshape(-1, nc, nc)
            assert self._mesh is not None  # (set with the bodies)
            for b in self._bodies:
                eps = eval_expression(expr, self._mesh, b.cells, nc).reshape(-1, nc)
                st = J2State(
                    self._widen(old["plastic_strain"][b.points]),
                    self._widen(old["backstress"][b.points]),
                    old["p"][b.points],
                )
                res = b.material.return_map(self._widen(eps), st)
                stress[b.points] = self._narrow(res.stress)
                tangent[b.points] = self._reduce_tangent(res.tangent)
                new["plastic_strain"][b.points] = self._narrow(res.state.plastic_strain)
                new["backstress"][b.points] = self._narrow(res.state.backstress)
                new["p"][b.points] = res.state.p
                plastic += int(np.count_nonzero(res.plastic))
                failed += int(np.count_nonzero(res.failed))
        counts = np.array([plastic, failed], dtype=np.int64)
        self._comm.Allreduce(MPI.IN_PLACE, counts, op=MPI.SUM)
        self.plastic_points, self.failed_points = int(counts[0]), int(counts[1])

    def commit(self) -> None:
        """The step converged: the trial state becomes the committed one."""
        for k in STATE_NAMES if self.functions else ():
            self.functions[k + "_old"].x.array[:] = self.functions[k].x.array

    def revert(self) -> None:
        """The step failed: the trial state is reset to the committed one."""
        for k in STATE_NAMES if self.functions else ():
            self.functions[k].x.array[:] = self.functions[k + "_old"].x.array

    # ------------------------------------------------------------------------------------
    def _owned_indices(self) -> np.ndarray:
        if not self._bodies:
            return np.zeros(0, dtype=np.int32)
        return np.concatenate([b.points for b in self._bodies])

    def at_points(self, name: str) -> np.ndarray:
        """Values of a function of :attr:`functions` at this rank's J2 points (a copy).

        In the order of :attr:`points`: (n,) for ``p``, (n, nc) or (n, nc, nc) for the others.
        """
        f = self.functions[name]
        bs = f.function_space.dofmap.bs
        vals = f.x.array.reshape(-1, bs)[self._owned_indices()]
        if name in ("p", "p_old"):
            return vals[:, 0].copy()
        nc = self.n_components
        return vals.reshape(-1, nc, nc) if name == "tangent" else vals.copy()

    def saved_state(self) -> dict[str, np.ndarray]:
        """This rank's committed state (copies), for checkpoints, by owned cell.

        Returns:
            ``plastic_strain`` and ``backstress`` ((n_owned_cells * nq, nc), Mandel) and ``p``
            ((n_owned_cells * nq,)): every owned cell's ``nq`` points, cell by cell in the
            mesh's local order (zeros in the cells of elastic bodies); empty without J2 bodies.
        """
        if not self.functions:
            return {}
        old = self._arrays("_old")
        return {k: old[k][self._owned_points].copy() for k in STATE_NAMES}

    def restore_state(self, data: Mapping[str, np.ndarray]) -> None:
        """Set the committed and trial state from arrays laid out as :meth:`saved_state` gives them.

        Collective: an error is raised on every rank.

        Raises:
            PlasticityError: A missing or unknown key, a wrong shape or a non-finite value.
        """
        error = None
        try:
            rows = self._restore_rows(data)
        except PlasticityError as e:
            error, rows = str(e), {}
        errors = [m for m in self._comm.allgather(error) if m]
        if errors:
            raise PlasticityError(errors[0])
        if not self.functions:
            return
        old, new = self._arrays("_old"), self._arrays("")
        for k in STATE_NAMES:
            old[k][self._owned_points] = rows[k]
            new[k][self._owned_points] = rows[k]

    def _restore_rows(self, data: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        names = STATE_NAMES if self.functions else ()
        extra = sorted(set(data) - set(names))
        missing = sorted(set(names) - set(data))
        if extra or missing:
            raise PlasticityError(
                f"the J2 state needs the arrays {list(names)}; missing: {missing}, unknown: {extra}"
            )
        n, nc = self._owned_points.size if names else 0, self.n_components
        out = {}
        for k in names:
            a = np.asarray(data[k], dtype=float)
            want = (n,) if k == "p" else (n, nc)
            if a.shape != want:
                raise PlasticityError(f"J2 state {k!r} has shape {a.shape}, expected {want}")
            if not np.isfinite(a).all():
                raise PlasticityError(f"J2 state {k!r} has non-finite values")
            out[k] = a
        return out
