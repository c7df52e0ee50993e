"""The topology: bodies and interfaces of a mesh, by the user's own group names, resolved once.

:class:`Topology` is the one value that says which bodies and interfaces there are and which two
bodies each interface joins: the reader (:func:`~.reader.read_interface_mesh`) builds it
(:attr:`~.interface_mesh.InterfaceMesh.topology`), and the problem
(:class:`~subfric_dolfinx.fem.InterfaceProblem`), the scenes and the outputs read it.

A mesh holds **bodies** (a body is one or several cell groups, e.g. a bolt's head and shank with
their own materials) and **interfaces** (facet groups whose nodes are duplicated, each between two
bodies: its *primary* body, whose outward normal defines the interface frame, and its *secondary*
body). :func:`mesh_topology` reads them from the physical groups of a gmsh model and from what the
user says:

* nothing: the classic layout, cell groups ``primary`` and ``secondary`` and the facet group
  ``interface``; ``names={"primary": "base", "secondary": "block", "interface": "contact"}``
  gives these roles the user's own group names;
* ``bodies={"bolt": ["head", "shank"], "plate": "plate"}``: bodies made of cell groups (by
  default every named cell group is a body of its own);
* ``interfaces={"contact": ("plate", "bolt"), ...}``: interfaces with (primary, secondary) bodies
  (or ``{"primary": ..., "secondary": ..., "kinematics": "finite_sliding"}`` for sides meshed
  independently, whose facets need not pair);
  a list of interface groups lets the sides be found: the two bodies whose cells the facets touch,
  the primary being the one whose first cell group has the smaller physical tag.

**Input aliases.** ``master`` and ``slave`` (the names of older codes, and the classic layout's
older group names) are accepted for ``primary`` and ``secondary`` at this boundary only: as roles
of ``names=``, as keys of an interface's mapping, and as keys of a problem's materials
(:meth:`Topology.materials`); the reader reads the classic layout's groups so named in a file as
their ``primary``/``secondary`` names (:data:`~.groups.CLASSIC_ALIASES`). Everything this
package writes says ``primary``/``secondary``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

from .groups import INTERFACE, PRIMARY, SECONDARY, InterfaceMeshError

__all__ = ["KINEMATICS", "ROLES", "InterfaceSides", "Topology", "default_names", "mesh_topology"]

KINEMATICS = ("small_sliding", "finite_sliding")
"""The interface kinds (``docs/model.md`` §11-12): sides paired node to node, or meshed apart."""

ROLES = ("primary", "secondary", "interface", "master", "slave")
"""The roles ``names=`` may map to the user's group names (``master``, ``slave``: input aliases of
``primary``, ``secondary``)."""


@dataclasses.dataclass(frozen=True)
class InterfaceSides:
    """The two bodies an interface joins.

    Attributes:
        primary: The body whose outward normal defines the interface's local frame.
        secondary: The other body.
        kinematics: ``"small_sliding"`` (the sides' nodes pair one to one) or
            ``"finite_sliding"`` (the sides are meshed independently: any numbers of facets).
    """

    primary: str
    secondary: str
    kinematics: str = "small_sliding"


ALIASES = {"master": "primary", "slave": "secondary"}
"""Input aliases of the sides' names (older codes'): accepted where the user names a side."""


@dataclasses.dataclass(frozen=True)
class Topology:
    """The bodies and interfaces of a mesh (or of a problem on it), resolved.

    Attributes:
        bodies: Body name -> its cell groups.
        interfaces: Interface (facet) group -> its :class:`InterfaceSides`, in order (the first
            is the interface of a two-body problem).
    """

    bodies: dict[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    interfaces: dict[str, InterfaceSides] = dataclasses.field(default_factory=dict)

    @property
    def first(self) -> InterfaceSides | None:
        """The sides of the first interface (``None``: no interface)."""
        return next(iter(self.interfaces.values()), None)

    def with_interfaces(self, interfaces: Mapping[str, InterfaceSides]) -> Topology:
        """These interfaces instead of the mesh's.

        A side that is no body is a body of its own cell group (the classic layout's ``primary``
        and ``secondary``).
        """
        bodies = dict(self.bodies)
        for sides in interfaces.values():
            for b in (sides.primary, sides.secondary):
                bodies.setdefault(b, (b,))
        return Topology(bodies, dict(interfaces))

    def body_tags(self, tags: Mapping[str, int]) -> dict[str, tuple[int, ...]]:
        """Body or cell-group name -> its cell tags (``tags``: group name -> tag).

        Raises:
            KeyError: A body's cell group that ``tags`` lacks.
        """
        out = {b: tuple(tags[g] for g in gs) for b, gs in self.bodies.items()}
        for gs in self.bodies.values():
            for g in gs:
                out.setdefault(g, (tags[g],))
        return out

    def materials(self, given: Mapping[str, Any]) -> dict[str, Any]:
        """The materials by body and cell group, the sides' input aliases resolved.

        The keys ``primary``/``secondary`` (and their aliases ``master``/``slave``) name the
        first interface's bodies, where these bodies have no material of their own.
        """
        out = dict(given)
        first = self.first
        if first is None:
            return out
        for role, body in (("primary", first.primary), ("secondary", first.secondary)):
            for key in (role, *(a for a, r in ALIASES.items() if r == role)):
                if key in given and body not in given:
                    out[body] = given[key]
        return out


def default_names(names: Mapping[str, str] | None) -> dict[str, str]:
    """The classic layout's group names with the user's ``names`` (role -> group name).

    The result has the roles ``primary``, ``secondary`` and ``interface``, and the input aliases
    ``master`` and ``slave`` for the first two.

    Raises:
        InterfaceMeshError: An unknown role, or a role given twice under both its names.
    """
    names = dict(names or {})
    unknown = sorted(set(names) - set(ROLES))
    if unknown:
        raise InterfaceMeshError(f"names: unknown role(s) {unknown}; roles: {list(ROLES)}")
    for alias, role in ALIASES.items():
        if alias in names and role in names and names[alias] != names[role]:
            raise InterfaceMeshError(
                f"names: {role!r} and {alias!r} name the same role differently"
            )
        if alias in names:
            names[role] = names.pop(alias)
    for role, value in names.items():
        if not isinstance(value, str) or not value:
            raise InterfaceMeshError(f"names.{role}: expected a group name, got {value!r}")
    out = {PRIMARY: PRIMARY, SECONDARY: SECONDARY, INTERFACE: INTERFACE, **names}
    return {**out, **{alias: out[role] for alias, role in ALIASES.items()}}


def _sides(value: Any, name: str) -> InterfaceSides | None:
    if value is None:
        return None
    if isinstance(value, InterfaceSides):
        return value
    kinematics = "small_sliding"
    if isinstance(value, Mapping):
        keys = set(value)
        pk = "primary" if "primary" in keys else "master"
        sk = "secondary" if "secondary" in keys else "slave"
        if keys - {"kinematics"} != {pk, sk}:
            raise InterfaceMeshError(
                f"interfaces.{name}: expected the keys 'primary' and 'secondary' (or 'master' "
                f"and 'slave') and optionally 'kinematics', got {sorted(keys)}"
            )
        kinematics = value.get("kinematics", kinematics)
        if kinematics not in KINEMATICS:
            raise InterfaceMeshError(
                f"interfaces.{name}.kinematics: expected one of {list(KINEMATICS)}, got "
                f"{kinematics!r}"
            )
        value = (value[pk], value[sk])
    if (
        not isinstance(value, Sequence)
        or isinstance(value, str)
        or len(value) != 2
        or not all(isinstance(v, str) and v for v in value)
    ):
        raise InterfaceMeshError(
            f"interfaces.{name}: expected (primary, secondary) body names, got {value!r}"
        )
    if value[0] == value[1]:
        raise InterfaceMeshError(f"interfaces.{name}: joins the body {value[0]!r} to itself")
    return InterfaceSides(value[0], value[1], kinematics)


def mesh_topology(
    groups: Mapping[str, tuple[int, int]],
    gdim: int,
    *,
    names: Mapping[str, str] | None = None,
    bodies: Mapping[str, str | Sequence[str]] | None = None,
    interfaces: Mapping[str, Any] | Sequence[str] | None = None,
) -> tuple[dict[str, tuple[str, ...]], dict[str, InterfaceSides | None]]:
    """Bodies and interfaces from the named physical groups (see the module docstring).

    Args:
        groups: Physical name -> (dimension, tag) of the model.
        gdim: The mesh's dimension.
        names: Roles of the classic layout -> the user's group names.
        bodies: Body -> its cell group(s) (default: every named cell group is a body).
        interfaces: Interface group -> (primary, secondary) bodies, or a list of interface
            groups (sides found from the mesh: ``None`` here), or ``None``: the classic layout's
            interface, if the model has it.

    Returns:
        The bodies (body -> cell groups) and the interfaces (group -> sides, ``None`` where they
        are to be found from the mesh).

    Raises:
        InterfaceMeshError: A group that is missing or of the wrong dimension, a cell group in two
            bodies, an interface naming an unknown body (every message names the group).
    """
    nm = default_names(names)
    cells = [n for n, (d, _) in groups.items() if d == gdim]
    out_bodies: dict[str, tuple[str, ...]]
    if bodies is None:
        out_bodies = {n: (n,) for n in sorted(cells, key=lambda n: groups[n][1])}
    else:
        out_bodies = {}
        owner: dict[str, str] = {}
        for body, gs in bodies.items():
            gs = (gs,) if isinstance(gs, str) else tuple(gs)
            if not gs:
                raise InterfaceMeshError(f"bodies.{body}: no cell group")
            for g in gs:
                _check_group(groups, g, gdim, f"bodies.{body}")
                if g in owner:
                    raise InterfaceMeshError(
                        f"bodies: the cell group {g!r} is in both {owner[g]!r} and {body!r}"
                    )
                owner[g] = body
            out_bodies[body] = gs
        stray = sorted(set(cells) - set(owner))
        if stray:
            raise InterfaceMeshError(
                f"bodies: the cell group(s) {stray} belong to no body (their cells would have no "
                "material); add them to a body"
            )
    if interfaces is None:
        if nm[INTERFACE] in groups:
            out_ifaces: dict[str, InterfaceSides | None] = {
                nm[INTERFACE]: InterfaceSides(nm[PRIMARY], nm[SECONDARY])
            }
        else:
            out_ifaces = {}
    elif isinstance(interfaces, Mapping):
        out_ifaces = {g: _sides(v, g) for g, v in interfaces.items()}
    else:
        out_ifaces = {g: None for g in interfaces}
    for g, sides in out_ifaces.items():
        _check_group(groups, g, gdim - 1, f"interfaces.{g}")
        if sides is None:
            continue
        for b in (sides.primary, sides.secondary):
            if b not in out_bodies:
                if bodies is None and b in groups:
                    _check_group(groups, b, gdim, f"interfaces.{g}")
                raise InterfaceMeshError(
                    f"interfaces.{g}: the body {b!r} is not a body of the mesh; bodies: "
                    f"{sorted(out_bodies)}"
                )
    return out_bodies, out_ifaces


def _check_group(groups: Mapping[str, tuple[int, int]], name: str, dim: int, where: str) -> None:
    if name not in groups:
        raise InterfaceMeshError(
            f"{where}: physical group {name!r} not found; physical groups found: {sorted(groups)}"
        )
    if groups[name][0] != dim:
        raise InterfaceMeshError(
            f"{where}: physical group {name!r} must have dimension {dim}, found dimension "
            f"{groups[name][0]}"
        )
