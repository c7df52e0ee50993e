"""Displacement and interface fields over time for ParaView (VTX or XDMF).

The interface fields are ``f_t`` (tangential traction, as a vector in global components), ``f_n``
and every internal variable of the law (tangential ones as vectors in global components, scalar
ones as they are) and the fixed point data (the initial gap ``g0``; ``region``, the region
number, with interface regions), as cell averages of the quadrature values on the interface
submesh (DG0).
Displacement of degree 2 is written as is in VTX and interpolated to degree 1 in XDMF (which needs
the mesh's degree). Collective.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import dolfinx
import dolfinx.io
import numpy as np

from ..constitutive import SCALAR

__all__ = ["FieldWriter"]


class FieldWriter:
    """Displacement and interface fields over time, for ParaView.

    Args:
        directory: Output directory (created).
        problem: The problem.
        fmt: ``"vtx"`` (``displacement.bp``, ``interface.bp``) or ``"xdmf"``
            (``displacement.xdmf``, ``interface.xdmf``).
    """

    def __init__(self, directory: str | Path, problem: Any, fmt: str = "vtx") -> None:
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
        gdim = el.gdim
        D0s = dolfinx.fem.functionspace(sub, ("DG", 0))
        D0v = dolfinx.fem.functionspace(sub, ("DG", 0, (gdim,)))
        F = dolfinx.fem.Function
        self.fields = {"f_t": F(D0v, name="f_t"), "f_n": F(D0s, name="f_n")}
        for var in problem.law.variables:
            space = D0s if var.shape == SCALAR else D0v
            self.fields[var.name] = F(space, name=var.name)
        for k in el.point_data:
            self.fields[k] = F(D0s, name=k)
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
        nf, nq, nt, gdim = el.n_elements, el.nq, el.nt, el.gdim
        w = el.w_ref / el.w_ref.sum()
        st = el.state.old
        tr = el.last.traction if el.last is not None else np.zeros((nf * nq, gdim))

        def avg(a: np.ndarray) -> np.ndarray:
            return np.einsum("q,cq...->c...", w, a.reshape(nf, nq, *a.shape[1:]))

        def global_vector(a: np.ndarray) -> np.ndarray:  # local components -> global vector
            k = a.shape[1]
            R = el.Q[..., :k, :]  # rows e1 [e2] (tangential) [-n] (local)
            return avg(np.einsum("cqi,cqid->cqd", a.reshape(nf, nq, k), R).reshape(-1, gdim))

        self.fields["f_t"].x.array[:] = global_vector(tr[:, :nt]).ravel()
        self.fields["f_n"].x.array[:] = avg(tr[:, nt])
        for var in self.problem.law.variables:
            a = st[var.name]
            self.fields[var.name].x.array[:] = (
                avg(a) if var.shape == SCALAR else global_vector(a).ravel()
            )
        for k, a in el.point_data.items():
            self.fields[k].x.array[:] = avg(a)

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
