"""Zero-thickness interface elements: quadrature, local frames, state, gap and assembly kernels.

An interface element is a pair of coincident facets (primary and secondary) with ``nfd``
displacement nodes each. At its quadrature points the relative displacement is

    ubar = sum_k N_k (u_secondary,k - u_primary,k)

and its local components are ``gap = Q ubar`` with ``Q`` the rows ``(e1, [e2,] -n)``: ``n`` is the
primary's outward normal, so ``gap_n = -n . ubar > 0`` on approach. The friction law returns the
local traction ``(f_t, f_n)``; the traction on the primary body in global components is
``f = Q^T (f_t, f_n) = f_t e - f_n n``. It is the derivative of the interface energy with respect
to ``ubar``, so the interface adds ``+int N f`` to the secondary rows of the residual and
``-int N f`` to the primary rows, and ``int N N Q^T D Q`` with the signs of ``[[1, -1], [-1, 1]]``
to the Jacobian (``D`` the consistent tangent of the law, not symmetric).

An initial gap ``g0`` (per point, > 0 where the interface starts open) enters the law's normal
input as ``ubar_n - g0``: the bodies touch where ``ubar_n`` reaches ``g0``. Interface regions
give points their own law (a :class:`~subfric_dolfinx.constitutive.RegionalLaw`).

Geometrically linear: small sliding, the pairs and frames are fixed at the reference geometry.

The internal variables live in DOLFINx Quadrature functions on the interface submesh (one cell per
owned primary facet), point ``q`` of cell ``c`` at index ``c * nq + q``; they are not ghosted.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import cast

import basix
import basix.ufl
import dolfinx
import numpy as np

from ....compat import geometry_dofmap
from ....constitutive import (
    LOCAL,
    SCALAR,
    FrictionLaw,
    InterfaceState,
    RegionalLaw,
    ReturnMapResult,
    StatePair,
)
from ...kinematics import point_weight
from ..base import initial_gaps, restore_law_state, saved_law_state
from ..geometry import coordinate_basis, frames, push_forward, quadrature_rule
from .pairing import InterfacePairs

__all__ = ["InterfaceElements"]


class InterfaceElements:
    """The interface elements owned by this rank, their state and kernels.

    Args:
        pairs: Result of :func:`~.pairing.pair_interface`.
        V: The displacement space.
        law: The friction law (:class:`~subfric_dolfinx.constitutive.FrictionLaw`).
        quadrature: ``"gauss"`` or ``"nodal"``, see :func:`quadrature_rule`.
        initial_gap: The initial normal gap ``g0`` (mm, > 0 open): a number, or a function of the
            points' coordinates ``x`` (gdim, n) returning (n,) values; ``None``: 0.
        regions: ``(region, laws)``: the region of every element (0: ``law``, ``i``: the
            ``i``-th of ``laws``, name -> law), for interface regions with their own laws.
        mode: The modelling mode (:data:`~subfric_dolfinx.fem.kinematics.MODES`); in
            ``"axisymmetric"`` the weights carry ``2 pi r`` (forces are totals over the
            revolution). ``None``: no weight.

    Attributes:
        nq: Quadrature points per element.
        Q: Local frames, rows ``(e1, [e2,] -n)``, shape (nf, nq, gdim, gdim).
        normal: Primary outward normal, (nf, nq, gdim).
        points: Physical quadrature points, (nf, nq, gdim).
        weights: Quadrature weight times surface Jacobian (times ``2 pi r`` in axisymmetric
            mode), (nf, nq): the integration weights of the interface forces.
        facet_weights: The same without the axisymmetric weight (sizes of the facets).
        N: Facet basis at the quadrature points, (nq, nfd).
        state: Committed (``old``) and trial (``new``) internal variables, views of the arrays of
            the Quadrature functions ``functions[name]`` (and ``functions[name + "_old"]``).
        functions: Quadrature functions: one per internal variable the law declares (trial
            state, e.g. ``up``, ``mu``, ``r``), the same with ``_old`` (committed state), and
            ``traction`` (``f_t..., f_n``, local components) and ``g0`` (the initial gap).
        g0: Initial normal gap at every point, (nf * nq,), a view of ``functions["g0"]``.
        point_data: Fixed data per point, for outputs and checkpoints: ``g0`` and, with regions,
            ``region`` (the region number, as floats; names in :attr:`region_names`).
        region_names: ``("default", <regions>...)``; ``("default",)`` without regions.
        coordinate_tolerance: Points closer than this are the same point (a small fraction of
            the smallest interface facet), for matching and ordering.
    """

    def __init__(
        self,
        pairs: InterfacePairs,
        V: dolfinx.fem.FunctionSpace,
        law: FrictionLaw,
        quadrature: str = "gauss",
        *,
        initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None,
        regions: tuple[np.ndarray, Mapping[str, FrictionLaw]] | None = None,
        mode: str | None = None,
    ) -> None:
        self.pairs = pairs
        self.V = V
        sub = pairs.submesh
        self.comm = sub.comm
        self.submesh = sub
        gdim = V.mesh.geometry.dim
        self.gdim = gdim
        self.nt = gdim - 1
        self.bs = V.dofmap.bs
        fcell = basix.CellType[sub.topology.cell_type.name]
        degree = V.ufl_element().embedded_superdegree
        X, w = quadrature_rule(fcell, degree, quadrature)
        self.X, self.w_ref = X, w
        self.nq = X.shape[0]
        nf = pairs.facets.size
        self.n_elements = nf
        self.region_names: tuple[str, ...] = ("default",)
        region = None
        if regions is not None:
            region = np.repeat(np.asarray(regions[0], dtype=np.int64), self.nq)
            regional = RegionalLaw(law, regions[1], region)
            self.region_names = regional.names
            law = regional
        self.law = law

        felem = basix.create_element(
            basix.ElementFamily.P, fcell, degree, basix.LagrangeVariant.gll_warped
        )
        self.N = cast(np.ndarray, felem.tabulate(0, X))[0, :, :, 0]  # (nq, nfd)
        self.nfd = self.N.shape[1]

        # Geometry: points, surface Jacobians, normals, frames.
        self.points = push_forward(sub, X)
        dphi = coordinate_basis(sub, X, 1)[1:]  # (fdim, nq, ngeo)
        xg = sub.geometry.x[geometry_dofmap(sub)][..., :gdim]  # (nf, ngeo, gdim)
        J = np.einsum("aqk,ckd->cqda", dphi, xg)  # (nf, nq, gdim, fdim)
        if gdim == 2:
            t = J[..., 0]
            nvec = np.stack([t[..., 1], -t[..., 0]], axis=-1)
        else:
            nvec = np.cross(J[..., 0], J[..., 1])
        detJ = np.linalg.norm(nvec, axis=-1)
        nvec = nvec / np.where(detJ > 0, detJ, 1.0)[..., None]
        # Orient n outward from the primary cell: away from the primary cell's centroid.
        mesh = V.mesh
        cnodes = geometry_dofmap(mesh)[pairs.primary_cells]
        centroid = mesh.geometry.x[cnodes][..., :gdim].mean(axis=1) if nf else np.zeros((0, gdim))
        out = np.einsum("cqd,cqd->cq", nvec, self.points - centroid[:, None, :])
        nvec *= np.where(out < 0.0, -1.0, 1.0)[..., None]
        self.normal = nvec
        self.facet_weights = detJ * w[None, :]
        self.mode = mode
        self.weights = self.facet_weights
        if mode is not None:
            pw = point_weight(self.points.reshape(-1, gdim), mode).reshape(nf, self.nq)
            self.weights = self.facet_weights * pw
        self.Q = frames(nvec)

        # State in Quadrature spaces on the interface submesh.
        cname = sub.topology.cell_name()
        qe_s = basix.ufl.quadrature_element(cname, value_shape=(), points=X, weights=w)
        qe_v = basix.ufl.quadrature_element(cname, value_shape=(self.nt,), points=X, weights=w)
        qe_f = basix.ufl.quadrature_element(cname, value_shape=(gdim,), points=X, weights=w)
        self.Qs = dolfinx.fem.functionspace(sub, qe_s)
        self.Qv = dolfinx.fem.functionspace(sub, qe_v)
        self.Qf = dolfinx.fem.functionspace(sub, qe_f)
        F = dolfinx.fem.Function
        npts = nf * self.nq
        # One Quadrature function per declared variable (trial) and its committed copy ("_old").
        fn: dict[str, dolfinx.fem.Function] = {}
        views: dict[str, dict[str, np.ndarray]] = {"": {}, "_old": {}}
        for var in law.variables:
            if var.name in ("g0", "region", "traction"):
                raise ValueError(f"a law variable may not be named {var.name!r} (reserved)")
            space = {SCALAR: self.Qs, LOCAL: self.Qf}.get(var.shape, self.Qv)
            for suffix, arrays in views.items():
                f = F(space, name=var.name + suffix)
                if f.x.array.size != npts * var.components(self.nt):
                    raise RuntimeError("unexpected layout of the interface Quadrature space")
                fn[var.name + suffix] = f
                arrays[var.name] = f.x.array.reshape(var.array_shape(npts, self.nt))
        fn["traction"] = F(self.Qf, name="traction")
        fn["g0"] = F(self.Qs, name="g0")
        self.functions = fn
        self.g0 = fn["g0"].x.array
        self.g0[:] = initial_gaps(initial_gap, self.points.reshape(-1, gdim), sub.comm)
        self.point_data: dict[str, np.ndarray] = {"g0": self.g0}
        if region is not None:
            self.point_data["region"] = region.astype(float)
        init = law.initial_state(npts, self.nt)
        self.state = StatePair(
            InterfaceState(views["_old"], self.nt, copy=False),
            InterfaceState(views[""], self.nt, copy=False),
        )
        self.state.old.assign(init)
        self.state.new.assign(init)

        # Element node lists: primary then secondary nodes, as local indices of the extended map.
        self.nodes = np.concatenate([pairs.primary_nodes, pairs.secondary_nodes], axis=1)
        self.dofs = (self.nodes[:, :, None] * self.bs + np.arange(self.bs)).reshape(
            nf, 2 * self.nfd * self.bs
        )
        self.coordinate_tolerance = 1e-6 * pairs.h_min
        self.last: ReturnMapResult | None = None  # the last iterate's
        self.last_gap = np.zeros((nf * self.nq, gdim))

    # ----------------------------------------------------------------------------------------
    def gap(self, u_local: np.ndarray) -> np.ndarray:
        """Local gap ``Q ubar`` at all points, (nf * nq, gdim), without the initial gap.

        From the local array of the extended vector.
        """
        U = u_local[self.dofs].reshape(self.n_elements, 2, self.nfd, self.bs)
        jump = U[:, 1] - U[:, 0]  # secondary - primary, (nf, nfd, gdim)
        ubar = np.einsum("qk,ckd->cqd", self.N, jump)
        return np.einsum("cqij,cqj->cqi", self.Q, ubar).reshape(-1, self.gdim)

    def update(self, u_local: np.ndarray, dt: float):
        """Evaluate the law at ``u`` from the committed state; fill the trial state.

        The law's input (kept in :attr:`last_gap`) is the gap with ``ubar_n - g0`` as its normal
        component.

        Returns:
            The :class:`~subfric_dolfinx.constitutive.ReturnMapResult`.
        """
        self.last_gap = self.gap(u_local)
        self.last_gap[:, self.nt] -= self.g0
        res = self.law.return_map(self.last_gap, self.state.old, dt, out=self.state.new)
        self.functions["traction"].x.array[:] = res.traction.ravel()
        self.last = res
        return res

    def add_residual(self, b_local: np.ndarray, traction: np.ndarray) -> None:
        """Add the interface forces to a local (extended, ghosted) array."""
        nf, nq, gdim = self.n_elements, self.nq, self.gdim
        fl = traction.reshape(nf, nq, gdim)
        fg = np.einsum("cqji,cqj->cqi", self.Q, fl)  # Q^T f
        Rs = np.einsum("cq,qk,cqd->ckd", self.weights, self.N, fg)  # (nf, nfd, gdim)
        R = np.concatenate([-Rs, Rs], axis=1)
        np.add.at(b_local, self.dofs.ravel(), R.ravel())

    def element_matrices(self, tangent: np.ndarray) -> np.ndarray:
        """Element matrices (nf, 2 nfd gdim, 2 nfd gdim), node-blocked, primary nodes first."""
        nf, nq, gdim, nfd = self.n_elements, self.nq, self.gdim, self.nfd
        D = tangent.reshape(nf, nq, gdim, gdim)
        Dg = np.einsum("cqai,cqab,cqbj->cqij", self.Q, D, self.Q)  # Q^T D Q
        Kss = np.einsum("cq,qk,ql,cqij->ckilj", self.weights, self.N, self.N, Dg)
        Kss = Kss.reshape(nf, nfd * gdim, nfd * gdim)
        K = np.empty((nf, 2, nfd * gdim, 2, nfd * gdim))
        K[:, 0, :, 0] = Kss
        K[:, 1, :, 1] = Kss
        K[:, 0, :, 1] = -Kss
        K[:, 1, :, 0] = -Kss
        return K.reshape(nf, 2 * nfd * gdim, 2 * nfd * gdim)

    def commit(self) -> None:
        """Accept the trial state."""
        self.state.commit()

    def saved_state(self) -> dict[str, np.ndarray]:
        """The committed internal variables (what a restart needs), name -> array."""
        return saved_law_state(self.state)

    def restore_state(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Put the internal variables back as the committed and trial state."""
        restore_law_state(self.state, arrays)

    def revert(self) -> None:
        """Reject the trial state."""
        self.state.revert()
