"""Newton's stopping test, scaled to the problem: relative, absolute, and at the round-off floor.

The residual ``F = K u - f_ext + R_int`` (free rows) is a sum of terms that cancel at the
solution, each computed in floating point: it cannot be made smaller than about ``eps`` times
the size of those terms, however exact the linear solves. That size is::

    S = || |K| |u| + |f_ext| + |R_int| ||_2        (free rows, not the Dirichlet ones)

with ``|K|`` the entrywise absolute value of the bulk stiffness (for a nonlinear bulk law: of its
tangent at rest, the elastic stiffness of the bodies, and ``K u`` is its internal force). The
smallest residual Newton reaches is a fixed fraction of ``eps S`` below one, at every size
(``docs/design.md``, *Newton's stopping test*). An absolute tolerance (``snes_atol``) or one
relative to a step's first residual (``snes_rtol``) cannot see this floor: it grows with the load
and the mesh, beyond any fixed ``snes_atol`` and beyond ``snes_rtol`` times the first residual of
a pressing step on a large mesh, and Newton then stalls at its iteration limit, the step is cut,
and cutting only lowers the relative target further.

:class:`ScaledConvergence` declares Newton's iteration ``k`` converged when, first that holds,

* ``|F_k| <= atol`` (the user's ``snes_atol``, 0 by default),
* ``|F_k| <= rtol |F_0|`` (``k >= 1``; ``snes_rtol``; where the first iterate was
  extrapolated, ``|F_0|`` is at least that of the step's start without the extrapolation,
  :attr:`ScaledConvergence.reference`),
* ``|F_k| <= FLOOR_FACTOR eps S_k`` (any ``k``, also 0: a step that needs nothing costs nothing;
  not 0 where the first iterate was extrapolated, :attr:`ScaledConvergence.predicted`),
* ``|F_k| <= STALL_FACTOR eps S_k`` and ``|F_k| > |F_{k-1}| / 2`` (``k >= 1``): stalled at the
  floor, no longer decreasing; a converged step, not a reason to cut it,
* ``|du_k| <= stol |u_k|`` (``k >= 1``; ``snes_stol``, as PETSc's own test: the Newton step no
  longer moves ``u``) with ``|F_k| <= STALL_FACTOR eps S_k`` or ``|F_k| <= SNORM_SLACK max(atol,
  rtol |F_0|)``: a zero update at a residual at the floor or near the tolerances,

and diverged on a NaN residual, beyond ``snes_divergence_tolerance`` times ``|F_0|`` at two
iterations in a row without decreasing (a jump beyond it is the normal path of a step that
closes a gap under a load: its first iterate, on the Jacobian of the open interface, lands deep
in the other body, and comes back within a few iterations), or with a step that no
longer moves ``u`` at a residual above these (``DIVERGED_LOCAL_MIN``: a line search shrinking its
steps on a load the interface cannot carry); SNES applies ``snes_max_it`` itself.
``FLOOR_FACTOR = 1`` lies above the floor Newton reaches; a stall is accepted only within two
decades of it. No absolute number remains: the test is the same in
any units and at any size.

The floor and stall tests apply only while the floor is a negligible part of the forces at
work, ``eps S <= FORCE_FRACTION * Phi`` with ``Phi = || |f_ext| + |R_int| || + || reactions ||``
(``FORCE_FRACTION = 1e-6``, far above ``eps S / Phi`` of converged runs): where Newton runs
away (a load beyond the friction's strength, no equilibrium: the body slides off without bound
within a few iterations), ``|u|`` and with it
``S`` grow without bound while the forces do not, and the floor would otherwise "converge" a
residual of the size of the loads. So a residual above ``1e-4 Phi`` is never accepted by them.
The one exception is a state without forces: no load, no interface traction (every point
separated) and reactions within the round-off of the residual, ``|reactions| <= STALL_FACTOR eps
S`` (bodies pulled apart by prescribed displacements and held, a body floating free): ``Phi`` is
then round-off itself, nothing can run away, and the floor tests apply. Without it, a step where
nothing changes in such a state could never converge (its residual is at the floor from the
first evaluation on, and no relative or absolute test is met).

``S`` and ``Phi`` cost one product with ``|K|`` (a second matrix of ``K``'s size, made once) and
one with ``K`` per Newton iteration, only where the cheaper tests did not already decide.
"""

from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..compat import SNES_DIVERGED_NAN

__all__ = [
    "EPS",
    "FLOOR_FACTOR",
    "FORCE_FRACTION",
    "SNORM_SLACK",
    "STALL_FACTOR",
    "ScaledConvergence",
    "abs_matrix",
]

EPS = float(np.finfo(float).eps)
FLOOR_FACTOR = 1.0
"""Converged when ``|F| <= FLOOR_FACTOR * EPS * S``."""
STALL_FACTOR = 100.0
"""Converged (stalled) when ``|F| <= STALL_FACTOR * EPS * S`` and not halved in the iteration."""
FORCE_FRACTION = 1e-6
"""The floor and stall tests apply only where ``EPS * S <= FORCE_FRACTION * Phi`` (the forces)."""
SNORM_SLACK = 1e4
"""A Newton step that no longer moves ``x`` (``snes_stol``) ends a solve as converged only if the
residual is at the floor (within :data:`STALL_FACTOR`) or within this factor of the function
tolerance ``max(atol, rtol * |F_0|)``: stagnation at round-off. A step that stops moving with a
large residual (a line search shrinking its steps on a load the interface cannot carry) is a
failure, not a solution."""

_REASON = PETSc.SNES.ConvergedReason


def abs_matrix(K: PETSc.Mat) -> PETSc.Mat:
    """A new matrix, ``K`` with every entry replaced by its absolute value (same layout)."""
    A = K.duplicate(copy=True)
    ai, aj, av = A.getValuesCSR()  # owned rows (local numbering), global columns
    rstart = A.getOwnershipRange()[0]
    rows = np.repeat(np.arange(ai.size - 1, dtype=PETSc.IntType) + rstart, np.diff(ai))
    A.zeroEntries()
    A.setValuesRCV(
        rows.reshape(-1, 1),
        aj.astype(PETSc.IntType).reshape(-1, 1),
        np.abs(av).reshape(-1, 1, 1),
        addv=PETSc.InsertMode.INSERT_VALUES,
    )
    A.assemble()
    return A


class ScaledConvergence:
    """SNES convergence test scaled by the size of the terms of the residual (module docstring).

    Install it with ``snes.setConvergenceTest(test)`` after ``setFromOptions``; call
    :meth:`start` before each solve. Tolerances are read from the SNES at each iteration (the
    user's ``snes_rtol``, ``snes_atol``, ``snes_stol``, ``snes_divergence_tolerance`` apply).

    Args:
        problem: The :class:`~subfric_dolfinx.fem.problem.InterfaceProblem` (its ``K``, loads,
            interface forces ``interface_force`` at the last residual, Dirichlet dofs; with a
            nonlinear bulk, ``K_scale`` (its tangent at rest) for ``|K|`` and ``bulk_force``).
        floor_factor: See :data:`FLOOR_FACTOR`.
        stall_factor: See :data:`STALL_FACTOR`.
    """

    reference: float | None = None
    """Where the first iterate was extrapolated (:class:`~.stepping.LoadStepper`'s predictor):
    the residual of the step's start without the extrapolation (0 if it could not be
    evaluated); the relative tests take ``|F_0|`` as at least this (the same target as without
    the predictor). ``None``: the first iterate was not extrapolated. Set by whoever sets the
    first iterate, before the solve; :meth:`start` keeps it."""

    @property
    def predicted(self) -> bool:
        """The first iterate was extrapolated: iteration 0 is not accepted at the floor.

        Where the extrapolation is exact (a linear stretch), the first residual is at the floor
        for an exact (LU) solution of the previous steps and above it for a Krylov solution at
        Newton's tolerance: one Newton iteration in every strategy keeps them in step (the same
        iterations, the same histories).
        """
        return self.reference is not None

    @property
    def reference_norm(self) -> float:
        """:attr:`reference`, 0 where the first iterate was not extrapolated."""
        return self.reference or 0.0

    def __init__(
        self,
        problem,
        floor_factor: float = FLOOR_FACTOR,
        stall_factor: float = STALL_FACTOR,
    ) -> None:
        self.problem = problem
        self.floor_factor = float(floor_factor)
        self.stall_factor = float(stall_factor)
        self.Kabs: PETSc.Mat | None = abs_matrix(getattr(problem, "K_scale", problem.K))
        self._ua = problem.K.createVecRight()
        self._w = problem.K.createVecLeft()
        self._ku = problem.K.createVecLeft()
        n = self._w.getLocalSize()
        self._free = np.ones(n, dtype=bool)
        self._free[problem.bc_dofs] = False
        self.start()

    def start(self) -> None:
        """Forget the previous solve (call before each)."""
        self.norms: list[float] = []
        self.scale = math.nan  # S at the last iterate where it was computed
        self.forces = math.nan  # Phi there
        self.force_free = False  # no load, no interface traction, reactions at round-off there
        self._floor = 0.0  # eps S where the floor test applies, else 0
        self.by: str | None = None  # which test decided

    def floor(self) -> float:
        """The residual the floor test accepts at the last iterate tested (0 if none)."""
        return self.floor_factor * self._floor

    def compute_scale(self, x: PETSc.Vec) -> float:
        """``S`` at ``x``, with the loads of the current time and the last interface forces.

        Also sets :attr:`forces` (``Phi`` of the module docstring) at ``x``.
        """
        p = self.problem
        assert p.K is not None and self.Kabs is not None  # (None once destroyed)
        x.copy(self._ua)
        self._ua.abs()
        self.Kabs.mult(self._ua, self._w)
        p.K.mult(x, self._ku)
        s = self._w.array_r.copy()
        fabs = np.zeros_like(s)
        reaction = self._ku.array_r.copy()
        bulk = getattr(p, "bulk_force", None)  # a nonlinear bulk's F_bulk(u); K: springs only
        if bulk is not None:
            reaction += bulk
        for c, f in p.loads:
            a = p.program.amplitude(c.amplitude, p.t)
            fabs += abs(a) * np.abs(f.array_r)
            reaction -= a * f.array_r
        r_int = p.interface_force[: s.size]
        off = p.interface_round_off  # the interfaces' own beyond |K| |u|
        if off is not None:
            s += off[: s.size]
        fabs += np.abs(r_int)
        reaction = (reaction + r_int)[~self._free]
        s = (s + fabs)[self._free]
        fabs = fabs[self._free]
        sums = p.comm.allreduce(np.array([s @ s, fabs @ fabs, reaction @ reaction]), op=MPI.SUM)
        self.forces = math.sqrt(sums[1]) + math.sqrt(sums[2])
        scale = math.sqrt(sums[0])
        self.force_free = sums[1] == 0.0 and math.sqrt(sums[2]) <= self.stall_factor * EPS * scale
        return scale

    def __call__(self, snes: PETSc.SNES, it: int, norms: tuple[float, float, float]) -> int:
        """The test at Newton iteration ``it`` (``norms``: solution, step and residual norms).

        Returns:
            A ``PETSc.SNES.ConvergedReason``: 0 to go on, > 0 converged, < 0 diverged.
        """
        xnorm, ynorm, fnorm = norms
        rtol, atol, stol, _ = snes.getTolerances()
        if not math.isfinite(fnorm):
            return SNES_DIVERGED_NAN
        if it == 0 or not self.norms:
            self.norms = [fnorm]
        else:
            self.norms.append(fnorm)
        f0 = max(self.norms[0], self.reference_norm)
        if fnorm <= atol:
            return self._done("atol", _REASON.CONVERGED_FNORM_ABS)
        if it > 0:
            if fnorm <= rtol * f0:
                return self._done("rtol", _REASON.CONVERGED_FNORM_RELATIVE)
        self.scale = self.compute_scale(snes.getSolution())
        floor = EPS * self.scale
        # running away: S means nothing (docstring), unless there is no force at all
        if floor > FORCE_FRACTION * self.forces and not self.force_free:
            floor = 0.0
        self._floor = floor
        if fnorm <= self.floor_factor * floor and (it > 0 or not self.predicted):
            return self._done("floor", _REASON.CONVERGED_FNORM_ABS)
        if it > 0:
            previous = self.norms[-2] if len(self.norms) > 1 else math.inf
            if fnorm <= self.stall_factor * floor and fnorm > 0.5 * previous and floor > 0:
                return self._done("stall", _REASON.CONVERGED_FNORM_ABS)
            if ynorm <= stol * xnorm:  # the step no longer moves x
                if fnorm <= self.stall_factor * floor or fnorm <= SNORM_SLACK * max(
                    atol, rtol * f0
                ):
                    return self._done("stol", _REASON.CONVERGED_SNORM_RELATIVE)
                return _REASON.DIVERGED_LOCAL_MIN  # stuck above the tolerances
            divtol = snes.getDivergenceTolerance()
            # growing beyond it: a jump there is the overshoot of a gap closing (docstring)
            beyond = divtol > 0 and min(fnorm, previous) > divtol * f0
            if beyond and fnorm >= previous:
                return _REASON.DIVERGED_DTOL
        return _REASON.ITERATING

    def _done(self, by: str, reason: int) -> int:
        self.by = by
        return reason

    def destroy(self) -> None:
        """Free the PETSc objects (safe to call more than once)."""
        for name in ("Kabs", "_ua", "_w", "_ku"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)
