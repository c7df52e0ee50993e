"""Interface fields at every converged step in one HDF5 file, readable with plain h5py.

Layout (``n`` steps, ``p`` interface points in the order of
:func:`~subfric_dolfinx.io.gather.gather_interface`, ``nt`` tangential components)::

    /time    (n,)          step end times
    /x       (p, gdim)     point coordinates (fixed)
    /f_t     (n, p, nt)    tangential traction, local frame (MPa)
    /f_n     (n, p)        normal traction, > 0 in compression (MPa)
    /status  (n, p)        return-map status (:class:`~subfric_dolfinx.constitutive.Status`)
    /<v>     (n, p[, nt])  every internal variable of the law (e.g. up, mu, r)
    /g0      (p,)          the initial gap (fixed; mm)
    /region  (p,)          with interface regions: the region of each point (fixed)

The attribute ``variables`` lists the law's variables (JSON), ``regions`` the region names
(``region`` indexes it; ``default`` first). Written by rank 0 (gathered),
flushed after each step. Opened on a restart, the steps after the restart time are dropped and the
run appends from there.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .gather import gather_interface

__all__ = ["InterfaceHistoryH5"]


class InterfaceHistoryH5:
    """Append the interface state of each converged step to an HDF5 file.

    Args:
        path: The file.
        problem: The problem.
        restart_time: ``None`` for a new file; the checkpoint time when restarting.
    """

    def __init__(self, path: str | Path, problem: Any, restart_time: float | None = None) -> None:
        self.path = Path(path)
        self.problem = problem
        el = problem.interface
        nt = el.nt
        self.shapes: dict[str, tuple[tuple[int, ...], Any]] = {
            "f_t": ((nt,), float),
            "f_n": ((), float),
            "status": ((), np.int8),
        }
        for var in problem.law.variables:
            self.shapes[var.name] = (var.array_shape(1, nt)[1:], float)
        x = gather_interface(el, dict(el.point_data), root=0)
        self._f = None
        if problem.comm.rank == 0:
            import h5py

            self.path.parent.mkdir(parents=True, exist_ok=True)
            if restart_time is not None and self.path.exists():
                f = h5py.File(self.path, "a")
                keep = int(np.count_nonzero(f["time"][()] <= restart_time + 1e-9))
                for k in ("time", *self.shapes):
                    f[k].resize(keep, axis=0)
            else:
                f = h5py.File(self.path, "w")
                f.attrs["variables"] = json.dumps([v.name for v in problem.law.variables])
                f["x"] = x["x"]
                f.attrs["regions"] = json.dumps(list(el.region_names))
                for k in el.point_data:
                    f[k] = x[k].astype(int) if k == "region" else x[k]
                p = x["x"].shape[0]
                f.create_dataset("time", (0,), maxshape=(None,), dtype=float)
                for k, (shape, dtype) in self.shapes.items():
                    f.create_dataset(
                        k, (0, p, *shape), maxshape=(None, p, *shape), dtype=dtype,
                        chunks=(1, p, *shape),
                    )  # fmt: skip
            self._f = f

    def write(self, t: float) -> None:
        """Append the current converged state at time ``t`` (collective)."""
        el = self.problem.interface
        nt = el.nt
        st, res = el.state.old, el.last
        values = {"f_t": res.traction[:, :nt], "f_n": res.traction[:, nt], "status": res.status}
        values.update({name: a for name, a in st.items()})
        g = gather_interface(el, values, root=0)
        if self._f is None:
            return
        f = self._f
        n = f["time"].shape[0]
        f["time"].resize(n + 1, axis=0)
        f["time"][n] = t
        for k in self.shapes:
            f[k].resize(n + 1, axis=0)
            f[k][n] = g[k]
        f.flush()

    def close(self) -> None:
        """Close the file."""
        if self._f is not None:
            self._f.close()
            self._f = None
