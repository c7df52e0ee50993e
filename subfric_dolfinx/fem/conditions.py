"""Boundary conditions, loads, materials and interfaces of an interface problem (plain data).

Each condition refers to a physical group by name and to a channel of the loading program
(:class:`~subfric_dolfinx.loading.LoadingProgram`) that scales it over time. A Dirichlet
condition acts on a group of facets, of cells (every dof of the cells: a whole body held) or of
nodes (gmsh physical points, or node groups added to the mesh); loads and springs on facet groups;
a point force on the vertex nearest to a point.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..constitutive.j2 import LinearElastic
from .dynamics import Dynamics

__all__ = [
    "Dirichlet",
    "DirichletField",
    "Interface",
    "Material",
    "PointForce",
    "Pressure",
    "ProblemSettings",
    "Spring",
    "Traction",
]


Material = LinearElastic
"""Isotropic linear elasticity of a body: ``Material(E, nu)``, ``E`` in MPa (> 0), -1 < nu < 0.5.

The one elastic material of the package (:class:`~subfric_dolfinx.constitutive.LinearElastic`,
under the name the problem's ``materials`` have always used): one class, one validation, for the
built-in linear elasticity, the J2 bulk's elastic bodies and the scene parser alike.
"""


@dataclasses.dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement ``value * amplitude(t)`` on a group of facets, cells or nodes.

    On a facet group, the dofs of its facets; on a cell group (a body), every dof of its cells;
    on a node group, the dofs at its vertices. Where conditions share a dof (e.g. along an edge of
    two faces), the later one wins.
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
    """Surface traction vector (MPa, any direction) on a facet group.

    Component ``i`` is ``value[i] * amplitude(t)``, or ``value[i] * amplitude[i](t)`` when
    ``amplitude`` is a sequence of channel names (``None``: constant), one per component.
    """

    group: str
    value: Sequence[float]
    amplitude: str | None | Sequence[str | None] = None


@dataclasses.dataclass(frozen=True)
class Pressure:
    """Pressure ``value * amplitude(t)`` (MPa, positive pushing inwards) on a facet group."""

    group: str
    value: float
    amplitude: str | None = None


@dataclasses.dataclass(frozen=True)
class Spring:
    """Elastic support (Robin condition) on a facet group: ``t = -k (u - u0)`` per component.

    A distributed spring: ``stiffness`` in MPa/mm (N/mm per mm² of surface), one value for every
    component or one per component (0 leaves a component free). The spring's other end moves as
    ``u0[i] * amplitude[i](t)`` (``amplitude`` one channel for all components, or one per
    component; ``u0`` defaults to 0, a fixed end). A discrete spring of ``K`` N/mm spread over a
    face of area ``A`` is ``stiffness = K / A``. The stiffness enters the Jacobian (it is part of
    the bulk matrix).
    """

    group: str
    stiffness: float | Sequence[float]
    u0: Sequence[float] | None = None
    amplitude: str | None | Sequence[str | None] = None


@dataclasses.dataclass(frozen=True)
class PointForce:
    """A force vector (N) at the mesh vertex nearest to the point ``x``.

    The vertex is searched among the vertices of the cells of ``body`` (``None``: all cells;
    give the body for a point on the interface, whose nodes are duplicated); it is found in
    parallel and the force applied once. Component ``i`` is ``value[i] * amplitude(t)`` (or
    ``amplitude[i]``, as for :class:`Traction`). A point farther from ``body`` (the mesh) than
    the size of its nearest cell is refused; ``name`` names it in messages.
    """

    x: Sequence[float]
    value: Sequence[float]
    amplitude: str | None | Sequence[str | None] = None
    body: str | None = None
    name: str | None = None

    @property
    def group(self) -> str:
        """A name for messages."""
        where = tuple(float(v) for v in self.x)
        return f"point {self.name!r} {where}" if self.name else f"point {where}"


@dataclasses.dataclass(frozen=True)
class Interface:
    """One frictional interface of a problem: its facet group, its sides and its own settings.

    Attributes:
        group: The interface's facet group (both sides tagged; nodes duplicated).
        primary: The body (a body of the mesh, or a cell group) whose outward normal defines the
            interface's local frame; ``None``: as the mesh says.
        secondary: The other body; ``None``: as the mesh says.
        law: Its friction law; ``None``: the problem's ``law``.
        initial_gap: Its initial normal gap ``g0`` (mm, > 0 open): a number or a function of the
            coordinates ``x`` (gdim, n).
        regions: Subgroups of its facets (``InterfaceMesh.interface_groups``) -> their laws.
        quadrature: ``"gauss"`` or ``"nodal"``; ``None``: the problem's.
        kinematics: ``"small_sliding"`` (node-to-node pairs fixed at the reference geometry,
            matching meshes: :class:`~.interface.FrictionInterface`) or ``"finite_sliding"``
            (pairing in the current configuration, non-matching meshes:
            :class:`~.interface.SlidingInterface`); ``None``: as the mesh says (its
            :class:`~subfric_dolfinx.meshing.InterfaceSides`), else small sliding.
        search_radius: Finite sliding: the largest normal distance at which a point faces the
            other body (mm); ``None``: twice the largest facet size.
        reach: Finite sliding: how far a point may slide in one step (mm); ``None``: the
            largest facet size.
        intended_compliance: Its normal penalty's compliance is the model's, chosen on purpose
            (a soft layer, rough surfaces): its penetration is then judged against the interface
            element size only, not as a compliance (:mod:`~subfric_dolfinx.fem.validity`).
    """

    group: str
    primary: str | None = None
    secondary: str | None = None
    law: Any = None
    initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None
    regions: Any = None
    quadrature: str | None = None
    kinematics: str | None = None
    search_radius: float | None = None
    reach: float | None = None
    intended_compliance: bool = False


@dataclasses.dataclass(frozen=True)
class ProblemSettings:
    """How a problem is discretised and modelled (:class:`~.problem.InterfaceProblem`).

    Attributes:
        degree: Displacement degree (1 or 2).
        quadrature: Interface quadrature of every interface that does not give its own,
            ``"gauss"`` or ``"nodal"``.
        mode: ``"3d"``, ``"plane_strain"`` (the 2-D default), ``"plane_stress"`` or
            ``"axisymmetric"`` (coordinates (r, z); every integral, the interfaces' included,
            carries ``2 pi r``: forces are totals over the revolution); ``None``: the mesh's
            dimension's default.
        dynamics: Inertia of the bodies (:class:`~.dynamics.Dynamics`: densities, the
            generalised-alpha integrator's ``rho_inf``, Rayleigh damping, initial velocities);
            ``None``, the default: quasi-static.
    """

    degree: int = 1
    quadrature: str = "gauss"
    mode: str | None = None
    dynamics: Dynamics | None = None


def channels(amplitude: str | None | Sequence[str | None], n: int, what: str) -> list[str | None]:
    """The channel of each of ``n`` components: one name for all, or a sequence of ``n``.

    Raises:
        ValueError: A sequence of the wrong length (naming ``what``).
    """
    if amplitude is None or isinstance(amplitude, str):
        return [amplitude] * n
    out = list(amplitude)
    if len(out) != n:
        raise ValueError(f"{what}: {len(out)} amplitude channels for {n} components")
    return out
