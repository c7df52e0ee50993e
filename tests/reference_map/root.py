"""The plastic branch of one point and its certified smallest root (plain floats).

For a plastic point with trial magnitude ``A``, saturation ``g`` and start state
``(r_0, mu_0)`` (after a reversal split: the state at the split point) :class:`Br` evaluates in
closed form ``r(dl)``, ``mu(dl)`` and ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)``;
:func:`solve` finds its smallest root by Newton in a well-conditioned variable, and
:func:`certified_root` falls back on the branch-and-bound scan (:mod:`.scan`) when the root is
not certified smallest.
"""

from __future__ import annotations

import math

import numpy as np

from . import scan
from .common import EPS, S_SERIES, TINY, Law

__all__ = ["Br", "E_dE", "certified_root", "dl_derivative", "finish", "g_of", "partials", "solve"]

_expm1, _log1p, _sqrt, _asin = math.expm1, math.log1p, math.sqrt, math.asin
_exp, _isfinite = math.exp, math.isfinite
_cos, _sin = math.cos, math.sin
_PI = math.pi
_FOUR_PI = 4.0 / math.pi


def E_dE(s: float) -> tuple[float, float]:
    """``E(s) = (1 - exp(-s)) / s`` and ``E'(s)``."""
    if s < S_SERIES:
        E = -_expm1(-s) / s if s > 0.0 else 1.0
        return E, -0.5 + s * (1.0 / 3.0 - 0.125 * s)
    em = _expm1(-s)
    return -em / s, (em * (1.0 + s) + s) / (s * s)


class Br:
    """One plastic point's branch ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)`` from a start state.

    The Newton variable is ``z`` with ``dl = z (2 c + z)``, ``c = sqrt(d_n)``, ``d_n`` the slip
    that takes ``r`` from 0 to ``r_0`` (``cos(pi r / 2) = exp(-k (dl + d_n))``): ``r`` is
    regular in ``z`` at ``r_0 = 0`` (``r ~ sqrt(dl)`` there), and ``dl`` is linear in ``z`` for
    ``c >> z``. ``c`` is capped at ``sqrt(36 / k)`` (``r_0`` within 1e-16 of 1).
    """

    __slots__ = (
        "A",
        "L",
        "b",
        "c",
        "c0",
        "d_k",
        "d_s",
        "dmu0",
        "g",
        "mu0",
        "mu_rec",
        "r0",
        "s0",
        "sin0",
    )

    def __init__(
        self, L: Law, A: float, g: float, r0: float, mu0: float, b: float, d_s=None
    ) -> None:
        self.L, self.A, self.g, self.r0, self.mu0, self.b = L, A, g, r0, mu0, b
        qq = 0.25 * _PI * r0
        self.c0 = _cos(2.0 * qq)
        sq = _sin(qq)
        self.s0 = sq * sq
        self.sin0 = 2.0 * _sqrt(self.s0 * (1.0 - self.s0))
        self.d_k = mu0 - L.mu_k
        self.d_s = mu0 - L.mu_s if d_s is None else d_s  # mu0 - mu_s (given: no cancellation)
        Eb, dEb = E_dE(b)
        self.mu_rec = min(max(mu0 - b * self.d_s * Eb, L.mu_k), L.mu_s)
        self.dmu0 = L.kappa * (-self.d_k * Eb - b * self.d_s * dEb)
        if self.s0 < 0.5:
            dn = -_log1p(-2.0 * self.s0) / L.k
            self.c = min(_sqrt(dn), L.zc_cap)
        else:
            self.c = L.zc_cap

    def with_A(self, A: float) -> Br:
        """The same start state with another ``A`` (nothing recomputed)."""
        o = Br.__new__(Br)
        o.L, o.A, o.b, o.c, o.c0 = self.L, A, self.b, self.c, self.c0
        o.d_k, o.d_s, o.dmu0, o.g, o.mu0 = self.d_k, self.d_s, self.dmu0, self.g, self.mu0
        o.mu_rec, o.r0, o.s0, o.sin0 = self.mu_rec, self.r0, self.s0, self.sin0
        return o

    def ev(self, dl: float) -> tuple[float, ...]:
        """``phi, r, U = dr/ddl, mu, dmu/ddl, cos(pi r/2), sin(pi r/2), E, E'`` at ``dl``."""
        L = self.L
        c0 = self.c0
        em = _expm1(-L.k * dl)
        w = c0 * (1.0 + em)
        q = self.s0 - 0.5 * c0 * em
        q = 0.0 if q < 0.0 else (1.0 if q > 1.0 else q)
        r = _FOUR_PI * _asin(_sqrt(q))
        sn = 2.0 * _sqrt(q * (1.0 - q))
        if w > 0.0:
            U = L.ut * w / sn if sn > 0.0 else math.inf
        else:
            U = 0.0
        a = L.kappa * dl
        s = a + self.b
        E, dE = E_dE(s)
        D = a * self.d_k + self.b * self.d_s
        mu = self.mu0 - D * E
        mu = L.mu_k if mu < L.mu_k else (L.mu_s if mu > L.mu_s else mu)
        dmu = L.kappa * (-self.d_k * E - D * dE)
        phi = self.A - L.at * dl - self.g * r * mu
        return phi, r, U, mu, dmu, w, sn, E, dE


def solve(br: Br, tol_f: float, max_iter: int, dl_start: float = 0.0, e_start=None):
    """Smallest root of ``phi`` (``phi(0) > 0``): Newton in ``z`` from ``dl_start``.

    Each iteration solves the model ``A - alpha_t z (2c + z) - h - h' (z' - z) = 0`` exactly
    (``h = g r mu`` linearised, the linear term kept): exact for ``r ~ sqrt(dl)`` from ``r = 0``
    and for a constant ``h`` (a trial far outside). Safeguarded by the bracket ``[lo, hi]`` with
    (geometric) bisection. ``e_start``: the evaluation at ``dl_start`` if known (the corrector
    starts from the predictor's root: same start state, ``phi`` shifted by ``A_eff - A``).
    Returns ``(dl, ev-tuple at dl, converged, evaluations, certified)``.
    """
    L = br.L
    at = L.at
    c = br.c
    A = br.A
    g = br.g
    dl_max = A / at
    hi = dl_max / (_sqrt(c * c + dl_max) + c)
    lo = 0.0
    f_lo, f_hi = math.inf, -math.inf
    it = 0
    if dl_start > 0.0:
        z = dl_start / (_sqrt(c * c + dl_start) + c)
        if e_start is None:
            e = br.ev(dl_start)
            it = 1
        else:
            e = e_start
            it = 0
    else:
        z = 0.0
        r0 = br.r0
        if br.sin0 > 0.0:
            U0 = L.ut * br.c0 / br.sin0
        else:
            U0 = math.inf
        mu = br.mu_rec
        Eb, dEb = E_dE(br.b)
        e = (A - g * r0 * mu, r0, U0, mu, br.dmu0, br.c0, br.sin0, Eb, dEb)
    phi = e[0]
    if phi > 0.0:
        lo, f_lo = z, phi
    else:
        hi, f_hi = z, phi
    conv = abs(phi) <= tol_f
    dz_old = hi - lo
    while not conv and it < max_iter:
        _, r, U, mu, dmu, w, sn = e[:7]
        cz = c + z
        if sn > 0.0:
            drdz = 2.0 * L.ut * w * cz / sn
        else:  # r = 0 at z = 0: the limit of 2 (c + z) U(r) with dl + d_n = (c + z)^2
            drdz = 2.0 * L.ut * L.sqrt2k_inv
        h = g * r * mu
        hp = g * (mu * drdz + r * dmu * 2.0 * cz)
        B = 2.0 * at * c + hp
        Q = A - h + hp * z
        disc = B * B + 4.0 * at * Q
        zn = -1.0
        if disc >= 0.0 and _isfinite(disc):
            sd = _sqrt(disc)
            zn = 2.0 * Q / (B + sd) if B > 0.0 else (sd - B) / (2.0 * at)
        if not (lo < zn < hi) or (abs(zn - z) > 0.5 * abs(dz_old) and it > 0):
            zn = _sqrt(max(lo, TINY)) * _sqrt(hi) if hi > 1e3 * lo else 0.5 * (lo + hi)
        dz_old = zn - z
        z = zn
        e = br.ev(z * (2.0 * c + z))
        it += 1
        phi = e[0]
        if phi > 0.0:
            lo, f_lo = z, phi
        else:
            hi, f_hi = z, phi
        if abs(phi) <= tol_f:
            conv = True
        elif f_lo - f_hi <= 2.0 * tol_f or hi - lo <= 4.0 * EPS * hi:
            z = lo if f_lo < -f_hi else hi
            e = br.ev(z * (2.0 * c + z))
            it += 1
            conv = True
    dl = z * (2.0 * c + z)
    _, r, U, mu = e[:4]
    cert = conv and at + g * U * mu - g * r * abs(br.dmu0) > 0.0
    return dl, e, conv, it, cert


def certified_root(br: Br, tol_f: float, max_iter: int, dl_start: float = 0.0, e_start=None):
    """``solve``, then the branch-and-bound scan when the root is not certified.

    Returns ``(dl, ev-tuple, converged, evaluations, jump)``.
    """
    dl, e, conv, it, cert = solve(br, tol_f, max_iter, dl_start, e_start)
    jump = False
    if conv and not cert:
        L = br.L
        vb = scan.Branch(
            L.p, np.array([br.A]), np.array([br.g]), np.array([br.r0]), np.array([br.mu0]), br.b
        )
        x, ok, its, jp = scan.scan(vb, np.array([0]), np.array([dl]), np.array([tol_f]), max_iter)
        dl, conv, jump = float(x[0]), bool(ok[0]), bool(jp[0])
        it += int(its[0])
        e = br.ev(dl)
    return dl, e, conv, it, jump


def g_of(L: Law, fn: float) -> float:
    """Saturation ``g(f_n) = 1 - exp(-c_n f_n)`` (0 for ``f_n <= 0``)."""
    return -_expm1(-L.cn * fn) if fn > 0.0 else 0.0


def partials(br: Br, dl: float, e) -> tuple[float, float, float, float]:
    """At the root: ``H = -phi'``, ``dr/dr0``, ``dmu/dmu0``, ``dmu/db``."""
    L = br.L
    _, r, U, mu, dmu, w, sn, E, dE = e
    H = L.at + br.g * (U * mu + r * dmu)
    H = H if _isfinite(H) else L.at
    H = max(H, 1e-12 * L.at)
    R = (w / br.c0) * br.sin0 / sn if (sn > 0.0 and br.c0 > 0.0) else (1.0 if dl == 0.0 else 0.0)
    a = L.kappa * dl
    s = a + br.b
    Mmu = _exp(-s)
    D = a * br.d_k + br.b * br.d_s
    Mb = -br.d_s * E - D * dE
    return H, R, Mmu, Mb


def dl_derivative(br, e, H, R, Mmu, Mb, dA, dg1, dr0, dmu0, db):
    """Derivative of the root from the implicit function theorem (lists over gap components)."""
    g = br.g
    _, r, _, mu = e[:4]
    return [
        (dA[j] - dg1[j] * r * mu - g * mu * R * dr0[j] - g * r * (Mmu * dmu0[j] + Mb * db[j])) / H
        for j in range(len(dA))
    ]


def finish(L, tr, tan, up1, e, g, jump, iters):
    """Outputs of a converged plastic point: clipped ``r``, status, the stability flag."""
    _, r, U, mu = e[:4]
    den = -L.kappa * (mu - L.mu_k) * r + U * mu + L.at / g
    r = min(max(r, 0.0), 1.0)
    return tr, tan, up1, mu, r, (3 if jump else 1), den <= 0.0, iters
