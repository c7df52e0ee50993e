"""Step 4, certification: the smallest root by branch and bound, and folds (``JUMP``).

Only for the roots of :mod:`.root` that the slope bound does not certify (strong softening:
``g kappa (mu - mu_k)`` comparable with ``alpha_t``). On an interval ``[x, y]`` the monotonicity
of the closed forms (``r`` increasing and concave, ``mu`` decreasing, ``|mu'|`` non-increasing)
bounds the value, ``phi >= A - alpha_t y - g r(y) mu(x)``, and the slope,
``-C <= phi' <= -B`` with ``B = alpha_t + g r'(y) mu(y) - g r(y) |mu'(x)|``,
``C = alpha_t + g r'(x) mu(x) - g r(x) |mu'(y)|``. The scan refines ``[0, dl*]`` on a grid until
an interval holds a sign change on which ``phi`` is strictly decreasing (solved there by
:func:`rtsafe`); if ``phi`` falls and then rises before it, the continuous branch ended in a fold
inside the step (``JUMP``). ``docs/model.md`` §6.3.
"""

from __future__ import annotations

import numpy as np

from .branch import Branch
from .common import EPS, TINY

__all__ = ["rtsafe", "scan"]

_SCAN_POINTS = 16
_SCAN_LEVELS = 80


def _phi_dphi(br: Branch, x, idx):
    """``phi``, ``phi'`` and the branch at slips ``x`` of points ``idx``."""
    e = br.ev(x, idx)
    g = br.g[idx] if x.ndim == 1 else br.g[idx][:, None]
    with np.errstate(invalid="ignore"):
        dphi = -br.L.at - g * (e.U * e.mu + e.r * e.dmu)
    return e.phi, dphi, e


def rtsafe(br: Branch, idx, lo, hi, x, tol_f, max_iter):
    """Safeguarded Newton for ``phi = 0`` on points ``idx`` with ``phi(lo) > 0 >= phi(hi)``.

    Returns ``(x, converged, evaluations)``.
    """
    lo, hi, x = lo.copy(), hi.copy(), x.copy()
    n = x.size
    f, df, _ = _phi_dphi(br, x, idx)
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
    act = (~conv).nonzero()[0]
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
        mid = np.where(ha > 1e3 * la, np.sqrt(np.maximum(la, TINY)) * np.sqrt(ha), 0.5 * (la + ha))
        xn = np.where(bisect, mid, newton)
        dx_old[act] = dx[act]
        dx[act] = xn - xa
        fn, dfn, _ = _phi_dphi(br, xn, idx[act])
        pos = fn > 0.0
        lo[act] = np.where(pos, xn, la)
        hi[act] = np.where(pos, ha, xn)
        f_lo[act] = np.where(pos, fn, f_lo[act])
        f_hi[act] = np.where(pos, f_hi[act], fn)
        x[act], f[act], df[act] = xn, fn, dfn
        iters[act] += 1
        ok = np.abs(fn) <= tol_f[act]
        flat = f_lo[act] - f_hi[act] <= 2.0 * tol_f[act]
        tight = hi[act] - lo[act] <= 4.0 * EPS * hi[act]
        a = act[(flat | tight) & ~ok]
        x[a] = np.where(f_lo[a] < -f_hi[a], lo[a], hi[a])
        done = ok | flat | tight
        conv[act[done]] = True
        act = act[~done]
    return x, conv, iters


def scan(br: Branch, hi, tol_f, max_iter):
    """Certified smallest root of every point of ``br`` on ``[0, hi]`` by branch and bound.

    Returns ``(root, converged, evaluations, jump)``.
    """
    n = hi.size
    K = _SCAN_POINTS
    at = br.L.at
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
        la, ea, tf = lo[act], end[act], tol_f[act][:, None]
        xs = la[:, None] + (ea - la)[:, None] * t[None, :]
        xs[:, -1] = ea
        phi, _, e = _phi_dphi(br, xs, act)
        r, dr, mu, dmu = e.r, e.U, e.mu, e.dmu
        iters[act] += K
        g = br.g[act][:, None]
        C = at + g * dr[:, :-1] * mu[:, :-1] - g * r[:, :-1] * np.abs(dmu[:, 1:])
        free = (br.A[act][:, None] - at * xs[:, 1:] - g * r[:, 1:] * mu[:, :-1] > 0.0) | (
            phi[:, :-1] - np.maximum(C, 0.0) * np.diff(xs, axis=1) > 0.0
        )
        decreasing = at + g * dr[:, 1:] * mu[:, 1:] - g * r[:, 1:] * np.abs(dmu[:, :-1]) > 0.0
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
        if np.count_nonzero(solve):
            s = act[solve]
            x, ok, it = rtsafe(
                br, s, x_left[solve], x_right[solve], x_right[solve], tol_f[s], max_iter
            )
            root[s], conv[s] = x, ok
            iters[s] += it
            finished[solve] = True
        ulps = 4.0 * EPS * end[act] + TINY
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
