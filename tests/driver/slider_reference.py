"""Independent references of the spring-slider (tests only; numpy and scipy, no package code).

* :func:`rates`: the law's rate equations (``docs/model.md``, ``../shared/MODEL.md`` "Rate form")
  with the mass, the spring and the optional dashpot, in the variables ``y = (delta, v, mu, r)``
  (``delta = x_L - u`` the spring's stretch, ``v`` the slider's velocity) while the interface slides
  (``f_t = g r mu``, plastic loading), and :func:`jacobian`, their Jacobian at steady sliding
  derived by hand (checked against finite differences of :func:`rates` in the tests);
* :func:`critical_stiffness`: the stiffness where the largest real part of the Jacobian's
  eigenvalues (``numpy.linalg.eigvals``) crosses zero (``scipy.optimize.brentq``);
* :func:`integrate_ode`: the rate equations of the whole stick-slip cycle, in
  ``(u, v, up, mu)`` with ``r = f_t / (g mu)``, ``lam = max(num, 0) / den``, integrated by
  ``scipy.integrate.solve_ivp`` (Radau, tight tolerances): the reference of the limit cycle.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

STICK_SLIP_LAW = {
    "alpha_t": 5000.0,
    "alpha_n": 5000.0,
    "mu_s": 500.0,
    "mu_k": 300.0,
    "kappa": 20.0,
    "xi": 2.0,
    "u_tilde": 50.0,
    "c_n": 2e-4,
}
"""The law of the stick-slip checks, the point map's slider calls and the slider benchmark
(keyword arguments of ``SubloadingLaw``; plain numbers here, the reference takes them as
:class:`Params`)."""


@dataclasses.dataclass(frozen=True)
class Params:
    """The law's parameters (absolute form), the normal stress, the mass, the velocity."""

    alpha_t: float
    mu_s: float
    mu_k: float
    kappa: float
    xi: float
    u_tilde: float
    c_n: float
    f_n: float
    mass: float
    velocity: float
    damping: float = 0.0  # the dashpot to the base, MPa s/mm

    @property
    def g(self) -> float:
        return 1.0 - math.exp(-self.c_n * self.f_n)

    def mu_steady(self, V: float | None = None) -> float:
        """``mu`` of steady sliding at ``V``: ``xi (mu_s - mu) = kappa (mu - mu_k) V``."""
        V = self.velocity if V is None else V
        return (self.kappa * self.mu_k * V + self.xi * self.mu_s) / (self.kappa * V + self.xi)


def U(p: Params, r: float) -> float:
    return p.u_tilde / math.tan(0.5 * math.pi * r)


def dU(p: Params, r: float) -> float:
    return -p.u_tilde * 0.5 * math.pi / math.sin(0.5 * math.pi * r) ** 2


def rates(p: Params, k: float, y: np.ndarray) -> np.ndarray:
    """``dy/dt`` of ``y = (delta, v, mu, r)`` while sliding (plastic loading)."""
    delta, v, mu, r = y
    g = p.g
    num = p.alpha_t * v - g * r * p.xi * (p.mu_s - mu)
    den = p.alpha_t + g * (U(p, r) * mu - p.kappa * r * (mu - p.mu_k))
    lam = num / den
    return np.array(
        [
            p.velocity - v,
            (k * delta - g * r * mu - p.damping * v) / p.mass,
            -p.kappa * (mu - p.mu_k) * lam + p.xi * (p.mu_s - mu),
            U(p, r) * lam,
        ]
    )


def steady(p: Params, k: float) -> np.ndarray:
    """Steady sliding at the driving velocity: ``((g mu_ss + eta V) / k, V, mu_ss, 1)``."""
    mu = p.mu_steady()
    return np.array([(p.g * mu + p.damping * p.velocity) / k, p.velocity, mu, 1.0])


def jacobian(p: Params, k: float) -> np.ndarray:
    """The Jacobian of :func:`rates` at steady sliding, by hand (``U(1) = 0``, ``lam = V``)."""
    g, V, m = p.g, p.velocity, p.mass
    mu = p.mu_steady()
    dmu = mu - p.mu_k
    den = p.alpha_t - g * p.kappa * dmu  # at r = 1
    lam_v = p.alpha_t / den
    lam_mu = g * p.xi / den - V / den * g * (-p.kappa)  # U(1) = 0
    lam_r = -g * p.xi * (p.mu_s - mu) / den - V / den * g * (dU(p, 1.0) * mu - p.kappa * dmu)
    J = np.zeros((4, 4))
    J[0, 1] = -1.0
    J[1, 0] = k / m
    J[1, 1] = -p.damping / m
    J[1, 2] = -g / m
    J[1, 3] = -g * mu / m
    J[2, 1] = -p.kappa * dmu * lam_v
    J[2, 2] = -p.kappa * V - p.kappa * dmu * lam_mu - p.xi
    J[2, 3] = -p.kappa * dmu * lam_r
    J[3, 3] = dU(p, 1.0) * V
    return J


def growth_rate(p: Params, k: float) -> float:
    """The largest real part of the eigenvalues of :func:`jacobian` (1/s)."""
    return float(np.max(np.linalg.eigvals(jacobian(p, k)).real))


def critical_stiffness(p: Params, lo: float, hi: float) -> float:
    """The stiffness in ``[lo, hi]`` where steady sliding turns unstable (growth rate 0)."""
    return brentq(lambda k: growth_rate(p, k), lo, hi, xtol=1e-12 * hi, rtol=1e-13)


def integrate_ode(
    p: Params,
    k: float,
    t_end: float,
    x0: float = 0.0,
    max_step: float = np.inf,
    y0: tuple[float, float, float, float] | None = None,
    t0: float = 0.0,
):
    """The stick-slip history from rest by the rate equations (``solve_ivp``, Radau).

    ``y = (u, v, up, mu)``, ``f_t = alpha_t (u - up)``, ``r = f_t / (g mu)``; plastic loading
    ``lam = max(num, 0) / den`` (``num``, ``den`` of :func:`rates`). Starts from a virgin rested
    contact (``mu = mu_s``, no slip) at rest with the load point at ``x0``, or from ``y0`` at
    ``t0`` (the load point at ``x0 + V t`` all along).
    """
    g = p.g

    def f(t, y):
        u, v, up, mu = y
        ft = p.alpha_t * (u - up)
        r = min(max(ft / (g * mu), 1e-300), 1.0)
        num = p.alpha_t * v - g * r * p.xi * (p.mu_s - mu)
        den = p.alpha_t + g * (U(p, r) * mu - p.kappa * r * (mu - p.mu_k))
        lam = max(num, 0.0) / den
        xl = x0 + p.velocity * t
        return [
            v,
            (k * (xl - u) - ft - p.damping * v) / p.mass,
            lam,
            -p.kappa * (mu - p.mu_k) * lam + p.xi * (p.mu_s - mu),
        ]

    return solve_ivp(
        f,
        (t0, t_end),
        [0.0, 0.0, 0.0, p.mu_s] if y0 is None else list(y0),
        method="Radau",
        rtol=1e-9,
        atol=1e-12,
        dense_output=True,
        max_step=max_step,
    )
