"""The interfaces and the bulk state in a checkpoint: collected and written, read and restored.

Every interface alike: its points, its law's committed variables and its fixed point data by
global row (the order of :func:`~.gather.gather_interface`), written by every rank in its slab
(:func:`extra_parts`, :func:`write_extras`), read back as a :class:`StoredInterface` and compared
on restart with the run's points, law and point data (:func:`restore_interface`). The bulk
model's state by original cell index (:func:`read_bulk`, :func:`restore_bulk`). The file's
layout: :mod:`.checkpoint_format`.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import numpy as np
from mpi4py import MPI

from ..constitutive import law_description
from .checkpoint_format import CheckpointError, first_difference
from .slabs import interface_rows, pull, push, slab

__all__ = [
    "ExtraParts",
    "StoredInterface",
    "compare_point_data",
    "extra_parts",
    "read_bulk",
    "restore_bulk",
    "restore_interface",
    "write_extras",
]


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
        ~.checkpoint_format.CheckpointError: The interface missing, of another
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
        ~.checkpoint_format.CheckpointError: A bulk array missing or of another
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
        ~.checkpoint_format.CheckpointError: On every rank, naming the datum, the
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
