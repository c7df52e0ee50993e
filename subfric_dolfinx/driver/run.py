"""Running a material-point case step by step, under displacement or stress control."""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from typing import Any

import numpy as np

from ..constitutive import SCALAR, FrictionLaw, InterfaceState, ReturnMapResult, Status
from .case import MAX_STEPS_PER_SEGMENT, Case, CaseError, parse_case

__all__ = ["DriverResult", "RunawayError", "fields", "run_case"]


def fields(law: FrictionLaw) -> tuple[str, ...]:
    """The sampled fields of a case with ``law``.

    ``t, f_t1, f_t2, f_n``, then the law's internal variables (a scalar ``v`` as ``v``, a
    tangential one as ``v_t1, v_t2``, a local one as ``v_t1, v_t2, v_n``), then ``ubar_t1,
    ubar_t2, ubar_n``.
    """
    own = []
    for v in law.variables:
        own += v.column_names(2)
    return ("t", "f_t1", "f_t2", "f_n", *own, "ubar_t1", "ubar_t2", "ubar_n")


class RunawayError(RuntimeError):
    """Under stress control the prescribed tangential stress cannot be sustained.

    Attributes:
        t: Time at which it happened (resolved by step cutting).
        partial: The result up to the last converged step.
    """

    def __init__(self, message: str, t: float, partial: DriverResult | None = None) -> None:
        super().__init__(message)
        self.t = t
        self.partial = partial


@dataclasses.dataclass
class DriverResult:
    """Result of a material-point run.

    Attributes:
        samples: Field name -> array over the sample times reached.
        sample_status: Status name of the step ending at each sample.
        status_counts: Number of steps per status (plus ``UNSTABLE``).
        stability_lost: ``None`` or ``{"t", "reason", ...state}`` at the first loss of stability.
        n_steps: Number of steps taken.
        wall_time: Seconds spent.
        complete: Whether every sample time was reached.
    """

    samples: dict[str, np.ndarray]
    sample_status: list[str]
    status_counts: dict[str, int]
    stability_lost: dict[str, Any] | None
    n_steps: int
    wall_time: float
    complete: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "samples": {k: v.tolist() for k, v in self.samples.items()},
            "sample_status": self.sample_status,
            "status_counts": self.status_counts,
            "stability_lost": self.stability_lost,
            "stable": self.stability_lost is None,
            "complete": self.complete,
            "n_steps": self.n_steps,
            "wall_time": self.wall_time,
        }


class _Runner:
    """Step-by-step integration along a case's path, with sampling and stability bookkeeping."""

    def __init__(self, case: Case, steps_per_mm: float, on_instability: str) -> None:
        self.case = case
        self.law = case.law
        self.nt = case.n_tangential
        self.spm = steps_per_mm
        self.stop_on_instability = on_instability == "stop"
        self.state: InterfaceState = self.law.initial_state(1, self.nt)
        self.ubar_t = np.zeros(self.nt)
        self.traction = np.zeros(self.nt + 1)
        self.status = Status.ELASTIC
        self.counts = {s.name: 0 for s in Status} | {"UNSTABLE": 0}
        self.n_steps = 0
        self.lost: dict[str, Any] | None = None
        self.rows: list[list[float]] = []
        self.row_status: list[str] = []
        self.fields = fields(self.law)

    def path_at(self, t: float) -> np.ndarray:
        path = self.case.path
        return np.array([np.interp(t, path[:, 0], path[:, j]) for j in (1, 2, 3)])

    def _x(self, p: np.ndarray) -> np.ndarray:
        return p[: self.nt]

    def _accept(self, res: ReturnMapResult, ubar_t: np.ndarray, t: float) -> None:
        self.state = res.state
        self.ubar_t = ubar_t
        self.traction = res.traction[0].copy()
        self.status = Status(int(res.status[0]))
        self.counts[self.status.name] += 1
        self.n_steps += 1
        unstable = bool(res.unstable[0])
        self.counts["UNSTABLE"] += int(unstable)
        if self.lost is None and (unstable or self.status == Status.JUMP):
            self.lost = {
                "t": t,
                "reason": "jump at a fold" if self.status == Status.JUMP else "den <= 0",
                **dict(zip(self.fields[1:], self._row(t)[1:], strict=True)),
            }

    def _row(self, t: float) -> list[float]:
        f, s, ut = self.traction, self.state, self.ubar_t
        two = (lambda a: [a[0], a[1]]) if self.nt == 2 else (lambda a: [a[0], 0.0])
        un = self.path_at(t)[2]
        own: list[float] = []
        for v in self.law.variables:
            a = s[v.name][0]
            own += [a] if v.shape == SCALAR else [*two(a[: self.nt]), *a[self.nt :]]
        return [t, *two(f), f[self.nt], *own, *two(ut), un]

    def sample(self, t: float) -> None:
        self.rows.append([float(v) for v in self._row(t)])
        self.row_status.append(self.status.name)

    # displacement control: one return map per step
    def step_disp(self, t: float, dt: float) -> None:
        p = self.path_at(t)
        gap = np.concatenate([self._x(p), [p[2]]])[None, :]
        res = self.law.return_map(gap, self.state, dt)
        if not res.converged:
            raise RuntimeError(f"return map failed at t = {t!r} (gap {gap[0].tolist()})")
        self._accept(res, self._x(p).copy(), t)

    # stress control: Newton on ubar_t so that f_t equals the prescribed value
    def _solve_stress(self, t: float, dt: float) -> tuple[ReturnMapResult, np.ndarray] | None:
        p = self.path_at(t)
        target, un = self._x(p), p[2]
        nt = self.nt
        alpha = self.law.alpha_t
        scale = max(float(np.linalg.norm(target)), 1e-3 * alpha * max(un, 0.0), 1e-12)
        # above the largest stress the surface can carry in this step: no solution at all
        fn = self.law.alpha_n * max(un, 0.0)
        strength = float(self.law.strength(self.state, [fn], dt)[0])
        if float(np.linalg.norm(target)) > strength * (1.0 + 1e-12):
            return None
        tol = 1e-11 * scale
        ut = self.ubar_t + (target - self.traction[:nt]) / alpha

        def evaluate(u: np.ndarray) -> tuple[ReturnMapResult, np.ndarray]:
            res = self.law.return_map(np.concatenate([u, [un]])[None, :], self.state, dt)
            return res, res.traction[0, :nt] - target

        res, R = evaluate(ut)
        for _ in range(40):
            if not res.converged:
                return None
            D = res.tangent[0, :nt, :nt]
            if np.linalg.norm(R) <= tol:
                # accept only on the ascending (stable) branch: symmetric part positive definite
                if np.all(np.linalg.eigvalsh(0.5 * (D + D.T)) > 0.0):
                    return res, ut
                return None
            try:
                d = np.linalg.solve(D, -R)
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(d)):
                return None
            s, r0 = 1.0, float(np.linalg.norm(R))
            while s > 1e-3:
                res_n, R_n = evaluate(ut + s * d)
                if np.linalg.norm(R_n) < (1.0 - 1e-4 * s) * r0:
                    break
                s *= 0.5
            else:
                return None
            ut, res, R = ut + s * d, res_n, R_n
        return None

    def step_stress(self, t_a: float, t_b: float, depth: int = 0) -> None:
        solved = self._solve_stress(t_b, t_b - t_a)
        if solved is not None:
            self._accept(solved[0], solved[1], t_b)
            return
        span = self.case.path[-1, 0] - self.case.path[0, 0]
        if t_b - t_a <= 1e-7 * span or depth >= 60:  # resolved to 1e-7 of the path's duration
            f = self.path_at(t_b)
            strength = float(self.law.strength(self.state, [self.law.alpha_n * max(f[2], 0.0)])[0])
            raise RunawayError(
                f"runaway at t = {t_b:.6g} s: the prescribed tangential stress "
                f"|f_t| = {np.linalg.norm(self._x(f)):.6g} MPa cannot be sustained at "
                f"f_n = {self.law.alpha_n * max(f[2], 0.0):.6g} MPa: the stress-slip response "
                f"has passed its peak (or the contact opened), so the slip would grow without "
                f"bound (for reference, g(f_n) mu = {strength:.6g} MPa now)",
                t_b,
            )
        t_m = 0.5 * (t_a + t_b)
        self.step_stress(t_a, t_m, depth + 1)
        self.step_stress(t_m, t_b, depth + 1)

    def n_sub(self, ta: float, tb: float) -> int:
        pa, pb = self.path_at(ta), self.path_at(tb)
        d = self._x(pb) - self._x(pa)
        with np.errstate(over="ignore"):
            dx = float(np.hypot(d[0], d[1]) if d.size == 2 else abs(d[0]))
            if self.case.control == "stress":
                dx /= self.law.alpha_t
            length = max(dx, abs(pb[2] - pa[2]))
            n = self.spm * length - 1e-9
        if not n <= MAX_STEPS_PER_SEGMENT:
            stress = self.case.control == "stress"
            what = "tangential stress change / alpha_t" if stress else "change"
            raise CaseError(
                f"field 'path': the {what} between t = {ta:g} and t = {tb:g} is {length:g} mm, "
                f"which needs {n:.3g} steps at steps_per_mm = {self.spm:g} (limit "
                f"{MAX_STEPS_PER_SEGMENT:g}); scale the path or lower steps_per_mm"
            )
        return max(1, math.ceil(n))

    def run(self) -> bool:
        case = self.case
        knots = np.union1d(case.path[:, 0], case.t_samples)
        segments = list(itertools.pairwise(knots))
        # every segment's step count first: a bad path fails here, before any step
        counts = [self.n_sub(float(ta), float(tb)) for ta, tb in segments]
        samples = list(case.t_samples)
        t0 = knots[0]
        # the state at the first path point (loaded from the virgin state in one step, dt = 0)
        if case.control == "disp":
            self.step_disp(t0, 0.0)
        else:
            self.step_stress(t0, t0)
        while samples and samples[0] <= t0:
            self.sample(samples.pop(0))
        for (ta, tb), n in zip(segments, counts, strict=True):
            ts = ta + (tb - ta) * np.arange(1, n + 1) / n
            ts[-1] = tb
            prev = ta
            for t in ts:
                if case.control == "disp":
                    self.step_disp(float(t), float(t - prev))
                else:
                    self.step_stress(float(prev), float(t))
                prev = t
                if self.lost is not None and self.stop_on_instability:
                    return False
            while samples and samples[0] <= tb:
                self.sample(samples.pop(0))
        return True

    def result(self, complete: bool, wall: float) -> DriverResult:
        arr = np.array(self.rows).reshape(-1, len(self.fields))
        return DriverResult(
            {k: arr[:, i] for i, k in enumerate(self.fields)},
            self.row_status,
            dict(self.counts),
            self.lost,
            self.n_steps,
            wall,
            complete,
        )


def run_case(
    case: Case | dict[str, Any],
    *,
    steps_per_mm: float | None = None,
    on_instability: str = "stop",
) -> DriverResult:
    """Run a material-point case.

    Args:
        case: A :class:`Case` or its JSON-like dictionary.
        steps_per_mm: Overrides the case's step density.
        on_instability: ``"stop"`` (default): stop at the first loss of stability, since no
            stable quasi-static solution exists beyond; ``"continue"``: go on, flagged.

    Returns:
        The sampled history and the diagnostics.

    Raises:
        CaseError: Invalid case.
        RunawayError: Under stress control, the prescribed stress cannot be sustained.
    """
    if not isinstance(case, Case):
        case = parse_case(case)
    if on_instability not in ("stop", "continue"):
        raise ValueError(f"on_instability must be 'stop' or 'continue', got {on_instability!r}")
    spm = case.steps_per_mm if steps_per_mm is None else float(steps_per_mm)
    if not spm > 0 or not math.isfinite(spm):
        raise CaseError(f"steps_per_mm must be finite and > 0, got {steps_per_mm!r}")
    runner = _Runner(case, spm, on_instability)
    t0 = time.perf_counter()
    try:
        complete = runner.run()
    except RunawayError as e:
        e.partial = runner.result(False, time.perf_counter() - t0)
        raise
    return runner.result(complete, time.perf_counter() - t0)
