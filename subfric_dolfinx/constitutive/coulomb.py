"""Batched return map of the classical penalty Coulomb law (the baseline).

``f_n = alpha_n ubar_n`` (no contact when ``ubar_n <= 0``), ``f_t* = alpha_t (ubar_t - up_n)``;
elastic when ``|f_t*| <= mu_c f_n``, otherwise radial return onto the cone. The law has no
hardening: to fill the same state arrays as the subloading law, ``mu`` holds ``mu_c`` and ``r`` the
utilisation ``|f_t| / (mu_c f_n)`` (0 when separated).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._norm import tangential_norm
from .parameters import CoulombParameters
from .result import ReturnMapResult, Status
from .state import InterfaceState

__all__ = ["coulomb_return_map"]


def coulomb_return_map(
    params: CoulombParameters,
    gap: npt.ArrayLike,
    state: InterfaceState,
    dt: float,
    *,
    out: InterfaceState | None = None,
) -> ReturnMapResult:
    """Integrate the penalty Coulomb law over one step at N points.

    Args:
        params: Coulomb parameters.
        gap: Local gap ``(ubar_t1, [ubar_t2,] ubar_n)``, shape (N, nt + 1).
        state: Converged state at the start of the step (not modified).
        dt: Time increment (unused by this rate-independent law; validated for symmetry).
        out: State to write the end-of-step internal variables into.

    Returns:
        Traction, consistent tangent, state and status, as for the subloading law.
    """
    p = params
    gap = np.asarray(gap, dtype=np.float64)
    nt, n = state.n_tangential, state.n_points
    m = nt + 1
    if gap.shape != (n, m):
        raise ValueError(f"gap must have shape ({n}, {m}) to match the state, got {gap.shape}")
    if not np.isfinite(float(dt)) or float(dt) < 0.0:
        raise ValueError(f"dt = {dt!r} must be finite and >= 0")
    if out is state:
        raise ValueError("out must not be the input state (inputs are never mutated)")

    ok_in = np.isfinite(gap).all(axis=1) & np.isfinite(state.up).all(axis=1)
    gap_s = np.where(ok_in[:, None], gap, 0.0)
    up_s = np.where(ok_in[:, None], state.up, 0.0)
    ft_trial = p.alpha_t * (gap_s[:, :nt] - up_s)
    A = tangential_norm(ft_trial)
    un = gap_s[:, nt]
    fn = p.alpha_n * un
    contact = ok_in & (un > 0.0)
    limit = p.mu_c * np.maximum(fn, 0.0)
    plastic = contact & (A > limit)
    elastic = contact & ~plastic

    new = InterfaceState.initial(n, nt, p.mu_c) if out is None else out
    traction = np.zeros((n, m))
    tangent = np.zeros((n, m, m))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        nstar = np.where(A[:, None] > 0.0, ft_trial / np.where(A > 0.0, A, 1.0)[:, None], 0.0)
        ratio = np.where(plastic, limit / np.where(A > 0.0, A, 1.0), 1.0)
    dl = np.where(plastic, (A - limit) / p.alpha_t, 0.0)

    traction[:, :nt] = np.where(contact[:, None], ratio[:, None] * ft_trial, 0.0)
    traction[:, nt] = np.where(contact, fn, 0.0)
    np.copyto(new.up, up_s + dl[:, None] * nstar)
    new.up[~ok_in] = np.where(np.isfinite(state.up[~ok_in]), state.up[~ok_in], 0.0)
    new.mu[:] = p.mu_c
    with np.errstate(divide="ignore", invalid="ignore"):
        new.r[:] = np.where(
            contact & (limit > 0.0), np.minimum(A, limit) / np.where(limit > 0, limit, 1.0), 0.0
        )

    eye = np.eye(nt)[None]
    nn = nstar[:, :, None] * nstar[:, None, :]
    tangent[elastic, :nt, :nt] = p.alpha_t * np.eye(nt)
    tangent[plastic, :nt, :nt] = (p.alpha_t * ratio[plastic])[:, None, None] * (eye - nn[plastic])
    tangent[plastic, :nt, nt] = p.mu_c * p.alpha_n * nstar[plastic]
    tangent[contact, nt, nt] = p.alpha_n
    # touching exactly (ubar_n = 0): zero traction, one-sided (contact) elastic tangent
    touching = ok_in & (un == 0.0)
    tangent[touching, :nt, :nt] = p.alpha_t * np.eye(nt)
    tangent[touching, nt, nt] = p.alpha_n

    status = np.full(n, Status.FAILED, dtype=np.int8)
    status[elastic] = Status.ELASTIC
    status[plastic] = Status.PLASTIC
    status[ok_in & ~contact] = Status.SEPARATED
    return ReturnMapResult(
        traction, tangent, new, status, np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64)
    )
