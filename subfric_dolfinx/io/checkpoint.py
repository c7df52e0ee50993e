"""Checkpoint and restart of a load-stepped run, in one HDF5 file written and read in slabs.

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
  (:func:`geometry_fingerprint`: weighted sums over the cells of their nodes' coordinates, the
  same on any partition to round-off; a checkpoint without it is of an earlier version and is
  not compared);
* ``/history``: the rows of the history so far (column names in the attribute ``columns``).

Every rank writes and reads its own contiguous slab of rows (:mod:`.slabs`) through h5py's MPI
driver (:class:`~.h5.ParallelH5`): memory O(local) per rank. The file is written as
``<path>.tmp``, flushed, closed and renamed over ``<path>`` by rank 0: a run killed (or a disk
filling up) while writing leaves the previous checkpoint intact; its ``format`` attribute is
written last, after everything else was flushed, so a temporary file cut short by a kill is
refused by every reader as incomplete; any failure is a
:class:`CheckpointWriteError` on every rank (a :class:`CheckpointError` and an
:class:`~.collective.OutputError`), naming the file and the OS error.

Format version 3 (still read) lacked the attribute ``stepper``: a restart from it takes the
memory's defaults (no cut hold step, the solver's own options first), as a run whose checkpoint
was written outside a hold and off the retry options continues anyway.
Format version 2 (still read) stored the first interface apart, at ``/interface`` and
``/point_data`` (its points counted by the top-level attribute ``n_points``, its law the top-level
``law``), and only the further ones under ``/interfaces/<name>``.

A bulk model with state (:class:`~subfric_dolfinx.fem.bulk.BulkModel`) stores each array of its
``saved_state()`` under ``/bulk/<name>``, by original cell index: ``(n_cells, k, ...)`` for ``k``
values per cell, so that it restores on any partition.

Nothing in a checkpoint is trusted: reading checks the format and version, the type and range of
every attribute, that the JSON attributes parse to objects, and the shape and dtype of every
dataset against the attributes (:func:`check_metadata`), and that the values a rank read are
finite (:func:`check_blocks`: NaN in ``mu`` is refused). Every failure is a
:class:`CheckpointError` naming the file and the item, never a raw ``IndexError``,
``JSONDecodeError`` or ``ValueError``. A restart compares the mesh, the law, the loading program
and the runner's settings with the run's, naming the first difference; a mesh of the same
numbers of cells and interface points but other node coordinates is told by the fingerprint.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from ..compat import geometry_dofmap
from ..constitutive import law_description
from ..fem import StepperMemory
from ..meshing.groups import canonical_names
from ..values import NotAnInteger, NotANumber, NotFinite, finite_float, short_repr, strict_int
from .collective import OutputError, collective
from .dynamic_state import by_cell, from_cells, read_dynamics
from .h5 import ParallelH5
from .slabs import interface_rows, pull, push, slab

__all__ = [
    "Checkpoint",
    "CheckpointError",
    "CheckpointWriteError",
    "StoredInterface",
    "read_checkpoint",
    "restore_checkpoint",
    "write_checkpoint",
]


# -- The format and its validation on read

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
    a.update({k: _json(name, k, f.attrs[k]) for k in jsons})
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


# -- Writing, reading and restoring


class CheckpointWriteError(CheckpointError, OutputError):
    """A checkpoint could not be written (an output failure: a full disk, ...).

    Both a :class:`CheckpointError` and an :class:`~.collective.OutputError`: a program tells it
    from an unusable restart file (bad input) by the latter.
    """


def geometry_fingerprint(mesh: Any) -> np.ndarray:
    """The mesh's geometry in :data:`FINGERPRINT` + 1 numbers (collective; the same on every rank).

    Each cell's value ``s_c`` is a fixed linear combination of the sums of its nodes' coordinates
    and of their squares (so it does not depend on the order of its nodes); the fingerprint is
    ``sum_c s_c cos(w_j i_c)`` for ``j < FINGERPRINT`` (``i_c`` the cell's original index, ``w_j``
    fixed irrational frequencies) and ``sum_c |s_c|``, the scale of the round-off. Two meshes
    with the same cells whose nodes differ give different sums; the same mesh on any partition
    gives the same sums to round-off.
    """
    gdim = mesh.geometry.dim
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    idx = np.asarray(mesh.topology.original_cell_index[:n], dtype=float)
    X = mesh.geometry.x[geometry_dofmap(mesh)[:n], :gdim]
    alpha = np.array([1.0, 0.5772156649, 0.3183098862])[:gdim]
    beta = np.array([0.2718281828, 0.1732050808, 0.1414213562])[:gdim]
    s = X.sum(axis=1) @ alpha + (X**2).sum(axis=1) @ beta
    w = 0.6180339887 * np.arange(1, FINGERPRINT + 1) + 0.1
    local = np.concatenate([np.cos(np.outer(idx, w)).T @ s, [np.abs(s).sum()]])
    out = np.zeros_like(local)
    mesh.comm.Allreduce(local, out, op=MPI.SUM)
    return out


def _compare_geometry(name: str, saved: Any, mesh: Any) -> None:
    """Refuse a checkpoint whose geometry fingerprint differs from the mesh's (collective)."""
    mine = geometry_fingerprint(mesh)
    theirs = np.asarray(saved, dtype=float)
    scale = max(abs(theirs[-1]), abs(mine[-1]), 1e-300)
    diff = float(np.abs(theirs - mine).max())
    if diff > FINGERPRINT_TOL * scale:
        raise CheckpointError(
            f"checkpoint {name} is for another mesh: the same numbers of cells and interface "
            f"points, but other node coordinates (its geometry fingerprint differs by "
            f"{diff / scale:.3g} of its scale, round-off allows {FINGERPRINT_TOL:g})"
        )


def _cell_dofs(problem: Any) -> tuple[np.ndarray, np.ndarray, int]:
    mesh, V = problem.mesh, problem.V
    imap = mesh.topology.index_map(mesh.topology.dim)
    n = imap.size_local
    cells = mesh.topology.original_cell_index[:n].astype(np.int64)
    return cells, V.dofmap.list[:n], imap.size_global


def write_checkpoint(
    path: str | Path,
    problem: Any,
    stepper: Any,
    history: Sequence[Mapping[str, float]],
    settings: dict[str, Any] | None = None,
) -> None:
    """Write the converged state of ``problem`` and the position of ``stepper`` (collective).

    Args:
        path: Checkpoint file.
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem`.
        stepper: The :class:`~subfric_dolfinx.fem.LoadStepper`: its memory is written
            (:meth:`~subfric_dolfinx.fem.LoadStepper.memory`: time, step, step size, the
            predictor's last increment, ...); its solver rebuilds its preconditioner at the next
            iteration, as a restart will
            (:meth:`~subfric_dolfinx.fem.FrictionSolver.refresh_preconditioner`).
        history: History rows so far (stored so that a restarted run continues them).
        settings: JSON-ready settings a restart must match (e.g. the scene's materials,
            boundary conditions and loads); compared by :func:`restore_checkpoint`.

    Raises:
        CheckpointWriteError: On every rank, naming the file and the OS error; the previous
            checkpoint at ``path`` is intact.
    """
    comm = problem.comm
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    what = f"writing the checkpoint {str(path)!r}"
    gdim = problem.gdim
    cells, dofs, n_cells = _cell_dofs(problem)
    u = problem.u.x.array.reshape(-1, gdim)
    # every rank's slab of every dataset (one Alltoallv each)
    ublock = push(comm, cells, u[dofs], n_cells)
    memory = stepper.memory()  # what decides its next steps (the same on every rank)
    # the stepper's last increment where its predictor uses it (every rank has one or none)
    inc = memory.increment
    iblock = None
    if inc is not None:
        du = np.zeros_like(problem.u.x.array)
        du[: inc.size] = inc
        v = problem.u.copy()
        v.x.array[:] = du
        v.x.scatter_forward()
        iblock = push(comm, cells, v.x.array.reshape(-1, gdim)[dofs], n_cells)
    extras = extra_parts(problem, cells, n_cells)  # every interface, the bulk state
    dynamics = getattr(problem, "dynamics", None)  # a dynamic problem's velocity, acceleration
    dblocks: dict[str, np.ndarray] = {}
    accounts = "{}"
    if dynamics is not None:
        saved = dynamics.saved_state()
        accounts = json.dumps(saved.pop("accounts"))
        dblocks = {k: by_cell(problem, v, cells, n_cells) for k, v in saved.items()}
    cols = list(history[0]) if history else []
    table = np.array([[r[c] for c in cols] for r in history], dtype=float).reshape(
        len(history), len(cols)
    )
    attrs = dict(
        format=FORMAT,
        version=VERSION,
        time=float(memory.t),
        step=int(memory.step),
        dt=float(memory.dt),
        easy=int(memory.easy),
        stepper=json.dumps(
            {
                "hold_step": memory.hold_step,
                "keep_retry": bool(memory.keep_retry),
                "retry_run": int(memory.retry_run),
            }
        ),
        law=json.dumps(law_description(problem.law)),
        program=json.dumps(problem.program.to_dict()),
        settings=json.dumps(jsonable(settings or {})),
        n_cells=int(n_cells),
        degree=int(problem.V.ufl_element().embedded_superdegree),
        gdim=int(gdim),
        geometry=geometry_fingerprint(problem.mesh),
    )
    c0, c1 = slab(n_cells, comm.size, comm.rank)

    def create(f: Any) -> None:  # collective metadata calls, the same on every rank
        f.attrs.update({k: v for k, v in attrs.items() if k != "format"})  # format: at the end
        kw = {"dtype": float, "fill_time": "never"}
        f.create_dataset("displacement", (n_cells, *ublock.shape[1:]), **kw)
        if iblock is not None:
            d = f.create_dataset("increment", (n_cells, *iblock.shape[1:]), **kw)
            d.attrs["dt"] = float(memory.increment_dt)
        h = f.create_dataset("history", table.shape, **kw)
        h.attrs["columns"] = json.dumps(cols)
        if dblocks:
            g = f.create_group("dynamics")
            g.attrs["accounts"] = accounts
            for k, b in dblocks.items():
                g.create_dataset(k, (n_cells, *b.shape[1:]), **kw)
        write_extras(f, extras, comm, create=True)

    def fill(f: Any) -> None:  # independent transfers: each rank its own slab
        if c1 > c0:
            f["displacement"][c0:c1] = ublock
            if iblock is not None:
                f["increment"][c0:c1] = iblock
            for k, b in dblocks.items():
                f["dynamics"][k][c0:c1] = b
        if comm.rank == 0 and table.size:
            f["history"][...] = table
        write_extras(f, extras, comm, create=False)

    try:
        collective(
            comm, lambda: tmp.unlink(missing_ok=True), what, error=CheckpointWriteError, path=tmp
        )
        values = (
            (1 + (iblock is not None) + len(dblocks)) * n_cells * int(np.prod(ublock.shape[1:]))
            + (table.size)
            + extras.values()
        )
        with ParallelH5(tmp, "w", comm, what, CheckpointWriteError) as h:
            n_sets = 4 + len(dblocks) + len(extras.bulk) + 8 * len(extras.interfaces)
            h.reserve(8 * values + 4096 * n_sets)  # all the file will hold
            h.call(create, meta=True)
            h.call(fill)
            h.call(lambda f: f.flush(), meta=True)
            # the mark of a whole checkpoint, once everything else is in the file: a write
            # killed before it (SIGKILL, mpirun's after SIGTERM) leaves a file no reader takes
            h.call(lambda f: f.attrs.__setitem__("format", FORMAT), meta=True)
            h.call(lambda f: f.flush(), meta=True)
    except CheckpointError:
        if comm.rank == 0:
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass
        raise

    def publish() -> None:
        os.replace(tmp, path)
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)

    collective(comm, publish, what, error=CheckpointWriteError, path=path)
    refresh = getattr(getattr(stepper, "solver", None), "refresh_preconditioner", None)
    if refresh is not None:  # a restart starts fresh: so does this run, from here on
        refresh()


@dataclasses.dataclass
class StoredInterface:
    """One interface in a checkpoint, as read: this rank's slab of its rows.

    Attributes:
        n_points: Its number of points (over all ranks).
        law: Its law (JSON).
        rows: ``(lo, hi)``, this rank's rows.
        x: This rank's points.
        variables: Name -> this rank's rows of each saved variable.
        point_data: Name -> this rank's rows of the fixed point data (``g0``, ``region``);
            empty for a checkpoint written without them.
    """

    n_points: int
    law: str
    rows: tuple[int, int]
    x: np.ndarray
    variables: dict[str, np.ndarray]
    point_data: dict[str, np.ndarray]


@dataclasses.dataclass
class Checkpoint:
    """The contents of a checkpoint file, as read.

    The same metadata and history on every rank, and each rank's slab of the datasets.

    Attributes:
        attrs: The attributes (validated types).
        history: The history rows.
        cells: ``(lo, hi)``, this rank's rows of ``displacement``.
        displacement: ``(hi - lo, n_dofs_per_cell, gdim)``.
        interfaces: Interface name -> its :class:`StoredInterface` (format 2's first interface,
            stored without its name, under :data:`V2_FIRST`).
        bulk: Name -> this rank's slab of each array of the bulk state (by original cell).
        increment: This rank's rows of the last step's displacement increment and its length
            (the load stepper's predictor), ``None`` in a checkpoint without it.
        dynamics: A dynamic run's vectors (name -> this rank's rows, laid out as
            ``displacement``) and energy accounts; ``None`` in a checkpoint without them.
    """

    attrs: dict[str, Any]
    history: list[dict[str, float]]
    cells: tuple[int, int]
    displacement: np.ndarray
    interfaces: dict[str, StoredInterface]
    bulk: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    increment: tuple[np.ndarray, float] | None = None
    dynamics: tuple[dict[str, np.ndarray], dict[str, Any]] | None = None

    @property
    def interface(self) -> dict[str, np.ndarray]:
        """The variables (this rank's rows) of the only interface (format 2: of the first).

        Raises:
            ValueError: The checkpoint holds several interfaces (format 3 on): name one in
                :attr:`interfaces`.
        """
        if V2_FIRST in self.interfaces:
            return self.interfaces[V2_FIRST].variables
        if len(self.interfaces) != 1:
            raise ValueError(f"the checkpoint holds the interfaces {sorted(self.interfaces)}")
        return next(iter(self.interfaces.values())).variables


def read_checkpoint(path: str | Path, comm: Any) -> Checkpoint:
    """Read and validate a checkpoint, each rank its own slab (collective).

    Raises:
        CheckpointError: On every rank: a missing, truncated, foreign or damaged file, an
            attribute of the wrong type, a dataset of the wrong shape or dtype, non-finite values.
    """
    p = Path(path)
    name = repr(str(p))

    def exists() -> None:
        if not p.exists():
            raise CheckpointError(f"checkpoint {name} does not exist")
        if not p.is_file():
            raise CheckpointError(f"checkpoint {name} is not a regular file")

    msg = None
    if comm.rank == 0:
        try:
            exists()
        except CheckpointError as e:
            msg = str(e)
    msg = comm.bcast(msg, root=0)
    if msg:
        raise CheckpointError(msg)
    what = f"reading the checkpoint {name}"
    hint = "not a readable HDF5 file (truncated?)"
    with ParallelH5(p, "r", comm, what, CheckpointError, hint) as h:
        attrs, history = h.call(lambda f: check_metadata(f, name))
        c0, c1 = slab(int(attrs["n_cells"]), comm.size, comm.rank)

        def read(f: Any) -> tuple[Any, ...]:
            u = f["displacement"][c0:c1]
            inc = None
            if "increment" in f:
                d = f["increment"]
                dt = d.attrs.get("dt")
                if d.shape != f["displacement"].shape or not (
                    isinstance(dt, float | np.floating) and np.isfinite(dt) and dt > 0
                ):
                    raise CheckpointError(
                        f"checkpoint {name}: 'increment' has shape {d.shape} (the "
                        f"displacement's: {f['displacement'].shape}) and dt {dt} (> 0 wanted)"
                    )
                inc = (np.asarray(d[c0:c1], dtype=float), float(dt))
                if not np.all(np.isfinite(inc[0])):
                    raise CheckpointError(
                        f"checkpoint {name}: 'increment' holds non-finite values (NaN/inf)"
                    )
            ifaces = {}
            for path, (npt, key) in interface_groups(f, name, attrs).items():
                p0, p1 = slab(npt, comm.size, comm.rank)
                g = f[path]
                data = {k: np.asarray(g[k][p0:p1], dtype=float) for k in g if k != "point_data"}
                pd = "point_data" if path == "interface" else f"{path}/point_data"
                pdata = {k: np.asarray(f[pd][k][p0:p1], dtype=float) for k in f.get(pd, {})}
                check_blocks(name, u, {f"{path}/{k}": v for k, v in data.items()})
                check_blocks(name, u, {f"{pd}/{k}": v for k, v in pdata.items()})
                law = attrs["law"] if path == "interface" else _json(name, path, g.attrs["law"])
                x = data.pop("x")
                ifaces[key] = StoredInterface(npt, law, (p0, p1), x, data, pdata)
            bulk = read_bulk(f, name, comm, int(attrs["n_cells"]))
            return u, ifaces, bulk, inc, read_dynamics(f, name, c0, c1, CheckpointError)

        u, ifaces, bulk, inc, dyn = h.call(read)
    return Checkpoint(attrs, history, (c0, c1), u, ifaces, bulk, inc, dyn)


def restore_checkpoint(
    path: str | Path, problem: Any, stepper: Any, settings: dict[str, Any] | None = None
) -> list[dict[str, float]]:
    """Put the state of a checkpoint into ``problem``, ``stepper`` and its solver (collective).

    Args:
        path: The checkpoint.
        problem: The problem (built as for the run that wrote it).
        stepper: Its stepper.
        settings: The run's settings (see :func:`write_checkpoint`); every key given must equal
            the checkpoint's. Solver options are not settings: they may change (the step size
            the run continues with is the checkpoint's, at most the stepper's ``dt_max``).

    Returns:
        The history rows stored in the checkpoint.

    Raises:
        CheckpointError: On every rank: an unreadable or invalid file (see
            :func:`read_checkpoint`), or one that does not fit: another mesh (cell count,
            degree, dimension, geometry, interface points), law, loading program or setting
            (named).
    """
    comm = problem.comm
    name = repr(str(path))
    ck = read_checkpoint(path, comm)
    a = ck.attrs
    cells, dofs, n_cells = _cell_dofs(problem)
    here = {
        "n_cells": n_cells,
        "degree": problem.V.ufl_element().embedded_superdegree,
        "gdim": problem.gdim,
    }
    for k, v in here.items():
        if int(a[k]) != v:
            raise CheckpointError(
                f"checkpoint {name} is for a mesh with {k} = {a[k]}, this one has {v}"
            )
    if "geometry" in a:
        _compare_geometry(name, a["geometry"], problem.mesh)
    if ck.displacement.shape[1] != dofs.shape[1]:
        raise CheckpointError(
            f"checkpoint {name} has {ck.displacement.shape[1]} dofs per cell, this run "
            f"{dofs.shape[1]}"
        )
    compare = [("law", law_description(problem.law)), ("program", problem.program.to_dict())]
    if settings is not None:
        compare.append(("settings", jsonable(settings)))
    for key, mine in compare:
        theirs = json.loads(a[key])
        if key == "settings":  # an older run's names (master, slave_left, ...) as today's
            theirs = canonical_names(theirs)
        d = first_difference(theirs, mine)
        if d is not None:
            where, theirs, ours = d
            label = where if key == "settings" else f"{key}{'.' if where else ''}{where}"
            raise CheckpointError(
                f"checkpoint {name} was written with {label or key} = {json.dumps(theirs)}, "
                f"this run has {json.dumps(ours)}"
            )
    gdim = problem.gdim
    # the displacement by original cell index, the interfaces by global row
    u = problem.u.x.array.reshape(-1, gdim)
    u[dofs] = pull(comm, cells, ck.displacement, n_cells)
    problem.u.x.scatter_forward()
    for i, (iname, iface) in enumerate(problem.interfaces.items()):
        key = V2_FIRST if a["version"] == 2 and i == 0 else iname
        restore_interface(name, iname, iface, ck.interfaces.get(key), comm)
    restore_bulk(name, problem, ck.bulk, cells, n_cells)
    problem.resume()
    # every rank read the same file: all have the increment or none
    increment, increment_dt = None, 0.0
    if ck.increment is not None:
        v = problem.u.copy()
        v.x.array.reshape(-1, gdim)[dofs] = pull(comm, cells, ck.increment[0], n_cells)
        v.x.scatter_forward()
        increment, increment_dt = v.x.array.copy(), ck.increment[1]
    dynamics = getattr(problem, "dynamics", None)
    if (dynamics is None) != (ck.dynamics is None):
        kinds = ("quasi-static", "dynamic") if dynamics is None else ("dynamic", "quasi-static")
        raise CheckpointError(
            f"checkpoint {name} was written by a {kinds[1]} run, this run is {kinds[0]}"
        )
    if dynamics is not None and ck.dynamics is not None:
        vectors, accounts = ck.dynamics
        dynamics.restore_state(
            {k: from_cells(problem, b, cells, n_cells) for k, b in vectors.items()}, accounts
        )
    stepper.restore(
        StepperMemory(
            t=float(a["time"]),
            step=int(a["step"]),
            dt=float(a["dt"]),  # at most the stepper's dt_max, which may change
            easy=int(a["easy"]),
            **a["stepper"],
            increment=increment,
            increment_dt=increment_dt,
        )
    )
    return ck.history


# -- The interfaces and the bulk state


@dataclasses.dataclass
class ExtraParts:
    """This rank's slabs of the interfaces and of the bulk state, ready to write.

    Attributes:
        interfaces: Name -> (n_points, law JSON, name -> slab (x and variables), point-data slabs).
        bulk: Name -> this rank's slab of the bulk array by original cell, (hi - lo, k, ...).
        n_cells: Number of cells (rows of the bulk arrays).
    """

    interfaces: dict[str, tuple[int, str, dict[str, np.ndarray], dict[str, np.ndarray]]]
    bulk: dict[str, np.ndarray]
    n_cells: int

    def values(self) -> int:
        """Number of floats they hold (over all ranks), for the file's size estimate."""
        n = 0
        for n_points, _, blocks, pblocks in self.interfaces.values():
            n += n_points * (sum(int(np.prod(b.shape[1:])) for b in blocks.values()) + len(pblocks))
        for b in self.bulk.values():
            n += self.n_cells * int(np.prod(b.shape[1:]))
        return n


def _bulk_state(problem: Any, n_cells_local: int) -> dict[str, np.ndarray]:
    """The bulk model's state, each array shaped (owned cells, k, ...)."""
    bulk = getattr(problem, "bulk", None)
    state = bulk.saved_state() if bulk is not None else {}
    out = {}
    for name, a in state.items():
        a = np.asarray(a, dtype=float)
        if n_cells_local and a.shape[0] % n_cells_local:
            raise CheckpointError(
                f"the bulk state {name!r} has {a.shape[0]} rows for {n_cells_local} owned cells "
                "(a whole number per cell expected)"
            )
        k = a.shape[0] // n_cells_local if n_cells_local else 0
        k = problem.comm.allreduce(k, op=MPI.MAX)
        out[name] = a.reshape(n_cells_local, k, *a.shape[1:])
    return out


def extra_parts(problem: Any, cells: np.ndarray, n_cells: int) -> ExtraParts:
    """Collect this rank's slabs of every interface and of the bulk state (collective)."""
    comm = problem.comm
    out: dict[str, tuple[int, str, dict[str, np.ndarray], dict[str, np.ndarray]]] = {}
    for name, iface in problem.interfaces.items():
        el = iface.law_points
        rows, n_points = interface_rows(el)
        blocks = {"x": push(comm, rows, el.points.reshape(-1, el.gdim), n_points)}
        for v, a in el.saved_state().items():
            blocks[v] = push(comm, rows, a, n_points)
        pblocks = {k: push(comm, rows, a, n_points) for k, a in el.point_data.items()}
        out[name] = (n_points, json.dumps(law_description(iface.law)), blocks, pblocks)
    bulk = {k: push(comm, cells, a, n_cells) for k, a in _bulk_state(problem, cells.size).items()}
    return ExtraParts(out, bulk, n_cells)


def write_extras(f: Any, parts: ExtraParts, comm: Any, create: bool) -> None:
    """Create the datasets (``create``: collective metadata) or fill this rank's slabs."""
    kw = {"dtype": float, "fill_time": "never"}
    for name, (n_points, law, blocks, pblocks) in parts.interfaces.items():
        if create:
            g = f.require_group("interfaces").create_group(name)
            g.attrs["n_points"] = int(n_points)
            g.attrs["law"] = law
            for k, b in blocks.items():
                g.create_dataset(k, (n_points, *b.shape[1:]), **kw)
            pd = g.create_group("point_data")
            for k in pblocks:
                pd.create_dataset(k, (n_points,), **kw)
            continue
        p0, p1 = slab(n_points, comm.size, comm.rank)
        if p1 > p0:
            g = f["interfaces"][name]
            for k, b in blocks.items():
                g[k][p0:p1] = b
            for k, b in pblocks.items():
                g["point_data"][k][p0:p1] = b
    c0, c1 = slab(parts.n_cells, comm.size, comm.rank)
    for name, b in parts.bulk.items():
        if create:
            f.require_group("bulk").create_dataset(name, (parts.n_cells, *b.shape[1:]), **kw)
        elif c1 > c0:
            f["bulk"][name][c0:c1] = b


def read_bulk(f: Any, name: str, comm: Any, n_cells: int) -> dict[str, np.ndarray]:
    """This rank's slabs of the bulk state, validated."""
    out: dict[str, np.ndarray] = {}
    c0, c1 = slab(n_cells, comm.size, comm.rank)
    for k in f.get("bulk", {}):
        d = f["bulk"][k]
        if d.shape[:1] != (n_cells,) or d.dtype.kind != "f":
            raise CheckpointError(f"checkpoint {name}: 'bulk/{k}' has shape {d.shape}")
        a = np.asarray(d[c0:c1], dtype=float)
        if not np.all(np.isfinite(a)):
            raise CheckpointError(f"checkpoint {name}: 'bulk/{k}' holds NaN/inf")
        out[k] = a
    return out


def restore_interface(
    name: str, iname: str, iface: Any, stored: StoredInterface | None, comm: Any
) -> None:
    """Put one interface's stored state into ``iface`` (collective): every interface alike.

    Raises:
        ~subfric_dolfinx.io.checkpoint.CheckpointError: The interface missing, of another
            number of points, law, points, point data or variables (named).
    """
    if stored is None:
        raise CheckpointError(f"checkpoint {name} lacks the interface {iname!r}")
    el = iface.law_points
    rows, n_points = interface_rows(el)
    if stored.n_points != n_points:
        raise CheckpointError(
            f"checkpoint {name}: the interface {iname!r} has {stored.n_points} points there, "
            f"{n_points} in this run"
        )
    d = first_difference(json.loads(stored.law), law_description(iface.law))
    if d is not None:
        raise CheckpointError(
            f"checkpoint {name} was written with another law on the interface {iname!r} "
            f"({d[0] or 'law'}: {json.dumps(d[1])} there, {json.dumps(d[2])} here)"
        )
    saved = el.saved_state()
    for v, mine in saved.items():
        got = stored.variables.get(v)
        if got is None:
            raise CheckpointError(f"checkpoint {name} lacks the variable {v!r} of {iname!r}")
        if got.shape[1:] != mine.shape[1:]:
            raise CheckpointError(
                f"checkpoint {name}: the variable {v!r} of {iname!r} has shape "
                f"{(n_points, *got.shape[1:])}, this run's law needs {(n_points, *mine.shape[1:])}"
            )
    x = pull(comm, rows, stored.x, n_points)
    pts = el.points.reshape(-1, el.gdim)
    scale = comm.allreduce(float(np.abs(pts).max()) if pts.size else 0.0, op=MPI.MAX)
    bad = comm.allreduce(
        int(np.count_nonzero(np.linalg.norm(x - pts, axis=1) > 1e-9 * max(scale, 1.0)))
    )
    if bad:
        raise CheckpointError(
            f"{bad} points of the interface {iname!r} are not in the checkpoint {name} "
            "(another mesh or quadrature)"
        )
    compare_point_data(name, el, stored.point_data, rows, n_points, comm)
    el.restore_state(
        {
            v: pull(comm, rows, stored.variables[v], n_points).reshape(a.shape)
            for v, a in saved.items()
        }
    )  # trial = committed


def restore_bulk(
    name: str, problem: Any, stored: dict[str, np.ndarray], cells: np.ndarray, n_cells: int
) -> None:
    """Put the bulk state into ``problem`` (collective).

    Raises:
        ~subfric_dolfinx.io.checkpoint.CheckpointError: A bulk array missing or of another
            shape (named).
    """
    comm = problem.comm
    state = _bulk_state(problem, cells.size)
    if set(state) != set(stored):
        raise CheckpointError(
            f"checkpoint {name} holds the bulk state {sorted(stored)}, this run's bulk "
            f"model has {sorted(state)}"
        )
    restored = {}
    for k, mine in state.items():
        block = stored[k]
        if block.shape[1:] != mine.shape[1:]:
            raise CheckpointError(
                f"checkpoint {name}: the bulk state {k!r} has {block.shape[1:]} values per cell "
                f"there, {mine.shape[1:]} in this run"
            )
        a = pull(comm, cells, block, n_cells).reshape(mine.shape)
        restored[k] = a.reshape(-1, *mine.shape[2:])
    if restored:
        problem.bulk.restore_state(restored)


_POINT_DATA = {"g0": "initial gap g0 (mm)", "region": "interface region numbers"}


def compare_point_data(
    name: str, el: Any, stored: dict[str, np.ndarray], rows: np.ndarray, n_points: int, comm: Any
) -> None:
    """The run's fixed point data must equal the checkpoint's (collective).

    A checkpoint without point data (an older one) fits a run whose data are all zero.

    Raises:
        ~subfric_dolfinx.io.checkpoint.CheckpointError: On every rank, naming the datum, the
            largest difference and where.
    """
    pts = el.points.reshape(-1, el.gdim)
    for key, here in el.point_data.items():
        has = key in stored
        there = pull(comm, rows, stored[key], n_points) if has else np.zeros_like(here)
        diff = np.abs(there - here)
        i = int(np.argmax(diff)) if diff.size else -1
        local = (float(diff[i]), tuple(pts[i]), float(there[i]), float(here[i])) if i >= 0 else None
        worst = max((w for w in comm.allgather(local) if w), default=None, key=lambda w: w[0])
        scale = comm.allreduce(float(np.abs(here).max()) if here.size else 0.0, op=MPI.MAX)
        if worst is not None and worst[0] > 1e-9 * max(1.0, scale):
            where = ", ".join(f"{v:.6g}" for v in worst[1])
            raise CheckpointError(
                f"checkpoint {name} was written with another {_POINT_DATA.get(key, key)}: "
                f"{worst[2]:.6g} there, {worst[3]:.6g} in this run at ({where})"
                + ("" if has else " (the checkpoint has none)")
            )
