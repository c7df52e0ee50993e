"""Certified smallest root by branch and bound: ``_Branch``, ``_rtsafe`` and ``_scan``.

Copied from ``subfric_dolfinx/constitutive/subloading.py`` (main at e941b1c) with one change:
``E'(s)`` uses a three-term series below ``s = 1e-3`` and the closed form above, instead of a
ten-term series and the closed form evaluated for all points (see ``dE``). The logic of the scan
(value and slope bounds, fold detection -> JUMP) is unchanged; the prototype calls it only for
points whose Newton root is not certified by the slope bound (strong softening).
"""

from __future__ import annotations

import numpy as np

_ALL = slice(None)
_EPS = float(np.finfo(float).eps)
_TINY = float(np.finfo(float).tiny)
_SCAN_POINTS = 16
_SCAN_LEVELS = 80
S_SERIES = 1e-3  # below: E'(s) = -1/2 + s/3 - s^2/8 (error < s^3/30 < 4e-11, times D = O(s))


def E(s: np.ndarray) -> np.ndarray:
    """``(1 - exp(-s)) / s`` for ``s >= 0`` with ``E(0) = 1``."""
    ss = np.where(s > 0.0, s, 1.0)
    return np.where(s > 0.0, -np.expm1(-ss) / ss, 1.0)


def dE(s: np.ndarray) -> np.ndarray:
    """``E'(s) = (expm1(-s) (1 + s) + s) / s^2``; series below ``S_SERIES``.

    The closed form loses ``eps / s`` absolutely to cancellation; ``E'`` only enters ``mu'``
    multiplied by ``D = a (mu_n - mu_k) + b (mu_n - mu_s) = O(s)``, so the loss in ``mu'`` is
    ``O(eps)`` relative. No ten-term polynomial, no evaluation of both branches' costly parts.
    """
    small = s < S_SERIES
    ss = np.where(small, 1.0, s)
    direct = (np.expm1(-ss) * (1.0 + ss) + ss) / (ss * ss)
    return np.where(small, -0.5 + s * (1.0 / 3.0 - 0.125 * s), direct)


class Branch:
    """Closed-form ``r(dl)``, ``mu(dl)`` and ``phi(dl)`` of plastic points (one per row)."""

    def __init__(self, p, A, g, r_n, mu_n, b) -> None:
        self.p = p
        self.A, self.g, self.mu_n = A, g, mu_n
        self.b = b  # scalar or per row
        self.k = 0.5 * np.pi * p.u_tilde
        quarter = 0.25 * np.pi * r_n
        self.c0 = np.cos(2.0 * quarter)
        self.s0 = np.sin(quarter) ** 2
        self.d_k = mu_n - p.mu_k
        self.d_s = mu_n - p.mu_s

    def eval(self, dl, idx=_ALL):
        """Return ``phi, dphi, r, dr, mu, dmu`` at slips ``dl`` (rows ``idx``; (n,) or (n, K))."""
        col = (lambda a: a[idx]) if dl.ndim == 1 else (lambda a: a[idx][:, None])
        colb = (lambda a: a) if np.ndim(self.b) == 0 else col
        p = self.p
        c0 = col(self.c0)
        em = np.expm1(-self.k * dl)
        w = c0 * (1.0 + em)
        q = np.clip(col(self.s0) - 0.5 * c0 * em, 0.0, 1.0)
        r = (4.0 / np.pi) * np.arcsin(np.sqrt(q))
        sin_th = 2.0 * np.sqrt(q * (1.0 - q))
        with np.errstate(divide="ignore", invalid="ignore"):
            dr = np.where(w > 0.0, p.u_tilde * w / sin_th, 0.0)
        a = p.kappa * dl
        b = colb(self.b)
        s = a + b
        Es = E(s)
        D = a * col(self.d_k) + b * col(self.d_s)
        mu = np.clip(col(self.mu_n) - D * Es, p.mu_k, p.mu_s)
        dmu = p.kappa * (-col(self.d_k) * Es - D * dE(s))
        g = col(self.g)
        phi = col(self.A) - p.alpha_t * dl - g * r * mu
        with np.errstate(invalid="ignore"):
            dphi = -p.alpha_t - g * (dr * mu + r * dmu)
        return phi, dphi, r, dr, mu, dmu


def rtsafe(br, idx, lo, hi, x, tol_f, max_iter):
    """Safeguarded Newton for ``phi = 0`` on rows ``idx`` with ``phi(lo) > 0 >= phi(hi)``."""
    lo, hi, x = lo.copy(), hi.copy(), x.copy()
    n = x.size
    f, df = br.eval(x, idx)[:2]
    f_lo = np.full(n, np.inf)
    f_hi = np.full(n, -np.inf)
    pos = f > 0.0
    lo = np.where(pos, np.maximum(lo, x), lo)
    hi = np.where(pos, hi, np.minimum(hi, x))
    f_lo[pos & (lo == x)] = f[pos & (lo == x)]
    f_hi[~pos & (hi == x)] = f[~pos & (hi == x)]
    conv = np.abs(f) <= tol_f
    iters = np.zeros(n, dtype=np.int64)
    dx_old = hi - lo
    dx = dx_old.copy()
    act = np.flatnonzero(~conv)
    for _ in range(max_iter):
        if act.size == 0:
            break
        xa, fa, dfa, la, ha = x[act], f[act], df[act], lo[act], hi[act]
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = xa - fa / dfa
        bisect = (
            ~(dfa < 0.0)
            | ~((newton > la) & (newton < ha))
            | (np.abs(2.0 * fa) > np.abs(dx_old[act] * dfa))
        )
        mid = np.where(ha > 1e3 * la, np.sqrt(np.maximum(la, _TINY)) * np.sqrt(ha), 0.5 * (la + ha))
        xn = np.where(bisect, mid, newton)
        dx_old[act] = dx[act]
        dx[act] = xn - xa
        fn, dfn = br.eval(xn, idx[act])[:2]
        pos = fn > 0.0
        lo[act] = np.where(pos, xn, la)
        hi[act] = np.where(pos, ha, xn)
        f_lo[act] = np.where(pos, fn, f_lo[act])
        f_hi[act] = np.where(pos, f_hi[act], fn)
        x[act], f[act], df[act] = xn, fn, dfn
        iters[act] += 1
        ok = np.abs(fn) <= tol_f[act]
        flat = f_lo[act] - f_hi[act] <= 2.0 * tol_f[act]
        tight = hi[act] - lo[act] <= 4.0 * _EPS * hi[act]
        a = act[(flat | tight) & ~ok]
        x[a] = np.where(f_lo[a] < -f_hi[a], lo[a], hi[a])
        done = ok | flat | tight
        conv[act[done]] = True
        act = act[~done]
    return x, conv, iters


def scan(br, idx, hi, tol_f, max_iter):
    """Certified smallest root on ``[0, hi]`` by branch and bound (unchanged from main)."""
    n = idx.size
    K = _SCAN_POINTS
    p = br.p
    lo = np.zeros(n)
    hi = hi.copy()
    end = hi.copy()
    root = hi.copy()
    conv = np.zeros(n, dtype=bool)
    fell = np.zeros(n, dtype=bool)
    jump = np.zeros(n, dtype=bool)
    iters = np.zeros(n, dtype=np.int64)
    t = np.linspace(0.0, 1.0, K + 1)
    jj = np.arange(K)[None, :]
    act = np.arange(n)
    for _ in range(_SCAN_LEVELS):
        if act.size == 0:
            break
        rows = idx[act]
        la, ea, tf = lo[act], end[act], tol_f[act][:, None]
        xs = la[:, None] + (ea - la)[:, None] * t[None, :]
        xs[:, -1] = ea
        phi, _, r, dr, mu, dmu = br.eval(xs, rows)
        iters[act] += K
        g = br.g[rows][:, None]
        C = p.alpha_t + g * dr[:, :-1] * mu[:, :-1] - g * r[:, :-1] * np.abs(dmu[:, 1:])
        free = (br.A[rows][:, None] - p.alpha_t * xs[:, 1:] - g * r[:, 1:] * mu[:, :-1] > 0.0) | (
            phi[:, :-1] - np.maximum(C, 0.0) * np.diff(xs, axis=1) > 0.0
        )
        decreasing = (
            p.alpha_t + g * dr[:, 1:] * mu[:, 1:] - g * r[:, 1:] * np.abs(dmu[:, :-1]) > 0.0
        )
        neg = phi[:, 1:] <= tf
        stop = neg | ~(free | decreasing)
        any_stop = stop.any(axis=1)
        j0 = np.where(any_stop, np.argmax(stop, axis=1), K)
        d = np.diff(phi, axis=1)
        before = jj < j0[:, None]
        falls = (d < -tf) & before
        rises = (d > tf) & before
        fell_before = fell[act][:, None] | (np.cumsum(falls, axis=1) - falls > 0)
        jump[act] |= (rises & fell_before).any(axis=1)
        fell[act] |= falls.any(axis=1)
        at_lo = phi[:, 0] <= tf[:, 0]
        ar = np.arange(act.size)
        jc = np.minimum(j0, K - 1)
        x_left, x_right = xs[ar, jc], xs[ar, jc + 1]
        neg0 = any_stop & neg[ar, jc]
        dec0 = any_stop & decreasing[ar, jc]
        clear = ~any_stop
        lo[act[clear]] = ea[clear]
        end[act[clear]] = hi[act[clear]]
        lo[act[any_stop]] = x_left[any_stop]
        solve = neg0 & dec0
        refine = any_stop & ~solve
        hi[act[neg0]] = x_right[neg0]
        end[act[refine]] = x_right[refine]
        finished = at_lo.copy()
        root[act[at_lo]] = la[at_lo]
        conv[act[at_lo]] = True
        solve &= ~at_lo
        if np.any(solve):
            s = act[solve]
            x, ok, it = rtsafe(
                br, idx[s], x_left[solve], x_right[solve], x_right[solve], tol_f[s], max_iter
            )
            root[s], conv[s] = x, ok
            iters[s] += it
            finished[solve] = True
        ulps = 4.0 * _EPS * end[act] + _TINY
        tiny = ~finished & (end[act] - lo[act] <= ulps)
        at_root = tiny & (neg0 | (hi[act] - lo[act] <= ulps))
        root[act[at_root]] = np.where(neg0[at_root], x_right[at_root], hi[act[at_root]])
        conv[act[at_root]] = True
        finished |= at_root
        skip = tiny & ~at_root
        lo[act[skip]] = end[act[skip]]
        end[act[skip]] = hi[act[skip]]
        act = act[~finished]
    return root, conv, iters, jump
