"""Displacement and interface fields over time for ParaView (VTX or XDMF).

The interface fields, named as in every output (:mod:`.units`), are ``f_t1`` [``f_t2``] and
``f_n`` (the traction's local components), ``traction_global`` (the traction on the primary body
in global components, for glyphs), every output variable of the law (a scalar as it is, a vector
by its local components ``up_t1`` ... and as ``<v>_global`` in global components) and the fixed
point data (the initial gap ``g0``; ``region``, the region number, with interface regions), as
cell averages of the quadrature values on the interface submesh (DG0). Their units, the frame
and the ``status`` legend are in ``units.json`` beside the files, and, once the files are closed,
in the files themselves: in XDMF (:func:`annotate_xdmf`) an ``Information`` element ``unit`` in
each ``Attribute``, the file's ``frame`` and ``status_legend`` in its ``Domain``, and the
attribute ``unit`` of each function's group in the ``.h5`` file; in VTX (ADIOS2 BP4,
:func:`~.vtx.annotate_vtx`) the ADIOS2 attributes ``<name>/unit`` of each function, ``frame``
and ``status_legend``, in the file's first step (the file copied with them, the number of steps
unchanged; left without them, ``units.json`` then their only record, when ADIOS2's Python
bindings are not installed).
Displacement of degree 2 is written as is in VTX and interpolated to degree 1 in XDMF (which needs
the mesh's degree). Collective.

Failures are collective (:mod:`.collective`): the directory is created and probed by rank 0, and
every write ends with the ranks agreeing on its outcome. ADIOS2 (VTX) and DOLFINx's HDF5 (XDMF)
write collectively: a full disk stops one rank inside an MPI collective where the others wait
for it (a hang, then SIGABRT at exit). So before each write rank 0 checks that the
file system has room for :meth:`FieldWriter.space_needed`: four times what a step takes
(``step_bytes``, twice the largest step: estimated from the mesh sizes, then taken from the
steps written) plus :data:`MARGIN` (64 KiB: what closing the files adds, ``profiling.json`` of
ADIOS2, HDF5's metadata, the end of the XDMF file), and ends the run with an
:class:`~.collective.OutputError` on every rank when it has not. The room asked for grows with
the step (a fixed margin would refuse a small step on a nearly full disk, or let a large one
fail): ADIOS2 (BP4) writes a step's data and metadata at the step, and closing adds a few hundred
bytes. A disk filled by
another process between that check and the write is not covered.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import dolfinx
import dolfinx.io
import numpy as np

from ..compat import coordinate_element, geometry_dofmap
from ..constitutive import SCALAR
from .collective import collective, ensure_space, probe_directory
from .gather import interface_of
from .links import refuse_links, write_text_nofollow
from .paths import inside, interface_stems
from .units import FRAME, interface_units, status_legend
from .vtx import annotate_vtx

__all__ = ["FieldWriter", "annotate_xdmf"]

MARGIN = 64 << 10
"""Bytes asked for beyond the steps' share (:meth:`FieldWriter.space_needed`): the files' close."""


def annotate_xdmf(
    path: str | Path, units: Mapping[str, str], attributes: Mapping[str, str] | None = None
) -> None:
    """Write units into a closed XDMF file of DOLFINx's and its HDF5 file (one process).

    Each ``<Attribute Name="X">`` gets ``<Information Name="unit" Value="..."/>`` (``"?"`` for a
    name ``units`` lacks), the ``Domain`` one ``Information`` element per entry of
    ``attributes`` (e.g. the frame and the status legend), and in the ``.h5`` file each group
    ``/Function/X`` the attribute ``unit``. An annotated file is left as it is.

    Args:
        path: The ``.xdmf`` file.
        units: Function name -> unit.
        attributes: File-level name -> text.
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    if '<Information Name="unit"' in text:
        return
    names = set(re.findall(r'<Attribute Name="([^"]+)"', text))

    def unit(m: re.Match) -> str:
        return f'{m.group(0)}<Information Name="unit" Value={quoteattr(units.get(m[1], "?"))}/>'

    text = re.sub(r'<Attribute Name="([^"]+)"[^>]*>', unit, text)
    info = "".join(
        f"<Information Name={quoteattr(k)} Value={quoteattr(v)}/>"
        for k, v in (attributes or {}).items()
    )
    text = text.replace("<Domain>", f"<Domain>{info}", 1)
    tmp = path.with_name(path.name + ".tmp")
    if tmp.is_symlink():
        tmp.unlink()
    write_text_nofollow(tmp, text)
    tmp.replace(path)
    h5 = path.with_suffix(".h5")
    if h5.is_file() and not h5.is_symlink():
        import h5py

        with h5py.File(h5, "a") as f:
            for name in sorted(names):
                group = f.get(f"Function/{name}")
                if group is not None:
                    group.attrs["unit"] = units.get(name, "?")


def _mesh_bytes(mesh: Any) -> int:
    """Bytes of a mesh's geometry and topology as written (an upper estimate)."""
    g = mesh.geometry
    n_nodes = g.index_map().size_global
    n_cells = mesh.topology.index_map(mesh.topology.dim).size_global
    return 8 * (3 * n_nodes + (geometry_dofmap(mesh).shape[1] + 2) * n_cells)


def _dir_bytes(d: Path) -> int:
    total = 0
    for p in d.rglob("*"):
        try:
            total += p.lstat().st_size
        except OSError:
            pass
    return total


class FieldWriter:
    """Displacement and interface fields over time, for ParaView.

    Args:
        directory: Output directory (created).
        problem: The problem.
        fmt: ``"vtx"`` (``displacement.bp``, ``interface.bp``) or ``"xdmf"``
            (``displacement.xdmf``, ``interface.xdmf``); with several interfaces one file each,
            ``interface_<name>.bp`` (``.xdmf``; the name made safe, :func:`~.paths.file_part`).
        extra_step_bytes: What the writes passed to :meth:`write` as ``also`` add per step
            (an estimate, for the first step's space check; later steps are measured).
    """

    def __init__(
        self, directory: str | Path, problem: Any, fmt: str = "vtx", extra_step_bytes: int = 0
    ) -> None:
        if fmt not in ("vtx", "xdmf"):
            raise ValueError(f"output format must be 'vtx' or 'xdmf', got {fmt!r}")
        comm = problem.comm
        self.dir = probe_directory(comm, directory, link_ok=False)
        self.problem = problem
        self.fmt = fmt
        ifaces = getattr(problem, "interfaces", None) or {"interface": None}
        F = dolfinx.fem.Function
        # one interface file per interface: interface.bp (or interface_<name>.bp with several)
        stems = interface_stems("interface", list(ifaces))
        self.parts: list[tuple[str, Any, Any, dict[str, Any]]] = []
        for name in ifaces:
            el, law = interface_of(problem, None if ifaces[name] is None else name)
            sub = el.submesh
            D0s = dolfinx.fem.functionspace(sub, ("DG", 0))
            D0v = dolfinx.fem.functionspace(sub, ("DG", 0, (el.gdim,)))
            nt = el.nt
            fields = {f"f_t{i + 1}": F(D0s, name=f"f_t{i + 1}") for i in range(nt)}
            fields["f_n"] = F(D0s, name="f_n")
            fields["traction_global"] = F(D0v, name="traction_global")
            for var in law.variables:
                if not var.output:
                    continue
                if var.shape == SCALAR:
                    fields[var.name] = F(D0s, name=var.name)
                    continue
                fields[f"{var.name}_global"] = F(D0v, name=f"{var.name}_global")
                for c in var.column_names(nt):
                    fields[c] = F(D0s, name=c)
            for k in el.point_data:
                fields[k] = F(D0s, name=k)
            self.parts.append((stems[name], el, law, fields))
        self.fields = self.parts[0][3]
        u = problem.u
        n_u = u.function_space.dofmap.index_map.size_global
        sub_bytes = 0
        for _, el, _, fields in self.parts:
            sub = el.submesh
            n_sub = sub.topology.index_map(sub.topology.dim).size_global
            sub_bytes += _mesh_bytes(sub) + 24 * n_sub * len(fields)
        self.step_bytes = 2 * (_mesh_bytes(problem.mesh) + 24 * n_u + sub_bytes + extra_step_bytes)
        self._wu: Any = None
        self._wi: Any = None
        self._u = u
        ensure_space(comm, self.dir, self.space_needed(), self._what("creating"))
        collective(
            comm,
            lambda: self._open(fmt),
            self._what("creating"),
            root=None,
            path=self.dir / "displacement",
            cleanup=self.abandon,
        )

    @staticmethod
    def file_names(fmt: str, interfaces: Sequence[str]) -> list[str]:
        """The names a writer creates in its directory, for a format and the interfaces' names.

        Raises:
            OutputError: Two interface names map to the same file (:mod:`.paths`).
        """
        stems = interface_stems("interface", interfaces).values()
        # .tmp, .old: annotate_xdmf's and annotate_vtx's
        exts = (".bp", ".bp.tmp", ".bp.old") if fmt == "vtx" else (".xdmf", ".h5", ".xdmf.tmp")
        return [n + e for n in ("displacement", *stems) for e in exts] + ["units.json"]

    def space_needed(self) -> int:
        """The free bytes a write asks for: ``2 step_bytes + MARGIN``.

        ``step_bytes`` is twice the largest step (estimated, then measured); twice that again
        leaves room for the close after the step and for the next step's check to see the disk
        filling before it is full.
        """
        return 2 * self.step_bytes + MARGIN

    def _what(self, verb: str, t: float | None = None) -> str:
        at = "" if t is None else f" at t = {t:.6g}"
        return f"{verb} the {self.fmt.upper()} fields in {str(self.dir)!r}{at}"

    def _open(self, fmt: str) -> None:
        problem, comm = self.problem, self.problem.comm
        u = problem.u
        gdim = problem.mesh.geometry.dim
        self._wi = []
        ifaces = getattr(problem, "interfaces", None) or {"interface": None}
        files = self.file_names(fmt, list(ifaces))
        path = {f: inside(self.dir, f) for f in files}  # .paths: every one inside the directory
        refuse_links(*path.values())  # .links
        units = {"displacement": "mm", "sigma": "MPa", "von_mises": "MPa"}
        for _, _, law, _ in self.parts:
            units.update(interface_units(law, gdim))
        self.units = units
        if comm.rank == 0:
            stems = ", ".join(stem for stem, _, _, _ in self.parts)
            meta = {
                "files": f"displacement, {stems} (DG0: the average of each interface "
                "facet) and stress, VTX (.bp) or XDMF",
                "units": units,
                "frame": FRAME,
                "status_legend": status_legend(),
            }
            write_text_nofollow(path["units.json"], json.dumps(meta, indent=1) + "\n")
        if fmt == "vtx":
            self._wu = dolfinx.io.VTXWriter(comm, path["displacement.bp"], [u], engine="BP4")
            for stem, _, _, fields in self.parts:
                self._wi.append(
                    dolfinx.io.VTXWriter(
                        comm, path[f"{stem}.bp"], list(fields.values()), engine="BP4"
                    )
                )
        else:
            mesh = problem.mesh
            cdeg = coordinate_element(mesh).degree
            if u.function_space.ufl_element().embedded_superdegree != cdeg:
                V1 = dolfinx.fem.functionspace(mesh, ("Lagrange", cdeg, (gdim,)))
                self._u = dolfinx.fem.Function(V1, name="displacement")
            self._wu = dolfinx.io.XDMFFile(comm, path["displacement.xdmf"], "w")
            self._wu.write_mesh(mesh)
            for stem, el, _, _ in self.parts:
                w = dolfinx.io.XDMFFile(comm, path[f"{stem}.xdmf"], "w")
                self._wi.append(w)
                w.write_mesh(el.submesh)

    def _update(self) -> None:
        for _, el, law, fields in self.parts:
            self._update_one(el, law, fields)

    @staticmethod
    def _update_one(el: Any, law: Any, fields: dict[str, Any]) -> None:
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

        for i in range(nt):
            fields[f"f_t{i + 1}"].x.array[:] = avg(tr[:, i])
        fields["f_n"].x.array[:] = avg(tr[:, nt])
        fields["traction_global"].x.array[:] = global_vector(tr).ravel()
        for var in law.variables:
            if not var.output:
                continue
            a = st[var.name]
            if var.shape == SCALAR:
                fields[var.name].x.array[:] = avg(a)
                continue
            fields[f"{var.name}_global"].x.array[:] = global_vector(a).ravel()
            for i, c in enumerate(var.column_names(nt)):
                fields[c].x.array[:] = avg(a[:, i])
        for k, a in el.point_data.items():
            fields[k].x.array[:] = avg(a)

    def write(self, t: float, also: Sequence[Callable[[], None]] = ()) -> None:
        """Write the current (converged) state at time ``t`` (collective).

        Args:
            t: The time.
            also: Other collective writes into the same directory at this step (e.g. the
                bodies' stress), made after these fields under the same space check and
                collective error handling, and counted in what a step takes.

        Raises:
            OutputError: On every rank: too little space left, or the write failed.
        """
        comm = self.problem.comm
        if self._wu is None:
            raise RuntimeError("the field writer is closed")
        self._update()
        if self._u is not self.problem.u:
            self._u.interpolate(self.problem.u)
        ensure_space(comm, self.dir, self.space_needed(), self._what("writing", t))
        before = _dir_bytes(self.dir) if comm.rank == 0 else 0

        def write() -> None:
            if self.fmt == "vtx":
                self._wu.write(t)
                for w in self._wi:
                    w.write(t)
            else:
                self._wu.write_function(self._u, t)
                for w, (_, _, _, fields) in zip(self._wi, self.parts, strict=True):
                    for f in fields.values():
                        w.write_function(f, t)
            for other in also:
                other()

        collective(
            comm,
            write,
            self._what("writing", t),
            root=None,
            path=self.dir / "displacement",
            cleanup=self.abandon,
        )
        if comm.rank == 0:  # what a step really took, for the next check
            self.step_bytes = max(self.step_bytes, 2 * (_dir_bytes(self.dir) - before))

    def abandon(self) -> None:
        """Close the files after a failure, ignoring errors (collective)."""
        for w in (self._wu, *(self._wi or [])):
            if w is not None:
                try:
                    w.close()
                except Exception:
                    pass
        self._wu = self._wi = None

    def close(self) -> None:
        """Close the files and write the units into them (collective; a failure on every rank)."""
        if self._wu is None:
            return

        def close() -> None:
            self._wu.close()
            for w in self._wi:
                w.close()

        comm = self.problem.comm
        try:
            collective(comm, close, self._what("closing"), root=None)
        finally:
            self._wu = self._wi = None
        files = ["displacement", *(stem for stem, _, _, _ in self.parts)]
        meta = {"frame": FRAME, "status_legend": json.dumps(status_legend())}
        if self.fmt == "vtx":
            for stem in files:
                annotate_vtx(comm, inside(self.dir, f"{stem}.bp"), self.units, meta)
        else:

            def annotate() -> None:
                for stem in files:
                    annotate_xdmf(inside(self.dir, f"{stem}.xdmf"), self.units, meta)

            collective(comm, annotate, self._what("writing the units into"), root=0)
