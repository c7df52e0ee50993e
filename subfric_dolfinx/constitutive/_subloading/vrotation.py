"""Rotation of the flow direction over a step, batched (the twin of :mod:`.rotation`).

The quadratures are matrix products with constant node matrices; trig-free.
"""

from __future__ import annotations

import numpy as np

from .common import GWI_A, GWO_A, GXI_A, GXO_A, HERMITE_MIN, NI, NO

__all__ = ["rotation"]


def _quad_matrices():
    """``(3, (NO + 1) NI)`` matrix: rho_H at the inner nodes from (rho_s, d0, rho1).

    Nodes: outer x_i (NO Gauss points and x = 1), inner y = x_i xi_j (NI Gauss points).
    """
    X = np.append(GXO_A, 1.0)
    Y = (X[:, None] * GXI_A[None, :]).ravel()
    Y2 = Y * Y
    return np.stack([1.0 - Y2, Y - Y2, Y2])


_QB = _quad_matrices()
_QY = np.outer(np.append(GXO_A, 1.0), GXI_A).ravel()  # the inner nodes y
_QY2 = _QY * _QY


def _el(rho_s, P, W, y):
    """Vector :func:`.rotation.el` at nodes ``y`` (row vector): arrays (k, len(y))."""
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


_QX = np.append(GXO_A, 1.0)  # outer nodes (and x = 1)
_QWX = np.outer(_QX, GWI_A).ravel()  # x_i w_j at the inner nodes
_QS = np.zeros(((NO + 1) * NI, NO + 1))  # sums the inner nodes of each outer node
_QS[np.arange((NO + 1) * NI), np.repeat(np.arange(NO + 1), NI)] = 1.0


def rotation(rho_s, d0, rho1, P, W, A, tau0):
    """Vector version of :func:`.rotation.rotation`: ``C, T1, dC, dT1``.

    The partials are lists of arrays in ``(tau0, rho_s, d0, rho1, P, W, A)``.
    """
    Y, Y2 = _QY, _QY2
    den_b = A - rho_s
    braw = np.where(den_b > 0.0, (rho1 - rho_s) / np.where(den_b > 0.0, den_b, 1.0), 1.0)
    beta = np.clip(braw, 0.0, 1.0)
    inside = (braw > 0.0) & (braw < 1.0)
    db_ = np.where(inside, den_b, np.inf)
    b_1, b_s, b_A = 1.0 / db_, (rho1 - A) / (db_ * db_), -braw / db_
    Pr = P / rho_s
    rel, drel, _, _, _ = _el(rho_s, P, W, Y)
    rhoH = np.stack([rho_s, d0, rho1], axis=1) @ _QB
    e = rel - rhoH + (d0 - Pr)[:, None] * (Y - Y2) + (rho1 - A)[:, None] * Y2
    bc = beta[:, None]
    rho = rhoH + bc * e
    dr = [
        (1.0 - Y2) + bc * (drel[0] - 1.0 + Y2 + (Pr / rho_s)[:, None] * (Y - Y2))
        + e * b_s[:, None],
        Y - Y2,
        Y2 + e * b_1[:, None],
        bc * (drel[1] - (Y - Y2) / rho_s[:, None]),
        bc * drel[2],
        -bc * Y2 + e * b_A[:, None],
    ]
    lin = ~(rho.min(axis=1) >= HERMITE_MIN * np.minimum(rho_s, rho1))
    if lin.any():
        lc = lin[:, None]
        rho = np.where(lc, rho_s[:, None] + (rho1 - rho_s)[:, None] * Y, rho)
        dr = [np.where(lc, 1.0 - Y, dr[0]), np.where(lc, 0.0, dr[1]), np.where(lc, Y, dr[2])] + [
            np.where(lc, 0.0, d) for d in dr[3:]
        ]
    # J(x_i) = J_el(x_i) + x_i sum_j w_j (1/rho - 1/rho_el)
    _, _, Je, dJe, q_el = _el(rho_s, P, W, _QX)  # (k, NO + 1)
    S = _QS
    inv, ie = 1.0 / rho, 1.0 / rel
    Jx = Je + ((inv - ie) * _QWX) @ S
    iv2 = inv * inv * _QWX
    ie2 = ie * ie * _QWX
    pJ = [
        dJe[0] + (ie2 * drel[0] - iv2 * dr[0]) @ S,
        -(iv2 * dr[1]) @ S,
        -(iv2 * dr[2]) @ S,
        dJe[1] + (ie2 * drel[1] - iv2 * dr[3]) @ S,
        dJe[2] + (ie2 * drel[2] - iv2 * dr[4]) @ S,
        -(iv2 * dr[5]) @ S,
    ]
    Wc = W[:, None]
    ex = np.exp(-Wc * Jx)
    T = tau0[:, None] * ex
    TW = T * Wc
    dT = [ex, -TW * pJ[0], -TW * pJ[1], -TW * pJ[2], -TW * pJ[3], -T * Jx - TW * pJ[4],
          -TW * pJ[5]]  # fmt: skip
    T4 = T[:, :NO]
    Te = tau0[:, None] * q_el[:, :NO]
    den2 = 1.0 + T4 * T4
    de2 = 1.0 + Te * Te
    rel1, drel1, _, _, _ = _el(rho_s, P, W, np.ones(1))  # C_el = (rho_el(1) - rho_s) / W
    rel1, drel1 = rel1[:, 0], [d[:, 0] for d in drel1]
    C0 = (2.0 * P + W * W) / (rel1 + rho_s) / W
    C = C0 + ((1.0 - T4 * T4) / den2 - (1.0 - Te * Te) / de2) @ GWO_A
    cw = -4.0 * T4 / (den2 * den2) * GWO_A
    ce = -4.0 * Te / (de2 * de2) * GWO_A
    TeW = Te * Wc
    Je4 = Je[:, :NO]
    dTe = [q_el[:, :NO], -TeW * dJe[0][:, :NO], None, None, -TeW * dJe[1][:, :NO],
           -Te * Je4 - TeW * dJe[2][:, :NO], None]  # fmt: skip
    dC0 = [0.0, (drel1[0] - 1.0) / W, 0.0, 0.0, drel1[1] / W, drel1[2] / W - C0 / W, 0.0]
    dC = []
    for q in range(7):
        v = np.einsum("ki,ki->k", cw, dT[q][:, :NO])
        if dTe[q] is not None:
            v = v - np.einsum("ki,ki->k", ce, dTe[q])
        dC.append(v + dC0[q])
    dT1 = [d[:, NO] for d in dT]
    return C, T[:, NO], dC, dT1

