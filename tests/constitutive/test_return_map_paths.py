"""The subloading return map's paths: split, rotation, the independent reference, tolerances.

* the consistent tangent against central differences by kind of step (straight, reversal split
  through zero in 1-D, split at a 2-D near-reversal, loading switch after a turn, rotation from a
  fixed start, start along the trial; an exact 2-D reversal is a kink of the map, as of the exact
  solution: the split point's ``|f_t|`` is a cone in the gap);
* the package's one numpy map equals an independent implementation of the same algorithm in
  plain floats, point by point (``tests/reference_map``) to 1e-12, and gives the same numbers
  whatever the batch size (1, 2, 7 points or all at once);
* the implementation has one module per step and no function with more than 8 parameters;
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
from subfric_dolfinx.constitutive._subloading.switch import (
    CUSP,
    ROOT,
    Segment,
    split_point,
    unstable_start,
)
from tests import reference_map

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
        D[:, j] = (
            law.return_map(gap + e, st, dt).traction[0]
            - law.return_map(gap - e, st, dt).traction[0]
        ) / (2 * h)
    return D


def split_of(law, st, gap, dt):
    """``split_point`` of the map for its points: arrays ``(s, kind)``, kind 0 for none."""
    nt = st.n_tangential
    f0 = st["f"]
    ft = law.alpha_t * (gap[:, :nt] - st.up)
    seg = Segment(
        f0[:, :nt],
        f0[:, nt],
        ft,
        law.alpha_n * gap[:, nt],
        np.linalg.norm(ft, axis=1),
        st.mu,
        np.full(len(gap), law.xi * dt),
    )
    return split_point(law._consts, seg)


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
    s, kind = split_of(P, st, gap, dt)
    assert kind[0] == (split or 0), (s, kind)
    D = res.tangent[0]
    D_fd = central(P, gap, st, dt)
    scale = np.abs(D).max()
    np.testing.assert_allclose(D, D_fd, atol=2e-6 * scale, rtol=1e-5)
    np.testing.assert_array_equal(res.state["f"], res.traction)


def random_points(law, nt, n, rng, fmax=600.0):
    """Points with start tractions on their loading surfaces (random ``r``, ``mu``, ``f_n0``)
    and trials along, against, across them or anywhere, some separated or touching."""
    d = rng.normal(size=(n, nt))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    fn0 = rng.uniform(0.0, fmax, n)
    mu = rng.uniform(law.mu_k, law.mu_s, n)
    r = rng.uniform(0.0, 1.0, n)
    g0 = -np.expm1(-law.c_n * fn0)
    f0t = (g0 * r * mu)[:, None] * d
    kind = rng.integers(0, 4, n)  # along, against, across, random
    e = rng.normal(size=(n, nt))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    dirs = np.where((kind == 0)[:, None], d, np.where((kind == 1)[:, None], -d, e))
    trial = f0t + rng.uniform(0.0, 3.0, (n, 1)) * (g0 * mu).mean() * dirs
    up = rng.normal(0.0, 0.1, (n, nt))
    un = rng.uniform(-0.2, 1.4, n) * fmax / law.alpha_n
    un[:5] = 1e-16 * fmax / law.alpha_n  # touching
    gap = np.column_stack([up + trial / law.alpha_t, un])
    st = InterfaceState({"up": up, "mu": mu, "r": r, "f": np.column_stack([f0t, fn0])}, nt)
    return gap, st


def assert_same(res, ref, rtol):
    """The map's result ``res`` equals ``ref`` (the reference's, or the map's on other batches):
    statuses exactly, numbers to ``rtol`` of each point's scale."""
    np.testing.assert_array_equal(res.status, ref.status)
    np.testing.assert_array_equal(res.unstable, ref.unstable)
    n = len(res.status)
    sc = np.maximum(np.abs(res.tangent).reshape(n, -1).max(axis=1), 1e-300)
    np.testing.assert_array_less(
        np.abs(res.tangent - ref.tangent).reshape(n, -1).max(axis=1), rtol * sc + 1e-300
    )
    np.testing.assert_allclose(res.traction, ref.traction, rtol=rtol, atol=rtol)
    for v in ("up", "mu", "r"):
        np.testing.assert_allclose(res.state[v], getattr(ref, v), rtol=rtol, atol=1e-14)


@pytest.mark.parametrize("name", ["sec7", "sec6-mus10000", "sec7-literal"])
@pytest.mark.parametrize("nt", [1, 2])
def test_the_map_equals_the_independent_reference(name, nt):
    """The package's map against the reference in plain floats (``tests/reference_map``), point
    by point, with and without start tractions (reversals, turns, splits at the loading switch,
    separation, touching), short and long steps and one ``dt`` per point: the same statuses,
    the same numbers to 1e-12 (iteration counts may differ by one at rounding-level ties)."""
    law = preset(name)
    rng = np.random.default_rng(5 + nt)
    n = 1500
    gap, st = random_points(law, nt, n, rng, 5000.0 if name.startswith("sec6") else 600.0)
    radial = InterfaceState({k: st[k] for k in ("up", "mu", "r")}, nt)
    for state, dt in ((st, 0.05), (st, 30.0), (radial, 0.05), (st, rng.uniform(0, 2, n))):
        res = law.return_map(gap, state, dt)
        ref = reference_map.return_map(law, gap, state, dt)
        assert_same(res, ref, 1e-12)
        assert np.mean(res.iterations == ref.iterations) > 0.99
        assert np.count_nonzero(res.status == Status.PLASTIC) > n // 5


@pytest.mark.parametrize("nt", [1, 2])
def test_the_same_numbers_whatever_the_batch_size(nt):
    """One implementation for any number of points: the points 1, 2 and 7 at a time (the
    material-point driver, a rank holding a few interface points) give exactly what they give
    all at once (10^4 points, two chunks of the map)."""
    rng = np.random.default_rng(2 + nt)
    n = 10_000
    gap, st = random_points(P, nt, n, rng)
    big = P.return_map(gap, st, 0.05)
    for size in (1, 2, 7):
        idx = np.concatenate([np.arange(k, min(k + size, n)) for k in range(0, 700, size)])
        parts = [
            P.return_map(gap[i], st.take(i), 0.05)
            for i in np.split(idx, range(size, idx.size, size))
        ]
        for f in ("traction", "tangent", "status", "unstable", "iterations"):
            np.testing.assert_array_equal(
                np.concatenate([getattr(p, f) for p in parts]), getattr(big, f)[idx], err_msg=f
            )
        for v in ("up", "mu", "r", "f"):
            np.testing.assert_array_equal(
                np.concatenate([p.state[v] for p in parts]), big.state[v][idx], err_msg=v
            )


def test_the_map_is_written_once_one_module_per_step():
    """The package's map is one implementation, one module per step of its docstring, and no
    function takes more than 8 parameters (the law, settings, inputs and outputs are objects).
    ``point`` is not a step: the float path of one 1-D point's common cases, for the
    spring-slider's 1e5 steps, proven equal to the map wherever it answers
    (``test_point_map.py``)."""
    import ast
    import pathlib

    from subfric_dolfinx.constitutive import _subloading

    pkg = pathlib.Path(_subloading.__file__).parent
    names = sorted(p.stem for p in pkg.glob("*.py"))
    assert names == [
        "__init__",
        "branch",
        "common",
        "integrate",
        "point",
        "root",
        "rotation",
        "scan",
        "switch",
        "tangent",
        "trial",
    ]
    many = []
    for p in pkg.glob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                a = node.args
                count = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                if count > 8 + (a.args[:1] != [] and a.args[0].arg == "self"):
                    many.append(f"{p.name}:{node.name} ({count})")
    assert not many, many


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
        np.testing.assert_allclose(
            res.state.r, np.linalg.norm(res.traction[:, :2], axis=1) / (G * p.mu_s), rtol=1e-12
        )


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
    taken; the whole step's loading test decides (elastic here), alone and among 40 points; C
    agrees too (tests/verification/test_c_reference.py)."""
    lit = preset("sec7-literal")
    L = lit._consts
    gap = np.array([[0.04377685, 1.1105782]])
    up, mu, r, f0 = 0.00908828, 412.43076, 0.39865093, [17.28639315, 555.42994531]
    st = InterfaceState({"up": [[up]], "mu": [mu], "r": [r], "f": [f0]}, 1)
    dt = 0.0015625
    ft = L.at * (gap[0, 0] - up)
    s, kind = split_of(lit, st, gap, dt)
    assert kind[0] == ROOT and 0.9 < s[0] < 1.0
    for res in (
        lit.return_map(gap, st, dt),
        lit.return_map(np.repeat(gap, 40, 0), st.take(np.zeros(40, int)), dt),
    ):
        assert np.all(res.status == Status.ELASTIC)
        np.testing.assert_allclose(res.traction[:, 0], ft, rtol=1e-15)
    # the rule itself: H(0) <= 0 at the split state, > 0 at a virgin-like one
    g = -math.expm1(-L.cn * L.an * gap[0, 1])
    a = np.array
    assert unstable_start(
        L, a([g, 0.1]), a([0.3986] * 2), a([413.84, 63.5]), a([0.017] * 2), a([-86.2, -436.5])
    ).tolist() == [True, False]
