"""Which bodies and interfaces a problem has: the mesh's topology and the user's interfaces.

A mesh read by :mod:`subfric_dolfinx.meshing` carries its
:class:`~subfric_dolfinx.meshing.Topology` (bodies, and interfaces with their primary and
secondary bodies), resolved once by the reader. A problem takes it as it is, or the interfaces
the user gives one by one (:class:`~.conditions.Interface`, whose sides default to the mesh's);
:func:`resolve_interfaces` completes each interface's settings (law, quadrature, kinematics) and
returns the problem's topology, the same kind of value, naming what is missing.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from ..meshing.groups import INTERFACE, PRIMARY, SECONDARY
from ..meshing.topology import InterfaceSides, Topology
from .conditions import Interface
from .interface import InterfaceError

__all__ = ["resolve_interfaces"]


def resolve_interfaces(
    domain: Any,
    law: Any,
    interfaces: Sequence[Interface] | None = None,
    quadrature: str = "gauss",
) -> tuple[Topology, list[Interface]]:
    """The problem's topology and its interfaces, every setting resolved.

    Args:
        domain: The mesh with its ``tags`` (and its ``topology``, if read by
            :mod:`subfric_dolfinx.meshing`).
        law: The friction law of every interface that does not give its own.
        interfaces: The interfaces one by one; ``None``: the mesh's (or, on a mesh that knows
            none, the classic layout's ``interface`` between ``primary`` and ``secondary``).
        quadrature: The quadrature of every interface that does not give its own.

    Raises:
        InterfaceError: A group or body that the mesh lacks, an interface given twice or
            without sides or law.
    """
    tags = dict(domain.tags)
    mesh = getattr(domain, "topology", None)
    mesh = mesh if isinstance(mesh, Topology) else Topology()
    if interfaces is None:
        if mesh.interfaces:
            specs = [Interface(g) for g in mesh.interfaces]
        else:
            specs = [Interface(INTERFACE, PRIMARY, SECONDARY)]
    else:
        specs = list(interfaces)
        if not specs:
            raise InterfaceError("no interface given (interfaces is empty)")
    groups = [s.group for s in specs]
    twice = sorted({g for g in groups if groups.count(g) > 1})
    if twice:
        raise InterfaceError(f"interface(s) {twice} given more than once")
    missing = [g for g in groups if g not in tags]
    if missing:
        raise InterfaceError(
            f"the mesh lacks the physical group(s) {missing}; it has {sorted(tags)}"
        )
    resolved = []
    sides: dict[str, InterfaceSides] = {}
    for s in specs:
        known = mesh.interfaces.get(s.group)
        primary = s.primary or (known.primary if known else None)
        secondary = s.secondary or (known.secondary if known else None)
        if primary is None or secondary is None:
            raise InterfaceError(
                f"interface {s.group!r}: its primary and secondary bodies are not known; give "
                "them (Interface(group, primary=..., secondary=...)) or read the mesh with them"
            )
        the_law = s.law if s.law is not None else law
        if the_law is None:
            raise InterfaceError(f"interface {s.group!r}: no friction law (nor a problem law)")
        kinematics = s.kinematics or getattr(known, "kinematics", None) or "small_sliding"
        resolved.append(
            dataclasses.replace(
                s,
                primary=primary,
                secondary=secondary,
                law=the_law,
                quadrature=s.quadrature or quadrature,
                kinematics=kinematics,
            )
        )
        sides[s.group] = InterfaceSides(primary, secondary, kinematics)
    topology = mesh.with_interfaces(sides)
    absent = [g for gs in topology.bodies.values() for g in gs if g not in tags]
    if absent:
        raise InterfaceError(
            f"the mesh lacks the physical group(s) {sorted(set(absent))}; it has {sorted(tags)}"
        )
    return topology, resolved
