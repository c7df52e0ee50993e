"""Split and/or rotation of the flow direction for one point, with the exact tangent.

Forward derivatives over the gap components through the split, the predictor's root, the
rotation (:func:`.rotation.rotation`) and the corrector's root (plain floats; the package's
numpy map: ``subfric_dolfinx/constitutive/_subloading``).
"""

from __future__ import annotations

import math

from .common import EPS, FAILED
from .root import certified_root, dl_derivative, finish, g_of, partials
from .rotation import rotation
from .switch import ROOT, split_ds

__all__ = ["general"]

_sqrt, _hypot = math.sqrt, math.hypot
_PI = math.pi


def general(
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
    dl0,
    e0,
    iters,
    jump,
    rotate,
):
    """Split and/or rotated flow direction, with forward derivatives for the exact tangent."""
    nt = len(up)
    m = nt + 1
    at, an, cn = L.at, L.an, L.cn
    mu_k = L.mu_k
    J = range(m)
    Z = [0.0] * m
    dft = [[(at if j == i else 0.0) for j in J] for i in range(nt)]
    dfn1 = [(an if j == nt else 0.0) for j in J]
    dg1 = [cn * (1.0 - g) * v for v in dfn1]
    fn0 = f0[nt]
    # start state of the (rest of the) step and its derivatives
    f_s = [f0[i] for i in range(nt)]
    df_s = [Z[:] for _ in range(nt)]
    drho_s, dr0, dmu0, db = Z[:], Z[:], Z[:], Z[:]
    fn_s, dfn_s = fn0, Z[:]
    r0, mu0, b0 = br.r0, br.mu0, br.b
    if split:
        w = [ft[i] - f0[i] for i in range(nt)]
        s, kind = split
        ds = split_ds(L, f0[:nt], ft, fn0, fn, mu_c, b, s, kind)
        f_s = [f0[i] + s * w[i] for i in range(nt)]
        df_s = [[ds[j] * w[i] + s * dft[i][j] for j in J] for i in range(nt)]
        fn_s = fn0 + s * (fn - fn0)
        dfn_s = [ds[j] * (fn - fn0) + s * dfn1[j] for j in J]
        g_s = g_of(L, fn_s)
        dg_s = [cn * (1.0 - g_s) * v for v in dfn_s]
        dmu0 = [-br.d_s * b * v for v in ds]  # d_s = mu0 - mu_s without cancellation
        rho_s = abs(f_s[0]) if nt == 1 else _hypot(f_s[0], f_s[1])
        if rho_s > 0.0:
            drho_s = [sum(f_s[i] * df_s[i][j] for i in range(nt)) / rho_s for j in J]
        if rho_s > 0.0 and r0 < 1.0:  # (ROOT: r0 = r_n rho_s g_0 mu_n / (rho_0 g_s mu0))
            c_r = r0 / rho_s if kind == ROOT else 1.0 / (g_s * mu0)
            dr0 = [c_r * drho_s[j] - r0 * (dg_s[j] / g_s + dmu0[j] / mu0) for j in J]
        db = [-b * v for v in ds]
    else:
        rho_s = abs(f_s[0]) if nt == 1 else _hypot(f_s[0], f_s[1])
        g_s = g_of(L, fn_s)
        dg_s = Z[:]
    dA = [(at * tstar[j] if j < nt else 0.0) for j in J]
    H, R, Mmu, Mb = partials(br, dl0, e0)
    ddl0 = dl_derivative(br, e0, H, R, Mmu, Mb, dA, dg1, dr0, dmu0, db)
    if not rotate:
        _, r, _, mu = e0[:4]
        rho1 = min(g * r * mu, A)
        drho1 = [dA[j] - at * ddl0[j] for j in J]
        df1 = [
            [
                drho1[j] * tstar[i]
                + (rho1 * ((i == j) - tstar[i] * tstar[j]) * at / A if j < nt else 0.0)
                for j in J
            ]
            for i in range(nt)
        ]
        f1 = [rho1 * t for t in tstar]
        up1 = [up[i] + dl0 * tstar[i] for i in range(nt)]
        return finish(L, [*f1, fn], [*df1, dfn1], up1, e0, g, jump, iters)

    # -- rotation of the flow direction over the step (2-D tangential plane); derivatives
    # of the quadratures through scalar partials; split terms only after a split
    ws0, ws1 = ft[0] - f_s[0], ft[1] - f_s[1]
    W = _hypot(ws0, ws1)
    ew0, ew1 = ws0 / W, ws1 / W
    W2 = W * W
    dW = [at * ew0, at * ew1, 0.0]
    dphi_w = [-at * ws1 / W2, at * ws0 / W2, 0.0]
    if split:
        for j in J:
            dW[j] -= ew0 * df_s[0][j] + ew1 * df_s[1][j]
            dphi_w[j] -= (ws0 * df_s[1][j] - ws1 * df_s[0][j]) / W2
        rr = rho_s * rho_s
        dth0 = [(f_s[0] * df_s[1][j] - f_s[1] * df_s[0][j]) / rr - dphi_w[j] for j in J]
    else:
        dth0 = [-v for v in dphi_w]
    Wr = W * rho_s
    cth0 = (ws0 * f_s[0] + ws1 * f_s[1]) / Wr
    sth0 = (ws0 * f_s[1] - ws1 * f_s[0]) / Wr
    tau0 = sth0 / (1.0 + cth0)  # tan(theta_0 / 2)
    Ws = W * sth0
    ddirect = [dW[j] * cth0 - Ws * dth0[j] for j in J]
    # slope of |f_t| at the start from the rate form (lam = num / den when loading)
    d0 = W * cth0
    dd0 = ddirect
    sin_r0 = br.sin0
    if sin_r0 > 0.0 and g_s > 0.0:
        U0 = L.ut * br.c0 / sin_r0
        gp = cn * (1.0 - g_s)
        dfr = fn - fn_s
        gs2 = g_s * g_s
        num = W * cth0 / g_s - rho_s * gp * dfr / gs2 + b0 * br.d_s * r0
        den = -L.kappa * (mu0 - mu_k) * r0 + U0 * mu0 + at / g_s
        # at a ROOT split the start is the loading switch: num = 0 there by construction (its
        # computed value is rounding of cancelling terms), so the slope is the elastic one
        if num > 0.0 and den > 0.0 and not (split and split[1] == ROOT):
            lam = num / den
            d0 = W * cth0 - at * lam
            cr = rho_s * gp / gs2
            dnum = [ddirect[j] / g_s - cr * (dfn1[j] - dfn_s[j]) for j in J]
            if split:
                c_g = (-W * cth0 + rho_s * cn * dfr + 2.0 * rho_s * gp * dfr / g_s) / gs2
                c_rho = gp * dfr / gs2
                c_b, c_m, c_r = -br.d_s * r0, b0 * r0, -b0 * br.d_s
                e_r = -L.kappa * (mu0 - mu_k) - L.ut * 0.5 * _PI / (sin_r0 * sin_r0) * mu0
                e_m = -L.kappa * r0 + U0
                e_g = at / gs2
                for j in J:
                    dden = e_r * dr0[j] + e_m * dmu0[j] - e_g * dg_s[j]
                    dnum[j] += (
                        c_g * dg_s[j]
                        - c_rho * drho_s[j]
                        - c_b * db[j]
                        + c_m * dmu0[j]
                        - c_r * dr0[j]
                        - lam * dden
                    )
            f = at / den
            dd0 = [ddirect[j] - f * dnum[j] for j in J]
    rho1p = A - at * dl0
    drho1p = [dA[j] - at * ddl0[j] for j in J]
    # rotation over the step (model of |f_t| and quadratures: _rotation)
    P = ws0 * f_s[0] + ws1 * f_s[1]
    dP = [
        ws0 * df_s[0][j]
        + ws1 * df_s[1][j]
        + f_s[0] * (dft[0][j] - df_s[0][j])
        + f_s[1] * (dft[1][j] - df_s[1][j])
        for j in J
    ]
    C, T1, cC, cT = rotation(rho_s, d0, rho1p, P, W, A, tau0)
    dtf = 0.5 * (1.0 + tau0 * tau0)  # d tau0 / d theta0
    bases = ([dtf * v for v in dth0], drho_s, dd0, drho1p, dP, dW, dA)
    dC = [sum(c * bv[j] for c, bv in zip(cC, bases, strict=True)) for j in J]
    h1 = 2.0 / (1.0 + T1 * T1)
    dth1 = [h1 * sum(c * bv[j] for c, bv in zip(cT, bases, strict=True)) for j in J]
    cth1 = (1.0 - T1 * T1) / (1.0 + T1 * T1)
    sth1 = 2.0 * T1 / (1.0 + T1 * T1)
    Aeff = rho_s + W * C
    dAeff = [drho_s[j] + dW[j] * C + W * dC[j] for j in J]
    if Aeff - g * r0 * br.mu_rec > 0.0:
        br2 = br.with_A(Aeff)
    else:  # rotated trial inside: keep the predictor
        br2, Aeff, dAeff = br, A, dA
    e_st = (e0[0] + (Aeff - A), *e0[1:])
    dl, e, conv, it2, jump = certified_root(br2, max(tol_f, 8.0 * EPS * Aeff), max_iter, dl0, e_st)
    iters += it2
    if not conv:
        m_ = len(gap)
        zero = [[0.0] * m_ for _ in range(m_)]
        return [0.0] * m_, zero, list(up), mu_c, br.r0, FAILED, False, iters
    H, R, Mmu, Mb = partials(br2, dl, e)
    ddl = dl_derivative(br2, e, H, R, Mmu, Mb, dAeff, dg1, dr0, dmu0, db)
    _, r, _, mu = e[:4]
    rho1 = min(g * r * mu, Aeff)
    drho1 = [dAeff[j] - at * ddl[j] for j in J]
    dph1 = [dphi_w[j] + dth1[j] for j in J]
    t1 = [cth1 * ew0 - sth1 * ew1, sth1 * ew0 + cth1 * ew1]  # e_w turned by theta_1
    f1 = [rho1 * t1[0], rho1 * t1[1]]
    df1 = [
        [drho1[j] * t1[0] - rho1 * t1[1] * dph1[j] for j in J],
        [drho1[j] * t1[1] + rho1 * t1[0] * dph1[j] for j in J],
    ]
    up1 = [up[i] + (ft[i] - f1[i]) / at for i in range(2)]
    return finish(L, [*f1, fn], [*df1, dfn1], up1, e, g, jump, iters)
