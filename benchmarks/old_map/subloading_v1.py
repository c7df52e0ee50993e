"""THE PREVIOUS SUBLOADING RETURN MAP (main at 961eee5), kept for before/after comparisons.

Verbatim but for the imports and without the law class. Its own description follows.

Batched return map of the subloading-friction model with saturation (numpy only).

Scheme (``docs/model.md``): for a step of length ``dt`` from the converged state
``(up_n, mu_n, r_n)`` to the prescribed local gap ``(ubar_t, ubar_n)``:

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

from typing import Any

import numpy as np
import numpy.typing as npt

from subfric_dolfinx.constitutive import InterfaceState, ReturnMapResult, Status
from subfric_dolfinx.constitutive.tolerances import tangential_norm

from .smallest_root_v1 import Branch, rtsafe, scan

__all__ = ["subloading_return_map"]


def subloading_return_map(
    params: Any,
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

    new = p.initial_state(n, nt) if out is None else out
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
    p: Any,
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
    br = Branch(p, A, g, r_n, mu_n, b)
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
    x, conv, iters = rtsafe(br, rows, x1, dl_max, start, tol_f, max_iter)

    # Certify: phi strictly decreasing on [0, x] means x is the smallest root.
    _, dphi, r, dr, mu, _ = br.eval(x)
    dmu0 = br.eval(np.zeros(npl))[5]
    certified = conv & (p.alpha_t + g * dr * mu - g * r * np.abs(dmu0) > 0.0)
    jump = np.zeros(npl, dtype=bool)
    unc = np.flatnonzero(~certified & conv)
    if unc.size:
        x_s, conv_s, it_s, jump_s = scan(br, unc, x[unc], tol_f[unc], max_iter)
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
