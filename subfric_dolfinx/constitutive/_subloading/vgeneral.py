"""Split and/or rotation of the flow direction, batched, with the exact tangent.

The twin of :mod:`.general`. Derivative arrays have a last axis over the m gap components. Rows
without a split have a start state independent of the gap (zero derivatives); the split part is
computed on the split rows only. The quadratures are chained through scalar partials.
"""

from __future__ import annotations

import numpy as np

from .common import EPS
from .switch import ROOT, vsplit_ds
from .vroot import finish, g_of, partials, vroot
from .vrotation import rotation

__all__ = ["general"]

_PI = np.pi


def general(L, P, gi, nt, ft_p, A_p, tstar, fn_p, g_p, f0, split, split_s, mu_c, b, tol_f,
            max_iter, br, dl0_all, e_all, it_all, jump_all, rot_all, up_s, tr, tan, up_o, mu_o,
            r_o, status, unst, its):  # fmt: skip
    """Split and/or rotation on rows ``gi`` of the plastic set, with forward derivatives.

    Derivative arrays have a last axis over the m gap components. Rows without a split have
    a start state independent of the gap (zero derivatives); the split part is computed on the
    split rows only. The quadratures are chained through scalar partials.
    """
    at, an, cn = L.at, L.an, L.cn
    mu_k = L.mu_k
    m = nt + 1
    k = gi.size
    Pg = P[gi]
    ft, A, ts, fn, g = ft_p[gi], A_p[gi], tstar[gi], fn_p[gi], g_p[gi]
    f0t, fn0 = f0[Pg, :nt], f0[Pg, nt]
    rot = rot_all[gi]
    e0 = [x[gi] for x in e_all]
    dl0 = dl0_all[gi]
    it = it_all[gi].copy()
    jump = jump_all[gi].copy()
    r0, mu0, b0 = br.r0[gi], br.mu0[gi], br.b[gi]
    ms0 = -br.d_s[gi]  # mu_s - mu0, without cancellation
    dg1n = cn * (1.0 - g) * an  # d g1 / d ubar_n (only the normal column)
    # start state: f_s, rho_s, fn_s, g_s and their derivatives (zero without a split)
    f_s = f0t.copy()
    fn_s = fn0.copy()
    df_s = np.zeros((k, nt, m))
    drho_s = np.zeros((k, m))
    dr0 = np.zeros((k, m))
    dmu0 = np.zeros((k, m))
    db = np.zeros((k, m))
    dg_s = np.zeros((k, m))
    dfn_s = np.zeros((k, m))
    si = np.flatnonzero(split[Pg])
    if si.size:
        wv = ft[si] - f0t[si]
        Ps = Pg[si]
        s = split_s[Ps]
        bp = b[Ps]
        ds = vsplit_ds(L, f0t[si], ft[si], fn0[si], fn[si], mu_c[Ps], bp, s, split[Ps])
        fsi = f0t[si] + s[:, None] * wv
        dfs = ds[:, None, :] * wv[:, :, None]
        for i in range(nt):
            dfs[:, i, i] += s * at
        fnsi = fn0[si] + s * (fn[si] - fn0[si])
        dfns = ds * (fn[si] - fn0[si])[:, None]
        dfns[:, nt] += s * an
        gsi = g_of(L, fnsi)
        dgs = (cn * (1.0 - gsi))[:, None] * dfns
        m0 = mu0[si]
        dm0 = (ms0[si] * bp)[:, None] * ds
        rhs = np.abs(fsi[:, 0]) if nt == 1 else np.hypot(fsi[:, 0], fsi[:, 1])
        rp = rhs > 0.0
        drh = np.einsum("ki,kij->kj", fsi, dfs) / np.where(rp, rhs, 1.0)[:, None]
        drh = np.where(rp[:, None], drh, 0.0)
        okr = rp & (r0[si] < 1.0)
        gsm = np.where(okr, gsi * m0, 1.0)
        # (ROOT: r0 = r_n rho_s g_0 mu_n / (rho_0 g_s mu0): d r0 / d rho_s = r0 / rho_s)
        gsm = np.where(split[Ps] == ROOT, np.where(okr, rhs / r0[si], 1.0), gsm)
        gs1 = np.where(okr, gsi, 1.0)
        dr0_si = drh / gsm[:, None] - r0[si][:, None] * (dgs / gs1[:, None] + dm0 / m0[:, None])
        dr0[si] = np.where(okr[:, None], dr0_si, 0.0)
        f_s[si], fn_s[si], df_s[si], drho_s[si] = fsi, fnsi, dfs, drh
        dmu0[si], db[si], dg_s[si], dfn_s[si] = dm0, -bp[:, None] * ds, dgs, dfns
    g_s = g_of(L, fn_s)
    rho_s = np.abs(f_s[:, 0]) if nt == 1 else np.hypot(f_s[:, 0], f_s[:, 1])
    dA = np.zeros((k, m))
    dA[:, :nt] = at * ts
    # predictor root derivative
    H, R, Mmu, Mb = partials(br, dl0, e0, gi)
    r_, mu_ = e0[1], e0[3]
    gmr, gr = (g * mu_ * R)[:, None], (g * r_)[:, None]
    ddl0 = (dA - gmr * dr0 - gr * (Mmu[:, None] * dmu0 + Mb[:, None] * db)) / H[:, None]
    ddl0[:, nt] -= dg1n * r_ * mu_ / H

    # -- no rotation (split only): fixed direction t*
    nr = np.flatnonzero(~rot)
    if nr.size:
        rho1 = np.minimum(g[nr] * r_[nr] * mu_[nr], A[nr])
        drho1 = dA[nr] - at * ddl0[nr]
        t = ts[nr]
        D = np.zeros((nr.size, m, m))
        D[:, :nt, :] = t[:, :, None] * drho1[:, None, :]
        proj = np.eye(nt) - t[:, :, None] * t[:, None, :]
        D[:, :nt, :nt] += (rho1 * at / A[nr])[:, None, None] * proj
        D[:, nt, nt] = an
        Pn = Pg[nr]
        tan[Pn] = D
        tr[Pn, :nt] = rho1[:, None] * t
        tr[Pn, nt] = fn[nr]
        up_o[Pn] = up_s[Pn] + dl0[nr][:, None] * t
        finish(L, Pn, e0, nr, g[nr], jump[nr], it[nr], mu_o, r_o, status, unst, its)
    q = np.flatnonzero(rot)
    ok = np.ones(k, dtype=bool)
    if q.size == 0:
        return ok
    # -- rotation of the flow direction (nt = 2), rows q
    ft, f_s, df_s, rho_s, drho_s = ft[q], f_s[q], df_s[q], rho_s[q], drho_s[q]
    dr0, dmu0, db, dg_s, g_s = dr0[q], dmu0[q], db[q], dg_s[q], g_s[q]
    r0, mu0, b0, fn, fn_s, dfn_s = r0[q], mu0[q], b0[q], fn[q], fn_s[q], dfn_s[q]
    ms0 = ms0[q]
    dA, ddl0, dl0, A, g, dg1n = dA[q], ddl0[q], dl0[q], A[q], g[q], dg1n[q]
    tol_q = tol_f[gi][q]
    kq = q.size
    sp_q = bool(np.any(split[Pg[q]]))  # else: the start state does not depend on the gap
    ws = ft - f_s
    W = np.hypot(ws[:, 0], ws[:, 1])
    ew = ws / W[:, None]
    dW = np.zeros((kq, 3))
    dphi_w = np.zeros((kq, 3))
    dW[:, :2] = at * ew
    dphi_w[:, 0] = -at * ws[:, 1] / (W * W)
    dphi_w[:, 1] = at * ws[:, 0] / (W * W)
    if sp_q:
        dW -= np.einsum("ki,kij->kj", ew, df_s)
        dphi_w -= (ws[:, 0, None] * df_s[:, 1] - ws[:, 1, None] * df_s[:, 0]) / (W * W)[:, None]
        cr = f_s[:, 0, None] * df_s[:, 1] - f_s[:, 1, None] * df_s[:, 0]
        dphi_f = cr / (rho_s * rho_s)[:, None]
        dth0 = dphi_f - dphi_w
    else:
        dth0 = -dphi_w
    Wr = W * rho_s
    cth0 = np.einsum("ij,ij->i", ws, f_s) / Wr
    sth0 = (ws[:, 0] * f_s[:, 1] - ws[:, 1] * f_s[:, 0]) / Wr
    tau0 = sth0 / (1.0 + cth0)
    ddirect = dW * cth0[:, None] - (W * sth0)[:, None] * dth0
    d0 = W * cth0
    dd0 = ddirect
    sin0 = br.sin0[gi][q]
    c0 = br.c0[gi][q]
    rf = (sin0 > 0.0) & (g_s > 0.0)
    sin0_ = np.where(rf, sin0, 1.0)
    gs_ = np.where(rf, g_s, 1.0)
    U0 = L.ut * c0 / sin0_
    gp = cn * (1.0 - g_s)
    dfr = fn - fn_s
    num = W * cth0 / gs_ - rho_s * gp * dfr / (gs_ * gs_) - b0 * ms0 * r0
    den = -L.kappa * (mu0 - mu_k) * r0 + U0 * mu0 + at / gs_
    lam_on = rf & (num > 0.0) & (den > 0.0)
    # at a ROOT split the start is the loading switch: num = 0 there by construction
    lam_on &= split[Pg[q]] != ROOT
    if np.any(lam_on):
        lam = np.where(lam_on, num / np.where(lam_on, den, 1.0), 0.0)
        gs2 = gs_ * gs_
        # d num, d den: the normal column carries dfr; the rest through the base derivatives
        ddfr = -dfn_s.copy()
        ddfr[:, 2] += L.an
        dnum = ddirect / gs_[:, None] - (rho_s * gp / gs2)[:, None] * ddfr
        if sp_q:
            c_g = -W * cth0 / gs2 + rho_s * cn * dfr / gs2 + 2.0 * rho_s * gp * dfr / (gs2 * gs_)
            dnum += (c_g[:, None] * dg_s
                     - (gp * dfr / gs2)[:, None] * drho_s
                     - (ms0 * r0)[:, None] * db + (b0 * r0)[:, None] * dmu0
                     - (b0 * ms0)[:, None] * dr0)  # fmt: skip
            dU = (-L.ut * 0.5 * _PI / (sin0_ * sin0_))
            dden = (
                (-L.kappa * (mu0 - mu_k) + dU * mu0)[:, None] * dr0
                + (-L.kappa * r0 + U0)[:, None] * dmu0
                - (at / gs2)[:, None] * dg_s
            )
            dnum -= lam[:, None] * dden
        d0 = np.where(lam_on, W * cth0 - at * lam, d0)
        dd0 = np.where(lam_on[:, None],
                       ddirect - at * dnum / np.where(lam_on, den, 1.0)[:, None], dd0)  # fmt: skip
    rho1p = A - at * dl0
    drho1p = dA - at * ddl0
    # rotation over the step (model of |f_t| and quadratures: _rotation)
    P = np.einsum("ij,ij->i", ws, f_s)
    dP = np.zeros((kq, 3))
    dP[:, :2] = at * f_s
    if sp_q:
        dP += np.einsum("ki,kij->kj", ws - f_s, df_s)
    C, T1, cC, cT = rotation(rho_s, d0, rho1p, P, W, A, tau0)
    cth1 = (1.0 - T1 * T1) / (1.0 + T1 * T1)
    sth1 = 2.0 * T1 / (1.0 + T1 * T1)
    h1 = 2.0 / (1.0 + T1 * T1)
    dtf = 0.5 * (1.0 + tau0 * tau0)  # dtau0 = dtf dth0
    bases = (dth0, drho_s, dd0, drho1p, dP, dW, dA)
    cC[0] = cC[0] * dtf
    cT[0] = cT[0] * dtf
    if not sp_q:  # drho_s = 0
        cC[1] = cT[1] = None
    dC = sum(c[:, None] * bv for c, bv in zip(cC, bases, strict=True) if c is not None)
    dth1 = h1[:, None] * sum(c[:, None] * bv for c, bv in zip(cT, bases, strict=True)
                             if c is not None)  # fmt: skip
    dAeff = dW * C[:, None] + W[:, None] * dC
    if sp_q:
        dAeff += drho_s
    Aeff = rho_s + W * C
    br2 = br.sub(gi[q], Aeff)
    keep = ~(Aeff - g * r0 * br2.mu_rec > 0.0)
    if np.any(keep):
        Aeff = np.where(keep, A, Aeff)
        dAeff = np.where(keep[:, None], dA, dAeff)
        br2.A[:] = Aeff
    e_st = [x[q] for x in e0]
    e_st[0] = e_st[0] + (Aeff - A)
    dl, e, conv, it2, jump2 = vroot(br2, np.maximum(tol_q, 8.0 * EPS * Aeff), max_iter, dl0, e_st)
    it[q] += it2
    H, R, Mmu, Mb = partials(br2, dl, e)
    r_, mu_ = e[1], e[3]
    ddl = dAeff / H[:, None]
    if sp_q:
        gmr, gr = (g * mu_ * R)[:, None], (g * r_)[:, None]
        ddl -= (gmr * dr0 + gr * (Mmu[:, None] * dmu0 + Mb[:, None] * db)) / H[:, None]
    ddl[:, 2] -= dg1n * r_ * mu_ / H
    rho1 = np.minimum(g * r_ * mu_, Aeff)
    drho1 = dAeff - at * ddl
    dph1 = dphi_w + dth1
    t1 = np.stack([cth1 * ew[:, 0] - sth1 * ew[:, 1], sth1 * ew[:, 0] + cth1 * ew[:, 1]], axis=1)
    D = np.zeros((kq, 3, 3))
    D[:, 0, :] = t1[:, 0, None] * drho1 - (rho1 * t1[:, 1])[:, None] * dph1
    D[:, 1, :] = t1[:, 1, None] * drho1 + (rho1 * t1[:, 0])[:, None] * dph1
    D[:, 2, 2] = an
    Pq = Pg[q]
    tan[Pq] = D
    f1 = rho1[:, None] * t1
    tr[Pq, :2] = f1
    tr[Pq, 2] = fn
    up_o[Pq] = up_s[Pq] + (ft - f1) / at
    finish(L, Pq, e, slice(None), g, jump2, it[q], mu_o, r_o, status, unst, its)
    ok[q] = conv
    return ok
