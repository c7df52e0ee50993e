"""Output on request: interface averages, a CSV history, and fields for ParaView.

Nothing here is created unless a scene asks for it. All functions are collective.

* :func:`interface_summary`: area-weighted interface averages and totals (same on all ranks).
* :class:`HistoryCSV`: one row per converged step (time, Newton iterations, averages, reaction
  forces of every Dirichlet group), written by rank 0.
* :class:`FieldWriter`: displacement and interface fields (``f_t``, ``f_n``, slip ``up``, ``mu``,
  ``r``) in VTX (ADIOS2, ``.bp``) or XDMF. The interface fields are cell averages of the quadrature
  values on the interface submesh (DG0); displacement of degree 2 is written as is in VTX and
  interpolated to degree 1 in XDMF (which needs the mesh's degree).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import dolfinx
import dolfinx.io
import numpy as np
from mpi4py import MPI

from .problem import InterfaceProblem

__all__ = ["FieldWriter", "HistoryCSV", "InterfaceHistoryH5", "interface_summary"]


def interface_summary(problem: InterfaceProblem) -> dict[str, float]:
    """Area-weighted means over the interface, totals and status fractions (all ranks).

    Keys: ``area``, ``F_t1`` [``F_t2``], ``F_n`` (resultant forces, traction integrals),
    ``f_t`` (mean |f_t|), ``f_n``, ``slip`` (mean |up|), ``up_t1`` [``up_t2``], ``mu``, ``r``,
    and the fractions ``plastic``, ``separated``, ``unstable`` (of quadrature points).
    """
    el = problem.interface
    nt = el.nt
    w = el.weights.ravel()
    st = el.state.old
    res = el.last
    tr = res.traction if res is not None else np.zeros((w.size, nt + 1))
    ft_mag = np.linalg.norm(tr[:, :nt], axis=1)
    cols = [w, *(w * tr[:, i] for i in range(nt + 1)), w * ft_mag]
    cols += [w * np.linalg.norm(st.up, axis=1), *(w * st.up[:, i] for i in range(nt))]
    cols += [w * st.mu, w * st.r]
    status = res.status if res is not None else np.zeros(w.size, np.int8)
    counts = [
        np.count_nonzero((status == 1) | (status == 3)),
        np.count_nonzero(status == 2),
        np.count_nonzero(res.unstable) if res is not None else 0,
        w.size,
    ]
    loc = np.array([c.sum() for c in cols] + counts, dtype=float)
    tot = np.zeros_like(loc)
    problem.comm.Allreduce(loc, tot, op=MPI.SUM)
    area = tot[0]
    names = ["area", *(f"F_t{i + 1}" for i in range(nt)), "F_n", "f_t", "slip"]
    names += [f"up_t{i + 1}" for i in range(nt)] + ["mu", "r"]
    # resultant forces (and the area) are totals; everything else is an area-weighted mean
    out = {
        k: tot[i] if k == "area" or k.startswith("F_") else tot[i] / area
        for i, k in enumerate(names)
    }
    out["f_n"] = out["F_n"] / area
    npts = max(tot[-1], 1.0)
    out["plastic"], out["separated"], out["unstable"] = (
        tot[-4] / npts,
        tot[-3] / npts,
        tot[-2] / npts,
    )
    return out


class HistoryCSV:
    """One row per converged step, kept in memory and written to a CSV file by rank 0.

    Args:
        path: File to write (parent directories are created); ``None``: memory only.
        problem: The problem (for the averages and the reaction forces).
    """

    def __init__(self, path: str | Path | None, problem: InterfaceProblem) -> None:
        self.path = Path(path) if path is not None else None
        self.problem = problem
        self._writer: Any = None
        self._file: Any = None
        self.rows: list[dict[str, float]] = []

    def preload(self, rows: list[dict[str, float]]) -> None:
        """Start from the rows of an earlier run (a restart); they are written first."""
        self.rows = [dict(r) for r in rows]

    def write(self, record: Any) -> dict[str, float]:
        """Append the row of a converged step (a :class:`~subfric_dolfinx.solver.StepRecord`)."""
        p = self.problem
        row: dict[str, float] = {
            "step": record.step,
            "t": record.t,
            "dt": record.dt,
            "newton": record.iterations,
            "cuts": record.cuts,
        }
        row.update(interface_summary(p))
        for group, force in p.reactions.items():
            for i, f in enumerate(force):
                row[f"R_{group}_{'xyz'[i]}"] = float(f)
        self.rows.append(row)
        if p.comm.rank == 0 and self.path is not None:
            if self._writer is None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._file = self.path.open("w", newline="")
                self._writer = csv.DictWriter(self._file, fieldnames=list(row))
                self._writer.writeheader()
                for old in self.rows[:-1]:  # preloaded rows of a restart
                    self._writer.writerow({k: f"{v:.17g}" for k, v in old.items()})
            self._writer.writerow({k: f"{v:.17g}" for k, v in row.items()})
            self._file.flush()
        return row

    def close(self) -> None:
        """Close the file."""
        if self._file is not None:
            self._file.close()
            self._file = None


class FieldWriter:
    """Displacement and interface fields over time, for ParaView.

    Args:
        directory: Output directory (created).
        problem: The problem.
        fmt: ``"vtx"`` (``displacement.bp``, ``interface.bp``) or ``"xdmf"``
            (``displacement.xdmf``, ``interface.xdmf``).
    """

    def __init__(self, directory: str | Path, problem: InterfaceProblem, fmt: str = "vtx") -> None:
        if fmt not in ("vtx", "xdmf"):
            raise ValueError(f"output format must be 'vtx' or 'xdmf', got {fmt!r}")
        self.dir = Path(directory)
        if problem.comm.rank == 0:
            self.dir.mkdir(parents=True, exist_ok=True)
        problem.comm.Barrier()
        self.problem = problem
        self.fmt = fmt
        el = problem.interface
        sub = el.submesh
        gdim, nt = el.gdim, el.nt
        D0s = dolfinx.fem.functionspace(sub, ("DG", 0))
        D0t = dolfinx.fem.functionspace(sub, ("DG", 0, (gdim,)))
        self.fields = {
            "f_t": dolfinx.fem.Function(D0t, name="f_t"),
            "f_n": dolfinx.fem.Function(D0s, name="f_n"),
            "slip": dolfinx.fem.Function(D0t, name="slip"),
            "mu": dolfinx.fem.Function(D0s, name="mu"),
            "r": dolfinx.fem.Function(D0s, name="r"),
        }
        self._nt = nt
        u = problem.u
        comm = problem.comm
        if fmt == "vtx":
            self._u = u
            self._wu = dolfinx.io.VTXWriter(comm, self.dir / "displacement.bp", [u], engine="BP4")
            self._wi = dolfinx.io.VTXWriter(
                comm, self.dir / "interface.bp", list(self.fields.values()), engine="BP4"
            )
        else:
            mesh = problem.mesh
            if u.function_space.ufl_element().embedded_superdegree != mesh.geometry.cmap.degree:
                V1 = dolfinx.fem.functionspace(
                    mesh, ("Lagrange", mesh.geometry.cmap.degree, (gdim,))
                )
                self._u = dolfinx.fem.Function(V1, name="displacement")
            else:
                self._u = u
            self._wu = dolfinx.io.XDMFFile(comm, self.dir / "displacement.xdmf", "w")
            self._wu.write_mesh(mesh)
            self._wi = dolfinx.io.XDMFFile(comm, self.dir / "interface.xdmf", "w")
            self._wi.write_mesh(sub)

    def _update(self) -> None:
        el = self.problem.interface
        nf, nq, nt, gdim = el.n_elements, el.nq, self._nt, el.gdim
        w = el.w_ref / el.w_ref.sum()
        st = el.state.old
        tr = el.last.traction if el.last is not None else np.zeros((nf * nq, gdim))

        def avg(a: np.ndarray) -> np.ndarray:
            return np.einsum("q,cq...->c...", w, a.reshape(nf, nq, *a.shape[1:]))

        # tangential vectors in global components: e_i rows of the local frames
        E = el.Q[..., :nt, :]  # (nf, nq, nt, gdim)
        ft_g = np.einsum("cqi,cqid->cqd", tr[:, :nt].reshape(nf, nq, nt), E)
        up_g = np.einsum("cqi,cqid->cqd", st.up.reshape(nf, nq, nt), E)
        self.fields["f_t"].x.array[:] = avg(ft_g.reshape(-1, gdim)).ravel()
        self.fields["slip"].x.array[:] = avg(up_g.reshape(-1, gdim)).ravel()
        self.fields["f_n"].x.array[:] = avg(tr[:, nt])
        self.fields["mu"].x.array[:] = avg(st.mu)
        self.fields["r"].x.array[:] = avg(st.r)

    def write(self, t: float) -> None:
        """Write the current (converged) state at time ``t``."""
        self._update()
        if self._u is not self.problem.u:
            self._u.interpolate(self.problem.u)
        if self.fmt == "vtx":
            self._wu.write(t)
            self._wi.write(t)
        else:
            self._wu.write_function(self._u, t)
            for f in self.fields.values():
                self._wi.write_function(f, t)

    def close(self) -> None:
        """Close the files."""
        self._wu.close()
        self._wi.close()


class InterfaceHistoryH5:
    """Interface fields at every converged step in one HDF5 file, readable with plain h5py.

    Layout (``n`` steps, ``p`` interface points sorted by coordinates, ``nt`` tangential
    components)::

        /time    (n,)          step end times
        /x       (p, gdim)     point coordinates (fixed)
        /f_t     (n, p, nt)    tangential traction, local frame (MPa)
        /f_n     (n, p)        normal traction, > 0 in compression (MPa)
        /up      (n, p, nt)    plastic slip, local frame (mm)
        /mu      (n, p)        hardening function (MPa)
        /r       (n, p)        normal-yield ratio
        /status  (n, p)        return-map status (0 elastic, 1 plastic, 2 separated, 3 jump)

    Written by rank 0 (gathered), flushed after each step. Opened on a restart, the steps after the
    restart time are dropped and the run appends from there.

    Args:
        path: The file.
        problem: The problem.
        restart_time: ``None`` for a new file; the checkpoint time when restarting.
    """

    FIELDS = ("f_t", "f_n", "up", "mu", "r", "status")

    def __init__(
        self, path: str | Path, problem: InterfaceProblem, restart_time: float | None = None
    ):
        self.path = Path(path)
        self.problem = problem
        el = problem.interface
        comm = problem.comm
        pts = np.concatenate(comm.allgather(el.points.reshape(-1, el.gdim))).reshape(-1, el.gdim)
        counts = comm.allgather(el.points.shape[0] * el.nq)
        self._counts = counts
        self._order = np.lexsort(pts.T[::-1])
        self._f = None
        if comm.rank == 0:
            import h5py

            self.path.parent.mkdir(parents=True, exist_ok=True)
            nt = el.nt
            if restart_time is not None and self.path.exists():
                f = h5py.File(self.path, "a")
                keep = int(np.count_nonzero(f["time"][()] <= restart_time + 1e-9))
                for k in ("time", *self.FIELDS):
                    f[k].resize(keep, axis=0)
            else:
                f = h5py.File(self.path, "w")
                f["x"] = pts[self._order]
                p = pts.shape[0]
                f.create_dataset("time", (0,), maxshape=(None,), dtype=float)
                for k, shape in (
                    ("f_t", (p, nt)),
                    ("f_n", (p,)),
                    ("up", (p, nt)),
                    ("mu", (p,)),
                    ("r", (p,)),
                    ("status", (p,)),
                ):
                    dt = np.int8 if k == "status" else float
                    f.create_dataset(
                        k, (0, *shape), maxshape=(None, *shape), dtype=dt, chunks=(1, *shape)
                    )
            self._f = f

    def write(self, t: float) -> None:
        """Append the current converged state at time ``t`` (collective)."""
        el = self.problem.interface
        nt = el.nt
        st, tr = el.state.old, el.last.traction
        local = np.column_stack([tr[:, :nt], tr[:, nt], st.up, st.mu, st.r, el.last.status])
        allv = self.problem.comm.gather(local, root=0)
        if self._f is None:
            return
        a = np.concatenate(allv).reshape(-1, local.shape[1])[self._order]
        f = self._f
        n = f["time"].shape[0]
        cols = {
            "f_t": a[:, :nt],
            "f_n": a[:, nt],
            "up": a[:, nt + 1 : 2 * nt + 1],
            "mu": a[:, 2 * nt + 1],
            "r": a[:, 2 * nt + 2],
            "status": a[:, 2 * nt + 3],
        }
        f["time"].resize(n + 1, axis=0)
        f["time"][n] = t
        for k, v in cols.items():
            f[k].resize(n + 1, axis=0)
            f[k][n] = v
        f.flush()

    def close(self) -> None:
        """Close the file."""
        if self._f is not None:
            self._f.close()
            self._f = None
