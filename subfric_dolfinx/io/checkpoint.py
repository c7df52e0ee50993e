"""Checkpoint and restart of a load-stepped run, in one HDF5 file (h5py).

A checkpoint holds the whole solver state with partition-independent keys, so a run written on 2
ranks restarts on 1 or 2:

* ``/displacement``: values per (original cell index, cell-local dof, component), shape
  ``(n_cells, n_dofs_per_cell, gdim)``;
* ``/interface/x`` and ``/interface/<v>`` for every internal variable ``v`` the law declares (e.g.
  ``up``, ``mu``, ``r``): the committed interface state per quadrature point, keyed by the point's
  coordinates (unique on the interface);
* ``/point_data/<name>``: the fixed data of each point, in the order of ``/interface/x``: the
  initial gap ``g0`` and, with interface regions, ``region`` (compared on restart: a run
  restarts only with the same initial gap and regions);
* attributes: ``format``, ``version``, ``time``, ``step``, ``dt``, ``easy`` (the step-growth
  counter of the stepper), ``law`` and ``program`` (JSON), ``n_cells``, ``degree``, ``gdim``;
* ``/history``: the rows of the history so far (column names in the attribute ``columns``).

It is gathered to rank 0 and written to ``<path>.tmp``, flushed and renamed over ``<path>``: a run
killed while writing leaves the previous checkpoint intact. Reading checks the format, version,
mesh and parameters, and raises :class:`CheckpointError` naming what is wrong (truncated or
foreign file, other mesh, other parameters).
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from ..constitutive import law_description
from ..fem.interface.geometry import match_points

__all__ = ["CheckpointError", "read_checkpoint", "restore_checkpoint", "write_checkpoint"]

FORMAT = "subfric-dolfinx checkpoint"
VERSION = 1


class CheckpointError(RuntimeError):
    """An unusable checkpoint; the message says why."""


def _cell_dofs(problem: Any) -> tuple[np.ndarray, np.ndarray]:
    mesh, V = problem.mesh, problem.V
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    return mesh.topology.original_cell_index[:n].astype(np.int64), V.dofmap.list[:n]


def write_checkpoint(path: str | Path, problem: Any, stepper: Any, history: list[dict]) -> None:
    """Write the converged state of ``problem`` and the position of ``stepper`` (collective).

    Args:
        path: Checkpoint file.
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem`.
        stepper: The :class:`~subfric_dolfinx.fem.LoadStepper` (time, step, dt).
        history: History rows so far (stored so that a restarted run continues them).
    """
    comm = problem.comm
    gdim = problem.gdim
    cells, dofs = _cell_dofs(problem)
    u = problem.u.x.array.reshape(-1, gdim)
    u_cells = u[dofs]  # (n, ndofs, gdim)
    el = problem.interface
    st = el.state.old
    pts = el.points.reshape(-1, gdim)
    pdata = dict(el.point_data)
    gathered = comm.gather((cells, u_cells, pts, {k: a for k, a in st.items()}, pdata), root=0)
    error = None
    if comm.rank == 0:
        try:
            import h5py

            cells_g = np.concatenate([g[0] for g in gathered])
            ucells = np.concatenate([g[1] for g in gathered])
            n_cells = int(cells_g.max()) + 1 if cells_g.size else 0
            U = np.zeros((n_cells, ucells.shape[1], gdim))
            U[cells_g] = ucells
            path = Path(path)
            tmp = path.with_name(path.name + ".tmp")
            path.parent.mkdir(parents=True, exist_ok=True)
            with h5py.File(tmp, "w") as f:
                f.attrs.update(
                    format=FORMAT,
                    version=VERSION,
                    time=stepper.t,
                    step=stepper.step,
                    dt=stepper.dt,
                    easy=stepper.easy,
                    law=json.dumps(law_description(problem.law)),
                    program=json.dumps(problem.program.to_dict()),
                    n_cells=n_cells,
                    degree=problem.V.ufl_element().embedded_superdegree,
                    gdim=gdim,
                )
                f["displacement"] = U
                g = f.create_group("interface")
                g["x"] = np.concatenate([x[2] for x in gathered]).reshape(-1, gdim)
                for name in st.names:
                    a = np.concatenate([x[3][name] for x in gathered])
                    g[name] = a.reshape(-1, *st[name].shape[1:])
                pd = f.create_group("point_data")
                for name in pdata:
                    pd[name] = np.concatenate([x[4][name] for x in gathered])
                cols = list(history[0]) if history else []
                h = f.create_dataset(
                    "history",
                    data=np.array([[r[c] for c in cols] for r in history], dtype=float).reshape(
                        len(history), len(cols)
                    ),
                )
                h.attrs["columns"] = json.dumps(cols)
                f.flush()
                os.fsync(f.id.get_vfd_handle())
            os.replace(tmp, path)
        except Exception as e:  # reported on all ranks below
            error = f"writing the checkpoint {str(path)!r} failed: {e}"
    error = comm.bcast(error, root=0)
    if error:
        raise CheckpointError(error)


@dataclasses.dataclass
class Checkpoint:
    """The contents of a checkpoint file (as read, on every rank)."""

    attrs: dict[str, Any]
    displacement: np.ndarray
    x: np.ndarray
    interface: dict[str, np.ndarray]
    history: list[dict[str, float]]
    point_data: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)


def read_checkpoint(path: str | Path, comm: Any) -> Checkpoint:
    """Read a checkpoint on rank 0 and broadcast it (collective).

    Raises:
        CheckpointError: Missing, truncated or foreign file (on all ranks).
    """
    data, error = None, None
    if comm.rank == 0:
        try:
            import h5py

            p = Path(path)
            if not p.is_file():
                raise CheckpointError(f"checkpoint {str(p)!r} does not exist")
            try:
                f = h5py.File(p, "r")
            except OSError as e:
                raise CheckpointError(
                    f"checkpoint {str(p)!r} is not a readable HDF5 file (truncated?): {e}"
                ) from None
            with f:
                if f.attrs.get("format") != FORMAT:
                    raise CheckpointError(
                        f"{str(p)!r} is not a subfric-dolfinx checkpoint "
                        f"(format attribute {f.attrs.get('format')!r})"
                    )
                if int(f.attrs.get("version", -1)) != VERSION:
                    raise CheckpointError(
                        f"checkpoint {str(p)!r} has version {f.attrs.get('version')!r}, "
                        f"this code reads version {VERSION}"
                    )
                need = ["displacement", "interface/x", "history"]
                missing = [k for k in need if k not in f]
                if missing:
                    raise CheckpointError(f"checkpoint {str(p)!r} lacks {missing}")
                attrs = {k: (v.item() if hasattr(v, "item") else v) for k, v in f.attrs.items()}
                cols = json.loads(f["history"].attrs["columns"])
                hist = [dict(zip(cols, row.tolist(), strict=True)) for row in f["history"][()]]
                data = Checkpoint(
                    attrs,
                    f["displacement"][()],
                    f["interface/x"][()],
                    {k: f["interface"][k][()] for k in f["interface"] if k != "x"},
                    hist,
                    {k: v[()] for k, v in f["point_data"].items()} if "point_data" in f else {},
                )
        except CheckpointError as e:
            error = str(e)
        except Exception as e:  # h5py errors on damaged datasets
            error = f"checkpoint {str(path)!r} is damaged: {type(e).__name__}: {e}"
    error = comm.bcast(error, root=0)
    if error:
        raise CheckpointError(error)
    return comm.bcast(data, root=0)


def restore_checkpoint(path: str | Path, problem: Any, stepper: Any) -> list[dict[str, float]]:
    """Put the state of a checkpoint into ``problem``, ``stepper`` and its solver (collective).

    Returns:
        The history rows stored in the checkpoint.

    Raises:
        CheckpointError: The checkpoint does not fit: other mesh (cell count, degree, dimension),
            other law parameters or loading program, or interface points that do not match.
    """
    comm = problem.comm
    ck = read_checkpoint(path, comm)
    a = ck.attrs
    cells, dofs = _cell_dofs(problem)
    n_cells = problem.mesh.topology.index_map(problem.mesh.topology.dim).size_global
    here = {
        "n_cells": n_cells,
        "degree": problem.V.ufl_element().embedded_superdegree,
        "gdim": problem.gdim,
    }
    for k, v in here.items():
        if int(a[k]) != v:
            raise CheckpointError(
                f"checkpoint {str(path)!r} is for a mesh with {k} = {a[k]}, this one has {v}"
            )
    if json.loads(a["law"]) != law_description(problem.law):
        raise CheckpointError(
            f"checkpoint {str(path)!r} was written with law {a['law']}, "
            f"this run has {json.dumps(law_description(problem.law))}"
        )
    if json.loads(a["program"]) != problem.program.to_dict():
        raise CheckpointError(f"checkpoint {str(path)!r} was written with another loading program")
    gdim = problem.gdim
    u = problem.u.x.array.reshape(-1, gdim)
    u[dofs] = ck.displacement[cells]
    problem.u.x.scatter_forward()
    el = problem.interface
    pts = el.points.reshape(-1, gdim)
    scale = float(np.abs(ck.x).max()) if ck.x.size else 1.0
    idx, _ = match_points(ck.x, pts, 1e-9 * max(scale, 1.0))
    bad = comm.allreduce(int(np.count_nonzero(idx < 0)))
    if bad:
        raise CheckpointError(
            f"{bad} interface points of this run are not in the checkpoint {str(path)!r}"
        )
    st = el.state.old
    missing = sorted(set(st.names) - set(ck.interface))
    if missing:
        raise CheckpointError(f"checkpoint {str(path)!r} lacks the interface variable(s) {missing}")
    _compare_point_data(path, el, ck, idx, comm)
    for name in st.names:
        st[name][:] = ck.interface[name][idx]
    el.state.revert()  # trial = committed
    stepper.restore(float(a["time"]), int(a["step"]), float(a["dt"]), int(a["easy"]))
    return ck.history


_POINT_DATA = {"g0": "initial gap g0 (mm)", "region": "interface region numbers"}


def _compare_point_data(path: Any, el: Any, ck: Checkpoint, idx: np.ndarray, comm: Any) -> None:
    """The run's fixed point data must equal the checkpoint's (collective).

    A checkpoint without point data (an older one) fits a run whose data are all zero.

    Raises:
        CheckpointError: On every rank, naming the datum, the largest difference and where.
    """
    gdim = el.gdim
    pts = el.points.reshape(-1, gdim)
    for name, here in el.point_data.items():
        stored = ck.point_data.get(name)
        there = np.zeros_like(here) if stored is None else np.asarray(stored, dtype=float)[idx]
        diff = np.abs(there - here)
        i = int(np.argmax(diff)) if diff.size else -1
        local = (float(diff[i]), tuple(pts[i]), float(there[i]), float(here[i])) if i >= 0 else None
        worst = max((w for w in comm.allgather(local) if w), default=None, key=lambda w: w[0])
        scale = comm.allreduce(float(np.abs(here).max()) if here.size else 0.0, op=MPI.MAX)
        if worst is not None and worst[0] > 1e-9 * max(1.0, scale):
            where = ", ".join(f"{v:.6g}" for v in worst[1])
            raise CheckpointError(
                f"checkpoint {str(path)!r} was written with another {_POINT_DATA.get(name, name)}: "
                f"{worst[2]:.6g} there, {worst[3]:.6g} in this run at ({where})"
                + (" (the checkpoint has none)" if stored is None else "")
            )
