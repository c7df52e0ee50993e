"""The kinds of interface a problem may have, chosen per interface by its ``kinematics``."""

from __future__ import annotations

from typing import Any

from ...meshing.topology import KINEMATICS
from .base import BaseInterface, InterfaceError, InterfaceOptions
from .finite import SlidingInterface, SlidingOptions
from .small import FrictionInterface

__all__ = ["KINEMATICS", "make_interface"]


def make_interface(
    spec: Any,
    V: Any,
    cell_tags: Any,
    facet_tags: Any,
    tag: int,
    primary: Any,
    secondary: Any,
    groups: Any,
    mode: str,
    timings: Any,
) -> BaseInterface:
    """The interface object of one resolved :class:`~..conditions.Interface` (its ``kinematics``).

    Raises:
        InterfaceError: An unknown kind, or settings the kind does not have.
    """
    kind = spec.kinematics or "small_sliding"
    shared = {
        "name": spec.group,
        "quadrature": spec.quadrature,
        "initial_gap": spec.initial_gap,
        "regions": spec.regions,
        "groups": groups,
        "mode": mode,
    }
    if kind == "small_sliding":
        options = InterfaceOptions(**shared)
        return FrictionInterface(
            V,
            cell_tags,
            facet_tags,
            spec.law,
            tag=tag,
            primary=primary,
            secondary=secondary,
            options=options,
            timings=timings,
        )
    if kind == "finite_sliding":
        finite = SlidingOptions(**shared, search_radius=spec.search_radius, reach=spec.reach)
        return SlidingInterface(
            V,
            cell_tags,
            facet_tags,
            spec.law,
            tag=tag,
            primary=primary,
            secondary=secondary,
            options=finite,
            timings=timings,
        )
    raise InterfaceError(
        f"interface {spec.group!r}: kinematics {kind!r} is not one of {list(KINEMATICS)}"
    )
