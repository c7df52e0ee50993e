"""The C reference of the throughput benchmark (benchmarks/c_reference) computes what the package's
map computes: same statuses, traction and tangent to round-off, on points with reversals, turns,
splits at the loading switch, recovery, separation and touching, with and without start
tractions. (Skipped without a C compiler; the benchmark says so too.)"""

import numpy as np
import pytest

from benchmarks.c_reference import c_map
from subfric_dolfinx.constitutive import InterfaceState, preset

pytestmark = pytest.mark.numpy_only


@pytest.fixture(scope="module")
def cmap():
    fn = c_map.load()
    if fn is None:
        pytest.skip(c_map.reason())
    return fn


def points(P, nt, n, rng, fmax):
    d = rng.normal(size=(n, nt))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    fn0 = rng.uniform(0.0, fmax, n)
    mu = rng.uniform(P.mu_k, P.mu_s, n)
    r = rng.uniform(0.0, 1.0, n)
    g0 = -np.expm1(-P.c_n * fn0)
    f0t = (g0 * r * mu)[:, None] * d
    kind = rng.integers(0, 4, n)  # along, against (reversal), across (turn), random
    e = rng.normal(size=(n, nt))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    dirs = np.where((kind == 0)[:, None], d, np.where((kind == 1)[:, None], -d, e))
    trial = f0t + rng.uniform(0.0, 3.0, (n, 1)) * (g0 * mu).mean() * dirs
    up = rng.normal(0.0, 0.1, (n, nt))
    un = rng.uniform(-0.2, 1.4, n) * fmax / P.alpha_n
    un[:50] = 1e-16  # touching
    gap = np.column_stack([up + trial / P.alpha_t, un])
    return gap, up, mu, r, np.column_stack([f0t, fn0])


@pytest.mark.parametrize("name", ["sec7", "sec6-mus10000", "sec7-literal"])
@pytest.mark.parametrize("nt", [1, 2])
@pytest.mark.parametrize("dt", [0.05, 30.0])
def test_c_reference_equals_the_package_map(cmap, name, nt, dt):
    P = preset(name)
    rng = np.random.default_rng(11)
    gap, up, mu, r, f = points(P, nt, 3000, rng, 5000.0 if name.startswith("sec6") else 600.0)
    for with_f in (True, False):
        st = InterfaceState({"up": up, "mu": mu, "r": r, **({"f": f} if with_f else {})}, nt)
        res = P.return_map(gap, st, dt)
        c = cmap(P, gap, up, mu, r, f if with_f else None, dt)
        use = c["status"] != c_map.NEEDS_SCAN  # (the C reference has no branch-and-bound scan)
        assert use.sum() > (900 if name.endswith("literal") else 2900)
        np.testing.assert_array_equal(c["status"][use], res.status[use])
        sc = np.abs(res.tangent).reshape(len(gap), -1).max(axis=1)[:, None]
        np.testing.assert_allclose(
            c["traction"][use], res.traction[use], rtol=0, atol=1e-12 * sc[use].max()
        )
        dD = np.abs(c["tangent"] - res.tangent).reshape(len(gap), -1).max(axis=1)
        assert np.all(dD[use] <= 1e-10 * sc[use, 0]), dD[use].max()
        np.testing.assert_allclose(c["mu"][use], res.state["mu"][use], rtol=1e-12)
        np.testing.assert_allclose(c["up"][use], res.state["up"][use], rtol=0, atol=1e-12)
        assert np.mean(c["iterations"][use] == res.iterations[use]) > 0.999
