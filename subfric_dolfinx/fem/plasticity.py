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
from .interface.geometry import match_points
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
        return ufl.as_vector(
            [e[0, 0], e[1, 1], e[2, 2], r2 * e[1, 2], r2 * e[0, 2], r2 * e[0, 1]]
        )
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
        materials: Body name -> :class:`~subfric_dolfinx.constitutive.J2Material` or
            :class:`~subfric_dolfinx.constitutive.LinearElastic`; every body of the problem
            needs one.
        quadrature_degree: Degree of the quadrature rule of the J2 bodies (see module docstring).

    Attributes:
        functions: Quadrature functions (after :meth:`forms`): ``stress``, ``tangent``,
            ``plastic_strain``, ``backstress``, ``p`` (trial state) and ``plastic_strain_old``,
            ``backstress_old``, ``p_old`` (committed state).
        points: Physical coordinates of the J2 points this rank owns, (n, gdim), in the order
            of :meth:`state`.
        n_components: 6 (3-D) or 4.
        plastic_points: Number of J2 points (all ranks) that yielded at the last update.
        failed_points: Number of points (all ranks) the return map could not integrate at the
            last update (non-finite strain): they carry zero stress.
    """

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
        self._mesh = None
        self._mode = ""
        self._X = np.zeros((0, 0))
        self._comm = MPI.COMM_SELF

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
                sharing a cell tag, J2 in plane stress, an unknown mode.
        """
        mesh = ctx.mesh
        mode = check_mode(ctx.mode, mesh.geometry.dim)
        tags = {name: tuple(int(t) for t in np.atleast_1d(ts)) for name, ts in ctx.tags.items()}
        missing = sorted(set(tags) - set(self.materials))
        unknown = sorted(set(self.materials) - set(tags))
        if missing or unknown:
            raise PlasticityError(
                f"every body needs a material: bodies without one: {missing}; materials for "
                f"unknown bodies: {unknown} (bodies: {sorted(tags)})"
            )
        seen: dict[int, str] = {}
        for name, ts in tags.items():
            for t in ts:
                if t in seen:
                    raise PlasticityError(f"bodies {seen[t]!r} and {name!r} share cell tag {t}")
                seen[t] = name
        j2 = [b for b in tags if isinstance(self.materials[b], J2Material)]
        if j2 and mode == "plane_stress":
            raise PlasticityError(
                f"J2 plasticity in plane stress needs its own return map (sigma_zz = 0 at every "
                f"point), which is not provided: bodies {j2}; use 'plane_strain', "
                f"'axisymmetric' or '3d', or LinearElastic materials"
            )
        self._mesh, self._mode, self._comm = mesh, mode, mesh.comm
        wt = weight(mesh, mode)
        F = 0
        J = 0
        for name, ts in tags.items():
            mat = self.materials[name]
            if isinstance(mat, LinearElastic):
                dxb = ctx.dx(ts)
                sig = elastic_stress(strain(u, mode), mat.E, mat.nu, mode)
                F += ufl.inner(sig, strain(v, mode)) * wt * dxb
                dsig = elastic_stress(strain(du, mode), mat.E, mat.nu, mode)
                J += ufl.inner(dsig, strain(v, mode)) * wt * dxb
        if j2:
            self._setup_points(ctx, tags, j2)
            fn = self.functions
            dxq = ctx.dx(tuple(t for b in j2 for t in tags[b]))
            ev, edu = mandel_strain(v, mode), mandel_strain(du, mode)
            F += ufl.dot(fn["stress"], ev) * wt * dxq
            J += ufl.dot(ufl.dot(fn["tangent"], edu), ev) * wt * dxq
        if isinstance(F, int):
            raise PlasticityError("no bodies: the context's tags are empty")
        return F, J

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

    def _setup_points(self, ctx, tags: dict[str, tuple[int, ...]], j2: list[str]) -> None:
        mesh, mode = ctx.mesh, self._mode
        nc = 6 if mode == "3d" else 4
        self.n_components = nc
        cname = mesh.topology.cell_name()
        deg = self._degree(ctx.V)
        X, w = basix.make_quadrature(basix.CellType[cname], deg)
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
        tdim = mesh.topology.dim
        n_owned = mesh.topology.index_map(tdim).size_local
        cell_tags = ctx.dx.subdomain_data()
        nq = X.shape[0]
        for Q in (Qv, Qt):
            if not np.array_equal(Q.dofmap.list, Qs.dofmap.list):
                raise RuntimeError("unexpected layout of the blocked Quadrature spaces")
        self._bodies = []
        for b in j2:
            cells = np.unique(np.concatenate([cell_tags.find(t) for t in tags[b]]))
            cells = cells[cells < n_owned].astype(np.int32)
            pts = Qs.dofmap.list[cells].reshape(-1)
            if pts.size != cells.size * nq:
                raise RuntimeError("unexpected layout of the Quadrature space")
            self._bodies.append(_Body(b, self.materials[b], cells, pts))
        # the elastic tangent where nothing has happened yet
        tangent = fn["tangent"].x.array.reshape(-1, nc, nc)
        for body in self._bodies:
            tangent[body.points] = self._reduce_tangent(body.material.elastic_tangent())
        gdim = mesh.geometry.dim
        xexpr = dolfinx.fem.Expression(ufl.SpatialCoordinate(mesh), X)
        xs = [
            eval_expression(xexpr, mesh, b.cells, gdim).reshape(-1, gdim) for b in self._bodies
        ]
        self.points = np.concatenate(xs) if xs else np.zeros((0, gdim))
        # points closer than 1e-8 of the J2 bodies' extent are the same point (restore)
        ext = np.full(2 * gdim, -np.inf)
        if self.points.size:
            ext[:gdim], ext[gdim:] = -self.points.min(axis=0), self.points.max(axis=0)
        mesh.comm.Allreduce(MPI.IN_PLACE, ext, op=MPI.MAX)
        span = ext[gdim:] + ext[:gdim]
        self._match_tol = 1e-8 * float(np.linalg.norm(span)) if np.all(span >= 0) else 0.0

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

    def state(self) -> dict[str, np.ndarray]:
        """This rank's committed state at its J2 points (copies), for checkpoints.

        Returns:
            ``x`` (the points' coordinates, (n, gdim)), ``plastic_strain`` and ``backstress``
            ((n, nc), Mandel) and ``p`` ((n,)), in the order of :attr:`points`.
        """
        idx = self._owned_indices()
        old = self._arrays("_old") if self.functions else {}
        out = {"x": self.points.copy()}
        for k in STATE_NAMES:
            out[k] = old[k][idx].copy() if self.functions else np.zeros((0,))
        return out

    def restore(self, data: Mapping[str, np.ndarray]) -> None:
        """Set the committed and trial state from :meth:`state`'s arrays (collective).

        With ``x``, rows are matched to this rank's points by their coordinates (the data may
        hold more rows, e.g. every rank's, in any order); without it, they are taken in the
        order of :attr:`points`.

        Raises:
            PlasticityError: A missing key, a wrong shape, a non-finite value, or a point of this
                rank's without a row (on every rank).
        """
        error = None
        try:
            rows = self._restore_rows(data)
        except PlasticityError as e:
            error, rows = str(e), None
        errors = [m for m in self._comm.allgather(error) if m]
        if errors:
            raise PlasticityError(errors[0])
        if not self.functions:
            return
        idx = self._owned_indices()
        old, new = self._arrays("_old"), self._arrays("")
        for k in STATE_NAMES:
            old[k][idx] = rows[k]
            new[k][idx] = rows[k]

    def _restore_rows(self, data: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        n, nc = self.points.shape[0], self.n_components
        for k in STATE_NAMES:
            if k not in data:
                raise PlasticityError(f"the J2 state has no {k!r}; keys: {sorted(data)}")
        arrays = {k: np.asarray(data[k], dtype=float) for k in STATE_NAMES}
        m = arrays["p"].shape[0] if arrays["p"].ndim == 1 else -1
        for k, a in arrays.items():
            want = (m,) if k == "p" else (m, nc)
            if a.shape != want or m < 0:
                raise PlasticityError(f"J2 state {k!r} has shape {a.shape}, expected {want}")
            if not np.isfinite(a).all():
                raise PlasticityError(f"J2 state {k!r} has non-finite values")
        if "x" in data:
            x = np.asarray(data["x"], dtype=float)
            if x.shape != (m, self.points.shape[1]):
                raise PlasticityError(
                    f"J2 state 'x' has shape {x.shape}, expected ({m}, {self.points.shape[1]})"
                )
            take, _ = match_points(x, self.points, self._match_tol)
            if np.any(take < 0):
                where = ", ".join(f"{c:.6g}" for c in self.points[np.flatnonzero(take < 0)[0]])
                raise PlasticityError(f"the J2 state has no row for the point ({where})")
        elif m != n:
            raise PlasticityError(f"the J2 state has {m} rows, this rank owns {n} points")
        else:
            take = np.arange(n)
        return {k: a[take] for k, a in arrays.items()}
