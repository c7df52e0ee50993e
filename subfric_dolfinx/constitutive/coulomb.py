"""The classical penalty Coulomb law (the baseline), with its parameters and batched return map.

``f_n = alpha_n ubar_n`` (no contact when ``ubar_n <= 0`` or within the contact band of
:mod:`.tolerances`), ``f_t* = alpha_t (ubar_t - up_n)``; elastic when ``|f_t*| <= mu_c f_n`` (to
the loading margin of :mod:`.tolerances`), otherwise radial return onto the cone. The law has no
hardening and no recovery: its only internal variable is the plastic slip ``up``.

The radial return is exact on straight legs at constant ``f_n`` and first order where the
sliding direction turns. It is kept so on purpose: this law is the baseline of the classical
penalty implementation, and a rotation of the flow direction (as in the subloading law) would
need the end-of-step traction as a second internal variable (outputs, checkpoints) for a law that
is a reference, not a target.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from .protocol import LawBase, positive, validate_fields
from .result import ReturnMapResult, Status
from .state import TANGENTIAL, InterfaceState, Variable
from .tolerances import CONTACT_TOL, LOAD_TOL, contact_band, tangential_norm

__all__ = ["CoulombLaw", "coulomb_return_map"]


@dataclasses.dataclass(frozen=True)
class CoulombLaw(LawBase):
    """The classical penalty Coulomb law: ``|f_t| <= mu_c f_n`` with radial return.

    Attributes:
        alpha_t: Tangential penalty modulus, MPa/mm, > 0.
        alpha_n: Normal penalty modulus, MPa/mm, > 0.
        mu_c: Friction coefficient (dimensionless), > 0.

    Internal variable: ``up`` (plastic slip, mm, tangential).
    """

    alpha_t: float
    alpha_n: float
    mu_c: float

    name: ClassVar[str] = "coulomb"
    variables: ClassVar[tuple[Variable, ...]] = (
        Variable("up", TANGENTIAL, "plastic slip (mm)", "mm"),
    )

    def __post_init__(self) -> None:
        validate_fields(
            self,
            {
                "alpha_t": (positive, "alpha_t > 0"),
                "alpha_n": (positive, "alpha_n > 0"),
                "mu_c": (positive, "mu_c > 0"),
            },
        )

    def return_map(
        self,
        gap: npt.ArrayLike,
        state: InterfaceState,
        dt: float,
        *,
        out: InterfaceState | None = None,
        contact_tol: float = CONTACT_TOL,
    ) -> ReturnMapResult:
        """Integrate the law over one step; see :func:`coulomb_return_map`."""
        return coulomb_return_map(self, gap, state, dt, out=out, contact_tol=contact_tol)

    def strength(self, state: InterfaceState, f_n: npt.ArrayLike, dt: float = 0.0) -> np.ndarray:
        """``mu_c f_n`` (0 where ``f_n <= 0``)."""
        fn = np.maximum(np.asarray(f_n, dtype=float), 0.0)
        return self.mu_c * np.broadcast_to(fn, (state.n_points,)).copy()


def coulomb_return_map(
    params: CoulombLaw,
    gap: npt.ArrayLike,
    state: InterfaceState,
    dt: float,
    *,
    out: InterfaceState | None = None,
    contact_tol: float = CONTACT_TOL,
) -> ReturnMapResult:
    """Integrate the penalty Coulomb law over one step at N points.

    Args:
        params: Coulomb parameters.
        gap: Local gap ``(ubar_t1, [ubar_t2,] ubar_n)``, shape (N, nt + 1).
        state: Converged state at the start of the step (not modified).
        dt: Time increment, a float or per point (N,) (unused by this rate-independent law;
            validated for symmetry).
        out: State to write the end-of-step internal variables into.
        contact_tol: Relative width of the contact band (:mod:`.tolerances`; this law has no
            length of its own: the band is ``contact_tol max(|ubar_t|, |up|)``).

    Returns:
        Traction, consistent tangent, state and status, as for the subloading law.
    """
    p = params
    gap = np.asarray(gap, dtype=np.float64)
    nt, n = state.n_tangential, state.n_points
    m = nt + 1
    if gap.shape != (n, m):
        raise ValueError(f"gap must have shape ({n}, {m}) to match the state, got {gap.shape}")
    dta = np.asarray(dt, dtype=np.float64)
    if dta.ndim not in (0, 1) or (dta.ndim == 1 and dta.shape != (n,)):
        raise ValueError(f"dt must be a float or have shape ({n},), got {dta.shape}")
    if not np.all(np.isfinite(dta) & (dta >= 0.0)):
        raise ValueError(f"dt = {dt!r} must be finite and >= 0")
    if out is state:
        raise ValueError("out must not be the input state (inputs are never mutated)")
    contact_tol = float(contact_tol)
    if not (np.isfinite(contact_tol) and contact_tol >= 0.0):
        raise ValueError(f"contact_tol = {contact_tol!r} must be finite and >= 0")

    ok_in = np.isfinite(gap).all(axis=1) & np.isfinite(state.up).all(axis=1)
    gap_s = np.where(ok_in[:, None], gap, 0.0)
    up_s = np.where(ok_in[:, None], state.up, 0.0)
    ft_trial = p.alpha_t * (gap_s[:, :nt] - up_s)
    A = tangential_norm(ft_trial)
    un = gap_s[:, nt]
    fn = p.alpha_n * un
    # contact band: |ubar_n| within the rounding of the gap touches (as ubar_n = 0)
    touching = ok_in & (np.abs(un) <= contact_band(gap_s, up_s, 0.0, contact_tol))
    contact = ok_in & (un > 0.0) & ~touching
    limit = p.mu_c * np.maximum(fn, 0.0)
    plastic = contact & (A - limit > LOAD_TOL * limit)
    elastic = contact & ~plastic

    new = p.initial_state(n, nt) if out is None else out
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

    eye = np.eye(nt)[None]
    nn = nstar[:, :, None] * nstar[:, None, :]
    tangent[elastic, :nt, :nt] = p.alpha_t * np.eye(nt)
    tangent[plastic, :nt, :nt] = (p.alpha_t * ratio[plastic])[:, None, None] * (eye - nn[plastic])
    tangent[plastic, :nt, nt] = p.mu_c * p.alpha_n * nstar[plastic]
    tangent[contact, nt, nt] = p.alpha_n
    # touching: zero traction, one-sided (contact) elastic tangent
    tangent[touching, :nt, :nt] = p.alpha_t * np.eye(nt)
    tangent[touching, nt, nt] = p.alpha_n

    status = np.full(n, Status.FAILED, dtype=np.int8)
    status[elastic] = Status.ELASTIC
    status[plastic] = Status.PLASTIC
    status[ok_in & ~contact] = Status.SEPARATED
    return ReturnMapResult(
        traction, tangent, new, status, np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64)
    )
