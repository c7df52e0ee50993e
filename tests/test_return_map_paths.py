"""The subloading return map's paths: split, rotation, fast paths, scalar vs batch, tolerances.

* the consistent tangent against central differences by kind of step (straight, reversal split
  through zero in 1-D, split at a 2-D near-reversal, loading switch after a turn, rotation from a
  fixed start, start along the trial; an exact 2-D reversal is a kink of the map, as of the exact
  solution: the split point's ``|f_t|`` is a cone in the gap);
* the scalar path (at most SMALL_N = 32 points) and the numpy path give the same numbers to 1e-12;
* the unrolled fast paths equal the general path;
* a state without the start traction ``f`` gives the radial return;
* the contact band and the loading margin (``constitutive/tolerances.py``, issue 12 items 7b/7c):
  statuses that do not depend on the rounding of the gap, for both laws.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from subfric_dolfinx.constitutive import (
    CONTACT_TOL,
    CoulombLaw,
    InterfaceState,
    Status,
    preset,
)
from subfric_dolfinx.constitutive._subloading import fast, general
from subfric_dolfinx.constitutive._subloading.root import Br, certified_root
from subfric_dolfinx.constitutive._subloading.switch import CUSP, ROOT, split_point

pytestmark = pytest.mark.numpy_only

P = preset("sec7")
FN = 300.0
UN = FN / P.alpha_n
G = -math.expm1(-P.c_n * FN)
EPS = float(np.finfo(float).eps)


def state_with(f0t, r=None, mu=400.0, up=None, fn0=FN):
    """One point whose start traction is ``(f0t, fn0)`` and ``r = |f0t| / (g mu)``."""
    f0t = np.asarray(f0t, dtype=float)
    nt = f0t.size
    g0 = -math.expm1(-P.c_n * fn0)
    r = float(np.linalg.norm(f0t)) / (g0 * mu) if r is None else r
    up = np.zeros(nt) if up is None else np.asarray(up, dtype=float)
    return InterfaceState(
        {"up": up[None], "mu": [mu], "r": [r], "f": np.append(f0t, fn0)[None]}, nt
    )


def gap_for(trial, st, un=UN):
    """The gap whose trial traction is ``trial``."""
    return np.append(st.up[0] + np.asarray(trial, dtype=float) / P.alpha_t, un)[None]


def central(law, gap, st, dt, rel=1e-7):
    m = gap.shape[1]
    D = np.zeros((m, m))
    for j in range(m):
        h = rel * max(abs(gap[0, j]), 1e-3)
        e = np.zeros((1, m))
        e[0, j] = h
        D[:, j] = (law.return_map(gap + e, st, dt).traction[0]
                   - law.return_map(gap - e, st, dt).traction[0]) / (2 * h)  # fmt: skip
    return D


def split_of(st, gap, dt):
    """``split_point`` of the map for one point (None, or (s, kind))."""
    nt = st.n_tangential
    f0 = st["f"][0]
    ft = P.alpha_t * (gap[0, :nt] - st.up[0])
    return split_point(P._consts, f0[:nt].tolist(), f0[nt], ft.tolist(), P.alpha_n * gap[0, nt],
                       float(np.linalg.norm(ft)), st.mu[0], P.xi * dt)  # fmt: skip


# (start tangential traction, trial tangential traction, dt, expected split kind)
KINDS = {
    "straight 1-D": ([12.0], [16.0], 0.01, None),
    "straight 2-D (start along the trial)": ([12.0, 0.0], [16.0, 0.0], 0.01, None),
    "reversal through zero, 1-D": ([15.0], [-9.0], 0.01, CUSP),
    "near-reversal in the plane": ([15.0, 0.0], [-9.0, 4.0], 0.01, ROOT),
    "turn at the peak (loading switch)": ([23.0, 0.0], [23.0, 6.0], 0.5, ROOT),
    "rotation from a fixed start": ([12.0, 0.0], [16.0, 7.0], 0.01, None),
}


@pytest.mark.parametrize("kind", list(KINDS))
def test_tangent_by_kind_of_step(kind):
    f0t, trial, dt, split = KINDS[kind]
    st = state_with(f0t)
    gap = gap_for(trial, st)
    res = P.return_map(gap, st, dt)
    assert res.status[0] == Status.PLASTIC
    sp = split_of(st, gap, dt)
    assert (sp is None and split is None) or sp[1] == split, sp
    D = res.tangent[0]
    D_fd = central(P, gap, st, dt)
    scale = np.abs(D).max()
    np.testing.assert_allclose(D, D_fd, atol=2e-6 * scale, rtol=1e-5)
    np.testing.assert_array_equal(res.state["f"], res.traction)


def test_scalar_and_batch_paths_agree():
    """Points 1..8 at a time (scalar path) and all at once (numpy path), with and without start
    tractions, reversals, turns, separation, both dimensions: the same to 1e-12."""
    rng = np.random.default_rng(5)
    for nt in (1, 2):
        n = 4000
        d = rng.normal(size=(n, nt))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        fn0 = rng.uniform(0.0, 600.0, n)
        mu = rng.uniform(P.mu_k, P.mu_s, n)
        r = rng.uniform(0.0, 1.0, n)
        g0 = -np.expm1(-P.c_n * fn0)
        f0t = (g0 * r * mu)[:, None] * d
        kind = rng.integers(0, 4, n)  # along, against, across, random
        e = rng.normal(size=(n, nt))
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        dirs = np.where((kind == 0)[:, None], d, np.where((kind == 1)[:, None], -d, e))
        trial = f0t + rng.uniform(0.0, 3.0, (n, 1)) * 30.0 * dirs
        up = rng.normal(0.0, 0.1, (n, nt))
        un = rng.uniform(-0.2, 1.4, n)
        gap = np.column_stack([up + trial / P.alpha_t, un])
        st = InterfaceState(
            {"up": up, "mu": mu, "r": r, "f": np.column_stack([f0t, fn0])}, nt
        )
        big = P.return_map(gap, st, 0.05)
        k = 0
        while k < n:
            size = 1 + (k // 7) % 8
            idx = np.arange(k, min(k + size, n))
            small = P.return_map(gap[idx], st.take(idx), 0.05)
            np.testing.assert_array_equal(small.status, big.status[idx])
            np.testing.assert_allclose(small.traction, big.traction[idx], rtol=1e-12, atol=1e-12)
            sc = np.abs(big.tangent[idx]).max()
            np.testing.assert_allclose(small.tangent, big.tangent[idx], rtol=1e-12, atol=1e-12 * sc)
            for v in ("up", "mu", "r", "f"):
                np.testing.assert_allclose(small.state[v], big.state[v][idx], rtol=1e-12,
                                           atol=1e-14)  # fmt: skip
            k += size
        assert np.count_nonzero(big.status == Status.PLASTIC) > n // 4


def _plastic_point(f0t, trial, dt=0.01):
    """Inputs of ``fast``/``general`` for one plastic point without a split."""
    L = P._consts
    st = state_with(f0t)
    gap = gap_for(trial, st)
    ft = list(P.alpha_t * (gap[0, :2] - st.up[0]))
    A = math.hypot(*ft)
    g = G
    b = P.xi * dt
    tol_f = max(1e-13 * g * P.mu_s, 8 * EPS * A)
    br = Br(L, A, g, st.r[0], st.mu[0], b)
    dl, e, conv, iters, jump = certified_root(br, tol_f, 100)
    assert conv
    tstar = [x / A for x in ft]
    f0 = list(st["f"][0])
    return L, gap[0].tolist(), [0.0, 0.0], ft, A, tstar, FN, g, f0, b, st.mu[0], tol_f, br, dl, \
        e, iters, jump  # fmt: skip


@pytest.mark.parametrize(("trial", "fast_path"), [([19.0, 0.0], "collinear"),
                                                  ([16.0, 7.0], "rotate_fixed")])  # fmt: skip
def test_fast_paths_equal_the_general_path(trial, fast_path):
    L, gap, up, ft, A, ts, fn, g, f0, b, mu, tol_f, br, dl, e, it, jump = _plastic_point(
        [12.0, 0.0], trial
    )
    ref = general.general(L, gap, up, ft, A, ts, fn, g, f0, None, b, mu, tol_f, 100, br, dl, e,
                          it, jump, True)  # fmt: skip
    if fast_path == "collinear":
        got = fast.collinear(L, up, ft, A, ts, fn, g, f0, br, dl, e, it, jump)
    else:
        got = fast.rotate_fixed(L, up, ft, A, ts, fn, g, f0, mu, tol_f, 100, br, dl, e, it)
    np.testing.assert_allclose(got[0], ref[0], rtol=3e-14, atol=1e-13)
    np.testing.assert_allclose(np.array(got[1]), np.array(ref[1]), rtol=3e-14, atol=3e-14 * 500)
    np.testing.assert_allclose(got[2], ref[2], rtol=3e-14, atol=1e-16)
    assert got[3:6] == pytest.approx(ref[3:6], rel=3e-14)


def test_a_state_without_start_traction_gives_the_radial_return():
    """Without ``f`` the map cannot know where the elastic trial starts: no split, no rotation;
    the traction stays along the trial (and the result carries no ``f``)."""
    st = state_with([15.0, 0.0])
    radial = InterfaceState({k: st[k] for k in ("up", "mu", "r")}, 2)
    gap = gap_for([-20.0, 8.0], st)
    a = P.return_map(gap, radial, 0.01)
    b = P.return_map(gap, st, 0.01)
    assert "f" not in a.state and a.status[0] == b.status[0] == Status.PLASTIC
    t = a.traction[0, :2]
    trial = np.array([-20.0, 8.0])
    assert abs(t[0] * trial[1] - t[1] * trial[0]) < 1e-12 * np.linalg.norm(trial) ** 2
    assert not np.allclose(a.traction, b.traction)  # the start traction matters


# --------------------------------------------------------------------------------------------
# Issue 12, items 7b and 7c: statuses independent of the rounding of the gap


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_touching_points_within_the_rounding_of_ubar_n_all_separate(law):
    """After sliding 1 mm while touching without load, ubar_n = 0 +- rounding of the gap: every
    point touches (SEPARATED, up frozen, zero traction, the contact-side stiffness), whatever the
    sign of the rounding; just above the band they are in contact."""
    p = P if law == "subloading" else CoulombLaw(alpha_t=500.0, alpha_n=500.0, mu_c=0.3)
    n = 200
    rng = np.random.default_rng(0)
    st = p.initial_state(n, 2)
    st.up[:] = rng.normal(0.0, 0.3, (n, 2))
    ut = st.up + rng.normal(0.0, 0.01, (n, 2))
    u = 1.0 + np.abs(ut).max(axis=1)  # the displacements behind the gap (mm)
    rounding = rng.uniform(-4.0, 4.0, n) * EPS * u
    res = p.return_map(np.column_stack([ut, rounding]), st, 0.1)
    assert np.all(res.status == Status.SEPARATED), res.counts()
    assert np.all(res.traction == 0.0)
    np.testing.assert_array_equal(res.state.up, st.up)
    np.testing.assert_array_equal(res.tangent[:, 2, 2], p.alpha_n)
    np.testing.assert_array_equal(res.tangent[:, 0, 0], p.alpha_t)
    # clearly above the band (1e3 times its width): in contact
    scale = np.maximum(np.linalg.norm(ut, axis=1), np.linalg.norm(st.up, axis=1))
    if law == "subloading":
        scale = np.maximum(scale, 1.0 / (p.c_n * p.alpha_n))
    res = p.return_map(np.column_stack([ut, 1e3 * CONTACT_TOL * scale]), st, 0.1)
    assert not np.any(res.status == Status.SEPARATED)


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
@pytest.mark.parametrize("size", [1e-81, 1e-40, 1e-22, 1e-16])
def test_pressing_with_a_rounding_tangential_gap_is_elastic(law, size):
    """Pressing from the virgin state with ubar_t = 0 to rounding (|f_t*| of 1e-81..1e-16 MPa):
    ELASTIC at every point, whatever the rounding (it was PLASTIC at every point: from r = 0 any
    nonzero trial loads), so the counts are the same on any number of ranks."""
    p = P if law == "subloading" else CoulombLaw(alpha_t=500.0, alpha_n=500.0, mu_c=0.3)
    n = 100
    rng = np.random.default_rng(1)
    gap = np.column_stack([rng.normal(0.0, size, (n, 2)), np.full(n, UN)])
    res = p.return_map(gap, p.initial_state(n, 2), 0.1)
    assert np.all(res.status == Status.ELASTIC), res.counts()
    np.testing.assert_array_equal(res.state.up, 0.0)
    if law == "subloading":
        np.testing.assert_allclose(res.state.r, np.linalg.norm(res.traction[:, :2], axis=1)
                                   / (G * p.mu_s), rtol=1e-12)  # fmt: skip


def test_a_real_first_slip_is_still_plastic():
    """The loading margin is the rounding of the surface (1e-13 g mu): a first slip of 1e-9 mm
    (|f_t*| = 5e-7 MPa, 2e-8 of g mu_s) from r = 0 is plastic, as the model wants."""
    res = P.return_map(np.array([[1e-9, 0.0, UN]]), P.initial_state(1, 2), 0.0)
    assert res.status[0] == Status.PLASTIC


@pytest.mark.parametrize("n", [5, 40])
def test_per_point_time_increments(n):
    """``dt`` per point (the batch driver) gives what one call per point gives, on both paths."""
    rng = np.random.default_rng(3)
    st = state_with([15.0, 0.0])
    st = st.take(np.zeros(n, dtype=int))
    trial = np.column_stack([rng.uniform(-25, 25, n), rng.uniform(-25, 25, n)])
    gap = np.column_stack([st.up + trial / P.alpha_t, np.full(n, UN)])
    dt = rng.uniform(0.0, 30.0, n)
    res = P.return_map(gap, st, dt)
    for i in range(n):
        one = P.return_map(gap[i : i + 1], st.take([i]), float(dt[i]))
        np.testing.assert_allclose(res.traction[i], one.traction[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(res.state.mu[i], one.state.mu[0], rtol=1e-13)
    with pytest.raises(ValueError, match="dt"):
        P.return_map(gap, st, dt[:-1])
    with pytest.raises(ValueError, match="dt"):
        P.return_map(gap, st, np.where(np.arange(n) == 1, -1.0, dt))


def test_no_split_where_the_plastic_part_would_start_unstable():
    """A point of the literal Sec. 7 set in FE (600 MPa, the block's edge): the elastic trial
    reaches its loading switch at s = 0.946 of the step, but there phi rises (softening faster
    than the elastic unloading), so the smallest root lies 0.018 mm away and the traction would
    drop from 17.3 to 8.3 MPa within a 1.6-ms step: no continuous branch. The split is not
    taken; the whole step's loading test decides (elastic here), on both paths; C agrees too
    (tests/test_c_reference.py)."""
    from subfric_dolfinx.constitutive._subloading.switch import (
        ROOT,
        split_point,
        unstable_start,
    )

    lit = preset("sec7-literal")
    L = lit._consts
    gap = np.array([[0.04377685, 1.1105782]])
    up, mu, r, f0 = 0.00908828, 412.43076, 0.39865093, [17.28639315, 555.42994531]
    st = InterfaceState({"up": [[up]], "mu": [mu], "r": [r], "f": [f0]}, 1)
    dt = 0.0015625
    ft = [L.at * (gap[0, 0] - up)]
    s, kind = split_point(L, f0[:1], f0[1], ft, L.an * gap[0, 1], abs(ft[0]), mu, L.xi * dt)
    assert kind == ROOT and 0.9 < s < 1.0
    for res in (lit.return_map(gap, st, dt),
                lit.return_map(np.repeat(gap, 40, 0), st.take(np.zeros(40, int)), dt)):  # fmt: skip
        assert np.all(res.status == Status.ELASTIC)
        np.testing.assert_allclose(res.traction[:, 0], ft[0], rtol=1e-15)
    # the rule itself: H(0) <= 0 at the split state, > 0 at a virgin-like one
    assert unstable_start(L, -math.expm1(-L.cn * L.an * gap[0, 1]), 0.3986, 413.84, 0.017, -86.2)
    assert not unstable_start(L, 0.1, 0.3986, 63.5, 0.017, -436.5)
