"""Rotation of the flow direction over a step, for one point (plain floats).

Plastic flow is radial, so only the elastic increment ``w = f* - f_s`` turns the traction: its
angle ``theta`` to ``w`` obeys ``tan(theta / 2) = tan(theta_0 / 2) exp(-|w| J(s))``,
``J(s) = int_0^s dy / rho(y)``, ``rho = |f_t|``, exactly; the end magnitude is
``|f_1| = |f_s| + |w| C - alpha_t dl`` with ``C = int_0^1 cos(theta) ds``. :func:`rotation`
computes ``C`` and ``T_1 = tan(theta_1 / 2)`` with their partials for a model of ``rho(s)``; the
package's is ``subfric_dolfinx/constitutive/_subloading/rotation.py``.
"""

from __future__ import annotations

import math

from .common import GWI, GWO, GXI, GXO, HERMITE_MIN

__all__ = ["el", "rotation"]

_sqrt, _log1p, _exp = math.sqrt, math.log1p, math.exp

# inner nodes per outer node: (x_i, outer weight (0: the end point x = 1), ((w_j, y, y^2)))
_QUAD2 = tuple(
    (xi, wi, tuple((wj, xi * xj, (xi * xj) ** 2) for xj, wj in zip(GXI, GWI, strict=True)))
    for xi, wi in zip((*GXO, 1.0), (*GWO, 0.0), strict=True)
)


def el(rho_s, P, W, y):
    """Elastic path ``rho_el(y) = |f_s + y w|`` and ``J_el(y) = int_0^y dy'/rho_el``.

    Closed forms, with their partials in ``(rho_s, P, W)``: ``rho, (r_s, r_P, r_W), J, (J_s,
    J_P, J_W), D / N``.

    ``J_el = ln(N / D) / W``, ``N = W rho_el + W^2 y + P``, ``D = W rho_s + P > 0`` (theta_0
    <= 90 degrees); ``N - D`` is formed without cancellation.
    """
    rel = _sqrt(rho_s * rho_s + 2.0 * y * P + y * y * W * W)
    dr = (rho_s / rel, y / rel, y * y * W / rel)
    D = W * rho_s + P
    ND = W * (2.0 * y * P + y * y * W * W) / (rel + rho_s) + W * W * y  # N - D
    N = D + ND
    J = _log1p(ND / D) / W
    J_s = (W * dr[0] / N - W / D) / W
    J_P = ((W * dr[1] + 1.0) / N - 1.0 / D) / W
    J_W = -J / W + ((rel + W * dr[2] + 2.0 * W * y) / N - rho_s / D) / W
    return rel, dr, J, (J_s, J_P, J_W), D / N


def rotation(rho_s, d0, rho1, P, W, A, tau0):
    """Rotation of the flow direction over a step: ``C = int_0^1 cos(theta) ds``, ``T_1``.

    ``tan(theta(s) / 2) = tau0 exp(-W J(s))``, ``J(s) = int_0^s dy / rho(y)``, with the model
    ``rho = rho_H + beta e_el``: ``rho_H`` the quadratic through ``rho_s``, slope ``d0`` and
    ``rho1``; ``e_el`` the error of the same interpolation of the elastic path
    ``rho_el(y) = |f_s + y w| = sqrt(rho_s^2 + 2 y P + y^2 W^2)`` (slope ``P / rho_s``, end
    ``A``); ``beta = (rho1 - rho_s) / (A - rho_s)`` clipped to [0, 1]: exact for a constant
    ``|f|`` (beta = 0, Coulomb-like) and for an elastic step (beta = 1). Linear in ``y`` if the
    model dips below half its end values at a node.

    The elastic path is subtracted: its integrals are closed forms (:func:`el`;
    ``int cos(theta_el) = (A - rho_s) / W``), and Gauss integrates only the differences, which
    stay smooth where the direction aligns within ``s ~ rho_s / W`` (a reversal through
    near-zero traction). Nodes:
    :mod:`.common` (3 outer Gauss points and x = 1, 2 inner points each).

    Returns ``C, T1, dC, dT1`` with ``dC``/``dT1`` the partials in
    ``(tau0, rho_s, d0, rho1, P, W, A)``.
    """
    den_b = A - rho_s
    braw = (rho1 - rho_s) / den_b if den_b > 0.0 else 1.0
    beta = 0.0 if braw < 0.0 else (1.0 if braw > 1.0 else braw)
    if 0.0 < braw < 1.0:
        b_1, b_s, b_A = 1.0 / den_b, (rho1 - A) / (den_b * den_b), -braw / den_b
    else:
        b_1 = b_s = b_A = 0.0
    Pr = P / rho_s
    Prr = Pr / rho_s
    nodes = []
    rs2, W2, P2 = rho_s * rho_s, W * W, 2.0 * P
    rmin = math.inf
    for _, _, inner in _QUAD2:
        for _, y, y2 in inner:
            rel = _sqrt(rs2 + P2 * y + y2 * W2)
            a1, a2 = 1.0 - y2, y - y2
            e = rel - rho_s * a1 - Pr * a2 - A * y2
            r_ = rho_s * a1 + d0 * a2 + rho1 * y2 + beta * e
            rmin = r_ if r_ < rmin else rmin
            nodes.append((r_, rel, e, y, y2, a1, a2))
    linear = not rmin >= HERMITE_MIN * min(rho_s, rho1)
    # C_el = (rho_el(1) - rho_s) / W
    rel1 = _sqrt(rs2 + P2 + W2)
    C = (P2 + W2) / (rel1 + rho_s) / W
    dC = [0.0, (rho_s / rel1 - 1.0) / W, 0.0, 0.0, 1.0 / (rel1 * W), 1.0 / rel1 - C / W, 0.0]
    if tau0 == 0.0:
        # start along the trial: T = 0 at every node, so C = C_el and only dT1/dtau0 =
        # exp(-W J(1)) is left (the same numbers as the general loop below, for less work)
        xi, _, inner = _QUAD2[-1]
        Je = el(rho_s, P, W, xi)[2]
        Jv = 0.0
        for (wj, y, _), (r_, rel, *_) in zip(inner, nodes[-len(inner) :], strict=True):
            if linear:
                r_ = rho_s + (rho1 - rho_s) * y
            Jv += wj * xi * (1.0 / r_ - 1.0 / rel)
        return C, 0.0, dC, [_exp(-W * (Jv + Je)), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    c_t = c_d = c_1 = c_A = 0.0
    c_s, c_P, c_W = dC[1], dC[4], dC[5]
    dT1 = None
    T1 = 0.0
    k = 0
    d1 = rho1 - rho_s
    for xi, wi, inner in _QUAD2:
        _, _, Je, (Je_s, Je_P, Je_W), q_el = el(rho_s, P, W, xi)
        Jv = 0.0
        p0, p1, p2, p3, p4, p5 = Je_s, 0.0, 0.0, Je_P, Je_W, 0.0  # rho_s, d0, rho1, P, W, A
        for wj, _, _ in inner:
            r_, rel, e, y, y2, a1, a2 = nodes[k]
            k += 1
            ir = 1.0 / rel
            g0, g3, g4 = rho_s * ir, y * ir, y2 * W * ir  # d rho_el / d(rho_s, P, W)
            if linear:
                r_ = rho_s + d1 * y
                dr0, dr1, dr2, dr3, dr4, dr5 = 1.0 - y, 0.0, y, 0.0, 0.0, 0.0
            else:
                dr0 = a1 + beta * (g0 - a1 + Prr * a2) + e * b_s
                dr1 = a2
                dr2 = y2 + e * b_1
                dr3 = beta * (g3 - a2 / rho_s)
                dr4 = beta * g4
                dr5 = -beta * y2 + e * b_A
            wx = wj * xi
            iv = 1.0 / r_
            Jv += wx * (iv - ir)
            iv2 = wx * iv * iv
            ie2 = wx * ir * ir
            p0 += ie2 * g0 - iv2 * dr0
            p1 -= iv2 * dr1
            p2 -= iv2 * dr2
            p3 += ie2 * g3 - iv2 * dr3
            p4 += ie2 * g4 - iv2 * dr4
            p5 -= iv2 * dr5
        Jv += Je
        ex = _exp(-W * Jv)
        T = tau0 * ex
        TW = T * W
        # dT: tau0 -> ex; W -> -T (J + W pW); others -> -T W p
        if wi:
            # + w_i (cos theta - cos theta_el) at x_i; T_el = tau0 D / N
            Te = tau0 * q_el
            den2 = 1.0 + T * T
            de2 = 1.0 + Te * Te
            C += wi * ((1.0 - T * T) / den2 - (1.0 - Te * Te) / de2)
            cw = -4.0 * T / (den2 * den2) * wi
            ce = -4.0 * Te / (de2 * de2) * wi
            cwT = cw * TW
            ceT = ce * Te * W  # dT_el = q_el dtau0 - T_el (W dJ_el + J_el dW)
            c_t += cw * ex - ce * q_el
            c_s += -cwT * p0 + ceT * Je_s
            c_d -= cwT * p1
            c_1 -= cwT * p2
            c_P += -cwT * p3 + ceT * Je_P
            c_W += cw * (-T * Jv - TW * p4) - ce * (-Te * Je - Te * W * Je_W)
            c_A -= cwT * p5
        else:
            T1 = T
            dT1 = [ex, -TW * p0, -TW * p1, -TW * p2, -TW * p3, -T * Jv - TW * p4, -TW * p5]
    return C, T1, [c_t, c_s, c_d, c_1, c_P, c_W, c_A], dT1
