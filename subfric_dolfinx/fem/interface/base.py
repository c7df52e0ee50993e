"""What both kinds of interface share: the abstract base, the error, the helpers.

* :class:`BaseInterface`: the abstract base of both kinds: what they do alike (the Dirichlet rows
  and columns of the residual and the tangent, the step, commit and revert, ``destroy``), and
  what the problem, the outputs and the checkpoints read of an interface of either kind.
* :class:`InterfaceOptions`: the settings both kinds take beyond their mesh, law and sides (a
  kind's own add to them: :class:`~.finite.interface.SlidingOptions`).
* :class:`NewtonStart`: how a step's Newton iteration starts (the stepper's knowledge, no kind's),
  which a kind's first Jacobian of the step may use.
* :class:`InterfaceError`: an unusable interface (mesh, tags, settings), from either kind.
* :func:`_bc_values`: the owned dofs of DOLFINx Dirichlet conditions and ``g - x`` there, for
  the Dirichlet rows and columns of an interface's residual and tangent.
* :func:`stiffen_separated`: the tangent with a fraction of the contact stiffness at points
  that have none (the retry of a failed step).
* :func:`initial_gaps`: the initial normal gap at the law's points.
* :func:`saved_law_state`, :func:`restore_law_state`: the law's committed variables out of and
  back into a state pair (checkpoints).
* :func:`exchange_rows`: rows of arrays sent to the ranks that need them (``MPI_Alltoallv``).
"""

from __future__ import annotations

import abc
import contextlib
import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ...compat import petsc_vector
from ...constitutive import FrictionLaw, StatePair

__all__ = [
    "BaseInterface",
    "InterfaceError",
    "InterfaceOptions",
    "NewtonStart",
    "Overhang",
    "Received",
    "exchange_rows",
    "initial_gaps",
    "restore_law_state",
    "saved_law_state",
    "stiffen_separated",
]


class InterfaceError(ValueError):
    """A mesh whose interface is unusable (missing tags, unpaired facets, undivided nodes)."""


@dataclasses.dataclass(frozen=True)
class InterfaceOptions:
    """The settings both kinds of interface take beyond their mesh, law and sides.

    Attributes:
        name: The interface's name (messages, outputs).
        quadrature: ``"gauss"`` or ``"nodal"`` (small sliding: on the pairs; finite sliding: on
            the secondary facets).
        initial_gap: An initial normal gap ``g0`` (mm, > 0 open), a number or a function of the
            reference coordinates ``x`` (gdim, n) of the law's points (finite sliding measures
            the geometric gap besides).
        regions: Region name -> its law; the regions are groups of interface facets given by the
            centroids of their facets in ``groups``; the other points take the interface's law.
        groups: Subgroup name -> centroids of its facets (``InterfaceMesh.interface_groups``).
        mode: The modelling mode; ``"axisymmetric"``: forces are totals over the circumference
            (weights ``2 pi r``).
    """

    name: str = "interface"
    quadrature: str = "gauss"
    initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None
    regions: Mapping[str, FrictionLaw] | None = None
    groups: Mapping[str, np.ndarray] | None = None
    mode: str | None = None


@dataclasses.dataclass(frozen=True)
class NewtonStart:
    """How a step's Newton iteration starts, as the stepper knows it (the loading program's doing).

    :class:`~subfric_dolfinx.fem.stepping.LoadStepper` gives it to the first Jacobian of every
    step (:meth:`~subfric_dolfinx.fem.solver.FrictionSolver.solve`); each kind decides what its
    tangent makes of it. A finite-sliding interface's law tangent keeps its normal stiffness
    alone where the program turns (the first iterate lets the interface slide instead of
    shearing the bodies on the stick tangent of a zero slip increment), and where the stepper
    extrapolates, its points open at the start that were in contact at the step's start keep
    their normal stiffness there. A small-sliding interface's tangent is the same with it.

    Attributes:
        turns: The loading program turns at this step and the stepper has nothing to
            extrapolate (a motion's first step, a reversal) nor a body the program carries
            along (:meth:`~subfric_dolfinx.fem.stepping.LoadStepper._carried`: a motion
            driven by loads).
        extrapolating: The stepper starts its steps from an extrapolated guess (its
            ``predictor``).
    """

    turns: bool = False
    extrapolating: bool = False


@dataclasses.dataclass(frozen=True)
class Overhang:
    """Where an interface's secondary facets reach beyond the primary surface, at the last iterate.

    Attributes:
        uncovered: Each secondary facet's fraction of its measure that no primary facet covers
            (signed as the transfer gives it), (nf,).
        beyond: Whether one of the facet's points faces no primary facet, (nf,).
        x: The points' current positions, facet-major, (nf nq, gdim).
    """

    uncovered: np.ndarray
    beyond: np.ndarray
    x: np.ndarray


class BaseInterface(abc.ABC):
    """One frictional interface of either kind: what both kinds do alike.

    A kind (:class:`~.small.interface.FrictionInterface`,
    :class:`~.finite.interface.SlidingInterface`) evaluates the law at a displacement
    (:meth:`update`), gives its forces (:meth:`forces`) and its tangent's blocks
    (:meth:`_add_tangent`) and the lifting of its tangent (:meth:`_lifting`); this base adds them
    to the user's PETSc vector and matrix with DOLFINx's Dirichlet convention
    (:meth:`assemble_residual`, :meth:`assemble_jacobian`), holds the step
    (:meth:`set_step`), the committed and trial state (:meth:`commit`, :meth:`revert`) and
    frees the PETSc vectors (:meth:`destroy`).

    Args:
        V: The displacement space.
        name: The interface's name (messages, outputs).
        timings: A :class:`~subfric_dolfinx.fem.timing.Timings` to time the sections in.

    Attributes:
        kinematics: ``"small_sliding"`` or ``"finite_sliding"`` (the kind's name, for messages
            and outputs; nothing outside the kinds branches on it).
        fixed_pairs: Whether the interface pairs its points once, at the reference geometry:
            then a slip is valid only while small against its elements (the validity watch
            judges it), where a kind that pairs again as the bodies move is not limited.
        pairs: The fixed pairs (``None`` where the interface pairs again as the bodies move).
        round_off: The forces' round-off per dof at the last :meth:`forces`, beyond that of
            the displacement (``None``: none beyond it; a finite-sliding interface's gaps are
            differences of positions), for the convergence test's floor.
        force: This rank's owned interface forces at the last residual (displacement layout).
        dt: The step of the return map.
        last: The return map's result at the last iterate (``None`` before the first).
    """

    kinematics: str
    fixed_pairs: bool
    pairs: Any = None
    round_off: np.ndarray | None = None
    last: Any
    law: Any
    #: The PETSc vectors :meth:`destroy` frees (``None`` where not made yet).
    _petsc_vectors: tuple[str, ...] = ("x_ext", "b_ext", "_work")

    @property
    def layout_version(self) -> int:
        """Grows when the ghosts and the matrix pattern change (a kind that re-pairs says so)."""
        return 0

    def overhang(self) -> Overhang | None:
        """Where the secondary facets reach beyond the primary surface at the last iterate.

        ``None`` where the kind has no such measure (fixed pairs: nothing to reach beyond) or
        before the first iterate; the validity watch judges it.
        """
        return None

    if TYPE_CHECKING:  # what a kind gives: an attribute (small sliding) or a property (finite)

        @property
        def index_map(self) -> dolfinx.common.IndexMap:
            """The index map of the interface's dofs: ``V``'s extended with its extra ghosts."""
            ...

        @property
        def b_ext(self) -> PETSc.Vec | None:
            """A work vector of :attr:`index_map` (``None`` once destroyed)."""
            ...

    def __init__(self, V: dolfinx.fem.FunctionSpace, name: str, timings: Any) -> None:
        self.name = name
        self.V = V
        self.comm = V.mesh.comm
        self.timings = timings
        self.n_owned = V.dofmap.index_map.size_local * V.dofmap.bs
        self.force = np.zeros(self.n_owned)
        self.dt = 0.0
        self._x_at_update: np.ndarray | None = None
        self._work: PETSc.Vec | None = None

    # -- what a kind gives -----------------------------------------------------------------------
    @property
    @abc.abstractmethod
    def law_points(self) -> Any:
        """The law's points (:class:`~.protocol.LawPoints`)."""

    @abc.abstractmethod
    def update(self, x: PETSc.Vec | np.ndarray) -> Any:
        """Evaluate the law at the displacement ``x`` (owned values; collective).

        Returns:
            The :class:`~subfric_dolfinx.constitutive.ReturnMapResult`.
        """

    @abc.abstractmethod
    def forces(self) -> np.ndarray:
        """The owned interface forces of the last iterate (collective: a reverse scatter)."""

    @abc.abstractmethod
    def resume(self, x: np.ndarray) -> None:
        """Continue from the owned displacement ``x`` with the committed state in place."""

    @abc.abstractmethod
    def layout_parts(self) -> tuple[np.ndarray, np.ndarray, Any, Any]:
        """Extra ghosts, their owners, the extended index map and the couplings."""

    @abc.abstractmethod
    def _lifting(self, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``K (g - x)`` over the constrained ``dofs`` with ``values`` there (owned rows)."""

    @abc.abstractmethod
    def _add_tangent(
        self,
        A: PETSc.Mat,
        constrained: np.ndarray | None,
        separated_stiffness: float,
        start: NewtonStart | None,
    ) -> None:
        """Add the tangent of the last iterate to ``A``, the ``constrained`` dofs left out.

        Args:
            A: The matrix (``ADD_VALUES``).
            constrained: Whether each local dof of the extended map is constrained (``None``:
                none is).
            separated_stiffness: As for :meth:`assemble_jacobian`.
            start: As for :meth:`assemble_jacobian`.
        """

    def start_correction(self, x: PETSc.Vec | np.ndarray) -> np.ndarray | None:
        """The change of an extrapolated start ``x`` this kind makes (collective).

        The stepper's extrapolated start (:meth:`~subfric_dolfinx.fem.solver.FrictionSolver.solve`'s
        ``predictor``) is given to every interface before Newton starts from it; a kind may
        change it (a finite-sliding interface keeps its points in contact closed:
        :meth:`~.finite.interface.SlidingInterface.start_correction`). The owned change of the
        displacement, or ``None``: none (the default: the fixed pairs of small sliding are
        evaluated as they are).
        """
        return None

    # -- the step --------------------------------------------------------------------------------
    def set_step(self, dt: float) -> None:
        """Set the length of the step the return map integrates (the recovery at rest)."""
        self.dt = float(dt)
        self._x_at_update = None

    def _time(self, name: str) -> Any:
        return self.timings(name) if self.timings is not None else contextlib.nullcontext()

    def _owned(self, x: PETSc.Vec | np.ndarray) -> np.ndarray:
        """The owned values of ``x`` (a PETSc vector, or an array of at least the owned ones)."""
        return x.array_r if isinstance(x, PETSc.Vec) else np.asarray(x)[: self.n_owned]

    def _ensure(self, x: PETSc.Vec | np.ndarray | None) -> None:
        """Evaluate the law at ``x`` unless it is the last iterate (``None``: the last one)."""
        if x is None:
            if self.last is None:
                raise RuntimeError(f"interface {self.name!r}: no iterate evaluated yet")
            return
        owned = self._owned(x)
        if self._x_at_update is None or not np.array_equal(self._x_at_update, owned):
            self.update(x)

    # -- into the user's vector and matrix -------------------------------------------------------
    def assemble_residual(
        self,
        b: PETSc.Vec,
        x: PETSc.Vec | None = None,
        *,
        bcs: Sequence[Any] | None = None,
    ) -> bool:
        """Add the interface forces at ``x`` to the residual ``b`` (owned part; collective).

        Args:
            b: The residual (displacement layout); its owned entries are added to.
            x: The iterate (``None``: the last one evaluated); evaluated if new.
            bcs: DOLFINx Dirichlet conditions: the forces go to the free rows only, plus the
                lifting ``K (g - x)`` of the tangent's coupling to the constrained dofs
                (DOLFINx's convention for Newton with lifting).

        Returns:
            Whether the return map succeeded at every point of this rank.
        """
        self._ensure(x)
        f = self.forces()
        ba = b.array_w
        if not bcs:
            ba += f
            return bool(self.last.converged)
        dofs, g_minus_x = _bc_values(self.V, bcs, self._x_at_update)
        free = np.ones(self.n_owned, dtype=bool)
        free[dofs] = False
        lift = self._lifting(dofs, g_minus_x)
        ba[free] += f[free] + lift[free]
        return bool(self.last.converged)

    def assemble_jacobian(
        self,
        A: PETSc.Mat,
        x: PETSc.Vec | None = None,
        *,
        bcs: Sequence[Any] | None = None,
        separated_stiffness: float = 0.0,
        start: NewtonStart | None = None,
    ) -> None:
        """Add the tangent at ``x`` to ``A`` (``ADD_VALUES``; call ``A.assemble()``).

        ``A`` must hold the interface's couplings (:func:`~.layout.create_matrix`, after the last
        :attr:`layout_version`).

        Args:
            A: The matrix.
            x: The displacement (owned values); ``None``: the last iterate's.
            bcs: DOLFINx Dirichlet conditions: the rows and columns of their dofs are left out
                (their diagonal is the bulk assembly's).
            separated_stiffness: In this Jacobian only, points without stiffness (separated
                beyond the contact band, failed) get this fraction of the law's contact
                stiffness (:func:`stiffen_separated`); 0: the exact tangent.
            start: The first Jacobian of a step: how its Newton iteration starts
                (:class:`NewtonStart`; each kind decides what its tangent makes of it);
                ``None``: a later iteration.
        """
        from ..timing import TIMER_INTERFACE

        self._ensure(x)
        with self._time(TIMER_INTERFACE):
            mask = self._constrained(bcs) if bcs else None
            self._add_tangent(A, mask, separated_stiffness, start)

    def _extended(self, dofs: np.ndarray, values: np.ndarray | float) -> np.ndarray:
        """The local values of ``values`` at the owned ``dofs`` (0 elsewhere), ghosts updated.

        A work vector of the extended map carries them (collective: a forward scatter).
        """
        if self._work is None:
            self._work = petsc_vector(self.index_map, self.V.dofmap.bs)
        w = self._work
        with w.localForm() as wl:
            wl.set(0.0)
        w.array_w[dofs] = values
        w.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with w.localForm() as wl:
            return wl.array_r.copy()

    def _sum_to_owners(self, add: Callable[[np.ndarray], None]) -> np.ndarray:
        """The owned sums of what ``add`` puts into the local values of the extended map.

        ``add`` adds into the local values (owned and ghosts, zeroed first) of :attr:`b_ext`; the
        ghosts' parts go to their owners (collective: a reverse scatter).
        """
        assert self.b_ext is not None  # (None once destroyed)
        with self.b_ext.localForm() as bl:
            bl.set(0.0)
            add(bl.array_w)
        self.b_ext.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return self.b_ext.array_r[: self.n_owned].copy()

    def _constrained(self, bcs: Sequence[Any]) -> np.ndarray:
        """Whether each local dof of the extended map is constrained by ``bcs`` (collective)."""
        dofs, _ = _bc_values(self.V, bcs, None)
        return self._extended(dofs, 1.0) > 0.5

    # -- state -----------------------------------------------------------------------------------
    def commit(self) -> None:
        """Accept the trial state (after a converged step)."""
        self.law_points.state.commit()

    def revert(self) -> None:
        """Reject the trial state (after a failed step)."""
        self.law_points.state.revert()
        self._x_at_update = None

    def destroy(self) -> None:
        """Free the PETSc vectors (safe to call more than once)."""
        for name in self._petsc_vectors:
            v = getattr(self, name, None)
            if v is not None:
                v.destroy()
                setattr(self, name, None)


def _bc_values(
    V: dolfinx.fem.FunctionSpace, bcs: Sequence[Any], x: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """Owned constrained dofs of DOLFINx ``bcs`` (unrolled, sorted) and ``g - x`` there."""
    bs = V.dofmap.bs
    imap = V.dofmap.index_map
    n_owned, n_all = imap.size_local * bs, (imap.size_local + imap.num_ghosts) * bs
    per_bc = [bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in bcs]
    dofs = np.unique(np.concatenate(per_bc)) if per_bc else np.zeros(0, np.int32)
    dofs = dofs[dofs < n_owned].astype(np.int32)
    values = np.zeros(n_all)
    x0 = np.zeros(n_all)
    if x is not None:
        x0[:n_owned] = x[:n_owned]
    for bc in bcs:
        bc.set(values, x0, 1.0)
    return dofs, values[dofs]


def saved_law_state(state: StatePair) -> dict[str, np.ndarray]:
    """The committed internal variables of the law (what a restart needs), name -> array."""
    return dict(state.old.items())


def restore_law_state(state: StatePair, arrays: Mapping[str, np.ndarray]) -> None:
    """Put the law's variables of ``arrays`` back as the committed and trial ``state``."""
    st = state.old
    for name in st.names:
        st[name][...] = np.asarray(arrays[name]).reshape(st[name].shape)
    state.revert()


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


def initial_gaps(
    spec: float | Callable[[np.ndarray], np.ndarray] | None, x: np.ndarray, comm
) -> np.ndarray:
    """The initial gap at points ``x`` (n, gdim) (collective: a failure is raised on every rank).

    Raises:
        InterfaceError: The function failed, gave the wrong number of values or a value that is
            not finite (the first such point is named).
    """
    n = x.shape[0]
    error = None
    g = np.zeros(n)
    try:
        if spec is not None:
            vals = spec(x.T.copy()) if callable(spec) else spec
            g = np.array(np.broadcast_to(np.asarray(vals, dtype=float), (n,)))
            bad = np.flatnonzero(~np.isfinite(g))
            if bad.size:
                where = ", ".join(f"{v:.6g}" for v in x[bad[0]])
                error = f"the initial gap is not finite at ({where}): {g[bad[0]]:g}"
    except Exception as e:  # a function of the user's, or values of the wrong shape
        error = f"the initial gap could not be evaluated: {type(e).__name__}: {e}"
    errors = [m for m in comm.allgather(error) if m]
    if errors:
        raise InterfaceError(errors[0])
    return g


@dataclasses.dataclass
class Received:
    """Rows received in an exchange, grouped by source rank (ascending)."""

    source: np.ndarray
    rows: list[np.ndarray]


def exchange_rows(comm: MPI.Comm, dest: np.ndarray, arrays: list[np.ndarray]) -> Received:
    """Send row ``i`` of each array to rank ``dest[i]`` (``MPI_Alltoallv``; collective).

    Only the counts go to every rank; the rows go where they are needed.
    """
    order = np.argsort(dest, kind="stable")
    counts = np.bincount(dest, minlength=comm.size).astype(np.int64)
    recv_counts = np.empty_like(counts)
    comm.Alltoall(counts, recv_counts)
    n_recv = int(recv_counts.sum())
    out = []
    for a in arrays:
        a = np.ascontiguousarray(a[order])
        width = math.prod(a.shape[1:])
        recv = np.empty((n_recv, *a.shape[1:]), dtype=a.dtype)
        sc, rc = counts * width, recv_counts * width
        sd = np.concatenate([[0], np.cumsum(sc)[:-1]])
        rd = np.concatenate([[0], np.cumsum(rc)[:-1]])
        comm.Alltoallv([a, (sc, sd)], [recv, (rc, rd)])
        out.append(recv)
    return Received(np.repeat(np.arange(comm.size, dtype=np.int32), recv_counts), out)
