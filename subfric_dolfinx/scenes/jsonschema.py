"""A JSON Schema of scenes, for editors: completion, hover text and checks while a scene is written.

Generated from the dataclasses of :mod:`.schema` (each field's type, default and docstring) and
from the laws' parameter dataclasses (names, units in their descriptions, presets), so it follows
them; the published copy is ``docs/scene.schema.json`` (``tests/scenes/test_scene_schema.py`` fails
when it is behind the code; regenerate it with ``python3 -m subfric_dolfinx.scenes.jsonschema --out
docs/scene.schema.json``). Draft 2020-12. In VS Code, for example::

    "json.schemas": [{"fileMatch": ["*.scene.json"], "url": "./docs/scene.schema.json"}]

The schema says what the strict parser (:func:`~.parser.parse_scene`) accepts structurally: the
keys, their types and required ones, no unknown key. Checks that need more than one value (a
channel named in a condition exists in the program, ``dt_min <= dt``, a group exists in the
mesh, ...) are the parser's alone: a scene the schema accepts can still be refused, with a
message naming the key.
"""

from __future__ import annotations

import dataclasses
import json
import re
import sys
import types
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..commandline import ArgumentError, ArgumentParser, error_line
from ..constitutive import LAWS, PRESETS
from ..meshing.topology import KINEMATICS
from . import schema

__all__ = ["SCHEMA_ID", "main", "scene_schema"]

SCHEMA_ID = "https://subfric-dolfinx.invalid/scene.schema.json"
"""The schema's ``$id`` (a name, not a download location: the schema is a file of the docs)."""


def _field_docs(cls: type) -> dict[str, str]:
    """Field name -> its text in the Google-style ``Attributes:`` section of ``cls``'s docstring."""
    doc = cls.__doc__ or ""
    m = re.search(r"^\s*Attributes:\s*$(.*?)(?=^\s*\w[\w ]*:\s*$|\Z)", doc, re.M | re.S)
    out: dict[str, str] = {}
    if not m:
        return out
    name = None
    for line in m.group(1).splitlines():
        head = re.match(r"^\s{4,8}(\w+)(?: \([^)]*\))?:\s*(.*)$", line)
        if head:
            name = head.group(1)
            out[name] = head.group(2).strip()
        elif name and line.strip():
            out[name] += " " + line.strip()
    return out


def _summary(cls: type) -> str:
    """The docstring up to its first section, on one line."""
    doc = (cls.__doc__ or "").strip()
    doc = re.split(r"^\s*(?:Attributes|Args|Raises|Returns):\s*$", doc, flags=re.M)[0]
    return " ".join(doc.split())


def _type(tp: Any, defs: dict[str, Any]) -> dict[str, Any]:
    """The JSON Schema of a type annotation (dataclasses become ``$defs``)."""
    origin = typing.get_origin(tp)
    if tp is Any:
        return {}
    if tp is type(None):
        return {"type": "null"}
    if tp is bool:
        return {"type": "boolean"}
    if tp is int:
        return {"type": "integer"}
    if tp is float:
        return {"type": "number"}
    if tp is str:
        return {"type": "string"}
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_type(a, defs) for a in typing.get_args(tp)]}
    if origin is list:
        (item,) = typing.get_args(tp) or (Any,)
        return {"type": "array", "items": _type(item, defs)}
    if origin is dict:
        _, value = typing.get_args(tp) or (str, Any)
        return {"type": "object", "additionalProperties": _type(value, defs)}
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        name = tp.__name__
        if name not in defs:
            defs[name] = {}  # (recursion guard)
            defs[name] = _dataclass(tp, defs)
        return {"$ref": f"#/$defs/{name}"}
    raise TypeError(f"no JSON Schema for the annotation {tp!r}")


def _dataclass(cls: type, defs: dict[str, Any]) -> dict[str, Any]:
    """An object with the dataclass's fields: required ones, no other key."""
    hints = typing.get_type_hints(cls)
    docs = _field_docs(cls)
    props: dict[str, Any] = {}
    required = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        special = _SPECIAL.get((cls.__name__, f.name))
        prop = dict(special(defs) if special else _type(hints[f.name], defs))
        if f.name in docs:
            prop.setdefault("description", docs[f.name])
        if f.default is not dataclasses.MISSING and _plain(f.default):
            prop["default"] = f.default
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            required.append(f.name)
        props[f.name] = prop
    out: dict[str, Any] = {
        "type": "object",
        "description": _summary(cls),
        "properties": props,
        "additionalProperties": False,
    }
    if required:
        out["required"] = required
    return out


def _plain(v: Any) -> bool:
    return v is None or isinstance(v, bool | int | float | str)


def _law_params(cls: type) -> dict[str, Any]:
    """The parameters of a law (its dataclass fields), with their descriptions (units)."""
    docs = _field_docs(cls)
    props: dict[str, dict[str, Any]] = {}
    for f in dataclasses.fields(cls):
        if f.init and not f.name.startswith("_"):
            props[f.name] = {"type": "number", "description": docs.get(f.name, f.name)}
            if f.default is None:
                props[f.name] = {"type": ["number", "null"], "description": docs.get(f.name, "")}
    return props


def _law(defs: dict[str, Any]) -> dict[str, Any]:
    """``{"law": name, "params": {...}}``, one branch per registered law."""
    if "Law" not in defs:
        branches = []
        for name, cls in sorted(LAWS.items()):
            params = _law_params(cls)
            if name == "subloading":
                params["preset"] = {
                    "enum": sorted(PRESETS),
                    "description": "start from one of the paper's parameter sets (the other "
                    "keys override its values)",
                }
            branch: dict[str, Any] = {
                "properties": {
                    "law": {"const": name},
                    "params": {
                        "type": "object",
                        "properties": params,
                        "additionalProperties": False,
                        "description": _summary(cls),
                    },
                },
            }
            if name == "subloading":  # the default law: "law" may be left out
                branch["properties"]["law"] = {"enum": [name]}
            else:
                branch["required"] = ["law"]
            branches.append(branch)
        defs["Law"] = {
            "type": "object",
            "description": "The friction law: {'law': name, 'params': {...}}; 'law' defaults to "
            "'subloading'. Units MPa, mm, s: mu_s, mu_k, mu0 are stresses in MPa.",
            "properties": {"law": {"enum": sorted(LAWS)}, "params": {"type": "object"}},
            "required": ["params"],
            "additionalProperties": False,
            "oneOf": branches,
        }
    return {"$ref": "#/$defs/Law"}


def _program(defs: dict[str, Any]) -> dict[str, Any]:
    num = {"type": "number"}
    return {
        "type": "object",
        "description": "The loading program: times (s) and, per channel, its value at each time "
        "(linear in between); conditions name the channels as their 'amplitude'.",
        "properties": {
            "times": {"type": "array", "items": num, "minItems": 2},
            "channels": {
                "type": "object",
                "additionalProperties": {"type": "array", "items": num},
            },
        },
        "required": ["times", "channels"],
    }


def _regions(defs: dict[str, Any]) -> dict[str, Any]:
    return {
        "type": "object",
        "additionalProperties": _law(defs),
        "description": "interface regions: a physical group of interface facets -> its law",
    }


def _initial_gap(defs: dict[str, Any]) -> dict[str, Any]:
    return {
        "description": "initial normal gap g0 (mm, > 0 open): a number, {'expression': ..., "
        "'parameters': {...}} (x, y, z, pi, e, + - * / **, sqrt abs exp log sin cos tan min "
        "max), {'parabola': {'R', 'center'}} or {'circle': {...}}",
        "anyOf": [{"type": "number"}, {"type": "null"}, {"type": "object"}],
    }


def _materials(defs: dict[str, Any]) -> dict[str, Any]:
    body = {
        "type": "object",
        "properties": {
            "E": {"type": "number", "exclusiveMinimum": 0, "description": "Young's modulus (MPa)"},
            "nu": {
                "type": "number",
                "minimum": 0,
                "exclusiveMaximum": 0.5,
                "description": "Poisson's ratio",
            },
            "density": {
                "type": "number",
                "exclusiveMinimum": 0,
                "description": "density (tonne/mm^3, steel 7.85e-9): a dynamic scene",
            },
        },
        "required": ["E", "nu"],
        "additionalProperties": False,
    }
    return {
        "type": "object",
        "additionalProperties": body,
        "description": "body (cell group) name -> its isotropic elasticity",
    }


def _positive_or_null() -> dict[str, Any]:
    return {"anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"type": "null"}]}


_SPECIAL = {  # fields typed Any or plain dicts in the dataclasses: what the parser accepts there
    ("FEScene", "law"): _law,
    ("FEScene", "program"): _program,
    ("FEScene", "regions"): _regions,
    ("FEScene", "initial_gap"): _initial_gap,
    ("FEScene", "materials"): _materials,
    ("InterfaceSpec", "kinematics"): lambda defs: {"enum": [*KINEMATICS, None]},
    ("InterfaceSpec", "search_radius"): lambda defs: _positive_or_null(),
    ("InterfaceSpec", "reach"): lambda defs: _positive_or_null(),
}


def scene_schema() -> dict[str, Any]:
    """The JSON Schema of a scene file (an FE scene or a pointwise one)."""
    defs: dict[str, Any] = {}
    fe = _type(schema.FEScene, defs)
    point = _type(schema.PointScene, defs)
    defs["FEScene"]["properties"]["kind"] = {"const": "fe", "default": "fe"}
    defs["PointScene"]["properties"]["kind"] = {"const": "pointwise"}
    defs["PointScene"]["required"] = sorted({*defs["PointScene"].get("required", []), "kind"})
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": SCHEMA_ID,
        "title": "subfric-dolfinx scene",
        "description": "A scene of subfric-dolfinx (run_scene): an FE scene (two elastic bodies "
        "and a frictional interface) or a pointwise one (material-point cases). Units MPa, mm, "
        "s. Generated from subfric_dolfinx.scenes.schema.",
        # a scene is FE unless its kind says pointwise (if/then/else rather than oneOf: editors
        # complete and explain the branch that applies)
        "if": {"properties": {"kind": {"const": "pointwise"}}, "required": ["kind"]},
        "then": point,
        "else": fe,
        "$defs": dict(sorted(defs.items())),
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Print the schema, or write it to ``--out``."""
    ap = ArgumentParser(
        prog="python3 -m subfric_dolfinx.scenes.jsonschema", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--out", help="write it to this file (default: print it)")
    try:
        args = ap.parse_args(argv)
    except ArgumentError as e:
        return error_line(str(e))
    text = json.dumps(scene_schema(), indent=1) + "\n"
    if args.out:
        Path(args.out).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
