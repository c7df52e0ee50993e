"""Running a material-point case step by step, under displacement or stress control."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..constitutive import (
    LOCAL,
    SCALAR,
    UNSTABLE,
    FrictionLaw,
    InterfaceState,
    ReturnMapResult,
    Status,
)
from .case import MAX_TOTAL_STEPS, Case, CaseError, parse_case
from .path import plan_steps
from .slider import SliderCase, SliderResult, run_slider

__all__ = ["DriverResult", "RunawayError", "fields", "run_case"]


_BASE = ("t", "f_t1", "f_t2", "f_n")
_JUMP, _FAILED = int(Status.JUMP), int(Status.FAILED)
_PROGRESS_EVERY = 2000  # steps between two calls of the progress callback


def fields(law: FrictionLaw) -> tuple[str, ...]:
    """The sampled fields of a case with ``law``.

    ``t, f_t1, f_t2, f_n``, then the law's internal variables (a scalar ``v`` as ``v``, a
    tangential one as ``v_t1, v_t2``, a local one as ``v_t1, v_t2, v_n``), then ``ubar_t1,
    ubar_t2, ubar_n``. A column named like one before it is left out: the subloading law's
    start traction ``f`` is the traction itself (``f_t1, f_t2, f_n``).
    """
    own: list[str] = []
    for v in law.variables:
        own += [c for c in v.column_names(2) if c not in _BASE and c not in own]
    return (*_BASE, *own, "ubar_t1", "ubar_t2", "ubar_n")


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
    """Step-by-step integration along a case's path, with sampling and stability bookkeeping.

    The step loop works on plain floats: a step's gap is interpolated within its knot interval
    (:mod:`.path`), the status is tested as an int, the counts live in a list; the return map
    is the only numpy work of a step.
    """

    def __init__(
        self,
        case: Case,
        steps_per_mm: float,
        on_instability: str,
        max_steps: float = MAX_TOTAL_STEPS,
        progress: Callable[[int, int, float], None] | None = None,
    ) -> None:
        self.case = case
        self.law = case.law
        self.nt = case.n_tangential
        self.spm = steps_per_mm
        self.plan = plan_steps(case, steps_per_mm, max_steps)  # all checks before any step
        self.stop_on_instability = on_instability == "stop"
        self.progress = progress
        self.state: InterfaceState = self.law.initial_state(1, self.nt)
        self.ubar_t = np.zeros(self.nt)
        self.traction = np.zeros(self.nt + 1)
        self.status = int(Status.ELASTIC)
        self.counts = [0] * (len(Status) + 1)  # per status code, then UNSTABLE
        self.n_steps = 0
        self.lost: dict[str, Any] | None = None
        self.rows: list[list[float]] = []
        self.row_status: list[str] = []
        self.fields = fields(self.law)
        self._own = own_columns(self.law, self.nt)
        self._seg = (0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self.gap_now = (0.0, 0.0, 0.0)

    # the prescribed values (x1, x2, ubar_n) at t, within the current knot interval
    def path_at(self, t: float) -> tuple[float, float, float]:
        ta, tb, va, vb = self._seg
        if t >= tb:
            return vb
        a = (t - ta) / (tb - ta) if tb > ta else 1.0
        return (
            va[0] + (vb[0] - va[0]) * a,
            va[1] + (vb[1] - va[1]) * a,
            va[2] + (vb[2] - va[2]) * a,
        )

    def _accept(self, res: ReturnMapResult, ubar_t: np.ndarray, t: float) -> None:
        self.state = res.state
        self.ubar_t = ubar_t
        self.traction = res.traction[0]
        st = int(res.status[0])
        self.status = st
        self.counts[st] += 1
        self.n_steps += 1
        if res.unstable[0]:
            self.counts[-1] += 1
            if self.lost is None:
                self._lose(t, "den <= 0")
        elif st == _JUMP and self.lost is None:
            self._lose(t, "jump at a fold")

    def _lose(self, t: float, reason: str) -> None:
        row = dict(zip(self.fields[1:], self._row(t)[1:], strict=True))
        self.lost = {"t": t, "reason": reason, **row}

    def _row(self, t: float) -> list[float]:
        f, s, ut = self.traction, self.state, self.ubar_t
        t2 = [float(ut[0]), float(ut[1]) if self.nt == 2 else 0.0]
        f2 = [float(f[0]), float(f[1]) if self.nt == 2 else 0.0]
        own = [
            0.0 if k == -1 else float(s[name][0] if k is None else s[name][0, k])
            for name, k in self._own
        ]
        return [t, *f2, float(f[self.nt]), *own, *t2, float(self.gap_now[2])]

    def sample(self, t: float) -> None:
        self.rows.append(self._row(t))
        self.row_status.append(Status(self.status).name)

    # displacement control: one return map per step
    def step_disp(self, t: float, dt: float, v: tuple[float, float, float]) -> None:
        self.gap_now = v
        if self.nt == 2:
            gap = np.array([v])
        else:
            gap = np.array([[v[0], v[2]]])
        res = self.law.return_map(gap, self.state, dt)
        if res.status[0] == _FAILED:
            raise RuntimeError(f"return map failed at t = {t!r} (gap {gap[0].tolist()})")
        self._accept(res, gap[0, : self.nt], t)

    # stress control: Newton on ubar_t so that f_t equals the prescribed value
    def _solve_stress(self, t: float, dt: float) -> tuple[ReturnMapResult, np.ndarray] | None:
        p = self.path_at(t)
        nt = self.nt
        target, un = np.array(p[:nt]), p[2]
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
            self.gap_now = (
                *solved[1].tolist(),
                *([0.0] if self.nt == 1 else []),
                self.path_at(t_b)[2],
            )
            self._accept(solved[0], solved[1], t_b)
            return
        span = self.case.path[-1, 0] - self.case.path[0, 0]
        if t_b - t_a <= 1e-7 * span or depth >= 60:  # resolved to 1e-7 of the path's duration
            f = self.path_at(t_b)
            fn = self.law.alpha_n * max(f[2], 0.0)
            strength = float(self.law.strength(self.state, [fn])[0])
            raise RunawayError(
                f"runaway at t = {t_b:.6g} s: the prescribed tangential stress "
                f"|f_t| = {math.hypot(*f[: self.nt]):.6g} MPa cannot be sustained at "
                f"f_n = {fn:.6g} MPa: the stress-slip response "
                f"has passed its peak (or the contact opened), so the slip would grow without "
                f"bound (for reference, g(f_n) mu = {strength:.6g} MPa now)",
                t_b,
            )
        t_m = 0.5 * (t_a + t_b)
        self.step_stress(t_a, t_m, depth + 1)
        self.step_stress(t_m, t_b, depth + 1)

    def run(self) -> bool:
        case, plan = self.case, self.plan
        knots, values = plan.knots, plan.values
        counts = cast(list[int], plan.counts.tolist())
        vals = [(float(v[0]), float(v[1]), float(v[2])) for v in values]  # (K, 3)
        kt = cast(list[float], knots.tolist())
        samples = list(case.t_samples)
        disp = case.control == "disp"
        t0 = kt[0]
        self._seg = (t0, t0, vals[0], vals[0])
        # the state at the first path point (loaded from the virgin state in one step, dt = 0)
        if disp:
            self.step_disp(t0, 0.0, vals[0])
        else:
            self.step_stress(t0, t0)
        while samples and samples[0] <= t0:
            self.sample(samples.pop(0))
        total = plan.total + 1
        check = _PROGRESS_EVERY
        for i, n in enumerate(counts):
            ta, tb, va, vb = kt[i], kt[i + 1], vals[i], vals[i + 1]
            self._seg = (ta, tb, va, vb)
            prev = ta
            d = (vb[0] - va[0], vb[1] - va[1], vb[2] - va[2])
            for k in range(1, n + 1):
                if k == n:
                    t, v = tb, vb
                else:
                    a = k / n
                    t = ta + (tb - ta) * a
                    v = (va[0] + d[0] * a, va[1] + d[1] * a, va[2] + d[2] * a)
                if disp:
                    self.step_disp(t, t - prev, v)
                else:
                    self.step_stress(prev, t)
                prev = t
                if self.lost is not None and self.stop_on_instability:
                    return False
                if self.n_steps >= check and self.progress is not None:
                    self.progress(self.n_steps, total, t)
                    check += _PROGRESS_EVERY
            while samples and samples[0] <= tb:
                self.sample(samples.pop(0))
        return True

    def result(self, complete: bool, wall: float) -> DriverResult:
        arr = np.array(self.rows).reshape(-1, len(self.fields))
        counts = {s.name: self.counts[s] for s in Status} | {UNSTABLE: self.counts[-1]}
        return DriverResult(
            {k: arr[:, i] for i, k in enumerate(self.fields)},
            self.row_status,
            counts,
            self.lost,
            self.n_steps,
            wall,
            complete,
        )


def own_columns(law: FrictionLaw, nt: int) -> list[tuple[str, int | None]]:
    """``(variable, component)`` per sampled column of the law's variables.

    In the order of :func:`fields`; component None: a scalar; -1: a second tangential
    component, 0 in 2-D.
    """
    out: list[tuple[str, int | None]] = []
    seen = set(_BASE)
    t2 = 1 if nt == 2 else -1
    for v in law.variables:
        names = v.column_names(2)
        comps: list[int | None]
        if v.shape == SCALAR:
            comps = [None]
        elif v.shape == LOCAL:
            comps = [0, t2, nt]
        else:
            comps = [0, t2]
        for name, c in zip(names, comps, strict=True):
            if name in seen:
                continue
            seen.add(name)
            out.append((v.name, c))
    return out


def run_case(
    case: Case | SliderCase | dict[str, Any],
    *,
    steps_per_mm: float | None = None,
    on_instability: str = "stop",
    max_steps: float = MAX_TOTAL_STEPS,
    progress: Callable[[int, int, float], None] | None = None,
) -> DriverResult | SliderResult:
    """Run a material-point case.

    Args:
        case: A :class:`Case`, a :class:`~.slider.SliderCase` (``"control": "slider"``: then
            :func:`~.slider.run_slider` runs it, ``steps_per_mm`` and ``on_instability`` do
            not apply) or its JSON-like dictionary.
        steps_per_mm: Overrides the case's step density.
        on_instability: ``"stop"`` (default): stop at the first loss of stability, since no
            stable quasi-static solution exists beyond; ``"continue"``: go on, flagged.
        max_steps: Limit of the total number of steps (checked before the first step).
        progress: Called every 2000 steps as ``progress(steps_done, steps_total, t)``.

    Returns:
        The sampled history and the diagnostics (a :class:`~.slider.SliderResult` for a slider).

    Raises:
        CaseError: Invalid case, or more steps than the limits (per knot interval and total).
        RunawayError: Under stress control, the prescribed stress cannot be sustained.
    """
    if not isinstance(case, Case | SliderCase):
        case = parse_case(case)
    if isinstance(case, SliderCase):  # the dynamic control
        if steps_per_mm is not None:
            raise CaseError("steps_per_mm does not apply to a slider case (its steps adapt)")
        return run_slider(case, max_steps=max_steps, progress=progress)
    if on_instability not in ("stop", "continue"):
        raise ValueError(f"on_instability must be 'stop' or 'continue', got {on_instability!r}")
    spm = case.steps_per_mm if steps_per_mm is None else float(steps_per_mm)
    if not spm > 0 or not math.isfinite(spm):
        raise CaseError(f"steps_per_mm must be finite and > 0, got {steps_per_mm!r}")
    runner = _Runner(case, spm, on_instability, max_steps, progress)
    t0 = time.perf_counter()
    try:
        complete = runner.run()
    except RunawayError as e:
        e.partial = runner.result(False, time.perf_counter() - t0)
        raise
    return runner.result(complete, time.perf_counter() - t0)
