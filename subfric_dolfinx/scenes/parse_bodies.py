"""Strict checks of a scene's bodies, interfaces, materials, modelling mode and group names.

Called by :func:`~.parser.parse_scene`; every error names its key path. The classic scene (a
builder's mesh, no ``bodies``, ``interfaces`` or ``mesh.names``) has exactly the materials
``master`` and ``slave``; otherwise materials are keyed by body or cell group, and what only the
mesh can tell (that a group exists) is checked once it is read.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..constitutive import FrictionLaw
from ..meshing.topology import KINEMATICS
from ..values import short_repr
from .materials import check_materials_fit, parse_material
from .schema import FEScene, SceneError

__all__ = ["MODES", "ROLES", "check_topology", "interface_laws", "is_classic"]

MODES = ("3d", "plane_strain", "plane_stress", "axisymmetric")
"""The modelling modes (``subfric_dolfinx.fem.kinematics.MODES``, named here without importing
the finite-element layer)."""
ROLES = ("master", "slave", "interface", "primary", "secondary")
"""The roles ``mesh.names`` may give the file's own group names."""


def is_classic(scene: FEScene) -> bool:
    """A two-body scene on a builder's mesh: the bodies are ``master`` and ``slave``."""
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
    allowed = ("master", "slave") if is_classic(scene) else None
    for name, pt in scene.points.items():
        if pt.body is None:
            continue
        if allowed is not None and pt.body not in allowed:
            raise SceneError(
                f"scene.points.{name}.body: must be 'master', 'slave' or null, got {pt.body!r}"
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
    if is_classic(scene):
        for body in ("master", "slave"):
            if body not in scene.materials:
                raise SceneError(f"scene.materials: missing key '{body}'")
        extra = sorted(set(scene.materials) - {"master", "slave"})
        if extra:
            raise SceneError(
                f"scene.materials: unknown key(s) {extra}; allowed: ['master', 'slave']"
            )
        return
    if scene.bodies:
        extra = sorted(set(scene.materials) - known - {"master", "slave"})
        if extra:
            raise SceneError(
                f"scene.materials: {extra} are neither bodies of scene.bodies nor their cell "
                f"groups; bodies: {sorted(scene.bodies)}"
            )
        _every_body_has_a_material(scene)


def _every_body_has_a_material(scene: FEScene) -> None:
    """Each body of ``scene.bodies`` has a material.

    Its own, one for each of its cell groups, or ``master``/``slave`` where it is the first
    interface's primary/secondary side. Checked before the mesh is read where the scene tells
    it (the first interface's sides given, or no ``master``/``slave`` key); otherwise once the
    mesh is read.

    Raises:
        SceneError: Naming the body without a material.
    """
    mats = scene.materials
    by_role: dict[str, str] = {}
    if scene.interfaces:
        p, q = next(iter(scene.interfaces.values())).sides
        if p is None and ({"master", "slave"} & set(mats)):
            return  # which body master/slave name is the mesh's to tell
        owner = {
            g: b for b, gs in scene.bodies.items() for g in ([gs] if isinstance(gs, str) else gs)
        }
        by_role = {"master": owner.get(p or "", p or ""), "slave": owner.get(q or "", q or "")}
    elif {"master", "slave"} & set(mats):
        return
    for body, groups in scene.bodies.items():
        groups = [groups] if isinstance(groups, str) else list(groups)
        if body in mats or all(g in mats for g in groups):
            continue
        if any(by_role.get(role) == body for role in ("master", "slave") if role in mats):
            continue
        raise SceneError(
            f"scene.materials: no material for the body {body!r} (give one for it, or for each "
            f"of its cell groups {groups}); materials are given for {sorted(mats)}"
        )
