"""Return map of the subloading-friction law and of Coulomb: exactness, robustness, tangent."""

import numpy as np
import pytest

from subfric_dolfinx.constitutive import (
    CoulombLaw,
    InterfaceState,
    StatePair,
    Status,
    SubloadingLaw,
    preset,
)

pytestmark = pytest.mark.numpy_only

BASE = dict(alpha_t=500.0, alpha_n=800.0, mu_s=500.0, mu_k=63.0, kappa=98 / 63, xi=11 / 500)
BASE.update(u_tilde=15.0, c_n=2e-4)


def law(**kw):
    return SubloadingLaw(**{**BASE, **kw})


def drive(p, path, dt_per_step, state=None):
    """Run gaps (steps, m) through the return map; return tractions, states, statuses."""
    nt = path.shape[1] - 1
    st = state if state is not None else p.initial_state(1, nt)
    out = []
    for gap in path:
        res = p.return_map(gap[None, :], st, dt_per_step)
        st = res.state
        out.append((res.traction[0].copy(), st.copy(), int(res.status[0])))
    return out


@pytest.mark.parametrize("n_steps", [1, 7, 50, 400])
def test_closed_form_without_softening_or_recovery(n_steps):
    """kappa = xi = 0: mu is constant and cos(pi r / 2) = exp(-pi u_tilde up / 2) exactly, so
    every step size lands on ubar = up + g mu r(up) / alpha_t."""
    p = law(kappa=0.0, xi=0.0, mu0=400.0)
    fn = 300.0
    g = 1.0 - np.exp(-p.c_n * fn)
    ub = np.linspace(0, 0.6, n_steps + 1)[1:]
    path = np.column_stack([ub, np.full_like(ub, fn / p.alpha_n)])
    res = drive(p, path, 1.0)
    for (f, st, status), u in zip(res, ub, strict=True):
        up = st.up[0, 0]
        r_exact = 2 / np.pi * np.arccos(np.exp(-np.pi * p.u_tilde * up / 2))
        assert status == Status.PLASTIC
        assert st.mu[0] == 400.0
        assert abs(st.r[0] - r_exact) < 1e-12
        assert abs(f[0] - g * 400.0 * r_exact) < 1e-9 * g * 400.0
        assert abs(u - (up + f[0] / p.alpha_t)) < 1e-13
        assert f[1] == pytest.approx(fn, rel=1e-15)


def test_inputs_are_never_mutated_and_out_is_filled():
    p = preset("sec7")
    rng = np.random.default_rng(1)
    n = 200
    st = InterfaceState.from_arrays(
        up=rng.normal(0, 0.1, (n, 2)), mu=rng.uniform(p.mu_k, p.mu_s, n), r=rng.uniform(0, 1, n)
    )
    gap = np.column_stack([rng.normal(0, 0.3, (n, 2)), rng.normal(0.2, 0.5, n)])
    copies = [a.copy() for a in (st.up, st.mu, st.r, gap)]
    out = p.initial_state(n, 2)
    res = p.return_map(gap, st, 0.1, out=out)
    for a, c in zip((st.up, st.mu, st.r, gap), copies, strict=True):
        np.testing.assert_array_equal(a, c)
    assert res.state is out
    assert not np.array_equal(out.r, np.zeros(n))
    with pytest.raises(ValueError, match="out must not be the input state"):
        p.return_map(gap, st, 0.1, out=st)


def test_state_pair_commit_and_revert():
    p = preset("sec7")
    pair = StatePair(p.initial_state(3, 1))
    res = p.return_map(np.array([[0.5, 1.0]] * 3), pair.old, 0.1, out=pair.new)
    assert res.state is pair.new and np.all(pair.new.up > 0)
    pair.revert()
    np.testing.assert_array_equal(pair.new.up, 0.0)
    p.return_map(np.array([[0.5, 1.0]] * 3), pair.old, 0.1, out=pair.new)
    pair.commit()
    np.testing.assert_array_equal(pair.old.up, pair.new.up)
    assert np.all(pair.old.up > 0)


SINGULAR = {
    # name: (state r, state mu, gap, dt)
    "r=0 (U(0)=inf), plastic": (0.0, None, [0.3, 0.0, 0.5], 0.1),
    "f_t=0 (t_f = 0/0)": (0.4, None, [0.0, 0.0, 0.5], 0.1),
    "f_n=0 (F = 0/0)": (0.4, None, [0.2, 0.1, 0.0], 0.1),
    "f_n tiny positive": (0.4, None, [0.2, 0.1, 1e-300], 0.1),
    "f_n subnormal": (0.4, None, [0.2, 0.1, 5e-324], 0.1),
    "r=1 exactly": (1.0, None, [0.3, 0.0, 0.5], 0.1),
    "a=b=0 (no slip, dt=0)": (0.5, None, [0.0, 0.0, 0.5], 0.0),
    "tiny step (expm1)": (0.5, None, [1e-14, 0.0, 0.5], 1e-300),
    "huge step": (0.5, None, [1e6, -1e6, 1e4], 1e12),
    "huge penetration": (0.5, None, [0.3, 0.0, 1e12], 0.1),
    "mu at mu_k": (0.9, "k", [0.3, 0.2, 0.5], 0.0),
    "separation": (0.9, None, [0.3, 0.2, -0.5], 0.1),
}


@pytest.mark.parametrize("name", list(SINGULAR))
@pytest.mark.parametrize(
    "preset_name", ["sec7", "sec6-mus10000", "sec6-mus10000-literal", "sec7-literal"]
)
def test_singular_spots_give_finite_results(name, preset_name):
    p = preset(preset_name)
    r0, mu0, gap, dt = SINGULAR[name]
    mu = p.mu_k if mu0 == "k" else p.mu_s
    st = InterfaceState.from_arrays(up=[[0.0, 0.0]], mu=[mu], r=[r0])
    res = p.return_map(np.array([gap]), st, dt)
    assert res.converged, res.counts()
    for a in (res.traction, res.tangent, res.state.up, res.state.mu, res.state.r):
        assert np.all(np.isfinite(a)), (name, a)
    assert p.mu_k <= res.state.mu[0] <= p.mu_s
    assert 0.0 <= res.state.r[0] <= 1.0
    if gap[2] <= 0.0:
        assert (
            res.status[0] == Status.SEPARATED
            and np.all(res.traction == 0.0)
            and res.state.r[0] == 0
        )
    ft = np.linalg.norm(res.traction[0, :2])
    g = -np.expm1(-p.c_n * max(p.alpha_n * gap[2], 0.0))
    assert ft <= g * res.state.mu[0] * (1 + 1e-12) + 1e-300


def test_non_finite_input_is_reported_with_its_index_and_never_nan():
    p = preset("sec7")
    gap = np.array([[0.1, 0.0, 0.2], [np.nan, 0.0, 0.2], [0.1, np.inf, 0.2], [0.2, 0.0, 0.3]])
    st = p.initial_state(4, 2)
    st.up[3, 0] = np.nan
    res = p.return_map(gap, st, 0.1)
    np.testing.assert_array_equal(res.failed_indices, [1, 2, 3])
    assert not res.converged
    assert res.status[0] != Status.FAILED
    for a in (res.traction, res.tangent, res.state.mu, res.state.r):
        assert np.all(np.isfinite(a))
    assert np.all(res.traction[1:3] == 0.0)


def fd_tangent(p, gap, st, dt, h):
    m = gap.shape[1]
    D = np.zeros((m, m))
    for j in range(m):
        e = np.zeros(m)
        e[j] = h
        fp = p.return_map(gap + e, st, dt).traction[0]
        fm = p.return_map(gap - e, st, dt).traction[0]
        D[:, j] = (fp - fm) / (2 * h)
    return D


TANGENT_CASES = {
    # name: (state r, state mu fraction between mu_k and mu_s, gap, expected status)
    "elastic": (0.8, 1.0, [0.01, 0.005, 0.4], Status.ELASTIC),
    "plastic early": (0.1, 1.0, [0.05, 0.02, 0.4], Status.PLASTIC),
    "plastic softening": (0.7, 0.8, [0.3, 0.1, 0.4], Status.PLASTIC),
    "near separation": (0.5, 0.9, [0.2, 0.05, 1e-3], Status.PLASTIC),
    "near r = 1": (0.999, 0.5, [0.5, 0.2, 0.6], Status.PLASTIC),
}


@pytest.mark.parametrize("nt", [1, 2])
@pytest.mark.parametrize("case", list(TANGENT_CASES))
def test_consistent_tangent_matches_finite_differences(case, nt):
    p = preset("sec7")
    r0, frac, gap, expected = TANGENT_CASES[case]
    gap = np.array([[*gap[:nt], gap[2]]])
    mu = p.mu_k + frac * (p.mu_s - p.mu_k)
    st = InterfaceState.from_arrays(up=np.zeros((1, nt)), mu=[mu], r=[r0])
    res = p.return_map(gap, st, 0.05)
    assert res.status[0] == expected
    D = res.tangent[0]
    h = 1e-7 * max(1e-3, np.abs(gap).max())
    D_fd = fd_tangent(p, gap, st, 0.05, h)
    scale = np.abs(D).max()
    np.testing.assert_allclose(D, D_fd, atol=1e-6 * scale, rtol=1e-5)
    if expected == Status.PLASTIC:
        assert abs(D[0, nt] - D[nt, 0]) > 1e-6 * scale  # unsymmetric: g depends on f_n


def test_frame_invariance_in_the_tangential_plane():
    p = preset("sec6-mus10000")
    rng = np.random.default_rng(7)
    n = 500
    up = rng.normal(0, 0.05, (n, 2))
    st = InterfaceState.from_arrays(
        up=up, mu=rng.uniform(p.mu_k, p.mu_s, n), r=rng.uniform(0, 1, n)
    )
    gap = np.column_stack([up + rng.normal(0, 0.5, (n, 2)), rng.uniform(-0.1, 1.0, n)])
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    st_rot = InterfaceState.from_arrays(up=up @ R.T, mu=st.mu, r=st.r)
    gap_rot = np.column_stack([gap[:, :2] @ R.T, gap[:, 2]])
    a = p.return_map(gap, st, 0.3)
    b = p.return_map(gap_rot, st_rot, 0.3)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_allclose(b.traction[:, :2], a.traction[:, :2] @ R.T, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(b.traction[:, 2], a.traction[:, 2], rtol=1e-14)
    np.testing.assert_allclose(b.state.up, a.state.up @ R.T, rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(b.state.mu, a.state.mu, rtol=1e-11)
    Q = np.eye(3)
    Q[:2, :2] = R
    np.testing.assert_allclose(b.tangent, Q @ a.tangent @ Q.T, rtol=1e-8, atol=1e-8 * p.alpha_t)


def test_fold_is_reported_as_a_jump_at_the_same_load_for_any_step():
    """Strong softening without recovery: alpha_t / g < kappa (mu - mu_k) near r = 1 gives a
    snap-back; displacement control must jump at the fold, wherever the steps fall."""
    p = SubloadingLaw(
        alpha_t=100.0,
        alpha_n=100.0,
        mu_s=1000.0,
        mu_k=500.0,
        kappa=1.0,
        xi=0.0,
        u_tilde=15.0,
        c_n=2e-4,
    )
    fn = 10000.0
    where = []
    for n in (50, 500, 5000):
        ub = np.linspace(0, 20, n + 1)[1:]
        res = drive(p, np.column_stack([ub, np.full(n, fn / p.alpha_n)]), 0.0)
        statuses = np.array([s for _, _, s in res])
        jumps = np.flatnonzero(statuses == Status.JUMP)
        assert len(jumps) == 1, statuses
        ft = np.array([f[0] for f, _, _ in res])
        drop = ft[jumps[0] - 1] - ft[jumps[0]]
        where.append((ub[jumps[0]], drop))
        assert np.all(statuses[statuses != Status.JUMP] == Status.PLASTIC)
    # the fold is at about 8.05 mm and the drop about 345 MPa, independent of the step
    for u, drop in where:
        assert 8.0 <= u <= 8.45 and 330 < drop < 360, where
    assert abs(where[-1][0] - where[-2][0]) < 0.05


def test_coulomb_return_map():
    p = CoulombLaw(alpha_t=1000.0, alpha_n=2000.0, mu_c=0.3)
    st = p.initial_state(3, 2)
    gap = np.array([[1e-4, 0.0, 0.01], [0.03, 0.04, 0.01], [0.03, 0.04, -0.01]])
    res = p.return_map(gap, st, 1.0)
    np.testing.assert_array_equal(res.status, [Status.ELASTIC, Status.PLASTIC, Status.SEPARATED])
    fn = 20.0
    np.testing.assert_allclose(res.traction[0], [0.1, 0.0, fn])
    np.testing.assert_allclose(res.traction[1], [0.3 * fn * 0.6, 0.3 * fn * 0.8, fn])
    np.testing.assert_allclose(res.state.up[1], (0.05 - 6.0 / 1000.0) * np.array([0.6, 0.8]))
    assert np.all(res.traction[2] == 0.0)
    D_fd = fd_tangent(p, gap[1:2], st.take([1]), 1.0, 1e-8)
    np.testing.assert_allclose(res.tangent[1], D_fd, rtol=1e-6, atol=1e-6)


def test_parameters_are_immutable():
    """(Bad parameter values are in the catalogue of bad inputs, tests/bad_inputs/.)"""
    p = law()
    with pytest.raises(AttributeError):
        p.kappa = 1.0
    assert p.kappa == BASE["kappa"]
