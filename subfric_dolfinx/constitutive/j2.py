"""Small-strain J2 (von Mises) plasticity with linear isotropic and kinematic hardening (numpy).

The bulk law of the bodies, evaluated at their quadrature points (batched over ``N`` points):

* elasticity: ``sigma = K tr(eps_e) 1 + 2 G dev(eps_e)``, ``eps_e = eps - eps_p``;
* yield function ``f = |s - beta| - sqrt(2/3) (sigma_y + H_iso p)`` with ``s = dev(sigma)``, the
  deviatoric backstress ``beta`` and the equivalent plastic strain ``p``;
* associative flow ``d eps_p = d gamma n``, ``n = (s - beta) / |s - beta|``,
  ``d p = sqrt(2/3) d gamma``, and Prager's linear kinematic hardening
  ``d beta = (2/3) H_kin d eps_p`` (no Armstrong-Frederick recall term).

In uniaxial stress the law is bilinear: yield at ``sigma_y``, then the tangent
``E (H_iso + H_kin) / (E + H_iso + H_kin)``; the backstress shifts the elastic range by
``H_kin eps_p`` (the Bauschinger effect), the isotropic part widens it by ``2 H_iso p``.

The step is integrated by backward Euler, i.e. the radial return (Simo and Hughes, *Computational
Inelasticity*, 1998, Box 3.1): with linear hardening the plastic multiplier is a closed form,
``d gamma = f_trial / (2 G + (2/3)(H_iso + H_kin))``, no iteration. The consistent (algorithmic)
tangent is Box 3.2's ``C = K 1 x 1 + 2 G theta I_dev - 2 G theta_bar n x n``. The return is
exact for a step whose trial direction does not turn (proportional loading) and first order in
the step otherwise.

Tensors are Mandel vectors of 6 components ``(11, 22, 33, sqrt2 23, sqrt2 13, sqrt2 12)``: the
dot product of two is the double contraction of the tensors, and 4th-order tangents are 6 x 6
matrices. The law is 3-D; plane strain and axisymmetric states are 3-D states with zero shear
components ``13``, ``23`` (the FE layer keeps the 4 components ``11, 22, 33, 12`` there).
Plane stress (``sigma_33 = 0`` at the point) needs its own return map and is not provided.

No NaN leaves the return map: a point with a non-finite strain, or whose result overflows, is
marked ``failed`` and gets zero stress, the elastic tangent and its committed state.

May import: numpy and the standard library only.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from .protocol import non_negative, positive, validate_fields

__all__ = [
    "J2Material",
    "J2Result",
    "J2State",
    "LinearElastic",
    "from_mandel",
    "j2_return_map",
    "mandel_deviator",
    "to_mandel",
    "von_mises",
]

SQRT2 = math.sqrt(2.0)
SQRT23 = math.sqrt(2.0 / 3.0)
ONE = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
"""The identity tensor as a Mandel vector."""
I_DEV = np.eye(6) - np.outer(ONE, ONE) / 3.0
"""The deviatoric projector (4th order) as a Mandel matrix."""

_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_FACTOR = np.array([1.0, 1.0, 1.0, SQRT2, SQRT2, SQRT2])


def to_mandel(t: npt.ArrayLike) -> np.ndarray:
    """Mandel vectors (..., 6) of symmetric 3 x 3 tensors (..., 3, 3)."""
    t = np.asarray(t, dtype=float)
    return np.stack([t[..., i, j] for i, j in _PAIRS], axis=-1) * _FACTOR


def from_mandel(m: npt.ArrayLike) -> np.ndarray:
    """Symmetric 3 x 3 tensors (..., 3, 3) of Mandel vectors (..., 6)."""
    v = np.asarray(m, dtype=float) / _FACTOR
    t = np.empty((*v.shape[:-1], 3, 3))
    for k, (i, j) in enumerate(_PAIRS):
        t[..., i, j] = v[..., k]
        t[..., j, i] = v[..., k]
    return t


def mandel_deviator(m: npt.ArrayLike) -> np.ndarray:
    """The deviatoric part of Mandel vectors (..., 6)."""
    m = np.asarray(m, dtype=float)
    return m - (m[..., :3].sum(axis=-1, keepdims=True) / 3.0) * ONE


def von_mises(stress: npt.ArrayLike) -> np.ndarray:
    """The von Mises equivalent stress ``sqrt(3/2) |dev sigma|`` of Mandel vectors (..., 6)."""
    return math.sqrt(1.5) * np.linalg.norm(mandel_deviator(stress), axis=-1)


class _Isotropic:
    """Elastic moduli of an isotropic material with fields ``E`` and ``nu``."""

    E: float
    nu: float

    @property
    def G(self) -> float:
        """Shear modulus ``E / (2 (1 + nu))``."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def K(self) -> float:
        """Bulk modulus ``E / (3 (1 - 2 nu))``."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def lam(self) -> float:
        """Lamé's first parameter ``E nu / ((1 + nu) (1 - 2 nu))``."""
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))

    def elastic_tangent(self) -> np.ndarray:
        """The elastic moduli as a 6 x 6 Mandel matrix ``K 1 x 1 + 2 G I_dev``."""
        return self.K * np.outer(ONE, ONE) + 2.0 * self.G * I_DEV


_ELASTIC_RULES = {"E": (positive, "E > 0"), "nu": (lambda v: -1.0 < v < 0.5, "-1 < nu < 0.5")}


@dataclasses.dataclass(frozen=True)
class LinearElastic(_Isotropic):
    """Isotropic linear elasticity (a body without plasticity).

    Attributes:
        E: Young's modulus, MPa, > 0.
        nu: Poisson's ratio, -1 < nu < 0.5.
    """

    E: float
    nu: float

    name: ClassVar[str] = "elastic"

    def __post_init__(self) -> None:
        validate_fields(self, _ELASTIC_RULES)


@dataclasses.dataclass(frozen=True)
class J2Material(_Isotropic):
    """J2 plasticity with linear isotropic and linear kinematic (Prager) hardening.

    Attributes:
        E: Young's modulus, MPa, > 0.
        nu: Poisson's ratio, -1 < nu < 0.5.
        sigma_y: Initial yield stress in uniaxial tension, MPa, > 0.
        H_iso: Isotropic hardening modulus ``d sigma_y / d p``, MPa, >= 0.
        H_kin: Kinematic hardening modulus (uniaxial backstress ``H_kin eps_p``), MPa, >= 0.
            ``H_iso = H_kin = 0``: perfect plasticity.

    The uniaxial elastic-plastic tangent is ``E H / (E + H)`` with ``H = H_iso + H_kin``.
    """

    E: float
    nu: float
    sigma_y: float
    H_iso: float = 0.0
    H_kin: float = 0.0

    name: ClassVar[str] = "j2"

    def __post_init__(self) -> None:
        validate_fields(
            self,
            {
                **_ELASTIC_RULES,
                "sigma_y": (positive, "sigma_y > 0"),
                "H_iso": (non_negative, "H_iso >= 0"),
                "H_kin": (non_negative, "H_kin >= 0"),
            },
        )

    def return_map(
        self, strain: npt.ArrayLike, old: J2State, *, out: J2State | None = None
    ) -> J2Result:
        """Integrate the law over one step; see :func:`j2_return_map`."""
        return j2_return_map(self, strain, old, out=out)


class J2State:
    """Internal variables of ``N`` points: plastic strain, backstress, equivalent plastic strain.

    Args:
        plastic_strain: ``eps_p`` (N, 6), Mandel, deviatoric.
        backstress: ``beta`` (N, 6), Mandel, deviatoric, MPa.
        p: Equivalent (accumulated) plastic strain ``int sqrt(2/3) |d eps_p|``, (N,).

    The arrays are kept as given (not copied): a state may wrap views of arrays owned elsewhere.
    """

    __slots__ = ("backstress", "p", "plastic_strain")
    NAMES: ClassVar[tuple[str, ...]] = ("plastic_strain", "backstress", "p")

    def __init__(self, plastic_strain: np.ndarray, backstress: np.ndarray, p: np.ndarray) -> None:
        n = p.shape[0]
        if plastic_strain.shape != (n, 6) or backstress.shape != (n, 6) or p.shape != (n,):
            raise ValueError(
                f"a J2 state of {n} points needs plastic_strain and backstress of shape ({n}, 6) "
                f"and p of shape ({n},), got {plastic_strain.shape}, {backstress.shape}, "
                f"{p.shape}"
            )
        self.plastic_strain = plastic_strain
        self.backstress = backstress
        self.p = p

    @classmethod
    def zeros(cls, n: int) -> J2State:
        """The virgin state of ``n`` points."""
        return cls(np.zeros((n, 6)), np.zeros((n, 6)), np.zeros(n))

    @property
    def n_points(self) -> int:
        """Number of points."""
        return self.p.shape[0]

    def arrays(self) -> dict[str, np.ndarray]:
        """Name -> array (the arrays themselves, not copies)."""
        return {k: getattr(self, k) for k in self.NAMES}

    def copy(self) -> J2State:
        """A deep copy."""
        return J2State(self.plastic_strain.copy(), self.backstress.copy(), self.p.copy())

    def assign(self, other: J2State) -> None:
        """Copy ``other``'s values into this state's arrays, in place."""
        for k in self.NAMES:
            np.copyto(getattr(self, k), getattr(other, k))


@dataclasses.dataclass
class J2Result:
    """Result of :func:`j2_return_map` over ``N`` points.

    Attributes:
        stress: Cauchy stress (N, 6), Mandel, MPa.
        tangent: Consistent tangent ``d stress / d strain`` (N, 6, 6), Mandel, symmetric.
        state: The internal variables at the end of the step.
        plastic: Points that yielded in the step, (N,) bool.
        failed: Points that could not be integrated (non-finite strain or result), (N,) bool.
    """

    stress: np.ndarray
    tangent: np.ndarray
    state: J2State
    plastic: np.ndarray
    failed: np.ndarray


YIELD_TOL = 1e-12
"""A trial point yields when ``f_trial > YIELD_TOL * sqrt(2/3) sigma_y`` (round-off on the
surface is not plastic loading)."""


def j2_return_map(
    material: J2Material, strain: npt.ArrayLike, old: J2State, *, out: J2State | None = None
) -> J2Result:
    """The stress, consistent tangent and state at the end of a step (radial return).

    Args:
        material: The parameters.
        strain: Total strain at the end of the step, (N, 6) Mandel.
        old: The committed state (start of the step); not modified (unless ``out`` is it).
        out: A state to write the end-of-step variables into (e.g. views of DOLFINx arrays);
            a new one when ``None``.

    Returns:
        The :class:`J2Result`.

    Raises:
        ValueError: ``strain`` or the states do not have N points of 6 components.
    """
    eps = np.asarray(strain, dtype=float)
    n = old.n_points
    if eps.shape != (n, 6):
        raise ValueError(f"strain must have shape ({n}, 6) (Mandel), got {eps.shape}")
    if out is None:
        out = J2State.zeros(n)
    elif out.n_points != n:
        raise ValueError(f"out has {out.n_points} points, the committed state {n}")
    G, K = material.G, material.K
    H = material.H_iso + material.H_kin
    finite = np.isfinite(eps).all(axis=1)
    eps = np.where(finite[:, None], eps, 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        tr = eps[:, :3].sum(axis=1)
        s_trial = 2.0 * G * (mandel_deviator(eps) - old.plastic_strain)
        xi = s_trial - old.backstress
        norm_xi = np.linalg.norm(xi, axis=1)
        radius = SQRT23 * (material.sigma_y + material.H_iso * old.p)
        f = norm_xi - radius
        plastic = finite & (f > YIELD_TOL * SQRT23 * material.sigma_y)
        safe = np.where(plastic, norm_xi, 1.0)
        nvec = np.where(plastic[:, None], xi / safe[:, None], 0.0)
        dgamma = np.where(plastic, f / (2.0 * G + (2.0 / 3.0) * H), 0.0)
        stress = s_trial - (2.0 * G * dgamma)[:, None] * nvec + (K * tr)[:, None] * ONE
        eps_p = old.plastic_strain + dgamma[:, None] * nvec
        beta = old.backstress + ((2.0 / 3.0) * material.H_kin * dgamma)[:, None] * nvec
        p = old.p + SQRT23 * dgamma
        # Box 3.2: theta = 1 - 2 G dgamma / |xi_trial|, theta_bar = 1 / (1 + H / 3G) - (1 - theta)
        theta = 1.0 - 2.0 * G * dgamma / safe
        theta_bar = 1.0 / (1.0 + H / (3.0 * G)) - (1.0 - theta)
        tangent = np.broadcast_to(material.elastic_tangent(), (n, 6, 6)).copy()
        tangent += (2.0 * G * (theta - 1.0))[:, None, None] * I_DEV
        tangent -= (2.0 * G * theta_bar)[:, None, None] * np.einsum("ni,nj->nij", nvec, nvec)
        ok = (
            np.isfinite(stress).all(axis=1)
            & np.isfinite(eps_p).all(axis=1)
            & np.isfinite(beta).all(axis=1)
            & np.isfinite(p)
        )
    failed = ~(finite & ok)
    if failed.any():
        stress[failed] = 0.0
        tangent[failed] = material.elastic_tangent()
        eps_p[failed] = old.plastic_strain[failed]
        beta[failed] = old.backstress[failed]
        p[failed] = old.p[failed]
        plastic = plastic & ~failed
    out.assign(J2State(eps_p, beta, p))
    return J2Result(stress, tangent, out, plastic, failed)
