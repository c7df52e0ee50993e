"""A frictional interface with finite sliding on non-matching meshes (``docs/model.md`` §11-12).

:class:`SlidingInterface` is the finite-sliding kind of interface beside the node-to-node
small-sliding :class:`~.small.interface.FrictionInterface`: the same law, return map and state
handling, the same building-block methods (:meth:`~SlidingInterface.set_step`,
:meth:`~SlidingInterface.update`, :meth:`~SlidingInterface.forces`,
:meth:`~SlidingInterface.assemble_residual`, :meth:`~SlidingInterface.assemble_jacobian`,
:meth:`~SlidingInterface.commit`, :meth:`~SlidingInterface.revert`), but the pairing is made in
the current configuration with the geometry of §11:

* The law's points are the quadrature points of the *slave* (secondary) facets, fixed material
  points of the slave body that carry the internal variables. The two sides need not match.
* **Per step** (:meth:`~SlidingInterface.begin_step`, collective, from the last converged
  configuration): averaged nodal normals of the master, the parallel search
  (:func:`.search.exchange_facets`), and for every slave facet the set of master facets it may
  face during the step (its *reach*: the candidates within the slave facet's size plus
  ``reach`` of it). The matrix pattern and the ghosts of the master nodes are those of the
  reach; they are rebuilt only when a slave facet needs a master facet outside its current
  reach (:attr:`~SlidingInterface.layout_version` then grows and the problem re-creates its
  matrices). Per step rather than per Newton iteration because the search and the exchange are
  collective and change the ghosts and the pattern; the reach makes the step's iterations
  independent of them.
* **Per Newton iteration** (:meth:`~SlidingInterface.update`): every point is projected along the
  master's smooth normal on the facets of its reach in the current configuration (a point may
  change facet inside a step), which gives the frame, the normal gap ``-gamma |n~|`` and the
  convected slip from the material point faced at the step's start; the tangential state is
  transported (:func:`.sliding.transport_matrix`, the identity in 2-D). A point that slides
  farther than ``reach`` in one step makes the evaluation fail (the step is cut).
* The slave nodes receive ``int N_s t`` by the slave facets' rule, the master nodes the segment
  transfer ``-B t`` (:mod:`.transfer`): a uniform traction crosses a non-matching interface
  exactly.
* The tangent holds the law's consistent tangent through the derivative of the local gap with
  respect to the slave point and the master nodes (:func:`.sliding.gap_operator`), the convected
  slip's own master nodes, in 2-D the frame's turn with the projection
  (:func:`.sliding.frame_rate`) and, with ``SlidingAssembly.transfer_in_tangent`` (on by
  default), the transfer's change with the geometry (:func:`.transfer.transfer_tangent`): then
  the 2-D tangent is the residual's derivative, the 3-D one but for the frame's turn. The
  nodal normals are the step's (held), so they have no derivative within it.

Geometrically the bodies stay linear (small strain, reference integration weights); only the
contact kinematics is finite.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ....compat import create_submesh
from ....constitutive import FrictionLaw, InterfaceState, StatePair
from ....constitutive.result import Status
from ....constitutive.state import LOCAL, TANGENTIAL
from ...kinematics import point_weight
from ..base import BaseInterface, InterfaceError, initial_gaps
from ..geometry import frames, quadrature_rule
from ..layout import Couplings
from .assembly import SlidingAssembly
from .points import SlidingPoints
from .projection import facet_basis, normal_projection, parametric_normal
from .reach import ReachSearch, _near, surface_size
from .segments import overlap_points
from .sliding import frame_rate, gap_operator, transport_matrix
from .surface import contact_surface
from .transfer import facet_mass, l2_projector, transfer_matrices

__all__ = ["SlidingInterface"]


class SlidingInterface(ReachSearch, SlidingAssembly, SlidingPoints, BaseInterface):
    """One frictional interface with finite sliding between independently meshed bodies.

    Args:
        V: The displacement space (vector Lagrange, degree 1 or 2).
        cell_tags: Cell tags of the bodies.
        facet_tags: Facet tags: the interface's facets of both bodies carry ``tag`` (their nodes
            need not match).
        law: The friction law.
        tag: The interface's facet tag.
        primary: Cell tag(s) of the primary body (the master surface: its smooth outward normal
            defines the frame).
        secondary: Cell tag(s) of the secondary body (the law's points are on its facets).
        name: The interface's name (messages).
        quadrature: ``"gauss"`` or ``"nodal"`` on the secondary facets.
        initial_gap: An extra initial normal gap ``g0`` (mm, > 0 open), a number or a function
            of the reference coordinates of the points; the geometric gap is measured anyway.
        mode: The modelling mode; ``"axisymmetric"``: the slave weights carry ``2 pi r`` and
            the transfer projects the traction times ``2 pi r`` (forces are totals over the
            circumference).
        timings: A :class:`~subfric_dolfinx.fem.timing.Timings`.
        search_radius: The largest normal distance at which a point faces the master (mm);
            farther points are open (also where they penetrate farther: give more than the
            largest penetration). Default: twice the largest facet size of either side.
        reach: How far a point may slide in one step (mm); also the hysteresis of the pattern
            (rebuilt when a facet needs a master facet beyond it). Default: the largest facet
            size of either side.

    Attributes:
        layout_version: Grows every time the pattern and ghosts are rebuilt.
        points: Reference positions of the law's points, (npts, gdim).
        weights: Their integration weights (reference slave surface), (npts,).
        last: The return map's result at the last iterate.
        projection_found: Whether each point faced the master at the last iterate.
        search_seconds: Wall time of the last :meth:`begin_step` and of the projections and
            segments of the last :meth:`update` (for the cost tables; never in tests).
    """

    kinematics = "finite_sliding"
    region_names = ("default",)  # no interface regions (summaries read it)
    pairs = None  # no fixed pairs: re-paired in the current configuration

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        cell_tags: dolfinx.mesh.MeshTags,
        facet_tags: dolfinx.mesh.MeshTags,
        law: FrictionLaw,
        *,
        tag: int,
        primary: int | Sequence[int],
        secondary: int | Sequence[int],
        name: str = "interface",
        quadrature: str = "gauss",
        initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None,
        mode: str | None = None,
        timings: Any = None,
        search_radius: float | None = None,
        reach: float | None = None,
    ) -> None:
        super().__init__(V, name, timings)
        self.law = law
        mesh = V.mesh
        gdim = mesh.geometry.dim
        self.gdim, self.nt, self.bs = gdim, gdim - 1, V.dofmap.bs
        self.imap0 = V.dofmap.index_map
        self.n_local0 = self.imap0.size_local + self.imap0.num_ghosts
        self.X0 = V.tabulate_dof_coordinates()[:, :gdim].copy()
        self.master = contact_surface(V, cell_tags, facet_tags, tag, list(np.atleast_1d(primary)))
        slave = contact_surface(V, cell_tags, facet_tags, tag, list(np.atleast_1d(secondary)))
        # the slave facets' own mesh (cell averages in field output): the facets in its order
        self.submesh, parents = create_submesh(mesh, mesh.topology.dim - 1, slave.facets)
        sorter = np.argsort(slave.facets)
        perm = sorter[np.searchsorted(slave.facets, parents, sorter=sorter)]
        self.slave = dataclasses.replace(
            slave,
            facets=slave.facets[perm],
            cells=slave.cells[perm],
            nodes=slave.nodes[perm],
            orientation=slave.orientation[perm],
            global_facets=slave.global_facets[perm],
        )
        self.n_elements = self.slave.size
        counts = self.comm.allreduce(np.array([self.master.size, self.slave.size]))
        if counts.min() == 0:
            side = "primary" if counts[0] == 0 else "secondary"
            raise InterfaceError(
                f"interface {name!r} (tag {tag}): its {side} body has no facet with the tag"
            )
        h = max(
            surface_size(self.master, self.X0, self.comm),
            surface_size(self.slave, self.X0, self.comm),
        )
        self.h = h
        self.radius = float(search_radius) if search_radius is not None else 2.0 * h
        self.reach = float(reach) if reach is not None else h
        if not (self.radius > 0 and self.reach > 0):
            raise InterfaceError(f"interface {name!r}: search_radius and reach must be > 0")

        # The law's points on the slave facets (reference geometry).
        s = self.slave
        degree = s.degree
        X, w = quadrature_rule(s.cell, degree, quadrature)
        self.w_ref = w
        self.nq = X.shape[0]
        self.Ns = facet_basis(s.cell, degree, X, 1)  # (1 + fdim, nq, nfd)
        Ys0 = self.X0[s.nodes]  # (ns, nfd, gdim)
        self.points = np.einsum("qk,fkd->fqd", self.Ns[0], Ys0).reshape(-1, gdim)
        jac = np.linalg.norm(
            parametric_normal(np.einsum("aqk,fkd->fqda", self.Ns[1:], Ys0)), axis=-1
        )
        self.facet_weights = jac * w[None, :]  # (ns, nq)
        pw = point_weight(self.points, mode or "3d").reshape(jac.shape)  # 2 pi r, or 1
        self.weights = (self.facet_weights * pw).reshape(-1)
        # the master forces by the segments are those the slave nodes get by the rule: the exact
        # mass (with a nodal rule the dual basis; the rule's lumped one gave the consistent mass).
        # Axisymmetric: the field projected is the traction times 2 pi r at the points (the
        # reference r, as the slave weights), whose segment integrals are the master's forces
        self.projector = (
            l2_projector(self.Ns[0], self.facet_weights, facet_mass(s.cell, degree, Ys0))
            * pw[:, None, :]
        )
        npts = s.size * self.nq
        self.n_points = npts
        self.g0 = initial_gaps(initial_gap, self.points, self.comm)
        self.point_data = {"g0": self.g0}
        fdim = max(gdim - 1, 1)
        sizes = self.facet_weights.sum(axis=1) ** (1.0 / fdim) if s.size else np.zeros(0)
        h_min = self.comm.allreduce(float(sizes.min(initial=np.inf)), op=MPI.MIN)
        self.coordinate_tolerance = 1e-6 * h_min
        init = law.initial_state(npts, self.nt)
        self.state = StatePair(init.copy(), init.copy())
        self._variables = {v.name: v.shape for v in law.variables}
        # kinematic state of the points: committed master facet (global number, -1: none),
        # its reference coordinates, the total tangential gap (local components), the frame and
        # the master's tangent basis there at the step's start.
        self.facet_old = np.full(npts, -1, dtype=np.int64)
        self.xi_old = np.zeros((npts, self.nt))
        self.ut_old = np.zeros((npts, self.nt))
        self.Q_old = np.zeros((npts, gdim, gdim))
        self.tan_old = np.zeros((npts, gdim, self.nt))
        self._trial: dict[str, np.ndarray] = {}
        self.projection_found = np.zeros(npts, dtype=bool)
        self.last = None
        # d f_n / d g_n of every point at the step's first evaluation (its start: the last
        # converged configuration with the step's Dirichlet values), for ``keep_contact``
        self.start_normal: np.ndarray | None = None
        self.last_gap = np.zeros((npts, gdim))
        self.layout_version = 0
        self.search_seconds = {"search": 0.0, "projection": 0.0, "segments": 0.0}
        self.index_map: dolfinx.common.IndexMap | None = None
        self.x_ext = self.b_ext = None
        self._x_committed = np.zeros(self.n_owned)
        self._owners0 = np.concatenate(
            [np.full(self.imap0.size_local, self.comm.rank, np.int32), self.imap0.owners]
        )
        self._global0 = self.imap0.local_to_global(np.arange(self.n_local0, dtype=np.int32))
        # the reach's (slave facet, master facet global number) pairs of the layout (None: no
        # layout yet) and the master facet pairs (global numbers) a tangent needed beyond the
        # pattern since it was built (:meth:`_pattern_check`): both read by :meth:`begin_step`
        self._pattern_pairs: set[tuple[int, int]] | None = None
        self._missed: set[tuple[int, int]] = set()
        self._stepped = False
        self.begin_step()

    # -- helpers ---------------------------------------------------------------------------------
    def _positions0(self, u_owned: np.ndarray) -> np.ndarray:
        """Current positions of the displacement space's local nodes (collective: ghost update)."""
        v = dolfinx.la.vector(self.imap0, self.bs)
        v.array[: self.n_owned] = u_owned
        v.scatter_forward()
        return self.X0 + v.array.reshape(-1, self.bs)[:, : self.gdim]

    # -- the step --------------------------------------------------------------------------------
    def set_step(self, dt: float) -> None:
        """Set the step of the return map and search from the last converged configuration.

        Collective (the search). See :meth:`begin_step`.
        """
        super().set_step(dt)
        self.start_normal = None
        self.begin_step()

    def _local_displacement(self, owned: np.ndarray) -> np.ndarray:
        """The displacement at every local node of the extended map (collective)."""
        self.x_ext.array_w[: self.n_owned] = owned
        self.x_ext.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with self.x_ext.localForm() as xl:
            return xl.array_r.reshape(-1, self.bs)[:, : self.gdim].copy()

    def _current(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points, master facets of the reach and slave facets' nodes at displacement ``u``."""
        s = self.slave
        Xs = self.X0[s.nodes] + u[s.nodes]  # (ns, nfd, gdim)
        xq = np.einsum("qk,fkd->fqd", self.Ns[0], Xs).reshape(-1, self.gdim)
        return xq, self.pf_X0 + u[self.pf_nodes], Xs

    def _project(self, xq: np.ndarray, Ym: np.ndarray) -> dict[str, np.ndarray]:
        """Every point along the smooth normal on the nearest facet of its reach it lands on."""
        nq, nt, gdim = self.nq, self.nt, self.gdim
        # the pairs that may project on each other (:func:`.search.near_pairs`) within the reach
        pp, ff = _near(xq, np.zeros(xq.shape[0]), Ym, self.pf_normals, self.radius)
        npf = max(self.pf_global.size, 1)
        owner = np.repeat(np.arange(self.slave.size), np.diff(self.reach_ptr))
        keep = np.isin((pp // nq) * npf + ff, owner * npf + self.reach_idx)
        pp, ff = pp[keep], ff[keep]
        m = self.master
        pr = normal_projection(xq[pp], Ym[ff], self.pf_normals[ff], m.cell, m.degree)
        good = pr.inside & (np.abs(pr.distance) <= self.radius)
        idx = np.flatnonzero(good)
        idx = idx[np.lexsort((np.abs(pr.distance[idx]), pp[idx]))]
        first = np.ones(idx.size, dtype=bool)
        first[1:] = pp[idx][1:] != pp[idx][:-1]
        idx = idx[first]
        p = pp[idx]
        out = {
            "facet": np.full(self.n_points, -1, dtype=np.int64),
            "xi": np.zeros((self.n_points, nt)),
            "normal": np.zeros((self.n_points, gdim)),
            # a point facing nothing is open: beyond the radius on the outer side (a distance
            # of -radius made it penetrate by the radius: pressed where it left the master)
            "distance": np.full(self.n_points, self.radius),
            "gamma": np.zeros(self.n_points),
        }
        out["facet"][p] = ff[idx]
        out["xi"][p] = pr.xi[idx]
        out["normal"][p] = pr.normal[idx]
        out["distance"][p] = pr.distance[idx]
        out["gamma"][p] = pr.gamma[idx]
        return out

    def update(self, x: PETSc.Vec | np.ndarray) -> Any:
        """Evaluate the law at the displacement ``x`` (owned values; collective: a ghost update).

        Returns:
            The :class:`~subfric_dolfinx.constitutive.ReturnMapResult`; ``converged`` is False
            also where a point slid farther than the reach in this step.
        """
        import time

        from ...timing import TIMER_INTERFACE, TIMER_PROJECTION, TIMER_RETURN_MAP

        owned = self._owned(x)
        gdim, nt = self.gdim, self.nt
        with self._time(TIMER_INTERFACE):
            u = self._local_displacement(owned)
            t0 = time.perf_counter()
            s, m = self.slave, self.master
            xq, Ym, Xs = self._current(u)
            self._xq = xq
            Nm = self.pf_normals
            with self._time(TIMER_PROJECTION):
                pj = self._project(xq, Ym)
            facet, xi, normal, gamma = pj["facet"], pj["xi"], pj["normal"], pj["gamma"]
            found = facet >= 0
            self.search_seconds["projection"] = time.perf_counter() - t0

            # frames: at the projection; an open point keeps its old frame
            Q = self.Q_old.copy()
            Q[found] = frames(normal[found])
            unset = ~found & (np.abs(Q).sum(axis=(1, 2)) == 0)
            if np.any(unset):
                Q[unset] = np.eye(gdim)[None]
            # normal gap (> 0 on penetration)
            gap = np.zeros((self.n_points, gdim))
            gap[:, nt] = -pj["distance"]
            # a distance within the coordinates' round-off is a closed gap (independent meshes
            # of one surface meet at +-1e-17, which would tell contact from separation by chance)
            gap[np.abs(gap[:, nt]) <= 1e-12 * self.h, nt] = 0.0
            # convected slip and transported tangential state
            old = self.pf_old
            moving = found & (old >= 0)
            self._old_facet = np.where(moving, old, -1)
            self._N_old = np.zeros((self.n_points, self.pf_nodes.shape[1]))
            ds = np.zeros((self.n_points, gdim))
            T = np.broadcast_to(np.eye(nt), (self.n_points, nt, nt)).copy()
            if np.any(moving):
                pm = np.flatnonzero(moving)
                B_old = facet_basis(m.cell, m.degree, self.xi_old[pm], 1)
                self._N_old[pm] = B_old[0]
                Yo = Ym[old[pm]]
                y_old_now = np.einsum("mk,mkd->md", B_old[0], Yo)
                B_new = facet_basis(m.cell, m.degree, xi[pm], 0)
                y_new = np.einsum("mk,mkd->md", B_new[0], Ym[facet[pm]])
                ds[pm] = y_new - y_old_now
                if nt == 2:
                    tan_now = np.einsum("amk,mkd->mda", B_old[1:], Yo)
                    n_now = np.einsum("mk,mkd->md", B_old[0], Nm[old[pm]])
                    n_now /= np.linalg.norm(n_now, axis=1, keepdims=True)
                    T[pm] = transport_matrix(
                        self.Q_old[pm], Q[pm], self.tan_old[pm], tan_now, n_now
                    )
            slip_too_far = np.linalg.norm(ds, axis=1) > self.reach
            gap[:, :nt] = np.einsum("mab,mb->ma", T, self.ut_old) + np.einsum(
                "mad,md->ma", Q[:, :nt, :], ds
            )
            self._trial = {"facet": facet, "xi": xi, "Q": Q, "ut": gap[:, :nt].copy()}
            law_gap = gap.copy()
            law_gap[:, nt] -= self.g0
            self.last_gap = law_gap
            start = self._transported(T) if nt == 2 else self.state.old
        with self._time(TIMER_RETURN_MAP):
            res = self.law.return_map(law_gap, start, self.dt, out=self.state.new)
        with self._time(TIMER_INTERFACE):
            if np.any(slip_too_far):
                res.status[slip_too_far] = Status.FAILED  # slid beyond the reach: cut the step
            if self.start_normal is None:  # the step's first evaluation: its start
                self.start_normal = res.tangent.reshape(-1, gdim, gdim)[:, nt, nt].copy()
            self.last = res
            self.projection_found = found
            self._found = found
            self._facet = facet
            # tangent pieces: G (gap derivative) and the master basis at the projections
            t1 = time.perf_counter()
            pf = np.flatnonzero(found)
            self._G = np.zeros((self.n_points, gdim, gdim))
            self._Nm = np.zeros((self.n_points, self.pf_nodes.shape[1]))
            if pf.size:
                G, Nb, R = gap_operator(
                    xq[pf], Ym[facet[pf]], Nm[facet[pf]], m.cell, m.degree, xi[pf], gamma[pf], Q[pf]
                )
                self._G[pf], self._Nm[pf] = G, Nb
                # no slip measured where the point faced nothing at the step's start
                self._G[~moving, :nt, :] = 0.0
            # 2-D: the frame turns with the projection (d e1 = (a_y, -a_x) dxi, d(-n) = -a dxi):
            # in the slip e1 . ds and in the forces Q^T f
            self._K = np.zeros((self.n_points, gdim, gdim))
            if gdim == 2 and pf.size:
                a, r = frame_rate(Nm[facet[pf]], m.cell, m.degree, xi[pf]), R[:, 0, :]
                de1 = np.stack([a[:, 1], -a[:, 0]], axis=1)
                self._G[pf, 0, :] += np.einsum("md,md->m", de1, ds[pf])[:, None] * r
                f = res.traction[pf]
                turn = de1 * f[:, :1] - a * f[:, 1:]
                self._K[pf] = turn[:, :, None] * r[:, None, :]
            self._Q = Q
            # the segments and the master-side transfer
            with self._time(TIMER_PROJECTION):
                seg = overlap_points(
                    Xs,
                    s.cell,
                    s.degree,
                    Ym,
                    Nm,
                    m.cell,
                    m.degree,
                    self.radius,
                    slave_measure_x=self.X0[s.nodes],
                    rates=self.transfer_in_tangent,
                )
                keep = seg.converged.copy()
                if seg.size:
                    npf = max(self.pf_global.size, 1)
                    owner = np.repeat(np.arange(s.size), np.diff(self.reach_ptr))
                    keep &= np.isin(seg.slave * npf + seg.master, owner * npf + self.reach_idx)
                seg = seg.take(keep)
                self._segments = seg
                self._transfer = transfer_matrices(
                    seg, self.projector, s.cell, s.degree, m.cell, m.degree
                )
                self._pattern_check(slip_too_far)
            self._Xs, self._Ym = Xs, Ym
            self.search_seconds["segments"] = time.perf_counter() - t1
        self._x_at_update = np.array(owned, copy=True)
        return res

    def _transported(self, T: np.ndarray) -> InterfaceState:
        """The committed state with its tangential components carried by ``T`` (3-D)."""
        st = self.state.old.copy()
        for name, shape in self._variables.items():
            if shape == TANGENTIAL:
                st[name][...] = np.einsum("mab,mb->ma", T, st[name])
            elif shape == LOCAL:
                st[name][:, : self.nt] = np.einsum("mab,mb->ma", T, st[name][:, : self.nt])
        return st

    # -- state -----------------------------------------------------------------------------------
    def commit(self) -> None:
        """Accept the trial state and the points' kinematics; remember the configuration."""
        super().commit()
        tr = self._trial
        if tr:
            found = tr["facet"] >= 0
            self.facet_old = np.where(found, self.pf_global[np.maximum(tr["facet"], 0)], -1)
            self.xi_old = tr["xi"]
            self.ut_old = tr["ut"]
            self.Q_old = tr["Q"]
        if self._x_at_update is not None:
            self._x_committed = self._x_at_update.copy()

    def layout_parts(self) -> tuple[np.ndarray, np.ndarray, dolfinx.common.IndexMap, Couplings]:
        """Extra ghosts, their owners, the extended index map and the pattern's couplings."""
        return self.extra_ghosts, self.extra_owners, self.index_map, self.couplings
