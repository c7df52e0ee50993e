"""Least-squares fit of the subloading law to measured curves, on the batched driver.

The model of a curve is the material-point driver under displacement control: ``ubar_t`` runs
from 0 at the curve's velocity to its last slip value at constant ``ubar_n = f_n / alpha_n``,
sampled at the measured slip values (each a knot of the steps). Residuals are model minus
measurement in MPa, all points weighted alike. The fit works on ``log p`` of the fitted
parameters (every parameter is positive, their scales differ by orders of magnitude);
``scipy.optimize.least_squares`` (trust region reflective, the bounds as box constraints on
``log p``) with a forward-difference Jacobian whose columns are computed in ONE batched driver
run (curves x fitted parameters cases). A trial with ``mu_s < mu_k`` is evaluated at
``mu_s = mu_k``.

Identifiability is checked before the fit, first by rules that hold for any values (``alpha_n``
never shows at a prescribed normal stress; ``xi`` trades off against ``kappa`` and ``mu_k`` at
one velocity; ``c_n`` against ``mu_s`` and ``mu_k`` together at one normal stress), then on the
Jacobian at the start values (columns scaled to unit length: a smallest singular value below
``IDENT_TOL`` means a combination of parameters the curves do not see). Standard errors and
correlations come from the Jacobian at the optimum: ``cov = s^2 (J^T J)^-1`` with
``s^2 = sum(res^2) / (points - fitted)``, transformed from ``log p`` to ``p``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, cast

import numpy as np
from scipy.optimize import least_squares

from ..constitutive import SubloadingLaw
from ..driver import Case, CaseError, run_cases
from ..driver.path import plan_steps
from .data import NAMES, CalibrationData, CalibrationError, Curve

__all__ = [
    "IDENT_TOL",
    "MAX_STEPS",
    "STEPS_PER_MM",
    "FitResult",
    "fit",
    "simulate",
    "synthetic_curves",
]

STEPS_PER_MM = 50.0  # the driver's step density: far below the noise of measured curves
MAX_STEPS = 1e9
"""Default limit of the driver steps of a whole fit (``fit``'s ``max_steps``, the command
line's ``--max-steps``), counted before it starts: the steps of one model run (every curve,
with the fitted parameters' difference columns) times the runs ``max_evaluations`` allows.
The batched driver makes a few million point-steps a second: 1e9 is minutes."""
IDENT_TOL = 1e-5  # smallest singular value of the column-scaled Jacobian still identifiable
_H = 1e-6  # forward-difference step in log p


@dataclasses.dataclass
class FitResult:
    """The fitted parameters and their statistics (FIT.json).

    Attributes:
        params: All eight parameters (the fitted ones at the optimum).
        stderr: Standard error of each fitted parameter.
        correlation: Correlation matrix of the fitted parameters, in the order of ``fit``.
        rms: Root mean square of the residuals, MPa.
        converged: Whether the least-squares solver met a convergence test.
        fit: Names of the fitted parameters.
        message: The solver's message.
        n_points: Number of measured points.
        evaluations: Driver runs (each a batch of cases).
        seconds: Wall time of the fit.
    """

    params: dict[str, float]
    stderr: dict[str, float]
    correlation: list[list[float]]
    rms: float
    converged: bool
    fit: list[str]
    message: str
    n_points: int
    evaluations: int
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (FIT.json)."""
        return dataclasses.asdict(self)


def _law(p: dict[str, float]) -> SubloadingLaw:
    q = dict(p)
    q["mu_s"] = max(q["mu_s"], q["mu_k"])
    return SubloadingLaw(**q)


def _cases(law: SubloadingLaw, curves: Sequence[Curve], spm: float) -> list[Case]:
    out = []
    for c in curves:
        un = c.f_n / law.alpha_n
        ts = c.slip / c.velocity
        path = np.array([[0.0, 0.0, 0.0, un], [ts[-1], c.slip[-1], 0.0, un]])
        out.append(Case(law, "disp", path, ts, 1, spm))
    return out


def simulate(
    param_sets: Sequence[dict[str, float]], curves: Sequence[Curve], steps_per_mm: float
) -> list[list[np.ndarray]]:
    """``f_t`` of every curve (at its slip values) for every parameter set, in ONE driver run.

    Returns:
        ``out[i][j]``: parameter set ``i``, curve ``j``.

    Raises:
        CalibrationError: A parameter set the law refuses, or too many steps.
    """
    cases = []
    for p in param_sets:
        try:
            law = _law(p)
        except (TypeError, ValueError) as e:
            raise CalibrationError(f"parameters {p}: {e}") from None
        cases += _cases(law, curves, steps_per_mm)
    try:
        res = run_cases(cases, on_instability="continue")
    except CaseError as e:
        raise CalibrationError(str(e)) from None
    except RuntimeError as e:  # the map failed at a point (non-finite input)
        raise CalibrationError(f"the model failed: {e}") from None
    k = len(curves)
    return [[r.samples["f_t1"] for r in res[i * k : (i + 1) * k]] for i in range(len(param_sets))]


def synthetic_curves(
    params: dict[str, float],
    f_n: Sequence[float],
    velocity: Sequence[float],
    slip: Sequence[float],
    *,
    noise: float = 0.0,
    seed: int = 0,
    steps_per_mm: float = STEPS_PER_MM,
) -> list[dict[str, Any]]:
    """Curves of DATA.json computed by the model (for tests and demos): "measured" curves.

    Args:
        params: All eight parameters.
        f_n: Normal stress of each curve, MPa.
        velocity: Sliding velocity of each curve, mm/s (same length as ``f_n``).
        slip: The slip values of every curve, mm.
        noise: Standard deviation of Gaussian noise added to ``f_t``, MPa.
        seed: Seed of the noise.
        steps_per_mm: Step density of the driver.

    Returns:
        ``[{"f_n", "velocity", "slip", "f_t"}, ...]`` (JSON-ready).
    """
    s = np.asarray(slip, dtype=float)
    curves = [
        Curve(float(fn), float(v), s, np.zeros(s.size)) for fn, v in zip(f_n, velocity, strict=True)
    ]
    sim = simulate([params], curves, steps_per_mm)[0]
    rng = np.random.default_rng(seed)
    return [
        {
            "f_n": c.f_n,
            "velocity": c.velocity,
            "slip": s.tolist(),
            "f_t": (f + noise * rng.standard_normal(s.size)).tolist(),
        }
        for c, f in zip(curves, sim, strict=True)
    ]


class _Model:
    """Residuals and their Jacobian in ``x = log p`` (fitted names), counted and cached."""

    def __init__(self, data: CalibrationData, spm: float) -> None:
        self.data = data
        self.spm = spm
        self.names = list(data.fit)
        self.measured = np.concatenate([c.f_t for c in data.curves])
        self.runs = 0
        self._last: tuple[bytes, np.ndarray] | None = None

    def params(self, x: np.ndarray) -> dict[str, float]:
        p = dict(self.data.params)
        for k, v in zip(self.names, x, strict=True):
            p[k] = math.exp(float(v))
        return p

    def many(self, xs: list[np.ndarray]) -> list[np.ndarray]:
        self.runs += 1
        out = simulate([self.params(x) for x in xs], self.data.curves, self.spm)
        return [np.concatenate(o) - self.measured for o in out]

    def fun(self, x: np.ndarray) -> np.ndarray:
        key = np.asarray(x, dtype=float).tobytes()
        if self._last is None or self._last[0] != key:
            self._last = (key, self.many([x])[0])
        return self._last[1]

    def jac(self, x: np.ndarray, hi: np.ndarray | None = None) -> np.ndarray:
        base = self.fun(x)
        steps: np.ndarray = np.full(x.size, _H)
        if hi is not None:
            steps = np.where(x + _H > hi, -_H, _H)  # stay within the upper bounds
        xs = []
        for i in range(x.size):
            xi = np.array(x, dtype=float)
            xi[i] += steps[i]
            xs.append(xi)
        cols = self.many(xs)
        return np.column_stack([(c - base) / h for c, h in zip(cols, steps, strict=True)])


def check_rules(data: CalibrationData) -> None:
    """The identifiability rules that hold for any parameter values.

    Raises:
        CalibrationError: A fitted parameter the curves cannot show, with what to do.
    """
    fit = set(data.fit)
    if "alpha_n" in fit:
        raise CalibrationError(
            "the data cannot identify alpha_n: at a prescribed normal stress it only converts "
            "f_n into the normal gap and does not change any curve; fix it"
        )
    vs = {c.velocity for c in data.curves}
    if "xi" in fit and len(vs) == 1 and fit & {"kappa", "mu_k"}:
        others = " and ".join(sorted(fit & {"kappa", "mu_k"}))
        raise CalibrationError(
            f"the data cannot identify xi together with {others}: all curves are monotonic "
            f"slides at one velocity ({vs.pop():g} mm/s), where the recovery of mu (xi, per "
            "second) cannot be told from its softening (kappa, mu_k, per mm of slip); give "
            "curves at two or more velocities, or fix xi (or both of the others)"
        )
    fns = {c.f_n for c in data.curves}
    if "c_n" in fit and len(fns) == 1 and {"mu_s", "mu_k"} <= fit:
        raise CalibrationError(
            f"the data cannot identify c_n together with mu_s and mu_k: at one normal stress "
            f"({fns.pop():g} MPa) only g(f_n) mu_s and g(f_n) mu_k show; give curves at two or "
            "more normal stresses, or fix c_n"
        )


def check_jacobian(J: np.ndarray, names: Sequence[str], where: str, scale: float = 0.0) -> float:
    """Refuse a Jacobian whose scaled columns are (nearly) dependent.

    Returns the smallest singular value of the column-scaled Jacobian.

    A column below ``1e-12`` of the largest one or of ``scale`` (the norm of the data) is a
    parameter without effect.

    Raises:
        CalibrationError: Names the parameters that have no effect, or the combination the
            curves cannot see.
    """
    norms = np.linalg.norm(J, axis=0)
    top = float(norms.max()) if norms.size else 0.0
    floor = 1e-12 * max(top, scale, 1e-300)
    dead = [n for n, v in zip(names, norms, strict=True) if not v > floor]
    if dead:
        raise CalibrationError(
            f"the data cannot identify {', '.join(dead)}: the curves do not change with "
            f"{'it' if len(dead) == 1 else 'them'} ({where}); fix "
            f"{'it' if len(dead) == 1 else 'them'} or add curves where it shows"
        )
    _, s, vt = np.linalg.svd(J / norms, full_matrices=False)
    smin = float(s[-1])
    if smin < IDENT_TOL:
        v = vt[-1]
        big = [f"{names[i]} ({v[i]:+.2f})" for i in np.argsort(-np.abs(v)) if abs(v[i]) > 0.1]
        raise CalibrationError(
            "the data cannot identify these parameters separately: the curves hardly change "
            f"along the combination {', '.join(big)} of their logarithms (smallest singular "
            f"value of the scaled Jacobian {smin:.2g} < {IDENT_TOL:g}, {where}); fix one of "
            "them, or add curves (other normal stresses, other velocities)"
        )
    return smin


def check_steps(
    data: CalibrationData, steps_per_mm: float, max_evaluations: int, max_steps: float
) -> int:
    """The driver steps a fit may take; refused beyond ``max_steps`` (before any run).

    Returns:
        The bound: steps of one model run (each curve's steps, ``1 + fitted`` cases each for a
        Jacobian) times ``max_evaluations + 2`` runs.

    Raises:
        CalibrationError: Naming the longest curve, the bound and the limit.
    """
    if not (max_steps >= 1):
        raise CalibrationError(f"max_steps must be >= 1, got {max_steps!r}")
    law = _law(data.params)
    per_curve = []
    for i, case in enumerate(_cases(law, data.curves, steps_per_mm)):
        try:
            per_curve.append(plan_steps(case, steps_per_mm).total)
        except CaseError as e:
            c = data.curves[i]
            raise CalibrationError(
                f"curves[{i}] (slip to {c.slip[-1]:g} mm) needs too many driver steps: {e}"
            ) from None
    per_run = sum(per_curve) * (1 + len(data.fit))
    bound = per_run * (max_evaluations + 2)
    if bound > max_steps:
        i = int(np.argmax(per_curve))
        c = data.curves[i]
        raise CalibrationError(
            f"the fit may take {bound:.3g} driver steps ({per_run:.3g} per model run, "
            f"{max_evaluations} evaluations), more than max_steps = {max_steps:g}: the longest "
            f"curve (curves[{i}], slip to {c.slip[-1]:g} mm) needs {per_curve[i]:.3g} steps at "
            f"steps_per_mm = {steps_per_mm:g}; lower steps_per_mm or max_evaluations, or raise "
            "max_steps"
        )
    return bound


def fit(
    data: CalibrationData,
    *,
    steps_per_mm: float = STEPS_PER_MM,
    max_evaluations: int = 200,
    log: Callable[[str], None] | None = None,
    max_steps: float = MAX_STEPS,
) -> FitResult:
    """Fit ``data.fit`` to the curves by least squares.

    Args:
        data: Validated calibration data.
        steps_per_mm: Step density of the driver.
        max_evaluations: Limit of residual evaluations of the solver.
        log: Called with a line per Jacobian (progress), if given.
        max_steps: Limit of the driver steps of the whole fit (:data:`MAX_STEPS`), checked
            before the first run.

    Returns:
        Parameters, standard errors, correlations, rms, convergence.

    Raises:
        CalibrationError: Parameters the data cannot identify (before the fit, or at the
            optimum), more steps than ``max_steps``, or a model run refused.
    """
    if not (math.isfinite(steps_per_mm) and steps_per_mm > 0):
        raise CalibrationError(f"steps_per_mm must be finite and > 0, got {steps_per_mm!r}")
    check_steps(data, steps_per_mm, max_evaluations, max_steps)
    t0 = time.perf_counter()
    check_rules(data)
    model = _Model(data, steps_per_mm)
    names = model.names
    x0 = np.array([math.log(data.params[k]) for k in names])
    lo = np.array(
        [math.log(data.bounds[k][0]) if data.bounds[k][0] > 0 else -np.inf for k in names]
    )
    hi = np.array(
        [math.log(data.bounds[k][1]) if math.isfinite(data.bounds[k][1]) else np.inf for k in names]
    )
    scale = float(np.linalg.norm(model.measured))
    check_jacobian(model.jac(x0, hi), names, "at the start values", scale)
    n_jac = [0]

    def jac(x: np.ndarray) -> np.ndarray:
        J = model.jac(x, hi)
        n_jac[0] += 1
        if log is not None:
            r = model.fun(x)
            vals = ", ".join(f"{k} {math.exp(v):.6g}" for k, v in zip(names, x, strict=True))
            log(f"iteration {n_jac[0]}: rms {math.sqrt(np.mean(r**2)):.4g} MPa; {vals}")
        return J

    sol = least_squares(
        model.fun,
        x0,
        jac=jac,
        bounds=(lo, hi),
        method="trf",
        x_scale=1.0,
        ftol=1e-12,
        xtol=1e-12,
        gtol=1e-12,
        max_nfev=max_evaluations,
    )
    x = sol.x
    J = model.jac(x, hi)
    r = model.fun(x)
    check_jacobian(
        J,
        names,
        "at the optimum "
        + ", ".join(f"{k} = {math.exp(v):.6g}" for k, v in zip(names, x, strict=True)),
        scale,
    )
    m, n = r.size, x.size
    s2 = float(r @ r) / (m - n)
    C = np.linalg.pinv(J.T @ J)
    p = _law(model.params(x)).parameters()  # (mu_s >= mu_k)
    sd = np.sqrt(np.maximum(np.diag(C), 0.0) * s2)
    stderr = {k: p[k] * float(sd[i]) for i, k in enumerate(names)}  # d p = p d log p
    d = np.sqrt(np.maximum(np.diag(C), 1e-300))
    corr = np.clip(C / np.outer(d, d), -1.0, 1.0)
    return FitResult(
        params={k: p[k] for k in NAMES},
        stderr=stderr,
        correlation=cast(list[list[float]], corr.tolist()),
        rms=math.sqrt(float(r @ r) / m),
        converged=bool(sol.success),
        fit=list(names),
        message=str(sol.message),
        n_points=m,
        evaluations=model.runs,
        seconds=time.perf_counter() - t0,
    )
