"""``SubloadingLaw.point_map``'s float path (``_subloading/point.py``) equals the vectorised map.

One implementation of the algorithm is the rule; the float path runs the vectorised map's
common one-point, 1-D cases operation for operation and hands every other case back
(``None``). Every point it answers must give the vectorised map's traction, tangent and state
to round-off and the same status and stability flag (the same iteration count, but for one
more or less in a long bisection, where a bracket test meets round-off), over

* the fuzz batches of ``tests/fuzz_support.py`` (1-D, with and without start tractions, the
  laws of the fuzz strategy, several ``dt``), and
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
from subfric_dolfinx.constitutive._subloading.point import point_step
from subfric_dolfinx.constitutive.tolerances import CONTACT_TOL, LOAD_TOL
from subfric_dolfinx.driver import SliderCase, run_slider
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
    has_f = "f" in state
    answered = 0
    for i in range(gap.shape[0]):
        f0 = (float(state["f"][i, 0]), float(state["f"][i, 1])) if has_f else None
        o = point_step(
            L,
            float(gap[i, 0]),
            float(gap[i, 1]),
            float(state["up"][i, 0]),
            float(state["mu"][i]),
            float(state["r"][i]),
            f0,
            float(dt),
            LOAD_TOL,
            100,
            contact_tol,
        )
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
        np.testing.assert_allclose(o[:7], want, rtol=RTOL, atol=0, err_msg=f"point {i}")
        assert res.tangent[i, 1, 0] == 0.0 and res.tangent[i, 1, 1] == law.alpha_n
        assert (o[7], o[8]) == (res.status[i], res.unstable[i]), i
        # the count of a long bisection may differ by one where a bracket test meets round-off
        assert abs(o[9] - res.iterations[i]) <= (1 if res.iterations[i] > 20 else 0), i
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
    for name in ("sec7", "sec7-literal", "sec6-mus10000", "sec6-mus10000-literal"):
        for dt in (0.0, 1e-3, 1.0):
            b = make_batch(preset(name), 1, dt, 7, 2000, start=start)
            a, n = compare(b.law, b.gap, b.state, b.dt)
            seen[0] += a
            seen[1] += n
    print(f"start tractions {start}: {seen[0]} of {seen[1]} points through the float path")
    assert seen[0] > 0.3 * seen[1]


LAW = SubloadingLaw(
    alpha_t=5000.0,
    alpha_n=5000.0,
    mu_s=500.0,
    mu_k=300.0,
    kappa=20.0,
    xi=2.0,
    u_tilde=50.0,
    c_n=2e-4,
)


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
    gap = np.array([[a[1], a[2]] for a in rows])
    by_dt: dict = {}
    for i, a in enumerate(rows):
        by_dt.setdefault(a[7], []).append(i)
    answered = 0
    for dt, idx in by_dt.items():
        idx = np.array(idx)
        state = InterfaceState(
            {
                "up": np.array([[rows[i][3]] for i in idx]),
                "mu": np.array([rows[i][4] for i in idx]),
                "r": np.array([rows[i][5] for i in idx]),
                "f": np.array([rows[i][6] for i in idx]),
            },
            1,
        )
        answered += compare(law, gap[idx], state, dt)[0]
    print(f"{len(rows)} calls compared, {answered} through the float path")
    assert answered > 0.9 * len(rows)
