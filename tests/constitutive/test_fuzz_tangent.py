"""The consistent tangent of the fuzzed return maps against central differences.

Random parameter sets with moderate magnitudes (both paper readings included), nt = 1 and 2,
with and without start tractions (reversal splits and rotations of the flow direction: the
tangent must be exact there too, ``tests/fuzz_support.py``), and Coulomb.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from subfric_dolfinx.constitutive import (
    PRESETS,
    CoulombLaw,
    InterfaceState,
    Status,
    SubloadingLaw,
    preset,
)
from tests.fuzz_support import (
    Batch,
    coulomb_laws,
    decades,
    fuzz_settings,
    log_uniform,
    maybe_rotated,
    mu_r,
    rnorm,
    rotation_ill_conditioned,
    saturation,
    seeds,
    state_of,
    with_start_traction,
    yield_scales,
    yield_size,
    zero_or,
)

pytestmark = pytest.mark.numpy_only


def fd_sample_laws():
    """Laws for which central differences are meaningful: moderate magnitudes (no subnormal g,
    no step below the float resolution of the gap), both paper readings included."""

    @st.composite
    def laws(draw):
        if draw(st.integers(0, 3)) == 0:
            return preset(draw(st.sampled_from(sorted(PRESETS))))
        mu_k = draw(decades(-1, 4))
        return SubloadingLaw(
            alpha_t=draw(decades(0, 5)),
            alpha_n=draw(decades(0, 5)),
            mu_k=mu_k,
            mu_s=mu_k * draw(st.one_of(st.just(1.0), decades(-3, 1).map(lambda v: 1 + v))),
            kappa=draw(zero_or(decades(-4, 1))) / mu_k,
            xi=draw(zero_or(decades(-3, 1))),
            u_tilde=draw(decades(-1, 2)),
            c_n=draw(decades(-5, -1)),
        )

    return laws()


def fd_candidates(law, nt, dt, seed, n=400, start=False):
    """Points away from kinks: r_n and the end r away from 0 and 1, f_n away from 0, trials
    clearly inside (elastic) or outside (plastic) the subloading surface grown by recovery;
    ``start``: with start tractions (subloading law)."""
    rng = np.random.default_rng(seed)
    Y, Fn, mu_k, mu_s = yield_scales(law)
    sub = isinstance(law, SubloadingLaw)
    r = rng.uniform(0.05, 0.95, n)
    mu = mu_k + (mu_s - mu_k) * rng.uniform(0.0, 1.0, n)
    up = rng.normal(size=(n, nt)) * (Y / law.alpha_t)
    fn = Fn * log_uniform(rng, -2, 0.7, n)
    g = saturation(law, fn)
    cap = g * (mu_s if sub else 1.0)
    d = rng.normal(size=(n, nt))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    A = cap * rng.uniform(0.05, 1.5, n)
    gap = np.column_stack([up + (A / law.alpha_t)[:, None] * d, fn / law.alpha_n])
    state = InterfaceState.from_arrays(up=up, mu=mu, r=r) if sub else state_of(law, up, mu, r)
    if start and sub:
        state = with_start_traction(law, gap, state, seed)
    return Batch(law, gap, state, float(dt))


def central_differences(b, idx, rel_h):
    """Central differences of the traction at points ``idx``, steps ``rel_h`` times a
    per-component scale (|ubar_t - up| for tangential components, ubar_n for the normal one).
    Returns (D_fd, statuses of all perturbed evaluations)."""
    nt, m = b.nt, b.nt + 1
    gap, st0 = b.gap[idx], b.state.take(idx)
    k = idx.size
    h = np.empty((k, m))
    h[:, :nt] = rel_h * rnorm(gap[:, :nt] - st0.up)[:, None]
    h[:, nt] = rel_h * gap[:, nt]
    gaps, states = [], []
    for j in range(m):
        for sign in (1.0, -1.0):
            gj = gap.copy()
            gj[:, j] += sign * h[:, j]
            gaps.append(gj)
            states.append(st0)
    big = InterfaceState(
        {k: np.concatenate([s[k] for s in states]) for k in st0.names}, st0.n_tangential
    )  # (the start traction, when there is one, goes with the state)
    res = b.law.return_map(np.concatenate(gaps), big, b.dt)
    tr = res.traction.reshape(m, 2, k, m)
    # use the steps actually taken (rounding of gap + h)
    taken = np.stack([gaps[2 * j][:, j] - gaps[2 * j + 1][:, j] for j in range(m)], axis=1)
    D = (tr[:, 0] - tr[:, 1]).transpose(1, 2, 0) / taken[:, None, :]
    return D, res.status.reshape(m, 2, k)


def scaled(D, b, idx):
    """Dimensionless tangent: rows by the traction scale, columns by the gap scale."""
    nt = b.nt
    gap, up = b.gap[idx], b.state.up[idx]
    fn = b.law.alpha_n * gap[:, nt]
    row = np.empty((idx.size, nt + 1))
    row[:, :nt] = yield_size(b.law, fn)[:, None]
    row[:, nt] = fn
    col = np.empty((idx.size, nt + 1))
    col[:, :nt] = rnorm(gap[:, :nt] - up)[:, None]
    col[:, nt] = gap[:, nt]
    return D * col[:, None, :] / row[:, :, None]


def check_tangent(b, seed, counter, n_sample=24):
    res = b.run()
    law, nt = b.law, b.nt
    sub = isinstance(law, SubloadingLaw)
    trial = law.alpha_t * (b.gap[:, :nt] - b.state.up)
    A = rnorm(trial)
    fn = law.alpha_n * b.gap[:, nt]
    g, cap = saturation(law, fn), yield_size(law, fn)
    if sub:
        mu_rec = b.state.mu + (law.mu_s - b.state.mu) * -np.expm1(-law.xi * b.dt)
        phi0 = A - g * b.state.r * mu_rec
    else:
        phi0 = A - g
    margin = np.abs(phi0) > 0.02 * cap
    r1 = mu_r(law, res.state, res.traction)[1]
    ok = margin & ~res.unstable & (r1 > 0.02) & (r1 < 0.98)
    if b.has_start and nt == 2:  # not at the kink of an exact 2-D reversal
        ok &= ~(maybe_rotated(b) & rotation_ill_conditioned(b))
    rng = np.random.default_rng(seed)
    for st_want in (Status.ELASTIC, Status.PLASTIC):
        cand = np.flatnonzero(ok & (res.status == st_want))
        if st_want == Status.PLASTIC and sub:
            # away from a fold: -phi' = H not small against alpha_t (tangent ~ alpha_t^2 / H)
            # along the trial direction n*, D_tt = alpha_t (1 - alpha_t / H)
            nstar = trial / np.maximum(A, 1e-300)[:, None]
            D_nn = np.einsum("ni,nij,nj->n", nstar, res.tangent[:, :nt, :nt], nstar)
            H_rel = 1.0 / np.maximum(1.0 - D_nn / law.alpha_t, 1e-300)  # H / alpha_t
            cand = cand[H_rel[cand] > 0.05]
        if cand.size == 0:
            continue
        idx = rng.choice(cand, min(n_sample, cand.size), replace=False)
        D1, s1 = central_differences(b, idx, 1e-6)
        D2, s2 = central_differences(b, idx, 0.5e-6)
        same = np.all(s1 == st_want, axis=(0, 1)) & np.all(s2 == st_want, axis=(0, 1))
        Ds, F1, F2 = scaled(res.tangent[idx], b, idx), scaled(D1, b, idx), scaled(D2, b, idx)
        amp = np.maximum(np.abs(Ds).reshape(idx.size, -1).max(axis=1), 1.0)
        # the differences themselves must be resolved (FD(h) ~ FD(h/2)) for a meaningful test
        resolved = np.abs(F1 - F2).reshape(idx.size, -1).max(axis=1) <= 1e-6 * amp
        use = same & resolved
        counter["candidates"] += idx.size
        counter["used"] += int(np.count_nonzero(use))
        err = np.abs(Ds - F2).reshape(idx.size, -1).max(axis=1)
        bad = use & (err > 1e-5 * amp)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise AssertionError(
                f"consistent tangent != central differences ({st_want.name}) for {law}, nt={nt}, "
                f"dt={b.dt!r}: gap={b.gap[idx[i]].tolist()}, "
                f"{dict((k, a[idx[i]].tolist()) for k, a in b.state.items())}\nscaled tangent\n"
                f"{Ds[i]}\nscaled central differences\n{F2[i]}"
            )


@pytest.mark.parametrize(
    ("law", "start"), [("subloading", False), ("subloading", True), ("coulomb", False)]
)
def test_consistent_tangent_matches_central_differences(law, start):
    """Central differences on a random sample of points away from kinks.

    The sample: points with ``r`` in (0.02, 0.98) after the step, the trial at least 2 % of the
    yield-surface size away from the loading surface (``|phi(0)| > 0.02 g mu_s``), plastic
    points not flagged unstable and with ``H = -phi' > 0.05 alpha_t`` (away from a fold), and the
    same status at every perturbed evaluation. Steps are 1e-6 of ``|ubar_t - up|`` and of
    ``ubar_n``; a point is compared only when the differences with h and h/2 agree to 1e-6 (the
    difference quotient is resolved), and at least 80 % of the sample must qualify. With start
    tractions (``start``) the exact 2-D reversals are left out: the map has a kink there.
    """
    counter = {"candidates": 0, "used": 0}
    laws = fd_sample_laws() if law == "subloading" else coulomb_laws

    @fuzz_settings(25)
    @given(law=laws, nt=st.sampled_from([1, 2]), dt=st.sampled_from([0.0, 0.01, 1.0]), seed=seeds)
    def run(law, nt, dt, seed):
        if isinstance(law, CoulombLaw):  # moderate magnitudes for the differences
            law = law.replace(alpha_t=min(max(law.alpha_t, 1.0), 1e5))
        check_tangent(fd_candidates(law, nt, dt, seed, start=start), seed, counter)

    run()
    print(f"{law} (start tractions: {start}): {counter}")
    assert counter["candidates"] >= 300
    assert counter["used"] >= 0.8 * counter["candidates"], counter


@pytest.mark.parametrize("start", [False, True])
def test_the_tangent_at_batch_sizes_1_2_7_and_1e5(start):
    """The consistent tangent of a batch of 10^5 points equals, point by point, the tangent of
    the same points taken 1, 2 and 7 at a time, and central differences (a batch of their
    perturbed gaps) at a sample of elastic and plastic points of each kind."""
    law = preset("sec7")
    counter = {"candidates": 0, "used": 0}
    for nt, dt, seed in ((1, 0.01, 3), (2, 1.0, 4)):
        b = fd_candidates(law, nt, dt, seed, n=100_000, start=start)
        big = b.run()
        idx = np.random.default_rng(seed).choice(b.gap.shape[0], 70, replace=False)
        for size in (1, 2, 7):
            D = np.concatenate(
                [
                    Batch(law, b.gap[i], b.state.take(i), b.dt).run().tangent
                    for i in np.split(idx, range(size, idx.size, size))
                ]
            )
            np.testing.assert_array_equal(D, big.tangent[idx], err_msg=f"batch size {size}")
        check_tangent(b, seed, counter, n_sample=40)
    assert counter["used"] >= 0.8 * counter["candidates"] >= 0.8 * 100, counter
