"""One point, one step of the subloading return map, in plain floats (the reference).

:func:`point` is the readable specification of the algorithm; the package's numpy map
(``subfric_dolfinx/constitutive/_subloading``) computes the same. Steps (see
``subfric_dolfinx/constitutive/subloading.py``):
validation; trial; contact band; reversal split; loading test; the predictor's certified root;
then a fixed direction (main's closed-form tangent), or :func:`.general.general` (split and/or
rotation with forward derivatives).
"""

from __future__ import annotations

import math

from .common import ELASTIC, EPS, FAILED, ROT_HI, ROT_LO, SEPARATED, Law
from .general import general
from .root import Br, certified_root, finish, g_of
from .switch import ROOT, split_point, unstable_start

__all__ = ["point"]

_expm1, _exp, _hypot, _isfinite = math.expm1, math.exp, math.hypot, math.isfinite


def point(L: Law, gap, up, mu_n, r_n, f0, dt, tol, max_iter, contact_tol):
    """One point, one step. ``gap`` (m,), ``up`` (nt,), ``f0`` (m,) or None (no start traction).

    Returns ``(traction list m, tangent m x m nested list, up list, mu, r, status, unstable,
    iterations)``; status codes as ``Status`` (0 elastic, 1 plastic, 2 separated, 3 jump,
    4 failed).
    """
    nt = len(up)
    m = nt + 1
    at, an = L.at, L.an
    mu_k, mu_s = L.mu_k, L.mu_s
    ok = (
        all(map(_isfinite, gap))
        and all(map(_isfinite, up))
        and -1e-9 <= r_n <= 1.0 + 1e-9  # (False for NaN)
        and mu_k * (1 - 1e-12) <= mu_n <= mu_s * (1 + 1e-12)
        and (f0 is None or all(map(_isfinite, f0)))
    )
    zero_t = [[0.0] * m for _ in range(m)]
    if not ok:  # as main: zero traction, state (0, mu_s, 0)
        return [0.0] * m, zero_t, [0.0] * nt, mu_s, 0.0, FAILED, False, 0
    mu_c = min(max(mu_n, mu_k), mu_s)
    r_c = min(max(r_n, 0.0), 1.0)
    ft = [at * (gap[i] - up[i]) for i in range(nt)]
    A = abs(ft[0]) if nt == 1 else _hypot(ft[0], ft[1])
    un = gap[nt]
    fn = an * un
    g = g_of(L, fn)
    b = L.xi * dt
    mu_rec = min(mu_c + (mu_s - mu_c) * -_expm1(-b), mu_s)
    # contact band (``..tolerances``): |ubar_n| within the rounding of the gap touches
    if nt == 1:
        band = max(abs(gap[0]), abs(up[0]), L.len_n) * contact_tol
    else:
        band = max(_hypot(gap[0], gap[1]), _hypot(up[0], up[1]), L.len_n) * contact_tol
    touching = abs(un) <= band if contact_tol > 0.0 else un == 0.0
    if touching or not (un > 0.0 and g > 0.0):
        tan = zero_t
        if touching:
            tan = [[(at if i == j and i < nt else 0.0) for j in range(m)] for i in range(m)]
            tan[nt][nt] = an
        return [0.0] * m, tan, list(up), mu_rec, 0.0, SEPARATED, False, 0

    # -- split of the elastic trial segment at the elastic -> plastic switch (.switch): the
    # first minimum of r along it (a reversal through zero, a near-reversal, a turn)
    split = None
    f_s = None
    rho_s = 0.0
    mu_st, r_st, b_st, d_st = mu_c, r_c, b, None
    fn0 = f0[nt] if f0 is not None else 0.0
    if f0 is not None and fn0 > 0.0:
        f_s = [f0[i] for i in range(nt)]
        split = split_point(L, f_s, fn0, ft, fn, A, mu_c, b)
        if split is not None:
            s = split[0]
            f_s = [f_s[i] + s * (ft[i] - f_s[i]) for i in range(nt)]
            fn_m = fn0 + s * (fn - fn0)
            g_s = g_of(L, fn_m)
            bs = b * s
            mu_st = min(mu_c + (mu_s - mu_c) * -_expm1(-bs), mu_s)
            d_st = (mu_c - mu_s) * _exp(-bs)  # mu_st - mu_s without cancellation
            rho_s = abs(f_s[0]) if nt == 1 else _hypot(f_s[0], f_s[1])
            if split[1] == ROOT:  # r scaled by r_el(s) / r_el(0): continuous as s -> 0
                rho0 = abs(f0[0]) if nt == 1 else _hypot(f0[0], f0[1])
                q = (rho_s / rho0) * (g_of(L, fn0) / g_s) * (mu_c / mu_st)
                r_st = min(r_c * q, 1.0)
            else:  # through zero: r from the traction there (0 to rounding)
                gm = g_s * mu_st
                r_st = (rho_s / gm if rho_s < gm else 1.0) if gm > 0.0 else float(rho_s > 0)
            b_st = b - bs
            if split[1] == ROOT and unstable_start(L, g, r_st, mu_st, b_st, d_st):
                # the plastic part would start where phi rises (softening faster than elastic
                # unloading): no continuous branch from the switch; the whole step's loading
                # test decides, as without the split
                split, f_s = None, [f0[i] for i in range(nt)]
                mu_st, r_st, b_st, d_st = mu_c, r_c, b, None
                rho_s = abs(f_s[0]) if nt == 1 else _hypot(f_s[0], f_s[1])
        else:
            rho_s = abs(f_s[0]) if nt == 1 else _hypot(f_s[0], f_s[1])

    # -- loading test (exact trial if elastic)
    mu_rec_st = min(mu_st + (mu_s - mu_st) * -_expm1(-b_st), mu_s) if split else mu_rec
    # plastic only when the trial leaves the loading surface by more than its rounding, tol g mu
    # (``..tolerances``: a round-off trial from r = 0 is elastic)
    if not (A > 0.0 and A - g * r_st * mu_rec_st > tol * g * mu_rec_st):
        tan = [[(at if i == j and i < nt else 0.0) for j in range(m)] for i in range(m)]
        tan[nt][nt] = an
        gm = g * mu_rec
        r_el = 0.0 if A == 0.0 else (A / gm if A < gm else 1.0)
        return [*ft, fn], tan, list(up), mu_rec, r_el, ELASTIC, False, 0

    if not _isfinite(A):
        return [0.0] * m, zero_t, list(up), mu_c, r_c, FAILED, False, 0
    tol_f = max(tol * g * mu_s, 8.0 * EPS * A)
    br = Br(L, A, g, r_st, mu_st, b_st, d_st)
    dl, e, conv, iters, jump = certified_root(br, tol_f, max_iter)
    if not conv:
        return [0.0] * m, zero_t, list(up), mu_c, r_c, FAILED, False, iters
    tstar = [ft[i] / A for i in range(nt)]

    # rotation path whenever there is a start traction (nt = 2) and the trial segment does not
    # shrink |f_t| all through the step (theta_0 <= 90 degrees: always after a split). At
    # theta_0 = 0 it gives the radial result, but its derivative across the trial is the
    # rotation's (a threshold on theta_0 would leave main's tangent where the map behaves like
    # the rotation). A step that unloads |f_t| throughout and is plastic only because g(f_n)
    # dropped keeps main's radial return.
    # Outside 1e-100 .. 1e100 MPa (and for g < 1e-100) the rotation's squares and ratios could
    # leave the float range: main's radial return there (no physical scale is that far out).
    rotate = False
    if nt == 2 and f_s is not None and rho_s > tol_f and g > ROT_LO:
        ws0, ws1 = ft[0] - f_s[0], ft[1] - f_s[1]
        W = _hypot(ws0, ws1)
        rotate = (
            ROT_LO < min(rho_s, W)
            and max(rho_s, W, A) < ROT_HI
            and g_of(L, f0[nt]) > ROT_LO
            and (split or ws0 * f_s[0] + ws1 * f_s[1] >= 0.0)
        )
    if not rotate and not split:
        # fixed direction from a fixed start: closed-form tangent of main
        _, r, U, mu, dmu = e[:5]
        H = at + g * (U * mu + r * dmu)
        H = H if _isfinite(H) else at
        H = max(H, 1e-12 * at)
        rho1 = min(g * r * mu, A)
        dg = L.cn * (1.0 - g)
        tan = [[0.0] * m for _ in range(m)]
        fa = rho1 / A
        c1 = 1.0 - at / H
        for i in range(nt):
            for j in range(nt):
                nn = tstar[i] * tstar[j]
                tan[i][j] = at * (c1 * nn + fa * ((1.0 if i == j else 0.0) - nn))
            tan[i][nt] = at * an * dg * r * mu / H * tstar[i]
        tan[nt][nt] = an
        up1 = [up[i] + dl * tstar[i] for i in range(nt)]
        return finish(L, [rho1 * t for t in tstar] + [fn], tan, up1, e, g, jump, iters)
    return general(
        L,
        gap,
        up,
        ft,
        A,
        tstar,
        fn,
        g,
        f0,
        split,
        b,
        mu_c,
        tol_f,
        max_iter,
        br,
        dl,
        e,
        iters,
        jump,
        rotate,
    )
