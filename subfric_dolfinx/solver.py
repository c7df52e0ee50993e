"""PETSc SNES for an :class:`~subfric_dolfinx.problem.InterfaceProblem`, and load stepping.

:class:`FrictionSolver` wraps a petsc4py SNES under a required, unique options prefix, so PETSc
options given on the command line (``-<prefix>snes_monitor``, ``-<prefix>ksp_type gmres``, ...)
or through ``PETSc.Options`` apply; defaults (Newton with a full step, LU with MUMPS) are set only
where the options database has no value. A point the return map cannot integrate makes SNES see a
function-domain error.

:class:`LoadStepper` advances through a loading program: steps end on every breakpoint, a failed
step is undone (displacement and interface state) and retried with a smaller step, easy steps let
the step grow; state is committed only after convergence. After too many cuts it raises
:class:`StepFailure` naming the time and the last converged step, with that state intact.
"""

from __future__ import annotations

import ctypes
import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .problem import TIMER_BULK, TIMER_INTERFACE, TIMER_RETURN_MAP, TIMER_SETUP, InterfaceProblem

__all__ = [
    "FrictionSolver",
    "LoadStepper",
    "StepFailure",
    "StepRecord",
    "format_breakdown",
    "timing_breakdown",
]

_PREFIXES: set[str] = set()
_DEFAULT_OPTIONS = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-9,
    "snes_atol": 1e-10,
    "snes_stol": 1e-12,
    "snes_max_it": 30,
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
}


def _petsc_library() -> ctypes.CDLL:
    with open("/proc/self/maps") as f:
        for line in f:
            path = line.split()[-1] if len(line.split()) >= 6 else ""
            if "libpetsc" in path and ".so" in path:
                return ctypes.CDLL(path)
    raise RuntimeError("libpetsc is not loaded in this process")


_LIB: ctypes.CDLL | None = None


def _set_domain_error(snes: PETSc.SNES) -> None:
    """``SNESSetFunctionDomainError`` (not wrapped by petsc4py 3.22), through ctypes."""
    global _LIB
    if _LIB is None:
        _LIB = _petsc_library()
    err = _LIB.SNESSetFunctionDomainError(ctypes.c_void_p(snes.handle))
    if err:
        raise RuntimeError(f"SNESSetFunctionDomainError failed with PETSc error {err}")


class FrictionSolver:
    """SNES on an interface problem.

    Args:
        problem: The problem.
        prefix: PETSc options prefix, required and unique among live solvers (e.g. ``"block_"``).
        options: Options to set under the prefix (they override command-line ones).

    Raises:
        ValueError: Empty, malformed or already used prefix.
    """

    def __init__(
        self, problem: InterfaceProblem, prefix: str, options: dict[str, Any] | None = None
    ) -> None:
        if not isinstance(prefix, str) or not prefix or not prefix.endswith("_"):
            raise ValueError(
                f"the options prefix must be a non-empty string ending in '_', got {prefix!r}"
            )
        if any(ch.isspace() or ch == "-" for ch in prefix):
            raise ValueError(f"the options prefix {prefix!r} must not contain spaces or '-'")
        if prefix in _PREFIXES:
            raise ValueError(
                f"the options prefix {prefix!r} is already used by another live solver; "
                "give each solver its own prefix"
            )
        self.problem = problem
        self.prefix = prefix
        comm = problem.comm
        opts = PETSc.Options()
        for k, v in _DEFAULT_OPTIONS.items():
            if not opts.hasName(prefix + k):
                opts[prefix + k] = v
        for k, v in (options or {}).items():
            opts[prefix + k] = v
        self.x = problem.create_vector()
        self.F = problem.create_vector()
        self.J = problem.create_matrix()
        snes = PETSc.SNES().create(comm)
        snes.setOptionsPrefix(prefix)
        snes.setFunction(self._residual, self.F)
        snes.setJacobian(self._jacobian, self.J)
        snes.setConvergenceHistory(length=200, reset=True)
        snes.setFromOptions()
        snes.getKSP().setFromOptions()
        self.snes = snes
        _PREFIXES.add(prefix)
        self.failed_points: np.ndarray = np.zeros(0, dtype=np.int64)
        # PETSc's log events are cumulative over the process: record where this solver starts.
        self.petsc_event_start = {e: _event_time(e) for e in _LINEAR_EVENTS.values()}

    # module-style callbacks
    def _residual(self, snes: PETSc.SNES, x: PETSc.Vec, F: PETSc.Vec) -> None:
        ok = self.problem.residual(x, F)
        if not ok:
            self.failed_points = self.problem.interface.last.failed_indices
            F.set(0.0)
            _set_domain_error(snes)

    def _jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        self.problem.jacobian(x, J)

    def solve(self, t: float, dt: float) -> dict[str, Any]:
        """Solve for the state at ``t`` after a step ``dt`` from the current (converged) one.

        The current ``x`` is the initial guess, with the Dirichlet values of ``t`` set in it.

        Returns:
            ``converged``, ``iterations``, ``reason`` (SNES reason code), ``residuals`` (norms per
            iteration) and ``counts`` (return-map statuses at the last evaluation, global).
        """
        p = self.problem
        p.set_step(t, dt)
        p.apply_dirichlet(self.x)
        self.failed_points = np.zeros(0, dtype=np.int64)
        self.snes.setConvergenceHistory(length=200, reset=True)
        try:
            self.snes.solve(None, self.x)
        except PETSc.Error as e:  # an error inside a callback or the linear solver
            return {
                "converged": False,
                "iterations": self.snes.getIterationNumber(),
                "reason": -100,
                "residuals": [],
                "counts": {},
                "error": str(e),
            }
        reason = self.snes.getConvergedReason()
        hist, _ = self.snes.getConvergenceHistory()
        last = p.interface.last
        counts = {k: p.comm.allreduce(v) for k, v in last.counts().items()} if last else {}
        return {
            "converged": reason > 0,
            "iterations": self.snes.getIterationNumber(),
            "reason": int(reason),
            "residuals": [float(r) for r in hist],
            "counts": counts,
        }

    def destroy(self) -> None:
        """Free the PETSc objects and release the prefix."""
        self.snes.destroy()
        self.J.destroy()
        self.x.destroy()
        self.F.destroy()
        _PREFIXES.discard(self.prefix)


class StepFailure(RuntimeError):
    """A step could not be solved even after the allowed cuts.

    Attributes:
        t: Time the failed step aimed at.
        last_t: Time of the last converged step (its state is intact).
        last_step: Index of the last converged step.
        reason: What failed (SNES reason, failed return-map points).
    """

    def __init__(self, message: str, t: float, last_t: float, last_step: int, reason: str) -> None:
        super().__init__(message)
        self.t, self.last_t, self.last_step, self.reason = t, last_t, last_step, reason


@dataclasses.dataclass
class StepRecord:
    """One converged step."""

    step: int
    t: float
    dt: float
    iterations: int
    cuts: int
    residuals: list[float]
    counts: dict[str, int]


class LoadStepper:
    """Adaptive load stepping through a loading program.

    Args:
        solver: The solver (its problem holds the program).
        dt: Initial step.
        dt_min: Smallest step before giving up.
        dt_max: Largest step.
        cut: Factor applied to the step after a failure.
        grow: Factor applied after ``easy_steps`` consecutive steps with at most
            ``easy_iterations`` Newton iterations.
        max_cuts: Consecutive cuts allowed before :class:`StepFailure`.
        on_step: Called with the :class:`StepRecord` after each converged step (after commit).
        log: Progress printer (rank 0 only); ``None`` for silence.
    """

    def __init__(
        self,
        solver: FrictionSolver,
        dt: float,
        *,
        dt_min: float | None = None,
        dt_max: float | None = None,
        cut: float = 0.5,
        grow: float = 1.5,
        easy_iterations: int = 4,
        easy_steps: int = 2,
        max_cuts: int = 10,
        on_step: Callable[[StepRecord], None] | None = None,
        log: Callable[[str], None] | None = print,
    ) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt = {dt!r} must be finite and > 0")
        self.solver = solver
        self.problem = solver.problem
        self.program = self.problem.program
        self.dt = float(dt)
        self.dt_max = float(dt_max) if dt_max is not None else self.dt
        self.dt_min = float(dt_min) if dt_min is not None else self.dt * cut**max_cuts
        self.cut, self.grow = cut, grow
        self.easy_iterations, self.easy_steps = easy_iterations, easy_steps
        self.max_cuts = max_cuts
        self.on_step = on_step
        self.log = log if self.problem.comm.rank == 0 else None
        self.t = self.program.t_start
        self.step = 0
        self.records: list[StepRecord] = []
        self.easy = 0  # consecutive easy steps (drives the growth of dt)
        self._x_converged = solver.x.copy()

    def restore(self, t: float, step: int, dt: float, easy: int = 0) -> None:
        """Continue from a restored state: ``problem.u`` and the interface state must hold it."""
        self.t, self.step, self.dt, self.easy = float(t), int(step), float(dt), int(easy)
        n = self.problem.layout.n_owned
        self.solver.x.array_w[:] = self.problem.u.x.array[:n]
        self._x_converged.array_w[:] = self.solver.x.array_r

    def _say(self, msg: str) -> None:
        if self.log is not None:
            self.log(msg)

    def run(self, t_end: float | None = None, stops: Sequence[float] = ()) -> list[StepRecord]:
        """Advance to ``t_end`` (default: the end of the program).

        Steps end on every breakpoint of the program and on every time in ``stops`` (e.g. the
        times of requested snapshots).

        Raises:
            StepFailure: After ``max_cuts`` consecutive cuts, or below ``dt_min``; the last
                converged state is in place (displacement and interface state).
        """
        t_end = self.program.t_end if t_end is None else float(t_end)
        stops_arr = np.sort(np.asarray(stops, dtype=float))

        def next_stop(t: float) -> float:
            nb = self.program.next_breakpoint(t)
            later = stops_arr[stops_arr > t + 1e-12 * max(1.0, abs(t))]
            return min(nb, float(later[0])) if later.size else nb

        cuts = 0
        tol = 1e-12 * max(1.0, abs(t_end))
        while self.t < t_end - tol:
            nb = min(next_stop(self.t), t_end)
            target = min(self.t + self.dt, nb)
            # do not leave a sliver before a breakpoint
            if nb - target < 0.25 * self.dt:
                target = nb
            dt = target - self.t
            t0 = time.perf_counter()
            r = self.solver.solve(target, dt)
            if not r["converged"]:
                self.solver.x.array_w[:] = self._x_converged.array_r
                self.problem.revert()
                cuts += 1
                why = f"SNES reason {r['reason']}"
                if self.solver.failed_points.size:
                    why += f", return map failed at {self.solver.failed_points.size} points"
                self._say(f"  step to t = {target:.6g} (dt {dt:.3g}) failed: {why}; cutting")
                self.dt = dt * self.cut
                self.easy = 0
                if cuts > self.max_cuts or self.dt < self.dt_min:
                    raise StepFailure(
                        f"no convergence at t = {target:.6g} with dt = {dt:.3g} ({why}; "
                        f"{cuts} failed attempt(s) since the last converged step, smallest step "
                        f"allowed {self.dt_min:.3g}); the last converged step is "
                        f"{self.step} at t = {self.t:.6g}, whose state is kept",
                        target,
                        self.t,
                        self.step,
                        why,
                    )
                continue
            self.problem.commit()
            self._x_converged.array_w[:] = self.solver.x.array_r
            self.problem.u.x.array[: self.problem.layout.n_owned] = self.solver.x.array_r
            self.problem.u.x.scatter_forward()
            self.step += 1
            self.t = target
            rec = StepRecord(
                self.step, target, dt, r["iterations"], cuts, r["residuals"], r["counts"]
            )
            self.records.append(rec)
            c = r["counts"]
            res = r["residuals"] or [0.0]
            n_pl = c.get("PLASTIC", 0) + c.get("JUMP", 0)
            n_all = sum(c.get(k, 0) for k in ("ELASTIC", "PLASTIC", "SEPARATED", "JUMP"))
            self._say(
                f"step {self.step:4d}  t = {target:10.5g}  dt = {dt:9.3g}  "
                f"newton {r['iterations']:2d}  |F| {res[0]:9.2e} -> {res[-1]:9.2e}  "
                f"plastic {n_pl}/{n_all}  sep {c.get('SEPARATED', 0)}  "
                f"({time.perf_counter() - t0:.2f} s)"
            )
            cuts = 0
            self.easy = self.easy + 1 if r["iterations"] <= self.easy_iterations else 0
            if self.easy >= self.easy_steps:
                self.dt = min(self.dt * self.grow, self.dt_max)
                self.easy = 0
            if self.on_step is not None:  # last: the stepper's state is that of the next step
                self.on_step(rec)
        return self.records


# Linear-solver sections of the breakdown and the PETSc log events they come from. With SNES in
# PETSc 3.22 the factorisation (PCSetUp, reached through KSPSetUp) is logged outside KSPSolve, so
# the two do not overlap; with a direct solver the factorisation is usually the larger.
_LINEAR_EVENTS = {"factorisation": "PCSetUp", "linear solve": "KSPSolve"}


def _event_time(name: str) -> float:
    """Cumulative seconds of a PETSc log event in this process (``nan`` without logging)."""
    try:
        return float(PETSc.Log.Event(name).getPerfInfo()["time"])
    except Exception:  # logging not started
        return float("nan")


def timing_breakdown(
    problem: InterfaceProblem, solver: FrictionSolver | None = None
) -> dict[str, float]:
    """Wall seconds per section of a run, maximum over ranks.

    Set-up, bulk assembly, return map and interface assembly come from the problem's timers; the
    factorisation and the linear solve are PETSc's ``PCSetUp`` and ``KSPSolve`` events (``nan``
    unless logging was started with ``PETSc.Log.begin()`` before the solver was created). PETSc's
    events are cumulative over the process: with ``solver`` given, only the time since that solver
    was created is counted, so several runs in one process each get their own numbers.
    """
    out = {
        k: problem.timings.seconds.get(k, 0.0)
        for k in (TIMER_SETUP, TIMER_BULK, TIMER_RETURN_MAP, TIMER_INTERFACE)
    }
    for section, event in _LINEAR_EVENTS.items():
        t = _event_time(event)
        if solver is not None:
            t -= solver.petsc_event_start.get(event, 0.0)
        out[section] = t
    return {k: problem.comm.allreduce(v, op=MPI.MAX) for k, v in out.items()}


def format_breakdown(breakdown: dict[str, float], total: float | None = None) -> str:
    """A one-table text of :func:`timing_breakdown` (plus the total wall time if given)."""
    lines = ["timing breakdown (s, max over ranks):"]
    for k, v in breakdown.items():
        lines.append(f"  {k:20s} {v:9.3f}")
    if total is not None:
        lines.append(f"  {'total run':20s} {total:9.3f}")
    return "\n".join(lines)
