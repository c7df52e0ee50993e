"""The spring-slider: one interface point carrying a mass, pulled through a spring (dynamics).

Per unit area of the interface (units MPa, mm, s; mass per unit area in tonne/mm^2, so that
tonne/mm^2 times mm/s^2 is N/mm^2 = MPa)::

    m u'' = k (x0 + V t - u) - f_t(u) - eta u',     ubar_t = u,  ubar_n = f_n / alpha_n (constant)

``u`` is the slider's displacement (the tangential gap of the interface point), ``f_t`` the
traction the law's return map gives for the step (the same map as the finite-element code's:
:meth:`~subfric_dolfinx.constitutive.SubloadingLaw.point_map` for the subloading law, one
point of ``return_map`` for any other law), ``k`` the spring stiffness per unit area (MPa/mm),
``V`` the load point's velocity (mm/s), ``x0`` its initial position, ``eta`` an optional
dashpot to the fixed base (MPa s/mm per unit area, default 0: undamped; e.g. the radiation
damping ``G / (2 c_s)`` of quasi-dynamic fault models).

Time integration: Newmark's average acceleration (trapezoidal rule, ``beta = 1/4``,
``gamma = 1/2``): implicit, unconditionally stable for a linear system, second order, without
numerical damping (stick-slip is an undamped oscillation between events: a damping scheme would
move the stability limit of steady sliding). Each step solves the scalar equilibrium
``R(u) = m a(u) + eta v(u) + k (u - x_L) + f_t(u) = 0`` (``a``, ``v`` Newmark's, linear in
``u``) by Newton with the law's
consistent tangent, safeguarded by a bracket and bisection.

Adaptive steps resolve the slip events: the local error estimate of the scheme,
``e = dt^2 |a_{n+1} - a_n| / 12`` (Zienkiewicz and Xie 1991), is kept below ``err_tol`` (mm): a
step above ``2 err_tol`` is taken again with a shorter one, the next step is
``dt sqrt(err_tol / e)`` times 0.9, growing by at most ``GROWTH``, up to ``dt_max``. A step
whose Newton does not converge is cut by 4. Sample times are hit exactly.

Case (JSON)::

    {
      "law": "subloading", "params": {"preset": "sec7"},
      "control": "slider",
      "slider": {
        "mass": 1e-6,          # tonne/mm^2, > 0
        "stiffness": 50.0,     # MPa/mm, > 0
        "velocity": 0.01,      # mm/s, >= 0
        "f_n": 300.0,          # MPa, > 0 (constant normal stress)
        "t_end": 20.0,         # s, > 0
        "x0": 0.0,             # optional: the load point at t = 0 (mm)
        "v0": 0.0,             # optional: the slider's initial velocity (mm/s)
        "damping": 0.0,        # optional: eta, MPa s/mm (>= 0)
        "dt_max": 0.01,        # optional (s): default 2 pi sqrt(m / k) / 100
        "err_tol": 1e-7        # optional (mm): default 1e-5 g(f_n) mu / k (the law's
                               #   initial strength over k)
      },
      "t_samples": [t, ...]    # optional: output at these times; default every step
    }
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..constitutive import FrictionLaw, InterfaceState, LawError, Status, SubloadingLaw, build_law
from ..values import short_repr
from .checks import CaseError, field_number

__all__ = [
    "GROWTH",
    "MAX_SLIDER_STEPS",
    "SLIDER_FIELDS",
    "STEPS_PER_PERIOD",
    "SliderCase",
    "SliderResult",
    "SteadySliding",
    "parse_slider",
    "run_slider",
    "steady_sliding",
    "stick_slip_cycles",
]

STEPS_PER_PERIOD = 100.0  # the default dt_max (docs/reference/spring_slider.md: accuracy)
GROWTH = 2.0  # largest ratio of two consecutive step lengths
MAX_SLIDER_STEPS = 1e7  # accepted steps of one case (about 10 minutes); more is a mistake
_ULPS = 4.0 * 2.0**-52  # a Newton update below this times |u| is the rounding of u: converged
MIN_DT_RATIO = 1e-12  # a step cut below this times dt_max: the run stops (an error)
SLIDER_FIELDS = ("t", "u", "v", "a", "x_load", "f_t", "f_spring", "up", "mu", "r")
"""The sampled fields: time (s), the slider's displacement (mm), velocity (mm/s), acceleration
(mm/s^2), the load point (mm), the interface traction and the spring force per area (MPa), then
the law's scalar internal variables present among ``up`` (plastic slip, mm), ``mu``, ``r``."""

_SLIDER_KEYS = {
    "mass",
    "stiffness",
    "velocity",
    "f_n",
    "t_end",
    "x0",
    "v0",
    "damping",
    "dt_max",
    "err_tol",
}


@dataclasses.dataclass(frozen=True)
class SliderCase:
    """A validated spring-slider case (see the module docstring for the JSON form)."""

    law: FrictionLaw
    mass: float
    stiffness: float
    velocity: float
    f_n: float
    t_end: float
    x0: float = 0.0
    v0: float = 0.0
    dt_max: float | None = None
    err_tol: float | None = None
    t_samples: np.ndarray | None = None
    damping: float = 0.0

    @property
    def period(self) -> float:
        """``2 pi sqrt(m / k)``, the spring's period with the mass (s)."""
        return 2.0 * math.pi * math.sqrt(self.mass / self.stiffness)

    def step_limit(self) -> float:
        """``dt_max``, or its default: :attr:`period` / ``STEPS_PER_PERIOD``."""
        return self.period / STEPS_PER_PERIOD if self.dt_max is None else self.dt_max

    def tolerance(self) -> float:
        """``err_tol``, or its default ``1e-5 g(f_n) mu_0 / k`` (the initial strength over k)."""
        if self.err_tol is not None:
            return self.err_tol
        nt = 1
        strength = float(self.law.strength(self.law.initial_state(1, nt), [self.f_n])[0])
        return 1e-5 * max(strength, 1e-300) / self.stiffness


def _positive(where: str, v: Any, allow_zero: bool = False) -> float:
    x = field_number(where, v)
    if not (x > 0.0 or (allow_zero and x == 0.0)):
        need = ">= 0" if allow_zero else "> 0"
        raise CaseError(f"field '{where}' must be {need}, got {short_repr(v)}")
    return x


def parse_slider(obj: dict[str, Any]) -> SliderCase:
    """Validate a slider case (``"control": "slider"``) given as a JSON-like dictionary.

    Raises:
        CaseError: The message names the offending field and value.
    """
    allowed = {"law", "params", "control", "slider", "t_samples"}
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise CaseError(f"unknown field(s) {unknown} of a slider case; allowed: {sorted(allowed)}")
    try:
        law = build_law(obj)
    except LawError as e:
        raise CaseError(str(e)) from None
    sl = obj.get("slider")
    if not isinstance(sl, dict):
        raise CaseError(
            f"field 'slider' must be an object with mass, stiffness, velocity, f_n, t_end; "
            f"got {short_repr(sl)}"
        )
    bad = sorted(set(sl) - _SLIDER_KEYS)
    if bad:
        raise CaseError(f"field 'slider': unknown keys {bad}; allowed: {sorted(_SLIDER_KEYS)}")
    for key in ("mass", "stiffness", "velocity", "f_n", "t_end"):
        if key not in sl:
            raise CaseError(f"field 'slider.{key}' is missing")
    mass = _positive("slider.mass", sl["mass"])
    stiffness = _positive("slider.stiffness", sl["stiffness"])
    velocity = _positive("slider.velocity", sl["velocity"], allow_zero=True)
    f_n = _positive("slider.f_n", sl["f_n"])
    t_end = _positive("slider.t_end", sl["t_end"])
    x0 = field_number("slider.x0", sl.get("x0", 0.0))
    v0 = field_number("slider.v0", sl.get("v0", 0.0))
    eta = _positive("slider.damping", sl.get("damping", 0.0), allow_zero=True)
    dt_max = None if sl.get("dt_max") is None else _positive("slider.dt_max", sl["dt_max"])
    err_tol = None if sl.get("err_tol") is None else _positive("slider.err_tol", sl["err_tol"])
    for name in ("alpha_t", "alpha_n"):
        if not isinstance(getattr(law, name, None), float | int):
            raise CaseError(f"the {law.name} law has no {name}: it cannot carry a slider")
    ts = obj.get("t_samples")
    samples = None
    if ts is not None:
        if not isinstance(ts, list) or not ts:
            raise CaseError("field 't_samples' must be a non-empty list of times")
        samples = np.array([field_number(f"t_samples[{i}]", v) for i, v in enumerate(ts)])
        for i, t in enumerate(samples):
            if not 0.0 <= t <= t_end:
                raise CaseError(
                    f"field 't_samples[{i}]' = {float(t)!r} lies outside [0, slider.t_end = "
                    f"{t_end!r}]"
                )
            if i and t < samples[i - 1]:
                raise CaseError(f"field 't_samples[{i}]': sample times must not decrease")
    case = SliderCase(
        law, mass, stiffness, velocity, f_n, t_end, x0, v0, dt_max, err_tol, samples, eta
    )
    steps = t_end / case.step_limit()
    if steps > MAX_SLIDER_STEPS:
        raise CaseError(
            f"field 'slider.t_end' = {t_end!r} needs at least {steps:.3g} steps of dt_max = "
            f"{case.step_limit():.3g} s (limit {MAX_SLIDER_STEPS:g}); shorten the run or raise "
            "slider.dt_max"
        )
    return case


@dataclasses.dataclass
class SliderResult:
    """Result of a spring-slider run.

    Attributes:
        samples: Field name (:data:`SLIDER_FIELDS`) -> array over the samples (every accepted
            step, or the case's sample times).
        sample_status: Status name of the step ending at each sample.
        status_counts: Accepted steps per status.
        n_steps: Accepted steps; ``n_rejected``: steps taken again shorter; ``map_calls``:
            return-map evaluations.
        wall_time: Seconds spent.
        complete: Whether ``t_end`` was reached.
        stability_lost: Always None (dynamics continue through the quasi-static limit).
        end_state: The interface point's state at ``t_end`` (``run_slider``'s ``state`` of a
            run that continues this one).
        end_motion: The slider's displacement (mm) and velocity (mm/s) at ``t_end`` (the
            continuing run's ``u0`` and ``v0``).
    """

    samples: dict[str, np.ndarray]
    sample_status: list[str]
    status_counts: dict[str, int]
    n_steps: int
    n_rejected: int
    map_calls: int
    wall_time: float
    complete: bool = True
    stability_lost: None = None
    end_state: InterfaceState | None = None
    end_motion: tuple[float, float] = (0.0, 0.0)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "samples": {k: v.tolist() for k, v in self.samples.items()},
            "sample_status": self.sample_status,
            "status_counts": self.status_counts,
            "complete": self.complete,
            "n_steps": self.n_steps,
            "n_rejected": self.n_rejected,
            "map_calls": self.map_calls,
            "wall_time": self.wall_time,
        }


class _Point:
    """The interface point under the slider: the law's step from the last accepted state."""

    def __init__(self, law: FrictionLaw, un: float, state: InterfaceState | None) -> None:
        self.law = law
        self.un = un
        self.calls = 0
        st = law.initial_state(1, 1) if state is None else state
        self.fast = isinstance(law, SubloadingLaw)
        if self.fast:
            self.s = (
                float(st["up"][0, 0]),
                float(st["mu"][0]),
                float(st["r"][0]),
                (float(st["f"][0, 0]), float(st["f"][0, 1])) if "f" in st else None,
            )
        else:
            self.state = st
        self.names = [n for n in ("up", "mu", "r") if n in st]

    def trial(self, u: float, dt: float) -> tuple[float, float, Any]:
        """``(f_t, df_t/du, pending)`` at the gap ``u`` after ``dt``; ``pending`` for accept."""
        self.calls += 1
        if self.fast:
            assert isinstance(self.law, SubloadingLaw)  # (fast: the subloading law's float path)
            o = self.law.point_map((u, self.un), self.s, dt)
            if o[7] == int(Status.FAILED):
                raise FloatingPointError
            return o[0], o[2], o
        res = self.law.return_map(np.array([[u, self.un]]), self.state, dt)
        if res.status[0] == int(Status.FAILED):
            raise FloatingPointError
        return float(res.traction[0, 0]), float(res.tangent[0, 0, 0]), res

    def current(self) -> InterfaceState:
        """The last accepted state, one point."""
        if not self.fast:
            return self.state
        up, mu, r, f = self.s
        arrays = {"up": np.array([[up]]), "mu": np.array([mu]), "r": np.array([r])}
        if f is not None:
            arrays["f"] = np.array([f])
        return InterfaceState(arrays, 1)

    def accept(self, pending: Any) -> tuple[int, list[float]]:
        """Take the state of a trial; return its status and the sampled internal variables."""
        if self.fast:
            o = pending
            self.s = (o[4], o[5], o[6], (o[0], o[1]))
            return o[7], [o[4], o[5], o[6]]
        self.state = pending.state
        st = self.state
        vals = [float(st[n][0, 0] if n == "up" else st[n][0]) for n in self.names]
        return int(pending.status[0]), vals


def _solve(
    pt: _Point, u0: float, u_pred: float, M: float, k: float, b: float, dt: float
) -> tuple[float, float, float, Any] | None:
    """Newton for ``M (u - u_pred) + k u - b + f_t(u) = 0`` from ``u0``; None if not converged.

    Returns ``(u, f_t, df_t/du, pending)``.
    """
    u = u0
    f, D, pend = pt.trial(u, dt)
    lo, hi = -math.inf, math.inf
    for _ in range(60):
        R = M * (u - u_pred) + (k * u - b) + f
        scale = abs(f) + abs(k * u - b) + abs(M * (u - u_pred))
        if abs(R) <= 1e-12 * scale or R == 0.0:
            return u, f, D, pend
        if R > 0.0:
            hi = min(hi, u)
        else:
            lo = max(lo, u)
        J = M + k + D
        un = u - R / J if J > 0.0 and math.isfinite(J) else math.nan
        if abs(un - u) <= _ULPS * abs(u):  # the Newton update is the rounding of u
            return u, f, D, pend
        if not (lo < un < hi):
            if math.isfinite(lo) and math.isfinite(hi):
                un = 0.5 * (lo + hi)
            else:  # no bracket yet: a step of the inertia alone, outward
                un = u - R / (M + k)
        if math.isfinite(lo) and math.isfinite(hi) and hi - lo <= _ULPS * abs(u):
            return u, f, D, pend
        u = un
        f, D, pend = pt.trial(u, dt)
    return None


def run_slider(
    case: SliderCase | dict[str, Any],
    *,
    state: InterfaceState | None = None,
    u0: float | None = None,
    max_steps: float = MAX_SLIDER_STEPS,
    progress: Callable[[int, int, float], None] | None = None,
) -> SliderResult:
    """Integrate a spring-slider case in time.

    Args:
        case: A :class:`SliderCase` or its JSON-like dictionary (``"control": "slider"``).
        state: The interface point's state at ``t = 0`` (one point, one tangential component;
            e.g. steady sliding), instead of the law's virgin state. The slider starts at
            ``u0``.
        u0: The slider's initial displacement (mm); default ``up + f_t / alpha_t`` of the
            state when it holds the start traction ``f`` (0 for the virgin state), else ``up``.
        max_steps: Limit of accepted steps (an error beyond).
        progress: Called every 2000 steps as ``progress(steps_done, steps_projected, t)``
            (the steps so far scaled by ``t_end / t``).

    Returns:
        The sampled history (:data:`SLIDER_FIELDS`) and the step counts.

    Raises:
        CaseError: An invalid case, more than ``max_steps`` steps, or a step cut below
            ``MIN_DT_RATIO dt_max`` (the message names the time).
    """
    if not isinstance(case, SliderCase):
        if not isinstance(case, dict):
            raise CaseError(f"the case must be a JSON object, got {type(case).__name__}")
        case = parse_slider(case)
    law = case.law
    m, k, V = case.mass, case.stiffness, case.velocity
    un = case.f_n / float(law.alpha_n)
    dt_max, err = case.step_limit(), case.tolerance()
    pt = _Point(law, un, state)
    t0 = time.perf_counter()
    # the initial state: the normal stress applied at rest (dt = 0), the slider at its gap
    u = 0.0
    if u0 is not None:
        u = field_number("u0", u0)
    elif state is not None:
        f_start = float(state["f"][0, 0]) if "f" in state else 0.0
        u = float(state["up"][0, 0]) + f_start / float(law.alpha_t)
    f, D_last, pend = _solve_at(pt, u, 0.0)
    status, own = pt.accept(pend)
    v = case.v0
    eta = case.damping
    a = (k * (case.x0 - u) - f - eta * v) / m
    rows: list[list[float]] = []
    row_status: list[str] = []
    counts = [0] * len(Status)
    counts[status] += 1
    samples = None if case.t_samples is None else cast(list[float], case.t_samples.tolist())

    def record(t: float) -> None:
        x = case.x0 + V * t
        rows.append([t, u, v, a, x, f, k * (x - u), *own])
        row_status.append(Status(status).name)

    t = 0.0
    if samples is None:
        record(0.0)
    else:
        while samples and samples[0] <= 0.0:
            samples.pop(0)
            record(0.0)
    dt = dt_max / 100.0
    n_steps = n_rej = 0
    check = 2000
    t_end = case.t_end
    while t < t_end:
        if n_steps >= max_steps:
            raise CaseError(f"the slider case needs more than {max_steps:g} steps (t = {t:.6g} s)")
        if dt < MIN_DT_RATIO * dt_max:
            raise CaseError(
                f"the slider's step was cut below {MIN_DT_RATIO:g} dt_max at t = {t:.6g} s "
                f"(u = {u:.6g} mm, v = {v:.6g} mm/s): the return map or Newton fails there"
            )
        h = min(dt, t_end - t)
        if samples and t + h >= samples[0]:
            h = samples[0] - t
        t_new = t + h if t + h < t_end else t_end
        # m a(u) + eta v(u) = M (u - u_pred) + eta v_pred (Newmark: a, v linear in u)
        M = 4.0 * m / (h * h) + 2.0 * eta / h
        u_pred = u + h * v + 0.25 * h * h * a
        x_load = case.x0 + V * t_new
        try:
            b = k * x_load - eta * (v + 0.5 * h * a)
            # the first iterate: Newton's step from the predictor on the last accepted tangent
            J = M + k + D_last
            R = k * u_pred - b + f + D_last * (u_pred - u)
            u_first = u_pred - R / J if J > 0.0 and math.isfinite(R / J) else u_pred
            sol = _solve(pt, u_first, u_pred, M, k, b, h)
        except FloatingPointError:
            sol = None
        if sol is None:
            n_rej += 1
            dt = 0.25 * h
            continue
        u_new, f_new, D_new, pend = sol
        a_new = 4.0 * (u_new - u_pred) / (h * h)
        e = h * h * abs(a_new - a) / 12.0
        if e > 2.0 * err and h > MIN_DT_RATIO * dt_max:
            n_rej += 1
            dt = h * max(0.2, 0.9 * math.sqrt(err / e))
            continue
        v = v + 0.5 * h * (a + a_new)
        u, a, f, t, D_last = u_new, a_new, f_new, t_new, D_new
        status, own = pt.accept(pend)
        counts[status] += 1
        n_steps += 1
        if samples is None:
            record(t)
        else:
            while samples and samples[0] <= t:
                samples.pop(0)
                record(t)
        grow = GROWTH if e == 0.0 else max(min(GROWTH, 0.9 * math.sqrt(err / e)), 0.2)
        # (a step shortened to hit a sample time does not shorten the next one unless needed)
        dt = min(dt_max, h * grow if h >= dt or grow < 1.0 else max(h * grow, dt))
        if progress is not None and n_steps >= check:
            progress(n_steps, max(n_steps, round(n_steps * t_end / t)), t)  # (projected)
            check += 2000
    names = [*SLIDER_FIELDS[:7], *pt.names]
    arr = np.array(rows).reshape(-1, len(names))
    return SliderResult(
        {n: arr[:, i] for i, n in enumerate(names)},
        row_status,
        {s.name: counts[s] for s in Status},
        n_steps,
        n_rej,
        pt.calls,
        time.perf_counter() - t0,
        end_state=pt.current(),
        end_motion=(u, v),
    )


def _solve_at(pt: _Point, u: float, dt: float) -> tuple[float, float, Any]:
    """The traction, its tangent and the pending state at the gap ``u`` (the initial step)."""
    try:
        return pt.trial(u, dt)
    except FloatingPointError:
        raise CaseError("the return map fails at the initial state of the slider") from None


@dataclasses.dataclass(frozen=True)
class SteadySliding:
    """Steady sliding of a spring-slider with the subloading law, and its linear stability.

    Linearised about steady sliding at ``V`` (``r = 1``, ``mu = mu_ss``), the law's rate
    equations with the mass, the spring and the dashpot give a decoupled decay of ``r`` and,
    for the spring's stretch, the slider's velocity and ``mu``, the characteristic cubic
    ``m s^3 + (m c2 + eta) s^2 + (k - k_w + eta c2) s + k c2 = 0`` with ``k_w = g c1``
    (docs/reference/spring_slider.md). Its Routh-Hurwitz condition gives the critical stiffness
    ``k_c = (m c2 + eta) (k_w - eta c2) / eta``: steady sliding is unstable below it, stable
    above.

    Attributes:
        velocity: The driving velocity ``V`` (mm/s).
        mu: ``mu_ss = (kappa mu_k V + xi mu_s) / (kappa V + xi)``, the recovery's balance of
            the weakening (MPa).
        traction: The friction traction of steady sliding, ``g(f_n) mu_ss`` (MPa).
        weakening: ``k_w = g c1``, the friction's fall per unit slip at steady sliding
            (MPa/mm): the quasi-static critical stiffness (without inertia).
        c2: The rate at which ``mu`` returns to ``mu_ss`` after a perturbation (1/s).
        critical_stiffness: ``k_c`` (MPa/mm); ``inf`` without damping (steady sliding is then
            unstable at every stiffness), ``0`` when the dashpot stabilises every stiffness.
        onset_period: The period of the oscillation that grows from steady sliding at ``k_c``,
            ``2 pi / omega_c`` with ``omega_c^2 = k_c c2 / (m c2 + eta)`` (s; ``nan`` without a
            finite, positive ``k_c``).
        f_n: The normal stress (MPa).
    """

    velocity: float
    mu: float
    traction: float
    weakening: float
    c2: float
    critical_stiffness: float
    onset_period: float
    f_n: float

    def state(self) -> InterfaceState:
        """The interface point sliding steadily (``run_slider``'s ``state``).

        ``up = 0``, ``mu_ss``, ``r = 1``, the traction ``(g mu_ss, f_n)``.
        """
        arrays = {"up": np.zeros((1, 1)), "mu": np.array([self.mu]), "r": np.array([1.0])}
        arrays["f"] = np.array([[self.traction, self.f_n]])
        return InterfaceState(arrays, 1)


def steady_sliding(
    law: SubloadingLaw, f_n: float, velocity: float, mass: float, damping: float = 0.0
) -> SteadySliding:
    """Steady sliding at ``velocity`` and its critical stiffness (:class:`SteadySliding`).

    Args:
        law: The subloading law (absolute form of ``kappa`` and ``xi``).
        f_n: The constant normal stress (MPa, > 0).
        velocity: The driving velocity (mm/s, > 0).
        mass: The mass per unit area (tonne/mm^2, > 0).
        damping: The dashpot ``eta`` (MPa s/mm, >= 0).

    Raises:
        CaseError: A bad value (named), or a law whose steady sliding snaps back
            (``alpha_t <= g kappa (mu_ss - mu_k)``: no stable quasi-static sliding).
    """
    if not isinstance(law, SubloadingLaw):
        raise CaseError(f"steady_sliding needs the subloading law, got {type(law).__name__}")
    f_n = _positive("f_n", f_n)
    V = _positive("velocity", velocity)
    m = _positive("mass", mass)
    eta = _positive("damping", damping, allow_zero=True)
    g = -math.expm1(-law.c_n * f_n)
    kappa, xi = float(law.kappa), float(law.xi)
    mu = (kappa * law.mu_k * V + xi * law.mu_s) / (kappa * V + xi)
    weak = kappa * (mu - law.mu_k)
    den = law.alpha_t - g * weak  # the rate form's denominator at r = 1 (U(1) = 0)
    if not den > 0.0:
        raise CaseError(
            f"steady sliding at velocity {V!r} snaps back: alpha_t = {law.alpha_t!r} <= "
            f"g kappa (mu_ss - mu_k) = {g * weak:.6g} MPa/mm"
        )
    lam_v = law.alpha_t / den  # the slip rate's change with the slider's velocity
    lam_mu = g * (xi + kappa * V) / den  # ... and with mu
    c1 = weak * lam_v
    c2 = kappa * V + xi + weak * lam_mu
    k_w = g * c1
    if eta == 0.0:
        kc = math.inf
    else:
        kc = max((m * c2 + eta) * (k_w - eta * c2) / eta, 0.0)
    period = math.nan
    if 0.0 < kc < math.inf:
        period = 2.0 * math.pi / math.sqrt(kc * c2 / (m * c2 + eta))
    return SteadySliding(V, mu, g * mu, k_w, c2, kc, period, f_n)


def stick_slip_cycles(
    t: np.ndarray, v: np.ndarray, f_t: np.ndarray, velocity: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The full stick-slip cycles of a history: their start, period and stress drop.

    A cycle runs from one slip event's velocity peak to the next: the peaks above twice the
    driving velocity and above half the history's highest (after an event a slider may ring on
    the interface's elastic layer: its smaller velocity peaks are not events). Its period is
    the peaks' distance in time, its stress drop the range of ``|f_t|`` over it.

    Args:
        t: Times (s), increasing.
        v: The slider's velocity (mm/s).
        f_t: The friction traction (MPa).
        velocity: The driving velocity (mm/s).

    Returns:
        ``(start, period, drop)``, one entry a cycle (empty without two events).
    """
    t, v, f = (np.asarray(a, dtype=float) for a in (t, v, f_t))
    f = np.abs(f)
    i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] > 2.0 * velocity)) + 1
    if i.size:
        i = i[v[i] >= 0.5 * v[i].max()]
    drops = [float(np.ptp(f[a : b + 1])) for a, b in itertools.pairwise(i)]
    return t[i[:-1]], np.diff(t[i]), np.array(drops)
