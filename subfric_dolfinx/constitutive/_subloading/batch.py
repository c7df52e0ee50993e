"""The subloading return map batched in numpy over cache-sized chunks (the twin of :mod:`.point`).

Results are independent of the chunking (no cross-point logic). Points are sorted into
separated/touching, elastic and plastic ones; plastic points with a fixed direction from a fixed
start get main's closed-form tangent here, split and rotated ones go to :mod:`.vgeneral`.
"""

from __future__ import annotations

import numpy as np

from ..tolerances import contact_band
from .common import CHUNK, ELASTIC, EPS, FAILED, ROT_HI, ROT_LO, SEPARATED, Law
from .switch import ROOT, vsplit_point, vunstable_start
from .vgeneral import general
from .vroot import VBr, finish, g_of, vroot

__all__ = ["batch"]


def batch(L: Law, gap, state, dt, out, tol, max_iter, contact_tol, chunk: int = CHUNK):
    """Integrate ``state`` (an ``InterfaceState``, with or without ``f``) to ``gap``.

    ``dt``: a float or per-point increments (N,).

    ``out``: the allocated end-of-step state (``f`` written when it has one). Returns
    ``(traction, tangent, status, unstable, iterations)``.
    """
    n, nt = state["up"].shape
    m = nt + 1
    tr = np.zeros((n, m))
    tan = np.zeros((n, m, m))
    status = np.empty(n, dtype=np.int8)
    unstable = np.zeros(n, dtype=bool)
    iters = np.zeros(n, dtype=np.int64)
    f_in = state["f"] if "f" in state else None
    up_i, mu_i, r_i = state["up"], state["mu"], state["r"]
    up_o, mu_o, r_o = out["up"], out["mu"], out["r"]
    with np.errstate(all="ignore"):
        for a in range(0, n, chunk):
            sl = slice(a, min(a + chunk, n))
            dts = dt if np.ndim(dt) == 0 else dt[sl]
            _chunk(L, gap[sl], up_i[sl], mu_i[sl], r_i[sl],
                   None if f_in is None else f_in[sl], dts, tol, max_iter, contact_tol,
                   tr[sl], tan[sl], up_o[sl], mu_o[sl], r_o[sl], status[sl],
                   unstable[sl], iters[sl])  # fmt: skip
    if "f" in out:
        np.copyto(out["f"], tr)
    return tr, tan, status, unstable, iters


def _chunk(L, gap, up, mu, r, f0, dt, tol, max_iter, contact_tol, tr, tan, up_o, mu_o, r_o,
           status, unst, its):  # fmt: skip
    n, nt = up.shape
    at, an = L.at, L.an
    mu_k, mu_s = L.mu_k, L.mu_s
    ok = (
        np.isfinite(gap).all(axis=1)
        & np.isfinite(up).all(axis=1)
        & np.isfinite(mu)
        & np.isfinite(r)
        & (r >= -1e-9)
        & (r <= 1.0 + 1e-9)
        & (mu >= mu_k * (1 - 1e-12))
        & (mu <= mu_s * (1 + 1e-12))
    )
    if f0 is not None:
        ok &= np.isfinite(f0).all(axis=1)
    gap_s = np.where(ok[:, None], gap, 0.0)
    up_s = np.where(ok[:, None], up, 0.0)
    mu_c = np.where(ok, np.minimum(np.maximum(mu, mu_k), mu_s), mu_s)
    r_c = np.where(ok, np.minimum(np.maximum(r, 0.0), 1.0), 0.0)
    ft = at * (gap_s[:, :nt] - up_s)
    A = np.abs(ft[:, 0]) if nt == 1 else np.hypot(ft[:, 0], ft[:, 1])
    un = gap_s[:, nt]
    fn = an * un
    g = g_of(L, fn)
    # contact band (``..tolerances``): |ubar_n| within the rounding of the gap touches
    if contact_tol > 0.0:
        touching = ok & (np.abs(un) <= contact_band(gap_s, up_s, L.len_n, contact_tol))
    else:
        touching = ok & (un == 0.0)
    contact = ok & ~touching & (un > 0.0) & (g > 0.0)
    b = np.full(n, L.xi * dt) if np.ndim(dt) == 0 else L.xi * dt  # per point
    mu_rec = np.minimum(mu_c + (mu_s - mu_c) * (-np.expm1(-b)), mu_s)

    # split of the elastic trial segment at the elastic -> plastic switch (.switch), computed on
    # the candidates only
    mu_st, r_st, b_st, d_st = mu_c, r_c, b.copy(), mu_c - mu_s
    split = np.zeros(n, dtype=np.int8)  # 0 or the kind of split
    split_s = np.zeros(n)
    f_s = None
    mu_rec_st = mu_rec
    if f0 is not None:
        f0t, fn0 = f0[:, :nt], f0[:, nt]
        f_s = f0t.copy()
        cand = np.flatnonzero(contact & (fn0 > 0.0) & np.isfinite(A))
        if cand.size:
            sc, kc = vsplit_point(L, f0t[cand], fn0[cand], ft[cand], fn[cand], A[cand],
                                  mu_c[cand], b[cand])  # fmt: skip
            split[cand], split_s[cand] = kc, sc
        si = np.flatnonzero(split)
        if si.size:
            s = split_s[si]
            f_s[si] += s[:, None] * (ft[si] - f0t[si])
            fn_m = fn0[si] + s * (fn[si] - fn0[si])
            g_s = g_of(L, fn_m)
            mu_c_ = mu_c[si]
            bs = b[si] * s
            mu_m = np.minimum(mu_c_ + (mu_s - mu_c_) * (-np.expm1(-bs)), mu_s)
            rho_m = np.abs(f_s[si, 0]) if nt == 1 else np.hypot(f_s[si, 0], f_s[si, 1])
            gm = g_s * mu_m
            r_m = np.where(gm > 0.0, np.where(rho_m < gm, rho_m / gm, 1.0),
                           np.where(rho_m == 0, 0, 1.0))  # fmt: skip
            ro = split[si] == ROOT  # r scaled by r_el(s) / r_el(0): continuous as s -> 0
            if ro.any():
                sr = si[ro]
                rho0 = np.abs(f0t[sr, 0]) if nt == 1 else np.hypot(f0t[sr, 0], f0t[sr, 1])
                q = (rho_m[ro] / rho0) * (g_of(L, fn0[sr]) / g_s[ro]) * (mu_c[sr] / mu_m[ro])
                r_m[ro] = np.minimum(r_c[sr] * q, 1.0)
            mu_st, r_st, mu_rec_st = mu_c.copy(), r_c.copy(), mu_rec.copy()
            mu_st[si], r_st[si], b_st[si] = mu_m, r_m, b[si] - bs
            d_st = d_st.copy()
            d_st[si] = (mu_c_ - mu_s) * np.exp(-bs)  # mu_st - mu_s without cancellation
            mu_rec_st[si] = np.minimum(mu_m + (mu_s - mu_m) * (-np.expm1(-b_st[si])), mu_s)
            if ro.any():  # no ROOT split where the plastic part would start unstable (.switch)
                sr = si[ro]
                bad = vunstable_start(L, g[sr], r_st[sr], mu_st[sr], b_st[sr], d_st[sr])
                if bad.any():
                    j = sr[bad]
                    split[j], split_s[j] = 0, 0.0
                    f_s[j] = f0t[j]
                    mu_st[j], r_st[j], b_st[j] = mu_c[j], r_c[j], b[j]
                    d_st[j], mu_rec_st[j] = mu_c[j] - mu_s, mu_rec[j]
    finite = np.isfinite(A)
    # plastic only when the trial leaves the loading surface by more than tol g mu
    gm_st = g * mu_rec_st
    plastic = contact & (A > 0.0) & (A - gm_st * r_st > tol * gm_st) & finite
    elastic = contact & ~plastic & finite
    sep = ok & ~contact
    contact &= finite  # an overflowing trial fails: last state kept
    status[:] = FAILED
    status[elastic] = ELASTIC
    status[sep] = SEPARATED
    # defaults: elastic trial (failed/separated: zero traction), state unchanged
    up_o[:] = up_s
    mu_o[:] = np.where(ok & finite, mu_rec, mu_c)
    gm = g * mu_rec
    r_el = np.where(A == 0.0, 0.0, np.where(A < gm, A / gm, 1.0))
    r_o[:] = np.where(contact, r_el, np.where(sep, 0.0, r_c))
    tr[elastic, :nt] = ft[elastic]  # tr: zeros on entry
    tr[elastic, nt] = fn[elastic]
    diag = np.zeros(nt + 1)
    diag[:nt], diag[nt] = at, an
    tan[elastic | touching] = np.diag(diag)  # tan, its, unst: zeros on entry
    P = np.flatnonzero(plastic)
    if P.size == 0:
        return
    _plastic(L, P, nt, ft, A, fn, g, f0, f_s, split, split_s, mu_st, r_st, b_st, d_st, mu_c, r_c, b,
             up_s, tol, max_iter, tr, tan, up_o, mu_o, r_o, status, unst, its)  # fmt: skip


def _plastic(L, P, nt, ft, A, fn, g, f0, f_s, split, split_s, mu_st, r_st, b_st, d_st, mu_c, r_c,
             b,
             up_s, tol, max_iter, tr, tan, up_o, mu_o, r_o, status, unst, its):  # fmt: skip
    """Solve the plastic points ``P`` of a chunk and write their outputs."""
    at, an = L.at, L.an
    A_p, g_p, fn_p = A[P], g[P], fn[P]
    tol_f = np.maximum(tol * g_p * L.mu_s, 8.0 * EPS * A_p)
    br = VBr(L, A_p, g_p, r_st[P], mu_st[P], b_st[P], d_s=d_st[P])
    dl, e, conv, it, jump = vroot(br, tol_f, max_iter)
    ft_p = ft[P]
    tstar = ft_p / A_p[:, None]
    sp = split[P] > 0
    rot = np.zeros(P.size, dtype=bool)
    if nt == 2 and f_s is not None:
        fs = f_s[P]
        ws = ft_p - fs
        W = np.hypot(ws[:, 0], ws[:, 1])
        rs = np.hypot(fs[:, 0], fs[:, 1])
        rot = conv & (rs > tol_f) & (W > 0.0) & (f0[P, nt] > 0.0)  # also at theta_0 = 0,
        rot &= sp | (np.einsum("ij,ij->i", ws, fs) >= 0.0)  # not if |f_t| shrinks all through
        rot &= (np.minimum(rs, W) > ROT_LO) & (np.maximum(np.maximum(rs, W), A_p) < ROT_HI)
        rot &= (g_p > ROT_LO) & (g_of(L, f0[P, nt]) > ROT_LO)
    simple = conv & ~rot & ~sp
    # -- fixed direction from a fixed start: main's closed-form tangent
    _, r, U, mu, dmu = e[:5]
    rho1 = np.minimum(g_p * r * mu, A_p)
    i = np.flatnonzero(simple)
    if i.size:
        Pi = P[i]
        H = at + g_p[i] * (U[i] * mu[i] + r[i] * dmu[i])
        H = np.maximum(np.where(np.isfinite(H), H, at), 1e-12 * at)
        ts = tstar[i]
        nn = ts[:, :, None] * ts[:, None, :]
        D = np.zeros((i.size, nt + 1, nt + 1))
        D[:, :nt, :nt] = at * ((1.0 - at / H)[:, None, None] * nn
                               + (rho1[i] / A_p[i])[:, None, None] * (np.eye(nt) - nn))  # fmt: skip
        dg = L.cn * (1.0 - g_p[i])
        D[:, :nt, nt] = (at * an * dg * r[i] * mu[i] / H)[:, None] * ts
        D[:, nt, nt] = an
        tan[Pi] = D
        tr[Pi, :nt] = rho1[i][:, None] * ts
        tr[Pi, nt] = fn_p[i]
        up_o[Pi] = up_s[Pi] + dl[i][:, None] * ts
        finish(L, Pi, e, i, g_p[i], jump[i], it[i], mu_o, r_o, status, unst, its)
    gi = np.flatnonzero(conv & (rot | sp))
    if gi.size:
        conv[gi] = general(
            L, P, gi, nt, ft_p, A_p, tstar, fn_p, g_p, f0, split, split_s, mu_c, b, tol_f,
            max_iter, br, dl, e,
            it, jump, rot, up_s, tr, tan, up_o, mu_o, r_o, status, unst, its,
        )  # fmt: skip
    bad = np.flatnonzero(~conv)
    if bad.size:
        Pb = P[bad]
        tr[Pb] = 0.0
        tan[Pb] = 0.0
        up_o[Pb] = up_s[Pb]
        mu_o[Pb] = mu_c[Pb]
        r_o[Pb] = r_c[Pb]
        status[Pb] = FAILED
        unst[Pb] = False
        its[Pb] = np.maximum(its[Pb], it[bad])

