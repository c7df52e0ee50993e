"""Step 5: rotation of the flow direction over the step, and the corrector.

In 3-D contact with a start traction, where ``|f_t|`` does not shrink all through the step
(:func:`rotates`), plastic flow is radial, so only the elastic increment ``w = f* - f_s`` turns
the traction: its angle ``theta`` to ``w`` obeys ``tan(theta / 2) = tan(theta_0 / 2)
exp(-|w| J(s))``, ``J(s) = int_0^s dy / |f_t|(y)``, exactly, and
``|f_1| = |f_s| + |w| C - alpha_t dl``, ``C = int_0^1 cos(theta) ds``. ``|f_t|(s)`` is modelled by
the quadratic through ``|f_s|``, its rate-form slope and the predictor's end value, blended with
the elastic path (:func:`quadrature`). The **corrector** solves ``phi`` again with
``A_eff = |f_s| + |w| C`` from the predictor's root and puts the traction along the rotated
direction (:func:`rotate`, with its forward derivatives for the tangent). ``docs/model.md``
§6.5.
"""

from __future__ import annotations

import numpy as np

from .branch import g_of
from .common import EPS, GWI, GWO, GXI, GXO, HERMITE_MIN, NI, NO, ROT_HI, ROT_LO, Law, dot, norm_t
from .root import smallest_root
from .switch import ROOT
from .tangent import StartDerivatives, root_derivative

__all__ = ["quadrature", "rotate", "rotates"]

_PI = np.pi


def _quad_matrices():
    """``(3, (NO + 1) NI)`` matrix: rho_H at the inner nodes from (rho_s, d0, rho1).

    Nodes: outer x_i (NO Gauss points and x = 1), inner y = x_i xi_j (NI Gauss points).
    """
    X = np.append(GXO, 1.0)
    Y = (X[:, None] * GXI[None, :]).ravel()
    Y2 = Y * Y
    return np.stack([1.0 - Y2, Y - Y2, Y2])


_QB = _quad_matrices()
_QY = np.outer(np.append(GXO, 1.0), GXI).ravel()  # the inner nodes y
_QY2 = _QY * _QY


def _el(rho_s, P, W, y):
    """Elastic path ``rho_el(y) = |f_s + y w|`` and ``J_el(y) = int_0^y dy' / rho_el``.

    At nodes ``y`` (row vector): ``rho, (r_s, r_P, r_W), J, (J_s, J_P, J_W), D / N``, arrays
    (k, len(y)), with the partials in ``(rho_s, P, W)``.

    ``J_el = ln(N / D) / W``, ``N = W rho_el + W^2 y + P``, ``D = W rho_s + P > 0`` (theta_0
    <= 90 degrees); ``N - D`` is formed without cancellation.
    """
    rs, Pc, Wc = rho_s[:, None], P[:, None], W[:, None]
    rel = np.sqrt(rs * rs + (2.0 * Pc) * y + (Wc * Wc) * (y * y))
    dr = (rs / rel, y / rel, (y * y) * Wc / rel)
    D = Wc * rs + Pc
    ND = Wc * ((2.0 * Pc) * y + (Wc * Wc) * (y * y)) / (rel + rs) + (Wc * Wc) * y
    N = D + ND
    J = np.log1p(ND / D) / Wc
    J_s = (Wc * dr[0] / N - Wc / D) / Wc
    J_P = ((Wc * dr[1] + 1.0) / N - 1.0 / D) / Wc
    J_W = -J / Wc + ((rel + Wc * dr[2] + 2.0 * Wc * y) / N - rs / D) / Wc
    return rel, dr, J, (J_s, J_P, J_W), D / N


_QX = np.append(GXO, 1.0)  # outer nodes (and x = 1)
_QWX = np.outer(_QX, GWI).ravel()  # x_i w_j at the inner nodes
_QYX = np.concatenate([_QY, _QX])  # the elastic path at the inner and at the outer nodes
_NY = _QY.size


def _sum_inner(x):
    """Sums of the inner nodes of each outer node: (k, (NO + 1) NI) -> (k, NO + 1).

    (Sums and einsum rather than matrix products throughout: BLAS rounds differently for
    different numbers of rows, and the map's numbers must not depend on the batch size.)
    """
    return x.reshape(x.shape[0], NO + 1, NI).sum(axis=2)


def quadrature(rho_s, d0, rho1, P, W, A, tau0):
    """Rotation of the flow direction over a step: ``C = int_0^1 cos(theta) ds`` and ``T_1``.

    ``tan(theta(s) / 2) = tau0 exp(-W J(s))``, ``J(s) = int_0^s dy / rho(y)``, with the model
    ``rho = rho_H + beta e_el``: ``rho_H`` the quadratic through ``rho_s``, slope ``d0`` and
    ``rho1``; ``e_el`` the error of the same interpolation of the elastic path
    ``rho_el(y) = |f_s + y w| = sqrt(rho_s^2 + 2 y P + y^2 W^2)`` (slope ``P / rho_s``, end
    ``A``); ``beta = (rho1 - rho_s) / (A - rho_s)`` clipped to [0, 1]: exact for a constant
    ``|f|`` (beta = 0, Coulomb-like) and for an elastic step (beta = 1). Linear in ``y`` where
    the model dips below ``HERMITE_MIN`` of its end values at a node.

    The elastic path is subtracted: its integrals are closed forms (:func:`_el`;
    ``int cos(theta_el) = (A - rho_s) / W``), and Gauss integrates only the differences, which
    stay smooth where the direction aligns within ``s ~ rho_s / W`` (a reversal through
    near-zero traction). The quadratures are matrix products with constant node matrices.

    Returns ``C, T1, dC, dT1``, the partials lists of arrays in
    ``(tau0, rho_s, d0, rho1, P, W, A)``.
    """
    Y, Y2 = _QY, _QY2
    den_b = A - rho_s
    braw = np.where(den_b > 0.0, (rho1 - rho_s) / np.where(den_b > 0.0, den_b, 1.0), 1.0)
    beta = np.minimum(np.maximum(braw, 0.0), 1.0)
    inside = (braw > 0.0) & (braw < 1.0)
    db_ = np.where(inside, den_b, np.inf)
    b_1, b_s, b_A = 1.0 / db_, (rho1 - A) / (db_ * db_), -braw / db_
    Pr = P / rho_s
    rel_a, drel_a, Je_a, dJe_a, q_a = _el(rho_s, P, W, _QYX)
    rel, drel = rel_a[:, :_NY], [d[:, :_NY] for d in drel_a]  # inner nodes
    Je, dJe, q_el = Je_a[:, _NY:], [d[:, _NY:] for d in dJe_a], q_a[:, _NY:]  # outer (k, NO + 1)
    rhoH = np.einsum("ki,ij->kj", np.stack([rho_s, d0, rho1], axis=1), _QB)
    e = rel - rhoH + (d0 - Pr)[:, None] * (Y - Y2) + (rho1 - A)[:, None] * Y2
    bc = beta[:, None]
    rho = rhoH + bc * e
    dr = [
        (1.0 - Y2)
        + bc * (drel[0] - 1.0 + Y2 + (Pr / rho_s)[:, None] * (Y - Y2))
        + e * b_s[:, None],
        Y - Y2,
        Y2 + e * b_1[:, None],
        bc * (drel[1] - (Y - Y2) / rho_s[:, None]),
        bc * drel[2],
        -bc * Y2 + e * b_A[:, None],
    ]
    lin = ~(rho.min(axis=1) >= HERMITE_MIN * np.minimum(rho_s, rho1))
    if np.count_nonzero(lin):
        lc = lin[:, None]
        rho = np.where(lc, rho_s[:, None] + (rho1 - rho_s)[:, None] * Y, rho)
        dr = [np.where(lc, 1.0 - Y, dr[0]), np.where(lc, 0.0, dr[1]), np.where(lc, Y, dr[2])] + [
            np.where(lc, 0.0, d) for d in dr[3:]
        ]
    # J(x_i) = J_el(x_i) + x_i sum_j w_j (1/rho - 1/rho_el)
    inv, ie = 1.0 / rho, 1.0 / rel
    Jx = Je + _sum_inner((inv - ie) * _QWX)
    iv2 = inv * inv * _QWX
    ie2 = ie * ie * _QWX
    pJ = [
        dJe[0] + _sum_inner(ie2 * drel[0] - iv2 * dr[0]),
        -_sum_inner(iv2 * dr[1]),
        -_sum_inner(iv2 * dr[2]),
        dJe[1] + _sum_inner(ie2 * drel[1] - iv2 * dr[3]),
        dJe[2] + _sum_inner(ie2 * drel[2] - iv2 * dr[4]),
        -_sum_inner(iv2 * dr[5]),
    ]
    Wc = W[:, None]
    ex = np.exp(-Wc * Jx)
    T = tau0[:, None] * ex
    TW = T * Wc
    dT = [ex, -TW * pJ[0], -TW * pJ[1], -TW * pJ[2], -TW * pJ[3], -T * Jx - TW * pJ[4], -TW * pJ[5]]
    T4 = T[:, :NO]
    Te = tau0[:, None] * q_el[:, :NO]
    den2 = 1.0 + T4 * T4
    de2 = 1.0 + Te * Te
    rel1, drel1 = rel_a[:, -1], [d[:, -1] for d in drel_a]  # C_el = (rho_el(1) - rho_s) / W
    C0 = (2.0 * P + W * W) / (rel1 + rho_s) / W
    C = C0 + np.einsum("ki,i->k", (1.0 - T4 * T4) / den2 - (1.0 - Te * Te) / de2, GWO)
    cw = -4.0 * T4 / (den2 * den2) * GWO
    ce = -4.0 * Te / (de2 * de2) * GWO
    TeW = Te * Wc
    Je4 = Je[:, :NO]
    dTe = [
        q_el[:, :NO],
        -TeW * dJe[0][:, :NO],
        None,
        None,
        -TeW * dJe[1][:, :NO],
        -Te * Je4 - TeW * dJe[2][:, :NO],
        None,
    ]
    dC0 = {1: (drel1[0] - 1.0) / W, 4: drel1[1] / W, 5: drel1[2] / W - C0 / W}
    dT = np.stack(dT)  # (7, k, NO + 1)
    dC = np.einsum("ki,qki->qk", cw, dT[:, :, :NO])
    e = (0, 1, 4, 5)  # the partials of T_el
    dC[e, :] -= np.einsum("ki,qki->qk", ce, np.stack([dTe[q] for q in e]))
    for q, v in dC0.items():
        dC[q] += v
    return C, T[:, NO], dC, dT[:, :, NO]


def rotates(L: Law, pl) -> np.ndarray:
    """Which plastic points ``pl`` (a ``Plastic``) take the rotation.

    3-D contact, a start traction in contact, a converged predictor, ``|f_t|`` not shrinking
    all through the step (always after a split; also at ``theta_0 = 0``, where the stiffness
    across the trial differs from the radial one), magnitudes within ``ROT_LO .. ROT_HI`` (else
    the radial return).
    """
    k, nt = pl.ft.shape
    if nt != 2 or pl.f_s is None:
        return np.zeros(k, dtype=bool)
    fs = pl.f_s
    ws = pl.ft - fs
    W = norm_t(ws)
    rs = pl.rho_s
    rot = pl.root.conv & (rs > pl.tol) & (W > 0.0) & (pl.fn0 > 0.0)
    rot &= (pl.kind > 0) | (dot(ws, fs) >= 0.0)  # not where |f_t| shrinks all through
    rot &= (np.minimum(rs, W) > ROT_LO) & (np.maximum(np.maximum(rs, W), pl.A) < ROT_HI)
    rot &= (pl.g > ROT_LO) & (g_of(L, pl.fn0) > ROT_LO)
    return rot


def rotate(L: Law, pl, sd: StartDerivatives | None, ddl0, max_iter: int):
    """The rotation and the corrector of plastic points ``pl`` (nt = 2), with the tangent.

    ``sd``: the start state's derivatives (None: no split among them, all zero); ``ddl0``: the
    predictor root's derivative. Returns the traction (k, 3), the tangent (k, 3, 3) and the
    corrector's :class:`.root.Root`.
    """
    at, an = L.at, L.an
    k = pl.A.size
    br, e0, dl0 = pl.br, pl.root.e, pl.root.dl
    ft, A, g, fn = pl.ft, pl.A, pl.g, pl.fn
    f_s, rho_s, r0 = pl.f_s, pl.rho_s, br.r0
    dA = np.zeros((k, 3))
    dA[:, :2] = at * pl.t
    ws = ft - f_s
    W = norm_t(ws)
    ew = ws / W[:, None]
    dW = np.zeros((k, 3))
    dphi_w = np.zeros((k, 3))  # the direction of w
    dW[:, :2] = at * ew
    dphi_w[:, 0] = -at * ws[:, 1] / (W * W)
    dphi_w[:, 1] = at * ws[:, 0] / (W * W)
    if sd is not None:
        df_s = sd.df_s
        dW -= np.einsum("ki,kij->kj", ew, df_s)
        dphi_w -= (ws[:, 0, None] * df_s[:, 1] - ws[:, 1, None] * df_s[:, 0]) / (W * W)[:, None]
        cr = f_s[:, 0, None] * df_s[:, 1] - f_s[:, 1, None] * df_s[:, 0]
        dth0 = cr / (rho_s * rho_s)[:, None] - dphi_w
    else:
        dth0 = -dphi_w
    Wr = W * rho_s
    cth0 = dot(ws, f_s) / Wr
    sth0 = (ws[:, 0] * f_s[:, 1] - ws[:, 1] * f_s[:, 0]) / Wr
    tau0 = sth0 / (1.0 + cth0)  # tan(theta_0 / 2)
    ddirect = dW * cth0[:, None] - (W * sth0)[:, None] * dth0
    # slope of |f_t| at the start: the elastic one, or from the rate form (lam = num / den)
    d0, dd0 = _start_slope(L, pl, sd, W * cth0, ddirect)
    rho1p = A - at * dl0
    drho1p = dA - at * ddl0
    P = dot(ws, f_s)
    dP = np.zeros((k, 3))
    dP[:, :2] = at * f_s
    if sd is not None:
        dP += np.einsum("ki,kij->kj", ws - f_s, sd.df_s)
    C, T1, cC, cT = quadrature(rho_s, d0, rho1p, P, W, A, tau0)
    cth1 = (1.0 - T1 * T1) / (1.0 + T1 * T1)
    sth1 = 2.0 * T1 / (1.0 + T1 * T1)
    h1 = 2.0 / (1.0 + T1 * T1)
    dtf = 0.5 * (1.0 + tau0 * tau0)  # dtau0 = dtf dth0
    bases = (dth0, None if sd is None else sd.drho_s, dd0, drho1p, dP, dW, dA)
    cC[0] = cC[0] * dtf
    cT[0] = cT[0] * dtf
    dC = sum(c[:, None] * bv for c, bv in zip(cC, bases, strict=True) if bv is not None)
    dth1 = h1[:, None] * sum(
        c[:, None] * bv for c, bv in zip(cT, bases, strict=True) if bv is not None
    )
    # the corrector: phi again with A_eff (the predictor's where the rotated trial is inside)
    Aeff = rho_s + W * C
    dAeff = dW * C[:, None] + W[:, None] * dC
    if sd is not None:
        dAeff += sd.drho_s
    br2 = br.with_A(Aeff)
    keep = ~(Aeff - g * r0 * br2.mu_rec > 0.0)
    if np.count_nonzero(keep):
        Aeff = np.where(keep, A, Aeff)
        dAeff = np.where(keep[:, None], dA, dAeff)
        br2.A[:] = Aeff
    e_st = e0.take(slice(None))
    e_st.phi = e_st.phi + (Aeff - A)
    root = smallest_root(br2, np.maximum(pl.tol, 8.0 * EPS * Aeff), max_iter, dl0, e_st)
    e = root.e
    rho1 = np.minimum(g * e.r * e.mu, Aeff)
    drho1 = dAeff - at * root_derivative(L, br2, root, dAeff, sd)
    dph1 = dphi_w + dth1
    t1 = np.stack([cth1 * ew[:, 0] - sth1 * ew[:, 1], sth1 * ew[:, 0] + cth1 * ew[:, 1]], axis=1)
    D = np.zeros((k, 3, 3))
    D[:, 0, :] = t1[:, 0, None] * drho1 - (rho1 * t1[:, 1])[:, None] * dph1
    D[:, 1, :] = t1[:, 1, None] * drho1 + (rho1 * t1[:, 0])[:, None] * dph1
    D[:, 2, 2] = an
    tr = np.empty((k, 3))
    tr[:, :2] = rho1[:, None] * t1
    tr[:, 2] = fn
    return tr, D, root


def _start_slope(L: Law, pl, sd, d_el, dd_el):
    """The slope ``d0`` of ``|f_t|`` at the start of the rotated part and its derivative.

    The elastic one ``d_el = W cos(theta_0)``, or, where the start loads (``num > 0``, ``den > 0``;
    not at a ROOT split, where the start is the loading switch and ``num = 0`` by construction),
    ``d_el - alpha_t lam`` with the rate form's ``lam = num / den``.
    """
    at, cn, mu_k = L.at, L.cn, L.mu_k
    br = pl.br
    r0, mu0, b0, ms0 = br.r0, br.mu0, br.b, -br.d_s
    g_s, rho_s = pl.g_s, pl.rho_s
    rf = (br.sin0 > 0.0) & (g_s > 0.0)
    sin0_ = np.where(rf, br.sin0, 1.0)
    gs_ = np.where(rf, g_s, 1.0)
    U0 = L.ut * br.c0 / sin0_
    gp = cn * (1.0 - g_s)
    dfr = pl.fn - pl.fn_s
    num = d_el / gs_ - rho_s * gp * dfr / (gs_ * gs_) - b0 * ms0 * r0
    den = -L.kappa * (mu0 - mu_k) * r0 + U0 * mu0 + at / gs_
    on = rf & (num > 0.0) & (den > 0.0) & (pl.kind != ROOT)
    if not np.count_nonzero(on):
        return d_el, dd_el
    lam = np.where(on, num / np.where(on, den, 1.0), 0.0)
    gs2 = gs_ * gs_
    # d num, d den: the normal column carries dfr; the rest through the start's derivatives
    ddfr = np.zeros_like(dd_el) if sd is None else -sd.dfn_s
    ddfr[:, 2] += L.an
    dnum = dd_el / gs_[:, None] - (rho_s * gp / gs2)[:, None] * ddfr
    if sd is not None:
        c_g = -d_el / gs2 + rho_s * cn * dfr / gs2 + 2.0 * rho_s * gp * dfr / (gs2 * gs_)
        dnum += (
            c_g[:, None] * sd.dg_s
            - (gp * dfr / gs2)[:, None] * sd.drho_s
            - (ms0 * r0)[:, None] * sd.db
            + (b0 * r0)[:, None] * sd.dmu0
            - (b0 * ms0)[:, None] * sd.dr0
        )
        dU = -L.ut * 0.5 * _PI / (sin0_ * sin0_)
        dden = (
            (-L.kappa * (mu0 - mu_k) + dU * mu0)[:, None] * sd.dr0
            + (-L.kappa * r0 + U0)[:, None] * sd.dmu0
            - (at / gs2)[:, None] * sd.dg_s
        )
        dnum -= lam[:, None] * dden
    d0 = np.where(on, d_el - at * lam, d_el)
    dd0 = np.where(on[:, None], dd_el - at * dnum / np.where(on, den, 1.0)[:, None], dd_el)
    return d0, dd0
