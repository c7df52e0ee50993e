"""High-accuracy reference of the RATE equations of the subloading-friction model (test support).

This module does not use the project's return map: it integrates the rate form of
``docs/model.md`` §2 ("Rate form") with :func:`scipy.integrate.solve_ivp` at a tight tolerance,
for one interface point under a prescribed, piecewise-linear gap history ``ubar(t)`` (the same
``[t, x1, x2, ubar_n]`` rows as a driver case under displacement control). State
``y = (up, mu, r)``::

    f_t = alpha_t (ubar_t - up),   f_n = alpha_n ubar_n,   g = 1 - exp(-c_n f_n),
    F = |f_t| / g,   t_f = f_t / |f_t|,
    X   = alpha_t / g - kappa (mu - mu_k) r                 (den = U(r) mu + X)
    num = alpha_t t_f . ubar_t' / g - alpha_n |f_t| g' ubar_n' / g^2 - xi (mu_s - mu) r
    plastic (num > 0):  lam = num / (U(r) mu + X),  up' = lam t_f,  r' = U(r) lam
    elastic (num <= 0): lam = 0,                     up' = 0,        r' = num / mu
    mu' = -kappa (mu - mu_k) lam + xi (mu_s - mu)

(The elastic ``r' = num / mu`` is ``d(F/mu)/dt`` written with ``r = F/mu``; it keeps ``r`` on the
subloading surface, and it makes ``r'`` continuous across the loading switch ``num = 0``.)

The singular start ``r = 0`` (``U(0) = inf``) is treated analytically, not by starting from a tiny
``r``: with ``V(r) = 1/U(r) = tan(pi r / 2) / u_tilde`` (``V(0) = 0``, finite below 1) the plastic
rates are rewritten as::

    r' = num / (mu + V X),    lam = V r'

which is the same system for ``r > 0`` and regular at ``r = 0`` (there ``r' = num / mu`` exactly,
as in the elastic branch, and ``lam = 0``): a sliding start from ``r = 0`` needs no special step.
The alternative, starting from a small ``r_start`` with the original ``U`` form, is available
(``r_start=``) so that tests can show it converges to the regularised answer as ``r_start -> 0``,
i.e. that the regularisation does not bias the result (measured on a reversal path of the Sec. 7
set: the difference is 0.59 ``r_start`` of the peak stress, linear in ``r_start``: the floor puts
``r`` above ``F/mu`` by ``r_start`` and that offset persists until the next projection).

Integration is piecewise, with a fresh ``solve_ivp`` call on each smooth piece:

* every path breakpoint (a reversal, a hold, a change of rate) and every sample time ends a piece
  (sample values are then integrator node values, not dense-output interpolants);
* inside a segment, terminal events end a piece where ``num`` changes sign (the elastic/plastic
  switch: its kink is resolved, not stepped over) and, in an elastic stretch, where
  ``f_t . ubar_t'`` crosses zero from below (``|f_t|`` passes through its minimum: in a straight
  reversal ``f_t`` passes through zero and ``t_f`` flips, a jump of the right-hand side). If
  ``|f_t|`` is zero there to round-off, ``up`` is set to ``ubar_t`` (``f_t = 0`` exactly) and
  ``r = 0``, and loading restarts in the direction of ``ubar_t'``. Along a path segment the gap
  rate is constant, so that minimum is watched once per segment (restarting right at it could
  fire the event again at once: a partial reversal in the plane cycled there, "too many
  switches").

At every piece end the invariant ``r = F / mu`` is checked (its largest violation is returned as
``drift``, a measure of the reference's own error) and ``r`` is then projected back onto it.
Contact must hold throughout (``ubar_n > 0``); ``den <= 0`` (a constitutive snap-back) raises.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
from scipy.integrate import solve_ivp

from subfric_dolfinx.constitutive import SubloadingLaw

__all__ = ["ReferenceSolution", "closed_form_no_softening", "solve_reference"]


@dataclasses.dataclass
class ReferenceSolution:
    """Reference history at the sample times.

    Attributes:
        t: Sample times, shape (n,).
        ubar: Gap ``(ubar_t1, [ubar_t2,] ubar_n)`` at the samples, shape (n, nt + 1).
        up: Plastic slip, shape (n, nt).
        mu: Hardening function, shape (n,).
        r: Normal-yield ratio, shape (n,).
        f_t: Tangential traction, shape (n, nt).
        f_n: Normal traction, shape (n,).
        drift: Largest ``|r - F/mu|`` seen at a piece end before projection.
        n_pieces: Number of ``solve_ivp`` calls.
        nfev: Total number of right-hand-side evaluations.
        switches: ``(t, kind)`` of the events that ended a piece: ``"load"`` / ``"unload"`` (the
            elastic/plastic switch, ``num`` changing sign) and ``"f_t min"`` (``|f_t|`` at a
            minimum in an elastic stretch; ``"f_t zero"`` when it passed through zero).
    """

    t: np.ndarray
    ubar: np.ndarray
    up: np.ndarray
    mu: np.ndarray
    r: np.ndarray
    f_t: np.ndarray
    f_n: np.ndarray
    drift: float
    n_pieces: int
    nfev: int
    switches: list[tuple[float, str]]


class _Point:
    """Right-hand side, events and helpers for one point under a given path."""

    def __init__(self, p: SubloadingLaw, path: np.ndarray, nt: int, r_start: float) -> None:
        self.p = p
        self.path = path
        self.nt = nt
        self.r_start = r_start

    # gap and its rate at t on segment k (rates are those of the segment: right derivative)
    def gap(self, t: float, k: int) -> tuple[np.ndarray, np.ndarray]:
        a, b = self.path[k], self.path[k + 1]
        cols = [1, 2, 3] if self.nt == 2 else [1, 3]
        v = (b[cols] - a[cols]) / (b[0] - a[0])
        return a[cols] + v * (t - a[0]), v

    def parts(self, t: float, y: np.ndarray, k: int) -> dict:
        p, nt = self.p, self.nt
        u, v = self.gap(t, k)
        up, mu, r = y[:nt], y[nt], y[nt + 1]
        ft = p.alpha_t * (u[:nt] - up)
        A = math.sqrt(float(ft @ ft))
        fn = p.alpha_n * u[nt]
        if not fn > 0.0:
            raise ValueError(f"the reference needs contact (ubar_n > 0): {u[nt]!r} at t = {t!r}")
        g = -math.expm1(-p.c_n * fn)
        dg = p.c_n * (1.0 - g)
        if A > 0.0:
            tf = ft / A
        else:  # f_t = 0: loading starts in the direction of the tangential gap rate
            nv = math.sqrt(float(v[:nt] @ v[:nt]))
            tf = v[:nt] / nv if nv > 0.0 else np.zeros(nt)
        num = (
            p.alpha_t * float(tf @ v[:nt]) / g
            - p.alpha_n * A * dg * v[nt] / g**2
            - p.xi * (p.mu_s - mu) * r
        )
        X = p.alpha_t / g - p.kappa * (mu - p.mu_k) * r
        return {"ft": ft, "A": A, "g": g, "tf": tf, "num": num, "X": X, "mu": mu, "r": r, "v": v}

    def rhs(self, t: float, y: np.ndarray, k: int, plastic: bool) -> np.ndarray:
        p, nt = self.p, self.nt
        q = self.parts(t, y, k)
        mu, r, num, X = q["mu"], q["r"], q["num"], q["X"]
        dy = np.empty(nt + 2)
        if plastic:
            rc = min(max(r, 0.0), 1.0)
            if self.r_start > 0.0:
                # original U form (the caller keeps r >= r_start > 0)
                U = p.u_tilde / math.tan(0.5 * math.pi * max(rc, 1e-300))
                den = U * mu + X
                if not den > 0.0:
                    raise FloatingPointError(f"den = {den!r} <= 0 at t = {t!r}: snap-back")
                lam = num / den
                rdot = U * lam
            else:
                V = math.tan(0.5 * math.pi * rc) / p.u_tilde
                den_v = mu + V * X  # = V * den
                if not den_v > 0.0:
                    raise FloatingPointError(f"den <= 0 at t = {t!r}: snap-back (no reference)")
                rdot = num / den_v
                lam = V * rdot
            dy[:nt] = lam * q["tf"]
        else:
            lam = 0.0
            rdot = num / mu
            dy[:nt] = 0.0
        dy[nt] = -p.kappa * (mu - p.mu_k) * lam + p.xi * (p.mu_s - mu)
        dy[nt + 1] = rdot
        return dy

    def num_scale(self, t: float, y: np.ndarray, k: int) -> float:
        """Size of the terms of ``num`` (for the event hysteresis)."""
        p, nt = self.p, self.nt
        q = self.parts(t, y, k)
        v = q["v"]
        return (
            p.alpha_t * math.sqrt(float(v[:nt] @ v[:nt])) / q["g"]
            + p.alpha_n * q["A"] * p.c_n * abs(v[nt]) / q["g"] ** 2
            + p.xi * p.mu_s
        )

    def invariant(self, t: float, y: np.ndarray, k: int) -> float:
        """``F / mu`` at ``(t, y)``."""
        q = self.parts(t, y, k)
        return q["A"] / (q["g"] * q["mu"])


def _segments_and_knots(path: np.ndarray, samples: np.ndarray) -> list[tuple[int, float, float]]:
    """Pieces ``(segment, t_a, t_b)`` between consecutive breakpoints and sample times."""
    knots = np.union1d(path[:, 0], samples)
    out = []
    for ta, tb in itertools.pairwise(knots):
        k = int(np.searchsorted(path[:, 0], ta, side="right") - 1)
        k = min(k, len(path) - 2)
        out.append((k, float(ta), float(tb)))
    return out


def solve_reference(
    params: SubloadingLaw,
    path: np.ndarray,
    t_samples: np.ndarray,
    *,
    n_tangential: int = 1,
    method: str = "LSODA",
    rtol: float = 1e-10,
    atol: float | None = None,
    max_step: float = np.inf,
    r_start: float = 0.0,
) -> ReferenceSolution:
    """Integrate the rate equations along a displacement-controlled path.

    Args:
        params: Material parameters (absolute form).
        path: Rows ``[t, ubar_t1, ubar_t2, ubar_n]``, times strictly increasing, gap linear in
            between; ``ubar_n > 0`` throughout. The state at ``path[0]`` is the virgin one
            (``up = 0``, ``mu = params.mu_initial``) with ``r = F/mu``, which must not exceed 1.
        t_samples: Output times within the path (non-decreasing).
        n_tangential: 1 (``ubar_t2`` must then be 0) or 2.
        method: ``solve_ivp`` method (``"LSODA"``, ``"Radau"``, ...).
        rtol: Relative tolerance.
        atol: Absolute tolerance for every component of ``(up, mu, r)``; by default ``rtol``
            times the scales ``(max |ubar_t| on the path (at least 1e-3 mm), mu_s, 1)``.
        max_step: Passed to ``solve_ivp``.
        r_start: 0 (default): the regularised form, exact at ``r = 0``. ``> 0``: the original
            ``U(r)`` form with ``r`` floored at ``r_start`` whenever sliding (re)starts from
            ``r < r_start`` (to show that the regularisation does not bias the result).

    Returns:
        The reference history at the sample times.
    """
    p = params
    nt = int(n_tangential)
    path = np.asarray(path, dtype=float)
    samples = np.asarray(t_samples, dtype=float)
    if nt == 1 and np.any(path[:, 2] != 0.0):
        raise ValueError("n_tangential = 1 needs ubar_t2 = 0 on the whole path")
    if np.any(np.diff(path[:, 0]) <= 0.0):
        raise ValueError("path times must increase strictly")
    if np.any(path[:, 3] <= 0.0):
        raise ValueError("the reference needs contact (ubar_n > 0) on the whole path")
    pt = _Point(p, path, nt, r_start)
    u_scale = max(float(np.abs(path[:, 1:3]).max()), 1e-3)
    if atol is None:
        atol_v = rtol * np.array([u_scale] * nt + [p.mu_s, 1.0])
    else:
        atol_v = np.full(nt + 2, float(atol))

    y = np.zeros(nt + 2)
    y[nt] = p.mu_initial
    y[nt + 1] = pt.invariant(path[0, 0], y, 0)
    if y[nt + 1] > 1.0:
        raise ValueError("the initial gap lies outside the normal-yield surface")
    drift = 0.0
    n_pieces = 0
    nfev = 0
    switches: list[tuple[float, str]] = []
    store: dict[float, np.ndarray] = {float(path[0, 0]): y.copy()}

    def phase(t: float, y: np.ndarray, k: int) -> bool:
        return pt.parts(t, y, k)["num"] > 0.0

    crossed = -1  # the path segment whose elastic |f_t| minimum has been passed
    for k, ta, tb in _segments_and_knots(path, samples):
        t = ta
        plastic = phase(t, y, k)
        guard = 0
        while t < tb:
            guard += 1
            if guard > 10000:
                raise RuntimeError(f"too many switches on [{ta}, {tb}]")
            if plastic and r_start > 0.0 and y[nt + 1] < r_start:
                y[nt + 1] = r_start

            # a tiny hysteresis keeps a num that stays at zero (rest at r = 0) from firing
            shift = (1.0 if plastic else -1.0) * (1e-13 * pt.num_scale(t, y, k) + 1e-300)

            def ev_num(tt, yy, k, _plastic, shift=shift):
                return pt.parts(tt, yy, k)["num"] + shift

            ev_num.terminal = True
            ev_num.direction = -1.0 if plastic else 1.0
            events = [ev_num]
            # along a segment the gap rate is constant: in an elastic stretch f_t is linear in t
            # and |f_t| has one minimum, so once passed it is not watched again in the segment
            # (a restart right at the event could fire it again at once, forever)
            if not plastic and crossed != k and np.any(pt.gap(t, k)[1][:nt] != 0.0):
                # (shifted up by a tiny amount: a start exactly at zero, e.g. right at a turn of
                # the sliding direction, must not fire)
                vt = pt.gap(t, k)[1][:nt]
                c_shift = 1e-13 * p.alpha_t * u_scale * math.sqrt(float(vt @ vt))

                def ev_cross(tt, yy, k, _plastic, c_shift=c_shift):
                    q = pt.parts(tt, yy, k)
                    return float(q["ft"] @ q["v"][:nt]) + c_shift

                ev_cross.terminal = True
                ev_cross.direction = 1.0
                events.append(ev_cross)
            sol = solve_ivp(
                pt.rhs,
                (t, tb),
                y,
                method=method,
                rtol=rtol,
                atol=atol_v,
                max_step=max_step,
                events=events,
                args=(k, plastic),
            )
            n_pieces += 1
            nfev += sol.nfev
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed on [{t}, {tb}]: {sol.message}")
            t_new, y = float(sol.t[-1]), sol.y[:, -1].copy()
            fired = sol.status == 1
            # project r back onto the invariant r = F/mu (and record the drift)
            inv = pt.invariant(t_new, y, k)
            drift = max(drift, abs(y[nt + 1] - inv))
            y[nt + 1] = inv
            if fired and len(sol.t_events) > 1 and sol.t_events[1].size:
                # |f_t| at a minimum: through zero (reversal) -> f_t = 0 exactly, r = 0
                q = pt.parts(t_new, y, k)
                zero = q["A"] <= 1e-9 * p.alpha_t * u_scale
                if zero:
                    u, _ = pt.gap(t_new, k)
                    y[:nt] = u[:nt]
                    y[nt + 1] = 0.0
                switches.append((t_new, "f_t zero" if zero else "f_t min"))
                crossed = k
                plastic = phase(t_new, y, k)
            elif fired:
                switches.append((t_new, "unload" if plastic else "load"))
                plastic = not plastic  # num changed sign: the elastic/plastic switch
            t = t_new if fired else tb
        store[tb] = y.copy()

    out_y = np.array([store[float(s)] for s in samples])
    ubar = np.array([pt.gap(float(s), _seg_of(path, float(s)))[0] for s in samples])
    ft = p.alpha_t * (ubar[:, :nt] - out_y[:, :nt])
    return ReferenceSolution(
        t=samples,
        ubar=ubar,
        up=out_y[:, :nt],
        mu=out_y[:, nt],
        r=out_y[:, nt + 1],
        f_t=ft,
        f_n=p.alpha_n * ubar[:, nt],
        drift=drift,
        n_pieces=n_pieces,
        nfev=nfev,
        switches=switches,
    )


def _seg_of(path: np.ndarray, t: float) -> int:
    k = int(np.searchsorted(path[:, 0], t, side="right") - 1)
    return min(max(k, 0), len(path) - 2)


def closed_form_no_softening(
    params: SubloadingLaw, ubar_t: np.ndarray, f_n: float
) -> tuple[np.ndarray, np.ndarray]:
    """Monotonic 1-D sliding from rest with ``kappa = xi = 0`` at constant ``f_n``.

    ``mu = mu_initial`` stays constant, ``cos(pi r / 2) = exp(-pi u_tilde up / 2)`` and
    ``ubar_t = up + g mu r(up) / alpha_t``; solved for ``up`` by bisection to round-off.

    Returns:
        ``(up, f_t)`` at the given ``ubar_t >= 0``.
    """
    p = params
    g = -math.expm1(-p.c_n * f_n)
    mu = p.mu_initial

    def r_of(up: np.ndarray) -> np.ndarray:
        return (2.0 / np.pi) * np.arccos(np.exp(-0.5 * np.pi * p.u_tilde * up))

    u = np.asarray(ubar_t, dtype=float)
    lo, hi = np.zeros_like(u), u.copy()
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        res = mid + g * mu * r_of(mid) / p.alpha_t - u
        lo, hi = np.where(res < 0.0, mid, lo), np.where(res < 0.0, hi, mid)
    up = 0.5 * (lo + hi)
    return up, g * mu * r_of(up)
