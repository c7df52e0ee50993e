"""The spring-slider (``driver/slider.py``) against independent references (issue 38, item 4).

* Static/kinetic (slip-weakening) friction: the closed form of undamped stick-slip, slip per
  event ``2 (F_s - F_k) / k`` and slip duration ``pi sqrt(m / k)`` for slow driving (1 %).
* The subloading law: the linear stability analysis of steady sliding (``slider_reference``:
  the rate equations with the mass and the spring, the Jacobian derived by hand and checked by
  finite differences, its eigenvalues by numpy) against the growth rate and the frequency of a
  small perturbation in the simulation (2 %). Undamped, the analysis finds no finite critical
  stiffness: the characteristic cubic of steady sliding fails the Routh-Hurwitz condition for
  every ``k`` (the law has no direct velocity effect, like rate-and-state friction with
  ``a = 0``), so the growth rate is positive at every stiffness and falls like ``1 / k``. With
  a dashpot there is one: from the eigenvalues, against the onset found by simulation (2 %).
* The limit cycle of stick-slip (period, stress drop) at two driving velocities against the
  rate equations integrated by ``scipy.integrate.solve_ivp`` (Radau) from the same start (2 %).
* ``driver.steady_sliding`` (the critical stiffness in closed form, the onset's period) against
  the eigenvalues; with a dashpot, the settled limit cycle (averaged over the cycles of a run's
  second half, which agree to 0.3 %) against the rate equations' at two velocities (1 %);
  slide-hold-slide: the recovery in the hold against the law's closed form and the friction's
  peak after it against the rate equations (0.5 %).
* Bad cases: each bad value named.
"""

from __future__ import annotations

import dataclasses
import json
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
    SubloadingLaw,
    Variable,
    preset,
)
from subfric_dolfinx.driver import (
    CaseError,
    SliderCase,
    parse_case,
    run_case,
    run_slider,
    steady_sliding,
    stick_slip_cycles,
)
from tests.driver import slider_reference as ref

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


# --------------------------------------------------------------------------------------------
# The subloading law: steady sliding and stick-slip

LAW = SubloadingLaw(**ref.STICK_SLIP_LAW)
FN, MASS = 300.0, 1.0  # MPa, tonne/mm^2


def params(V: float) -> ref.Params:
    names = ("alpha_t", "mu_s", "mu_k", "kappa", "xi", "u_tilde", "c_n")
    return ref.Params(**{n: getattr(LAW, n) for n in names}, f_n=FN, mass=MASS, velocity=V)


@pytest.mark.parametrize("k", [50.0, 200.0, 1000.0])
def test_jacobian_of_steady_sliding_against_finite_differences(k):
    p = params(0.1)
    y = ref.steady(p, k)
    np.testing.assert_allclose(ref.rates(p, k, y), 0.0, atol=1e-9)
    J = ref.jacobian(p, k)
    Jfd = np.zeros((4, 4))
    for j in range(4):
        h = 1e-6 * max(abs(y[j]), 1e-3)
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        if j == 3:  # r <= 1: a one-sided difference of second order
            yp, ym = y.copy(), y.copy()
            ym[j] -= h
            y2 = y.copy()
            y2[j] -= 2 * h
            Jfd[:, j] = 3 * ref.rates(p, k, y) - 4 * ref.rates(p, k, ym) + ref.rates(p, k, y2)
            Jfd[:, j] /= 2 * h
            continue
        Jfd[:, j] = (ref.rates(p, k, yp) - ref.rates(p, k, ym)) / (2 * h)
    np.testing.assert_allclose(J, Jfd, rtol=1e-5, atol=1e-6 * np.abs(J).max())


def test_steady_sliding_is_unstable_at_every_stiffness():
    """No finite critical stiffness: the growth rate is positive from 1 to 1e7 MPa/mm and falls
    like 1 / k (the cubic's Routh-Hurwitz condition reduces to ``-g c1 > 0``)."""
    p = params(0.1)
    ks = np.logspace(0, 7, 29)
    sig = np.array([ref.growth_rate(p, k) for k in ks])
    print("k sigma:", list(zip(ks[::4].round(1), sig[::4], strict=True)))
    assert np.all(sig > 0.0)
    tail = ks[-5:] * sig[-5:]
    np.testing.assert_allclose(tail, tail[-1], rtol=1e-3)
    # the cubic m s^3 + m c2 s^2 + (k - g c1) s + k c2 of (delta, v, mu): its roots sum to -c2
    # and its real root tends to -k c2 / (k - g c1), so the pair's real part tends to
    # g c1 c2 / (2 (k - g c1)) > 0: positive at every stiffness, independent of the mass
    J = ref.jacobian(p, 1.0)
    gc1 = -J[2, 1] * (-J[1, 2] * MASS)  # g * kappa (mu_ss - mu_k) dlam/dv
    c2 = -J[2, 2]
    for k in (1e5, 1e6, 1e7):
        assert ref.growth_rate(p, k) == pytest.approx(gc1 * c2 / (2 * (k - gc1)), rel=1e-3)
    light = dataclasses.replace(p, mass=1e-6)
    assert ref.growth_rate(light, 1e6) == pytest.approx(ref.growth_rate(p, 1e6), rel=1e-3)


def steady_state(p: ref.Params) -> tuple[InterfaceState, float]:
    """The interface point sliding steadily at ``p.velocity`` (``r = 1``, ``mu = mu_ss``) and
    its traction."""
    mu = p.mu_steady()
    ft = p.g * mu
    arrays = {"up": np.zeros((1, 1)), "mu": np.array([mu]), "r": np.array([1.0])}
    arrays["f"] = np.array([[ft, FN]])
    return InterfaceState(arrays, 1), ft


@pytest.mark.parametrize("k", [20.0, 200.0, 1000.0])
def test_growth_and_frequency_of_a_perturbation_against_the_eigenvalues(k):
    """A small velocity perturbation of steady sliding grows as the Jacobian's eigenvalue says:
    monotonically below the slip-weakening stiffness (k = 20: a real eigenvalue), as an
    oscillation above it (k = 200, 1000: a complex pair)."""
    V = 0.1
    p = params(V)
    ev = np.linalg.eigvals(ref.jacobian(p, k))
    lam = ev[np.argmax(ev.real)]
    st, ft = steady_state(p)
    u0 = ft / LAW.alpha_t
    if lam.imag == 0.0:  # 12 e-folds, the second half fitted (the other modes decayed)
        t_end, dt_max = 12.0 / lam.real, 6e-3 / lam.real
    else:
        t_end, dt_max = 6.0, 2 * np.pi * np.sqrt(MASS / k) / 100
    eps = perturbation(lam.real, t_end)
    case = SliderCase(LAW, MASS, k, V, FN, t_end, x0=u0 + ft / k, v0=V * (1 + eps), dt_max=dt_max)
    res = run_slider(case, state=st)
    t, v = res.samples["t"], res.samples["v"] - V
    if lam.imag == 0.0:
        i = np.flatnonzero(t > 0.5 * t_end)
        assert np.all(v[i] > 0.0)  # no oscillation
        sigma = np.polyfit(t[i], np.log(v[i]), 1)[0]
        omega = 0.0
    else:
        i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:])) + 1
        i = i[t[i] > 1.0]  # after the decay of the other modes
        sigma = np.polyfit(t[i], np.log(v[i]), 1)[0]
        omega = 2 * np.pi / np.mean(np.diff(t[i]))
    print(
        f"k = {k}: growth {sigma:.6g} 1/s (eigenvalue {lam.real:.6g}), frequency "
        f"{omega:.6g} rad/s ({lam.imag:.6g}); largest {v[i].max():.3g} mm/s"
    )
    assert v[i].max() < 1e-3 * V  # still linear
    assert sigma == pytest.approx(lam.real, rel=0.02)
    assert omega == pytest.approx(lam.imag, rel=0.02, abs=1e-12)


def perturbation(sigma: float, t_end: float) -> float:
    """The relative velocity perturbation that grows to about 1e-5 at ``t_end`` (linear, and far
    above the rounding and the Newton tolerance of the steps)."""
    return min(max(1e-5 * math.exp(-sigma * t_end), 1e-12), 1e-5)


def measured_growth(k: float, p: ref.Params, t_end: float) -> tuple[float, float]:
    """(growth rate, frequency) of a small perturbation of steady sliding in the simulation,
    from the peaks of ``v - V`` after the first second (the other modes decayed)."""
    V = p.velocity
    st, ft = steady_state(p)
    u0 = ft / LAW.alpha_t
    x0 = u0 + (ft + p.damping * V) / k
    dt_max = 2 * np.pi * np.sqrt(MASS / k) / 100
    case = SliderCase(
        LAW,
        MASS,
        k,
        V,
        FN,
        t_end,
        x0=x0,
        v0=V * (1 + perturbation(ref.growth_rate(p, k), t_end)),
        dt_max=dt_max,
        damping=p.damping,
    )
    res = run_slider(case, state=st)
    t, v = res.samples["t"], res.samples["v"] - V
    i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:])) + 1
    i = i[t[i] > 1.0]
    assert v[i].max() < 1e-3 * V  # still linear
    return np.polyfit(t[i], np.log(v[i]), 1)[0], 2 * np.pi / np.mean(np.diff(t[i]))


def test_critical_stiffness_with_a_dashpot_against_the_onset_by_simulation():
    """With a dashpot (eta = 1 MPa s/mm) steady sliding has a critical stiffness: from the
    eigenvalues (brentq on the largest real part), checked against the Routh-Hurwitz closed form
    ``(m c2 + eta)(g c1 - eta c2) / eta``; the simulation's growth rates at 0.97 and 1.03 times
    it change sign and their linear interpolation gives the onset within 2 %."""
    p = dataclasses.replace(params(0.1), damping=1.0)
    kc = ref.critical_stiffness(p, 100.0, 2000.0)
    J = ref.jacobian(p, kc)
    gc1, c2 = -J[2, 1] * (-J[1, 2] * MASS), -J[2, 2]
    assert kc == pytest.approx((MASS * c2 + p.damping) * (gc1 - p.damping * c2) / p.damping)
    ks = (0.97 * kc, 1.03 * kc)
    (s1, w1), (s2, w2) = (measured_growth(k, p, 12.0) for k in ks)
    eig = [np.linalg.eigvals(ref.jacobian(p, k)) for k in ks]
    onset = ks[0] + (ks[1] - ks[0]) * s1 / (s1 - s2)
    print(
        f"critical stiffness {kc:.6g} MPa/mm (eigenvalues), onset by simulation {onset:.6g}; "
        f"growth {s1:.4g}, {s2:.4g} 1/s (eigenvalues {max(e.real.max() for e in eig[:1]):.4g}, "
        f"{eig[1].real.max():.4g}); frequency {w1:.5g}, {w2:.5g} rad/s"
    )
    assert s1 > 0.0 > s2  # unstable below, stable above
    assert onset == pytest.approx(kc, rel=0.02)


def cycle(t, v, f, V):
    """(period, stress drop) of the last full cycle: between the last two velocity peaks."""
    i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] > 2 * V)) + 1
    a, b = i[-2], i[-1]
    seg = slice(a, b + 1)
    return t[b] - t[a], f[seg].max() - f[seg].min()


@pytest.mark.parametrize(("V", "t_end"), [(0.1, 20.0), (0.3, 12.0)])
def test_limit_cycle_against_the_rate_equations(V, t_end):
    """Stick-slip from a rested contact: period and stress drop of the last cycle against
    ``solve_ivp`` on the rate equations (k = 50 MPa/mm, below the slip-weakening stiffness)."""
    k = 50.0
    p = params(V)
    dt_max = 2 * np.pi * np.sqrt(MASS / k) / 400
    res = run_slider(SliderCase(LAW, MASS, k, V, FN, t_end, dt_max=dt_max, err_tol=1e-8))
    s = res.samples
    T, drop = cycle(s["t"], s["v"], s["f_t"], V)
    o = ref.integrate_ode(p, k, t_end, max_step=0.01)
    assert o.status == 0
    T_ref, drop_ref = cycle(o.t, o.y[1], LAW.alpha_t * (o.y[0] - o.y[2]), V)
    print(
        f"V = {V}: period {T:.5g} s (rate equations {T_ref:.5g}), stress drop {drop:.5g} MPa "
        f"({drop_ref:.5g}); {res.n_steps} steps"
    )
    assert T == pytest.approx(T_ref, rel=0.02)
    assert drop == pytest.approx(drop_ref, rel=0.02)


# --------------------------------------------------------------------------------------------
# The package's steady-sliding analysis, settled limit cycles, hold-time recovery


DAMPED = 5.0  # MPa s/mm: the dashpot of the settled cycles (the stick mode's ringing dies out)


@pytest.mark.parametrize(("V", "eta"), [(0.1, 1.0), (0.1, 5.0), (0.03, 5.0), (0.3, 2.0)])
def test_the_critical_stiffness_of_steady_sliding_against_the_eigenvalues(V, eta):
    """``driver.steady_sliding`` (the Routh-Hurwitz closed form) against the stiffness where the
    largest real part of the reference Jacobian's eigenvalues crosses zero, and its onset
    period against the crossing pair's frequency."""
    p = dataclasses.replace(params(V), damping=eta)
    ss = steady_sliding(LAW, FN, V, MASS, eta)
    assert ss.mu == pytest.approx(p.mu_steady(), rel=1e-13)
    assert ss.traction == pytest.approx(p.g * p.mu_steady(), rel=1e-13)
    kc = ref.critical_stiffness(p, 10.0, 5000.0)
    ev = np.linalg.eigvals(ref.jacobian(p, kc))
    omega = np.abs(ev[np.argmax(ev.real)].imag)
    print(f"V = {V}, eta = {eta}: k_c {ss.critical_stiffness:.8g} MPa/mm (eigenvalues {kc:.8g})")
    assert ss.critical_stiffness == pytest.approx(kc, rel=1e-9)
    assert ss.onset_period == pytest.approx(2 * np.pi / omega, rel=1e-6)
    for k in (0.9 * kc, 1.1 * kc):  # unstable below, stable above
        assert (ref.growth_rate(p, k) > 0.0) == (k < ss.critical_stiffness)


@pytest.mark.parametrize("V", [0.05, 0.1])
def test_the_onset_from_rest_brackets_the_critical_stiffness(V):
    """The full nonlinear runs from a rested contact (a large perturbation, not a linear one),
    with the dashpot eta = 5 MPa s/mm: at 0.98 ``k_c`` stick-slip does not die out (the
    friction's range over each 10 s of 40 does not shrink), at 1.02 ``k_c`` it decays to steady
    sliding (each range under 0.7 of the one before): the onset lies within 2 % of the analysis'
    ``k_c``."""
    ss = steady_sliding(LAW, FN, V, MASS, DAMPED)
    ranges = {}
    for ratio in (0.98, 1.02):
        k = ratio * ss.critical_stiffness
        s = run_slider(SliderCase(LAW, MASS, k, V, FN, 40.0, damping=DAMPED)).samples
        t = s["t"]
        ranges[ratio] = np.array(
            [np.ptp(s["f_t"][(t >= a) & (t <= a + 10.0)]) for a in (10, 20, 30)]
        )
    print(f"V = {V}: k_c {ss.critical_stiffness:.6g} MPa/mm; ranges (MPa) {ranges}")
    below, above = ranges[0.98], ranges[1.02]
    assert np.all(below[1:] > 0.9 * below[:-1]) and below[-1] > 0.5
    assert np.all(above[1:] < 0.7 * above[:-1])


def test_steady_sliding_without_a_critical_stiffness():
    """Undamped: ``k_c = inf`` (unstable at every stiffness); a dashpot above ``k_w / c2``
    (here V = 1 mm/s, eta = 2 MPa s/mm): ``k_c = 0``, the eigenvalues stable at every
    stiffness; a bad value named."""
    ss = steady_sliding(LAW, FN, 0.1, MASS)
    assert ss.critical_stiffness == math.inf and math.isnan(ss.onset_period)
    J = ref.jacobian(params(0.1), 1.0)
    assert ss.weakening == pytest.approx(-J[2, 1] * (-J[1, 2] * MASS), rel=1e-12)
    ss = steady_sliding(LAW, FN, 1.0, MASS, 2.0)
    assert ss.critical_stiffness == 0.0
    p = dataclasses.replace(params(1.0), damping=2.0)
    assert all(ref.growth_rate(p, k) < 0.0 for k in (1.0, 10.0, 100.0, 1e4))
    with pytest.raises(CaseError, match="field 'velocity' must be > 0, got 0"):
        steady_sliding(LAW, FN, 0.0, MASS)
    with pytest.raises(CaseError, match=r"field 'damping' must be >= 0, got -1\.0"):
        steady_sliding(LAW, FN, 0.1, MASS, -1.0)
    with pytest.raises(CaseError, match="needs the subloading law, got StaticKinetic"):
        steady_sliding(StaticKinetic(1e3, 1e3, 0.6, 0.4), FN, 0.1, MASS)  # type: ignore[arg-type]
    soft = SubloadingLaw(**{**ref.STICK_SLIP_LAW, "alpha_t": 100.0})  # below g kappa (mu - mu_k)
    with pytest.raises(
        CaseError, match=r"steady sliding at velocity 0\.1 snaps back: alpha_t = 100"
    ):
        steady_sliding(soft, FN, 0.1, MASS)


def test_stick_slip_cycles_of_a_known_signal():
    """A velocity with a peak of 1 every 2 s (and ringing peaks of 0.3 between), a friction
    falling by 5 in each event: periods 2, drops 5; no events, no cycles."""
    t = np.linspace(0.0, 10.0, 10001)
    phase = (t - 0.5) % 2.0
    v = np.exp(-(((phase - 1.0) / 0.05) ** 2)) + 0.3 * np.exp(-(((phase - 1.5) / 0.02) ** 2))
    f = 20.0 + 5.0 * np.where(phase < 1.0, phase, 0.0)
    start, T, drop = stick_slip_cycles(t, v, -f, 0.01)
    np.testing.assert_allclose(start, [1.5, 3.5, 5.5, 7.5])
    np.testing.assert_allclose(T, 2.0)
    np.testing.assert_allclose(drop, 5.0, rtol=1e-3)
    empty = stick_slip_cycles(t, np.full_like(t, 0.01), f, 0.01)
    assert all(a.size == 0 for a in empty)


@pytest.mark.parametrize(("V", "cycles"), [(0.1, 12), (0.15, 12)])
def test_settled_limit_cycle_with_a_dashpot_against_the_rate_equations(V, cycles):
    """With a dashpot (eta = 5 MPa s/mm; k = 50 MPa/mm, below ``k_c``) stick-slip settles to
    one limit cycle: the slider's cycles of the run's second half agree to 0.3 % with each
    other, and their mean period and stress drop with the rate equations' cycles (solve_ivp,
    two cycles from the slider's state in the stick before its third last: the attractor, not
    the slider's trajectory) within 1 %. (Undamped, the cycles do not settle: the ringing of the
    stick mode on the interface's elastic layer sets each event's start, so they scatter.)"""
    k = 50.0
    p = dataclasses.replace(params(V), damping=DAMPED)
    ss = steady_sliding(LAW, FN, V, MASS, DAMPED)
    assert k < ss.critical_stiffness
    T0 = 2 * np.pi * np.sqrt(MASS / k)
    t_end = cycles * 0.26 / V  # (the period is about 0.26 / V s)
    case = SliderCase(LAW, MASS, k, V, FN, t_end, dt_max=T0 / 400, damping=DAMPED)
    s = run_slider(case).samples
    start, T, drop = stick_slip_cycles(s["t"], s["v"], s["f_t"], V)
    late = start > 0.5 * t_end
    assert late.sum() >= 4
    for x in (T[late], drop[late]):
        assert np.ptp(x) < 3e-3 * x.mean()
    i = int(np.searchsorted(s["t"], start[-3] - 0.5 * T[-1]))
    y0 = (s["u"][i], s["v"][i], s["up"][i], s["mu"][i])
    o = ref.integrate_ode(p, k, start[-3] + 2.3 * T[-1], max_step=5e-3, y0=y0, t0=s["t"][i])
    assert o.status == 0
    _, T_ref, drop_ref = stick_slip_cycles(o.t, o.y[1], LAW.alpha_t * (o.y[0] - o.y[2]), V)
    print(
        f"V = {V}: settled period {T[late].mean():.5g} s (rate equations {T_ref.mean():.5g}), "
        f"stress drop {drop[late].mean():.5g} MPa ({drop_ref.mean():.5g}); "
        f"{late.sum()} and {T_ref.size} cycles"
    )
    assert T_ref.size >= 2
    assert T[late].mean() == pytest.approx(T_ref.mean(), rel=0.01)
    assert drop[late].mean() == pytest.approx(drop_ref.mean(), rel=0.01)


@pytest.mark.parametrize("hold", [0.2, 2.0])
def test_hold_time_recovery_against_the_rate_equations(hold):
    """Slide-hold-slide: the contact sliding steadily at V = 0.1 mm/s stopped (at rest, the
    spring holding the kinetic traction) for ``hold`` s, then driven at V again. In the hold
    ``mu`` recovers as the law's closed form ``mu_s - (mu_s - mu_ss) exp(-xi t)`` (elastic:
    nothing slips); the friction's first peak after it against the rate equations (solve_ivp
    from the held state) within 0.5 %, between the steady traction and ``g mu_s`` (``mu``
    still recovers while the spring reloads, and weakens with the slip before the peak)."""
    V, k = 0.1, 50.0
    ss = steady_sliding(LAW, FN, V, MASS)
    u0 = ss.traction / LAW.alpha_t
    x0 = u0 + ss.traction / k
    res = run_slider(SliderCase(LAW, MASS, k, 0.0, FN, hold, x0=x0), state=ss.state(), u0=u0)
    mu_h = LAW.mu_s - (LAW.mu_s - ss.mu) * math.exp(-LAW.xi * hold)
    assert res.samples["mu"][-1] == pytest.approx(mu_h, rel=1e-12)
    assert res.samples["up"][-1] == 0.0 and abs(res.end_motion[1]) < 1e-12
    p = params(V)
    t_end = (p.g * LAW.mu_s - ss.traction) / (k * V)  # past the peak: the spring at g mu_s
    reload = SliderCase(LAW, MASS, k, V, FN, t_end, x0=x0, dt_max=2e-3)
    s = run_slider(reload, state=res.end_state, u0=res.end_motion[0]).samples
    f = s["f_t"]
    i = np.flatnonzero((f[1:-1] > f[:-2]) & (f[1:-1] >= f[2:]))[0] + 1
    y0 = (res.end_motion[0], 0.0, 0.0, mu_h)
    o = ref.integrate_ode(p, k, t_end, x0=x0, max_step=2e-3, y0=y0)
    assert o.status == 0
    f_ref = LAW.alpha_t * (o.y[0] - o.y[2])
    j = np.flatnonzero((f_ref[1:-1] > f_ref[:-2]) & (f_ref[1:-1] >= f_ref[2:]))[0] + 1
    print(
        f"hold {hold} s: peak {f[i]:.6g} MPa at {s['t'][i]:.4g} s (rate equations {f_ref[j]:.6g} "
        f"at {o.t[j]:.4g} s); steady {ss.traction:.6g}, g mu after the hold {p.g * mu_h:.6g}"
    )
    assert f[i] == pytest.approx(f_ref[j], rel=5e-3)
    assert ss.traction < f[i] < p.g * LAW.mu_s


# --------------------------------------------------------------------------------------------
# The case's JSON form and its errors

GOOD = {
    "law": "subloading",
    "params": {"preset": "sec7"},
    "control": "slider",
    "slider": {"mass": 1e-3, "stiffness": 100.0, "velocity": 0.1, "f_n": 300.0, "t_end": 0.05},
}


def test_a_slider_case_through_run_case():
    res = run_case(dict(GOOD, t_samples=[0.0, 0.025, 0.05]))
    assert res.samples["t"].tolist() == [0.0, 0.025, 0.05]
    assert res.complete and res.n_steps > 0
    # spring force = k (V t - u); at rest at t = 0
    s = res.samples
    np.testing.assert_allclose(s["f_spring"], 100.0 * (0.1 * s["t"] - s["u"]), rtol=1e-12)
    assert set(res.to_dict()) >= {"samples", "n_steps", "n_rejected", "map_calls"}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"mass": 0.0}, "field 'slider.mass' must be > 0, got 0.0"),
        ({"stiffness": -1.0}, "field 'slider.stiffness' must be > 0, got -1.0"),
        ({"velocity": -0.1}, "field 'slider.velocity' must be >= 0, got -0.1"),
        ({"f_n": "300"}, "field 'slider.f_n' must be a number, got '300'"),
        ({"t_end": float("nan")}, "field 'slider.t_end' must be finite, got nan"),
        ({"dt_max": 0}, "field 'slider.dt_max' must be > 0, got 0"),
        ({"err_tol": True}, "field 'slider.err_tol' must be a number, got True"),
        ({"x0": float("inf")}, "field 'slider.x0' must be finite, got inf"),
        ({"damping": -1.0}, "field 'slider.damping' must be >= 0, got -1.0"),
        ({"dashpot": 1.0}, "field 'slider': unknown keys ['dashpot']"),
        ({"t_end": 1e9}, "field 'slider.t_end' = 1000000000.0 needs at least"),
    ],
)
def test_bad_slider_values_are_named(change, message):
    case = dict(GOOD, slider=dict(GOOD["slider"], **change))
    with pytest.raises(CaseError) as e:
        parse_case(case)
    assert message in str(e.value)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        (dict(GOOD, path=[[0, 0, 0, 0]]), "unknown field(s) ['path'] of a slider case"),
        ({k: v for k, v in GOOD.items() if k != "slider"}, "field 'slider' must be an object"),
        (dict(GOOD, slider={"mass": 1.0}), "field 'slider.stiffness' is missing"),
        (dict(GOOD, t_samples=[0.0, 1.0]), "field 't_samples[1]' = 1.0 lies outside [0,"),
        (dict(GOOD, t_samples=[0.02, 0.01]), "field 't_samples[1]': sample times must not"),
        (dict(GOOD, control="slide"), "field 'control' must be 'slider' in a case with a 'sl"),
    ],
)
def test_bad_slider_cases_are_named(case, message):
    with pytest.raises(CaseError) as e:
        parse_case(case)
    assert message in str(e.value)


def test_steps_per_mm_is_refused_for_a_slider_case():
    with pytest.raises(CaseError, match="steps_per_mm does not apply to a slider case"):
        run_case(GOOD, steps_per_mm=100.0)


def test_the_command_line_runs_a_slider_case(tmp_path, capsys):
    from subfric_dolfinx.driver import main

    case = tmp_path / "slider.json"
    case.write_text(json.dumps(dict(GOOD, t_samples=[0.0, 0.05])))
    out = tmp_path / "r.json"
    assert main([str(case), "--out", str(out)]) == 0
    got = json.loads(out.read_text())
    assert got["samples"]["t"] == [0.0, 0.05] and got["complete"]
    assert "ok:" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(dict(GOOD, slider=dict(GOOD["slider"], mass=-1))))
    assert main([str(bad)]) == 2
    assert "field 'slider.mass' must be > 0, got -1" in capsys.readouterr().err


# -- stability: extreme slip events (issue 38 item 6) -----------------------------------------
EXTREME = {
    # a light slider on a stiff spring driven fast: slip events every few microseconds
    "fast": ({}, {"mass": 1e-9, "stiffness": 1e4, "velocity": 10.0, "t_end": 2e-4}),
    # thrown at 1 m/s against its own friction, then stuck
    "impact": ({}, {"mass": 1e-6, "stiffness": 50.0, "velocity": 0.0, "v0": 1e3, "t_end": 0.01}),
    # released from a spring stretched to twice the static strength: slip at metres a second
    "release": ({}, {"mass": 1e-6, "stiffness": 50.0, "velocity": 0.0, "x0": 1.0, "t_end": 0.01}),
    # an interface 1e8 MPa/mm stiff (the preset's 1,000-fold)
    "stiff": ({"alpha_t": 1e8}, {"mass": 1e-6, "stiffness": 50.0, "velocity": 1.0, "t_end": 0.05}),
    # with a dashpot
    "damped": ({}, {"mass": 1e-6, "stiffness": 1e3, "velocity": 1, "damping": 5.0, "t_end": 0.02}),
}


@pytest.mark.parametrize("name", sorted(EXTREME))
def test_extreme_slip_events_stay_finite_and_balance_their_energy(name):
    """Extreme slip events of the spring-slider: no NaN, the run complete, and the energy
    accounts of Newmark's average acceleration closed at every step (kinetic + spring energy =
    the initial energy + the load point's work - the friction's and the dashpot's work, each by
    the trapezoidal rule: an identity of the scheme, so to round-off and Newton's tolerance),
    the friction's plastic work never negative (no energy from the interface)."""
    params, slider = EXTREME[name]
    case = {
        "law": "subloading",
        "params": {"preset": "sec7", **params},
        "control": "slider",
        "slider": {"f_n": 300.0, **slider},
    }
    res = run_slider(case)
    s = res.samples
    assert res.complete and all(np.all(np.isfinite(a)) for a in s.values())
    m, k, eta = slider["mass"], slider["stiffness"], slider.get("damping", 0.0)
    u, v, x, f = s["u"], s["v"], s["x_load"], s["f_t"]

    def work(force, path):  # the trapezoidal rule's running integral
        return np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(path))])

    w_load, w_friction, w_dashpot = work(k * (x - u), x), work(f, u), work(eta * v, u)
    energy = 0.5 * m * v**2 + 0.5 * k * (x - u) ** 2
    scale = max(energy.max(), w_load.max(), np.abs(w_friction).max())
    balance = energy - energy[0] - w_load + w_friction + w_dashpot
    assert np.abs(balance).max() <= 1e-9 * scale, np.abs(balance).max() / scale
    alpha_t = params.get("alpha_t", preset("sec7").alpha_t)
    plastic = w_friction - 0.5 * (f**2 - f[0] ** 2) / alpha_t
    assert plastic.min() >= -1e-9 * scale, plastic.min() / scale
    assert np.abs(v).max() > 0.5 * abs(slider.get("v0", 0.0)) and plastic[-1] > 0.0
