"""The checkpoint format and its validation on read (see :mod:`.checkpoint` for the layout).

Nothing in a checkpoint is trusted: :func:`check_metadata` checks the format and version, the type
and range of every attribute, that the JSON attributes parse to objects, and the shape and dtype
of every dataset against the attributes; :func:`check_blocks` checks that the values a rank read
are finite (NaN in ``mu`` is refused). Every failure is a :class:`CheckpointError` naming the
file and the item, never a raw ``IndexError``, ``JSONDecodeError`` or ``ValueError``.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ..values import NotAnInteger, NotANumber, NotFinite, finite_float, short_repr, strict_int

__all__ = [
    "FORMAT",
    "VERSION",
    "CheckpointError",
    "check_blocks",
    "check_metadata",
    "first_difference",
    "jsonable",
]

FORMAT = "subfric-dolfinx checkpoint"
VERSION = 2

INTS = {"step": 0, "easy": 0, "n_cells": 1, "n_points": 0, "degree": 1, "gdim": 2}
"""Integer attributes and their smallest valid value."""
FLOATS = ("time", "dt")
JSONS = ("law", "program", "settings")


class CheckpointError(RuntimeError):
    """An unusable checkpoint, or one that could not be written; the message says why."""


def _text(v: Any) -> Any:
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else v


def _int(name: str, key: str, v: Any) -> int:
    try:
        n = strict_int(v, numpy=True)
    except NotAnInteger:
        raise CheckpointError(
            f"checkpoint {name}: attribute {key!r} is {short_repr(v)}, not an integer"
        ) from None
    if n < INTS.get(key, 0):
        raise CheckpointError(f"checkpoint {name}: attribute {key!r} = {n} is below {INTS[key]}")
    return n


def _float(name: str, key: str, v: Any) -> float:
    try:
        return finite_float(v, numpy=True)
    except NotANumber:
        raise CheckpointError(
            f"checkpoint {name}: attribute {key!r} is {short_repr(v)}, not a number"
        ) from None
    except NotFinite:
        raise CheckpointError(
            f"checkpoint {name}: attribute {key!r} = {short_repr(v)} is not finite"
        ) from None


def _json(name: str, key: str, v: Any) -> str:
    v = _text(v)
    if not isinstance(v, str):
        raise CheckpointError(
            f"checkpoint {name}: attribute {key!r} is {short_repr(v)}, not a string"
        )
    try:
        obj = json.loads(v)
    except ValueError as e:
        raise CheckpointError(f"checkpoint {name}: attribute {key!r} is not JSON ({e})") from None
    if not isinstance(obj, dict):
        raise CheckpointError(f"checkpoint {name}: attribute {key!r} is not a JSON object")
    return v


def _dataset(f: Any, name: str, key: str, shape: tuple[int | None, ...]) -> Any:
    """The dataset ``key``, a float array of ``shape`` (``None``: any size)."""
    import h5py

    d = f.get(key)
    if not isinstance(d, h5py.Dataset):
        raise CheckpointError(f"checkpoint {name} lacks the dataset {key!r}")
    if d.dtype.kind != "f":
        raise CheckpointError(f"checkpoint {name}: {key!r} has dtype {d.dtype}, not float")
    ok = len(d.shape) == len(shape) and all(
        s is None or s == n for s, n in zip(shape, d.shape, strict=False)
    )
    if not ok:
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise CheckpointError(f"checkpoint {name}: {key!r} has shape {d.shape}, expected {want}")
    return d


def check_metadata(f: Any, name: str) -> tuple[dict[str, Any], list[dict[str, float]]]:
    """Validate an open checkpoint file's attributes and dataset shapes; read the history.

    Returns:
        The attributes (as Python values) and the history rows.
    """
    fmt = _text(f.attrs.get("format"))
    if fmt != FORMAT:
        raise CheckpointError(
            f"{name} is not a subfric-dolfinx checkpoint (format attribute {short_repr(fmt)})"
        )
    version = f.attrs.get("version")
    if not isinstance(version, int | np.integer) or int(version) != VERSION:
        raise CheckpointError(
            f"checkpoint {name} has version {short_repr(version)}, this code reads version "
            f"{VERSION}"
        )
    missing = [k for k in (*INTS, *FLOATS, *JSONS) if k not in f.attrs]
    if missing:
        raise CheckpointError(f"checkpoint {name} lacks the attribute(s) {missing}")
    a: dict[str, Any] = {"format": fmt, "version": int(version)}
    a.update({k: _int(name, k, f.attrs[k]) for k in INTS})
    a.update({k: _float(name, k, f.attrs[k]) for k in FLOATS})
    a.update({k: _json(name, k, f.attrs[k]) for k in JSONS})
    if a["dt"] <= 0:
        raise CheckpointError(f"checkpoint {name}: attribute 'dt' = {a['dt']} is not > 0")
    if a["degree"] > 2 or a["gdim"] > 3:
        raise CheckpointError(
            f"checkpoint {name}: degree {a['degree']} / gdim {a['gdim']} out of range"
        )
    nc, npt, gdim = a["n_cells"], a["n_points"], a["gdim"]
    _dataset(f, name, "displacement", (nc, None, gdim))
    _dataset(f, name, "interface/x", (npt, gdim))
    for k in f["interface"]:
        d = f["interface"][k]
        shape = (npt,) if len(getattr(d, "shape", ())) == 1 else (npt, None)
        d = _dataset(f, name, f"interface/{k}", shape)
        if d.ndim == 2 and d.shape[1] not in (gdim - 1, gdim):
            raise CheckpointError(
                f"checkpoint {name}: 'interface/{k}' has {d.shape[1]} components per point "
                f"(a {gdim}-D interface has {gdim - 1} or {gdim})"
            )
    h = _dataset(f, name, "history", (a["step"], None))
    try:
        cols = json.loads(_text(h.attrs["columns"]))
    except (KeyError, ValueError, TypeError) as e:
        raise CheckpointError(f"checkpoint {name}: history columns unreadable ({e})") from None
    if not (isinstance(cols, list) and all(isinstance(c, str) for c in cols)):
        raise CheckpointError(f"checkpoint {name}: history columns are not a list of names")
    if len(cols) != h.shape[1]:
        raise CheckpointError(
            f"checkpoint {name}: {len(cols)} history columns for {h.shape[1]} values per row"
        )
    table = h[()]
    if not np.all(np.isfinite(table)):
        raise CheckpointError(f"checkpoint {name}: the history holds non-finite values")
    rows = [dict(zip(cols, row, strict=True)) for row in table.tolist()]
    return a, rows


def check_blocks(name: str, displacement: np.ndarray, interface: dict[str, np.ndarray]) -> None:
    """Refuse non-finite values in the slabs a rank read (NaN in ``mu``, inf in ``u``, ...)."""
    for key, a in [("displacement", displacement), *(
        (f"interface/{k}", v) for k, v in interface.items()
    )]:  # fmt: skip
        if not np.all(np.isfinite(a)):
            raise CheckpointError(f"checkpoint {name}: {key!r} holds non-finite values (NaN/inf)")


def jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON values (lists for tuples and arrays, floats for numpy scalars)."""

    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray | np.generic):
            return o.tolist()
        raise TypeError(f"{type(o).__name__} {o!r} cannot be stored in a checkpoint")

    return json.loads(json.dumps(obj, default=default))


def first_difference(a: Any, b: Any, path: str = "") -> tuple[str, Any, Any] | None:
    """The first place where two JSON values differ: ``(dotted path, a's, b's)``, or ``None``."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            sub = f"{path}.{k}" if path else str(k)
            if k not in a or k not in b:
                return sub, a.get(k), b.get(k)
            d = first_difference(a[k], b[k], sub)
            if d is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return path, a, b
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d is not None:
                return d
        return None
    numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (a, b))
    same = a == b if numbers else (type(a) is type(b) and a == b)
    return None if same else (path, a, b)
