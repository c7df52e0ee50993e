"""The law factory: laws by name, and a law from its JSON-like description.

``{"law": "subloading", "params": {"preset": "sec7", "mu0": 400.0}}`` or
``{"law": "coulomb", "params": {"alpha_t": 500, "alpha_n": 500, "mu_c": 0.1}}`` become law objects
(:class:`~.protocol.FrictionLaw`). Scenes and material-point cases use this one factory. A law
defined elsewhere becomes usable by name after :func:`register_law`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .coulomb import CoulombLaw
from .presets import PRESETS
from .protocol import FrictionLaw, LawError
from .subloading import SubloadingLaw

__all__ = ["LAWS", "build_law", "law_description", "register_law"]

LAWS: dict[str, type[Any]] = {SubloadingLaw.name: SubloadingLaw, CoulombLaw.name: CoulombLaw}
"""Registered law classes by name."""


def register_law(cls: type) -> type:
    """Make a law class usable by name (``{"law": cls.name, ...}``); usable as a decorator.

    The class must have a ``name``, ``variables`` and a classmethod ``from_parameters`` (e.g. a
    :class:`~.protocol.LawBase` dataclass).

    Raises:
        ValueError: No name, or the name is taken by another class.
    """
    name = getattr(cls, "name", "")
    if not isinstance(name, str) or not name:
        raise ValueError(f"law class {cls!r} has no name")
    if LAWS.get(name, cls) is not cls:
        raise ValueError(f"a law named {name!r} is already registered ({LAWS[name]!r})")
    for attr in ("variables", "from_parameters"):
        if not hasattr(cls, attr):
            raise ValueError(f"law class {cls!r} lacks {attr!r}")
    LAWS[name] = cls
    return cls


def build_law(obj: Mapping[str, Any] | FrictionLaw) -> FrictionLaw:
    """A law from ``{"law": name, "params": {...}}`` (a law object is returned as it is).

    ``"law"`` defaults to ``"subloading"``; a subloading law may start from a named preset
    (``"params": {"preset": "sec7", ...}``), the other keys overriding the preset's values.

    Raises:
        LawError: Unknown law, preset or parameter name, or an invalid value (named).
    """
    if isinstance(obj, FrictionLaw):
        return obj
    if not isinstance(obj, Mapping):
        raise LawError(f"a law must be an object {{'law': ..., 'params': ...}}, got {obj!r}")
    kind = obj.get("law", SubloadingLaw.name)
    if not isinstance(kind, str) or kind not in LAWS:
        raise LawError(f"field 'law' must be one of {sorted(LAWS)}, got {kind!r}")
    if "params" not in obj:
        raise LawError("field 'params' is missing")
    params = obj["params"]
    if not isinstance(params, Mapping):
        raise LawError(f"field 'params' must be an object, got {type(params).__name__}")
    params = dict(params)
    base: dict[str, Any] = {}
    if "preset" in params:
        name = params.pop("preset")
        if kind != SubloadingLaw.name or not isinstance(name, str) or name not in PRESETS:
            known = ", ".join(PRESETS) if kind == SubloadingLaw.name else "none"
            raise LawError(
                f"field 'params.preset' = {name!r} is not a preset of the {kind} law; "
                f"known: {known}"
            )
        base = PRESETS[name].law.parameters()
    try:
        return LAWS[kind].from_parameters({**base, **params})
    except LawError as e:
        raise LawError(f"field 'params': {e}") from None


def law_description(law: FrictionLaw) -> dict[str, Any]:
    """``{"law": name, "params": {...}}``: the inverse of :func:`build_law` (JSON-ready)."""
    return {"law": law.name, "params": law.parameters()}
