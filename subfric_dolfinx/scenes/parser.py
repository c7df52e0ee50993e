"""Strict parsing of scenes: every key checked, every error named by its path.

:func:`parse_scene` validates a JSON-like scene into the dataclasses of :mod:`.schema`, converting
by their type annotations (:func:`from_dict`); an unknown key, a missing key or a wrong type is a
:class:`~.schema.SceneError` naming its path (``scene.solver.dt``). The law, the loading program,
the initial gaps and the regions are built here too, once, before any mesh is made
(:func:`scene_model`, kept as ``FEScene.model``): the problem is built from these objects.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import types
import typing
from typing import Any

from ..constitutive import FrictionLaw, LawError, build_law
from ..driver import CaseError, parse_case
from ..driver.case import read_json
from ..loading import LoadingError, LoadingProgram
from ..values import NotAnInteger, short_repr, strict_int, typed_repr
from .interface_spec import gap_function, parse_initial_gap, parse_regions
from .parse_bodies import check_topology, interface_laws, resolve_aliases
from .parse_features import check_features
from .schema import (
    BUILDER_GDIM,
    LINEAR_STRATEGIES,
    FEScene,
    InterfaceModel,
    MeshSpec,
    OutputSpec,
    PointScene,
    SceneError,
    SceneModel,
    SolverSpec,
    scene_number,
)

__all__ = [
    "build_program",
    "check_name",
    "check_plain",
    "from_dict",
    "load_scene",
    "parse_law",
    "parse_scene",
    "scene_model",
]


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp)).replace("NoneType", "null")


_INT_LIMIT = 2**31
_NUMBER_LIMIT = 2**53  # integers in free-form values (mesh options, programs, cases)


def check_plain(value: Any, path: str) -> None:
    """Check a free-form (JSON-like) value, e.g. mesh options or a loading program.

    Allowed: null, booleans, strings, finite numbers, lists and objects with string keys;
    integers below 2**53 in magnitude.

    Raises:
        SceneError: Naming the path of the first offending item.
    """
    if value is None or isinstance(value, bool | str):
        return
    if isinstance(value, int):
        if abs(value) >= _NUMBER_LIMIT:
            raise SceneError(
                f"{path}: number out of range (|value| < 2**53), got {short_repr(value)}"
            )
        return
    if isinstance(value, float):
        scene_number(value, path)
        return
    if isinstance(value, list | tuple):
        for i, v in enumerate(value):
            check_plain(v, f"{path}[{i}]")
        return
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise SceneError(f"{path}: keys must be strings, got {short_repr(k)}")
            check_plain(v, f"{path}.{k}")
        return
    raise SceneError(f"{path}: expected a JSON value, got {typed_repr(value)}")


def _same_kind(value: Any, tp: Any) -> bool:
    """Whether a JSON value is of the kind of the type ``tp`` (a number for a number, ...)."""
    origin = typing.get_origin(tp)
    if isinstance(value, bool):
        return tp is bool
    if isinstance(value, int | float):
        return tp in (int, float)
    if isinstance(value, list | tuple):
        return origin is list
    if isinstance(value, dict):
        return origin is dict or dataclasses.is_dataclass(tp)
    return False


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
                errors.append((option, str(e)))
        for option, text in errors:  # the value has this option's kind: its own error says more
            if _same_kind(value, option):  # (a number not finite, an item of a list, ...)
                raise SceneError(text)
        names = " or ".join(_type_name(a) for a in typing.get_args(tp))
        raise SceneError(f"{path}: expected {names}, got {short_repr(value)}")
    if tp is type(None):
        if value is None:
            return None
        raise SceneError(f"{path}: expected null, got {short_repr(value)}")
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return from_dict(tp, value, path)
    if origin is list:
        if not isinstance(value, list | tuple):
            raise SceneError(f"{path}: expected a list, got {typed_repr(value)}")
        (item,) = typing.get_args(tp)
        return [_convert(v, item, f"{path}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise SceneError(f"{path}: expected an object, got {typed_repr(value)}")
        _, item = typing.get_args(tp)
        return {str(k): _convert(v, item, f"{path}.{k}") for k, v in value.items()}
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise SceneError(f"{path}: expected true or false, got {short_repr(value)}")
    if tp is int:
        try:
            n = strict_int(value)
        except NotAnInteger:
            raise SceneError(f"{path}: expected an integer, got {short_repr(value)}") from None
        if abs(n) >= _INT_LIMIT:
            raise SceneError(f"{path}: integer out of range (< 2**31), got {short_repr(value)}")
        return n
    if tp is float:
        return scene_number(value, path)
    if tp is str:
        if isinstance(value, str):
            return value
        raise SceneError(f"{path}: expected a string, got {short_repr(value)}")
    raise TypeError(f"unsupported annotation {tp!r} at {path}")


def from_dict(cls: type, obj: Any, path: str) -> Any:
    """Build the dataclass ``cls`` from ``obj``, converting fields by their annotations.

    Raises:
        SceneError: Not an object, unknown or missing keys, wrong types (named by ``path``).
    """
    if isinstance(obj, cls):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"{path}: expected an object, got {typed_repr(obj)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
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
        raise SceneError(f"{path}: must be one of {list(allowed)}, got {short_repr(value)}")


def load_scene(
    source: str | os.PathLike[str] | dict[str, Any] | FEScene | PointScene,
) -> FEScene | PointScene:
    """Read a scene from a JSON file (or take it as given) and validate it (:func:`parse_scene`).

    The file is read strictly: a key given twice in one object (which ``json.load`` would
    resolve silently, keeping the last value) is refused naming its key path, and so are files
    that are not UTF-8, too large, nested too deeply or not JSON at all. File names in the scene
    (a mesh file) are taken as given, relative to the working directory.

    Args:
        source: The name of a JSON file, or the scene itself (a dict, or a parsed scene).

    Raises:
        SceneError: The file cannot be read, is malformed, or its scene is invalid; ``source``
            is neither a file name nor a scene.
    """
    if isinstance(source, dict | FEScene | PointScene):
        return parse_scene(source)
    if not isinstance(source, str | os.PathLike):
        raise SceneError(
            f"load_scene: expected the name of a JSON file or a scene (a dict), got "
            f"{type(source).__name__} {str(source)[:60]!r}"
        )
    try:
        obj = read_json(source, "scene file", root="scene")
    except CaseError as e:
        raise SceneError(str(e)) from None
    return parse_scene(obj)


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
        check_name(scene.name, "scene.name")
        _choice("scene.on_instability", scene.on_instability, ("stop", "continue"))
        if scene.steps_per_mm is not None and not scene.steps_per_mm > 0:
            raise SceneError(f"scene.steps_per_mm: must be > 0, got {scene.steps_per_mm!r}")
        cases = {}
        for name, case in scene.cases.items():
            check_plain(case, f"scene.cases.{name}")
            try:
                cases[name] = parse_case(case)
            except CaseError as e:
                raise SceneError(f"scene.cases.{name}: {e}") from None
        object.__setattr__(scene, "model", cases)  # (frozen: set once, here, as it is made)
        return scene
    scene = resolve_aliases(from_dict(FEScene, obj, "scene"))
    check_name(scene.name, "scene.name")
    _check_mesh(scene.mesh)
    _choice("scene.degree", scene.degree, (1, 2))
    _choice("scene.quadrature", scene.quadrature, ("gauss", "nodal"))
    _check_conditions(scene)
    check_topology(scene)
    prog = scene.program
    if set(prog) != {"times", "channels"}:
        raise SceneError(f"scene.program: keys must be 'times' and 'channels', got {sorted(prog)}")
    check_plain(prog, "scene.program")
    _check_solver(scene.solver)
    # the law, program, gaps and regions now, once (clear errors before any mesh is built)
    model = scene_model(scene)
    _check_steps(scene.solver, model.program)
    _check_outputs(scene.outputs, model.program.t_start, model.program.t_end)
    check_features(scene, model.program, model.variables)
    object.__setattr__(scene, "model", model)  # (frozen: set once, here, as it is made)
    return scene


def scene_model(scene: FEScene) -> SceneModel:
    """The law, loading program, initial gaps and regions of an FE scene, as objects.

    :func:`parse_scene` makes it once (:attr:`~.schema.FEScene.model`); the problem's builder
    makes it for a scene made otherwise.

    Raises:
        SceneError: A bad law, program, initial gap or region, or an interface without a law
            (named by its key path).
    """
    law, own = interface_laws(scene, parse_law)
    gdim = scene.mesh.geometric_dim
    one = len(scene.interfaces) == 1
    interfaces = {}
    for name, spec in scene.interfaces.items():
        path = f"scene.interfaces.{name}"
        gap, gap_path = spec.initial_gap, f"{path}.initial_gap"
        regions, regions_path = spec.regions, f"{path}.regions"
        if one:  # the scene's own gap and regions serve its one interface where it has none
            if gap is None:
                gap, gap_path = scene.initial_gap, "scene.initial_gap"
            else:
                parse_initial_gap(scene.initial_gap)  # not used, but checked
            if not regions:
                regions, regions_path = scene.regions, "scene.regions"
            else:
                parse_regions(scene.regions)  # not used, but checked
        interfaces[name] = InterfaceModel(
            own[name],
            gap_function(gap, gdim, gap_path),
            parse_regions(regions, regions_path),
        )
    classic = not scene.interfaces
    laws = [law, *own.values()]
    return SceneModel(
        law=law,
        program=build_program(scene.program),
        initial_gap=gap_function(scene.initial_gap, gdim) if classic else None,
        regions=parse_regions(scene.regions) if classic else {},
        interfaces=interfaces,
        variables=tuple(dict.fromkeys(v.name for x in laws if x for v in x.variables)),
    )


def check_name(name: str, path: str) -> None:
    """A name used as a file name must be a plain one: no directory, nothing special.

    Raises:
        SceneError: Empty, ``.`` or ``..``, with a slash or a backslash, NUL or another control
            character, or longer than 100 characters.
    """
    bad = (
        not name
        or name in (".", "..")
        or len(name) > 100
        or any(c in "/\\" or ord(c) < 32 or ord(c) == 127 for c in name)
    )
    if bad:
        raise SceneError(
            f"{path}: must be a plain file name (1 to 100 characters, no '/', '\\', control "
            f"characters, not '.' or '..'), got {short_repr(name)}"
        )


def _check_mesh(m: MeshSpec) -> None:
    if (m.builder is None) == (m.file is None):
        raise SceneError("scene.mesh: give exactly one of 'builder' and 'file'")
    if m.builder is not None:
        _choice("scene.mesh.builder", m.builder, tuple(BUILDER_GDIM))
        if m.gdim is not None and m.gdim != BUILDER_GDIM[m.builder]:
            raise SceneError(
                f"scene.mesh.gdim: the builder {m.builder!r} makes a "
                f"{BUILDER_GDIM[m.builder]}-D mesh, got gdim = {m.gdim!r}"
            )
        check_plain(m.options, "scene.mesh.options")
    else:
        if m.gdim not in (2, 3):
            raise SceneError(f"scene.mesh.gdim: must be 2 or 3 with a mesh file, got {m.gdim!r}")
        if m.options:
            raise SceneError(
                f"scene.mesh.options: builder options {sorted(m.options)} given with a mesh "
                "file (they apply to a builder only)"
            )
        if not m.file or "\0" in m.file:
            raise SceneError(f"scene.mesh.file: not a file name: {short_repr(m.file)}")
    kinds = (None, "default", "bodies", "together", "balanced")
    _choice("scene.mesh.partitioner", m.partitioner, kinds)
    if m.file is not None and m.file.endswith(".xdmf") and m.partitioner not in (None, "default"):
        raise SceneError(
            f"scene.mesh.partitioner: a partitioned mesh ({short_repr(m.file)}) is read with "
            f"DOLFINx's partitioner: None or 'default', got {short_repr(m.partitioner)}"
        )
    if isinstance(m.refine, bool) or not isinstance(m.refine, int) or not 0 <= m.refine <= 8:
        raise SceneError(f"scene.mesh.refine: expected an integer from 0 to 8, got {m.refine!r}")


def _check_conditions(scene: FEScene) -> None:
    for i, d in enumerate(scene.dirichlet):
        path = f"scene.dirichlet[{i}]"
        vector = isinstance(d.value, list)
        if d.component is not None and vector:
            raise SceneError(
                f"{path}.value: a list (all components) with 'component' = {d.component}; give "
                "a number for one component, or drop 'component'"
            )
        if d.component is None and not vector:
            raise SceneError(
                f"{path}.value: a number ({d.value!r}) needs 'component'; give a list for all "
                "components"
            )
        if d.component is not None and not 0 <= d.component <= 2:
            raise SceneError(f"{path}.component: must be 0, 1 or 2, got {d.component!r}")
    for i, ld in enumerate(scene.loads):
        path = f"scene.loads[{i}]"
        _choice(f"{path}.type", ld.type, ("pressure", "traction"))
        if ld.type == "pressure" and isinstance(ld.value, list):
            raise SceneError(
                f"{path}.value: a pressure is a number, got a list {short_repr(ld.value)}"
            )
        if ld.type == "traction" and not isinstance(ld.value, list):
            raise SceneError(
                f"{path}.value: a traction is a list (one value per component), got {ld.value!r}"
            )


_OPTION_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def _check_solver(sv: SolverSpec) -> None:
    path = "scene.solver"
    if sv.dt <= 0:
        raise SceneError(f"{path}.dt: must be > 0, got {sv.dt!r}")
    if sv.dt_max is not None and sv.dt_max < sv.dt:
        raise SceneError(f"{path}.dt_max: must be >= dt = {sv.dt!r}, got {sv.dt_max!r}")
    if sv.dt_min is not None and not 0 <= sv.dt_min <= sv.dt:
        raise SceneError(f"{path}.dt_min: must be in [0, dt = {sv.dt!r}], got {sv.dt_min!r}")
    if sv.hold_dt is not None and not sv.hold_dt > 0:
        raise SceneError(f"{path}.hold_dt: must be > 0, got {sv.hold_dt!r}")
    if sv.max_cuts < 0:
        raise SceneError(f"{path}.max_cuts: must be >= 0, got {sv.max_cuts!r}")
    if sv.max_steps < 1:
        raise SceneError(f"{path}.max_steps: must be >= 1, got {sv.max_steps!r}")
    _choice(f"{path}.linear", sv.linear, LINEAR_STRATEGIES)
    for key, value in sv.options.items():
        where = f"{path}.options.{key}"
        if not _OPTION_NAME.match(key):
            raise SceneError(
                f"{where}: not a PETSc option name (letters, digits and '_', without the "
                f"leading '-' and the prefix), got {short_repr(key)}"
            )
        if isinstance(value, float | int) and not isinstance(value, bool):
            scene_number(value, where)
        elif isinstance(value, str):
            if any(ord(c) < 32 for c in value):
                raise SceneError(f"{where}: control characters in {short_repr(value)}")
        elif value is not None and not isinstance(value, bool):
            raise SceneError(
                f"{where}: a PETSc option value is a string, number, true/false or null, got "
                f"{typed_repr(value)}"
            )


def _check_steps(sv: SolverSpec, program: Any) -> None:
    """Refuse a program that needs more than ``max_steps`` steps even at the largest step."""
    dt_max = sv.dt_max if sv.dt_max is not None else sv.dt
    need = 0.0
    t = program.t_start
    while t < program.t_end:
        b = program.next_breakpoint(t)
        size = sv.hold_dt if sv.hold_dt is not None and program.is_hold(t) else dt_max
        need += max(1.0, math.ceil((b - t) / size - 1e-9))
        if b <= t:  # pragma: no cover - a program's times increase
            break
        t = b
    if need > sv.max_steps:
        raise SceneError(
            f"scene.solver: the program (t = {program.t_start:g} to {program.t_end:g} s) needs "
            f"at least {need:.3g} steps at dt_max = {dt_max:g} s"
            + (f" (hold_dt = {sv.hold_dt:g} s in holds)" if sv.hold_dt is not None else "")
            + f", more than max_steps = {sv.max_steps:g}: raise dt/dt_max, or max_steps"
        )


def _check_outputs(out: OutputSpec, t0: float, t1: float) -> None:
    path = "scene.outputs"
    if out.checkpoint_every < 0:
        raise SceneError(f"{path}.checkpoint_every: must be >= 0, got {out.checkpoint_every!r}")
    _choice(f"{path}.fields", out.fields, (None, "vtx", "xdmf"))
    if out.field_times and out.fields is None:
        raise SceneError(f"{path}.field_times: given, but no fields are written (fields is null)")
    if out.snapshot_file and not out.snapshots:
        raise SceneError(f"{path}.snapshot_file: true, but no snapshots are asked for")
    tol = 1e-12 * max(1.0, abs(t0), abs(t1))
    for key in ("snapshots", "field_times", "checkpoint_times"):
        for i, t in enumerate(getattr(out, key)):
            if not t0 - tol <= t <= t1 + tol:
                raise SceneError(
                    f"{path}.{key}[{i}]: {t!r} is outside the loading program [{t0:g}, {t1:g}]"
                )


def parse_law(obj: dict[str, Any] | FrictionLaw) -> FrictionLaw:
    """The law of a scene: ``{"law": name, "params": {...}}`` or a law object (Python API).

    Raises:
        SceneError: Unknown key, law, preset or parameter, or an invalid value (``scene.law: ...``).
    """
    if isinstance(obj, FrictionLaw):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"scene.law: expected an object or a law, got {short_repr(obj)}")
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
    except (LoadingError, TypeError, ValueError, OverflowError) as e:
        raise SceneError(f"scene.program: {e}") from None
