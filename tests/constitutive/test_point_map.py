"""``SubloadingLaw.point_map``'s float path (``_subloading/point.py``) equals the vectorised map.

One implementation of the algorithm is the rule; the float path runs the vectorised map's
common one-point, 1-D cases operation for operation and hands every other case back
(``None``). Every point it answers must give the vectorised map's traction, tangent and state
to 1e-12 of each point's scale and the same status and stability flag (the same iteration
count, but for one more or less in a long bisection, where a bracket test meets round-off),
over

* the fuzz batches of ``tests/fuzz_support.py`` (1-D, with and without start tractions, the
  laws of the fuzz strategy, several ``dt``);
* the points the vectorised map is checked on against the independent reference
  (``test_return_map_paths.random_points``: reversals, reloads, separation, touching; 1-D);
* the material-point stability catalogue (``tests/stability``, the driver's 2-D runs along
  ``x1``): each one-point call whose second tangential components are zero, as the 1-D point
  it is; and
* every one-point call made by spring-slider runs (stick-slip, steady sliding: the sequences a
  driver produces, with reloads slower than the recovery and back-slips).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from subfric_dolfinx.constitutive import InterfaceState, SubloadingLaw, preset
from subfric_dolfinx.constitutive import subloading as S
from subfric_dolfinx.constitutive._subloading.common import Settings
from subfric_dolfinx.constitutive._subloading.point import point_step
from subfric_dolfinx.constitutive.tolerances import CONTACT_TOL, LOAD_TOL
from subfric_dolfinx.driver import SliderCase, run_slider
from tests.constitutive.test_return_map_paths import random_points
from tests.driver.slider_reference import STICK_SLIP_LAW
from tests.fuzz_support import contact_tols, fuzz_settings, make_batch, subloading_laws, time_steps

pytestmark = [
    pytest.mark.numpy_only,
    pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning"),
]

RTOL = 1e-12  # relative, on each float output (the two use libm and numpy's transcendentals)


def compare(law, gap, state, dt, contact_tol=CONTACT_TOL):
    """Point by point: the float path against one call of the vectorised map on all points.

    Returns (points answered by the float path, points).
    """
    res = law.return_map(gap, state, dt, contact_tol=contact_tol)
    L = law._consts
    cfg = Settings(LOAD_TOL, 100, contact_tol)
    has_f = "f" in state
    answered = 0
    for i in range(gap.shape[0]):
        f0 = (float(state["f"][i, 0]), float(state["f"][i, 1])) if has_f else None
        dt_i = float(dt if np.ndim(dt) == 0 else dt[i])
        st = (float(state["up"][i, 0]), float(state["mu"][i]), float(state["r"][i]), f0)
        o = point_step(L, (float(gap[i, 0]), float(gap[i, 1])), st, dt_i, cfg)
        if o is None:
            continue
        answered += 1
        want = (
            res.traction[i, 0],
            res.traction[i, 1],
            res.tangent[i, 0, 0],
            res.tangent[i, 0, 1],
            res.state["up"][i, 0],
            res.state["mu"][i],
            res.state["r"][i],
        )
        # each number to RTOL of its point's scale (as the map against the reference map,
        # test_return_map_paths.assert_same): the tangent's (D_tt = alpha_t (1 - alpha_t / H)
        # cancels), the traction's; the state to RTOL and 1e-14
        sc_D = max(np.abs(res.tangent[i]).max(), 1e-300)
        sc_f = max(np.abs(res.traction[i]).max(), 1e-300)
        got, want = np.array(o[:7]), np.array(want)
        err = np.abs(got - want)
        bound = np.array([sc_f, sc_f, sc_D, sc_D, 0, 0, 0]) * RTOL
        bound[4:] = RTOL * np.abs(want[4:]) + 1e-14
        assert np.all(err <= bound), (i, got, want)
        assert res.tangent[i, 1, 0] == 0.0 and res.tangent[i, 1, 1] == law.alpha_n
        assert (o[7], o[8]) == (res.status[i], res.unstable[i]), i
        # the count of a long bisection may differ by one where a bracket test meets round-off
        assert abs(o[9] - res.iterations[i]) <= (1 if res.iterations[i] > 20 else 0), (
            i,
            o[9],
            res.iterations[i],
            res.status[i],
        )
    return answered, gap.shape[0]


@pytest.mark.parametrize("start", [False, True])
def test_float_path_equals_the_vectorised_map_on_the_fuzz_batches(start):
    seen = [0, 0]

    @fuzz_settings(60)
    @given(law=subloading_laws(), dt=time_steps, seed=st.integers(0, 2**31), ctol=contact_tols)
    def run(law, dt, seed, ctol):
        b = make_batch(law, 1, dt, seed, 500, start=start, contact_tol=ctol)
        a, n = compare(law, b.gap, b.state, b.dt, ctol)
        seen[0] += a
        seen[1] += n

    run()
    assert seen[0] > 0, seen  # the drawn batches reach the float path
    fixed = [0, 0]  # the presets' batches (a fixed seed): the share the float path answers
    for name in ("sec7", "sec7-literal", "sec6-mus10000", "sec6-mus10000-literal"):
        for dt in (0.0, 1e-3, 1.0):
            b = make_batch(preset(name), 1, dt, 7, 2000, start=start)
            a, n = compare(b.law, b.gap, b.state, b.dt)
            fixed[0] += a
            fixed[1] += n
    print(f"start tractions {start}: drawn {seen}, presets {fixed} (answered, points)")
    assert fixed[0] > 0.3 * fixed[1], fixed


LAW = SubloadingLaw(**STICK_SLIP_LAW)


@pytest.mark.parametrize(
    ("law", "k", "V", "t_end"),
    [(LAW, 50.0, 0.1, 8.0), (LAW, 1000.0, 0.03, 2.0), (preset("sec7"), 5.0, 1.0, 2.0)],
)
def test_float_path_equals_the_vectorised_map_on_slider_runs(law, k, V, t_end, monkeypatch):
    calls = []
    orig = S.point_step

    def record(*a):
        calls.append(a)
        return orig(*a)

    monkeypatch.setattr(S, "point_step", record)
    run_slider(SliderCase(law, 1.0, k, V, 300.0, t_end))
    monkeypatch.undo()
    assert len(calls) > 100
    rows = calls[:: max(1, len(calls) // 3000)]
    by_dt: dict = {}
    for i, a in enumerate(rows):
        by_dt.setdefault(a[3], []).append(i)
    answered = 0
    for dt, idx in by_dt.items():
        gap = np.array([rows[i][1] for i in idx])
        state = InterfaceState(
            {
                "up": np.array([[rows[i][2][0]] for i in idx]),
                "mu": np.array([rows[i][2][1] for i in idx]),
                "r": np.array([rows[i][2][2] for i in idx]),
                "f": np.array([rows[i][2][3] for i in idx]),
            },
            1,
        )
        answered += compare(law, gap, state, dt)[0]
    print(f"{len(rows)} calls compared, {answered} through the float path")
    assert answered > 0.9 * len(rows)


@pytest.mark.parametrize("name", ["sec7", "sec6-mus10000", "sec7-literal"])
def test_float_path_equals_the_vectorised_map_on_the_reference_points(name):
    law = preset(name)
    rng = np.random.default_rng(11)
    n = 1500
    gap, st = random_points(law, 1, n, rng, 5000.0 if name.startswith("sec6") else 600.0)
    radial = InterfaceState({k: st[k] for k in ("up", "mu", "r")}, 1)
    answered = 0
    for state, dt in ((st, 0.05), (st, 30.0), (radial, 0.05), (st, rng.uniform(0, 2, n))):
        answered += compare(law, gap, state, dt)[0]
    print(f"{name}: {answered} of {4 * n} points through the float path")
    assert answered > 0.2 * 4 * n


def rest(state, i):
    return state["mu"][i], state["r"][i]


def test_float_path_equals_the_vectorised_map_on_the_stability_catalogue(monkeypatch):
    from tests.stability import POINT_CASES

    calls = []
    orig = SubloadingLaw.return_map

    def record(self, gap, state, dt, **kw):
        g = np.asarray(gap, dtype=float)
        if np.ndim(dt) == 0 and len(calls) < 400_000:
            for i in range(g.shape[0]):
                if g.shape[1] == 2:  # 1-D
                    f = None if "f" not in state else tuple(state["f"][i])
                    calls.append((self, g[i, 0], g[i, 1], state["up"][i, 0], *rest(state, i), f))
                elif g[i, 1] == 0.0 and state["up"][i, 1] == 0.0:  # 2-D along x1
                    f = None if "f" not in state else (state["f"][i, 0], state["f"][i, 2])
                    if f is None or state["f"][i, 1] == 0.0:
                        calls.append(
                            (self, g[i, 0], g[i, 2], state["up"][i, 0], *rest(state, i), f)
                        )
                if calls and len(calls[-1]) == 7:
                    calls[-1] = (*calls[-1], float(dt))
        return orig(self, gap, state, dt, **kw)

    monkeypatch.setattr(SubloadingLaw, "return_map", record)
    for case in POINT_CASES:
        try:
            case.run(None)
        except Exception:  # (the catalogue's errors are its own tests' business)
            pass
    monkeypatch.undo()
    assert len(calls) > 1000
    rows = calls[:: max(1, len(calls) // 20000)]
    answered = 0
    groups: dict = {}
    for a in rows:
        groups.setdefault((id(a[0]), a[6] is None), []).append(a)
    for (_, radial), items in groups.items():
        law = items[0][0]
        gap = np.array([[a[1], a[2]] for a in items])
        arrays = {
            "up": np.array([[a[3]] for a in items]),
            "mu": np.array([a[4] for a in items]),
            "r": np.array([a[5] for a in items]),
        }
        if not radial:
            arrays["f"] = np.array([a[6] for a in items])
        dts = np.array([a[7] for a in items])
        answered += compare(law, gap, InterfaceState(arrays, 1), dts)[0]
    print(f"stability catalogue: {len(rows)} calls compared, {answered} through the float path")
    assert answered > 0.3 * len(rows)


def test_point_map_returns_the_vectorised_map_where_the_float_path_declines():
    """``point_map`` itself: the float path's answer, else the numpy map's result unpacked (a
    separated point, a touching one, a reversal through zero inside the step, a bad state)."""
    law = preset("sec7")
    un = 300.0 / law.alpha_n
    f0 = (20.0, 300.0)
    cases = [
        (0.01, -0.1, 0.0, law.mu_s, 0.5, None),  # separated
        (0.01, 1e-20, 0.0, law.mu_s, 0.5, None),  # touching
        (-0.05, un, 0.0, 400.0, 0.9, f0),  # f_t from +20 MPa to about -25: a cusp split
        (0.01, un, 0.0, 2 * law.mu_s, 0.5, None),  # mu out of range: FAILED
        (0.05, un, 0.0, 400.0, 0.9, f0),  # plastic, on floats
    ]
    L = law._consts
    for ut, ubn, up, mu, r, f in cases:
        arrays = {"up": np.array([[up]]), "mu": np.array([mu]), "r": np.array([r])}
        if f is not None:
            arrays["f"] = np.array([f])
        res = law.return_map(np.array([[ut, ubn]]), InterfaceState(arrays, 1), 0.01)
        got = law.point_map((ut, ubn), (up, mu, r, f), 0.01)
        want = (
            res.traction[0, 0],
            res.traction[0, 1],
            res.tangent[0, 0, 0],
            res.tangent[0, 0, 1],
            res.state["up"][0, 0],
            res.state["mu"][0],
            res.state["r"][0],
            res.status[0],
            res.unstable[0],
            res.iterations[0],
        )
        cfg = Settings(LOAD_TOL, 100, CONTACT_TOL)
        floats = point_step(L, (ut, ubn), (up, mu, r, f), 0.01, cfg)
        if floats is None:  # the numpy map's own numbers
            assert got == tuple(type(g)(w) for g, w in zip(got, want, strict=True))
        else:
            assert got == floats
            np.testing.assert_allclose(got[:7], want[:7], rtol=1e-12, atol=1e-14)
    with pytest.raises(ValueError, match="dt"):
        law.point_map((0.0, un), (0.0, law.mu_s, 0.0, None), -1.0)
