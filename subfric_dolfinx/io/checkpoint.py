"""Checkpoint and restart of a load-stepped run, in one HDF5 file written and read in slabs.

:func:`write_checkpoint` writes the converged state of a problem and the memory of its stepper
(:class:`~subfric_dolfinx.fem.stepping.StepperMemory`), :func:`read_checkpoint` reads and
validates a file, :func:`restore_checkpoint` puts it into a problem and its stepper, so that
the run continues as the uninterrupted run does. The file's layout, its versions and its
validation: :mod:`.checkpoint_format`; the interfaces and the bulk state:
:mod:`.checkpoint_parts`.

Every rank writes and reads its own contiguous slab of rows (:mod:`.slabs`) through h5py's MPI
driver (:class:`~.h5.ParallelH5`): memory O(local) per rank. The file is written as
``<path>.tmp``, flushed, closed and renamed over ``<path>`` by rank 0: a run killed (or a disk
filling up) while writing leaves the previous checkpoint intact; its ``format`` attribute is
written last, after everything else was flushed, so a temporary file cut short by a kill is
refused by every reader as incomplete; any failure is a
:class:`CheckpointWriteError` on every rank (a :class:`CheckpointError` and an
:class:`~.collective.OutputError`), naming the file and the OS error.

A restart compares the mesh, the law, the loading program and the runner's settings with the
run's, naming the first difference; a mesh of the same numbers of cells and interface points but
other node coordinates is told by the fingerprint (:func:`geometry_fingerprint`).
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
from .checkpoint_format import (
    FINGERPRINT,
    FINGERPRINT_TOL,
    FORMAT,
    V2_FIRST,
    VERSION,
    CheckpointError,
    check_blocks,
    check_metadata,
    first_difference,
    interface_groups,
    json_object,
    jsonable,
)
from .checkpoint_parts import (
    ExtraParts,
    StoredInterface,
    extra_parts,
    read_bulk,
    restore_bulk,
    restore_interface,
    write_extras,
)
from .collective import OutputError, collective
from .dynamic_state import by_cell, from_cells, read_dynamics
from .h5 import ParallelH5
from .slabs import pull, push, slab

__all__ = [
    "Checkpoint",
    "CheckpointError",
    "CheckpointWriteError",
    "StoredInterface",
    "geometry_fingerprint",
    "read_checkpoint",
    "restore_checkpoint",
    "write_checkpoint",
]


class CheckpointWriteError(CheckpointError, OutputError):
    """A checkpoint could not be written (an output failure: a full disk, ...).

    Both a :class:`CheckpointError` and an :class:`~.collective.OutputError`: a program tells it
    from an unusable restart file (bad input) by the latter.
    """


def geometry_fingerprint(mesh: Any) -> np.ndarray:
    """The mesh's geometry in a few numbers, the same on every rank (collective).

    :data:`~.checkpoint_format.FINGERPRINT` + 1 of them.

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
    memory = stepper.memory()  # what decides its next steps (the same on every rank)
    stepper.forget_curvature()  # (not in the file: this run continues as a restart would)
    slabs = _collect(problem, memory, history)
    attrs = _attributes(problem, memory, settings, slabs.n_cells)
    _write_file(tmp, comm, what, slabs, attrs)

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
class _Slabs:
    """This rank's slabs of everything a checkpoint holds, ready to write.

    Attributes:
        n_cells: Number of cells (rows of the datasets laid out by cell).
        displacement: This rank's rows of ``/displacement``.
        increment: Those of ``/increment`` and its step length, ``None`` without one.
        dynamics: Those of each dataset of ``/dynamics`` (none for a quasi-static problem).
        accounts: The energy accounts (JSON) of a dynamic problem.
        extras: Every interface and the bulk state (:class:`~.checkpoint_parts.ExtraParts`).
        columns: The history's column names.
        table: The history's rows (written by rank 0).
    """

    n_cells: int
    displacement: np.ndarray
    increment: tuple[np.ndarray, float] | None
    dynamics: dict[str, np.ndarray]
    accounts: str
    extras: ExtraParts
    columns: list[str]
    table: np.ndarray

    def values(self) -> int:
        """Number of floats the file will hold (over all ranks), for its size estimate."""
        per_cell = int(np.prod(self.displacement.shape[1:]))
        layers = 1 + (self.increment is not None) + len(self.dynamics)
        return layers * self.n_cells * per_cell + self.table.size + self.extras.values()


def _collect(problem: Any, memory: Any, history: Sequence[Mapping[str, float]]) -> _Slabs:
    """Every rank's slab of every dataset (collective: one ``Alltoallv`` each)."""
    comm = problem.comm
    gdim = problem.gdim
    cells, dofs, n_cells = _cell_dofs(problem)
    u = problem.u.x.array.reshape(-1, gdim)
    ublock = push(comm, cells, u[dofs], n_cells)
    # the stepper's last increment where its predictor uses it (every rank has one or none)
    inc = memory.increment
    increment = None
    if inc is not None:
        du = np.zeros_like(problem.u.x.array)
        du[: inc.size] = inc
        v = problem.u.copy()
        v.x.array[:] = du
        v.x.scatter_forward()
        iblock = push(comm, cells, v.x.array.reshape(-1, gdim)[dofs], n_cells)
        increment = (iblock, float(memory.increment_dt))
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
    return _Slabs(n_cells, ublock, increment, dblocks, accounts, extras, cols, table)


def _attributes(
    problem: Any, memory: Any, settings: dict[str, Any] | None, n_cells: int
) -> dict[str, Any]:
    """The file's attributes (:mod:`.checkpoint_format`; collective: the fingerprint)."""
    return dict(
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
        gdim=int(problem.gdim),
        geometry=geometry_fingerprint(problem.mesh),
    )


def _write_file(tmp: Path, comm: Any, what: str, slabs: _Slabs, attrs: dict[str, Any]) -> None:
    """Write the temporary file ``tmp`` whole, its ``format`` mark last (collective).

    Raises:
        CheckpointWriteError: On every rank; ``tmp`` is removed.
    """
    n_cells, ublock, extras = slabs.n_cells, slabs.displacement, slabs.extras
    dblocks, table = slabs.dynamics, slabs.table
    c0, c1 = slab(n_cells, comm.size, comm.rank)

    def create(f: Any) -> None:  # collective metadata calls, the same on every rank
        f.attrs.update({k: v for k, v in attrs.items() if k != "format"})  # format: at the end
        kw = {"dtype": float, "fill_time": "never"}
        f.create_dataset("displacement", (n_cells, *ublock.shape[1:]), **kw)
        if slabs.increment is not None:
            iblock, idt = slabs.increment
            d = f.create_dataset("increment", (n_cells, *iblock.shape[1:]), **kw)
            d.attrs["dt"] = idt
        h = f.create_dataset("history", table.shape, **kw)
        h.attrs["columns"] = json.dumps(slabs.columns)
        if dblocks:
            g = f.create_group("dynamics")
            g.attrs["accounts"] = slabs.accounts
            for k, b in dblocks.items():
                g.create_dataset(k, (n_cells, *b.shape[1:]), **kw)
        write_extras(f, extras, comm, create=True)

    def fill(f: Any) -> None:  # independent transfers: each rank its own slab
        if c1 > c0:
            f["displacement"][c0:c1] = ublock
            if slabs.increment is not None:
                f["increment"][c0:c1] = slabs.increment[0]
            for k, b in dblocks.items():
                f["dynamics"][k][c0:c1] = b
        if comm.rank == 0 and table.size:
            f["history"][...] = table
        write_extras(f, extras, comm, create=False)

    try:
        collective(
            comm, lambda: tmp.unlink(missing_ok=True), what, error=CheckpointWriteError, path=tmp
        )
        with ParallelH5(tmp, "w", comm, what, CheckpointWriteError) as h:
            n_sets = 4 + len(dblocks) + len(extras.bulk) + 8 * len(extras.interfaces)
            h.reserve(8 * slabs.values() + 4096 * n_sets)  # all the file will hold
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
            stored without its name, under :data:`~.checkpoint_format.V2_FIRST`).
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
                law = (
                    attrs["law"] if path == "interface" else json_object(name, path, g.attrs["law"])
                )
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
