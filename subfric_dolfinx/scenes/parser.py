"""Strict parsing of scenes: every key checked, every error named by its path.

:func:`parse_scene` validates a JSON-like scene into the dataclasses of :mod:`.schema`, converting
by their type annotations (:func:`from_dict`); an unknown key, a missing key or a wrong type is a
:class:`~.schema.SceneError` naming its path (``scene.solver.dt``). The law and the loading program
are built and validated here too, before any mesh is made.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any

from ..constitutive import FrictionLaw, LawError, build_law
from ..driver import CaseError, parse_case
from ..loading import LoadingError, LoadingProgram
from .schema import FEScene, PointScene, SceneError

__all__ = ["build_program", "from_dict", "parse_law", "parse_scene"]


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp)).replace("NoneType", "null")


def _convert(value: Any, tp: Any, path: str) -> Any:
    origin = typing.get_origin(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        errors = []
        for option in typing.get_args(tp):
            try:
                return _convert(value, option, path)
            except SceneError as e:
                errors.append(str(e))
        names = " or ".join(_type_name(a) for a in typing.get_args(tp))
        raise SceneError(f"{path}: expected {names}, got {value!r}")
    if tp is type(None):
        if value is None:
            return None
        raise SceneError(f"{path}: expected null, got {value!r}")
    if dataclasses.is_dataclass(tp):
        return from_dict(tp, value, path)
    if origin is list:
        if not isinstance(value, list | tuple):
            raise SceneError(f"{path}: expected a list, got {type(value).__name__} {value!r}")
        (item,) = typing.get_args(tp)
        return [_convert(v, item, f"{path}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise SceneError(f"{path}: expected an object, got {type(value).__name__} {value!r}")
        _, item = typing.get_args(tp)
        return {str(k): _convert(v, item, f"{path}.{k}") for k, v in value.items()}
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise SceneError(f"{path}: expected true or false, got {value!r}")
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise SceneError(f"{path}: expected an integer, got {value!r}")
    if tp is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            if not math.isfinite(float(value)):
                raise SceneError(f"{path}: expected a finite number, got {value!r}")
            return float(value)
        raise SceneError(f"{path}: expected a number, got {value!r}")
    if tp is str:
        if isinstance(value, str):
            return value
        raise SceneError(f"{path}: expected a string, got {value!r}")
    raise TypeError(f"unsupported annotation {tp!r} at {path}")


def from_dict(cls: type, obj: Any, path: str) -> Any:
    """Build the dataclass ``cls`` from ``obj``, converting fields by their annotations.

    Raises:
        SceneError: Not an object, unknown or missing keys, wrong types (named by ``path``).
    """
    if isinstance(obj, cls):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"{path}: expected an object, got {type(obj).__name__} {obj!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(obj) - set(fields))
    if unknown:
        raise SceneError(f"{path}: unknown key(s) {unknown}; allowed: {sorted(fields)}")
    kwargs = {}
    for name, f in fields.items():
        if name in obj:
            kwargs[name] = _convert(obj[name], hints[name], f"{path}.{name}")
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise SceneError(f"{path}: missing key '{name}'")
    return cls(**kwargs)


def _choice(path: str, value: Any, allowed: tuple) -> None:
    if value not in allowed:
        raise SceneError(f"{path}: must be one of {list(allowed)}, got {value!r}")


def parse_scene(obj: dict[str, Any] | FEScene | PointScene) -> FEScene | PointScene:
    """Validate a scene configuration.

    Raises:
        SceneError: Unknown key, missing key, wrong type or value; the message gives its path.
    """
    if isinstance(obj, FEScene | PointScene):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"scene: expected an object, got {type(obj).__name__}")
    kind = obj.get("kind")
    _choice("scene.kind", kind, ("fe", "pointwise"))
    if kind == "pointwise":
        scene = from_dict(PointScene, obj, "scene")
        _choice("scene.on_instability", scene.on_instability, ("stop", "continue"))
        for name, case in scene.cases.items():
            try:
                parse_case(case)
            except CaseError as e:
                raise SceneError(f"scene.cases.{name}: {e}") from None
        return scene
    scene = from_dict(FEScene, obj, "scene")
    m = scene.mesh
    if (m.builder is None) == (m.file is None):
        raise SceneError("scene.mesh: give exactly one of 'builder' and 'file'")
    if m.builder is not None:
        _choice("scene.mesh.builder", m.builder, ("block_on_base", "pad_on_plate"))
    if m.file is not None and m.gdim not in (2, 3):
        raise SceneError(f"scene.mesh.gdim: must be 2 or 3 with a mesh file, got {m.gdim!r}")
    _choice("scene.mesh.partitioner", m.partitioner, (None, "default", "bodies", "together"))
    _choice("scene.degree", scene.degree, (1, 2))
    _choice("scene.quadrature", scene.quadrature, ("gauss", "nodal"))
    _choice("scene.outputs.fields", scene.outputs.fields, (None, "vtx", "xdmf"))
    for i, ld in enumerate(scene.loads):
        _choice(f"scene.loads[{i}].type", ld.type, ("pressure", "traction"))
    for body in ("master", "slave"):
        mat = scene.materials.get(body)
        if mat is None:
            raise SceneError(f"scene.materials: missing key '{body}'")
        if set(mat) != {"E", "nu"}:
            raise SceneError(
                f"scene.materials.{body}: keys must be 'E' and 'nu', got {sorted(mat)}"
            )
    extra = sorted(set(scene.materials) - {"master", "slave"})
    if extra:
        raise SceneError(f"scene.materials: unknown key(s) {extra}; allowed: ['master', 'slave']")
    prog = scene.program
    if set(prog) != {"times", "channels"}:
        raise SceneError(f"scene.program: keys must be 'times' and 'channels', got {sorted(prog)}")
    if scene.outputs.checkpoint_every < 0:
        raise SceneError(
            f"scene.outputs.checkpoint_every: must be >= 0, got {scene.outputs.checkpoint_every!r}"
        )
    if scene.solver.dt <= 0:
        raise SceneError(f"scene.solver.dt: must be > 0, got {scene.solver.dt!r}")
    # validate the law and program now (clear errors before any mesh is built)
    parse_law(scene.law)
    build_program(prog)
    return scene


def parse_law(obj: dict[str, Any] | FrictionLaw) -> FrictionLaw:
    """The law of a scene: ``{"law": name, "params": {...}}`` or a law object (Python API).

    Raises:
        SceneError: Unknown key, law, preset or parameter, or an invalid value (``scene.law: ...``).
    """
    if isinstance(obj, FrictionLaw):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"scene.law: expected an object or a law, got {obj!r}")
    allowed = {"law", "params"}
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise SceneError(f"scene.law: unknown key(s) {unknown}; allowed: {sorted(allowed)}")
    try:
        return build_law(obj)
    except LawError as e:
        raise SceneError(f"scene.law: {e}") from None


def build_program(obj: dict[str, Any]) -> LoadingProgram:
    """The loading program of a scene (``{"times": [...], "channels": {...}}``).

    Raises:
        SceneError: An invalid program (``scene.program: ...``).
    """
    try:
        return LoadingProgram(obj["times"], obj["channels"])
    except (LoadingError, TypeError, ValueError) as e:
        raise SceneError(f"scene.program: {e}") from None
