"""A frictional interface with finite sliding on non-matching meshes (``docs/model.md`` §11-12).

:class:`SlidingInterface` is the finite-sliding kind of interface beside the node-to-node
small-sliding :class:`~..small.interface.FrictionInterface`: the same contract
(:class:`~..base.BaseInterface`), law, return map and state handling, the same building-block
methods (:meth:`~SlidingInterface.set_step`,
:meth:`~SlidingInterface.update`, :meth:`~SlidingInterface.forces`,
:meth:`~SlidingInterface.assemble_residual`, :meth:`~SlidingInterface.assemble_jacobian`,
:meth:`~SlidingInterface.commit`, :meth:`~SlidingInterface.revert`), but the pairing is made in
the current configuration with the geometry of §11.

It is made of parts it holds, each with its own state: its :class:`~.sides.Sides` (the two
surfaces, fixed), its law's points (:class:`~.points.SlidingPoints`), its search
(:class:`~.reach.ReachSearch`), its transfer (:class:`~.transfer.SegmentTransfer`) and its assembly
(:class:`~.assembly.SlidingAssembly`); each iterate's contact geometry is one immutable
:class:`~.contact.ContactGeometry` that the return map, the forces, the tangent and the commit
read.

* The law's points are the quadrature points of the *secondary* facets, fixed material
  points of the secondary body that carry the internal variables. The two sides need not match.
* **Per step** (:meth:`~SlidingInterface.begin_step`, collective, from the last converged
  configuration): averaged nodal normals of the primary, the parallel search
  (:func:`.search.exchange_facets`), and for every secondary facet the set of primary facets it may
  face during the step (its *reach*: the candidates within the secondary facet's size plus
  ``reach`` of it). The matrix pattern and the ghosts of the primary nodes are those of the
  reach; they are rebuilt only when a secondary facet needs a primary facet outside its current
  reach (:attr:`~SlidingInterface.layout_version` then grows and the problem re-creates its
  matrices). Per step rather than per Newton iteration because the search and the exchange are
  collective and change the ghosts and the pattern; the reach makes the step's iterations
  independent of them.
* **Per Newton iteration** (:meth:`~SlidingInterface.update`, :func:`.contact.contact_geometry`):
  the primary's averaged nodal normals of the iterate (:meth:`.reach.ReachSearch.current_normals`,
  collective; :attr:`~SlidingInterface.normals_per_iteration`), then every point is projected
  along the primary's smooth normal on the facets of its reach in the current configuration (a
  point may change facet inside a step), which gives the frame, the normal gap ``-gamma |n~|``
  and the convected slip from the material point faced at the step's start; the tangential
  state is transported (:func:`.sliding.transport_matrix`, the identity in 2-D). A point that
  slides farther than ``reach`` in one step makes the evaluation fail (the step is cut).
* The secondary nodes receive ``int N_s t`` by the secondary facets' rule, the primary nodes the
  segment transfer ``-B t`` (:mod:`.transfer`): a uniform traction crosses a non-matching interface
  exactly; where a secondary facet overhangs the primary surface, the share the segments miss goes
  to the primary where each point projects (:func:`.transfer.complete_transfer`): action equals
  reaction whatever the overhang.
* With regions, each point takes the law of its secondary facet's region
  (:mod:`~subfric_dolfinx.fem.interface.finite.regions`).
* The tangent holds the law's consistent tangent through the derivative of the local gap with
  respect to the secondary point and the primary nodes (:func:`.sliding.gap_operator`), the
  convected slip's own primary nodes, the frame's turn with the projection (2-D
  :func:`.sliding.frame_rate`; 3-D :class:`~.contact.FrameTurn`: the frame's rows and the
  transport's rotation, :func:`.sliding.frame_jacobian`, :func:`.sliding.transport_angle_rates`),
  the nodal normals' change with the primary's nodes (:mod:`.normals`: through the projection,
  the gap, the frame, the transport and the transfer) and, with ``SegmentTransfer.in_tangent``
  (on by default), the transfer's change with the geometry (:func:`.transfer.transfer_tangent`):
  the Jacobian is the residual's derivative, 2-D and 3-D
  (``tests/fem/interface/finite/test_finite_sliding_tangent.py``,
  ``tests/fem/interface/finite/test_finite_sliding_normals.py``), but where a secondary facet
  overhangs the primary surface (the complement's change with the normals is left out).

Geometrically the bodies stay linear (small strain, reference integration weights); only the
contact kinematics is finite.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ....constitutive import FrictionLaw, RegionalLaw
from ....constitutive.result import Status
from ..base import BaseInterface, InterfaceOptions, NewtonStart, Overhang
from ..layout import Couplings
from .assembly import Block, SlidingAssembly
from .contact import ContactGeometry, contact_geometry
from .points import SlidingPoints
from .reach import ReachSearch, StepStart
from .regions import secondary_regions
from .sides import make_sides
from .transfer import SegmentTransfer

__all__ = ["SlidingInterface", "SlidingOptions"]


@dataclasses.dataclass(frozen=True)
class SlidingOptions(InterfaceOptions):
    """A finite-sliding interface's settings: those of both kinds and the search's distances.

    Attributes:
        search_radius: The largest normal distance at which a point faces the primary (mm);
            farther points are open (also where they penetrate farther: give more than the
            largest penetration). ``None``: twice the largest facet size of either side.
        reach: How far a point may slide in one step (mm); also the hysteresis of the pattern
            (rebuilt when a facet needs a primary facet beyond it). ``None``: the largest facet
            size of either side.
    """

    search_radius: float | None = None
    reach: float | None = None


class SlidingInterface(BaseInterface):
    """One frictional interface with finite sliding between independently meshed bodies.

    Args:
        V: The displacement space (vector Lagrange, degree 1 or 2).
        cell_tags: Cell tags of the bodies.
        facet_tags: Facet tags: the interface's facets of both bodies carry ``tag`` (their nodes
            need not match).
        law: The friction law.
        tag: The interface's facet tag.
        primary: Cell tag(s) of the primary body (the primary surface: its smooth outward normal
            defines the frame).
        secondary: Cell tag(s) of the secondary body (the law's points are on its facets).
        options: Name, quadrature, initial gap, regions, modelling mode and the search's
            distances (:class:`SlidingOptions`; ``None``: its defaults). With ``"axisymmetric"``
            the secondary weights carry ``2 pi r`` and the transfer projects the traction times
            ``2 pi r``; with regions each secondary point takes the law of the region that holds
            its secondary facet and keeps it as it slides
            (:mod:`~subfric_dolfinx.fem.interface.finite.regions`).
        timings: A :class:`~subfric_dolfinx.fem.timing.Timings`.

    Attributes:
        sides: The two surfaces and the search distances (:class:`~.sides.Sides`).
        search: The search part: the reach, the layout, the step's nodal normals
            (:class:`~.reach.ReachSearch`).
        transfer: The transfer part (:class:`~.transfer.SegmentTransfer`).
        assembly: The forces and tangent part (:class:`~.assembly.SlidingAssembly`).
        start: The points' projections at the step's start (:class:`~.reach.StepStart`).
        geometry: The contact geometry of the last iterate (``None`` before the first).
        search_seconds: Wall time of the last :meth:`begin_step` and of the projections and
            segments of the last :meth:`update` (for the cost tables; never in tests).
    """

    kinematics = "finite_sliding"
    fixed_pairs = False  # re-paired in the current configuration
    _petsc_vectors = ("_work",)  # and the search's (:meth:`destroy`)
    #: Whether the primary's nodal normals are those of every iterate (the current configuration,
    #: the default: a slide's forces then do not depend on the step; docs/model.md §11) rather
    #: than the step's, held (their derivative is in the tangent either way). A point with an
    #: initial gap is measured from its contact surface (:func:`.contact.contact_geometry`), so
    #: the normals' turn within a step does not slide it by its initial gap times the turn.
    normals_per_iteration = True
    #: Whether an extrapolated start keeps the points in contact at the step's start closed
    #: (:meth:`start_correction`; ``False``: Newton starts from the extrapolation as it is).
    closes_extrapolated_start = True
    #: The most passes of :meth:`start_correction` (each evaluates the interface once more).
    closing_passes = 3

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
        options: SlidingOptions | None = None,
        timings: Any = None,
    ) -> None:
        o = options or SlidingOptions()
        name = o.name
        super().__init__(V, name, timings)
        self.sides = make_sides(
            V,
            cell_tags,
            facet_tags,
            tag,
            primary,
            secondary,
            name,
            o.quadrature,
            o.search_radius,
            o.reach,
        )
        region = None
        if o.regions:
            region = np.repeat(
                secondary_regions(self.sides, o.groups or {}, list(o.regions), name),
                self.sides.nq,
            )
            law = RegionalLaw(law, dict(o.regions), region)
        self.law = law
        self._points = SlidingPoints(self.sides, law, o.initial_gap, o.mode, region)
        self.search = ReachSearch(self.sides)
        self.transfer = SegmentTransfer(self.sides, self._points, o.mode)
        self.assembly = SlidingAssembly(self.sides, self._points, self.transfer)
        self.geometry: ContactGeometry | None = None
        self.search_seconds = {"search": 0.0, "projection": 0.0, "segments": 0.0}
        self._x_committed = np.zeros(self.n_owned)
        # the committed return map's statuses, tangents and law gaps, and the step's points that
        # continue to slip from there (:meth:`_continuing`)
        self._committed: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._continuing: tuple[np.ndarray, np.ndarray] | None = None
        self._first_jacobian = True
        # the iterate of the last evaluation while its state stands (cleared where the step,
        # the committed state or the configuration changes): :meth:`update` at the same
        # displacement on every rank returns the result it has
        self._evaluated: np.ndarray | None = None
        self.start: StepStart = self.begin_step()

    # -- what the base reads ---------------------------------------------------------------------
    @property
    def law_points(self) -> SlidingPoints:
        """The law's points (:class:`~..protocol.LawPoints`): the secondary facets' points."""
        return self._points

    @property
    def last(self) -> Any:
        """The return map's result at the last iterate (``None`` before the first)."""
        return self._points.last

    @property
    def layout_version(self) -> int:
        """Grows every time the pattern and ghosts are rebuilt."""
        return self.search.layout_version

    def overhang(self) -> Overhang | None:
        """Where the secondary facets reach beyond the primary surface at the last iterate.

        The transfer's uncovered fraction of each secondary facet, whether one of its points
        faces no primary facet, the points' positions; ``None`` before the first iterate.
        """
        g = self.geometry
        if g is None or g.transfer.uncovered is None:
            return None
        beyond = np.asarray(~g.found.reshape(-1, self.sides.nq).all(axis=1))
        return Overhang(uncovered=g.transfer.uncovered, beyond=beyond, x=g.xq)

    @property
    def index_map(self) -> dolfinx.common.IndexMap:
        """The displacement's index map with the reach's primary nodes as extra ghosts."""
        assert self.search.reach is not None  # (searched when made)
        return self.search.reach.index_map

    @property
    def x_ext(self) -> PETSc.Vec | None:
        """A vector of the extended layout (``None`` once destroyed)."""
        return self.search.x_ext

    @property
    def b_ext(self) -> PETSc.Vec | None:
        """A vector of the extended layout (``None`` once destroyed)."""
        return self.search.b_ext

    # -- the step --------------------------------------------------------------------------------
    def set_step(self, dt: float) -> None:
        """Set the step of the return map and search from the last converged configuration.

        Collective (the search). See :meth:`begin_step`.
        """
        super().set_step(dt)
        self._evaluated = None
        self.start = self.begin_step()
        self._first_jacobian = True
        self._continuing = None

    def begin_step(self) -> StepStart:
        """Search the primary facets near the secondary points at the last converged configuration.

        Collective (:meth:`.reach.ReachSearch.begin_step`). Where the search rebuilds the layout,
        :attr:`layout_version` grows (the problem re-creates its matrices).

        Returns:
            The points' projections at the step's start; their frames become the committed ones.
        """
        from ...timing import TIMER_SEARCH

        t0 = time.perf_counter()
        version = self.search.layout_version
        pts = self._points
        with self._time(TIMER_SEARCH):
            start = self.search.begin_step(self._x_committed, pts.facet_old, pts.Q_old)
        pts.Q_old = start.Q
        if self.search.layout_version != version and self._work is not None:
            self._work.destroy()  # of the former layout
            self._work = None
        self.search_seconds["search"] = time.perf_counter() - t0
        return start

    def update(self, x: PETSc.Vec | np.ndarray) -> Any:
        """Evaluate the law at the displacement ``x`` (owned values; collective: a ghost update).

        The same displacement as the last evaluation's on every rank, with nothing changed
        since (step, committed state), returns the last result as it is: the same numbers,
        without the projections again (the start :meth:`start_correction` left unchanged is
        the solver's first iterate).

        Returns:
            The :class:`~subfric_dolfinx.constitutive.ReturnMapResult`; ``converged`` is False
            also where a point slid farther than the reach in this step.
        """
        from ...timing import TIMER_INTERFACE, TIMER_RETURN_MAP

        owned = self._owned(x)
        same = self._evaluated is not None and np.array_equal(self._evaluated, owned)
        if self.comm.allreduce(same, op=MPI.LAND):
            return self.last
        pts, nt = self._points, self.sides.nt
        with self._time(TIMER_INTERFACE):
            u = self.search.displacement(owned)
            normals = (
                self.search.current_normals(u)
                if self.normals_per_iteration
                else self.search.normals
            )
            g, seconds = contact_geometry(
                self.sides,
                self.search,
                self.start,
                pts.ut_old,
                u,
                self.transfer,
                self._time,
                normals,
                self.normals_per_iteration,
                pts.g0,
            )
            self.search_seconds.update(seconds)
            law_gap = g.gap.copy()
            committed = pts.transported(g.transport) if nt == 2 else pts.state.old
        with self._time(TIMER_RETURN_MAP):
            res = self.law.return_map(law_gap, committed, self.dt, out=pts.state.new)
        with self._time(TIMER_INTERFACE):
            if np.any(g.slid_too_far):
                res.status[g.slid_too_far] = Status.FAILED  # slid beyond the reach: cut the step
            if self.start.normal_stiffness is None:  # the step's first evaluation: its start
                stiffness = res.tangent.reshape(-1, nt + 1, nt + 1)[:, nt, nt].copy()
                self.start = dataclasses.replace(
                    self.start, normal_stiffness=stiffness, normal_gap=law_gap[:, nt].copy()
                )
            if self._first_jacobian:  # the evaluation the step's first Jacobian takes
                self._continuing = self._continuing_points(res, law_gap)
            pts.record(res, law_gap, g.Q)
            self.geometry = g
        self._x_at_update = np.array(owned, copy=True)
        self._evaluated = self._x_at_update
        return res

    def start_correction(self, x: PETSc.Vec | np.ndarray) -> np.ndarray | None:
        """The change of an extrapolated start that keeps its points in contact closed (collective).

        An extrapolated start (:class:`~subfric_dolfinx.fem.stepping.LoadStepper`'s
        ``predictor``) carries the last step's motion on; a point's normal gap is a difference of
        the two bodies' positions, millimetres apart in the step, against a penetration of
        micrometres, so the extrapolation may open points that the step keeps pressed (the
        base's indentation travels with a sliding block, and each node of the base takes it up
        and lets it go). Where a point in contact at the step's start (a normal stiffness at
        its first evaluation) faces the primary open at ``x``, its normal gap of the step's start
        is restored: the secondary facets' nodes move along the primary's normal by the points'
        openings, averaged at each node with the weights ``w N_k`` of the opened points (a
        uniform opening is closed exactly; where neighbours' openings differ, the average may
        leave a point open: the moved start is evaluated and closed again, at most
        :attr:`closing_passes` times). The first Jacobian then has the pressed points in
        contact, where a start with them open lets the body tilt on the few still touching.

        Args:
            x: The extrapolated start (owned values).

        Returns:
            The owned change of the displacement (its Dirichlet rows are the caller's), or
            ``None`` where no point opened on any rank (the interface is then evaluated at ``x``).
        """
        if not self.closes_extrapolated_start:
            return None
        owned = np.array(self._owned(x), dtype=float)
        total: np.ndarray | None = None
        for _ in range(self.closing_passes):
            self.update(owned if total is None else owned + total)  # (on every rank)
            change = self._closing_change()
            if change is None:
                break
            total = change if total is None else total + change
        return total

    def _closing_change(self) -> np.ndarray | None:
        """One pass of :meth:`start_correction` at the last iterate (collective).

        Returns:
            The owned change that moves the secondary facets' nodes by their opened points'
            openings, or ``None`` where no point pressed at the step's start is open.
        """
        start, g = self.start, self.geometry
        assert g is not None  # (evaluated)
        sd, pts = self.sides, self._points
        nt, gdim, bs, nq = sd.nt, sd.gdim, sd.bs, sd.nq
        gap = pts.last_gap[:, nt]
        opened = np.zeros(gap.shape, dtype=bool)
        if start.normal_stiffness is not None and start.normal_gap is not None:
            pressed = start.normal_stiffness > 0.0
            opened = pressed & g.found & ~g.slid_too_far & (gap <= 0.0)
        if not self.comm.allreduce(bool(opened.any()), op=MPI.LOR):
            return None
        assert start.normal_gap is not None  # (opened somewhere: the step's start is known)
        ns = sd.secondary.size
        close = np.where(opened, start.normal_gap - gap, 0.0)  # > 0: deeper along -n
        move = (close[:, None] * g.Q[:, nt, :]).reshape(ns, nq, gdim)  # Q's last row: -n
        w = (pts.weights * opened).reshape(ns, nq)
        wN = w[:, :, None] * np.maximum(sd.Ns[0], 0.0)[None]  # (ns, nq, nfd)
        nodes = sd.secondary.nodes.ravel()

        def moved(b: np.ndarray) -> None:
            shift = np.einsum("fqk,fqd->fkd", wN, move).reshape(-1, gdim)
            np.add.at(b.reshape(-1, bs)[:, :gdim], nodes, shift)

        def weights(b: np.ndarray) -> None:
            np.add.at(b.reshape(-1, bs)[:, 0], nodes, wN.sum(axis=1).ravel())

        shift = self._sum_to_owners(moved).reshape(-1, bs)
        weight = self._sum_to_owners(weights).reshape(-1, bs)[:, 0]
        out = np.zeros_like(shift)
        some = weight > 0.0
        out[some] = shift[some] / weight[some, None]
        return out.ravel()

    # -- forces and tangent ----------------------------------------------------------------------
    def forces(self) -> np.ndarray:
        """The owned interface forces of the last iterate (collective: reverse scatters).

        Also their round-off per dof (:attr:`round_off`: the gaps are differences of positions).
        """
        from ...timing import TIMER_INTERFACE

        g, res, part = self.geometry, self.last, self.assembly
        assert g is not None  # (the last iterate's)
        with self._time(TIMER_INTERFACE):
            self.force = self._sum_to_owners(lambda b: part.add_forces(b, g, res.traction))
            self.round_off = self._sum_to_owners(lambda b: part.add_round_off(b, g, res.tangent))
        return self.force

    def _continuing_points(self, res: Any, law_gap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The points that slipped in the last converged step and are at its gap still.

        At the step's first evaluation a point that slipped and has not moved since (a start
        without a predictor, or a zero one: only the Dirichlet values are the step's; a step
        whose last one's forces were not resolved keeps a zero increment) is at its strength with a
        zero increment, which the return map calls elastic (stick): the tangent of a stick
        there shears the bodies by the whole step's slide and the next iterates lift the block
        off its base. Continuing the loading it slips: its committed (slip) tangent is the
        one-sided derivative the step's first Jacobian takes (:meth:`_blocks`).

        Returns:
            The points and their committed tangents, (k,) and (k, gdim, gdim).
        """
        gdim = self.sides.gdim
        if self._committed is None:
            return np.zeros(0, dtype=np.int64), np.zeros((0, gdim, gdim))
        status, tangent, gap = self._committed
        still = np.all(np.abs(law_gap - gap) <= 1e-12 * (np.abs(gap) + self.sides.h), axis=1)
        slipped = np.isin(status, (Status.PLASTIC, Status.JUMP))
        idx = np.flatnonzero(still & slipped & (res.status == Status.ELASTIC))
        return idx, tangent.reshape(-1, gdim, gdim)[idx]

    def _blocks(
        self,
        separated_stiffness: float = 0.0,
        start: NewtonStart | None = None,
        first: bool = False,
    ) -> tuple[list[Block], Any]:
        """The tangent of the last iterate (:meth:`.assembly.SlidingAssembly.blocks`).

        Its blocks, and its part through the iterate's nodal normals (a ``scipy.sparse`` CSR
        matrix over the local dofs, or ``None``).

        ``first``: the step's first Jacobian; unless its ``start`` turns, the points that
        continue to slip take their slip tangent (:meth:`_continuing_points`: a start that did
        not move them, without a predictor or with a zero one).
        Where it turns, the tangent is a frictionless contact's
        (:meth:`.assembly.SlidingAssembly.law_tangent`), its geometric terms too: the frame's
        turn, the transport's and the transfer's change take the normal tractions alone (with
        the tangential ones and no tangential stiffness, the first iterate of the 3-D pad's first
        sliding step flung it off the plate).
        """
        res = self.last
        D = self.assembly.law_tangent(
            res.tangent, self.law, separated_stiffness, start, self.start.normal_stiffness
        )
        assert self.geometry is not None  # (the last iterate's)
        plain = start is None or not start.turns
        if first and plain and self._continuing is not None and self._continuing[0].size:
            idx, Dc = self._continuing
            D = D.copy()
            D[idx] = Dc
        traction = res.traction
        if start is not None and start.turns:  # a frictionless contact's: f_t held out too
            traction = traction.copy()
            traction[:, : self.sides.nt] = 0.0
        return self.assembly.blocks(self.geometry, D, traction)

    def _add_tangent(
        self,
        A: PETSc.Mat,
        constrained: np.ndarray | None,
        separated_stiffness: float,
        start: NewtonStart | None,
    ) -> None:
        """Add the tangent of the last iterate to ``A``, block by block (:meth:`_blocks`).

        The part through the nodal normals, summed already, goes in row by row.

        ``A`` must hold this interface's pattern (the problem's :meth:`create_matrix` after the
        last :attr:`layout_version`). The rows and columns of ``constrained`` dofs are left out.
        ``separated_stiffness`` and ``start``: :meth:`.assembly.SlidingAssembly.law_tangent`.
        """
        bs = self.sides.bs
        mask = constrained.reshape(-1, bs) if constrained is not None else None
        gl = self.index_map.local_to_global
        first, self._first_jacobian = self._first_jacobian, False
        blocks, chained = self._blocks(separated_stiffness, start, first)
        if chained is not None:
            _add_rows(A, chained, constrained, bs, gl)
        for rows, cols, vals in _grouped(blocks):
            if rows.shape[0] == 0:
                continue
            if mask is not None:
                mr = mask[rows].reshape(rows.shape[0], -1)
                mc = mask[cols].reshape(cols.shape[0], -1)
                vals = vals.copy()
                vals[mr[:, :, None] | mc[:, None, :]] = 0.0
            R = gl(rows.ravel().astype(np.int32)).reshape(rows.shape).astype(PETSc.IntType)
            Cc = gl(cols.ravel().astype(np.int32)).reshape(cols.shape).astype(PETSc.IntType)
            A.setValuesBlockedRCV(R, Cc, vals, addv=PETSc.InsertMode.ADD_VALUES)

    def _lifting(self, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``K (g - x)`` over the constrained dofs (owned rows; collective), block by block."""
        bs = self.sides.bs
        we = self._extended(dofs, values).reshape(-1, bs)

        def add(local: np.ndarray) -> None:
            acc = local.reshape(-1, bs)
            blocks, chained = self._blocks()
            if chained is not None:
                local += chained @ we.ravel()
            for rows, cols, vals in blocks:
                if rows.shape[0] == 0:  # a rank without points or segments: nothing to add
                    continue
                lift = np.einsum("pij,pj->pi", vals, we[cols].reshape(cols.shape[0], -1))
                np.add.at(acc, rows.ravel(), lift.reshape(-1, bs))

        return self._sum_to_owners(add)

    # -- state -----------------------------------------------------------------------------------
    def commit(self) -> None:
        """Accept the trial state and the points' kinematics; remember the configuration."""
        super().commit()
        self._evaluated = None
        res = self.last
        if res is not None:
            self._committed = (
                res.status.copy(),
                np.array(res.tangent, copy=True),
                self._points.last_gap.copy(),
            )
        g = self.geometry
        if g is not None:
            facet = np.where(g.found, g.reach.facets[np.maximum(g.facet, 0)], -1)
            self._points.commit_kinematics(facet, g.gap[:, : self.sides.nt].copy(), g.Q)
        if self._x_at_update is not None:
            self._x_committed = self._x_at_update.copy()

    def revert(self) -> None:
        """Reject the trial state (after a failed step)."""
        super().revert()
        self._evaluated = None

    def resume(self, x: np.ndarray) -> None:
        """Continue from the owned displacement ``x`` (a restart).

        The next step searches from it: the points' primary facets and reference coordinates
        there are found again (the facets are not in the checkpoint: their numbers depend on the
        partition).
        """
        self._x_committed = np.array(np.asarray(x)[: self.n_owned], dtype=float)
        self._x_at_update = None
        self._evaluated = None
        self._points.last = None
        self._committed = None

    def layout_parts(self) -> tuple[np.ndarray, np.ndarray, dolfinx.common.IndexMap, Couplings]:
        """Extra ghosts, their owners, the extended index map and the pattern's couplings."""
        return self.search.layout_parts()

    def destroy(self) -> None:
        """Free the PETSc vectors (safe to call more than once)."""
        super().destroy()
        self.search.destroy()


def _add_rows(A: PETSc.Mat, C: Any, constrained: np.ndarray | None, bs: int, gl: Any) -> None:
    """Add the CSR matrix ``C`` over the local dofs to ``A`` (``ADD_VALUES``), row by row.

    The rows and columns of ``constrained`` dofs are left out; ``gl``: the index map's local to
    global node numbers.
    """
    C = C.tocoo()
    keep = C.data != 0.0
    if constrained is not None:
        keep &= ~(constrained[C.row] | constrained[C.col])
    r, c, v = C.row[keep], C.col[keep], C.data[keep]
    if r.size == 0:
        return
    rows, count = np.unique(r, return_counts=True)  # (C's rows are sorted)
    indptr = np.concatenate([[0], np.cumsum(count)]).astype(PETSc.IntType)

    def glob(dof: np.ndarray) -> np.ndarray:
        node = gl((dof // bs).astype(np.int32)).astype(np.int64)
        return (node * bs + dof % bs).astype(PETSc.IntType)

    A.setValuesIJV(indptr, glob(c), v, addv=PETSc.InsertMode.ADD_VALUES, rowmap=glob(rows))


def _grouped(blocks: list[Block]) -> list[Block]:
    """The blocks of one shape stacked into one (fewer, larger insertions into the matrix)."""
    by: dict[tuple[int, ...], list[Block]] = {}
    for b in blocks:
        if b[0].shape[0]:
            by.setdefault((*b[0].shape[1:], *b[1].shape[1:]), []).append(b)
    out: list[Block] = []
    for group in by.values():
        if len(group) == 1:
            out.append(group[0])
        else:
            rows, cols, vals = zip(*group, strict=True)
            out.append((np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)))
    return out
