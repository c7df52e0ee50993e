"""Fuzzing support for the return maps: strategies, batches of points, helpers.

Hypothesis draws a parameter set (random over many decades, or one of the paper's sets, literal
and normalised), the dimension (nt = 1 or 2), the time step, a seed and whether the contact band
is on (the default ``CONTACT_TOL``) or off (``contact_tol = 0``, so that subnormal normal gaps
reach the contact branch); the seed drives a numpy generator that builds a batch of points
mixing random values with the singular spots of ``docs/model.md`` §7: ``r = 0`` (``U(0) = inf``) and
``r = 1``, ``mu`` at ``mu_k`` and ``mu_s``, ``f_t = 0`` exactly (``t_f = 0/0``), ``ubar_n = 0``,
negative, subnormal and tiny (``F = 0/0``), tiny and huge increments, and ``dt`` = 0, subnormal,
tiny and huge. With ``start=True`` the subloading states carry a start traction ``f`` (the
traction at the end of the previous step): per point ``f_n0 = alpha_n ubar_n`` times 0.5..1.5
(or 0: a separated start), ``|f_t0| = g(f_n0) r mu`` (on the loading surface, consistent with
``r``) along the trial (no rotation), against it (an exact reversal: split), a random direction,
or zero -- so that reversal splits and rotations of the flow direction are fuzzed too.

Domain: all finite inputs whose trial tractions ``alpha_t |ubar_t - up|`` and ``alpha_n ubar_n``
stay below 1e150 MPa (down to subnormal ones). Checks: ``tests/fuzz_checks.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st

from subfric_dolfinx.constitutive import (
    CONTACT_TOL,
    PRESETS,
    CoulombLaw,
    InterfaceState,
    Status,
    SubloadingLaw,
    preset,
)
from subfric_dolfinx.constitutive._subloading import switch

EPS = float(np.finfo(float).eps)
TINY = float(np.finfo(float).smallest_subnormal)
BATCH = 2000  # points per example of the CI tests
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
contact_tols = st.sampled_from([CONTACT_TOL, 0.0])
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
    contact_tol: float = CONTACT_TOL

    @property
    def nt(self):
        return self.state.n_tangential

    @property
    def has_start(self):
        """The state carries a start traction ``f`` (subloading law)."""
        return "f" in self.state

    def run(self, **kw):
        kw.setdefault("contact_tol", self.contact_tol)
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


def make_batch(law, nt, dt, seed, n=BATCH, start=False, contact_tol=CONTACT_TOL):
    """Random points mixed with the singular spots (see the module docstring); ``start``: with
    start tractions (subloading law)."""
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
    state = state_of(law, up, mu, r)
    if start and isinstance(law, SubloadingLaw):
        state = with_start_traction(law, gap, state, seed)
    return Batch(law, gap, state, float(dt), contact_tol)


def state_of(law, up, mu, r):
    """A state holding the law's own variables without a start traction (subloading: the
    radial return), or Coulomb's only ``up``."""
    if isinstance(law, SubloadingLaw):
        return InterfaceState.from_arrays(up=up, mu=mu, r=r)
    return InterfaceState.from_arrays(up=up)


def with_start_traction(law, gap, state, seed):
    """``state`` with start tractions ``f`` consistent with its ``r`` (see the module doc)."""
    rng = np.random.default_rng(seed ^ 0xF0F0)
    up, mu, r = state.up, state.mu, state.r
    n, nt = up.shape
    fn0 = np.maximum(law.alpha_n * gap[:, nt], 0.0) * rng.uniform(0.5, 1.5, n)
    fn0[rng.random(n) < 0.05] = 0.0
    g0 = -np.expm1(-law.c_n * fn0)
    trial = law.alpha_t * (gap[:, :nt] - up)
    tn = rnorm(trial)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        tdir = np.where(tn > 0, trial / np.where(tn > 0, tn, 1.0), 0.0)
    d = rng.normal(size=(n, nt))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    c = pick(rng, n, [0.3, 0.3, 0.1])
    d[c == 0] = tdir[c == 0]  # along the trial: no rotation
    d[c == 1] = -tdir[c == 1]  # against it: a reversal inside the step
    f = np.zeros((n, nt + 1))
    f[:, :nt] = (g0 * r * mu)[:, None] * d
    f[c == 2, :nt] = 0.0
    f[:, nt] = fn0
    return InterfaceState({"up": up, "mu": mu, "r": r, "f": f}, nt)


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


# --------------------------------------------------------------------------------------------
# Start tractions: where the flow direction may rotate, and where the map has kinks


def maybe_rotated(b):
    """Points whose flow direction may rotate (a start traction in contact, nt = 2)."""
    n = b.gap.shape[0]
    if b.nt == 1 or not b.has_start:
        return np.zeros(n, dtype=bool)
    f = b.state["f"]
    return (np.abs(f[:, :2]).sum(axis=1) > 0) & (f[:, 2] > 0)


def split_point(b):
    """``(s, f_s)``: the reversal split of the elastic trial segment from ``f_t0`` (``s = 0``
    where ``|f_t|`` does not fall inside the step)."""
    nt = b.nt
    f0 = b.state["f"][:, :nt]
    tr0 = b.law.alpha_t * (b.gap[:, :nt] - b.state.up)
    wv = tr0 - f0
    fw = np.einsum("ij,ij->i", f0, wv)
    ww = np.einsum("ij,ij->i", wv, wv)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where((fw < 0.0) & (-fw < ww), -fw / np.where(ww > 0, ww, 1.0), 0.0)
    return s, f0 + s[:, None] * wv


@np.errstate(invalid="ignore", divide="ignore", over="ignore")
def rotation_ill_conditioned(b):
    """The rotation's start (the split point, or ``f_t0``) is over 1e3 times smaller than the
    rest of the step or than ``|f_t0|`` (cancellation in the split point): the derivatives carry
    ``1 / |f_s|`` factors that amplify the rounding of rotated inputs like an ill-conditioned
    root. At an exact reversal (``f_t0`` antiparallel to the trial) ``f_s = 0``: the map has a
    kink there (the split point's ``|f_t|`` is a cone in the gap; the exact solution too)."""
    nt = b.nt
    f0 = b.state["f"][:, :nt]
    tr0 = b.law.alpha_t * (b.gap[:, :nt] - b.state.up)
    _, fs = split_point(b)
    rs = rnorm(fs)
    return (rnorm(tr0 - fs) > ILL_CONDITIONED * rs) | (rnorm(f0) > ILL_CONDITIONED * rs)


@np.errstate(invalid="ignore", divide="ignore", over="ignore")
def split_phi0(b, A):
    """The map's loading test after its split of the elastic trial segment (its own split
    routine), ``A - g r_s mu_rec`` (+inf where there is none): within rounding of it the status
    may differ between frames."""
    law, nt = b.law, b.nt
    n = b.gap.shape[0]
    out = np.full(n, np.inf)
    f = b.state["f"]
    f0, fn0 = f[:, :nt], f[:, nt]
    fn1 = law.alpha_n * b.gap[:, nt]
    tr0 = law.alpha_t * (b.gap[:, :nt] - b.state.up)
    mu = np.clip(b.state.mu, law.mu_k, law.mu_s)
    bb = law.xi * b.dt
    cand = np.flatnonzero((fn0 > 0) & (fn1 > 0) & np.isfinite(A))
    seg = switch.Segment(
        f0[cand], fn0[cand], tr0[cand], fn1[cand], A[cand], mu[cand], np.full(cand.size, bb)
    )
    s, kind = switch.split_point(law._consts, seg)
    sp = cand[kind > 0]
    s = s[kind > 0]
    if sp.size == 0:
        return out
    fm = f0[sp] + s[:, None] * (tr0[sp] - f0[sp])
    gm = -np.expm1(-law.c_n * (fn0[sp] + s * (fn1[sp] - fn0[sp])))
    mu_m = np.minimum(mu[sp] + (law.mu_s - mu[sp]) * -np.expm1(-bb * s), law.mu_s)
    r_m = np.minimum(rnorm(fm) / (gm * mu_m), 1.0)
    mu_r = np.minimum(mu_m + (law.mu_s - mu_m) * -np.expm1(-(bb - bb * s)), law.mu_s)
    g1 = -np.expm1(-law.c_n * fn1[sp])
    out[sp] = A[sp] - g1 * r_m * mu_r
    return out


def touching(b):
    """Points in the contact band (``subfric_dolfinx.constitutive.tolerances``)."""
    nt = b.nt
    gap, up = b.gap, b.state.up
    length = 1.0 / (b.law.c_n * b.law.alpha_n) if isinstance(b.law, SubloadingLaw) else 0.0
    scale = np.maximum(np.maximum(rnorm(gap[:, :nt]), rnorm(up)), length)
    if b.contact_tol == 0.0:
        return gap[:, nt] == 0.0
    return np.abs(gap[:, nt]) <= b.contact_tol * scale
