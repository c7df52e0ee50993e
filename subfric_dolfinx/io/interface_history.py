"""Interface fields at every converged step in one HDF5 file, readable with plain h5py.

Layout (``n`` steps, ``p`` interface points in the order of
:func:`~subfric_dolfinx.io.gather.gather_interface`, ``nt`` tangential components)::

    /time    (n,)            step end times
    /x       (p, gdim)       point coordinates (fixed)
    /f_t     (n, p, nt)      tangential traction, local frame (MPa)
    /f_n     (n, p)          normal traction, > 0 in compression (MPa)
    /gap     (n, p, nt + 1)  the gap ubar in the local frame: tangential components, then
                             ubar_n (> 0 on approach; f_n = alpha_n ubar_n in contact) (mm)
    /status  (n, p)          return-map status (:class:`~subfric_dolfinx.constitutive.Status`)
    /<v>     (n, p[, nt])    every output variable of the law (e.g. up, mu, r), local frame
    /g0      (p,)            the initial gap (fixed; mm)
    /region  (p,)            with interface regions: the region of each point (fixed)

The attribute ``variables`` lists the law's variables (JSON), ``regions`` the region names
(``region`` indexes it; ``default`` first); ``units`` (name -> unit), ``frame`` and
``status_legend`` (code -> meaning) are the vocabulary of :mod:`.units`, and every dataset has
its ``unit``. A step counts once its time is in
``/time``, written last: after a failed write the other datasets may hold one more (incomplete)
row, which a restart drops. Each rank writes its own slab of
points (:mod:`.slabs`) through h5py's MPI driver (:class:`~.h5.ParallelH5`), and the file is
flushed after each step. Opened on a restart, the file is checked (readable, the same variables
and points, reaching the restart time), the steps after the restart time are dropped and the run
appends from there. Any failure is an :class:`~.collective.OutputError` on every rank naming the
file.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .collective import Failure
from .gather import interface_of
from .h5 import ParallelH5
from .slabs import interface_rows, push, slab
from .units import file_attributes, interface_units

__all__ = ["InterfaceHistoryH5"]


class InterfaceHistoryH5:
    """Append the interface state of each converged step to an HDF5 file (collective).

    Args:
        path: The file.
        problem: The problem.
        restart_time: ``None`` for a new file; the checkpoint time when restarting.
        interface: Which interface (``None``: the first, e.g. the only one).
        profiles: A file of interface profiles (snapshots) at chosen times: every variable of
            the law (those that are no output too: the profiles of
            :func:`~subfric_dolfinx.scenes.outputs.interface_profile`), and a restart keeps the
            profiles up to the restart time, whichever it is.

    Raises:
        OutputError: On every rank: the file cannot be created, or (restart) the existing one
            cannot be continued (unreadable, another interface or law, ends before the restart).
    """

    def __init__(
        self,
        path: str | Path,
        problem: Any,
        restart_time: float | None = None,
        interface: str | None = None,
        profiles: bool = False,
    ) -> None:
        self.path = Path(path)
        self.profiles = profiles
        self.problem = problem
        comm = problem.comm
        el, self.law = interface_of(problem, interface)
        self.el = el
        nt, gdim = el.nt, el.gdim
        self.shapes: dict[str, tuple[tuple[int, ...], Any]] = {
            "f_t": ((nt,), float),
            "f_n": ((), float),
            "gap": ((nt + 1,), float),
            "status": ((), np.int8),
        }
        for var in self.law.variables:
            if var.output or profiles:
                self.shapes[var.name] = (var.array_shape(1, nt)[1:], float)
        self.rows, self.p = interface_rows(el)
        self.lo, self.hi = slab(self.p, comm.size, comm.rank)
        # what a step adds to the file (reserved before it, see ParallelH5.reserve): the new
        # chunks, twice, and then twice what the steps written took
        self.step_bytes = (
            2
            * self.p
            * sum(
                int(np.prod(shape)) * np.dtype(dtype).itemsize
                for shape, dtype in self.shapes.values()
            )
            + 2048
        )
        x = push(comm, self.rows, el.points.reshape(-1, gdim), self.p)
        self.pdata = {k: push(comm, self.rows, a, self.p) for k, a in el.point_data.items()}
        self.h: ParallelH5 | None = None
        self.n = 0  # steps in the file
        exists = comm.bcast(self.path.exists() if comm.rank == 0 else None, root=0)
        if restart_time is not None and exists:
            self.h = ParallelH5(
                self.path,
                "r+",
                comm,
                f"continuing the interface history {str(self.path)!r}",
                open_hint="not a readable HDF5 file (truncated?)",
            )
            self._cut(x, float(restart_time), el.coordinate_tolerance)
        else:
            self.h = ParallelH5(self.path, "w", comm, f"writing {str(self.path)!r}")
            self._create(x)
        self.h.what = f"writing {str(self.path)!r}"

    def _create(self, x: np.ndarray) -> None:
        assert self.h is not None
        p, gdim = self.p, x.shape[1]
        names = [v.name for v in self.law.variables]

        units = interface_units(self.problem.law, gdim)

        def create(f: Any) -> None:
            f.attrs["variables"] = json.dumps(names)
            f.attrs["regions"] = json.dumps(list(self.el.region_names))
            for k, v in file_attributes(self.law, gdim).items():
                f.attrs[k] = v
            f.create_dataset("x", (p, gdim), dtype=float, fill_time="never")
            for k in self.pdata:
                dtype = np.int32 if k == "region" else float
                f.create_dataset(k, (p,), dtype=dtype, fill_time="never")
            f.create_dataset("time", (0,), maxshape=(None,), dtype=float, chunks=(256,))
            for k, (shape, dtype) in self.shapes.items():
                f.create_dataset(
                    k,
                    (0, p, *shape),
                    maxshape=(None, p, *shape),
                    dtype=dtype,
                    chunks=(1, max(p, 1), *shape),
                    fill_time="never",
                )
            for k in ("x", "time", *self.pdata, *self.shapes):
                f[k].attrs["unit"] = units.get(k, "?")

        def fill(f: Any) -> None:
            if self.hi > self.lo:
                f["x"][self.lo : self.hi] = x
                for k, a in self.pdata.items():
                    f[k][self.lo : self.hi] = a.astype(np.int32) if k == "region" else a

        self.h.reserve(
            8 * (x.size + len(self.pdata) * max(x.shape[0], 1)) * self.h.comm.size
            + 4096 * (len(self.shapes) + len(self.pdata) + 2)  # + the vocabulary's attributes
        )
        self.h.call(create, meta=True)
        self.h.call(fill)
        self.h.call(lambda f: f.flush(), meta=True)

    def _cut(self, x: np.ndarray, t: float, tol: float) -> None:
        """Check the existing file and drop its steps after ``t`` (a restart)."""
        assert self.h is not None
        p, gdim = self.p, x.shape[1]
        names = [v.name for v in self.law.variables]
        eps = 1e-9 * max(1.0, abs(t))

        def check(f: Any) -> int:
            if json.loads(f.attrs["variables"]) != names:
                raise Failure(f"it holds the variables {f.attrs['variables']}, not {names}")
            if f["x"].shape != (p, gdim):
                raise Failure(f"its points have shape {f['x'].shape}, this run {(p, gdim)}")
            times = f["time"][()]
            for k, (shape, _) in self.shapes.items():
                if f[k].shape[0] < times.size or f[k].shape[1:] != (p, *shape):
                    raise Failure(f"{k!r} has shape {f[k].shape} for {times.size} steps")
            if np.any(np.abs(f["x"][self.lo : self.hi] - x) > 1e3 * tol):
                raise Failure("its points are not those of this run's interface")
            keep = int(np.count_nonzero(times <= t + eps))
            if self.profiles:  # profiles at chosen times: those up to the restart
                return keep
            if keep == 0 or abs(times[keep - 1] - t) > eps:
                last = f"ends at t = {times[-1]:.6g}" if times.size else "is empty"
                raise Failure(f"it {last}, without the restart time t = {t:.6g}")
            return keep

        self.h.what = (
            f"continuing the interface history {str(self.path)!r} (move it away to start a new one)"
        )
        keep = min(self.problem.comm.allgather(self.h.call(check)))
        self.h.reserve(4096 * len(self.shapes))

        def cut(f: Any) -> None:
            for k in ("time", *self.shapes):
                f[k].resize(keep, axis=0)

        self.h.call(cut, meta=True)
        self.h.call(lambda f: f.flush(), meta=True)
        self.n = keep

    def write(self, t: float) -> None:
        """Append the current converged state at time ``t`` (collective)."""
        assert self.h is not None, "the interface history is closed"
        el = self.el
        nt = el.nt
        st, res = el.state.old, el.last
        values = {
            "f_t": res.traction[:, :nt],
            "f_n": res.traction[:, nt],
            "gap": el.last_gap,
            "status": res.status,
        }
        values.update({name: a for name, a in st.items() if name in self.shapes})
        n_local = self.rows.size
        widths = {k: int(np.prod(s)) for k, (s, _) in self.shapes.items()}
        table = np.column_stack(
            [np.asarray(values[k], dtype=float).reshape(n_local, w) for k, w in widths.items()]
        )
        block = push(self.problem.comm, self.rows, table, self.p)
        n = self.n

        def grow(f: Any) -> None:
            for k in self.shapes:
                f[k].resize(n + 1, axis=0)

        def fill(f: Any) -> None:
            if self.hi > self.lo:
                c = 0
                for k, (shape, dtype) in self.shapes.items():
                    w = widths[k]
                    part = block[:, c : c + w].reshape(-1, *shape).astype(dtype)
                    f[k][n, self.lo : self.hi] = part
                    c += w

        def stamp(f: Any) -> None:  # the step counts once its time is written
            f["time"][n] = t

        before = self.h.size()
        self.h.reserve(self.step_bytes)
        self.h.call(grow, meta=True)
        self.h.call(fill)
        self.h.call(lambda f: f["time"].resize(n + 1, axis=0), meta=True)
        self.h.call(stamp, root=0)
        self.h.call(lambda f: f.flush(), meta=True)
        self.n = n + 1
        self.step_bytes = max(self.step_bytes, 2 * (self.h.size() - before))

    def close(self) -> None:
        """Close the file (collective)."""
        h, self.h = self.h, None
        if h is not None:
            h.close()
