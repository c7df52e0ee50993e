"""The J2 return map at material points (numpy only) against closed forms and an independent
integration:

* uniaxial stress, loading-unloading-reloading (isotropic, kinematic, mixed hardening): the
  closed-form bilinear response with its reverse yield points (Bauschinger shift), driven with the
  closed form's own lateral strain, so that the lateral stresses must vanish too;
* the consistent tangent against central finite differences of the return map;
* a non-proportional 3-D strain path against scipy's integration of the rate equations (the
  continuum law, DOP853 with events at the yield and unloading switches): first-order
  convergence in the step size;
* parameter checks naming the parameter; no NaN for non-finite or overflowing input.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from subfric_dolfinx.constitutive import J2Material, J2State, LinearElastic, j2_return_map
from subfric_dolfinx.constitutive.j2 import (
    ONE,
    from_mandel,
    mandel_deviator,
    to_mandel,
    von_mises,
)

pytestmark = pytest.mark.numpy_only

E, NU, SY = 200e3, 0.3, 250.0
EY = SY / E


def uniaxial_closed_form(E, sy, Hi, Hk, eps_a, eps_b, n):
    """The bilinear closed form on the path 0 -> eps_a -> eps_b -> eps_a (n points a leg).

    Returns strains, stresses, plastic strains and p, each (3 n,), and the two reverse yield
    stresses (unloading from eps_a, reloading from eps_b).
    """
    H = Hi + Hk
    Et = E * H / (E + H)
    out = []
    # leg 1: 0 -> eps_a (eps_a beyond yield)
    e1 = np.linspace(0, eps_a, n + 1)[1:]
    s1 = np.where(e1 <= sy / E, E * e1, sy + Et * (e1 - sy / E))
    out.append((e1, s1))
    sA = s1[-1]
    epA = eps_a - sA / E
    pA = epA
    # leg 2: unloading; reverse yield at alpha - (sy + Hi p)
    s_rev = Hk * epA - (sy + Hi * pA)
    e_rev = eps_a - (sA - s_rev) / E
    e2 = np.linspace(eps_a, eps_b, n + 1)[1:]
    s2 = np.where(e2 >= e_rev, sA - E * (eps_a - e2), s_rev + Et * (e2 - e_rev))
    out.append((e2, s2))
    sB = s2[-1]
    epB = eps_b - sB / E
    pB = pA + (epA - epB)
    # leg 3: reloading; yield at alpha + (sy + Hi p)
    s_rel = Hk * epB + (sy + Hi * pB)
    e_rel = eps_b + (s_rel - sB) / E
    e3 = np.linspace(eps_b, eps_a, n + 1)[1:]
    s3 = np.where(e3 <= e_rel, sB + E * (e3 - eps_b), s_rel + Et * (e3 - e_rel))
    out.append((e3, s3))
    e = np.concatenate([o[0] for o in out])
    s = np.concatenate([o[1] for o in out])
    ep = e - s / E
    # p: the accumulated |d ep| along the path (monotone on each plastic leg)
    p = np.concatenate(
        [
            np.maximum(ep[:n], 0.0),
            pA + (epA - ep[n : 2 * n]),
            pB + (ep[2 * n :] - epB),
        ]
    )
    return e, s, ep, p, (s_rev, s_rel)


def drive_uniaxial(mat, e, s, ep, steps):
    """Run the return map along a uniaxial-stress path given by the closed form's strains.

    The lateral strain is the closed form's ``-nu s / E - ep / 2``; the return map must give
    back ``sigma = diag(s, 0, 0)``.
    """
    state = J2State.zeros(1)
    rows = []
    for k in steps:
        lat = -mat.nu * s[k] / mat.E - ep[k] / 2
        strain = to_mandel(np.diag([e[k], lat, lat]))[None]
        res = mat.return_map(strain, state)
        state = res.state
        rows.append((res.stress[0], res.state.p[0], res.state.plastic_strain[0], res.state))
    return rows


@pytest.mark.parametrize(
    "Hi, Hk",
    [(0.0, 0.0), (10e3, 0.0), (0.0, 10e3), (4e3, 6e3)],
    ids=["perfect", "isotropic", "kinematic", "mixed"],
)
@pytest.mark.parametrize("n", [40, 3], ids=["fine", "coarse"])
def test_uniaxial_load_unload_reload_closed_form(Hi, Hk, n):
    """Stress, plastic strain and p along 0 -> 5 eps_y -> -5 eps_y -> 5 eps_y, every step.

    A step crossing the yield point (or both elastic range and reverse yield, coarse: 3 steps a
    leg) is exact as well: the path is proportional. Measured: 1e-13 of sigma_y.
    """
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=Hi, H_kin=Hk)
    e, s, ep, p, (s_rev, _) = uniaxial_closed_form(E, SY, Hi, Hk, 5 * EY, -5 * EY, n)
    rows = drive_uniaxial(mat, e, s, ep, range(e.size))
    sig = np.array([r[0] for r in rows])
    tol = 1e-12 * SY
    assert np.max(np.abs(sig[:, 0] - s)) < tol
    assert np.max(np.abs(sig[:, 1:])) < tol  # the lateral stresses vanish
    assert np.max(np.abs(np.array([r[1] for r in rows]) - p)) < 1e-12 * EY
    epm = np.array([r[2] for r in rows])
    assert np.max(np.abs(from_mandel(epm)[:, 0, 0] - ep)) < 1e-12 * EY
    # the Bauschinger shift: reverse yield at sigma_A - 2 (sigma_y + H_iso p_A) ... the closed
    # form's reverse yield stress is below the peak by exactly twice the current radius
    sA = s[n - 1]
    pA = p[n - 1]
    assert s_rev == pytest.approx(sA - 2 * (SY + Hi * pA), rel=1e-14)
    if Hk > 0 and Hi == 0:
        assert -s_rev < SY  # kinematic: yields in compression before -sigma_y
    if Hi > 0 and Hk == 0:
        assert s_rev == pytest.approx(-sA, rel=1e-14)  # isotropic: no shift


def test_uniaxial_backstress_and_stresses_on_the_surface():
    """Kinematic hardening: the uniaxial backstress is H_kin eps_p ((3/2) beta_11), and at a
    plastic step the stress sits on the shifted surface |sigma - alpha| = sigma_y + H_iso p."""
    Hi, Hk = 4e3, 6e3
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=Hi, H_kin=Hk)
    e, s, ep, _, _ = uniaxial_closed_form(E, SY, Hi, Hk, 5 * EY, -5 * EY, 20)
    rows = drive_uniaxial(mat, e, s, ep, range(e.size))
    for k, (sig, pk, _, st) in enumerate(rows):
        alpha = 1.5 * from_mandel(st.backstress)[0, 0, 0]
        assert alpha == pytest.approx(Hk * ep[k], abs=1e-12 * SY)
        if k in (19, 39, 59):  # the legs' ends are plastic
            assert abs(sig[0] - alpha) == pytest.approx(SY + Hi * pk, rel=1e-13)


def random_states(mat, rng, n):
    """States reached by random strain paths (some points plastic, with backstress)."""
    state = J2State.zeros(n)
    for _ in range(4):
        strain = rng.normal(size=(n, 6)) * 2 * EY
        state = mat.return_map(strain, state).state
    return state


@pytest.mark.parametrize("Hi, Hk", [(0.0, 0.0), (5e3, 0.0), (0.0, 5e3), (2e3, 3e3)])
def test_consistent_tangent_against_finite_differences(Hi, Hk):
    """Central differences (h = 1e-7 eps_y) of the stress: relative error < 1e-6 (measured
    ~1e-9) on 200 random points, plastic and elastic."""
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=Hi, H_kin=Hk)
    rng = np.random.default_rng(7)
    n = 200
    old = random_states(mat, rng, n)
    # around the centre of each point's elastic range, near and far
    centre = old.plastic_strain + old.backstress / (2 * mat.G)
    strain = centre + rng.normal(size=(n, 6)) * rng.uniform(0.1, 3.0, size=(n, 1)) * EY
    res = mat.return_map(strain, old)
    assert np.count_nonzero(res.plastic) > 50 and np.count_nonzero(~res.plastic) > 10
    h = 1e-7 * EY
    fd = np.empty((n, 6, 6))
    same = np.ones(n, dtype=bool)  # points clear of the elastic/plastic switch (a kink)
    for j in range(6):
        d = np.zeros(6)
        d[j] = h
        rp = mat.return_map(strain + d, old)
        rm = mat.return_map(strain - d, old)
        same &= (rp.plastic == res.plastic) & (rm.plastic == res.plastic)
        fd[:, :, j] = (rp.stress - rm.stress) / (2 * h)
    assert same.sum() > n - 3
    err = np.linalg.norm(fd - res.tangent, axis=(1, 2)) / np.linalg.norm(res.tangent, axis=(1, 2))
    err = err[same]
    assert np.max(err) < 1e-6
    assert np.allclose(res.tangent, np.swapaxes(res.tangent, 1, 2), rtol=0, atol=1e-9 * E)
    print(f"max relative tangent error {np.max(err):.2e}")


def rate_reference(mat, path, t_end, rtol=1e-11):
    """The continuum law integrated along ``path(t)`` (Mandel strain) by scipy (DOP853).

    Phases: elastic until f = 0 (event), plastic with the consistency rate until the loading
    ``n : de`` turns negative (event), and so on. Returns a function t -> stress (6,).
    """
    G, K, Hi, Hk = mat.G, mat.K, mat.H_iso, mat.H_kin
    H = Hi + Hk
    dt = 1e-7

    def rate(t):
        return (path(t + dt) - path(t - dt)) / (2 * dt)

    def unpack(y):
        return y[:6], y[6:12], y[12]

    def xi_f(t, y):
        ep, beta, p = unpack(y)
        xi = 2 * G * (mandel_deviator(path(t)) - ep) - beta
        return xi, np.linalg.norm(xi) - math.sqrt(2 / 3) * (mat.sigma_y + Hi * p)

    def rhs_plastic(t, y):
        xi, _ = xi_f(t, y)
        n = xi / np.linalg.norm(xi)
        dg = max(2 * G * n @ rate(t), 0.0) / (2 * G + 2 / 3 * H)
        return np.concatenate([dg * n, 2 / 3 * Hk * dg * n, [math.sqrt(2 / 3) * dg]])

    def yield_event(t, y):
        return xi_f(t, y)[1]

    def unload_event(t, y):
        xi, _ = xi_f(t, y)
        return xi @ rate(t)

    yield_event.terminal, yield_event.direction = True, 1
    unload_event.terminal, unload_event.direction = True, -1
    segments = []
    t, y, plastic = 0.0, np.zeros(13), False
    while t < t_end:
        if plastic:
            sol = solve_ivp(
                rhs_plastic,
                (t, t_end),
                y,
                method="DOP853",
                rtol=rtol,
                atol=1e-16,
                events=unload_event,
                dense_output=True,
            )
        else:
            sol = solve_ivp(
                lambda t, y: np.zeros(13),
                (t, t_end),
                y,
                method="DOP853",
                rtol=rtol,
                atol=1e-16,
                events=yield_event,
                dense_output=True,
                first_step=1e-4,
                max_step=1e-3,
            )
        segments.append((t, sol.t[-1], sol.sol))
        t, y = sol.t[-1], sol.y[:, -1]
        plastic = not plastic
        if sol.status == 0:
            break

    def stress(tq):
        for t0, t1, s in segments:
            if t0 <= tq <= t1:
                ep, _, _ = unpack(s(tq))
                e = path(tq)
                tr = e[:3].sum()
                return 2 * G * (mandel_deviator(e) - ep) + K * tr * ONE
        raise ValueError(tq)

    return stress, len(segments)


def path3d(t):
    """A non-proportional strain path (Mandel): tension, reversed into compression, with shear
    turning and some volume change."""
    a = 4 * EY
    main = math.sin(math.pi * t / 1.2)  # up to t = 0.6, then down into compression
    return a * np.array(
        [
            main,
            -0.5 * main + 0.1 * t**2,
            -0.4 * main,
            0.2 * math.sin(3 * t),
            0.1 * (1 - math.cos(2 * t)),
            0.15 * t * math.cos(t),
        ]
    )


@pytest.mark.parametrize("Hi, Hk", [(0.0, 0.0), (0.0, 8e3), (3e3, 5e3)])
def test_non_proportional_path_against_rate_integration(Hi, Hk):
    """The return map stepped along ``path3d`` (t in [0, 2]: yield, unloading, reverse yielding,
    unloading, in turning directions) converges to the rate integration at first order: max
    stress error over the path < 1e-3 sigma_y with 1600 steps (measured 5.7e-4 to 5.9e-4 of
    sigma_y), error ratios 1.97-1.99 between 400, 800 and 1600 steps."""
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=Hi, H_kin=Hk)
    ref, nseg = rate_reference(mat, path3d, 2.0)
    assert nseg >= 4  # elastic, plastic, elastic, plastic, ...
    errors = {}
    for n in (400, 800, 1600):
        state = J2State.zeros(1)
        err = 0.0
        for k in range(1, n + 1):
            t = 2.0 * k / n
            res = mat.return_map(path3d(t)[None], state)
            state = res.state
            if k % (n // 20) == 0:
                err = max(err, float(np.max(np.abs(res.stress[0] - ref(t)))))
        errors[n] = err / SY
    assert errors[1600] < 1e-3
    assert 1.8 < errors[400] / errors[800] < 2.2
    assert 1.8 < errors[800] / errors[1600] < 2.2


def test_yield_surface_and_flow_properties():
    """At plastic points: von Mises of (s - beta) equals the current radius, the plastic strain
    and backstress are deviatoric, p grows by sqrt(2/3) |d eps_p|."""
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=3e3, H_kin=4e3)
    rng = np.random.default_rng(3)
    old = random_states(mat, rng, 300)
    res = mat.return_map(rng.normal(size=(300, 6)) * 3 * EY, old)
    pl = res.plastic
    assert pl.sum() > 50
    rel = von_mises(mandel_deviator(res.stress) - res.state.backstress)
    assert np.allclose(rel[pl], SY + mat.H_iso * res.state.p[pl], rtol=1e-13)
    assert np.all(rel[~pl] <= (SY + mat.H_iso * res.state.p[~pl]) * (1 + 1e-12))
    assert np.max(np.abs(res.state.plastic_strain[:, :3].sum(axis=1))) < 1e-17
    assert np.max(np.abs(res.state.backstress[:, :3].sum(axis=1))) < 1e-12
    dep = np.linalg.norm(res.state.plastic_strain - old.plastic_strain, axis=1)
    assert np.allclose(res.state.p - old.p, math.sqrt(2 / 3) * dep, rtol=1e-13, atol=1e-18)
    assert np.array_equal(res.state.p[~pl], old.p[~pl])


def test_out_and_old_not_modified():
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=1e3)
    rng = np.random.default_rng(5)
    old = random_states(mat, rng, 20)
    keep = old.copy()
    out = J2State.zeros(20)
    strain = rng.normal(size=(20, 6)) * 3 * EY
    res = j2_return_map(mat, strain, old, out=out)
    assert res.state is out
    for k in J2State.NAMES:
        assert np.array_equal(getattr(old, k), getattr(keep, k))
    again = j2_return_map(mat, strain, old)
    assert np.array_equal(again.state.p, out.p)


def test_non_finite_and_overflowing_strain_fail_without_nan():
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_kin=1e3)
    rng = np.random.default_rng(1)
    old = random_states(mat, rng, 5)
    strain = rng.normal(size=(5, 6)) * EY
    strain[1, 2] = np.nan
    strain[2, 0] = np.inf
    strain[3, :] = 1e306
    with np.errstate(all="raise"):
        res = mat.return_map(strain, old)
    assert list(res.failed) == [False, True, True, True, False]
    for a in (res.stress, res.tangent, res.state.plastic_strain, res.state.backstress, res.state.p):
        assert np.isfinite(a).all()
    assert np.all(res.stress[1:4] == 0.0)
    assert np.array_equal(res.state.p[1:4], old.p[1:4])
    assert np.array_equal(res.tangent[2], mat.elastic_tangent())


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"E": 0.0}, "E"),
        ({"nu": 0.5}, "nu"),
        ({"nu": -1.0}, "nu"),
        ({"sigma_y": 0.0}, "sigma_y"),
        ({"sigma_y": math.inf}, "sigma_y"),
        ({"H_iso": -1.0}, "H_iso"),
        ({"H_kin": math.nan}, "H_kin"),
        ({"H_kin": True}, "H_kin"),
    ],
)
def test_bad_parameters_are_named(kwargs, name):
    args = {"E": E, "nu": NU, "sigma_y": SY} | kwargs
    with pytest.raises((ValueError, TypeError), match=f"parameter {name} "):
        J2Material(**args)


def test_elastic_material_and_shapes():
    el = LinearElastic(E=E, nu=NU)
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    eps = np.array([[1e-3, 2e-4, -3e-4], [2e-4, 5e-4, 1e-4], [-3e-4, 1e-4, 2e-4]])
    sig = 2 * el.G * eps + lam * np.trace(eps) * np.eye(3)
    assert np.allclose(from_mandel(el.elastic_tangent() @ to_mandel(eps)), sig, rtol=1e-14)
    assert el.lam == pytest.approx(lam)
    with pytest.raises(ValueError, match="parameter nu "):
        LinearElastic(E=E, nu=0.7)
    mat = J2Material(E=E, nu=NU, sigma_y=SY)
    with pytest.raises(ValueError, match=r"strain must have shape \(2, 6\)"):
        mat.return_map(np.zeros((2, 4)), J2State.zeros(2))
    with pytest.raises(ValueError, match="plastic_strain and backstress"):
        J2State(np.zeros((2, 6)), np.zeros((2, 4)), np.zeros(2))
