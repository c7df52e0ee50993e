"""Boundary conditions, loads and materials of a two-body interface problem (plain data).

Each condition refers to a physical group by name and to a channel of the loading program
(:class:`~subfric_dolfinx.loading.LoadingProgram`) that scales it over time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["Dirichlet", "DirichletField", "Material", "Pressure", "Traction"]


@dataclasses.dataclass(frozen=True)
class Material:
    """Isotropic linear elasticity. ``E`` in MPa, ``nu`` in [0, 0.5)."""

    E: float
    nu: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.E) and self.E > 0):
            raise ValueError(f"Young's modulus E = {self.E!r} must be finite and > 0")
        if not (np.isfinite(self.nu) and 0.0 <= self.nu < 0.5):
            raise ValueError(f"Poisson's ratio nu = {self.nu!r} must be in [0, 0.5)")


@dataclasses.dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement ``value * amplitude(t)`` on a facet group.

    Where conditions share a dof (e.g. along an edge of two faces), the later one wins.
    ``value`` is a vector (all components) or a scalar with ``component`` given, or a callable
    taking the dof coordinates ``x`` (3, n) and returning values (gdim, n), or (n,) with
    ``component``.
    """

    group: str
    value: float | Sequence[float] | Callable[[np.ndarray], np.ndarray]
    component: int | None = None
    amplitude: str | None = None


@dataclasses.dataclass(frozen=True)
class DirichletField:
    """Prescribed displacement component ``function(x, t)`` on a facet group.

    For prescribed fields that are not one shape times one channel: ``function`` receives the
    dof coordinates ``x`` (3, n) and the time, and returns the values (n,).
    """

    group: str
    function: Callable[[np.ndarray, float], np.ndarray]
    component: int
    amplitude: None = None


@dataclasses.dataclass(frozen=True)
class Traction:
    """Surface traction vector ``value * amplitude(t)`` (MPa) on a facet group."""

    group: str
    value: Sequence[float]
    amplitude: str | None = None


@dataclasses.dataclass(frozen=True)
class Pressure:
    """Pressure ``value * amplitude(t)`` (MPa, positive pushing inwards) on a facet group."""

    group: str
    value: float
    amplitude: str | None = None
