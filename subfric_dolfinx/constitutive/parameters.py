"""Validated, immutable parameter sets of the friction laws and the paper's presets.

Units throughout: MPa, mm, s. ``alpha_t`` and ``alpha_n`` are penalty (elastic sliding) moduli in
MPa/mm, ``kappa`` is in 1/mm, ``xi`` in 1/s, ``u_tilde`` in 1/mm and ``c_n`` in 1/MPa.

The project implements the absolute form of the evolution law of the hardening function (Eq. 21 of
Hashiguchi et al., 2022)::

    mu' = -kappa (mu - mu_k) |up'| + xi (mu_s - mu)

The paper's parameter sets reproduce its curves only in the normalised reading of the same law,
``mu' = -kappa_N (mu/mu_k - 1)|up'| + xi_N (1 - mu/mu_s)``, i.e. with::

    kappa = kappa_N / mu_k,    xi = xi_N / mu_s

The presets below store the paper's sets in that normalised reading (converted with
:func:`normalised_to_absolute`); the literal readings are available under ``...-literal`` names as
stress tests (the literal Sec. 6 set has no stable quasi-static solution).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from typing import Any

__all__ = [
    "PRESETS",
    "CoulombParameters",
    "Preset",
    "SubloadingParameters",
    "normalised_to_absolute",
    "preset",
]


def _real(name: str, value: Any, ok: Callable[[float], bool], allowed: str) -> float:
    """Return ``value`` as a float, or raise an error naming the parameter and its allowed range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"parameter {name} must be a real number ({allowed}), got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"parameter {name} = {v!r} is not finite; allowed: {allowed}")
    if not ok(v):
        raise ValueError(f"parameter {name} = {v!r} is out of range; allowed: {allowed}")
    return v


def _validate_fields(obj: Any, rules: dict[str, tuple[Callable[[float], bool], str]]) -> None:
    for name, (ok, allowed) in rules.items():
        object.__setattr__(obj, name, _real(name, getattr(obj, name), ok, allowed))


def _positive(v: float) -> bool:
    return v > 0.0


def _non_negative(v: float) -> bool:
    return v >= 0.0


@dataclasses.dataclass(frozen=True)
class SubloadingParameters:
    """Parameters of the subloading-friction model with saturation of tangential stress.

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

    def __post_init__(self) -> None:
        _validate_fields(
            self,
            {
                "alpha_t": (_positive, "alpha_t > 0"),
                "alpha_n": (_positive, "alpha_n > 0"),
                "mu_k": (_positive, "mu_k > 0"),
                "kappa": (_non_negative, "kappa >= 0"),
                "xi": (_non_negative, "xi >= 0"),
                "u_tilde": (_positive, "u_tilde > 0"),
                "c_n": (_positive, "c_n > 0"),
            },
        )
        mu_k = self.mu_k
        object.__setattr__(
            self, "mu_s", _real("mu_s", self.mu_s, lambda v: v >= mu_k, f"mu_s >= mu_k = {mu_k!r}")
        )
        if self.mu0 is not None:
            lo, hi = self.mu_k, self.mu_s
            object.__setattr__(
                self,
                "mu0",
                _real(
                    "mu0",
                    self.mu0,
                    lambda v: lo <= v <= hi,
                    f"mu_k <= mu0 <= mu_s = [{lo!r}, {hi!r}]",
                ),
            )

    @property
    def mu_initial(self) -> float:
        """Initial value of the hardening function (``mu0``, or ``mu_s`` when not given)."""
        return self.mu_s if self.mu0 is None else float(self.mu0)

    name = "subloading"

    def return_map(self, gap: Any, state: Any, dt: float, **kwargs: Any) -> Any:
        """Integrate the law over one step; see :func:`~.subloading.subloading_return_map`."""
        from .subloading import subloading_return_map

        return subloading_return_map(self, gap, state, dt, **kwargs)

    def initial_state(self, n_points: int, n_tangential: int) -> Any:
        """Virgin state of ``n_points`` points: ``up = 0``, ``mu = mu_initial``, ``r = 0``."""
        from .state import InterfaceState

        return InterfaceState.initial(n_points, n_tangential, self.mu_initial)

    def replace(self, **changes: Any) -> SubloadingParameters:
        """Return a validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float | None]:
        """Return the parameters as a plain dictionary (JSON-serialisable)."""
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class CoulombParameters:
    """Parameters of the classical penalty Coulomb law (the baseline).

    ``|f_t| <= mu_c f_n`` with radial return; no hardening, no recovery.

    Attributes:
        alpha_t: Tangential penalty modulus, MPa/mm, > 0.
        alpha_n: Normal penalty modulus, MPa/mm, > 0.
        mu_c: Friction coefficient (dimensionless), > 0.
    """

    alpha_t: float
    alpha_n: float
    mu_c: float

    def __post_init__(self) -> None:
        _validate_fields(
            self,
            {
                "alpha_t": (_positive, "alpha_t > 0"),
                "alpha_n": (_positive, "alpha_n > 0"),
                "mu_c": (_positive, "mu_c > 0"),
            },
        )

    name = "coulomb"

    def return_map(self, gap: Any, state: Any, dt: float, **kwargs: Any) -> Any:
        """Integrate the law over one step; see :func:`~.coulomb.coulomb_return_map`."""
        from .coulomb import coulomb_return_map

        return coulomb_return_map(self, gap, state, dt, **kwargs)

    def initial_state(self, n_points: int, n_tangential: int) -> Any:
        """Virgin state of ``n_points`` points."""
        from .state import InterfaceState

        return InterfaceState.initial(n_points, n_tangential, self.mu_c)

    def replace(self, **changes: Any) -> CoulombParameters:
        """Return a validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        """Return the parameters as a plain dictionary (JSON-serialisable)."""
        return dataclasses.asdict(self)


def normalised_to_absolute(
    kappa_normalised: float, xi_normalised: float, mu_k: float, mu_s: float
) -> tuple[float, float]:
    """Convert ``kappa`` and ``xi`` from the normalised reading to the absolute form (Eq. 21).

    Normalised: ``mu' = -kappa_N (mu/mu_k - 1)|up'| + xi_N (1 - mu/mu_s)``; absolute:
    ``mu' = -kappa (mu - mu_k)|up'| + xi (mu_s - mu)``. Hence ``kappa = kappa_N / mu_k`` and
    ``xi = xi_N / mu_s``.

    Returns:
        ``(kappa, xi)`` in the absolute form.
    """
    return kappa_normalised / mu_k, xi_normalised / mu_s


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named parameter set of the paper.

    Attributes:
        name: Preset name.
        parameters: The parameters (absolute form).
        slip_rate: Tangential sliding velocity of the paper's experiments, mm/s.
        description: Where the set comes from and how it was read.
    """

    name: str
    parameters: SubloadingParameters
    slip_rate: float
    description: str


def _paper_sets() -> dict[str, Preset]:
    sets: dict[str, Preset] = {}
    sec6 = {"alpha_t": 5000.0, "alpha_n": 5000.0, "mu_k": 7000.0, "u_tilde": 15.0, "c_n": 2e-4}
    sec7 = {"alpha_t": 500.0, "alpha_n": 500.0, "mu_k": 63.0, "u_tilde": 15.0, "c_n": 2e-4}
    cases = [
        (
            "sec6-mus10000",
            sec6,
            10000.0,
            15000.0,
            110.0,
            1.0 / 60.0,
            "Sec. 6 (Figs. 5-9), mu_s = 10000 MPa",
        ),
        (
            "sec6-mus7500",
            sec6,
            7500.0,
            15000.0,
            110.0,
            1.0 / 60.0,
            "Sec. 6 (Figs. 5-9), mu_s = 7500 MPa",
        ),
        ("sec7", sec7, 500.0, 98.0, 11.0, 1.0, "Sec. 7 (Figs. 10-11), A16111-T4 / tool steel"),
    ]
    for name, base, mu_s, kappa_n, xi_n, rate, what in cases:
        kappa, xi = normalised_to_absolute(kappa_n, xi_n, base["mu_k"], mu_s)
        sets[name] = Preset(
            name,
            SubloadingParameters(mu_s=mu_s, kappa=kappa, xi=xi, **base),
            rate,
            f"{what}; normalised reading: kappa = {kappa_n:g}/mu_k = {kappa:.6g} 1/mm, "
            f"xi = {xi_n:g}/mu_s = {xi:.6g} 1/s",
        )
        sets[name + "-literal"] = Preset(
            name + "-literal",
            SubloadingParameters(mu_s=mu_s, kappa=kappa_n, xi=xi_n, **base),
            rate,
            f"{what}; literal reading of Eq. 21: kappa = {kappa_n:g} 1/mm, xi = {xi_n:g} 1/s "
            "(a stress test, not a physical set)",
        )
    return sets


PRESETS: dict[str, Preset] = _paper_sets()
"""The paper's parameter sets, by name (``sec6-mus10000``, ``sec6-mus7500``, ``sec7`` and their
``-literal`` variants)."""


def preset(name: str) -> SubloadingParameters:
    """Return the parameters of a named preset.

    Raises:
        KeyError: Unknown name; the message lists the known ones.
    """
    try:
        return PRESETS[name].parameters
    except KeyError:
        raise KeyError(f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}") from None
