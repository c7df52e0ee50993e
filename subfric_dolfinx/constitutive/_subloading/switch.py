"""Step 2: where a step switches from elastic to plastic, and the start state of the plastic part.

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
branch: where ``phi`` rises at the switch (softening faster than the elastic unloading,
``H(0) = alpha_t + g (U(r_s) mu + r_s mu'(0)) <= 0``) its smallest root lies a finite slip
away, so the traction would jump at the switch; the whole step's loading test decides there, as
without the split (the literal Sec. 7 set in FE needs it to converge).

The rest of the step starts at ``f_s = f(s)`` with ``mu`` recovered over ``s dt`` and ``r`` from
the traction there: ``|f_s| / (g_s mu_e(s))`` at a cusp (0 to rounding), ``r_0 r_el(s) / r_el(0)``
at a root (continuous as ``s -> 0``) (:func:`start_state`). The split point's derivative over the
gap components, for the tangent: ``ds = -(f0 + 2 s w).dw / |w|^2`` at a cusp, ``ds = -dh / h'(s)``
at a root (:func:`split_ds`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .branch import Branch, g_of
from .common import EPS, ROT_HI, ROT_LO, SPLIT_EPS, Law, dot, norm_t
from .trial import Trial

__all__ = [
    "CUSP",
    "ROOT",
    "Segment",
    "Start",
    "split_ds",
    "split_point",
    "start_state",
    "unstable_start",
]

CUSP, ROOT = 1, 2
CUSP_REL = 1e-8  # |f| at its minimum below this times (|f0| + |f*|): a cusp (r_el = 0 there)
_MAX_IT = 60


class Segment:
    """The elastic trial segments of k points.

    Start ``f0t`` (k, nt), ``fn0``; end ``ft``, ``fn``, ``A = |ft|``; ``mu_c`` (``mu`` at the
    start); ``b = xi dt``; and ``w = ft - f0t``, ``ww = |w|^2``, ``dfn = fn - fn0``.
    """

    __slots__ = ("A", "b", "dfn", "f0t", "fn", "fn0", "ft", "mu_c", "w", "ww")

    def __init__(self, f0t, fn0, ft, fn, A, mu_c, b) -> None:
        self.f0t, self.fn0, self.ft, self.fn, self.A = f0t, fn0, ft, fn, A
        self.mu_c, self.b = mu_c, b
        self.w = ft - f0t
        self.ww = dot(self.w, self.w)
        self.dfn = fn - fn0

    def take(self, i) -> Segment:
        """Points ``i`` (an increasing index array: all of them means these segments)."""
        if i.size == self.A.size:
            return self
        o = object.__new__(Segment)
        for k in Segment.__slots__:
            setattr(o, k, getattr(self, k)[i])
        return o


def _h(L: Law, sg: Segment, s):
    """``h(s)``, ``h'(s)`` and ``f_s, |f_s|^2, f_s.w, g_s`` at ``s`` (one per point)."""
    fs = sg.f0t + s[:, None] * sg.w
    q = dot(fs, fs)
    N1 = dot(fs, sg.w)
    g = -np.expm1(-L.cn * (sg.fn0 + s * sg.dfn))
    mu_c, b, dfn = sg.mu_c, sg.b, sg.dfn
    mu_e = np.minimum(mu_c + (L.mu_s - mu_c) * -np.expm1(-b * s), L.mu_s)
    mr = (L.mu_s - mu_c) * np.exp(-b * s) / mu_e  # (mu_s - mu_e) / mu_e without cancellation
    h = N1 / q - L.cn * (1.0 - g) * dfn / g - b * mr
    hp = (sg.ww * q - 2.0 * N1 * N1) / (q * q)
    hp += L.cn * L.cn * (1.0 - g) * dfn * dfn / (g * g) + b * b * L.mu_s * mr / mu_e
    return h, hp, fs, q, N1, g


def _newton(L: Law, sg: Segment, lo, hi, x, hx, hpx):
    """Safeguarded Newton for ``h = 0`` on ``[lo, hi]`` (``h(lo) < 0 < h(hi)``) from ``x``.

    Points move in lockstep; a point stops when ``h = 0``, when its Newton step falls below the
    rounding of ``x`` (before it is taken: a step that cannot move ``x`` would otherwise count
    as leaving the bracket and turn into some 50 bisections), when its last step was that small,
    or its bracket is exhausted.
    """
    dx_old = hi - lo
    i = np.arange(x.size)  # the active points
    si = sg  # their segments
    for _ in range(_MAX_IT):
        if i.size == 0:
            break
        xi, hxi, hpi = x[i], hx[i], hpx[i]
        step = hxi / np.where(hpi > 0.0, hpi, 1.0)
        conv = (hpi > 0.0) & (np.abs(step) <= 4.0 * EPS * xi)  # step below rounding: done
        if np.count_nonzero(conv):
            keep = ~conv
            i, xi, hxi, hpi, step = i[keep], xi[keep], hxi[keep], hpi[keep], step[keep]
            si = sg.take(i)
            if i.size == 0:
                break
        li, hi_ = lo[i], hi[i]
        xn = np.where(hpi > 0.0, xi - step, -1.0)
        bad = ~((li < xn) & (xn < hi_)) | (np.abs(xn - xi) > 0.5 * np.abs(dx_old[i]))
        xn = np.where(bad, 0.5 * (li + hi_), xn)
        dx_old[i] = xn - xi
        x[i] = xn
        h, hp = _h(L, si, xn)[:2]
        hx[i], hpx[i] = h, hp
        lo[i] = np.where(h < 0.0, xn, li)
        hi[i] = np.where(h > 0.0, xn, hi_)
        tight = hi[i] - lo[i] <= 4.0 * EPS * hi[i]
        done = (h == 0.0) | (np.abs(dx_old[i]) <= 4.0 * EPS * xn) | tight
        if np.count_nonzero(done):
            i = i[~done]
            si = sg.take(i)
    return x


def split_point(L: Law, sg: Segment):
    """``(s, kind)`` of the split of each segment: ``kind`` 0 where there is none (``s = 0``).

    The segments are those of points in contact with a start in contact (``f_n0 > 0``).
    """
    k = sg.A.size
    f0t, w, ww, A = sg.f0t, sg.w, sg.ww, sg.A
    fw = dot(f0t, w)
    rho0 = norm_t(f0t)
    W = np.sqrt(ww)
    s = np.zeros(k)
    kind = np.zeros(k, dtype=np.int8)
    base = (ww > 0.0) & (rho0 > 0.0)
    sa = fw < 0.0  # |f| falls at the start
    resolved = ww + fw > SPLIT_EPS * W * (rho0 + A)  # its minimum inside, the rest resolved
    caseA = base & sa & resolved
    caseB = base & ~sa
    n_A = np.count_nonzero(caseA)
    if not (n_A or np.count_nonzero(caseB)):
        return s, kind  # (unloading that stays elastic through the segment's end)
    ok_h = (
        (ROT_LO < rho0)
        & (rho0 < ROT_HI)
        & (ROT_LO < W)
        & (W < ROT_HI)
        & (A < ROT_HI)
        & (sg.b < ROT_HI)
        & (-np.expm1(-L.cn * sg.fn0) > ROT_LO)
        & (-np.expm1(-L.cn * sg.fn) > ROT_LO)
    )
    caseB &= ok_h
    if n_A:
        s_f = np.where(caseA, -fw / np.where(ww > 0.0, ww, 1.0), 0.0)
        s[caseA] = s_f[caseA]
        kind[caseA] = CUSP
        fm = f0t + s_f[:, None] * w
        refine = caseA & ok_h & (norm_t(fm) > CUSP_REL * (rho0 + A))
        rows = (refine | caseB).nonzero()[0]
    else:
        refine = caseA
        rows = caseB.nonzero()[0]
    if rows.size == 0:
        return s, kind
    sr = sg.take(rows)
    isA = refine[rows]
    x0 = np.where(isA, s_f[rows], 0.0) if n_A else np.zeros(rows.size)
    hx, hpx = _h(L, sr, x0)[:2]  # B: h(0); A: h(s_f)
    if not np.count_nonzero(isA | (hx < 0.0)):
        return s, kind  # (the usual loading step: h(0) >= 0, plastic from the start)
    # h(1) and h(0) only where the decision needs them (B: h(0) < 0 is rare in loading steps)
    h1 = np.zeros(rows.size)
    i1 = (hx < 0.0).nonzero()[0]
    if i1.size:
        h1[i1] = _h(L, sr.take(i1), np.ones(i1.size))[0]
    h0 = hx.copy()
    i0 = (isA & (hx > 0.0)).nonzero()[0]
    if i0.size:
        h0[i0] = _h(L, sr.take(i0), np.zeros(i0.size))[0]
    lo = np.where(isA & (hx > 0.0), 0.0, x0)
    hi = np.where(isA & (hx > 0.0), x0, 1.0)
    # A: h(s_f) < 0 needs h(1) > 0 (else the cusp split stays); h(s_f) > 0 needs h(0) < 0
    # (else no split); h(s_f) = 0 is the root. B: h(0) < 0 < h(1).
    none = np.where(isA, (hx > 0.0) & ~(h0 < 0.0), ~((hx < 0.0) & (h1 > 0.0)))
    keep_cusp = isA & (hx < 0.0) & ~(h1 > 0.0)
    solve = ~none & ~keep_cusp & (hx != 0.0)
    x = x0.copy()
    j = solve.nonzero()[0]
    if j.size:
        x[j] = _newton(L, sr.take(j), lo[j], hi[j], x0[j].copy(), hx[j], hpx[j])
    root = solve | (~none & ~keep_cusp & (hx == 0.0))
    ok = root & ((1.0 - x) * W[rows] > SPLIT_EPS * (rho0[rows] + A[rows]))
    r_ok, r_none = rows[ok], rows[none | (root & ~ok)]
    s[r_ok], kind[r_ok] = x[ok], ROOT
    s[r_none], kind[r_none] = 0.0, 0
    return s, kind


def split_ds(L: Law, sg: Segment, s, kind):
    """Derivative of the split points ``s`` over the gap components: (k, m)."""
    k, nt = sg.ft.shape
    at, an = L.at, L.an
    w, ww = sg.w, sg.ww
    ds = np.zeros((k, nt + 1))
    cu = kind == CUSP
    if np.count_nonzero(cu):
        ds[cu, :nt] = -(sg.f0t[cu] + 2.0 * s[cu, None] * w[cu]) * (at / ww[cu])[:, None]
    ro = (kind == ROOT).nonzero()[0]
    if ro.size:
        sr = sg.take(ro)
        s_r = s[ro]
        _, hp, fs, q, N1, g = _h(L, sr, s_r)
        c = 2.0 * s_r * N1 / q
        ds[ro, :nt] = -at * (fs + s_r[:, None] * sr.w - c[:, None] * fs) / (q * hp)[:, None]
        ds[ro, nt] = L.cn * an * ((1.0 / g - 1.0) - sr.dfn * L.cn * (1.0 - g) * s_r / (g * g)) / hp
    return ds


class Start:
    """The start state of the plastic part of the step, per point of a chunk.

    Attributes:
        kind, s: The split (0: none, ``CUSP``, ``ROOT``) and its point on the segment.
        f0t, fn0: The start traction of the step (None without one: the radial return).
        f_s, fn_s, g_s, rho_s: The traction at the start of the plastic part (``f0t`` where
            there is no split), its normal component, saturation and magnitude.
        mu, r, d: ``mu``, ``r`` there, and ``mu - mu_s`` (without cancellation).
        b, mu_rec: ``xi dt`` of the rest of the step; ``mu`` recovered over it.
    """

    __slots__ = (
        "b",
        "d",
        "f0t",
        "f_s",
        "fn0",
        "fn_s",
        "g_s",
        "kind",
        "mu",
        "mu_rec",
        "r",
        "rho_s",
        "s",
    )

    kind: npt.NDArray[np.int8]
    s: npt.NDArray[np.float64]
    f0t: npt.NDArray[np.float64] | None
    fn0: npt.NDArray[np.float64] | None
    f_s: npt.NDArray[np.float64] | None
    fn_s: npt.NDArray[np.float64] | None
    g_s: npt.NDArray[np.float64] | None
    rho_s: npt.NDArray[np.float64] | None
    mu: npt.NDArray[np.float64]
    r: npt.NDArray[np.float64]
    d: npt.NDArray[np.float64]
    b: npt.NDArray[np.float64]
    mu_rec: npt.NDArray[np.float64]


def start_state(L: Law, t: Trial, f0) -> Start:
    """The split of the elastic trial segments of a chunk and the start of their plastic parts.

    ``f0``: the start tractions (n, m), or None.
    """
    n, nt = t.ft.shape
    st = Start()
    st.kind = np.zeros(n, dtype=np.int8)
    st.s = np.zeros(n)
    st.mu, st.r, st.b, st.mu_rec = t.mu, t.r, t.b, t.mu_rec
    st.d = t.mu - L.mu_s
    if f0 is None:
        st.f0t = st.fn0 = st.f_s = st.fn_s = st.g_s = st.rho_s = None
        return st
    st.f0t, st.fn0 = f0t, fn0 = f0[:, :nt], f0[:, nt]
    cand = (t.contact & (fn0 > 0.0)).nonzero()[0]
    if cand.size == n:
        sg = Segment(f0t, fn0, t.ft, t.fn, t.A, t.mu, t.b)
        st.s, st.kind = split_point(L, sg)
    elif cand.size:
        sg = Segment(f0t[cand], fn0[cand], t.ft[cand], t.fn[cand], t.A[cand], t.mu[cand], t.b[cand])
        st.s[cand], st.kind[cand] = split_point(L, sg)
    si = st.kind.nonzero()[0]
    if si.size == 0:  # the start traction throughout (views: nothing writes into them)
        st.f_s, st.fn_s = f0t, fn0
        st.g_s = g_of(L, fn0)
        st.rho_s = norm_t(f0t)
        return st
    st.f_s, st.fn_s = f_s, fn_s = f0t.copy(), fn0.copy()
    if si.size:
        s = st.s[si]
        f_s[si] += s[:, None] * (t.ft[si] - f0t[si])
        fn_s[si] = fn0[si] + s * (t.fn[si] - fn0[si])
    st.g_s = g_of(L, fn_s)
    st.rho_s = norm_t(f_s)
    mu_s = L.mu_s
    g_s, rho_m = st.g_s[si], st.rho_s[si]
    mu_c = t.mu[si]
    bs = t.b[si] * s
    mu_m = np.minimum(mu_c + (mu_s - mu_c) * (-np.expm1(-bs)), mu_s)
    gm = g_s * mu_m
    r_m = np.where(gm > 0.0, np.where(rho_m < gm, rho_m / gm, 1.0), np.where(rho_m == 0, 0, 1.0))
    ro = st.kind[si] == ROOT  # r scaled by r_el(s) / r_el(0): continuous as s -> 0
    if np.count_nonzero(ro):
        sr = si[ro]
        rho0 = norm_t(f0t[sr])
        q = (rho_m[ro] / rho0) * (g_of(L, fn0[sr]) / g_s[ro]) * (t.mu[sr] / mu_m[ro])
        r_m[ro] = np.minimum(t.r[sr] * q, 1.0)
    st.mu, st.r, st.b, st.d = t.mu.copy(), t.r.copy(), t.b.copy(), st.d.copy()
    st.mu_rec = t.mu_rec.copy()
    st.mu[si], st.r[si], st.b[si] = mu_m, r_m, t.b[si] - bs
    st.d[si] = (mu_c - mu_s) * np.exp(-bs)  # mu_st - mu_s without cancellation
    st.mu_rec[si] = np.minimum(mu_m + (mu_s - mu_m) * (-np.expm1(-st.b[si])), mu_s)
    if np.count_nonzero(ro):  # no ROOT split where the plastic part would start unstable
        sr = si[ro]
        bad = unstable_start(L, t.g[sr], st.r[sr], st.mu[sr], st.b[sr], st.d[sr])
        if np.count_nonzero(bad):
            j = sr[bad]
            st.kind[j], st.s[j] = 0, 0.0
            f_s[j], fn_s[j] = f0t[j], fn0[j]
            st.g_s[j], st.rho_s[j] = g_of(L, fn0[j]), norm_t(f0t[j])
            st.mu[j], st.r[j], st.b[j] = t.mu[j], t.r[j], t.b[j]
            st.d[j], st.mu_rec[j] = t.mu[j] - mu_s, t.mu_rec[j]
    return st


def unstable_start(L: Law, g, r0, mu0, b, d_s):
    """Whether ``phi`` rises at the start of a plastic part from ``(r0, mu0)``.

    ``H(0) = alpha_t + g (U(r0) mu_rec + r0 mu'(0)) <= 0`` (the branch of :mod:`.branch`).
    """
    br = Branch.start(L, g, g, r0, mu0, b, d_s)
    ok = (r0 > 0.0) & (br.sin0 > 0.0)
    U0 = L.ut * br.c0 / np.where(ok, br.sin0, 1.0)
    return ok & (L.at + g * (U0 * br.mu_rec + r0 * br.dmu0) <= 0.0)
