"""Material-point driver: one interface point along a prescribed path (numpy only).

Library use::

    from subfric_dolfinx.driver import load_case, run_case
    result = run_case(load_case("case.json"), steps_per_mm=500)

Command line::

    python3 -m subfric_dolfinx.driver CASE.json [--steps-per-mm N] [--out OUT.json]

CASE.json::

    {
      "law": "subloading",                 # or "coulomb"; optional, default "subloading"
      "params": {"preset": "sec7", "mu0": 400.0},   # or every parameter by name
      "control": "disp",                   # "disp": x is ubar_t (mm); "stress": x is f_t (MPa)
      "path": [[t, x1, x2, ubar_n], ...],  # linear in between; times strictly increasing
      "t_samples": [t, ...],               # output times within the path
      "n_tangential": 2,                   # optional: 1 (2-D, x2 must be 0) or 2 (3-D)
      "steps_per_mm": 200                  # optional; --steps-per-mm overrides it
    }

Steps are split at every path breakpoint and sample time; between them a segment gets
``ceil(steps_per_mm * L)`` equal steps, ``L`` being the largest change of ``|ubar_t|`` or ``ubar_n``
in mm (under stress control the tangential change counts as ``|f_t| / alpha_t`` mm). A hold (no
change) is one step: recovery integrates exactly.

Output (JSON): at each sample time ``t, f_t1, f_t2, f_n, up_t1, up_t2, mu, r, ubar_t1, ubar_t2,
ubar_n`` and the status of the step ending there; the number of steps per status; and
``stability_lost``: ``null``, or the first time the rate-form denominator went non-positive or the
solution jumped at a fold, with the state there. By default the driver stops there, because no
stable quasi-static solution exists beyond (``on_instability="continue"`` goes on, flagged).
Under stress control, loading beyond what the interface can sustain raises :class:`RunawayError`
at the time it happened.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .constitutive import (
    PRESETS,
    CoulombParameters,
    InterfaceState,
    ReturnMapResult,
    Status,
    SubloadingParameters,
)

__all__ = [
    "Case",
    "CaseError",
    "DriverResult",
    "RunawayError",
    "load_case",
    "main",
    "parse_case",
    "parse_law",
    "run_case",
]

FIELDS = ("t", "f_t1", "f_t2", "f_n", "up_t1", "up_t2", "mu", "r", "ubar_t1", "ubar_t2", "ubar_n")
DEFAULT_STEPS_PER_MM = 200.0
MAX_STEPS_PER_SEGMENT = 1e7  # steps between two knots of the path; more is a mistake


class CaseError(ValueError):
    """A malformed case; the message names the offending field."""


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


@dataclasses.dataclass(frozen=True)
class Case:
    """A validated material-point case (see the module docstring for the JSON form)."""

    law: SubloadingParameters | CoulombParameters
    control: str
    path: np.ndarray
    t_samples: np.ndarray
    n_tangential: int = 2
    steps_per_mm: float = DEFAULT_STEPS_PER_MM


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


# --------------------------------------------------------------------------------------------
# Parsing


def _number(where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise CaseError(f"field '{where}' must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise CaseError(f"field '{where}' must be finite, got {v!r}")
    return x


def parse_law(obj: dict[str, Any]) -> SubloadingParameters | CoulombParameters:
    """Parameters from ``{"law": "subloading"|"coulomb", "params": {...}}`` (``preset`` allowed).

    Raises:
        CaseError: Unknown law, preset or parameter name, or an invalid value (named).
    """
    kind = obj.get("law", "subloading")
    if kind not in ("subloading", "coulomb"):
        raise CaseError(f"field 'law' must be 'subloading' or 'coulomb', got {kind!r}")
    if "params" not in obj:
        raise CaseError("field 'params' is missing")
    params = obj["params"]
    if not isinstance(params, dict):
        raise CaseError(f"field 'params' must be an object, got {type(params).__name__}")
    params = dict(params)
    cls = SubloadingParameters if kind == "subloading" else CoulombParameters
    names = {f.name for f in dataclasses.fields(cls)}
    base: dict[str, Any] = {}
    if "preset" in params:
        name = params.pop("preset")
        if kind != "subloading" or name not in PRESETS:
            raise CaseError(
                f"field 'params.preset' = {name!r} is not a preset of the {kind} law; "
                f"known: {', '.join(PRESETS) if kind == 'subloading' else 'none'}"
            )
        base = PRESETS[name].parameters.as_dict()
    unknown = sorted(set(params) - names)
    if unknown:
        raise CaseError(
            f"field 'params' has unknown key(s) {unknown} for the {kind} law; "
            f"allowed: {sorted(names)} (and 'preset')"
        )
    merged = {**base, **params}
    missing = sorted(n for n in names if n not in merged and n != "mu0")
    if missing:
        raise CaseError(f"field 'params' misses {missing} for the {kind} law")
    try:
        return cls(**merged)
    except (TypeError, ValueError) as e:
        raise CaseError(f"field 'params': {e}") from None


def parse_case(obj: Any) -> Case:
    """Validate a case given as a JSON-like dictionary.

    Raises:
        CaseError: The message names the offending field.
    """
    if not isinstance(obj, dict):
        raise CaseError(f"the case must be a JSON object, got {type(obj).__name__}")
    allowed = {"law", "params", "control", "path", "t_samples", "n_tangential", "steps_per_mm"}
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise CaseError(f"unknown field(s) {unknown}; allowed: {sorted(allowed)}")
    law = parse_law(obj)
    control = obj.get("control")
    if control not in ("disp", "stress"):
        raise CaseError(f"field 'control' must be 'disp' or 'stress', got {control!r}")
    nt = obj.get("n_tangential", 2)
    if nt not in (1, 2) or isinstance(nt, bool):
        raise CaseError(f"field 'n_tangential' must be 1 or 2, got {nt!r}")
    raw = obj.get("path")
    if not isinstance(raw, list) or len(raw) < 2:
        raise CaseError("field 'path' must be a list of at least two rows [t, x1, x2, ubar_n]")
    rows = []
    for i, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != 4:
            raise CaseError(f"field 'path[{i}]' must be a row [t, x1, x2, ubar_n], got {row!r}")
        rows.append([_number(f"path[{i}][{j}]", v) for j, v in enumerate(row)])
    path = np.array(rows)
    for i in range(1, len(path)):
        if not path[i, 0] > path[i - 1, 0]:
            raise CaseError(
                f"field 'path[{i}][0]': times must increase strictly, got {path[i, 0]!r} "
                f"after {path[i - 1, 0]!r}"
            )
    if nt == 1 and np.any(path[:, 2] != 0.0):
        i = int(np.flatnonzero(path[:, 2] != 0.0)[0])
        raise CaseError(f"field 'path[{i}][2]' must be 0 with n_tangential = 1, got {path[i, 2]!r}")
    ts = obj.get("t_samples")
    if not isinstance(ts, list) or not ts:
        raise CaseError("field 't_samples' must be a non-empty list of times")
    samples = np.array([_number(f"t_samples[{i}]", v) for i, v in enumerate(ts)])
    t0, t1 = path[0, 0], path[-1, 0]
    for i, t in enumerate(samples):
        if not t0 <= t <= t1:
            raise CaseError(
                f"field 't_samples[{i}]' = {t!r} lies outside the path [{t0!r}, {t1!r}]"
            )
        if i and t < samples[i - 1]:
            raise CaseError(f"field 't_samples[{i}]': sample times must not decrease")
    spm = obj.get("steps_per_mm", DEFAULT_STEPS_PER_MM)
    spm = _number("steps_per_mm", spm)
    if spm <= 0:
        raise CaseError(f"field 'steps_per_mm' must be > 0, got {spm!r}")
    return Case(law, control, path, samples, int(nt), spm)


def load_case(path: str | Path) -> Case:
    """Read and validate a CASE.json file.

    Raises:
        CaseError: Unreadable file, invalid JSON, or a bad field (named in the message).
    """
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as e:
        raise CaseError(f"cannot read case file {str(p)!r}: {e.strerror}") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as e:
        raise CaseError(f"case file {str(p)!r} is not valid JSON: {e}") from None
    return parse_case(obj)


# --------------------------------------------------------------------------------------------
# Running


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
                **dict(zip(FIELDS[1:], self._row(t)[1:], strict=True)),
            }

    def _row(self, t: float) -> list[float]:
        f, s, ut = self.traction, self.state, self.ubar_t
        up = s.up[0]
        two = (lambda a: [a[0], a[1]]) if self.nt == 2 else (lambda a: [a[0], 0.0])
        un = self.path_at(t)[2]
        return [t, *two(f), f[self.nt], *two(up), s.mu[0], s.r[0], *two(ut), un]

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
        if isinstance(self.law, SubloadingParameters):
            mu_max = self.state.mu[0] + (self.law.mu_s - self.state.mu[0]) * -math.expm1(
                -self.law.xi * dt
            )
            strength = -math.expm1(-self.law.c_n * fn) * mu_max
        else:
            strength = self.law.mu_c * fn
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
            g = 1.0 - math.exp(-getattr(self.law, "c_n", 0.0) * self.law.alpha_n * max(f[2], 0.0))
            strength = (
                g * float(self.state.mu[0])
                if isinstance(self.law, SubloadingParameters)
                else self.law.mu_c * self.law.alpha_n * max(f[2], 0.0)
            )
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
        arr = np.array(self.rows).reshape(-1, len(FIELDS))
        return DriverResult(
            {k: arr[:, i] for i, k in enumerate(FIELDS)},
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


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status.

    0: stable and complete; 2: bad case or arguments; 3: stability lost (no stable quasi-static
    solution beyond the reported time) or runaway under stress control.
    """
    ap = argparse.ArgumentParser(
        prog="python3 -m subfric_dolfinx.driver",
        description="Material-point driver of the subloading-friction law.",
    )
    ap.add_argument("case", help="CASE.json")
    ap.add_argument("--steps-per-mm", type=float, default=None, help="step density (steps per mm)")
    ap.add_argument("--out", help="write the result to this JSON file")
    ap.add_argument(
        "--continue-unstable",
        action="store_true",
        help="go on after stability is lost (results flagged), instead of stopping",
    )
    args = ap.parse_args(argv)
    try:
        case = load_case(args.case)
        spm = args.steps_per_mm
        if spm is not None and not (math.isfinite(spm) and spm > 0):
            raise CaseError(f"--steps-per-mm must be finite and > 0, got {spm!r}")
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    code = 0
    try:
        result = run_case(
            case,
            steps_per_mm=args.steps_per_mm,
            on_instability="continue" if args.continue_unstable else "stop",
        )
        out = result.to_dict()
        if result.stability_lost is not None:
            lost = result.stability_lost
            print(
                f"unstable: no stable quasi-static solution beyond t = {lost['t']:.6g} "
                f"({lost['reason']}, r = {lost['r']:.4g}, f_t1 = {lost['f_t1']:.6g} MPa)"
                + ("" if args.continue_unstable else "; stopped there"),
                file=sys.stderr,
            )
            code = 3
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except RunawayError as e:
        print(f"error: {e}", file=sys.stderr)
        out = e.partial.to_dict() if e.partial is not None else {}
        out["error"] = {"kind": "runaway", "t": e.t, "message": str(e)}
        code = 3
    text = json.dumps(out, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n")
    else:
        print(text)
    if code == 0:
        print(
            f"ok: {result.n_steps} steps in {result.wall_time:.3g} s; "
            + ", ".join(f"{k} {v}" for k, v in result.status_counts.items() if v),
            file=sys.stderr,
        )
    return code


if __name__ == "__main__":
    sys.exit(main())
