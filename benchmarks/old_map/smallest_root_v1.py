"""THE PREVIOUS SMALLEST-ROOT MODULE (main at 961eee5), for ``subloading_v1``; verbatim.

The closed-form plastic branch of the subloading law and its certified smallest root.

For a plastic point with trial magnitude ``A = |f_t*|``, ``g = g(f_n)`` and start-of-step state
``(r_n, mu_n)``, :class:`Branch` evaluates in closed form, at a trial slip ``dl``, ``r(dl)``,
``mu(dl)``, the consistency function ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)`` and their
derivatives. :func:`rtsafe` is a safeguarded Newton iteration for ``phi = 0`` in a bracket;
:func:`scan` certifies the smallest root on ``[0, x]`` by branch and bound when ``phi`` is not
provably decreasing there (strong softening), and detects folds (a local minimum of ``phi`` before
the root: ``JUMP``). See :mod:`.subloading` for the scheme.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .subloading import SubloadingLaw

__all__ = ["Branch", "rtsafe", "scan"]

_ALL = slice(None)
_EPS = float(np.finfo(float).eps)
_TINY = float(np.finfo(float).tiny)
_SCAN_POINTS = 16
_SCAN_LEVELS = 80

# Taylor coefficients of E'(s) = sum_n (-1)^n n s^(n-1) / (n+1)!, n = 1..10
_DE_SERIES = np.array([(-1) ** n * n / float(np.prod(np.arange(1, n + 2))) for n in range(1, 11)])


def _E(s: np.ndarray) -> np.ndarray:
    """``(1 - exp(-s)) / s`` for ``s >= 0`` with ``E(0) = 1``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        e = -np.expm1(-s) / s
    return np.where(s > 0.0, e, 1.0)


def _dE(s: np.ndarray) -> np.ndarray:
    """``E'(s)``, accurate for all ``s >= 0`` (Taylor series below 0.05)."""
    small = s < 0.05
    ss = np.where(small, s, 0.0)
    series = np.polynomial.polynomial.polyval(ss, _DE_SERIES)
    sl = np.where(small, 1.0, s)
    with np.errstate(over="ignore"):
        direct = (np.expm1(-sl) * (1.0 + sl) + sl) / (sl * sl)
    return np.where(small, series, direct)


class Branch:
    """Closed-form ``r(dl)``, ``mu(dl)`` and ``phi(dl)`` of plastic points (one per row)."""

    def __init__(
        self,
        p: SubloadingLaw,
        A: np.ndarray,
        g: np.ndarray,
        r_n: np.ndarray,
        mu_n: np.ndarray,
        b: float,
    ) -> None:
        self.p = p
        self.A, self.g, self.mu_n = A, g, mu_n
        self.b = b
        self.k = 0.5 * np.pi * p.u_tilde
        quarter = 0.25 * np.pi * r_n
        self.c0 = np.cos(2.0 * quarter)  # cos(pi r_n / 2)
        self.s0 = np.sin(quarter) ** 2  # (1 - c0) / 2, accurate for small r_n
        self.d_k = mu_n - p.mu_k
        self.d_s = mu_n - p.mu_s

    def eval(self, dl: np.ndarray, idx: np.ndarray | slice = _ALL) -> tuple[np.ndarray, ...]:
        """Return ``phi, dphi, r, dr, mu, dmu`` at slips ``dl`` (rows ``idx``; (n,) or (n, K))."""
        col = (lambda a: a[idx]) if dl.ndim == 1 else (lambda a: a[idx][:, None])
        p = self.p
        c0 = col(self.c0)
        em = np.expm1(-self.k * dl)  # exp(-k dl) - 1
        w = c0 * (1.0 + em)  # cos(pi r / 2)
        q = np.clip(col(self.s0) - 0.5 * c0 * em, 0.0, 1.0)  # (1 - w) / 2 = sin^2(pi r / 4)
        r = (4.0 / np.pi) * np.arcsin(np.sqrt(q))
        sin_th = 2.0 * np.sqrt(q * (1.0 - q))  # sin(pi r / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            dr = np.where(w > 0.0, p.u_tilde * w / sin_th, 0.0)  # U(r) = u_tilde cot(pi r / 2)
        a = p.kappa * dl
        s = a + self.b
        E = _E(s)
        D = a * col(self.d_k) + self.b * col(self.d_s)
        mu = np.clip(col(self.mu_n) - D * E, p.mu_k, p.mu_s)
        dmu = p.kappa * (-col(self.d_k) * E - D * _dE(s))
        g = col(self.g)
        phi = col(self.A) - p.alpha_t * dl - g * r * mu
        with np.errstate(invalid="ignore"):
            dphi = -p.alpha_t - g * (dr * mu + r * dmu)
        return phi, dphi, r, dr, mu, dmu


def rtsafe(
    br: Branch,
    idx: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    x: np.ndarray,
    tol_f: np.ndarray,
    max_iter: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Safeguarded Newton for ``phi = 0`` on rows ``idx`` with ``phi(lo) > 0 >= phi(hi)``.

    Returns the roots, a converged mask and the iteration counts. Newton steps that leave the
    bracket or do not halve it fast enough are replaced by bisection, so it always converges.

    A point has converged when ``|phi| <= tol_f`` at the iterate, or when the bracket can no longer
    improve it: ``phi(lo) - phi(hi) <= 2 tol_f`` (both ends evaluated; the better end is returned),
    or the bracket is down to a few ulps of ``dl``. A small step or bracket in ``dl`` alone is
    not enough: ``phi'`` can be far steeper than ``-alpha_t`` inside the bracket, near ``r = 0``
    where ``U(r) = u_tilde cot(pi r / 2)`` is unbounded, or for a large ``kappa``.
    """
    lo, hi, x = lo.copy(), hi.copy(), x.copy()
    n = x.size
    f, df = br.eval(x, idx)[:2]
    # Values at the bracket ends, once evaluated (+-inf until then). The first iterate is an end.
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
        # Bisection is geometric while the bracket spans more than three decades (a root close to
        # zero, e.g. a tiny first slip from r = 0, is then found in tens, not hundreds, of steps).
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
        # Bracket exhausted: return whichever end is closer to phi = 0.
        a = act[(flat | tight) & ~ok]
        x[a] = np.where(f_lo[a] < -f_hi[a], lo[a], hi[a])
        done = ok | flat | tight
        conv[act[done]] = True
        act = act[~done]
    return x, conv, iters


def scan(
    br: Branch,
    idx: np.ndarray,
    hi: np.ndarray,
    tol_f: np.ndarray,
    max_iter: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Certified smallest root on ``[0, hi]`` by branch and bound (rows ``idx``; ``phi(hi) ~ 0``).

    Keeps ``lo`` (no root in ``[0, lo]``, ``phi(lo) > 0``), a window ``[lo, end]`` and ``hi``
    (``phi(hi) <= 0``). Each level evaluates ``phi`` on a grid of the window and classifies each
    interval: root-free by the value bound, or strictly decreasing by the slope bound (then it holds
    a root iff ``phi`` at its right end is not positive). Everything left of the first interval that
    is unresolved or holds a root is certified root-free; a decreasing interval with a root is
    solved by safeguarded Newton; an unresolved one becomes the next window. Returns the roots, a
    converged mask, the evaluation counts and a mask of points where ``phi`` fell and then rose
    before the root (a local minimum: the continuous branch ended in a fold, ``JUMP``).
    """
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
        # Root-free: the value bound, or phi(x_j) minus the largest possible fall over the interval
        # (slope bound phi' >= -C with C from the extreme values of r', mu, r, |mu'| on it).
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
        # Fold detection on the certified root-free part: a fall followed by a rise.
        d = np.diff(phi, axis=1)
        before = jj < j0[:, None]
        falls = (d < -tf) & before
        rises = (d > tf) & before
        fell_before = fell[act][:, None] | (np.cumsum(falls, axis=1) - falls > 0)
        jump[act] |= (rises & fell_before).any(axis=1)
        fell[act] |= falls.any(axis=1)

        # phi at the certified left end already within tolerance: that is the smallest root (the
        # window may otherwise shrink towards lo = 0 without ever reaching a few ulps of it).
        at_lo = phi[:, 0] <= tf[:, 0]
        ar = np.arange(act.size)
        jc = np.minimum(j0, K - 1)
        x_left, x_right = xs[ar, jc], xs[ar, jc + 1]
        neg0 = any_stop & neg[ar, jc]
        dec0 = any_stop & decreasing[ar, jc]
        # Whole window root-free: continue from its end towards hi.
        clear = ~any_stop
        lo[act[clear]] = ea[clear]
        end[act[clear]] = hi[act[clear]]
        # Otherwise lo moves to the left end of the first interval needing attention.
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
                br,
                idx[s],
                x_left[solve],
                x_right[solve],
                x_right[solve],
                tol_f[s],
                max_iter,
            )
            root[s], conv[s] = x, ok
            iters[s] += it
            finished[solve] = True
        # A window down to a few ulps of dl: its right end is a root if phi <= tol there,
        # otherwise it is passed over (a tangency that double precision cannot resolve).
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
