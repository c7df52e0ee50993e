"""Property-based fuzzing of the batched return maps (subloading-friction law and Coulomb).

Hypothesis draws a parameter set (random over many decades, or one of the paper's sets, literal
and normalised), the dimension (nt = 1 or 2), the time step and a seed; the seed drives a numpy
generator that builds a batch of points mixing random values with the singular spots of
``docs/model.md`` §7: ``r = 0`` (``U(0) = inf``) and ``r = 1``, ``mu`` at ``mu_k`` and ``mu_s``,
``f_t = 0`` exactly (``t_f = 0/0``), ``ubar_n = 0``, negative, subnormal and tiny (``F = 0/0``),
tiny and huge increments, and ``dt`` = 0, subnormal, tiny and huge. Every CI run pushes more
than 1e5 points through the return maps (each test asserts its own volume); the ``slow`` test
(``--run-slow``) pushes about 1e7.

Domain: all finite inputs whose trial tractions ``alpha_t |ubar_t - up|`` and ``alpha_n ubar_n``
stay below 1e150 MPa (down to subnormal ones).

Properties: no NaN or inf in the result, no FAILED point, ``mu`` in ``[mu_k, mu_s]``, ``r`` in
``[0, 1]``, separated points carry no traction, elastic points the exact trial, plastic points
slip along the trial direction with non-negative dissipation, stay inside the yield surface and
lie on the subloading surface, invariance under rotations and reflections of the tangential
plane, the consistent tangent against central differences, and inputs never mutated.

Bugs found by this fuzzing and fixed in the return maps (regression tests below): ``mu``
recovered one ulp above ``mu_s``; ``r = 0/0 = NaN`` for ``f_t = 0`` on an underflowing surface
(``g mu = 0`` with ``g > 0``); B1, the safeguarded Newton stopping on a small step or bracket in
slip (``tol_f / alpha_t``) although ``phi'`` can be far steeper than ``-alpha_t`` near ``r = 0``
(``U(r) = u_tilde cot(pi r / 2)`` unbounded; large ``u_tilde`` or ``kappa``), which left plastic
points off the subloading surface (``r`` far from ``F / mu``, by 1e-6 for the paper's sets from a
virgin state, up to O(1) for extreme ones); B3, ``|f_t*|`` computed as the square root of a sum
of squares, which overflowed above about 1.3e154 MPa and underflowed to 0 below about
1.5e-154 MPa.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from subfric_dolfinx.constitutive import (
    PRESETS,
    CoulombLaw,
    InterfaceState,
    Status,
    SubloadingLaw,
    preset,
)

# The return maps evaluate both branches of np.where, e.g. 0 * inf at r = 0 with a subnormal g;
# the NaN is masked (the results are checked to be finite), the warning is noise here.
pytestmark = [
    pytest.mark.numpy_only,
    pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning"),
]

EPS = float(np.finfo(float).eps)
TINY = float(np.finfo(float).smallest_subnormal)
BATCH = 2000  # points per example of the CI tests
CI_MIN_POINTS = 100_000  # per CI test below
SURFACE_TOL = 1e-9  # |f_t| = g r mu, relative to g mu_s (the return map's tolerance is 1e-13)
ILL_CONDITIONED = 1e3  # frame invariance compared to 1e-8 only below this |phi'| / alpha_t
TRACTION_CAP = 1e150  # domain: trial tractions below this (MPa)


def fuzz_settings(max_examples):
    return settings(
        max_examples=max_examples,
        derandomize=True,
        deadline=None,
        database=None,
        phases=(Phase.explicit, Phase.generate),  # no shrinking: a failure shows its batch
        suppress_health_check=list(HealthCheck),
    )


# --------------------------------------------------------------------------------------------
# Strategies: parameters, dt, seed


def decades(lo, hi):
    """10**e with e in [lo, hi]: the ends themselves, or e on a fine uniform grid (hypothesis's
    own floats favour simple values too much to spread over the decades)."""
    k = 1 << 20
    grid = st.integers(0, k).map(lambda i: lo + (hi - lo) * i / k)
    return st.one_of(st.sampled_from([lo, hi]), grid, grid).map(lambda e: float(10.0**e))


def zero_or(strategy):
    return st.one_of(st.just(0.0), strategy)


@st.composite
def subloading_laws(draw):
    if draw(st.integers(0, 4)) == 0:  # a fifth: the paper's sets, normalised and literal
        return preset(draw(st.sampled_from(sorted(PRESETS))))
    mu_k = draw(decades(-3, 6))
    mu_s = mu_k * draw(st.one_of(st.just(1.0), decades(-12, 3).map(lambda v: 1.0 + v)))
    return SubloadingLaw(
        alpha_t=draw(decades(-3, 8)),
        alpha_n=draw(decades(-3, 8)),
        mu_s=mu_s,
        mu_k=mu_k,
        kappa=draw(zero_or(decades(-6, 8))),
        xi=draw(zero_or(decades(-6, 8))),
        u_tilde=draw(decades(-6, 8)),
        c_n=draw(decades(-10, 6)),
    )


coulomb_laws = st.builds(
    CoulombLaw, alpha_t=decades(-3, 8), alpha_n=decades(-3, 8), mu_c=decades(-4, 2)
)
time_steps = st.one_of(st.sampled_from([0.0, TINY, 1e-300, 1e-12, 1e12]), decades(-12, 12))
seeds = st.integers(0, 2**32 - 1)


# --------------------------------------------------------------------------------------------
# Batches of points


@dataclasses.dataclass
class Batch:
    law: SubloadingLaw | CoulombLaw
    gap: np.ndarray
    state: InterfaceState
    dt: float

    @property
    def nt(self):
        return self.state.n_tangential

    def run(self, **kw):
        return self.law.return_map(self.gap, self.state, self.dt, **kw)


def log_uniform(rng, lo, hi, size):
    return 10.0 ** rng.uniform(lo, hi, size)


def pick(rng, n, fractions):
    """A category per point: 0..len(fractions)-1 with these probabilities, else len(fractions)."""
    u = rng.random(n)
    edges = np.cumsum(fractions)
    return np.searchsorted(edges, u, side="right")


def yield_scales(law):
    """(tangential stress scale, normal stress scale, mu_k, mu_s) of a law."""
    if isinstance(law, SubloadingLaw):
        return law.mu_s, 1.0 / law.c_n, law.mu_k, law.mu_s
    return law.mu_c * 100.0, 100.0, law.mu_c, law.mu_c


def make_batch(law, nt, dt, seed, n=BATCH):
    """Random points mixed with the singular spots (see the module docstring)."""
    rng = np.random.default_rng(seed)
    Y, Fn, mu_k, mu_s = yield_scales(law)
    at, an = law.alpha_t, law.alpha_n
    # state: r with exact 0, 1, 1 - eps, subnormal; mu with exact ends
    r = rng.uniform(0.0, 1.0, n)
    c = pick(rng, n, [0.12, 0.12, 0.04, 0.04])
    r[c == 0], r[c == 1], r[c == 2], r[c == 3] = 0.0, 1.0, 1.0 - EPS / 2, TINY
    mu = np.clip(mu_k + (mu_s - mu_k) * rng.uniform(0.0, 1.0, n), mu_k, mu_s)
    c = pick(rng, n, [0.15, 0.15])
    mu[c == 0], mu[c == 1] = mu_k, mu_s
    up = rng.normal(size=(n, nt)) * log_uniform(rng, -3, 3, (n, 1)) * (Y / at)
    up[rng.random(n) < 0.15] = 0.0
    # trial tangential traction: magnitude over 23 decades, exact zero, absolutely tiny
    d = rng.normal(size=(n, nt))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    A = np.minimum(Y * log_uniform(rng, -15, 8, n), 0.1 * TRACTION_CAP)
    c = pick(rng, n, [0.1, 0.03])
    gap_t = up + (A / at)[:, None] * d
    gap_t[c == 0] = up[c == 0]  # f_t = 0 exactly
    gap_t[c == 1] = up[c == 1] + 1e-300 * d[c == 1]  # |f_t*| underflows
    # normal gap: compression over 21 decades, separation, exact 0, subnormal, tiny
    fn = np.minimum(Fn * log_uniform(rng, -15, 6, n), 0.1 * TRACTION_CAP)
    un = fn / an
    c = pick(rng, n, [0.1, 0.05, 0.03, 0.02])
    un[c == 0] *= -1.0
    un[c == 1], un[c == 2], un[c == 3] = 0.0, TINY, 1e-300
    gap = np.column_stack([gap_t, un])
    return Batch(law, gap, state_of(law, up, mu, r), float(dt))


def state_of(law, up, mu, r):
    """A state holding the law's own variables: Coulomb has only ``up``."""
    if isinstance(law, SubloadingLaw):
        return InterfaceState.from_arrays(up=up, mu=mu, r=r)
    return InterfaceState.from_arrays(up=up)


def mu_r(law, state, traction=None):
    """``(mu, r)`` of a state; for Coulomb ``mu_c`` and the utilisation ``|f_t| / (mu_c f_n)``
    of the given traction (0 without one or out of contact)."""
    if isinstance(law, SubloadingLaw):
        return state.mu, state.r
    n, nt = state.n_points, state.n_tangential
    mu = np.full(n, law.mu_c)
    if traction is None:
        return mu, np.zeros(n)
    limit = law.mu_c * np.maximum(traction[:, nt], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(limit > 0.0, rnorm(traction[:, :nt]) / np.where(limit > 0, limit, 1.0), 0.0)
    # (subnormal tractions: the ratio is not resolved; the cone itself is checked on f_t)
    return mu, np.minimum(r, 1.0)


# --------------------------------------------------------------------------------------------
# Checks


def rnorm(a):
    """Row norms without underflow or overflow."""
    s = np.max(np.abs(a), axis=1)
    sd = np.where(s > 0.0, s, 1.0)
    return s * np.sqrt(np.sum((a / sd[:, None]) ** 2, axis=1))


def assert_nowhere(mask, what, b, res, **extra):
    """Fail with the first offending point's inputs and outputs."""
    if not np.any(mask):
        return
    i = int(np.flatnonzero(mask)[0])
    more = ", ".join(f"{k}={np.asarray(v)[i]!r}" for k, v in extra.items())
    raise AssertionError(
        f"{what}: {int(np.count_nonzero(mask))} of {mask.size} points, first #{i}: "
        f"law={b.law}, nt={b.nt}, dt={b.dt!r}, gap={b.gap[i].tolist()}, "
        f"{dict((k, a[i].tolist()) for k, a in b.state.items())} -> "
        f"status={Status(int(res.status[i])).name}, traction={res.traction[i].tolist()}, "
        f"{dict((k, a[i].tolist()) for k, a in res.state.items())}" + (f"; {more}" if more else "")
    )


def saturation(law, fn):
    """``g(f_n)`` of the subloading law; for Coulomb ``mu_c f_n`` (the cone's "g mu")."""
    if isinstance(law, SubloadingLaw):
        return -np.expm1(-law.c_n * np.maximum(fn, 0.0))
    return law.mu_c * np.maximum(fn, 0.0)


def slope_ratio(law, g, r, mu):
    """|phi'| / alpha_t near the root: (alpha_t + g mu U(r) + g kappa (mu - mu_k) r) / alpha_t.

    Large where the root is ill-conditioned (r -> 0, large u_tilde or kappa): there a rounding of
    the input of eps |ubar_t| moves the result by far more than eps.
    """
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        U = law.u_tilde / np.tan(0.5 * np.pi * r)
        U = np.where(r > 0.0, U, np.inf)
        return 1.0 + g * (mu * U + law.kappa * (mu - law.mu_k) * r) / law.alpha_t


def yield_size(law, fn):
    """Size of the yield surface at ``f_n``: ``g mu_s`` (subloading) or ``mu_c f_n``."""
    g = saturation(law, fn)
    return g * law.mu_s if isinstance(law, SubloadingLaw) else g


@np.errstate(divide="ignore", invalid="ignore", over="ignore")
def check_invariants(b, res, *, surface=True):
    """Assert the properties of the module docstring on one evaluated batch.

    ``surface``: assert that every plastic point lies on the subloading surface (``False``: skip
    that check, for inputs whose magnitudes make the tolerance meaningless).
    """
    law, nt, gap, s0 = b.law, b.nt, b.gap, b.state
    sub = isinstance(law, SubloadingLaw)
    _, _, mu_k, mu_s = yield_scales(law)
    n = gap.shape[0]
    status, tr, s1 = res.status, res.traction, res.state
    assert tr.shape == (n, nt + 1) and res.tangent.shape == (n, nt + 1, nt + 1)
    assert s1.names == tuple(v.name for v in law.variables)
    mu1, r1 = mu_r(law, s1, tr)
    assert s1.up.shape == (n, nt) and mu1.shape == (n,) and r1.shape == (n,)
    for name, a in [("traction", tr), ("tangent", res.tangent), ("up", s1.up)]:
        assert_nowhere(~np.isfinite(a.reshape(n, -1)).all(axis=1), f"non-finite {name}", b, res)
    for name, a in [("mu", mu1), ("r", r1)]:
        assert_nowhere(~np.isfinite(a), f"non-finite {name}", b, res)
    assert_nowhere(status == Status.FAILED, "FAILED for finite input", b, res)
    assert_nowhere(~np.isin(status, [s.value for s in Status]), "unknown status", b, res)
    assert_nowhere((mu1 < mu_k) | (mu1 > mu_s), "mu outside [mu_k, mu_s]", b, res)
    assert_nowhere((r1 < -1e-15) | (r1 > 1.0 + 1e-15), "r outside [0, 1]", b, res)

    ft, fn, un = tr[:, :nt], tr[:, nt], gap[:, nt]
    trial = law.alpha_t * (gap[:, :nt] - s0.up)
    A = rnorm(trial)
    slip = s1.up - s0.up
    ft_mag, dl = rnorm(ft), rnorm(slip)
    g = saturation(law, law.alpha_n * un)
    gmu_s = g * mu_s if sub else g
    # resolution of subnormal results (tractions, g, Coulomb's ratio mu_c f_n / |f_t*|)
    floor = 4.0 * TINY * (1.0 + mu_s + A)

    sep = status == Status.SEPARATED
    ela = status == Status.ELASTIC
    pla = (status == Status.PLASTIC) | (status == Status.JUMP)
    assert_nowhere((un <= 0.0) & ~sep, "not separated at ubar_n <= 0", b, res)
    assert_nowhere(sep & np.any(tr != 0.0, axis=1), "traction on a separated point", b, res)
    assert_nowhere(sep & (r1 != 0.0), "r != 0 on a separated point", b, res)
    assert_nowhere(~pla & np.any(slip != 0.0, axis=1), "slip without plastic status", b, res)
    assert_nowhere(res.unstable & ~pla, "unstable flag on a non-plastic point", b, res)
    if sub:  # separated and elastic points: mu recovers exactly over dt (and never decreases)
        mu_rec = s0.mu + (law.mu_s - s0.mu) * -np.expm1(-law.xi * b.dt)
        bad = ~pla & (np.abs(s1.mu - mu_rec) > 4 * EPS * law.mu_s)
        assert_nowhere(bad | (~pla & (s1.mu < s0.mu)), "mu recovery", b, res, expected=mu_rec)

    # elastic: the exact trial, inside the surface, r = F / mu
    assert_nowhere(
        ela[:, None] & (np.abs(ft - trial) > 2 * EPS * np.abs(trial)),
        "elastic tangential traction != trial",
        b,
        res,
    )
    in_contact = ela | pla
    fn_ok = np.abs(fn - law.alpha_n * un) <= 2 * EPS * np.abs(law.alpha_n * un)
    assert_nowhere(in_contact & ~fn_ok, "normal traction != alpha_n ubar_n", b, res)
    cap = (mu1 if sub else 1.0) * g
    assert_nowhere(
        in_contact & (ft_mag > cap * (1.0 + 1e-12) + floor),
        "outside the yield surface",
        b,
        res,
    )
    r_err = np.abs(ft_mag - cap * r1)
    assert_nowhere(
        ela & (r_err > 1e-12 * gmu_s + floor),
        "elastic r != F / mu",
        b,
        res,
        err=r_err / gmu_s,
    )

    # plastic: slip along the trial direction, |f_t| <= |f_t*|, non-negative dissipation (up to
    # the rounding of up_new - up_old, which is large against the slip when |up| is large)
    du = 2.0 * EPS * (rnorm(s0.up) + rnorm(s1.up))
    along = np.einsum("ij,ij->i", slip, trial)
    assert_nowhere(
        pla & (along < (1.0 - 1e-9) * dl * A - 2.0 * du * A),
        "slip not along the trial direction",
        b,
        res,
    )
    assert_nowhere(pla & (ft_mag > A * (1.0 + 1e-12)), "|f_t| > |f_t*|", b, res)
    work = np.einsum("ij,ij->i", ft, slip)
    assert_nowhere(
        work < -1e-12 * ft_mag * dl - ft_mag * du, "negative dissipation", b, res, work=work
    )

    # on the subloading surface, and f_t = alpha_t (ubar_t - up_new) (the return itself)
    mask = pla.copy()
    if surface:
        on = np.abs(ft_mag - cap * r1)
        # rounding of ubar_t - up (large |up|, small |f_t*|) on top of the tolerance
        rnd = 8 * EPS * law.alpha_t * (rnorm(gap[:, :nt]) + rnorm(s0.up) + rnorm(s1.up))
        tol = SURFACE_TOL * np.maximum(gmu_s, A) + rnd + floor
        assert_nowhere(mask & (on > tol), "off the subloading surface", b, res, err=on / gmu_s)
        ret = rnorm(ft - law.alpha_t * (gap[:, :nt] - s1.up))
        assert_nowhere(mask & (ret > tol), "f_t != alpha_t (ubar_t - up)", b, res, err=ret / gmu_s)
    surf = mask if surface else np.zeros(n, dtype=bool)
    parts = [("separated", sep), ("elastic", ela), ("plastic", pla), ("on surface", surf)]
    return {k: int(np.count_nonzero(v)) for k, v in parts}


def random_orthogonal(rng, n, nt):
    """Per-point rotations and reflections of the tangential plane, shape (n, nt, nt), and a
    mask of the exact ones (quarter turns and axis reflections: no rounding in ``Q x``)."""
    if nt == 1:
        return np.where(rng.random(n) < 0.5, -1.0, 1.0)[:, None, None], np.ones(n, dtype=bool)
    th = rng.uniform(0.0, 2.0 * np.pi, n)
    exact = rng.random(n) < 0.25
    th[exact] = 0.5 * np.pi * rng.integers(0, 4, np.count_nonzero(exact))
    c, s = np.cos(th), np.sin(th)
    c[exact], s[exact] = np.round(c[exact]), np.round(s[exact])
    Q = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    Q[rng.random(n) < 0.3, :, 1] *= -1.0  # a reflection
    return Q, exact


@np.errstate(divide="ignore", invalid="ignore", over="ignore")
def check_frame_invariance(b, res, seed):
    """Rotating the tangential plane rotates traction, slip and tangent; mu, r, status stay.

    Exact symmetries (sign flips in 2-D; quarter turns and axis reflections in 3-D) must give
    bit-identical results. General rotations round the inputs at ``eps |ubar_t|``, which is
    amplified where the root is ill-conditioned; there the comparison is on points whose trial
    is resolved (the rounding below 1e-9 |f_t*|), not within that rounding of the loading
    surface, not at a fold (JUMP, unstable) and not where the root is ill-conditioned
    (``|phi'| / alpha_t > ILL_CONDITIONED``, see :func:`slope_ratio`).
    """
    rng = np.random.default_rng(seed ^ 0x5EED)
    n, nt, law = b.gap.shape[0], b.nt, b.law
    sub = isinstance(law, SubloadingLaw)
    Q, exact = random_orthogonal(rng, n, nt)
    rot = lambda a: np.einsum("nij,nj->ni", Q, a)  # noqa: E731
    st_q = b.state.copy()
    st_q.up[:] = rot(b.state.up)
    rq = Batch(law, np.column_stack([rot(b.gap[:, :nt]), b.gap[:, nt]]), st_q, b.dt).run()
    P = np.zeros((n, nt + 1, nt + 1))
    P[:, :nt, :nt], P[:, nt, nt] = Q, 1.0
    D_rot = np.einsum("nij,njk,nlk->nil", P, res.tangent, P)
    tr_rot = np.column_stack([rot(res.traction[:, :nt]), res.traction[:, nt]])
    pairs = [
        ("status", res.status, rq.status),
        ("unstable flag", res.unstable, rq.unstable),
        *((k, res.state[k], rq.state[k]) for k in res.state.names if k != "up"),
        ("traction", tr_rot, rq.traction),
        ("slip", rot(res.state.up), rq.state.up),
        ("tangent", D_rot.reshape(n, -1), rq.tangent.reshape(n, -1)),
    ]
    for name, a, q in pairs:
        differ = (a != q).reshape(n, -1).any(axis=1)
        assert_nowhere(exact & differ, f"{name} changed by an exact symmetry", b, res)

    fn = res.traction[:, nt]
    g, size = saturation(law, fn), yield_size(law, fn)
    A = rnorm(law.alpha_t * (b.gap[:, :nt] - b.state.up))
    rnd = 64 * EPS * law.alpha_t * (rnorm(b.gap[:, :nt]) + rnorm(b.state.up))
    if sub:
        mu_rec = b.state.mu + (law.mu_s - b.state.mu) * -np.expm1(-law.xi * b.dt)
        phi0 = A - g * b.state.r * mu_rec
        r_lo = np.minimum(b.state.r, res.state.r)
        ill = slope_ratio(law, g, r_lo, b.state.mu) > ILL_CONDITIONED
    else:
        phi0, ill = A - g, np.zeros(n, dtype=bool)
    cmp = ~exact & (rnd <= 1e-9 * A) & (np.abs(phi0) > 1e-6 * np.maximum(A, size))
    assert_nowhere(cmp & (rq.status != res.status), "status changed by a rotation", b, res)
    cmp &= (res.status != Status.JUMP) & ~res.unstable & ~ill
    assert_nowhere(cmp & (rq.unstable != res.unstable), "unstable changed by a rotation", b, res)
    ft_err = rnorm(rq.traction[:, :nt] - rot(res.traction[:, :nt]))
    scale = np.maximum(A, size)
    assert_nowhere(cmp & (ft_err > 1e-8 * scale), "traction not rotated", b, res, err=ft_err)
    assert_nowhere(rq.traction[:, nt] != fn, "f_n changed by a rotation", b, res)
    up_err = rnorm(rq.state.up - rot(res.state.up))
    up_tol = 1e-8 * (scale / law.alpha_t) + 8 * EPS * rnorm(res.state.up)
    assert_nowhere(cmp & (up_err > up_tol), "slip not rotated", b, res, err=up_err)
    if sub:  # (Coulomb stores no mu or r: its traction is compared above)
        mu_err, r_err = np.abs(rq.state.mu - res.state.mu), np.abs(rq.state.r - res.state.r)
        mu_s = law.mu_s
        assert_nowhere(cmp & (mu_err > 1e-8 * mu_s), "mu changed by a rotation", b, res, err=mu_err)
        assert_nowhere(cmp & (r_err > 1e-8), "r changed by a rotation", b, res, err=r_err)
    D_err = np.abs(rq.tangent - D_rot).reshape(n, -1).max(axis=1)
    D_scale = np.abs(res.tangent).reshape(n, -1).max(axis=1)
    assert_nowhere(
        cmp & (D_err > 1e-7 * D_scale), "tangent not rotated", b, res, err=D_err / D_scale
    )
    return {"exact symmetry": int(np.count_nonzero(exact)), "rotated": int(np.count_nonzero(cmp))}


# --------------------------------------------------------------------------------------------
# The fuzz tests


class Volume:
    """Points pushed through the return map, and how many met each check."""

    def __init__(self):
        self.points = 0
        self.counts = {}

    def add(self, n, counts):
        self.points += n
        for k, v in counts.items():
            self.counts[k] = self.counts.get(k, 0) + v


def fuzz_law(laws, max_examples, batch, volume, frame=True):
    @fuzz_settings(max_examples)
    @given(law=laws, nt=st.sampled_from([1, 2]), dt=time_steps, seed=seeds)
    def run(law, nt, dt, seed):
        b = make_batch(law, nt, dt, seed, batch)
        inputs = (b.gap, *(a for _, a in b.state.items()))
        copies = [a.copy() for a in inputs]
        res = b.run()
        for a, c in zip(inputs, copies, strict=True):
            np.testing.assert_array_equal(a, c, err_msg="the return map mutated its inputs")
        volume.add(b.gap.shape[0], check_invariants(b, res))
        if frame:
            volume.add(b.gap.shape[0], check_frame_invariance(b, res, seed))

    run()


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_fuzz_invariants_and_frame_invariance(law):
    volume = Volume()
    laws = subloading_laws() if law == "subloading" else coulomb_laws
    fuzz_law(laws, 100 if law == "subloading" else 40, BATCH, volume)
    print(f"{law}: {volume.points} points, {volume.counts}")
    assert volume.points >= CI_MIN_POINTS
    c, half = volume.counts, volume.points / 2  # half: the first evaluations (not rotated)
    assert min(c["separated"], c["elastic"], c["plastic"]) > 0.05 * half  # every regime
    assert c["on surface"] > 0.5 * c["plastic"]
    assert c["exact symmetry"] > 0.1 * half and c["rotated"] > 0.02 * half


@pytest.mark.slow
@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_fuzz_invariants_long(law):
    """The long run (``--run-slow``): about 1e7 points in total over both laws."""
    volume = Volume()
    if law == "subloading":
        fuzz_law(subloading_laws(), 700, 5000, volume)
    else:
        fuzz_law(coulomb_laws, 300, 5000, volume)
    print(f"{law}: {volume.points} points, {volume.counts}")
    assert volume.points >= (6_000_000 if law == "subloading" else 2_500_000)


# --------------------------------------------------------------------------------------------
# Consistent tangent against central differences


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


def fd_candidates(law, nt, dt, seed, n=400):
    """Points away from kinks: r_n and the end r away from 0 and 1, f_n away from 0, trials
    clearly inside (elastic) or outside (plastic) the subloading surface grown by recovery."""
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
    return Batch(law, gap, InterfaceState.from_arrays(up=up, mu=mu, r=r), float(dt))


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
    )
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


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_consistent_tangent_matches_central_differences(law):
    """Central differences on a random sample of points away from kinks.

    The sample: points with ``r`` in (0.02, 0.98) after the step, the trial at least 2 % of the
    yield-surface size away from the loading surface (``|phi(0)| > 0.02 g mu_s``), plastic
    points not flagged unstable and with ``H = -phi' > 0.05 alpha_t`` (away from a fold), and the
    same status at every perturbed evaluation. Steps are 1e-6 of ``|ubar_t - up|`` and of
    ``ubar_n``; a point is compared only when the differences with h and h/2 agree to 1e-6 (the
    difference quotient is resolved), and at least 80 % of the sample must qualify.
    """
    counter = {"candidates": 0, "used": 0}
    laws = fd_sample_laws() if law == "subloading" else coulomb_laws

    @fuzz_settings(25)
    @given(law=laws, nt=st.sampled_from([1, 2]), dt=st.sampled_from([0.0, 0.01, 1.0]), seed=seeds)
    def run(law, nt, dt, seed):
        if isinstance(law, CoulombLaw):  # moderate magnitudes for the differences
            law = law.replace(alpha_t=min(max(law.alpha_t, 1.0), 1e5))
        check_tangent(fd_candidates(law, nt, dt, seed), seed, counter)

    run()
    print(f"{law}: {counter}")
    assert counter["candidates"] >= 300
    assert counter["used"] >= 0.8 * counter["candidates"], counter


# --------------------------------------------------------------------------------------------
# Regressions of bugs this fuzzing found and that were fixed in subloading.py


def test_recovery_never_overshoots_mu_s():
    """mu + (mu_s - mu) (1 - exp(-xi dt)) rounded above mu_s for about 1 point in 20 once
    exp(-xi dt) = 0 (here xi dt = 50): mu left [mu_k, mu_s] by one ulp."""
    p = SubloadingLaw(
        alpha_t=664910.87, alpha_n=156.48, mu_s=444.3668939609549, mu_k=32.608568832899785,
        kappa=666.56, xi=50.0, u_tilde=0.018, c_n=3.2e-9,
    )  # fmt: skip
    rng = np.random.default_rng(3)
    n = 20000
    mu = rng.uniform(p.mu_k, p.mu_s, n)
    gap = np.column_stack([np.zeros(n), rng.choice([-1.0, 1.0], n)])  # elastic and separated
    res = p.return_map(
        gap, InterfaceState.from_arrays(up=np.zeros((n, 1)), mu=mu, r=rng.uniform(0, 1, n)), 1.0
    )
    assert np.all(res.state.mu <= p.mu_s) and np.all(res.state.mu >= p.mu_k)
    np.testing.assert_allclose(res.state.mu, p.mu_s, rtol=4 * EPS)


def test_zero_traction_on_an_underflowing_surface_gives_r_zero():
    """f_t = 0 with g mu_rec underflowing to 0 (subnormal g, mu < 1) gave r = 0/0 = NaN."""
    p = SubloadingLaw(
        alpha_t=1.0, alpha_n=1.0, mu_s=0.6, mu_k=0.3, kappa=0.0, xi=0.0, u_tilde=1.0, c_n=1.0
    )
    st0 = InterfaceState.from_arrays(up=[[0.0, 0.0], [0.0, 0.0]], mu=[0.44, 0.44], r=[0.3, 0.3])
    res = p.return_map(np.array([[0.0, 0.0, TINY], [1e-100, 0.0, TINY]]), st0, 0.0)
    assert res.status[0] == Status.ELASTIC and res.state.r[0] == 0.0  # F = 0: r = 0
    b = Batch(p, np.array([[0.0, 0.0, TINY], [1e-100, 0.0, TINY]]), st0, 0.0)
    check_invariants(b, res)  # and the point slipping on the zero-size surface is sound


# --------------------------------------------------------------------------------------------
# Regressions of B1 and B3 (see the module docstring), fixed in the return maps


@pytest.mark.parametrize(
    ("name", "r0", "ubar_t", "ubar_n", "kw"),
    [
        ("sec7", 0.0, 1e-12, 1.2, {}),  # virgin state, tiny first slip: r = 3.9e-7, F/mu = 9e-12
        ("sec7", 0.0, 1e-9, 1.2, {}),
        ("sec6-mus10000", 0.0, 1e-9, 1.2, {}),
        ("sec7", 0.0, 0.1, 1.2, {"u_tilde": 4e5, "alpha_t": 6e-3}),  # large U: 2.5 % off
    ],
)
def test_b1_plastic_point_on_the_surface_near_r0(name, r0, ubar_t, ubar_n, kw):
    """Was 1e-6 (paper's sets) to 2.5 % (large u_tilde) off the surface: r >> F / mu."""
    law = preset(name).replace(**kw)
    b = Batch(
        law,
        np.array([[ubar_t, ubar_n]]),
        InterfaceState.from_arrays(up=[[0.0]], mu=[law.mu_s], r=[r0]),
        0.0,
    )
    res = b.run()
    assert res.status[0] == Status.PLASTIC
    check_invariants(b, res)


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_b3_huge_trial_norm_does_not_overflow(law):
    """|f_t*| = 1e160 MPa was inf: FAILED (subloading) or NaN slip (Coulomb)."""
    p = preset("sec7") if law == "subloading" else CoulombLaw(1.0, 1.0, 0.3)
    b = Batch(p, np.array([[1e160, 0.0, 1.0]]), p.initial_state(1, 2), 0.1)
    check_invariants(b, b.run(), surface=False)


@pytest.mark.parametrize("law", ["subloading", "coulomb"])
def test_b3_tiny_trial_norm_does_not_underflow(law):
    """|f_t*| = 1e-300 MPa was 0: taken as elastic with r = 0, even outside the yield surface."""
    if law == "subloading":  # f_n = 5e-297, g mu_s = 1e-296, |f_t| = 5e-297 MPa: r = 0.5
        p = preset("sec6-mus10000")
        b = Batch(
            p,
            np.array([[-1e-300, 1e-300]]),
            InterfaceState.from_arrays(up=[[0.0]], mu=[p.mu_s], r=[0.5]),
            0,
        )
    else:  # |f_t*| = 1e-300 MPa against mu_c f_n = 3e-301 MPa: must slip
        p = CoulombLaw(1.0, 1.0, 0.3)
        b = Batch(p, np.array([[1e-300, 0.0, 1e-300]]), p.initial_state(1, 2), 0.0)
    res = b.run()
    check_invariants(b, res)
    fn = res.traction[0, -1]
    assert rnorm(res.traction[:, :-1])[0] <= yield_size(p, fn) * (1 + 1e-12)
    if law == "subloading":
        assert res.state.r[0] == pytest.approx(0.5, rel=1e-12), res.state.r[0]
