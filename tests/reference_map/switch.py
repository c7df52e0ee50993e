"""Where a step switches from elastic to plastic: the split point of the elastic trial segment.

Along the elastic trial ``f(s) = f0 + s w`` (``w = f* - f0``), ``f_n(s) = f_n0 + s df_n``, with
``mu`` recovering (``mu_e(s)``), the normal-yield ratio of an elastic state is
``r_el(s) = |f(s)| / (g(f_n(s)) mu_e(s))``. In the subloading model ``r`` can only grow by plastic
flow: the step is elastic while ``r_el`` falls and plastic from its first minimum on. With

    ``h(s) = d ln r_el / ds = f(s).w / |f(s)|^2 - c_n (1 - g) df_n / g - b (mu_s - mu_e) / mu_e``

(``b = xi dt``; ``h(0) dt`` is the rate-form loading criterion ``num`` at the start with the
step's mean rates, up to a positive factor) the split point is:

* ``CUSP``: ``|f|`` passes through zero (an exact reversal, any 1-D one): ``s = -f0.w / |w|^2``,
  where ``r_el = 0``;
* ``ROOT``: the first root of ``h`` in ``(0, 1)`` where ``h`` turns from negative to positive: a
  2-D near-reversal (``|f|`` at a minimum, shifted by the recovery), a turn of the sliding
  direction (``|f|`` stationary while ``mu`` recovers: elastic first, plastic once the direction
  has turned enough), a reload slower than the recovery;
* none: ``h(0) >= 0`` (plastic from the start) or ``r_el`` still falling at the end (elastic, the
  loading test decides).

The split is taken only where the rest of the segment, ``(1 - s) |w|``, is resolved against the
rounding of ``f0 + s w``, and a ``ROOT`` split only where the plastic part starts on a stable
branch (:func:`unstable_start`): where ``phi`` rises at the switch (softening faster than the
elastic unloading, ``H(0) = alpha_t + g (U(r_s) mu + r_s mu'(0)) <= 0``) its smallest root lies
a finite slip away, so the traction would jump at the switch; the whole step's loading test
decides there, as without the split (the literal Sec. 7 set in FE needs it to converge).

The split point's derivative over the gap components, for the tangent: the classic
``ds = -(f0 + 2 s w).dw / |w|^2`` at a cusp, ``ds = -dh / h'(s)`` at a root.
"""

from __future__ import annotations

import math

from .common import EPS, ROT_HI, ROT_LO, S_SERIES, SPLIT_EPS, Law

__all__ = ["CUSP", "ROOT", "split_ds", "split_point", "unstable_start"]

CUSP, ROOT = 1, 2
CUSP_REL = 1e-8  # |f| at its minimum below this times (|f0| + |f*|): a cusp (r_el = 0 there)
_MAX_IT = 60
_expm1, _exp, _sqrt, _hypot = math.expm1, math.exp, math.sqrt, math.hypot
_sin, _cos, _PI = math.sin, math.cos, math.pi


def _h(L: Law, f0t, w, ww, fn0, dfn, mu_c, b, s):
    """``h(s)``, ``h'(s)`` and ``(f_s, q, N1, g_s, mu_e)`` (scalar)."""
    fs = [f0t[i] + s * w[i] for i in range(len(w))]
    q = sum(v * v for v in fs)
    N1 = sum(fs[i] * w[i] for i in range(len(w)))
    g = -_expm1(-L.cn * (fn0 + s * dfn))
    mu_e = min(mu_c + (L.mu_s - mu_c) * -_expm1(-b * s), L.mu_s)
    mr = (L.mu_s - mu_c) * _exp(-b * s) / mu_e  # (mu_s - mu_e) / mu_e without cancellation
    h = N1 / q - L.cn * (1.0 - g) * dfn / g - b * mr
    hp = (ww * q - 2.0 * N1 * N1) / (q * q)
    hp += L.cn * L.cn * (1.0 - g) * dfn * dfn / (g * g) + b * b * L.mu_s * mr / mu_e
    return h, hp, (fs, q, N1, g, mu_e)


def _newton(L, args, lo, hi, x, hx, hpx):
    """Safeguarded Newton for ``h = 0`` on ``[lo, hi]`` (``h(lo) < 0 < h(hi)``) from ``x``.

    Stops when ``h = 0``, when the Newton step falls below the rounding of ``x`` (before it is
    taken: a step that cannot move ``x`` would otherwise count as leaving the bracket and turn
    into some 50 bisections), when the last step was that small, or the bracket is exhausted.
    """
    dx_old = hi - lo
    for _ in range(_MAX_IT):
        if hpx > 0.0:
            step = hx / hpx
            if abs(step) <= 4.0 * EPS * x:  # converged: the Newton step is below rounding
                break
            xn = x - step
        else:
            xn = -1.0
        if not (lo < xn < hi) or abs(xn - x) > 0.5 * abs(dx_old):
            xn = 0.5 * (lo + hi)
        dx_old = xn - x
        x = xn
        hx, hpx, _ = _h(L, *args, x)
        if hx < 0.0:
            lo = x
        elif hx > 0.0:
            hi = x
        else:
            break
        if abs(dx_old) <= 4.0 * EPS * x or hi - lo <= 4.0 * EPS * hi:
            break
    return x


def split_point(L: Law, f0t, fn0, ft, fn, A, mu_c, b):
    """``(s, kind)`` of the split of a point's elastic trial segment, or ``None`` (scalar).

    ``f0t`` (nt,) and ``fn0 > 0``: the start traction; ``ft`` (nt,), ``fn > 0``, ``A = |ft|``:
    the trial; ``mu_c``: ``mu`` at the start; ``b = xi dt``.
    """
    nt = len(ft)
    w = [ft[i] - f0t[i] for i in range(nt)]
    fw = sum(f0t[i] * w[i] for i in range(nt))
    ww = sum(v * v for v in w)
    rho0 = abs(f0t[0]) if nt == 1 else _hypot(f0t[0], f0t[1])
    if not (ww > 0.0 and rho0 > 0.0):
        return None
    W = _sqrt(ww)
    dfn = fn - fn0
    ok_h = (
        ROT_LO < rho0 < ROT_HI
        and ROT_LO < W < ROT_HI
        and A < ROT_HI
        and b < ROT_HI
        and -_expm1(-L.cn * fn0) > ROT_LO
        and -_expm1(-L.cn * fn) > ROT_LO
    )
    args = (f0t, w, ww, fn0, dfn, mu_c, b)
    if fw < 0.0:
        # |f| falls at the start; its minimum inside the step, the rest resolved
        if not ww + fw > SPLIT_EPS * W * (rho0 + A):
            return None
        s_f = -fw / ww
        if not ok_h:
            return s_f, CUSP
        fm = [f0t[i] + s_f * w[i] for i in range(nt)]
        if (abs(fm[0]) if nt == 1 else _hypot(fm[0], fm[1])) <= CUSP_REL * (rho0 + A):
            return s_f, CUSP
        hm, hpm, _ = _h(L, *args, s_f)
        if hm < 0.0:
            if not _h(L, *args, 1.0)[0] > 0.0:
                return s_f, CUSP  # r_el falls to the end: elastic (the loading test says so)
            lo, hi = s_f, 1.0
        elif hm > 0.0:
            if not _h(L, *args, 0.0)[0] < 0.0:
                return None  # r grows from the start (g falls faster): plastic throughout
            lo, hi = 0.0, s_f
        else:
            return s_f, ROOT
        s = _newton(L, args, lo, hi, s_f, hm, hpm)
    else:
        if not ok_h:
            return None
        h0, hp0, _ = _h(L, *args, 0.0)
        if not h0 < 0.0 or not _h(L, *args, 1.0)[0] > 0.0:
            return None
        s = _newton(L, args, 0.0, 1.0, 0.0, h0, hp0)
    if not (1.0 - s) * W > SPLIT_EPS * (rho0 + A):
        return None
    return s, ROOT


def _E_dE(s):
    if s < S_SERIES:
        return (-_expm1(-s) / s if s > 0.0 else 1.0), -0.5 + s * (1.0 / 3.0 - 0.125 * s)
    em = _expm1(-s)
    return -em / s, (em * (1.0 + s) + s) / (s * s)


def unstable_start(L: Law, g, r0, mu0, b, d_s) -> bool:
    """Whether ``phi`` rises at the start of a plastic part from ``(r0, mu0)`` (scalar).

    ``H(0) = alpha_t + g (U(r0) mu_rec + r0 mu'(0)) <= 0`` with the closed forms of
    :class:`.root.Br` (``mu_rec`` after the recovery ``b``, ``d_s = mu0 - mu_s``).
    """
    if not r0 > 0.0:
        return False  # U(0) = inf
    qq = 0.25 * _PI * r0
    sq = _sin(qq)
    s0 = sq * sq
    sin0 = 2.0 * _sqrt(s0 * (1.0 - s0))
    if not sin0 > 0.0:
        return False
    U0 = L.ut * _cos(2.0 * qq) / sin0
    Eb, dEb = _E_dE(b)
    mu_rec = min(max(mu0 - b * d_s * Eb, L.mu_k), L.mu_s)
    dmu0 = L.kappa * (-(mu0 - L.mu_k) * Eb - b * d_s * dEb)
    return L.at + g * (U0 * mu_rec + r0 * dmu0) <= 0.0


def split_ds(L: Law, f0t, ft, fn0, fn, mu_c, b, s, kind):
    """Derivative of the split point ``s`` over the gap components (list of m = nt + 1)."""
    nt = len(ft)
    at, an = L.at, L.an
    w = [ft[i] - f0t[i] for i in range(nt)]
    ww = sum(v * v for v in w)
    if kind == CUSP:
        return [-(f0t[j] + 2.0 * s * w[j]) * at / ww for j in range(nt)] + [0.0]
    dfn = fn - fn0
    _, hp, (fs, q, N1, g, _) = _h(L, f0t, w, ww, fn0, dfn, mu_c, b, s)
    c = 2.0 * s * N1 / q
    ds = [-at * (fs[j] + s * w[j] - c * fs[j]) / (q * hp) for j in range(nt)]
    dh2 = L.cn * an * ((1.0 / g - 1.0) - dfn * L.cn * (1.0 - g) * s / (g * g))
    ds.append(dh2 / hp)
    return ds
