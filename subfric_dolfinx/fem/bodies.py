"""Which bodies and interfaces a problem has: from the mesh, the user's names and settings.

A mesh read by :mod:`subfric_dolfinx.meshing` knows its bodies (body name -> its cell groups) and
its interfaces (facet group -> primary and secondary body). A problem may name the groups of the
classic two-body layout (``names={"master": ..., "slave": ..., "interface": ...}``), or give its
interfaces one by one (:class:`~.conditions.Interface`). :func:`resolve_topology` turns all that
into the bodies and the fully specified interfaces of the problem, naming what is missing.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .conditions import Interface, Material
from .interface import InterfaceError

__all__ = ["DEFAULT_NAMES", "Topology", "resolve_topology"]

DEFAULT_NAMES = {"interface": "interface", "master": "master", "slave": "slave"}
"""The groups of the classic two-body layout (role -> group name)."""


@dataclasses.dataclass(frozen=True)
class Topology:
    """The bodies and interfaces of a problem.

    Attributes:
        bodies: Body name -> its cell groups.
        interfaces: The interfaces, each with its group, sides, law and settings resolved.
        tags: Body or cell-group name -> its cell tags.
    """

    bodies: dict[str, tuple[str, ...]]
    interfaces: list[Interface]
    tags: dict[str, tuple[int, ...]]

    def materials(self, given: Mapping[str, Material]) -> dict[str, Material]:
        """The materials by body and cell group.

        The legacy keys ``master``/``slave`` name the first interface's primary and secondary.
        """
        out = dict(given)
        if self.interfaces:
            first = self.interfaces[0]
            for role, body in (("master", first.primary), ("slave", first.secondary)):
                if role in given and body not in given and body is not None:
                    out[body] = given[role]
        return out


def resolve_topology(
    domain: Any,
    law: Any,
    *,
    names: Mapping[str, str] | None = None,
    interfaces: Sequence[Interface] | None = None,
    initial_gap: float | Callable[[np.ndarray], np.ndarray] | None = None,
    regions: Mapping[str, Any] | None = None,
    quadrature: str = "gauss",
) -> Topology:
    """The problem's bodies and interfaces (see the module docstring).

    Raises:
        InterfaceError: A group or body that the mesh lacks, an interface without sides, a law,
            initial gap or regions that do not say which interface they belong to.
    """
    tags = dict(domain.tags)
    mesh_bodies = dict(getattr(domain, "bodies", None) or {})
    mesh_ifaces = dict(getattr(domain, "interfaces", None) or {})
    nm = {**DEFAULT_NAMES, **(names or {})}
    if interfaces is None:
        if names or not mesh_ifaces:
            specs = [Interface(nm["interface"], nm["master"], nm["slave"])]
        else:
            specs = [Interface(g) for g in mesh_ifaces]
        if len(specs) > 1 and (initial_gap is not None or regions):
            raise InterfaceError(
                f"the mesh has {len(specs)} interfaces {[s.group for s in specs]}: give the "
                "initial gap and the regions per interface (interfaces=[Interface(...), ...])"
            )
        specs = [
            dataclasses.replace(s, initial_gap=initial_gap, regions=regions or None) for s in specs
        ]
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
    for s in specs:
        known = mesh_ifaces.get(s.group)
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
        resolved.append(
            dataclasses.replace(
                s,
                primary=primary,
                secondary=secondary,
                law=the_law,
                quadrature=s.quadrature or quadrature,
                kinematics=s.kinematics or getattr(known, "kinematics", None) or "small_sliding",
            )
        )
    bodies = dict(mesh_bodies)
    for s in resolved:
        for b in (s.primary, s.secondary):
            if b not in bodies:
                bodies[b] = (b,)
    absent = [g for gs in bodies.values() for g in gs if g not in tags]
    if absent:
        raise InterfaceError(
            f"the mesh lacks the physical group(s) {sorted(set(absent))}; it has {sorted(tags)}"
        )
    body_tags = {b: tuple(tags[g] for g in gs) for b, gs in bodies.items()}
    for gs in bodies.values():
        for g in gs:
            body_tags.setdefault(g, (tags[g],))
    return Topology(bodies, resolved, body_tags)
