"""The checkpoint file's format: what it holds, its versions, and its validation on read.

A checkpoint holds the whole solver state with partition-independent keys, so a run written on 2
ranks restarts on 1 or 2 (format version 4; versions 3 and 2 are still read):

* ``/displacement``: values per (original cell index, cell-local dof, component), shape
  ``(n_cells, n_dofs_per_cell, gdim)``;
* ``/interfaces/<name>``, every interface of the problem alike, with the attributes ``n_points``
  and ``law`` (JSON): ``x`` and ``<v>`` for every internal variable ``v`` its law declares (e.g.
  ``up``, ``mu``, ``r``), the committed state per quadrature point, in the order of
  :func:`~.gather.gather_interface` (points sorted by rounded coordinates); a finite-sliding
  interface adds its points' total tangential gap ``sliding_ut`` and frame normals
  ``sliding_normal``
  (:meth:`~subfric_dolfinx.fem.interface.finite.points.SlidingPoints.saved_state`: its points
  are the secondary facets', and the primary facet each faces is found again from the
  displacement); ``point_data/<name>``: the fixed data of each point, in the order of ``x``: the
  initial gap ``g0`` and, with interface regions, ``region`` (compared on restart: a run restarts
  only with the same initial gap and regions);
* ``/increment`` (where the load stepper extrapolates its steps:
  :class:`~subfric_dolfinx.fem.LoadStepper`'s ``predictor``, on by default): the last converged
  step's displacement increment, laid out as ``/displacement``, its step length in the attribute
  ``dt``; a restart starts its first step from it as the uninterrupted run does;
* ``/dynamics`` (a dynamic problem, :class:`~subfric_dolfinx.fem.dynamics.Inertia`): the
  committed ``velocity``, ``acceleration``, the quasi-static residual ``force`` and the
  interfaces' ``interface_force`` at the last converged step (the generalised-alpha method's
  start of the next step), each laid out as ``/displacement``, and the energy accounts in the
  attribute ``accounts`` (JSON); a dynamic run restarts only from a checkpoint with it, a
  quasi-static one only from one without it (no new format version: a checkpoint without it
  reads as before);
* attributes: ``format``, ``version``, ``time``, ``step``, ``dt``, ``easy`` (the step-growth
  counter of the stepper), ``stepper`` (JSON: the rest of what decides the stepper's next steps,
  :class:`~subfric_dolfinx.fem.stepping.StepperMemory`: ``hold_step``, ``keep_retry``,
  ``retry_run``; with the increment, a restart takes the uninterrupted run's steps from the same
  first guesses), ``law`` (the first interface's), ``program`` and ``settings`` (JSON: what the
  runner passed, e.g. the scene's materials, boundary conditions and loads),
  ``n_cells``, ``degree``, ``gdim``, and ``geometry``: the mesh's fingerprint
  (:func:`~.checkpoint.geometry_fingerprint`: weighted sums over the cells of their nodes'
  coordinates, the same on any partition to round-off; a checkpoint without it is of an earlier
  version and is not compared);
* ``/history``: the rows of the history so far (column names in the attribute ``columns``).

A bulk model with state (:class:`~subfric_dolfinx.fem.bulk.BulkModel`) stores each array of its
``saved_state()`` under ``/bulk/<name>``, by original cell index: ``(n_cells, k, ...)`` for ``k``
values per cell, so that it restores on any partition.

Format version 3 (still read) lacked the attribute ``stepper``: a restart from it takes the
memory's defaults (no cut hold step, the solver's own options first), as a run whose checkpoint
was written outside a hold and off the retry options continues anyway.
Format version 2 (still read) stored the first interface apart, at ``/interface`` and
``/point_data`` (its points counted by the top-level attribute ``n_points``, its law the top-level
``law``), and only the further ones under ``/interfaces/<name>``.

Nothing in a checkpoint is trusted: reading checks the format and version, the type and range of
every attribute, that the JSON attributes parse to objects, and the shape and dtype of every
dataset against the attributes (:func:`check_metadata`), and that the values a rank read are
finite (:func:`check_blocks`: NaN in ``mu`` is refused). Every failure is a
:class:`CheckpointError` naming the file and the item, never a raw ``IndexError``,
``JSONDecodeError`` or ``ValueError``.

Written, read and restored by :mod:`.checkpoint`; the interfaces and the bulk state by
:mod:`.checkpoint_parts`.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ..values import NotAnInteger, NotANumber, NotFinite, finite_float, short_repr, strict_int

__all__ = [
    "FINGERPRINT",
    "FINGERPRINT_TOL",
    "FORMAT",
    "READS",
    "STEPPER",
    "V2_FIRST",
    "VERSION",
    "CheckpointError",
    "check_blocks",
    "check_metadata",
    "first_difference",
    "interface_groups",
    "json_object",
    "jsonable",
]


FORMAT = "subfric-dolfinx checkpoint"
VERSION = 4
READS = (2, 3, 4)
"""The format versions this code reads: 4 (the stepper's memory in ``stepper``), 3 (every
interface under ``/interfaces``) and 2."""
V2_FIRST = ""
"""The key of format 2's first interface (stored without its name) among the interfaces read."""

INTS = {"step": 0, "easy": 0, "n_cells": 1, "degree": 1, "gdim": 2}
"""Integer attributes and their smallest valid value (format 2 adds ``n_points``, >= 0)."""
FLOATS = ("time", "dt")
JSONS = ("law", "program", "settings")
STEPPER = {"hold_step": None, "keep_retry": False, "retry_run": 0}
"""The attribute ``stepper``'s keys (format 4) and the values a checkpoint of format 2 or 3
restores (:class:`~subfric_dolfinx.fem.stepping.StepperMemory`'s defaults)."""
FINGERPRINT = 8
"""Weighted sums in the geometry fingerprint (and one more: the sum of magnitudes)."""
FINGERPRINT_TOL = 1e-10
"""A restart's fingerprint may differ from the checkpoint's by this fraction of the magnitudes
(round-off of sums over differently partitioned cells)."""


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


def json_object(name: str, key: str, v: Any) -> str:
    """The attribute ``key``'s text, checked to be a JSON object (``name``: the file, quoted).

    Raises:
        CheckpointError: Not a string, not JSON, or not an object.
    """
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


def _stepper(name: str, text: str | None) -> dict[str, Any]:
    """The attribute ``stepper`` (format 4) validated, or :data:`STEPPER` (formats 2 and 3)."""
    if text is None:
        return dict(STEPPER)
    obj = json.loads(text)
    if set(obj) != set(STEPPER):
        raise CheckpointError(
            f"checkpoint {name}: attribute 'stepper' has the keys {sorted(obj)}, expected "
            f"{sorted(STEPPER)}"
        )
    hold, keep, run = obj["hold_step"], obj["keep_retry"], obj["retry_run"]
    if hold is not None:
        hold = _float(name, "stepper.hold_step", hold)
        if hold <= 0:
            raise CheckpointError(
                f"checkpoint {name}: attribute 'stepper.hold_step' = {hold} is not > 0"
            )
    if not isinstance(keep, bool):
        raise CheckpointError(
            f"checkpoint {name}: attribute 'stepper.keep_retry' is {short_repr(keep)}, not a "
            "boolean"
        )
    if isinstance(run, bool):
        raise CheckpointError(
            f"checkpoint {name}: attribute 'stepper.retry_run' is {short_repr(run)}, not an integer"
        )
    run = _int(name, "stepper.retry_run", run)
    return {"hold_step": hold, "keep_retry": keep, "retry_run": run}


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
    if fmt is None and "version" in f.attrs and "time" in f.attrs:
        raise CheckpointError(
            f"checkpoint {name} is incomplete: its write was interrupted before its end (the "
            "previous checkpoint, if any, is the one to restart from)"
        )
    if fmt != FORMAT:
        raise CheckpointError(
            f"{name} is not a subfric-dolfinx checkpoint (format attribute {short_repr(fmt)})"
        )
    version = f.attrs.get("version")
    if not isinstance(version, int | np.integer) or int(version) not in READS:
        raise CheckpointError(
            f"checkpoint {name} has version {short_repr(version)}, this code reads versions "
            f"{', '.join(str(v) for v in READS[:-1])} and {READS[-1]}"
        )
    ints = {**INTS, "n_points": 0} if int(version) == 2 else INTS
    jsons = (*JSONS, "stepper") if int(version) >= 4 else JSONS
    missing = [k for k in (*ints, *FLOATS, *jsons) if k not in f.attrs]
    if missing:
        raise CheckpointError(f"checkpoint {name} lacks the attribute(s) {missing}")
    a: dict[str, Any] = {"format": fmt, "version": int(version)}
    a.update({k: _int(name, k, f.attrs[k]) for k in ints})
    a.update({k: _float(name, k, f.attrs[k]) for k in FLOATS})
    a.update({k: json_object(name, k, f.attrs[k]) for k in jsons})
    a["stepper"] = _stepper(name, a.get("stepper"))
    if a["dt"] <= 0:
        raise CheckpointError(f"checkpoint {name}: attribute 'dt' = {a['dt']} is not > 0")
    if "geometry" in f.attrs:  # (absent from checkpoints of earlier versions)
        g = f.attrs["geometry"]
        if (
            not isinstance(g, np.ndarray)
            or g.shape != (FINGERPRINT + 1,)
            or g.dtype.kind != "f"
            or not np.all(np.isfinite(g))
        ):
            raise CheckpointError(
                f"checkpoint {name}: attribute 'geometry' is not {FINGERPRINT + 1} finite numbers"
            )
        a["geometry"] = np.asarray(g, dtype=float)
    if a["degree"] > 2 or a["gdim"] > 3:
        raise CheckpointError(
            f"checkpoint {name}: degree {a['degree']} / gdim {a['gdim']} out of range"
        )
    nc, gdim = a["n_cells"], a["gdim"]
    _dataset(f, name, "displacement", (nc, None, gdim))
    groups = interface_groups(f, name, a)
    if not groups:
        raise CheckpointError(f"checkpoint {name} holds no interface")
    for path, (npt, _) in groups.items():
        _check_interface(f, name, path, npt, gdim)
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


def interface_groups(f: Any, name: str, attrs: dict[str, Any]) -> dict[str, tuple[int, str]]:
    """Where each interface of an open checkpoint is: group path -> (points, its key).

    Formats 3 and 4: ``interfaces/<name>`` -> (its ``n_points`` attribute, ``<name>``); format
    2 adds its first interface, ``interface`` -> (the file's ``n_points``, :data:`V2_FIRST`).

    Raises:
        CheckpointError: A group without a valid ``n_points`` (formats 3 and 4).
    """
    out: dict[str, tuple[int, str]] = {}
    if attrs["version"] == 2:
        out["interface"] = (int(attrs["n_points"]), V2_FIRST)
    for iname in f.get("interfaces", {}):
        g = f["interfaces"][iname]
        n = g.attrs.get("n_points")
        if n is None or "x" not in g:
            raise CheckpointError(f"checkpoint {name}: the interface {iname!r} is incomplete")
        out[f"interfaces/{iname}"] = (_int(name, f"interfaces/{iname}/n_points", n), iname)
    return out


def _check_interface(f: Any, name: str, path: str, npt: int, gdim: int) -> None:
    """The shapes and dtypes of one interface's datasets (format 2's first: ``/point_data``)."""
    _dataset(f, name, f"{path}/x", (npt, gdim))
    for k in f[path]:
        if k == "point_data":
            continue
        d = f[path][k]
        shape = (npt,) if len(getattr(d, "shape", ())) == 1 else (npt, None)
        d = _dataset(f, name, f"{path}/{k}", shape)
        if d.ndim == 2 and d.shape[1] not in (gdim - 1, gdim):
            raise CheckpointError(
                f"checkpoint {name}: '{path}/{k}' has {d.shape[1]} components per point "
                f"(a {gdim}-D interface has {gdim - 1} or {gdim})"
            )
    pdata = "point_data" if path == "interface" else f"{path}/point_data"
    for k in f.get(pdata, {}):
        _dataset(f, name, f"{pdata}/{k}", (npt,))


def check_blocks(name: str, displacement: np.ndarray, interface: dict[str, np.ndarray]) -> None:
    """Refuse non-finite values in the slabs a rank read (NaN in ``mu``, inf in ``u``, ...).

    ``interface``: dataset path -> this rank's rows.
    """
    for key, a in [("displacement", displacement), *interface.items()]:
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
