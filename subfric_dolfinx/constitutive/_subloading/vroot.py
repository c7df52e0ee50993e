"""The plastic branch and its certified smallest root, batched (the twin of :mod:`.root`).

:func:`vsolve` keeps the active points in one compact (fields, points) work array, compressed
with one boolean index whenever some converge; :func:`vroot` adds the branch-and-bound scan
(:mod:`.scan`) for the roots not certified smallest.
"""

from __future__ import annotations

import numpy as np

from . import scan
from .common import EPS, JUMP, PLASTIC, S_SERIES, TINY, Law

__all__ = ["E_dE", "VBr", "finish", "g_of", "partials", "vroot", "vsolve"]

_PI = np.pi


def E_dE(s):
    """``E(s)``, ``E'(s)`` (series below ``S_SERIES``; no 0/0)."""
    em = np.expm1(-s)
    E = -em / s
    dE = (em * (1.0 + s) + s) / (s * s)
    small = s < S_SERIES
    if not small.any():
        return E, dE
    ss = s[small]
    dE[small] = -0.5 + ss * (1.0 / 3.0 - 0.125 * ss)
    E[s == 0.0] = 1.0
    return E, dE


def g_of(L: Law, fn):
    """Saturation ``g(f_n)`` (0 for ``f_n <= 0``)."""
    return -np.expm1(-L.cn * np.maximum(fn, 0.0))


_PM = ("c0", "s0", "b", "d_k", "d_s", "mu0", "A", "g", "c", "r0", "sin0", "mu_rec", "dmu0")


class VBr:
    """Vector version of :class:`.root.Br` (one plastic point per column).

    The per-point constants live in one (13, k) block ``Pm`` (rows ``_PM``; the attributes are
    views), so that a subset is one gather and the solver's work array one copy.
    """

    def __init__(self, L: Law, A, g, r0, mu0, b, Pm=None, d_s=None) -> None:
        self.L = L
        if Pm is None:
            k = A.size
            Pm = np.empty((len(_PM), k))
            Pm[2] = b
            b = Pm[2]
            qq = 0.25 * _PI * r0
            Pm[0] = np.cos(2.0 * qq)
            Pm[1] = np.sin(qq) ** 2
            Pm[10] = 2.0 * np.sqrt(Pm[1] * (1.0 - Pm[1]))
            Pm[3] = mu0 - L.mu_k
            Pm[4] = mu0 - L.mu_s if d_s is None else d_s  # (given: no cancellation)
            Pm[5], Pm[6], Pm[7], Pm[9] = mu0, A, g, r0
            Eb, dEb = E_dE(b)
            Pm[11] = np.minimum(np.maximum(mu0 - b * Pm[4] * Eb, L.mu_k), L.mu_s)
            Pm[12] = L.kappa * (-Pm[3] * Eb - b * Pm[4] * dEb)
            s0 = Pm[1]
            dn = -np.log1p(-2.0 * np.where(s0 < 0.5, s0, 0.25)) / L.k
            Pm[8] = np.where(s0 < 0.5, np.minimum(np.sqrt(dn), L.zc_cap), L.zc_cap)
        self.Pm = Pm
        for i, name in enumerate(_PM):
            setattr(self, name, Pm[i])

    def sub(self, idx, A) -> VBr:
        """Columns ``idx`` with another ``A`` (same start state: nothing recomputed)."""
        Pm = self.Pm[:, idx]
        Pm[6] = A
        return VBr(self.L, None, None, None, None, None, Pm)

    def ev(self, dl, idx):
        """``phi, r, U, mu, dmu, w, sn`` at ``dl`` for columns ``idx``."""
        L = self.L
        c0 = self.c0[idx]
        em = np.expm1(-L.k * dl)
        w = c0 * (1.0 + em)
        q = np.minimum(np.maximum(self.s0[idx] - 0.5 * c0 * em, 0.0), 1.0)
        r = (4.0 / _PI) * np.arcsin(np.sqrt(q))
        sn = 2.0 * np.sqrt(q * (1.0 - q))
        U = L.ut * w / sn  # w > 0 always (cos(pi/2) > 0 in floats); inf where sn = 0
        a = L.kappa * dl
        b = self.b[idx]
        s = a + b
        E, dE = E_dE(s)
        d_k = self.d_k[idx]
        D = a * d_k + b * self.d_s[idx]
        mu = np.minimum(np.maximum(self.mu0[idx] - D * E, L.mu_k), L.mu_s)
        dmu = L.kappa * (-d_k * E - D * dE)
        phi = self.A[idx] - L.at * dl - self.g[idx] * r * mu
        return [phi, r, U, mu, dmu, w, sn]


# rows of the compact work array of vsolve: per-point constants, iteration state, evaluation
_C0, _HC0, _S0, _KDK, _BDS, _B, _MU0, _A, _G, _C2A, _CC, _TOL, _ROW = range(13)
_Z, _LO, _HI, _FLO, _FHI, _DZ = range(13, 19)
_PHI, _R, _MU, _DMU, _W, _SN = range(19, 25)
_NF = 25
_4PI = 4.0 / _PI


def _ev_rows(L: Law, Wk, dl) -> None:
    """Evaluate the branch at ``dl`` for the columns of ``Wk``; write rows _PHI.._SN.

    Same formulas as ``VBr.ev`` / :meth:`.root.Br.ev` with the per-point constants folded
    (``0.5 c0``, ``kappa d_k``, ``b d_s``, ``2 alpha_t c``).
    """
    em = np.expm1(dl * -L.k)
    np.multiply(Wk[_C0], 1.0 + em, out=Wk[_W])
    q = np.clip(Wk[_S0] - Wk[_HC0] * em, 0.0, 1.0)
    np.multiply(np.arcsin(np.sqrt(q)), _4PI, out=Wk[_R])
    np.multiply(np.sqrt(q * (1.0 - q)), 2.0, out=Wk[_SN])
    E, dE = E_dE(dl * L.kappa + Wk[_B])
    kdk = Wk[_KDK]
    D = dl * kdk + Wk[_BDS]  # kappa dl (mu0 - mu_k) + b (mu0 - mu_s)
    np.clip(Wk[_MU0] - D * E, L.mu_k, L.mu_s, out=Wk[_MU])
    np.negative(kdk * E + (L.kappa * D) * dE, out=Wk[_DMU])
    np.subtract(Wk[_A] - L.at * dl, Wk[_G] * Wk[_R] * Wk[_MU], out=Wk[_PHI])


def vsolve(br: VBr, tol_f, max_iter, dl_start=None, e_start=None):
    """Vector version of :func:`.root.solve`: returns ``dl, e (list of arrays), conv, it, cert``.

    The active points live in one compact (fields, points) array, compressed with one boolean
    index whenever some converge; finished columns are written to the outputs then.
    """
    L = br.L
    at = L.at
    k = br.A.size
    Pm = br.Pm
    Wk = np.empty((_NF, k))
    Wk[_C0] = Pm[0]
    np.multiply(Pm[0], 0.5, out=Wk[_HC0])
    Wk[_S0] = Pm[1]
    np.multiply(Pm[3], L.kappa, out=Wk[_KDK])
    np.multiply(Pm[2], Pm[4], out=Wk[_BDS])
    Wk[_B], Wk[_MU0], Wk[_A], Wk[_G], Wk[_CC] = Pm[2], Pm[5], Pm[6], Pm[7], Pm[8]
    np.multiply(Pm[8], 2.0 * at, out=Wk[_C2A])
    Wk[_TOL] = tol_f
    Wk[_ROW] = np.arange(k)
    c = Wk[_CC]
    dl_max = Wk[_A] / at
    hi = dl_max / (np.sqrt(c * c + dl_max) + c)
    it = 0
    if dl_start is None:
        z = 0.0
        Wk[_PHI] = br.A - br.g * br.r0 * br.mu_rec
        Wk[_R], Wk[_MU], Wk[_DMU], Wk[_W], Wk[_SN] = br.r0, br.mu_rec, br.dmu0, br.c0, br.sin0
    else:
        z = dl_start / (np.sqrt(c * c + dl_start) + c)
        if e_start is None:
            _ev_rows(L, Wk, dl_start)
            it = 1
        else:
            Wk[_PHI], Wk[_R], Wk[_MU], Wk[_DMU] = e_start[0], e_start[1], e_start[3], e_start[4]
            Wk[_W], Wk[_SN] = e_start[5], e_start[6]
    Wk[_Z] = z
    phi = Wk[_PHI]
    pos = phi > 0.0
    Wk[_LO] = np.where(pos, z, 0.0)
    Wk[_FLO] = np.where(pos, phi, np.inf)
    Wk[_HI] = np.where(pos, hi, z)
    Wk[_FHI] = np.where(pos, -np.inf, phi)
    Wk[_DZ] = Wk[_HI] - Wk[_LO]
    z_out = np.empty(k)
    e_out = [np.empty(k) for _ in range(7)]
    it_out = np.empty(k, dtype=np.int64)
    conv = np.zeros(k, dtype=bool)
    ut = L.ut

    def retire(done, its):
        Wd = Wk[:, done]
        rows = Wd[_ROW].astype(np.intp)
        z_out[rows] = Wd[_Z]
        for j, row in ((0, _PHI), (1, _R), (3, _MU), (4, _DMU), (5, _W), (6, _SN)):
            e_out[j][rows] = Wd[row]
        e_out[2][rows] = ut * Wd[_W] / Wd[_SN]  # U = dr/ddl (w > 0 always; inf at sn = 0)
        it_out[rows] = its
        return rows

    done = np.abs(phi) <= Wk[_TOL]
    if done.any():
        conv[retire(done, it)] = True
        Wk = Wk[:, ~done]
    halve = dl_start is not None and e_start is None
    ut2 = 2.0 * ut
    lim0 = ut2 * L.sqrt2k_inv
    tiny4 = 4.0 * EPS
    while Wk.shape[1] and it < max_iter:
        za, ca, ga, r, mu, sn = Wk[_Z], Wk[_CC], Wk[_G], Wk[_R], Wk[_MU], Wk[_SN]
        cz = ca + za
        drdz = (ut2 * cz) * Wk[_W] / sn
        z0 = sn == 0.0
        if z0.any():  # r = 0 at z = 0: the limit of 2 (c + z) U(r)
            drdz[z0] = lim0
        gr = ga * r
        hp = ga * mu * drdz + (2.0 * gr) * Wk[_DMU] * cz
        B = Wk[_C2A] + hp
        Q = Wk[_A] - gr * mu + hp * za
        disc = B * B + (4.0 * at) * Q
        sd = np.sqrt(np.maximum(disc, 0.0))
        zn = np.where(B > 0.0, 2.0 * Q / (B + sd), (sd - B) / (2.0 * at))
        la, ha = Wk[_LO], Wk[_HI]
        bad = ~((disc >= 0.0) & (zn > la) & (zn < ha))
        if halve:
            bad |= np.abs(zn - za) > 0.5 * np.abs(Wk[_DZ])
        if bad.any():
            geo = np.sqrt(np.maximum(la, TINY)) * np.sqrt(ha)
            mid = np.where(ha > 1e3 * la, geo, 0.5 * (la + ha))
            zn = np.where(bad, mid, zn)
        np.subtract(zn, za, out=Wk[_DZ])
        Wk[_Z] = zn
        _ev_rows(L, Wk, zn * (2.0 * ca + zn))
        it += 1
        ph = Wk[_PHI]
        pos = ph > 0.0
        Wk[_LO] = np.where(pos, zn, la)
        Wk[_HI] = np.where(pos, ha, zn)
        Wk[_FLO] = np.where(pos, ph, Wk[_FLO])
        Wk[_FHI] = np.where(pos, Wk[_FHI], ph)
        tol = Wk[_TOL]
        ok = np.abs(ph) <= tol
        flat = (Wk[_FLO] - Wk[_FHI] <= 2.0 * tol) | (Wk[_HI] - Wk[_LO] <= tiny4 * Wk[_HI])
        ex = flat & ~ok
        exn = ex.any()
        if exn:  # bracket exhausted: the end closer to phi = 0 (one more evaluation)
            Wx = Wk[:, ex]
            Wx[_Z] = np.where(Wx[_FLO] < -Wx[_FHI], Wx[_LO], Wx[_HI])
            _ev_rows(L, Wx, Wx[_Z] * (2.0 * Wx[_CC] + Wx[_Z]))
            Wk[:, ex] = Wx
        done = ok | flat
        if done.any():
            its = it + ex[done] if exn else it
            conv[retire(done, its)] = True
            Wk = Wk[:, ~done]
        halve = True
    if Wk.shape[1]:  # iteration limit: not converged
        retire(np.ones(Wk.shape[1], dtype=bool), it)
    c = br.c
    dl = z_out * (2.0 * c + z_out)
    g = br.g
    cert = conv & (at + g * e_out[2] * e_out[3] - g * e_out[1] * np.abs(br.dmu0) > 0.0)
    return dl, e_out, conv, it_out, cert


def vroot(br: VBr, tol_f, max_iter, dl_start=None, e_start=None):
    """``vsolve`` then main's scan where not certified: ``dl, e, conv, it, jump``."""
    dl, e, conv, it, cert = vsolve(br, tol_f, max_iter, dl_start, e_start)
    jump = np.zeros(dl.size, dtype=bool)
    unc = np.flatnonzero(conv & ~cert)
    if unc.size:
        L = br.L
        vb = scan.Branch(L.p, br.A[unc], br.g[unc], br.r0[unc], br.mu0[unc], br.b[unc])
        x, ok, its, jp = scan.scan(vb, np.arange(unc.size), dl[unc], tol_f[unc], max_iter)
        dl[unc], conv[unc], jump[unc] = x, ok, jp
        it[unc] += its
        ee = br.ev(dl[unc], unc)
        for j in range(7):
            e[j][unc] = ee[j]
    return dl, e, conv, it, jump


def partials(br: VBr, dl, e, idx=None):
    """``H = -phi'``, ``dr/dr0``, ``dmu/dmu0``, ``dmu/db`` at the root (rows idx of br)."""
    L = br.L
    idx = slice(None) if idx is None else idx
    _, r, U, mu, dmu, w, sn = e[:7]
    g = br.g[idx]
    H = L.at + g * (U * mu + r * dmu)
    H = np.maximum(np.where(np.isfinite(H), H, L.at), 1e-12 * L.at)
    c0, sin0 = br.c0[idx], br.sin0[idx]
    okR = (sn > 0.0) & (c0 > 0.0)
    R = np.where(okR, (w / np.where(okR, c0, 1.0)) * sin0 / np.where(okR, sn, 1.0),
                 np.where(dl == 0.0, 1.0, 0.0))  # fmt: skip
    a = L.kappa * dl
    b = br.b[idx]
    E, dE = E_dE(a + b)
    Mmu = np.exp(-(a + b))
    D = a * br.d_k[idx] + b * br.d_s[idx]
    Mb = -br.d_s[idx] * E - D * dE
    return H, R, Mmu, Mb


def finish(L, Pi, e, i, g, jump, it, mu_o, r_o, status, unst, its):
    """Write the outputs of converged plastic points ``Pi`` (rows ``i`` of ``e``)."""
    r, U, mu = e[1][i], e[2][i], e[3][i]
    den = -L.kappa * (mu - L.mu_k) * r + U * mu + L.at / g
    mu_o[Pi] = mu
    r_o[Pi] = np.minimum(np.maximum(r, 0.0), 1.0)
    status[Pi] = np.where(jump, JUMP, PLASTIC)
    unst[Pi] = den <= 0.0
    its[Pi] = it
