"""Batched return map of the subloading-friction model with saturation (numpy only).

Scheme (``MODEL.md``): for a step of length ``dt`` from the converged state ``(up_n, mu_n, r_n)``
to the prescribed local gap ``(ubar_t, ubar_n)``:

1. Trial: ``f_t* = alpha_t (ubar_t - up_n)``, ``A = |f_t*|``, ``f_n = alpha_n ubar_n``,
   ``g = 1 - exp(-c_n f_n)``. No contact (``ubar_n <= 0``): zero traction, ``r = 0``, ``up``
   frozen, ``mu`` recovers.
2. For a plastic slip ``dl`` at a constant rate over the step, ``r`` and ``mu`` integrate exactly:
   ``cos(pi r / 2) = cos(pi r_n / 2) exp(-pi u_tilde dl / 2)`` and
   ``mu = mu_n - (a (mu_n - mu_k) + b (mu_n - mu_s)) E(a + b)`` with ``a = kappa dl``,
   ``b = xi dt`` and ``E(s) = (1 - exp(-s)) / s`` (``E(0) = 1``).
3. Radial return: ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)``.
4. Loading test: plastic iff ``phi(0) > 0`` (the surface grown by recovery over the step).
5. ``phi(A / alpha_t) < 0``: a root exists in ``(0, A / alpha_t]``; the **smallest** root is taken.

Finding the smallest root, certified. On an interval ``[x, y]`` the monotonicity of the closed
forms (``r`` increasing and concave, ``mu`` decreasing, ``|mu'|`` non-increasing in ``dl``) gives:

* a lower bound of the value, ``phi >= A - alpha_t y - g r(y) mu(x)``;
* bounds of the slope, ``-C <= phi' <= -B`` with
  ``B = alpha_t + g r'(y) mu(y) - g r(y) |mu'(x)|`` and
  ``C = alpha_t + g r'(x) mu(x) - g r(x) |mu'(y)|``.

A safeguarded Newton iteration finds a root ``x*``; if ``B(0, x*) > 0``, ``phi`` is strictly
decreasing on ``[0, x*]`` and ``x*`` is the smallest root (the usual case, one extra check). If not
(strong softening: ``g kappa (mu - mu_k)`` comparable with ``alpha_t``), a vectorised
branch-and-bound scan over ``[0, x*]`` with these bounds certifies the smallest root; if ``phi``
falls and then rises before it (a local minimum), the continuous branch ended in a fold inside
the step and the point is reported as a ``JUMP``.

The result is never NaN or inf; a point that cannot be integrated (non-finite input) gets status
``FAILED``, zero traction and its last converged state.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._norm import tangential_norm
from .parameters import SubloadingParameters
from .result import ReturnMapResult, Status
from .state import InterfaceState

__all__ = ["subloading_return_map"]

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


class _Branch:
    """Closed-form ``r(dl)``, ``mu(dl)`` and ``phi(dl)`` of plastic points (one per row)."""

    def __init__(
        self,
        p: SubloadingParameters,
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


def _rtsafe(
    br: _Branch,
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


def _scan(
    br: _Branch,
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
            x, ok, it = _rtsafe(
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


def subloading_return_map(
    params: SubloadingParameters,
    gap: npt.ArrayLike,
    state: InterfaceState,
    dt: float,
    *,
    out: InterfaceState | None = None,
    tol: float = 1e-13,
    max_iter: int = 100,
) -> ReturnMapResult:
    """Integrate the subloading-friction law over one step at N points.

    Args:
        params: Material parameters.
        gap: Local gap ``(ubar_t1, [ubar_t2,] ubar_n)`` at the end of the step, shape (N, nt + 1);
            ``ubar_n > 0`` on approach.
        state: Converged state at the start of the step (not modified).
        dt: Time increment of the step (>= 0), s; drives the recovery of ``mu``.
        out: State to write the end-of-step internal variables into (e.g. views of DOLFINx
            Quadrature functions); a new one is allocated when omitted. Must not be ``state``.
        tol: Relative tolerance of the consistency condition, on ``phi / (g mu_s)``.
        max_iter: Iteration limit of the safeguarded Newton solves.

    Returns:
        Traction, consistent tangent, end-of-step state, per-point status and stability flags.

    Raises:
        ValueError: Bad shapes or a non-finite or negative ``dt``.
    """
    p = params
    gap = np.asarray(gap, dtype=np.float64)
    nt = state.n_tangential
    n = state.n_points
    m = nt + 1
    if gap.shape != (n, m):
        raise ValueError(f"gap must have shape ({n}, {m}) to match the state, got {gap.shape}")
    dt = float(dt)
    if not np.isfinite(dt) or dt < 0.0:
        raise ValueError(f"dt = {dt!r} must be finite and >= 0")
    if out is state:
        raise ValueError("out must not be the input state (inputs are never mutated)")

    up_n, mu_n, r_n = state.up, state.mu, state.r
    ok_in = (
        np.isfinite(gap).all(axis=1)
        & np.isfinite(up_n).all(axis=1)
        & np.isfinite(mu_n)
        & np.isfinite(r_n)
        & (r_n >= -1e-9)
        & (r_n <= 1.0 + 1e-9)
        & (mu_n >= p.mu_k * (1 - 1e-12))
        & (mu_n <= p.mu_s * (1 + 1e-12))
    )
    # Sanitise rejected points so that no NaN enters the arithmetic below.
    gap_s = np.where(ok_in[:, None], gap, 0.0)
    up_s = np.where(ok_in[:, None], up_n, 0.0)
    mu_s = np.where(ok_in, np.clip(mu_n, p.mu_k, p.mu_s), p.mu_s)
    r_s = np.where(ok_in, np.clip(r_n, 0.0, 1.0), 0.0)

    ft_trial = p.alpha_t * (gap_s[:, :nt] - up_s)
    A = tangential_norm(ft_trial)
    un = gap_s[:, nt]
    fn = p.alpha_n * un
    g = -np.expm1(-p.c_n * np.maximum(fn, 0.0))
    contact = ok_in & (un > 0.0) & (g > 0.0)

    b = p.xi * dt
    # mu after recovery alone; the min keeps the rounding of mu + (mu_s - mu) from exceeding mu_s
    mu_rec = np.minimum(mu_s + (p.mu_s - mu_s) * (-np.expm1(-b)), p.mu_s)
    phi0 = A - g * r_s * mu_rec
    plastic = contact & (phi0 > 0.0) & (A > 0.0)
    elastic = contact & ~plastic

    status = np.full(n, Status.FAILED, dtype=np.int8)
    status[elastic] = Status.ELASTIC
    status[ok_in & ~contact] = Status.SEPARATED
    unstable = np.zeros(n, dtype=bool)
    iterations = np.zeros(n, dtype=np.int64)

    new = InterfaceState.initial(n, nt, p.mu_s) if out is None else out
    if new.up.shape != up_n.shape:
        raise ValueError(f"out has shape {new.up.shape}, expected {up_n.shape}")
    traction = np.zeros((n, m))
    tangent = np.zeros((n, m, m))

    # Defaults: elastic trial everywhere (overwritten below for the other cases).
    np.copyto(new.up, up_s)
    np.copyto(new.mu, mu_rec)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # F = 0 gives r = 0 even where g mu_rec underflows to 0 (subnormal g): no 0/0
        r_el = np.where(contact & (A > 0.0), A / (g * mu_rec), 0.0)
    np.copyto(new.r, np.clip(r_el, 0.0, 1.0))
    traction[:, :nt] = np.where(elastic[:, None], ft_trial, 0.0)
    traction[:, nt] = np.where(elastic, fn, 0.0)
    diag = np.zeros(m)
    diag[:nt], diag[nt] = p.alpha_t, p.alpha_n
    # Touching exactly (ubar_n = 0, e.g. an unloaded initial state): zero traction, but the
    # one-sided tangent from the contact side, so that a touching interface has stiffness.
    touching = ok_in & (un == 0.0)
    tangent[elastic | touching] = np.diag(diag)

    # Failed inputs keep their last converged state where it was finite.
    bad = ~ok_in
    if np.any(bad):
        new.up[bad] = up_s[bad]
        new.mu[bad] = mu_s[bad]
        new.r[bad] = r_s[bad]

    pidx = np.flatnonzero(plastic)
    if pidx.size:
        _plastic(
            p,
            pidx,
            ft_trial,
            A,
            fn,
            g,
            r_s,
            mu_s,
            mu_rec,
            b,
            up_s,
            tol,
            max_iter,
            new,
            traction,
            tangent,
            status,
            unstable,
            iterations,
        )

    return ReturnMapResult(traction, tangent, new, status, unstable, iterations)


def _plastic(
    p: SubloadingParameters,
    pidx: np.ndarray,
    ft_trial: np.ndarray,
    A_all: np.ndarray,
    fn_all: np.ndarray,
    g_all: np.ndarray,
    r_all: np.ndarray,
    mu_all: np.ndarray,
    mu_rec_all: np.ndarray,
    b: float,
    up_all: np.ndarray,
    tol: float,
    max_iter: int,
    new: InterfaceState,
    traction: np.ndarray,
    tangent: np.ndarray,
    status: np.ndarray,
    unstable: np.ndarray,
    iterations: np.ndarray,
) -> None:
    """Solve the plastic points ``pidx`` and write their outputs in place."""
    nt = ft_trial.shape[1]
    A, fn, g = A_all[pidx], fn_all[pidx], g_all[pidx]
    r_n, mu_n, mu_rec = r_all[pidx], mu_all[pidx], mu_rec_all[pidx]
    br = _Branch(p, A, g, r_n, mu_n, b)
    npl = pidx.size
    rows = np.arange(npl)
    dl_max = A / p.alpha_t
    # Tolerances relative to the size of the yield surface, floored at what the float resolution
    # of dl (and hence of A - alpha_t dl) allows when the trial is far outside (huge steps).
    eps = np.finfo(float).eps
    tol_f = np.maximum(tol * g * p.mu_s, 8.0 * eps * A)

    # A certified first point: one Newton step on phi with mu frozen at mu(0) (a convex lower
    # bound of phi) stays left of the smallest root. Infinite slope (r_n = 0) gives 0.
    phi0 = A - g * r_n * mu_rec
    with np.errstate(divide="ignore"):
        dr0 = br.eval(np.zeros(npl))[3]
        x1 = np.where(np.isfinite(dr0), phi0 / (p.alpha_t + g * mu_rec * dr0), 0.0)
    x1 = np.clip(x1, 0.0, dl_max)
    start = np.where(x1 > 0.0, x1, dl_max)
    x, conv, iters = _rtsafe(br, rows, x1, dl_max, start, tol_f, max_iter)

    # Certify: phi strictly decreasing on [0, x] means x is the smallest root.
    _, dphi, r, dr, mu, _ = br.eval(x)
    dmu0 = br.eval(np.zeros(npl))[5]
    certified = conv & (p.alpha_t + g * dr * mu - g * r * np.abs(dmu0) > 0.0)
    jump = np.zeros(npl, dtype=bool)
    unc = np.flatnonzero(~certified & conv)
    if unc.size:
        x_s, conv_s, it_s, jump_s = _scan(br, unc, x[unc], tol_f[unc], max_iter)
        x[unc], conv[unc], jump[unc] = x_s, conv_s, jump_s
        iters[unc] += it_s
        _, dphi, r, dr, mu, _ = br.eval(x)

    # Outputs
    nstar = ft_trial[pidx] / A[:, None]
    # On the subloading surface exactly (equal to A - alpha_t dl within the root tolerance).
    ft_mag = np.minimum(g * np.clip(r, 0.0, 1.0) * mu, A)
    traction[pidx, :nt] = ft_mag[:, None] * nstar
    traction[pidx, nt] = fn
    new.up[pidx] = up_all[pidx] + x[:, None] * nstar
    new.mu[pidx] = mu
    new.r[pidx] = np.clip(r, 0.0, 1.0)

    # Consistent tangent: d dl = (dA - g' r mu d f_n) / H with H = -phi'(dl).
    H = -dphi
    H_safe = np.maximum(np.where(np.isfinite(H), H, p.alpha_t), 1e-12 * p.alpha_t)
    dg = p.c_n * (1.0 - g)
    nn = nstar[:, :, None] * nstar[:, None, :]
    eye = np.eye(nt)[None]
    D = np.zeros((npl, nt + 1, nt + 1))
    D[:, :nt, :nt] = p.alpha_t * (
        (1.0 - p.alpha_t / H_safe)[:, None, None] * nn + (ft_mag / A)[:, None, None] * (eye - nn)
    )
    D[:, :nt, nt] = (p.alpha_t * p.alpha_n * dg * r * mu / H_safe)[:, None] * nstar
    D[:, nt, nt] = p.alpha_n
    tangent[pidx] = D

    # Rate-form denominator at the end state: den = -kappa (mu - mu_k) r + U(r) mu + alpha_t / g.
    with np.errstate(over="ignore"):
        den = -p.kappa * (mu - p.mu_k) * r + dr * mu + p.alpha_t / g
    st = np.where(jump, Status.JUMP, Status.PLASTIC).astype(np.int8)
    st[~conv] = Status.FAILED
    status[pidx] = st
    unstable[pidx] = conv & (den <= 0.0)
    iterations[pidx] = iters
    if np.any(~conv):
        f = pidx[~conv]
        new.up[f], new.mu[f], new.r[f] = up_all[f], mu_all[f], r_all[f]
        traction[f] = 0.0
        tangent[f] = 0.0
