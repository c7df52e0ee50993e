"""The parts of a checkpoint beyond the first interface: more interfaces and the bulk state.

A problem with several interfaces stores the first at ``/interface`` (and ``/point_data``), as a
problem with one, and each further interface ``<name>`` under ``/interfaces/<name>``: ``x``, every
variable of its law, ``point_data/<k>``, with the attributes ``n_points`` and ``law`` (JSON). A bulk
model with state (:class:`~subfric_dolfinx.fem.bulk.BulkModel`) stores each array of its
``state()`` under ``/bulk/<name>``, by original cell index: ``(n_cells, k, ...)`` for ``k`` values
per cell, so that it restores on any partition.

Each rank writes and reads its own slab of rows (:mod:`.slabs`), as for the rest of the file.
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
    "compare_point_data",
    "extra_parts",
    "read_extras",
    "restore_extras",
    "write_extras",
]


@dataclasses.dataclass
class ExtraParts:
    """This rank's slabs of the extra interfaces and of the bulk state, ready to write.

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
    state = bulk.state() if bulk is not None else {}
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
    """Collect this rank's slabs of the extra interfaces and the bulk state (collective)."""
    comm = problem.comm
    ifaces = list(getattr(problem, "interfaces", {}).items())[1:]
    out: dict[str, tuple[int, str, dict[str, np.ndarray], dict[str, np.ndarray]]] = {}
    for name, iface in ifaces:
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


def read_extras(f: Any, name: str, comm: Any, n_cells: int) -> dict[str, Any]:
    """This rank's slabs of the extra interfaces and the bulk state, validated."""
    out: dict[str, Any] = {"interfaces": {}, "bulk": {}}
    for iname in f.get("interfaces", {}):
        g = f["interfaces"][iname]
        n_points = int(g.attrs.get("n_points", -1))
        if n_points < 0 or "x" not in g:
            raise CheckpointError(f"checkpoint {name}: the interface {iname!r} is incomplete")
        p0, p1 = slab(n_points, comm.size, comm.rank)
        data = {k: np.asarray(g[k][p0:p1], dtype=float) for k in g if k != "point_data"}
        pdata = {k: np.asarray(g["point_data"][k][p0:p1], dtype=float)
                 for k in g.get("point_data", {})}  # fmt: skip
        for k, a in [*data.items(), *pdata.items()]:
            if a.shape[:1] != (p1 - p0,) or not np.all(np.isfinite(a)):
                raise CheckpointError(f"checkpoint {name}: 'interfaces/{iname}/{k}' is damaged")
        law = g.attrs.get("law", "{}")
        law = law.decode() if isinstance(law, bytes) else str(law)
        out["interfaces"][iname] = (n_points, law, data, pdata)
    c0, c1 = slab(n_cells, comm.size, comm.rank)
    for k in f.get("bulk", {}):
        d = f["bulk"][k]
        if d.shape[:1] != (n_cells,) or d.dtype.kind != "f":
            raise CheckpointError(f"checkpoint {name}: 'bulk/{k}' has shape {d.shape}")
        a = np.asarray(d[c0:c1], dtype=float)
        if not np.all(np.isfinite(a)):
            raise CheckpointError(f"checkpoint {name}: 'bulk/{k}' holds NaN/inf")
        out["bulk"][k] = a
    return out


def restore_extras(
    name: str, problem: Any, extras: dict[str, Any], cells: np.ndarray, n_cells: int
) -> None:
    """Put the extra interfaces' state and the bulk state into ``problem`` (collective).

    Raises:
        ~subfric_dolfinx.io.checkpoint.CheckpointError: An interface or bulk array missing, of
            another law or shape (named).
    """
    comm = problem.comm
    ifaces = list(getattr(problem, "interfaces", {}).items())[1:]
    for iname, iface in ifaces:
        stored = extras["interfaces"].get(iname)
        if stored is None:
            raise CheckpointError(f"checkpoint {name} lacks the interface {iname!r}")
        n_stored, law, data, pdata = stored
        el = iface.law_points
        rows, n_points = interface_rows(el)
        if n_stored != n_points:
            raise CheckpointError(
                f"checkpoint {name}: the interface {iname!r} has {n_stored} points there, "
                f"{n_points} in this run"
            )
        d = first_difference(json.loads(law), law_description(iface.law))
        if d is not None:
            raise CheckpointError(
                f"checkpoint {name} was written with another law on the interface {iname!r} "
                f"({d[0] or 'law'}: {json.dumps(d[1])} there, {json.dumps(d[2])} here)"
            )
        x = pull(comm, rows, data["x"], n_points)
        pts = el.points.reshape(-1, el.gdim)
        scale = comm.allreduce(float(np.abs(pts).max()) if pts.size else 0.0, op=MPI.MAX)
        bad = comm.allreduce(int(np.count_nonzero(
            np.linalg.norm(x - pts, axis=1) > 1e-9 * max(scale, 1.0)
        )))  # fmt: skip
        if bad:
            raise CheckpointError(
                f"{bad} points of the interface {iname!r} are not in the checkpoint {name}"
            )
        compare_point_data(name, el, pdata, rows, n_points, comm)
        arrays = {}
        for v, mine in el.saved_state().items():
            if v not in data:
                raise CheckpointError(f"checkpoint {name} lacks the variable {v!r} of {iname!r}")
            arrays[v] = pull(comm, rows, data[v], n_points).reshape(mine.shape)
        el.restore_state(arrays)
    state = _bulk_state(problem, cells.size)
    if set(state) != set(extras["bulk"]):
        raise CheckpointError(
            f"checkpoint {name} holds the bulk state {sorted(extras['bulk'])}, this run's bulk "
            f"model has {sorted(state)}"
        )
    restored = {}
    for k, mine in state.items():
        block = extras["bulk"][k]
        if block.shape[1:] != mine.shape[1:]:
            raise CheckpointError(
                f"checkpoint {name}: the bulk state {k!r} has {block.shape[1:]} values per cell "
                f"there, {mine.shape[1:]} in this run"
            )
        a = pull(comm, cells, block, n_cells).reshape(mine.shape)
        restored[k] = a.reshape(-1, *mine.shape[2:])
    if restored:
        problem.bulk.restore(restored)


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
