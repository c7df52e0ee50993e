"""The subloading-friction law with saturation: parameters and return map (numpy only).

Scheme (``docs/model.md``) for a step of length ``dt`` from the converged state
``(up_n, mu_n, r_n, f_n)`` (``f_n`` the traction at the end of the previous step) to the local
gap ``(ubar_t, ubar_n)``:

1. **Trial** ``f_t* = alpha_t (ubar_t - up_n)``, ``A = |f_t*|``, ``f_n = alpha_n ubar_n``,
   ``g = 1 - exp(-c_n f_n)``. Out of contact (``ubar_n`` negative, or within the contact band
   of :mod:`.tolerances`): zero traction, ``r = 0``, ``up`` frozen, ``mu`` recovers.
2. **Split at the loading switch** (``_subloading.switch``). The elastic trial runs from the
   start traction ``f0`` along ``f(s) = f0 + s (f* - f0)``; ``r`` of an elastic state,
   ``|f(s)| / (g(f_n(s)) mu_e(s))``, can only grow by plastic flow, so the step is elastic up to
   the first minimum of ``r_el`` along the segment and plastic from there: a cusp where ``f_t``
   passes through zero (any 1-D reversal: ``r = 0`` there), or the first root of
   ``d ln r_el / ds`` (a 2-D near-reversal, a turn while ``mu`` recovers, a reload slower than
   the recovery; ``r`` scaled by ``r_el(s) / r_el(0)``). The rest of the step starts there with
   ``mu`` recovered over ``s dt``. Without it the step holding the zero crossing of ``f_t``
   would start its return from the ``r`` of the step start. Not taken where the rest of the
   segment is below the rounding of ``f0 + s w``, nor where ``phi`` would rise at the start of
   the plastic part (softening faster than elastic unloading: no continuous branch from the
   switch; the whole step's loading test decides, as without the split).
3. For a plastic slip ``dl`` at a constant rate over the (rest of the) step ``r`` and ``mu``
   integrate exactly: ``cos(pi r / 2) = cos(pi r_0 / 2) exp(-pi u_tilde dl / 2)`` and
   ``mu = mu_0 - (a (mu_0 - mu_k) + b (mu_0 - mu_s)) E(a + b)``, ``a = kappa dl``, ``b = xi dt``,
   ``E(s) = (1 - exp(-s)) / s``. **Loading test**: plastic iff ``phi(0) > tol g mu``
   (:mod:`.tolerances`), ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)``.
4. **Predictor**: the smallest root of ``phi`` (the radial return), by Newton in
   ``z`` (``dl = z (2 c + z)``: ``r`` is regular in ``z`` at ``r_0 = 0``) from ``dl = 0``, each
   iteration solving a quadratic model exactly, safeguarded by a bracket and bisection;
   *certified* smallest by the slope bound ``alpha_t + g U(r*) mu* - g r* |mu'(0)| > 0``
   (``phi`` strictly decreasing on ``[0, dl*]``), else by a branch-and-bound scan
   (``_subloading.scan``), which also detects folds (``JUMP``).
5. **Rotation of the flow direction** (3-D contact, with a start traction, ``|f_t|`` not
   shrinking all through the step): plastic flow is radial, so only the elastic increment
   ``w = f* - f_s`` turns the traction; its angle ``theta`` to ``w`` obeys
   ``tan(theta / 2) = tan(theta_0 / 2) exp(-|w| J(s))``, ``J(s) = int_0^s dy / |f_t|(y)``,
   exactly, and ``|f_1| = |f_s| + |w| C - alpha_t dl``, ``C = int_0^1 cos(theta) ds``.
   ``|f_t|(s)`` is modelled by the quadratic through ``|f_s|``, its rate-form slope and the
   predictor's end value, blended with the elastic path (exact for a constant ``|f_t|`` and for
   an elastic step); the elastic path's integrals are closed forms and Gauss integrates the
   smooth rest. The **corrector** solves ``phi`` again with ``A_eff = |f_s| + |w| C`` from the
   predictor's root and puts the traction along the rotated direction. Second to third order
   at a turn (the radial return alone is first order).
6. **Consistent tangent**: the closed form of the radial return for a fixed direction from a
   fixed start; otherwise forward derivatives through split, predictor, rotation and corrector
   (exact for what is computed, so that FE Newton converges quadratically).

The start traction is the internal variable ``f`` (:data:`SubloadingLaw.variables`); a state
without it gives the radial return of steps 1, 3, 4 (no split, no rotation). One implementation
in numpy, one module per step (``_subloading``: ``trial``, ``switch``, ``branch``, ``root`` with
``scan``, ``rotation``, ``tangent``; ``integrate`` runs them over chunks of 8192 points), for
any number of points: the results do not depend on the batch size.

The result is never NaN or inf; a point that cannot be integrated (non-finite input, or no
converged root) gets status ``FAILED``, zero traction and its last converged state.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import numpy.typing as npt

from ._subloading.common import Inputs, Law, Outputs, Settings
from ._subloading.integrate import integrate
from ._subloading.point import PointResult, point_step
from .protocol import LawBase, non_negative, positive, real, validate_fields
from .result import ReturnMapResult
from .state import LOCAL, SCALAR, TANGENTIAL, InterfaceState, Variable
from .tolerances import CONTACT_TOL, LOAD_TOL

__all__ = ["LOW_STRENGTH", "SubloadingLaw", "subloading_return_map"]

_MU_UNIT = "a stress: the strength is g(f_n) mu, not a friction coefficient"

LOW_STRENGTH = 0.01
"""A static strength ``g(f_n) mu_s`` below this fraction of the normal stress ``f_n`` is taken for
friction coefficients given as ``mu_s``, ``mu_k`` (:meth:`SubloadingLaw.units_check`): a sliding
contact's friction coefficient lies above 0.01 even lubricated, and the presets' static ratio
``g mu_s / f_n`` is 0.09 or more up to 1000 MPa."""


@dataclasses.dataclass(frozen=True)
class SubloadingLaw(LawBase):
    """The subloading-friction law with saturation of the tangential stress, with its parameters.

    Units: the hardening function ``mu`` and its static and kinetic values ``mu_s``, ``mu_k``
    are **stresses in MPa**, not friction coefficients: the strength is ``g(f_n) mu`` with the
    dimensionless saturation ``g = 1 - exp(-c_n f_n)`` (the Sec. 7 set: ``mu_s = 500`` MPa,
    ``c_n = 2e-4`` 1/MPa, so ``g mu_s = 29`` MPa at 300 MPa, a ratio ``f_t/f_n`` of 0.097).
    Coulomb's ``mu_c`` is the coefficient. Values that look like friction coefficients at a
    scene's pressure are warned about (``units_check``).

    Attributes:
        alpha_t: Tangential penalty (elastic sliding) modulus, MPa/mm, > 0.
        alpha_n: Normal penalty modulus, MPa/mm, > 0.
        mu_s: Static (maximum) value of the hardening function ``mu``, MPa, >= mu_k.
        mu_k: Kinetic (minimum) value of ``mu``, MPa, > 0.
        kappa: Softening of ``mu`` per unit plastic slip (absolute form), 1/mm, >= 0.
        xi: Recovery rate of ``mu`` with time (absolute form), 1/s, >= 0.
        u_tilde: Rate of approach of the subloading surface to the yield surface, 1/mm, > 0.
        c_n: Saturation constant of ``g(f_n) = 1 - exp(-c_n f_n)``, 1/MPa, > 0.
        mu0: Initial ``mu`` in ``[mu_k, mu_s]``; ``None`` means ``mu_s`` (a fresh, rested contact).

    Internal variables: ``up`` (plastic slip, mm, tangential), ``mu`` (hardening function, MPa),
    ``r`` (normal-yield ratio ``F / mu``, in [0, 1]) and ``f`` (the traction at the end of the
    step, MPa, local: the start of the next step's elastic trial, for the reversal split and the
    rotation of the flow direction).

    Raises:
        TypeError: A value is not a real number.
        ValueError: A value is not finite or out of its range; the message names it.
    """

    alpha_t: float
    alpha_n: float
    mu_s: float
    mu_k: float
    kappa: float
    xi: float
    u_tilde: float
    c_n: float
    mu0: float | None = None

    name: ClassVar[str] = "subloading"
    variables: ClassVar[tuple[Variable, ...]] = (
        Variable("up", TANGENTIAL, "plastic slip (mm)", "mm"),
        Variable("mu", SCALAR, "hardening function (MPa)", "MPa"),
        Variable("r", SCALAR, "normal-yield ratio F / mu", "1"),
        Variable(
            "f",
            LOCAL,
            "traction at the end of the step (MPa): the next trial's start",
            "MPa",
            output=False,  # the traction f_t, f_n itself
        ),
    )

    if TYPE_CHECKING:  # the map's floats, set by __post_init__ (no field at run time)
        _consts: Law = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        validate_fields(
            self,
            {
                "alpha_t": (positive, "alpha_t > 0"),
                "alpha_n": (positive, "alpha_n > 0"),
                "mu_k": (positive, f"mu_k > 0, in MPa ({_MU_UNIT})"),
                "kappa": (non_negative, "kappa >= 0"),
                "xi": (non_negative, "xi >= 0"),
                "u_tilde": (positive, "u_tilde > 0"),
                "c_n": (positive, "c_n > 0"),
            },
        )
        mu_k = self.mu_k
        object.__setattr__(
            self,
            "mu_s",
            real(
                "mu_s",
                self.mu_s,
                lambda v: v >= mu_k,
                f"mu_s >= mu_k = {mu_k!r}, in MPa ({_MU_UNIT})",
            ),
        )
        if self.mu0 is not None:
            lo, hi = self.mu_k, self.mu_s
            object.__setattr__(
                self,
                "mu0",
                real(
                    "mu0",
                    self.mu0,
                    lambda v: lo <= v <= hi,
                    f"mu_k <= mu0 <= mu_s = [{lo!r}, {hi!r}], in MPa ({_MU_UNIT})",
                ),
            )
        object.__setattr__(self, "_consts", Law(self))  # the map's floats, once per law

    @property
    def mu_initial(self) -> float:
        """Initial value of the hardening function (``mu0``, or ``mu_s`` when not given)."""
        return self.mu_s if self.mu0 is None else float(self.mu0)

    def initial_value(self, name: str) -> float:
        """Virgin values: ``up = 0``, ``mu = mu_initial``, ``r = 0``, ``f = 0``."""
        return self.mu_initial if name == "mu" else 0.0

    def return_map(
        self,
        gap: npt.ArrayLike,
        state: InterfaceState,
        dt: float,
        *,
        out: InterfaceState | None = None,
        tol: float = LOAD_TOL,
        max_iter: int = 100,
        contact_tol: float = CONTACT_TOL,
    ) -> ReturnMapResult:
        """Integrate the law over one step; see :func:`subloading_return_map`."""
        return subloading_return_map(
            self, gap, state, dt, out=out, tol=tol, max_iter=max_iter, contact_tol=contact_tol
        )

    def point_map(
        self,
        gap: tuple[float, float],
        state: tuple[float, float, float, tuple[float, float] | None],
        dt: float,
        *,
        tol: float = LOAD_TOL,
        max_iter: int = 100,
        contact_tol: float = CONTACT_TOL,
    ) -> PointResult:
        """The return map of ONE point with one tangential component, on floats.

        The same step as :meth:`return_map` on the point ``gap = [[ubar_t, ubar_n]]`` with the
        state ``up = [[up]], mu = [mu], r = [r]`` and the start traction ``f = [f0]`` (None: a
        state without it); its common cases (contact, no split, elastic or a certified root)
        run on Python floats (``_subloading.point``: some ten times cheaper than a call of the
        vectorised map for one point), the others through :func:`subloading_return_map`.

        Args:
            gap: ``(ubar_t, ubar_n)`` at the end of the step (mm; ``ubar_n > 0`` in contact).
            state: ``(up, mu, r, f0)`` at its start: plastic slip (mm), hardening function
                (MPa), normal-yield ratio, and the start traction ``(f_t, f_n)`` (the law's
                ``f``) or None.
            dt: Time increment (s), finite and >= 0.
            tol: As for :meth:`return_map`.
            max_iter: As for :meth:`return_map`.
            contact_tol: As for :meth:`return_map`.

        Returns:
            ``(f_t, f_n, D_tt, D_tn, up, mu, r, status, unstable, iterations)``: the traction,
            the tangential row of the consistent tangent (its normal row is ``(0, alpha_n)``
            in contact, zero otherwise: :meth:`return_map` gives it), the end state, the
            status code (:class:`Status`), the stability flag and the root iterations.

        Raises:
            ValueError: A non-finite or negative ``dt``.
        """
        dt = float(dt)
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt = {dt!r} must be finite and >= 0")
        L = self._consts
        g = (float(gap[0]), float(gap[1]))
        f0 = state[3]
        f = None if f0 is None else (float(f0[0]), float(f0[1]))
        st = (float(state[0]), float(state[1]), float(state[2]), f)
        try:
            res = point_step(L, g, st, dt, Settings(float(tol), int(max_iter), float(contact_tol)))
        except (ArithmeticError, ValueError):  # (a float path's corner: the numpy map decides)
            res = None
        if res is not None:
            return res
        arrays = {"up": np.array([[st[0]]]), "mu": np.array([st[1]]), "r": np.array([st[2]])}
        if f is not None:
            arrays["f"] = np.array([f])
        v = subloading_return_map(
            self,
            np.array([g]),
            InterfaceState.wrap(arrays, 1, 1),
            dt,
            tol=tol,
            max_iter=max_iter,
            contact_tol=contact_tol,
        )
        tr, D, out = v.traction[0], v.tangent[0], v.state
        return (
            float(tr[0]),
            float(tr[1]),
            float(D[0, 0]),
            float(D[0, 1]),
            float(out["up"][0, 0]),
            float(out["mu"][0]),
            float(out["r"][0]),
            int(v.status[0]),
            bool(v.unstable[0]),
            int(v.iterations[0]),
        )

    def units_check(self, f_n: float) -> str | None:
        """Do ``mu_s``, ``mu_k`` look like friction coefficients at the normal stress ``f_n``?

        Args:
            f_n: A normal stress the interface is pressed with (MPa), e.g. a scene's pressure.

        Returns:
            ``None`` when the static strength ``g(f_n) mu_s`` is at least :data:`LOW_STRENGTH`
            ``f_n`` (or ``f_n <= 0``); otherwise what the values give and what would give a
            friction coefficient of ``mu_s`` (the text of a
            :class:`~subfric_dolfinx.logs.UnitsWarning`).
        """
        f_n = float(f_n)
        if not f_n > 0 or not math.isfinite(f_n):
            return None
        g = -math.expm1(-self.c_n * f_n)
        static, kinetic = g * self.mu_s, g * self.mu_k
        if static >= LOW_STRENGTH * f_n:
            return None
        return (
            f"mu_s = {self.mu_s:g} and mu_k = {self.mu_k:g} are stresses in MPa, not friction "
            f"coefficients: at f_n = {f_n:g} MPa the strength g(f_n) mu is {static:.3g} MPa "
            f"static and {kinetic:.3g} MPa kinetic, a ratio f_t / f_n of {static / f_n:.2g} (below "
            f"{LOW_STRENGTH:g}). A friction coefficient m at this f_n is mu = m f_n / g(f_n) with "
            f"g(f_n) = {g:.3g} (c_n = {self.c_n:g} 1/MPa): m = {self.mu_s:g} is mu_s = "
            f"{self.mu_s * f_n / g:.4g} MPa; or take a preset's values (e.g. 'sec7': mu_s 500 MPa)"
        )

    def strength(self, state: InterfaceState, f_n: npt.ArrayLike, dt: float = 0.0) -> np.ndarray:
        """``g(f_n) mu`` with ``mu`` recovered over ``dt`` (0 where ``f_n <= 0``)."""
        fn = np.maximum(np.asarray(f_n, dtype=float), 0.0)
        mu = np.asarray(state["mu"], dtype=float)
        mu_rec = np.minimum(mu + (self.mu_s - mu) * -np.expm1(-self.xi * float(dt)), self.mu_s)
        return -np.expm1(-self.c_n * fn) * mu_rec


def subloading_return_map(
    params: SubloadingLaw,
    gap: npt.ArrayLike,
    state: InterfaceState,
    dt: float | npt.ArrayLike,
    *,
    out: InterfaceState | None = None,
    tol: float = LOAD_TOL,
    max_iter: int = 100,
    contact_tol: float = CONTACT_TOL,
) -> ReturnMapResult:
    """Integrate the subloading-friction law over one step at N points.

    Args:
        params: Material parameters.
        gap: Local gap ``(ubar_t1, [ubar_t2,] ubar_n)`` at the end of the step, shape (N, nt + 1);
            ``ubar_n > 0`` on approach.
        state: Converged state at the start of the step (not modified); with the start traction
            ``f`` (the law's own states) or without it (then the radial return: no split, no
            rotation).
        dt: Time increment of the step (>= 0), s; drives the recovery of ``mu``. A float, or
            one increment per point, shape (N,) (the material-point batch driver advances cases
            with different steps together).
        out: State to write the end-of-step internal variables into (e.g. views of DOLFINx
            Quadrature functions); a new one with the variables of ``state`` is allocated when
            omitted. Must not be ``state``.
        tol: Relative tolerance of the consistency condition, on ``phi / (g mu_s)``, and margin
            of the loading test (:mod:`.tolerances`).
        max_iter: Iteration limit of the root finders.
        contact_tol: Relative width of the contact band (:mod:`.tolerances`).

    Returns:
        Traction, consistent tangent, end-of-step state, per-point status and stability flags.

    Raises:
        ValueError: Bad shapes, a non-finite or negative ``dt``, ``tol`` or ``contact_tol``, or
            ``out`` being ``state``.
    """
    gap = np.asarray(gap, dtype=np.float64)
    up = state["up"]
    n, nt = up.shape
    m = nt + 1
    if gap.shape != (n, m):
        raise ValueError(f"gap must have shape ({n}, {m}) to match the state, got {gap.shape}")
    dt = _check_dt(dt, n)
    tol, contact_tol = float(tol), float(contact_tol)
    if not (math.isfinite(tol) and tol >= 0.0 and math.isfinite(contact_tol) and contact_tol >= 0):
        raise ValueError(f"tol = {tol!r} and contact_tol = {contact_tol!r} must be finite, >= 0")
    if out is state:
        raise ValueError("out must not be the input state (inputs are never mutated)")
    L = params._consts
    has_f = "f" in state
    if out is not None:
        if out.n_points != n or out["up"].shape != up.shape:
            raise ValueError(f"out has {out.n_points} points of {out['up'].shape}, expected {n}")
    if out is None:  # (every entry is written)
        arrays = {"up": np.empty((n, nt)), "mu": np.empty(n), "r": np.empty(n)}
        if has_f:
            arrays["f"] = np.empty((n, m))
        out = InterfaceState.wrap(arrays, n, nt)
    tr = np.zeros((n, m))
    tan = np.zeros((n, m, m))
    status = np.empty(n, dtype=np.int8)
    unstable = np.zeros(n, dtype=bool)
    iters = np.zeros(n, dtype=np.int64)
    inp = Inputs(gap, up, state["mu"], state["r"], state["f"] if has_f else None, dt)
    res = Outputs(tr, tan, out["up"], out["mu"], out["r"], status, unstable, iters)
    integrate(L, inp, res, Settings(tol, max_iter, contact_tol))
    if "f" in out:
        np.copyto(out["f"], tr)
    return ReturnMapResult(tr, tan, out, status, unstable, iters)


def _check_dt(dt, n: int) -> float | np.ndarray:
    """``dt`` as a float, or as a float64 array (n,); finite and >= 0."""
    if isinstance(dt, float | int) or np.ndim(dt) == 0:
        d = float(dt)
        if not (math.isfinite(d) and d >= 0.0):
            raise ValueError(f"dt = {d!r} must be finite and >= 0")
        return d
    a = np.asarray(dt, dtype=np.float64)
    if a.shape != (n,):
        raise ValueError(f"dt must be a float or have shape ({n},), got {a.shape}")
    if not np.all(np.isfinite(a) & (a >= 0.0)):
        i = int(np.flatnonzero(~(np.isfinite(a) & (a >= 0.0)))[0])
        raise ValueError(f"dt[{i}] = {a[i]!r} must be finite and >= 0")
    return a
