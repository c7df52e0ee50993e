"""Strict checks of a scene's bodies, interfaces, materials, modelling mode and group names.

Called by :func:`~.parser.parse_scene`; every error names its key path. The classic scene (a
builder's mesh, no ``bodies``, ``interfaces`` or ``mesh.names``) has exactly the materials
``primary`` and ``secondary``; otherwise materials are keyed by body or cell group, and what only
the mesh can tell (that a group exists) is checked once it is read.

**Input aliases** (:func:`resolve_aliases`, the scene's boundary): ``master`` and ``slave`` are
read as ``primary`` and ``secondary`` (materials' keys, an interface's sides, ``mesh.names``'
roles), and the classic layout's older group names (``master_left``, ``slave_xmax``, ...:
:data:`~subfric_dolfinx.meshing.groups.CLASSIC_ALIASES`) as their names wherever the scene names
a group or a body (conditions, loads, springs, points, reaction frames, bodies): the outputs say
``primary``/``secondary`` (e.g. the history's ``R_primary_xmin_x``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from ..constitutive import FrictionLaw
from ..meshing.groups import canonical_group
from ..meshing.topology import ALIASES, KINEMATICS
from ..values import short_repr
from .materials import check_materials_fit, parse_material, scene_dynamics
from .schema import FEScene, SceneError

__all__ = ["MODES", "ROLES", "check_topology", "interface_laws", "is_classic", "resolve_aliases"]

MODES = ("3d", "plane_strain", "plane_stress", "axisymmetric")
"""The modelling modes (``subfric_dolfinx.fem.kinematics.MODES``, named here without importing
the finite-element layer)."""
ROLES = ("primary", "secondary", "interface", "master", "slave")
"""The roles ``mesh.names`` may give the file's own group names (``master``, ``slave``: input
aliases of ``primary``, ``secondary``)."""


def resolve_aliases(scene: FEScene) -> FEScene:
    """The scene with its input aliases resolved (see the module docstring).

    Raises:
        SceneError: A key given under both its names (``master`` and ``primary``), naming its
            path.
    """

    def g(name: Any) -> Any:
        return canonical_group(name) if isinstance(name, str) else name

    def keys(mapping: dict[str, Any], path: str) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in mapping.items():
            if g(k) != k and g(k) in mapping:
                raise SceneError(f"{path}: {k!r} and {g(k)!r} name the same key (an alias)")
            out[g(k)] = v
        return out

    def sides(spec: Any) -> Any:
        p, q = spec.sides
        for a, b in (("primary", "master"), ("secondary", "slave")):
            va, vb = getattr(spec, a), getattr(spec, b)
            if va is not None and vb is not None and va != vb:
                return spec  # check_topology names it
        return dataclasses.replace(
            spec,
            primary=g(p),
            secondary=g(q),
            master=None,
            slave=None,
        )

    def roles(names: dict[str, str]) -> dict[str, str]:
        out: dict[str, str] = {}
        for r, n in names.items():
            role, value = ALIASES.get(r, r), g(n)
            if role in out and out[role] != value:
                raise SceneError(
                    f"scene.mesh.names: {role!r} and {r!r} name the same role differently"
                )
            out[role] = value
        return out

    def body_groups(gs: Any) -> Any:
        return [g(x) for x in gs] if isinstance(gs, list) else g(gs)

    out = scene.outputs
    frames = [dataclasses.replace(f, group=g(f.group)) for f in out.reaction_frames]
    return dataclasses.replace(
        scene,
        mesh=dataclasses.replace(scene.mesh, names=roles(scene.mesh.names)),
        materials=keys(scene.materials, "scene.materials"),
        dirichlet=[dataclasses.replace(c, group=g(c.group)) for c in scene.dirichlet],
        loads=[dataclasses.replace(c, group=g(c.group)) for c in scene.loads],
        springs=[dataclasses.replace(c, group=g(c.group)) for c in scene.springs],
        points={n: dataclasses.replace(p, body=g(p.body)) for n, p in scene.points.items()},
        bodies={b: body_groups(gs) for b, gs in scene.bodies.items()},
        interfaces={n: sides(spec) for n, spec in scene.interfaces.items()},
        outputs=dataclasses.replace(out, reaction_frames=frames),
    )


def is_classic(scene: FEScene) -> bool:
    """A two-body scene on a builder's mesh: the bodies are ``primary`` and ``secondary``."""
    return (
        scene.mesh.builder is not None
        and not scene.bodies
        and not scene.interfaces
        and not scene.mesh.names
    )


def interface_laws(
    scene: FEScene, parse_law: Callable[[Any], FrictionLaw]
) -> tuple[FrictionLaw | None, dict[str, FrictionLaw | None]]:
    """The scene's law and each interface's own (``None``: the scene's), parsed once each.

    Raises:
        SceneError: A bad law, or no law for an interface (named).
    """
    default = parse_law(scene.law) if scene.law is not None else None
    own: dict[str, FrictionLaw | None] = {}
    for name, spec in scene.interfaces.items():
        own[name] = None
        if spec.law is not None:
            try:
                own[name] = parse_law(spec.law)
            except SceneError as e:
                where = f"scene.interfaces.{name}.law"
                raise SceneError(str(e).replace("scene.law", where)) from None
        elif default is None:
            raise SceneError(
                f"scene.interfaces.{name}.law: missing, and the scene has no 'law' for it"
            )
    if default is None and not own:
        raise SceneError("scene: missing key 'law'")
    return default, own


def _check_kinematics(scene: FEScene, name: str, spec: Any, path: str) -> None:
    """The interface's kind and the settings only finite sliding has.

    Raises:
        SceneError: An unknown kind, a setting that is not a positive number, a finite-sliding
            setting on a small-sliding interface (it would be ignored), each naming its key
            path.
    """
    if spec.kinematics is not None and spec.kinematics not in KINEMATICS:
        raise SceneError(
            f"{path}.kinematics: must be one of {list(KINEMATICS)}, got "
            f"{short_repr(spec.kinematics)}"
        )
    finite = spec.kinematics == "finite_sliding"
    for key in ("search_radius", "reach"):
        value = getattr(spec, key)
        if value is None:
            continue
        if not finite:
            raise SceneError(
                f"{path}.{key}: a finite-sliding setting, but the interface slides small (give "
                f"{path}.kinematics = 'finite_sliding')"
            )
        if not value > 0:
            raise SceneError(f"{path}.{key}: must be > 0 (mm), got {short_repr(value)}")


def check_topology(scene: FEScene) -> None:
    """Check the mode, names, bodies, interfaces, materials and the points' bodies.

    Raises:
        SceneError: Naming the key path of the first bad value.
    """
    gdim = scene.mesh.geometric_dim
    if scene.mode is not None:
        if scene.mode not in MODES:
            raise SceneError(
                f"scene.mode: must be one of {list(MODES)}, got {short_repr(scene.mode)}"
            )
        want = 3 if scene.mode == "3d" else 2
        if gdim and gdim != want:
            raise SceneError(
                f"scene.mode: {scene.mode!r} needs a {want}-D mesh, this one is {gdim}-D"
            )
    for role, group in scene.mesh.names.items():
        if role not in ROLES:
            raise SceneError(f"scene.mesh.names: unknown role {role!r}; roles: {list(ROLES)}")
        if not group:
            raise SceneError(f"scene.mesh.names.{role}: expected a group name, got {group!r}")
    groups: dict[str, str] = {}
    for body, gs in scene.bodies.items():
        gs = [gs] if isinstance(gs, str) else gs
        if not isinstance(gs, list) or not gs or not all(isinstance(g, str) and g for g in gs):
            raise SceneError(
                f"scene.bodies.{body}: expected a cell group or a list of them, got "
                f"{short_repr(gs)}"
            )
        for g in gs:
            if g in groups:
                raise SceneError(f"scene.bodies.{body}: the group {g!r} is also in {groups[g]!r}")
            groups[g] = body
    known = set(scene.bodies) | set(groups)
    for name, spec in scene.interfaces.items():
        path = f"scene.interfaces.{name}"
        for a, b in (("primary", "master"), ("secondary", "slave")):
            va, vb = getattr(spec, a), getattr(spec, b)
            if va is not None and vb is not None and va != vb:
                raise SceneError(f"{path}: '{a}' and '{b}' name the same side differently")
        p, q = spec.sides
        if (p is None) != (q is None):
            raise SceneError(f"{path}: give both sides (primary and secondary) or neither")
        if p is not None and p == q:
            raise SceneError(f"{path}: joins the body {p!r} to itself")
        if scene.bodies:
            for side in (p, q):
                if side is not None and side not in known:
                    raise SceneError(
                        f"{path}: {side!r} is not a body of scene.bodies {sorted(scene.bodies)}"
                    )
        if spec.quadrature not in (None, "gauss", "nodal"):
            raise SceneError(
                f"{path}.quadrature: must be 'gauss' or 'nodal', got {spec.quadrature!r}"
            )
        _check_kinematics(scene, name, spec, path)
    if len(scene.interfaces) > 1 and (scene.initial_gap is not None or scene.regions):
        raise SceneError(
            "scene.initial_gap/regions: the scene has several interfaces; give them per interface "
            "(scene.interfaces.<name>.initial_gap, .regions)"
        )
    _check_materials(scene, known)
    allowed = ("primary", "secondary") if is_classic(scene) else None
    for name, pt in scene.points.items():
        if pt.body is None:
            continue
        if allowed is not None and pt.body not in allowed:
            raise SceneError(
                f"scene.points.{name}.body: must be 'primary', 'secondary' (or their aliases "
                f"'master', 'slave') or null, got {pt.body!r}"
            )
        if scene.bodies and pt.body not in known:
            raise SceneError(
                f"scene.points.{name}.body: {pt.body!r} is not a body of scene.bodies "
                f"{sorted(scene.bodies)} (nor one of their groups)"
            )


def _check_materials(scene: FEScene, known: set[str]) -> None:
    for name, mat in scene.materials.items():
        parse_material(mat, f"scene.materials.{name}")
    check_materials_fit(scene)
    scene_dynamics(scene)  # densities on every material or none, scene.dynamics's values
    if is_classic(scene):
        for body in ("primary", "secondary"):
            if body not in scene.materials:
                alias = {"primary": "master", "secondary": "slave"}[body]
                raise SceneError(f"scene.materials: missing key '{body}' (or its alias '{alias}')")
        extra = sorted(set(scene.materials) - {"primary", "secondary"})
        if extra:
            raise SceneError(
                f"scene.materials: unknown key(s) {extra}; allowed: ['primary', 'secondary'] "
                "(or their aliases 'master', 'slave')"
            )
        return
    if scene.bodies:
        extra = sorted(set(scene.materials) - known - {"primary", "secondary"})
        if extra:
            raise SceneError(
                f"scene.materials: {extra} are neither bodies of scene.bodies nor their cell "
                f"groups; bodies: {sorted(scene.bodies)}"
            )
        _every_body_has_a_material(scene)


def _every_body_has_a_material(scene: FEScene) -> None:
    """Each body of ``scene.bodies`` has a material.

    Its own, one for each of its cell groups, or ``primary``/``secondary`` where it is the first
    interface's primary/secondary side. Checked before the mesh is read where the scene tells
    it (the first interface's sides given, or no ``primary``/``secondary`` key); otherwise once
    the mesh is read.

    Raises:
        SceneError: Naming the body without a material.
    """
    mats = scene.materials
    by_role: dict[str, str] = {}
    if scene.interfaces:
        p, q = next(iter(scene.interfaces.values())).sides
        if p is None and ({"primary", "secondary"} & set(mats)):
            return  # which body primary/secondary name is the mesh's to tell
        owner = {
            g: b for b, gs in scene.bodies.items() for g in ([gs] if isinstance(gs, str) else gs)
        }
        by_role = {
            "primary": owner.get(p or "", p or ""),
            "secondary": owner.get(q or "", q or ""),
        }
    elif {"primary", "secondary"} & set(mats):
        return
    for body, groups in scene.bodies.items():
        groups = [groups] if isinstance(groups, str) else list(groups)
        if body in mats or all(g in mats for g in groups):
            continue
        if any(by_role.get(role) == body for role in ("primary", "secondary") if role in mats):
            continue
        raise SceneError(
            f"scene.materials: no material for the body {body!r} (give one for it, or for each "
            f"of its cell groups {groups}); materials are given for {sorted(mats)}"
        )
