"""Unrolled fast paths of :func:`.general.general` for a rotation from a fixed start (nt = 2).

Same arithmetic as the general path (checked to 3e-14 in the tests): the start state does not
depend on the gap, so every derivative is a combination of the three gap components.
"""

from __future__ import annotations

import math

from .common import EPS, FAILED
from .root import certified_root, finish, g_of, partials
from .rotation import rotation

__all__ = ["collinear", "rotate_fixed"]

_hypot, _isfinite = math.hypot, math.isfinite


def rotate_fixed(L, up, ft, A, tstar, fn, g, f0, mu_c, tol_f, max_iter, br, dl0, e0, iters):
    """The general path for a rotation from a fixed start (no split; nt = 2), unrolled.

    The start state does not depend on the gap, so every derivative is a combination of the
    three gap components, written out as (x, y, n) triples. Same arithmetic as
    :func:`.general.general`.
    """
    at, an, cn = L.at, L.an, L.cn
    mu_k = L.mu_k
    fs0, fs1, fn_s = f0[0], f0[1], f0[2]
    rho_s = _hypot(fs0, fs1)
    g_s = g_of(L, fn_s)
    r0, mu0, b0 = br.r0, br.mu0, br.b
    dg1n = cn * (1.0 - g) * an
    # predictor: d dl0 = (dA - dg1 r mu) / H with dA = alpha_t t* (tangential)
    H = partials(br, dl0, e0)[0]
    _, r, _, mu = e0[:4]
    t0x, t0y = tstar
    dl0x, dl0y, dl0n = at * t0x / H, at * t0y / H, -dg1n * r * mu / H
    ws0, ws1 = ft[0] - fs0, ft[1] - fs1
    W = _hypot(ws0, ws1)
    ew0, ew1 = ws0 / W, ws1 / W
    W2 = W * W
    dWx, dWy = at * ew0, at * ew1  # dW_n = 0
    dpx, dpy = -at * ws1 / W2, at * ws0 / W2  # d phi_w; d theta0 = -d phi_w
    Wr = W * rho_s
    cth0 = (ws0 * fs0 + ws1 * fs1) / Wr
    sth0 = (ws0 * fs1 - ws1 * fs0) / Wr
    tau0 = sth0 / (1.0 + cth0)
    Ws = W * sth0
    ddx = dWx * cth0 + Ws * dpx
    ddy = dWy * cth0 + Ws * dpy
    ddn = 0.0
    d0 = W * cth0
    sin_r0 = br.sin0
    if sin_r0 > 0.0 and g_s > 0.0:
        U0 = L.ut * br.c0 / sin_r0
        gp = cn * (1.0 - g_s)
        dfr = fn - fn_s
        gs2 = g_s * g_s
        num = W * cth0 / g_s - rho_s * gp * dfr / gs2 + b0 * br.d_s * r0
        den = -L.kappa * (mu0 - mu_k) * r0 + U0 * mu0 + at / g_s
        if num > 0.0 and den > 0.0:
            lam = num / den
            d0 = W * cth0 - at * lam
            f = at / den
            ddx, ddy, ddn = ddx - f * ddx / g_s, ddy - f * ddy / g_s, f * rho_s * gp / gs2 * an
    rho1p = A - at * dl0
    r1x, r1y, r1n = at * t0x - at * dl0x, at * t0y - at * dl0y, -at * dl0n
    P = ws0 * fs0 + ws1 * fs1  # d P = f_s . d f* (the start is fixed)
    C, T1, cC, cT = rotation(rho_s, d0, rho1p, P, W, A, tau0)
    dtf = 0.5 * (1.0 + tau0 * tau0)
    # bases (x, y, n): d tau0 = -dtf (dpx, dpy, 0); rho_s fixed; d0; rho1; P; W; A
    c_t, _, c_d, c_1, c_P, c_W, c_A = cC
    dCx = -c_t * dtf * dpx + c_d * ddx + c_1 * r1x + c_P * at * fs0 + c_W * dWx + c_A * at * t0x
    dCy = -c_t * dtf * dpy + c_d * ddy + c_1 * r1y + c_P * at * fs1 + c_W * dWy + c_A * at * t0y
    dCn = c_d * ddn + c_1 * r1n
    h1 = 2.0 / (1.0 + T1 * T1)
    c_t, _, c_d, c_1, c_P, c_W, c_A = cT
    dtx = h1 * (-c_t * dtf * dpx + c_d * ddx + c_1 * r1x + c_P * at * fs0 + c_W * dWx
                + c_A * at * t0x)  # fmt: skip
    dty = h1 * (-c_t * dtf * dpy + c_d * ddy + c_1 * r1y + c_P * at * fs1 + c_W * dWy
                + c_A * at * t0y)  # fmt: skip
    dtn = h1 * (c_d * ddn + c_1 * r1n)
    cth1 = (1.0 - T1 * T1) / (1.0 + T1 * T1)
    sth1 = 2.0 * T1 / (1.0 + T1 * T1)
    Aeff = rho_s + W * C
    dAx, dAy, dAn = dWx * C + W * dCx, dWy * C + W * dCy, W * dCn
    if Aeff - g * r0 * br.mu_rec > 0.0:
        br2 = br.with_A(Aeff)
    else:  # rotated trial inside: keep the predictor
        br2, Aeff, dAx, dAy, dAn = br, A, at * t0x, at * t0y, 0.0
    e_st = (e0[0] + (Aeff - A), *e0[1:])
    dl, e, conv, it2, jump = certified_root(br2, max(tol_f, 8.0 * EPS * Aeff), max_iter, dl0, e_st)
    iters += it2
    if not conv:
        return [0.0] * 3, [[0.0] * 3 for _ in range(3)], list(up), mu_c, br.r0, FAILED, False, iters
    H = partials(br2, dl, e)[0]
    _, r, _, mu = e[:4]
    rho1 = min(g * r * mu, Aeff)
    # d rho1 = dAeff - alpha_t d dl = dAeff (1 - alpha_t / H) + alpha_t dg1 r mu / H
    k1 = 1.0 - at / H
    drx, dry, drn = dAx * k1, dAy * k1, dAn * k1 + at * dg1n * r * mu / H
    dpx1, dpy1, dpn1 = dpx + dtx, dpy + dty, dtn
    t1x, t1y = cth1 * ew0 - sth1 * ew1, sth1 * ew0 + cth1 * ew1
    q1x, q1y = rho1 * t1x, rho1 * t1y
    tan = [
        [drx * t1x - q1y * dpx1, dry * t1x - q1y * dpy1, drn * t1x - q1y * dpn1],
        [drx * t1y + q1x * dpx1, dry * t1y + q1x * dpy1, drn * t1y + q1x * dpn1],
        [0.0, 0.0, an],
    ]
    f1x, f1y = rho1 * t1x, rho1 * t1y
    up1 = [up[0] + (ft[0] - f1x) / at, up[1] + (ft[1] - f1y) / at]
    return finish(L, [f1x, f1y, fn], tan, up1, e, g, jump, iters)


def collinear(L, up, ft, A, tstar, fn, g, f0, br, dl, e, iters, jump):
    """The rotation path for a start traction exactly along the trial (theta_0 = 0).

    Same numbers as :func:`rotate_fixed` at ``tau0 = 0``: ``C = 1``, ``A_eff = A`` (the
    predictor's root is the corrector's), the traction of the radial return, and main's tangent
    except across the trial, where the stiffness is ``alpha_t rho_1 (1 - exp(-W J(1))) / W``
    (the end direction follows a perpendicular perturbation of the trial only partly: it is
    turned back towards ``w`` by the rotation) instead of ``alpha_t rho_1 / A``.
    """
    at, an, cn = L.at, L.an, L.cn
    fs0, fs1, fn_s = f0[0], f0[1], f0[2]
    rho_s = _hypot(fs0, fs1)
    g_s = g_of(L, fn_s)
    ws0, ws1 = ft[0] - fs0, ft[1] - fs1
    W = _hypot(ws0, ws1)
    r0, mu0, b0 = br.r0, br.mu0, br.b
    d0 = W
    if br.sin0 > 0.0 and g_s > 0.0:  # rate-form slope of |f_t| at the start (as _rotate)
        gp = cn * (1.0 - g_s)
        num = W / g_s - rho_s * gp * (fn - fn_s) / (g_s * g_s) + b0 * br.d_s * r0
        den = -L.kappa * (mu0 - L.mu_k) * r0 + L.ut * br.c0 / br.sin0 * mu0 + at / g_s
        if num > 0.0 and den > 0.0:
            d0 = W - at * num / den
    ex1 = rotation(rho_s, d0, A - at * dl, ws0 * fs0 + ws1 * fs1, W, A, 0.0)[3][0]
    _, r, U, mu, dmu = e[:5]
    H = at + g * (U * mu + r * dmu)
    H = H if _isfinite(H) else at
    H = max(H, 1e-12 * at)
    rho1 = min(g * r * mu, A)
    dg = cn * (1.0 - g)
    t0, t1 = tstar
    c1 = 1.0 - at / H
    fp = rho1 * (1.0 - ex1) / W  # across the trial (radial: rho1 / A)
    tan = [
        [at * (c1 * t0 * t0 + fp * (1.0 - t0 * t0)), at * (c1 - fp) * t0 * t1, 0.0],
        [at * (c1 - fp) * t0 * t1, at * (c1 * t1 * t1 + fp * (1.0 - t1 * t1)), 0.0],
        [0.0, 0.0, an],
    ]
    cn_ = at * an * dg * r * mu / H
    tan[0][2], tan[1][2] = cn_ * t0, cn_ * t1
    f1x, f1y = rho1 * t0, rho1 * t1
    up1 = [up[0] + (ft[0] - f1x) / at, up[1] + (ft[1] - f1y) / at]
    return finish(L, [f1x, f1y, fn], tan, up1, e, g, jump, iters)
