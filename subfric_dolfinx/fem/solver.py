"""PETSc SNES on an :class:`~subfric_dolfinx.fem.problem.InterfaceProblem`, with a clean lifecycle.

:class:`FrictionSolver` wraps a petsc4py SNES under an options prefix, so that PETSc options given
on the command line (``-<prefix>snes_monitor``, ``-<prefix>ksp_type gmres``, ...) apply. Its
lifecycle follows DOLFINx's own SNES ``NonlinearProblem`` (DOLFINx main,
``python/dolfinx/fem/petsc.py``): the solver's options are pushed into the global options database
under its prefix, applied by ``setFromOptions``, and deleted again (values the database had before
are restored), so nothing outlives the object and options given to one solver never reach
another. The solver's own options are pushed again around each solve, because PETSc reads some
of them late (e.g. MUMPS reads ``mat_mumps_*`` when it factorises). It is a context manager whose
exit destroys the PETSc objects and releases the prefix; :meth:`FrictionSolver.destroy` is
idempotent, and a solver that is garbage-collected releases its prefix too.

Defaults (Newton with a full step, LU with MUMPS) apply only where neither the solver's options
nor the options database give a value. A point the return map cannot integrate makes SNES see a
function-domain error (:mod:`._petsc`).

Newton stops by the load-scaled test of :mod:`.convergence` (relative to the step's first
residual, or at the round-off floor of the residual, which grows with the load and the mesh;
a step stalled at that floor is converged): no absolute tolerance is needed, ``snes_atol`` is 0
by default. The user's ``snes_rtol``, ``snes_atol``, ``snes_stol``,
``snes_divergence_tolerance`` and ``snes_max_it`` apply within it;
``-<prefix>snes_convergence_test default`` selects PETSc's own test instead (then give a
``snes_atol`` suited to the problem).
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from collections.abc import Callable, Mapping, Sequence
from typing import Any, cast

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..compat import pushed_options
from ._petsc import set_function_domain_error
from .convergence import SNORM_SLACK, ScaledConvergence
from .interface import NewtonStart
from .linear import LinearStrategy, choose_strategy, strategy_options
from .problem import InterfaceProblem
from .timing import event_times

__all__ = [
    "DEFAULT_OPTIONS",
    "KSP_REASON_NAMES",
    "PETSC_ERROR_REASON",
    "FrictionSolver",
    "SolveResult",
    "SolverOptionError",
    "krylov_failure",
]

DEFAULT_OPTIONS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-9,
    "snes_atol": 0.0,
    "snes_stol": 1e-12,
    "snes_max_it": 30,
}
"""Options used where neither the solver's options nor the options database give a value
(with those of the linear strategy for the problem, :func:`~.linear.strategy_options`)."""

PETSC_ERROR_REASON = -100
""":attr:`SolveResult.reason` of a solve that PETSc ended with an error (raised inside a callback
or the linear solver: :attr:`SolveResult.error` says what); not an SNES reason code."""


@dataclasses.dataclass(frozen=True)
class SolveResult:
    """What one :meth:`FrictionSolver.solve` did: the same fields whatever the outcome.

    Attributes:
        converged: Newton converged (``CONVERGED_SNORM_RELATIVE`` with a residual far above the
            tolerances is not converged: :data:`~.convergence.SNORM_SLACK`).
        iterations: Newton iterations.
        reason: SNES converged reason code; :data:`PETSC_ERROR_REASON` if PETSc raised an error.
        converged_by: Which test of :class:`~.convergence.ScaledConvergence` stopped Newton:
            ``"rtol"``, ``"atol"``, ``"floor"``, ``"stall"``, ``"stol"``; ``None`` if it did not
            converge or PETSc's own test was used.
        residuals: Residual norms per iteration (empty after a PETSc error).
        counts: Return-map statuses at the last evaluation, over every interface and rank
            (:meth:`~.problem.InterfaceProblem.status_counts`; empty after a PETSc error).
        krylov: Krylov iterations (of both solves when the linear solve was repeated; those of
            a Newton solve that PETSc ended with an error are not counted).
        linear_retry: The solve was repeated with a fresh preconditioner after a Krylov failure
            with a stale one; the other values are the repeat's.
        interrupted: :attr:`FrictionSolver.interrupt` asked to stop: not converged, ``x`` is
            that of an abandoned iterate.
        error: PETSc's error message when PETSc raised one (``reason`` is then
            :data:`PETSC_ERROR_REASON`), else ``None``.
        linear_failure: Newton stopped because a Krylov solve failed
            (``DIVERGED_LINEAR_SOLVE``): what the Krylov solver did and the options that
            change it (:func:`krylov_failure`), else ``None``.
    """

    converged: bool
    iterations: int
    reason: int
    converged_by: str | None = None
    residuals: tuple[float, ...] = ()
    counts: Mapping[str, int] = dataclasses.field(default_factory=dict)
    krylov: int = 0
    linear_retry: bool = False
    interrupted: bool = False
    error: str | None = None
    linear_failure: str | None = None


def _ksp_reason_names() -> dict[int, str]:
    names: dict[int, str] = {}
    for name, code in vars(PETSc.KSP.ConvergedReason).items():
        if name.isupper() and "DEPRECATED" not in name and isinstance(code, int):
            names.setdefault(int(code), name)
    return names


KSP_REASON_NAMES = _ksp_reason_names()
"""PETSc's names of the Krylov solver's converged reasons, by code (negative: failed)."""


def krylov_failure(ksp: PETSc.KSP, prefix: str) -> str | None:
    """What a failed Krylov solve did and the options that change it (``None``: it did not fail).

    Names the method, the preconditioner, PETSc's reason and the iterations, then the options
    under ``prefix`` to change for that reason: GMRES's breakdown at a restart (the residual of
    its recursion far from the true one: raise the restart or reorthogonalise), the iteration
    limit, a failed preconditioner. The same text on every rank (the KSP is collective).
    """
    reason = int(ksp.getConvergedReason())
    if reason >= 0:
        return None
    name = KSP_REASON_NAMES.get(reason, str(reason))
    why = PETSc.KSP.ConvergedReason
    kind, pc, its = ksp.getType(), ksp.getPC().getType(), ksp.getIterationNumber()
    max_it = ksp.getTolerances()[3]
    text = f"the Krylov solver failed: {kind} with pc {pc}, {name} after {its} iterations"
    o = f"-{prefix}"
    if reason == why.DIVERGED_BREAKDOWN and kind in ("gmres", "fgmres", "lgmres", "dgmres"):
        hint = (
            f"at a restart GMRES's true residual was far from the one of its recursion (a "
            f"basis no longer orthogonal, or a preconditioner that is not one linear "
            f"operator): raise {o}ksp_gmres_restart (at most {o}ksp_max_it, {max_it}: no "
            f"restart) and orthogonalise twice ({o}ksp_gmres_cgs_refinement_type "
            "refine_always, the strategy 'gamg''s default)"
        )
    elif reason == why.DIVERGED_MAX_IT:
        hint = f"raise {o}ksp_max_it ({max_it}), or choose the linear strategy 'lu'"
    elif reason == why.DIVERGED_PCSETUP_FAILED:
        hint = f"the preconditioner failed: change {o}pc_type, or choose the linear strategy 'lu'"
    else:
        hint = f"change {o}ksp_type or {o}pc_type, or choose the linear strategy 'lu'"
    return f"{text} ({hint})"


_LIVE_PREFIXES: set[str] = set()


class _AutoPrefix:
    """The next number of an automatic prefix ``subfric_<n>_`` in this process."""

    next = 0


def _local_prefix_problem(prefix: str) -> str | None:
    """What is wrong with ``prefix`` on this rank (``None``: nothing)."""
    if not isinstance(prefix, str) or not prefix or not prefix.endswith("_"):
        return f"the options prefix must be a non-empty string ending in '_', got {prefix!r}"
    if any(ch.isspace() or ch == "-" for ch in prefix):
        return f"the options prefix {prefix!r} must not contain spaces or '-'"
    if prefix in _LIVE_PREFIXES:
        return (
            f"the options prefix {prefix!r} is already used by another live solver; "
            "give each solver its own prefix (or destroy the other one first)"
        )
    return None


def _check_prefix(prefix: str | None, comm: MPI.Comm) -> str:
    """The solver's prefix, the same on every rank of ``comm`` (collective).

    Each rank reads its options under its own prefix, so ranks with different prefixes would
    configure one SNES differently (and part ways in a collective). An automatic prefix is
    agreed over ``comm`` (a solver made on some ranks only, e.g. on ``COMM_SELF``, has moved
    their count on); a given one must be the same on every rank.

    Raises:
        ValueError: On every rank: the ranks give different prefixes, or one is malformed or
            used by a live solver on some rank.
    """
    if prefix is None:
        n = comm.allreduce(_AutoPrefix.next, op=MPI.MAX)
        while comm.allreduce(f"subfric_{n}_" in _LIVE_PREFIXES, op=MPI.LOR):
            n += 1
        _AutoPrefix.next = n + 1
        return f"subfric_{n}_"
    given = comm.allgather((prefix, _local_prefix_problem(prefix)))
    prefixes = [p for p, _ in given]
    if any(p != prefix for p in prefixes):
        raise ValueError(
            f"the options prefix differs between the ranks: {prefixes} (by rank); a solver's "
            "prefix must be the same on every rank of its communicator"
        )
    problem = next((why for _, why in given if why is not None), None)
    if problem is not None:
        raise ValueError(problem)
    return prefix


class SolverOptionError(ValueError):
    """PETSc refused a solver option (a value of the wrong kind, an unknown type name).

    Attributes:
        key: The option (without the prefix) found to be refused alone, or ``None``.
    """

    def __init__(self, message: str, key: str | None = None) -> None:
        super().__init__(message)
        self.key = key


def _refused_alone(key: str, value: Any) -> PETSc.Error | None:
    """PETSc's error on a scratch SNES (this process only) given only ``key = value``."""
    prefix = "subfric_optcheck_"
    snes = PETSc.SNES().create(PETSc.COMM_SELF)
    try:
        snes.setOptionsPrefix(prefix)
        with pushed_options(prefix, {key: value}):
            snes.setFromOptions()
    except PETSc.Error as e:
        return e
    finally:
        snes.destroy()
    return None


def option_error(prefix: str, layers: Sequence[Mapping[str, Any]], error: Exception) -> Exception:
    """The error to raise when ``setFromOptions`` failed under ``prefix`` (on every rank).

    The first option under the prefix (the database's, then ``layers``' values) that PETSc
    refuses alone on a scratch solver is named with its value; each rank probes on its own
    and finds the same.
    """
    given: dict[str, Any] = {}
    db = PETSc.Options()
    for name in db.getAll():
        if name.startswith(prefix):
            given[name[len(prefix) :]] = db.getString(name)
    for layer in layers:
        given.update({k.lstrip("?"): v for k, v in layer.items()})
    code = getattr(error, "ierr", None)
    why = f"PETSc error code {code}" if code is not None else str(error)
    for key, value in given.items():
        e = _refused_alone(key, value)
        if e is not None:
            return SolverOptionError(
                f"PETSc refuses the option {prefix}{key} = {value!r} ({why}: a value of the "
                "wrong kind or an unknown name)",
                key,
            )
    return SolverOptionError(f"PETSc refuses the options under {prefix!r} ({why}): {given}")


class FrictionSolver:
    """SNES on an interface problem, under an options prefix.

    Use as a context manager (or call :meth:`destroy`)::

        with FrictionSolver(problem, "block_", {"snes_rtol": 1e-10}) as solver:
            solver.solve(t, dt)

    Args:
        problem: The problem.
        prefix: PETSc options prefix, the same on every rank, unique among live solvers (e.g.
            ``"block_"``); a unique ``"subfric_<n>_"`` (agreed over the ranks) when omitted.
        options: Options under the prefix (they override the command line's for this solver,
            without changing the database).
        linear: The linear strategy, ``"auto"`` (default: chosen by the problem's size and
            dimension, :func:`~.linear.auto_choice`), ``"reuse"``, ``"lu"`` or ``"gamg"``
            (:mod:`.linear`); its PETSc options are defaults that options override. The one
            chosen is :attr:`strategy`.

    Raises:
        ValueError: Malformed prefix, one used by a live solver, prefixes that differ between
            the ranks, or an unknown strategy.
    """

    def __init__(
        self,
        problem: InterfaceProblem,
        prefix: str | None = None,
        options: Mapping[str, Any] | None = None,
        *,
        linear: str = "auto",
    ) -> None:
        linear = choose_strategy(linear, problem)
        self.strategy = linear
        """The linear strategy in use (``"auto"`` resolved)."""
        self.prefix = _check_prefix(prefix, problem.comm)
        self.problem = problem
        self.options = dict(options or {})
        defaults = {**DEFAULT_OPTIONS, **strategy_options(linear, problem)}
        self._defaults = {"?" + k: v for k, v in defaults.items()}
        # (None before they are made and once destroyed)
        self.snes: PETSc.SNES | None = None
        self.x: PETSc.Vec | None = None
        self.F: PETSc.Vec | None = None
        self.J: PETSc.Mat | None = None
        self._x0: PETSc.Vec | None = None
        self.convergence: ScaledConvergence | None = None
        self.linear: LinearStrategy | None = None
        _LIVE_PREFIXES.add(self.prefix)
        # Release the prefix even if the solver is never destroyed explicitly.
        self._finalizer = weakref.finalize(self, _LIVE_PREFIXES.discard, self.prefix)
        try:
            self.x = problem.create_vector()
            self._x0 = problem.create_vector()
            self.F = problem.create_vector()
            self.J = problem.create_matrix()
            self._layout_version = getattr(problem, "layout_version", 0)
            self.linear = LinearStrategy(linear, problem)
            snes = PETSc.SNES().create(problem.comm)
            self.snes = snes
            snes.setOptionsPrefix(self.prefix)
            # Module-level-style callbacks through a weak reference: the SNES does not keep the
            # solver alive, and the solver's finalizer can run (the SNES, and with it these
            # callbacks, lives no longer than the solver: ref() is the solver when they run).
            ref = weakref.ref(self)
            snes.setFunction(lambda s, x, F: cast(FrictionSolver, ref())._residual(s, x, F), self.F)
            snes.setJacobian(
                lambda s, x, J, P: cast(FrictionSolver, ref())._jacobian(s, x, J, P),
                *self.linear.matrices(self.J),
            )
            snes.setConvergenceHistory(length=200, reset=True)
            self.convergence = ScaledConvergence(problem)
            self._converged = lambda s, it, norms: cast(FrictionSolver, ref())._convergence_test(
                s, it, norms
            )
            self._configure()
        except BaseException:
            self.destroy()
            raise
        self.failed_points: np.ndarray = np.zeros(0, dtype=np.int64)
        self.separated_stiffness = 0.0  # of the current solve (see solve)
        self._start_next: NewtonStart | None = None  # the next Jacobian's (a step's first)
        self.interrupt: Callable[[], bool] | None = None
        """Asked at every residual evaluation, on every rank: ``True`` on any rank abandons
        the solve there (collectively, through a function-domain error; nothing is raised
        inside PETSc): :meth:`solve` returns ``interrupted``. E.g. a second stop signal."""
        self.interrupted = False
        # PETSc's log events are cumulative over the process: where this solver starts.
        self.event_start = event_times()

    def _new_pattern(self) -> None:
        """New Jacobian matrices on the problem's new pattern (finite sliding re-paired)."""
        assert self.J is not None and self.snes is not None and self.linear is not None  # (alive)
        self.J.destroy()
        self.J = self.problem.create_matrix()
        self.linear.new_pattern()
        self._bind()
        self._layout_version = self.problem.layout_version

    def _bind(self) -> None:
        """Give the SNES the Jacobian callback and the current matrices."""
        assert self.J is not None and self.snes is not None and self.linear is not None  # (alive)
        ref = weakref.ref(self)
        self.snes.setJacobian(
            lambda s, x, J, P: cast(FrictionSolver, ref())._jacobian(s, x, J, P),
            *self.linear.matrices(self.J),
        )

    def _configure(self, extra: Mapping[str, Any] | None = None) -> None:
        db = PETSc.Options()
        given = {k for k in db.getAll() if k.startswith(self.prefix)}
        user = {k[len(self.prefix) :] for k in given} | set(self.options) | set(extra or {})
        assert self.snes is not None and self.linear is not None  # (alive)
        with pushed_options(self.prefix, self._defaults, self.options, extra or {}):
            try:
                self.snes.setFromOptions()
            except PETSc.Error as e:
                layers = (self.options, extra or {})
                raise option_error(self.prefix, layers, e) from None
            # PETSc's own test only where asked for by name (setFromOptions has set it then)
            if not db.hasName(self.prefix + "snes_convergence_test"):
                self.snes.setConvergenceTest(self._converged)
            self.linear.configure(self.snes, user)

    # -- callbacks ------------------------------------------------------------------------------
    def _residual(self, snes: PETSc.SNES, x: PETSc.Vec, F: PETSc.Vec) -> None:
        assert self.linear is not None  # (alive: the SNES calls back)
        self.linear.linear_done(snes)
        ok = self.problem.residual(x, F)
        if not ok:
            self.failed_points = self.problem.failed_points()
        stop = self.interrupted or (self.interrupt is not None and bool(self.interrupt()))
        # on every rank or none: SNES's line search checks the domain error on each rank alone,
        # and ranks that disagree would part ways (one leaves the solve, the other waits)
        flags = self.problem.comm.allreduce(int(not ok) | 2 * int(stop), op=MPI.BOR)
        self.interrupted = bool(flags & 2)
        if flags:
            set_function_domain_error(snes, F)

    def _jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        assert self.linear is not None and self.convergence is not None  # (alive)
        self.linear.linear_done(snes)
        start, self._start_next = self._start_next, None
        self.problem.jacobian(x, J, self.separated_stiffness, start)
        self.linear.jacobian(snes, J, self.convergence.floor(), self.convergence.reference_norm)
        if self.linear.rebind:  # a new preconditioning matrix: the SNES factorises it from now
            self.linear.rebind = False
            self._bind()

    def _convergence_test(self, snes: PETSc.SNES, it: int, norms: tuple) -> int:
        if self.interrupted:  # agreed by every rank at the residual
            return PETSc.SNES.ConvergedReason.DIVERGED_FUNCTION_DOMAIN
        assert self.convergence is not None and self.linear is not None  # (alive)
        reason = self.convergence(snes, it, norms)
        if reason > 0 and self.linear.loosened:
            # the iterate of a loosened Krylov solve is never the answer: one more iteration,
            # solved to the strategy's full accuracy (the same decision on every rank)
            self.convergence.by = None
            self.linear.held += 1
            return PETSc.SNES.ConvergedReason.ITERATING
        return reason

    # -- solving --------------------------------------------------------------------------------
    def solve(
        self,
        t: float,
        dt: float,
        *,
        options: Mapping[str, Any] | None = None,
        separated_stiffness: float = 0.0,
        predictor: np.ndarray | None = None,
        start: NewtonStart | None = None,
    ) -> SolveResult:
        """Solve for the state at ``t`` after a step ``dt`` from the current (converged) one.

        The current ``x`` is the initial guess, with the Dirichlet values of ``t`` set in it
        (plus ``predictor``, if given).

        Args:
            t: End time of the step.
            dt: Step length.
            options: Options for this solve only (e.g. ``{"snes_linesearch_type": "bt"}`` for a
                retry); the solver's configuration is restored afterwards.
            separated_stiffness: For this solve, the Jacobian gives points without stiffness
                (separated) this fraction of the contact stiffness
                (:func:`~.problem.stiffen_separated`: Newton steps exist where a body floats
                free); 0, the default: the exact Jacobian.
            predictor: An increment of the owned values added to the initial guess (e.g. the
                last step's, extrapolated: :class:`~.stepping.LoadStepper`'s ``predictor``;
                Dirichlet values stay those of ``t``). Newton's relative tolerance is then
                taken against the residual of the guess without it (one more residual
                evaluation): the same target as without the predictor, however close the
                extrapolated guess is (an exact one has a residual of round-off, against which
                no relative target is reachable), and the first iterate is not accepted at the
                round-off floor (:attr:`~.convergence.ScaledConvergence.predicted`). The
                interfaces may change the extrapolated start
                (:meth:`~.problem.InterfaceProblem.correct_start`: a finite-sliding interface
                keeps the points pressed at the step's start closed).
            start: How the step's Newton iteration starts (:class:`~.interface.NewtonStart`:
                the loading program turns here, the stepper extrapolates), for its first
                Jacobian alone: each interface's kind decides what its tangent makes of it (a
                finite-sliding interface's first iterate slides instead of shearing the bodies
                where the program turns, and keeps in contact the points an extrapolated start
                opened by a hair; ``docs/model.md`` §12). The later iterations, the residual and
                the solution are unchanged. :class:`~.stepping.LoadStepper` gives it.

        Returns:
            A :class:`SolveResult` (its fields are the same on success, failure and a PETSc
            error).
        """
        if self.snes is None:
            raise RuntimeError("the solver has been destroyed")
        # (all made with the SNES, and destroyed with it)
        assert self.x is not None and self.F is not None and self._x0 is not None
        assert self.convergence is not None and self.linear is not None
        p = self.problem
        if not (math.isfinite(separated_stiffness) and separated_stiffness >= 0.0):
            raise ValueError(f"separated_stiffness = {separated_stiffness!r} must be >= 0")
        self.separated_stiffness = float(separated_stiffness)
        p.set_step(t, dt)
        if getattr(p, "layout_version", 0) != self._layout_version:
            self._new_pattern()
        p.apply_dirichlet(self.x)
        self.failed_points = np.zeros(0, dtype=np.int64)
        self.interrupted = False
        self.snes.setConvergenceHistory(length=200, reset=True)
        self.convergence.start()
        self.convergence.reference = None
        if predictor is not None:
            ok = p.comm.allreduce(int(bool(p.residual(self.x, self.F))), op=MPI.MIN)
            self.convergence.reference = self.F.norm() if ok else 0.0
            self.x.array_w[:] += predictor
            p.apply_dirichlet(self.x)
            correct = getattr(p, "correct_start", None)
            if correct is not None:  # the interfaces' say on the extrapolated start
                correct(self.x)
                p.apply_dirichlet(self.x)
        if options:
            self._configure(options)
        self.x.copy(self._x0)
        self._start_next = start
        krylov = 0
        retried = False
        try:
            with pushed_options(self.prefix, self._defaults, self.options, options or {}):
                self.linear.start()
                self.snes.solve(None, self.x)
                krylov = self.snes.getLinearSolveIterations()
                retry = self.linear.finish(self.snes, self.snes.getConvergedReason() > 0)
                if retry and not self.interrupted:
                    # the Krylov solve failed with a stale preconditioner: once more, fresh
                    self.linear.retries += 1
                    retried = True
                    self._x0.copy(self.x)
                    p.revert()
                    self.failed_points = np.zeros(0, dtype=np.int64)
                    self.snes.setConvergenceHistory(length=200, reset=True)
                    self.convergence.start()
                    self._start_next = start
                    self.linear.start(fresh=True)
                    self.snes.solve(None, self.x)
                    krylov += self.snes.getLinearSolveIterations()
                    self.linear.finish(self.snes, self.snes.getConvergedReason() > 0)
        except PETSc.Error as e:  # an error inside a callback or the linear solver
            self.linear.force = True
            return SolveResult(
                converged=False,
                iterations=self.snes.getIterationNumber(),
                reason=PETSC_ERROR_REASON,
                krylov=int(krylov),
                linear_retry=retried,
                interrupted=self.interrupted,
                error=str(e),
            )
        finally:
            self._start_next = None
            if options:
                self._configure()
        reason = self.snes.getConvergedReason()
        hist, _ = self.snes.getConvergenceHistory()
        converged = reason > 0
        snorm = reason == PETSc.SNES.ConvergedReason.CONVERGED_SNORM_RELATIVE
        if snorm and len(hist) and self.convergence.by is None:
            # PETSc's own test (ours decides this itself, :mod:`.convergence`)
            rtol, atol, _, _ = self.snes.getTolerances()
            converged = bool(hist[-1] <= SNORM_SLACK * max(atol, rtol * hist[0]))
        counts = p.status_counts()
        failure = None
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
            failure = krylov_failure(self.snes.getKSP(), self.prefix)
        return SolveResult(
            converged=bool(converged),
            iterations=self.snes.getIterationNumber(),
            reason=int(reason),
            converged_by=self.convergence.by if reason > 0 else None,
            residuals=tuple(float(r) for r in hist),
            counts=counts,
            krylov=int(krylov),
            linear_retry=retried,
            interrupted=bool(self.interrupted),
            linear_failure=failure,
        )

    def refresh_preconditioner(self) -> None:
        """Rebuild the preconditioner at the next Newton iteration (strategies that reuse one).

        :func:`~subfric_dolfinx.io.write_checkpoint` calls it: a run restarted from the
        checkpoint starts with a fresh preconditioner, and so does the run that wrote it from
        there on, so both continue alike, to round-off (with a factor kept from earlier, the
        inexact Krylov solves would leave differences of the order of Newton's tolerance).
        """
        if self.linear is not None:
            self.linear.force = True

    # -- lifecycle ------------------------------------------------------------------------------
    def destroy(self) -> None:
        """Free the PETSc objects and release the prefix (safe to call more than once)."""
        for name in ("snes", "J", "x", "_x0", "F", "convergence", "linear"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)
        self._finalizer()

    @property
    def alive(self) -> bool:
        """Whether the solver still holds its PETSc objects."""
        return self.snes is not None

    def __enter__(self) -> FrictionSolver:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()
