"""The interface state at its quadrature points, as a point-cloud time series for ParaView.

:class:`~.fields.FieldWriter` averages the quadrature values of each interface facet (DG0: VTX
and DOLFINx's XDMF do not write Quadrature spaces); :class:`InterfacePointsXDMF` writes them
point by point, where the law computes them: an XDMF file (``interface_points.xdmf``, open it in
ParaView; a temporal collection of polyvertex grids) and its HDF5 heavy data
(``interface_points.h5``)::

    /geometry        (p, gdim)   quadrature point coordinates (written once)
    /topology        (p, 1)      0 .. p-1 (one vertex per point)
    /rank            (p,)        the rank owning the point
    /step_<k>        group, attribute ``time``, for the k-th written step (k = 0, 1, ...):
      f_t1 [f_t2], f_n         traction, local components (MPa; f_n > 0 in compression)
      traction_global (p, 3)   traction on the primary body in global components (glyphs)
      status         (p,)      return-map status (:class:`~subfric_dolfinx.constitutive.Status`)
      <v>, <v>_t1 .. <v>_n     every output variable of the law by its local components (e.g.
                               up_t1, mu, r), and a vector one as ``<v>_global`` (p, 3)

The names are those of every output (:mod:`.units`); the file's attributes ``units``, ``frame``
and ``status_legend`` and each dataset's ``unit`` say the rest, and the XDMF file repeats each
array's unit in an ``Information`` element.

The points are in rank order, each rank's points in its own order (a slab per rank, written by
that rank with h5py's MPI driver: nothing is gathered); ``/rank`` tells which rank owned a
point, and :func:`~.gather.gather_interface` puts them in a partition-independent order.

Errors are collective: a failure on any rank (directory, open, write, flush, the XDMF text) makes
every rank close the file and raise the same :class:`PointCloudError`. Data transfers are
independent (a failed collective transfer can leave the other ranks waiting), and the ranks agree
on the outcome of every step before the next collective call.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..constitutive import LOCAL, SCALAR
from .gather import interface_of
from .links import refuse_links, write_text_nofollow
from .units import file_attributes, interface_units

__all__ = ["InterfacePointsXDMF", "PointCloudError"]


class PointCloudError(OSError):
    """The point-cloud output could not be written (the same message on every rank)."""


def _agree(comm: Any, error: BaseException | None) -> None:
    """Raise the same :class:`PointCloudError` on every rank if any rank failed (collective)."""
    text = None if error is None else f"{type(error).__name__}: {error}"
    texts = comm.allgather(text)
    failed = [(r, t) for r, t in enumerate(texts) if t is not None]
    if failed:
        rank, what = failed[0]
        raise PointCloudError(f"interface point output: rank {rank}: {what}")


def _components(name: str, kind: Any, nt: int) -> list[str]:
    """Names of the scalar arrays of a variable: ``mu``; ``up_t1``, ``up_t2``; ``f_t1``, ``f_n``."""
    if kind == SCALAR:
        return [name]
    names = [f"{name}_t{i + 1}" for i in range(nt)]
    return [*names, f"{name}_n"] if kind == LOCAL else names


class InterfacePointsXDMF:
    """Write the interface state at the quadrature points, step by step (collective).

    Args:
        path: The XDMF file (``.xdmf``); the HDF5 file is written beside it (``.h5``).
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem`.
        interface: Which interface (``None``: the first, e.g. the only one).

    Raises:
        PointCloudError: On every rank, if the directory or the files cannot be written.
    """

    def __init__(self, path: str | Path, problem: Any, interface: str | None = None) -> None:
        import h5py

        self.path = Path(path)
        self.h5path = self.path.with_suffix(".h5")
        self.problem = problem
        self.comm = comm = problem.comm
        el, self.law = interface_of(problem, interface)
        self.el = el
        self.gdim, self.nt = el.gdim, el.nt
        self.n_local = el.n_elements * el.nq
        sizes = comm.allgather(self.n_local)
        self.n_points = int(sum(sizes))
        self.offset = int(sum(sizes[: comm.rank]))
        self.times: list[float] = []
        self.arrays: list[tuple[str, str]] = []  # (name, "Scalar" or "Vector") per step
        self.units = interface_units(problem.law, el.gdim)
        self._f: Any = None
        error: Exception | None = None
        if comm.rank == 0:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                error = e
        _agree(comm, error)
        if comm.size > 1 and not h5py.get_config().mpi:
            raise PointCloudError("interface point output on several ranks needs h5py with MPI")
        error = None
        try:
            refuse_links(self.path, self.h5path)  # .links
            kw = {"driver": "mpio", "comm": comm} if comm.size > 1 else {}
            self._f = h5py.File(self.h5path, "w", **kw)
        except Exception as e:
            error = e
        self._agree_or_close(error)
        x = el.points.reshape(-1, self.gdim)
        slab = slice(self.offset, self.offset + self.n_local)
        error = None
        try:
            f = self._f
            for k, v in file_attributes(problem.law, self.gdim).items():
                f.attrs[k] = v
            dg = self._dataset(f, "geometry", (self.n_points, self.gdim), float)
            dg.attrs["unit"] = "mm"
            dt = self._dataset(f, "topology", (self.n_points, 1), np.int64)
            dr = self._dataset(f, "rank", (self.n_points,), np.int32)
        except Exception as e:
            error = e
        self._agree_or_close(error)
        error = None
        try:
            self._write_slab(dg, x)
            self._write_slab(dt, np.arange(slab.start, slab.stop, dtype=np.int64)[:, None])
            self._write_slab(dr, np.full(self.n_local, comm.rank, dtype=np.int32))
        except Exception as e:
            error = e
        self._agree_or_close(error)

    @staticmethod
    def _dataset(f: Any, name: str, shape: tuple[int, ...], dtype: Any) -> Any:
        """A dataset created collectively, its bytes written by their owners only."""
        return f.create_dataset(name, shape, dtype=dtype, fill_time="never", track_times=False)

    def _write_slab(self, dataset: Any, a: np.ndarray) -> None:
        """This rank's rows of ``dataset`` (an independent transfer; nothing if it has none)."""
        if self.n_local:
            dataset[self.offset : self.offset + self.n_local] = a

    def _agree_or_close(self, error: BaseException | None) -> None:
        """Agree on the outcome; after a failure every rank closes the file and raises."""
        try:
            _agree(self.comm, error)
        except PointCloudError:
            self._close_quietly()
            raise

    def _close_quietly(self) -> None:
        if self._f is not None:
            try:
                self._f.close()
            except Exception:
                pass
            self._f = None

    def _values(self) -> dict[str, np.ndarray]:
        """This rank's values, by array name (scalars (n,), the traction vector (n, 3))."""
        el = self.el
        n, nt, gdim = self.n_local, self.nt, self.gdim
        tr = el.last.traction if el.last is not None else np.zeros((n, nt + 1))
        status = el.last.status if el.last is not None else np.zeros(n, dtype=np.int8)
        out = {name: tr[:, i] for i, name in enumerate(_components("f", LOCAL, nt))}

        def global_vector(a: np.ndarray) -> np.ndarray:  # local components -> (n, 3) global
            k = a.shape[1]
            g = np.einsum("cqji,cqj->cqi", el.Q[..., :k, :], a.reshape(el.n_elements, el.nq, k))
            vec = np.zeros((n, 3))
            vec[:, :gdim] = g.reshape(n, gdim)
            return vec

        out["traction_global"] = global_vector(tr)
        out["status"] = np.asarray(status, dtype=np.int32)
        st = el.state.old
        for var in self.law.variables:
            if not var.output:
                continue
            width = int(np.prod(var.array_shape(1, nt)[1:]))
            a = np.asarray(st[var.name], dtype=float).reshape(n, width)
            for i, name in enumerate(_components(var.name, var.shape, nt)):
                out[name] = a[:, i]
            if var.shape != SCALAR:
                out[f"{var.name}_global"] = global_vector(a)
        return out

    def write(self, t: float) -> None:
        """Write the current (converged) state at time ``t`` (collective).

        Raises:
            PointCloudError: On every rank, if any rank failed; the file is closed.
        """
        if self._f is None:
            raise PointCloudError(f"interface point output {self.h5path} is closed")
        # three phases, each agreed on before the next collective call: the values (local),
        # the metadata (collective: the same calls on every rank), the slabs (independent)
        values: dict[str, np.ndarray] = {}
        error = None
        try:
            values = self._values()
        except Exception as e:
            error = e
        self._agree_or_close(error)
        k = len(self.times)
        datasets = {}
        error = None
        try:
            g = self._f.create_group(f"step_{k}")
            g.attrs["time"] = float(t)
            for name, a in values.items():
                datasets[name] = self._dataset(g, name, (self.n_points, *a.shape[1:]), a.dtype)
                datasets[name].attrs["unit"] = self.units.get(name, "?")
        except Exception as e:
            error = e
        self._agree_or_close(error)
        error = None
        try:
            for name, a in values.items():
                self._write_slab(datasets[name], a)
        except Exception as e:
            error = e
        self._agree_or_close(error)
        error = None
        try:
            self._f.flush()
        except Exception as e:
            error = e
        self._agree_or_close(error)
        self.times.append(float(t))
        self.arrays = [(n, "Vector" if a.ndim == 2 else "Scalar") for n, a in values.items()]
        error = None
        if self.comm.rank == 0:
            try:
                self._write_xdmf()
            except Exception as e:
                error = e
        self._agree_or_close(error)

    def _write_xdmf(self) -> None:
        """The XDMF text for the steps written so far (rank 0; replaced atomically)."""
        p, gdim = self.n_points, self.gdim
        h5 = escape(self.h5path.name)

        def item(path: str, dims: str, number: str = "Float", precision: int = 8) -> str:
            return (
                f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="{precision}" '
                f'Format="HDF">{h5}:{path}</DataItem>'
            )

        geometry = item("/geometry", f"{p} {gdim}")
        topology = item("/topology", f"{p} 1", "Int", 8)
        lines = [
            '<?xml version="1.0"?>',
            '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">',
            "<Domain>",
            *(
                f"<Information Name={quoteattr(k)} Value={quoteattr(v)}/>"
                for k, v in file_attributes(self.problem.law, gdim).items()
            ),
            '<Grid Name="interface_points" GridType="Collection" CollectionType="Temporal">',
        ]
        for k, t in enumerate(self.times):
            lines += [
                f'<Grid Name="step_{k}" GridType="Uniform">',
                f'<Time Value="{t!r}"/>',
                f'<Topology TopologyType="Polyvertex" NumberOfElements="{p}" '
                f'NodesPerElement="1">{topology}</Topology>',
                f'<Geometry GeometryType="{"XY" if gdim == 2 else "XYZ"}">{geometry}</Geometry>',
                f'<Attribute Name="rank" AttributeType="Scalar" Center="Node">'
                f"{item('/rank', str(p), 'Int', 4)}</Attribute>",
            ]
            for name, kind in self.arrays:
                dims = f"{p} 3" if kind == "Vector" else str(p)
                number, prec = ("Int", 4) if name == "status" else ("Float", 8)
                unit = quoteattr(self.units.get(name, "?"))
                lines.append(
                    f'<Attribute Name={quoteattr(name)} AttributeType="{kind}" '
                    f'Center="Node"><Information Name="unit" Value={unit}/>'
                    f"{item(f'/step_{k}/{name}', dims, number, prec)}</Attribute>"
                )
            lines.append("</Grid>")
        lines += ["</Grid>", "</Domain>", "</Xdmf>", ""]
        tmp = self.path.with_name(self.path.name + ".tmp")
        if tmp.is_symlink():  # our temporary name: a planted link is removed, not followed
            tmp.unlink()
        write_text_nofollow(tmp, "\n".join(lines))
        os.replace(tmp, self.path)

    def close(self) -> None:
        """Close the HDF5 file (collective); closing twice does nothing."""
        if self._f is None:
            return
        error = None
        try:
            self._f.close()
        except Exception as e:
            error = e
        self._f = None
        _agree(self.comm, error)

    def __enter__(self) -> InterfacePointsXDMF:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.close()
        else:
            self._close_quietly()
