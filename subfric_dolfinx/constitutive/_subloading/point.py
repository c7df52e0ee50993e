"""The return map's common one-point, 1-D cases on Python floats (a fast path, not a second law).

A call of the vectorised map costs some hundred microseconds for one point whatever the work
(each numpy operation has a fixed cost of about a microsecond, and a plastic step makes some
hundreds of them); a 1-DOF dynamic driver (:mod:`subfric_dolfinx.driver.slider`) needs 1e5
steps of a few calls each. :func:`point_step` runs the steps of :mod:`.integrate` for ONE point
with one tangential component, operation for operation as the vectorised modules write them
(:mod:`.trial`, :mod:`.switch`, :mod:`.branch`, :mod:`.root`, :mod:`.tangent`), on floats with
:mod:`math`, for the cases it covers:

* a contact point with valid inputs (finite, ``r`` and ``mu`` in range), not touching, with a
  saturation ``g(f_n)`` above ``ROT_LO`` and a time step 0 or above it (1e-100: no subnormal
  arithmetic);
* no split of the elastic trial (no start traction; or a start traction whose segment gives no
  cusp and no root of ``h``: ``h(0) >= 0``, or ``h(0) < 0`` and ``h(1) <= 0``, see
  :mod:`.switch`);
* elastic, or plastic with the predictor's root converged and certified smallest by the slope
  bound (no branch-and-bound scan, no fold).

Everything else (separation, touching, failed inputs, a reversal or a slow reload splitting the
step, an uncertified root, a fold) returns ``None``: the caller runs the vectorised map, the one
implementation of those paths. ``tests/constitutive/test_point_map.py`` checks that every point
of the fuzz batches and of the material-point stability cases that this path answers gets the
vectorised map's result to round-off.
"""

from __future__ import annotations

import math

from .common import ELASTIC, EPS, PLASTIC, ROT_HI, ROT_LO, S_SERIES, SPLIT_EPS, TINY, Law, Settings

__all__ = ["PointResult", "point_step"]

_4PI = 4.0 / math.pi
_INF = math.inf

PointResult = tuple[float, float, float, float, float, float, float, int, bool, int]
"""``(f_t, f_n, D_tt, D_tn, up, mu, r, status, unstable, iterations)`` of one 1-D point; the
tangent's normal row is ``(0, alpha_n)``."""


def _E_dE(s: float) -> tuple[float, float]:
    """:func:`.branch.E_dE` for one ``s >= 0``."""
    em = math.expm1(-s)
    if s < S_SERIES:
        dE = -0.5 + s * (1.0 / 3.0 - 0.125 * s)
        E = 1.0 if s == 0.0 else -em / s
    else:
        dE = (em * (1.0 + s) + s) / (s * s)
        E = -em / s
    return E, dE


def point_step(
    L: Law,
    gap: tuple[float, float],
    state: tuple[float, float, float, tuple[float, float] | None],
    dt: float,
    cfg: Settings,
) -> PointResult | None:
    """One step of one 1-D point.

    Args:
        L: The law's floats.
        gap: ``(ubar_t, ubar_n)`` at the end of the step.
        state: ``(up, mu, r, f0)`` at its start, ``f0`` the start traction ``(f_t, f_n)`` or
            None.
        dt: The time increment.
        cfg: The consistency tolerance, iteration limit and contact band.

    Returns:
        The outputs (:data:`PointResult`), or ``None`` where the case is not covered (see the
        module docstring): then the vectorised map must be called.
    """
    ut, un = gap
    up, mu, r, f0 = state
    tol, max_iter, contact_tol = cfg.tol, cfg.max_iter, cfg.contact_tol
    # step 1: the trial (.trial.Trial)
    mu_k, mu_s, at, an = L.mu_k, L.mu_s, L.at, L.an
    if not (
        math.isfinite(ut)
        and math.isfinite(un)
        and math.isfinite(up)
        and -1e-9 <= r <= 1.0 + 1e-9
        and mu_k * (1 - 1e-12) <= mu <= mu_s * (1 + 1e-12)
    ):
        return None
    if f0 is not None and not (math.isfinite(f0[0]) and math.isfinite(f0[1])):
        return None
    mu_c = min(max(mu, mu_k), mu_s)
    r_c = min(max(r, 0.0), 1.0)
    ft = at * (ut - up)
    A = abs(ft)
    fn = an * un
    g = -math.expm1(-L.cn * max(fn, 0.0))
    if contact_tol > 0.0:
        if abs(un) <= contact_tol * max(max(abs(ut), abs(up)), L.len_n):
            return None  # touching
    elif un == 0.0:
        return None
    if not (un > 0.0 and g > ROT_LO and math.isfinite(A)) or 0.0 < dt <= ROT_LO:
        return None  # (also an underflowing saturation or step: subnormal arithmetic not ported)
    b = L.xi * dt
    mu_rec = min(mu_c + (mu_s - mu_c) * (-math.expm1(-b)), mu_s)
    # step 2: no split (.switch.split_point), else the vectorised map
    if f0 is not None and f0[1] > 0.0:
        f0t, fn0 = f0
        w = ft - f0t
        ww = w * w
        fw = f0t * w
        rho0 = abs(f0t)
        W = math.sqrt(ww)
        if ww > 0.0 and rho0 > 0.0:
            if fw < 0.0:
                if ww + fw > SPLIT_EPS * W * (rho0 + A):
                    return None  # a cusp inside the step
            elif (
                ROT_LO < rho0 < ROT_HI
                and ROT_LO < W < ROT_HI
                and A < ROT_HI
                and b < ROT_HI
                and -math.expm1(-L.cn * fn0) > ROT_LO
                and g > ROT_LO
            ):
                dfn = fn - fn0
                g0 = -math.expm1(-L.cn * (fn0 + 0.0 * dfn))
                mu_e = min(mu_c + (mu_s - mu_c) * -math.expm1(-b * 0.0), mu_s)
                mr = (mu_s - mu_c) * math.exp(-b * 0.0) / mu_e
                h = fw / (f0t * f0t) - L.cn * (1.0 - g0) * dfn / g0 - b * mr
                if not h >= 0.0:  # r_el falls at the start: a split where h turns positive
                    fs = f0t + 1.0 * w
                    g1 = -math.expm1(-L.cn * (fn0 + 1.0 * dfn))
                    mu_e = min(mu_c + (mu_s - mu_c) * -math.expm1(-b * 1.0), mu_s)
                    mr = (mu_s - mu_c) * math.exp(-b * 1.0) / mu_e
                    q1 = fs * fs
                    h1 = (
                        (fs * w) / q1 - L.cn * (1.0 - g1) * dfn / g1 - b * mr
                        if q1 > 0
                        else math.nan
                    )
                    if not (h < 0.0 and not h1 > 0.0):
                        return None  # h turns positive inside the step: a split
    # step 3: the loading test (.integrate._chunk)
    gm = g * mu_rec
    if not (A > 0.0 and A - gm * r_c > tol * gm):
        r_el = 0.0 if A == 0.0 else (A / gm if A < gm else 1.0)
        return (ft, fn, at, 0.0, up, mu_rec, r_el, ELASTIC, False, 0)
    # the branch from the start state (.branch.Branch.start)
    kappa, k = L.kappa, L.k
    tol_f = max(tol * g * mu_s, 8.0 * EPS * A)
    r0, mu0, d_s = r_c, mu_c, mu_c - mu_s
    qq = 0.25 * math.pi * r0
    c0 = math.cos(2.0 * qq)
    hc0 = c0 * 0.5
    s0 = math.sin(qq) ** 2
    sin0 = 2.0 * math.sqrt(s0 * (1.0 - s0))
    d_k = mu0 - mu_k
    kdk = d_k * kappa
    bds = b * d_s
    Eb, dEb = _E_dE(b)
    mu_rb = min(max(mu0 - b * d_s * Eb, mu_k), mu_s)
    dmu0 = kappa * (-d_k * Eb - b * d_s * dEb)
    if s0 < 0.5:
        c = min(math.sqrt(-math.log1p(-2.0 * s0) / k), L.zc_cap)
    else:
        c = L.zc_cap

    def evaluate(dl: float) -> tuple[float, float, float, float, float, float]:
        # (.branch.evaluate): phi, r, mu, dmu, w, sn
        em = math.expm1(dl * -k)
        w_ = c0 * (1.0 + em)
        q = min(max(s0 - hc0 * em, 0.0), 1.0)
        r_ = math.asin(math.sqrt(q)) * _4PI
        sn_ = math.sqrt(q * (1.0 - q)) * 2.0
        E, dE = _E_dE(dl * kappa + b)
        D = dl * kdk + bds
        mu_ = min(max(mu0 - D * E, mu_k), mu_s)
        dmu_ = -(kdk * E + (kappa * D) * dE)
        phi_ = (A - at * dl) - g * r_ * mu_
        return phi_, r_, mu_, dmu_, w_, sn_

    # step 4: the predictor's root, Newton in z (.root._solve)
    c2a = c * (2.0 * at)
    dl_max = A / at
    hi = dl_max / (math.sqrt(c * c + dl_max) + c)
    z = 0.0
    phi = A - g * r0 * mu_rb
    rr, mm, dmu, ww_, sn = r0, mu_rb, dmu0, c0, sin0
    if phi > 0.0:
        lo, f_lo, hi_, f_hi = z, phi, hi, -_INF
    else:
        lo, f_lo, hi_, f_hi = 0.0, _INF, z, phi
    dz = hi_ - lo
    it = 0
    its = 0
    conv = abs(phi) <= tol_f
    halve = False
    ut2 = 2.0 * L.ut
    lim0 = ut2 * L.sqrt2k_inv
    tiny4 = 4.0 * EPS
    while not conv and it < max_iter:
        cz = c + z
        drdz = lim0 if sn == 0.0 else (ut2 * cz) * ww_ / sn
        gr = g * rr
        hp = g * mm * drdz + (2.0 * gr) * dmu * cz
        Bq = c2a + hp
        Q = A - gr * mm + hp * z
        disc = Bq * Bq + (4.0 * at) * Q
        sd = math.sqrt(max(disc, 0.0))
        if Bq > 0.0:
            zn = 2.0 * Q / (Bq + sd)
        else:
            zn = (sd - Bq) / (2.0 * at)
        bad = not (disc >= 0.0 and lo < zn < hi_)
        if halve and abs(zn - z) > 0.5 * abs(dz):
            bad = True
        if bad:
            zn = math.sqrt(max(lo, TINY)) * math.sqrt(hi_) if hi_ > 1e3 * lo else 0.5 * (lo + hi_)
        dz = zn - z
        z = zn
        phi, rr, mm, dmu, ww_, sn = evaluate(zn * (2.0 * c + zn))
        it += 1
        if phi > 0.0:
            lo, f_lo = zn, phi
        else:
            hi_, f_hi = zn, phi
        ok = abs(phi) <= tol_f
        flat = (f_lo - f_hi <= 2.0 * tol_f) or (hi_ - lo <= tiny4 * hi_)
        if not (ok or flat):
            halve = True
            continue
        its = it
        if flat and not ok:  # bracket exhausted: the end closer to phi = 0
            z = lo if f_lo < -f_hi else hi_
            phi, rr, mm, dmu, ww_, sn = evaluate(z * (2.0 * c + z))
            its = it + 1
        conv = True
    if not conv:
        return None  # FAILED: the vectorised map's bookkeeping
    if sn == 0.0:
        U = _INF if ww_ > 0.0 else math.nan
    else:
        U = L.ut * ww_ / sn
    dl = z * (2.0 * c + z)
    if not (at + g * U * mm - g * rr * abs(dmu0) > 0.0):
        return None  # not certified: the scan (and fold detection) of the vectorised map
    # step 6: traction and tangent along the fixed direction (.tangent.fixed_direction)
    t = ft / A
    rho1 = min(g * rr * mm, A)
    H = at + g * (U * mm + rr * dmu)
    H = max(H if math.isfinite(H) else at, 1e-12 * at)
    dA = at * t
    ddl_t = dA / H
    ddl_n = 0.0 - L.cn * (1.0 - g) * an * rr * mm / H
    D_tt = t * (dA - at * ddl_t)
    D_tn = t * (0.0 - at * ddl_n)
    unst = -kappa * (mm - mu_k) * rr + U * mm + at / g <= 0.0
    r_out = min(max(rr, 0.0), 1.0)
    return (rho1 * t, fn, D_tt, D_tn, up + dl * t, mm, r_out, PLASTIC, unst, its)
