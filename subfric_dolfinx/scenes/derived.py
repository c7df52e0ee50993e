"""Derived outputs of an FE scene: probes, spring forces, reactions in local frames, stresses.

:class:`DerivedOutputs` adds columns to the history row of every converged step (collective):

* ``S_<group>_x`` ...: the force of a group's springs on the body;
* ``R_<name>_t``, ``R_<name>_n`` (2-D) or ``R_<name>_t1``, ``_t2``, ``_n`` (3-D): the reaction of
  a group (its Dirichlet conditions, or else its springs' force) resolved in a local frame;
* ``<point>.<quantity>`` for each probe: ``u_x`` ... (displacement), ``sigma_xx`` ...
  (the 9 stress components), ``von_mises``; at the interface quadrature point nearest to the
  point: ``f_t1`` [``f_t2``], ``f_n``, ``gap_t1`` [``gap_t2``], ``gap_n``, ``status`` and the law's
  variables (``mu``, ``up_t1`` ...).

With ``outputs.stress`` it writes the Cauchy stress (3 x 3) and von Mises stress of the bodies
(:class:`~subfric_dolfinx.fem.stress.StressField`, interpolated in a DG space one degree below the
displacement) to ``fields/stress.bp`` (VTX) or ``fields/stress.xdmf`` with the other fields.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import dolfinx.io
import numpy as np

from ..fem.probes import InterfacePointProbe, PointEvaluator
from ..fem.stress import STRESS_COMPONENTS, StressField
from ..io.collective import collective
from ..io.fields import annotate_xdmf
from ..io.links import refuse_links
from ..io.paths import inside
from ..io.vtx import annotate_vtx
from .parse_features import frame_axes
from .schema import FEScene, SceneError

__all__ = ["DerivedOutputs"]

_BODY_FIELDS = ("u", "sigma", "von_mises")


class DerivedOutputs:
    """Probes, spring forces, frame reactions and stress fields of a scene (collective).

    Args:
        scene: The validated scene.
        problem: Its problem.
        fields_dir: Directory of the field output (``None``: no stress files).
    """

    def __init__(self, scene: FEScene, problem: Any, fields_dir: Path | None = None) -> None:
        out = scene.outputs
        self.problem = problem
        gdim = problem.gdim
        self.gdim = gdim
        self.probes = list(out.probes)
        wanted = {f for p in self.probes for f in p.fields}
        needs_stress = out.stress or bool(wanted & {"sigma", "von_mises"})
        self.stress = StressField(problem) if needs_stress else None
        names = list(dict.fromkeys(p.point for p in self.probes))
        pts = [scene.points[n] for n in names]
        self._index = {n: i for i, n in enumerate(names)}
        x = np.array([p.x for p in pts], dtype=float).reshape(-1, gdim)
        self.evaluator = None
        if wanted & set(_BODY_FIELDS):
            self.evaluator = PointEvaluator(problem.domain, x, [p.body for p in pts], names)
        # interface probes: the points at the quadrature points of each probe's interface
        self.iprobes: dict[str, InterfacePointProbe] = {}
        ifaces = problem.interfaces
        self._iface_of: dict[str, str] = {}
        for p in self.probes:
            if not set(p.fields) - set(_BODY_FIELDS):
                continue
            iname = p.interface or next(iter(ifaces))
            if iname not in ifaces:
                raise SceneError(
                    f"scene.outputs.probes: point {p.point!r}: no interface {iname!r}; "
                    f"interfaces: {sorted(ifaces)}"
                )
            if p.interface is None and len(ifaces) > 1:
                raise SceneError(
                    f"scene.outputs.probes: point {p.point!r}: the scene has the interfaces "
                    f"{sorted(ifaces)}: say which one ('interface')"
                )
            self._iface_of[p.point] = iname
        for iname in dict.fromkeys(self._iface_of.values()):
            self.iprobes[iname] = InterfacePointProbe(ifaces[iname].law_points, x)
        self.frames = [
            (f.name or f.group, f.group, np.asarray(frame_axes(f.normal, f.tangent, f.group)))
            for f in out.reaction_frames
        ]
        self.writer: Any = None
        self.fmt = out.fields
        if out.stress and fields_dir is not None:
            self._open(fields_dir)

    # -- history ---------------------------------------------------------------------------------
    def columns(self) -> dict[str, float]:
        """The extra history columns of the current (converged) state (collective)."""
        p = self.problem
        row: dict[str, float] = {}
        xyz = "xyz"[: self.gdim]
        springs = p.spring_forces(p.u.x.array, p.program, p.t)
        for group, force in springs.items():
            row.update({f"S_{group}_{c}": float(v) for c, v in zip(xyz, force, strict=True)})
        for name, group, axes in self.frames:
            force = p.reactions.get(group, springs.get(group))
            local = axes @ np.asarray(force, dtype=float)
            labels = ["t", "n"] if self.gdim == 2 else ["t1", "t2", "n"]
            row.update({f"R_{name}_{c}": float(v) for c, v in zip(labels, local, strict=True)})
        if self.probes:
            row.update(self._probe_columns())
        return row

    def _probe_columns(self) -> dict[str, float]:
        p = self.problem
        values: dict[str, np.ndarray] = {}
        if self.evaluator is not None:
            values["u"] = self.evaluator.eval(p.u)
            if self.stress is not None:
                self.stress.update()
                values["sigma"] = self.evaluator.eval(self.stress.sigma)
                values["von_mises"] = self.evaluator.eval(self.stress.von_mises)
        labels: dict[str, list[str]] = {
            "u": [f"u_{c}" for c in "xyz"[: self.gdim]],
            "sigma": [f"sigma_{c}" for c in STRESS_COMPONENTS],
            "von_mises": ["von_mises"],
        }
        per_iface: dict[str, dict[str, np.ndarray]] = {}
        for iname, iprobe in self.iprobes.items():
            iface = p.interfaces[iname]
            el = iface.law_points
            nt = el.nt
            n = el.n_elements * el.nq
            tr = el.last.traction if el.last is not None else np.zeros((n, nt + 1))
            status = el.last.status if el.last is not None else np.zeros(n)
            arrays = {
                "f_t": tr[:, :nt],
                "f_n": tr[:, nt],
                "gap": el.last_gap,
                "status": status,
                **dict(el.state.old.items()),
            }
            per_iface[iname] = iprobe.values(arrays)
            tang = [f"t{i + 1}" for i in range(nt)]
            labels.update(
                f_t=[f"f_{t}" for t in tang],
                f_n=["f_n"],
                gap=[f"gap_{t}" for t in tang] + ["gap_n"],
                status=["status"],
            )
            labels.update({v.name: v.column_names(nt) for v in iface.law.variables})
        row: dict[str, float] = {}
        for probe in self.probes:
            i = self._index[probe.point]
            for field in probe.fields:
                source = values if field in _BODY_FIELDS else per_iface[self._iface_of[probe.point]]
                for label, v in zip(labels[field], source[field][i], strict=True):
                    row[f"{probe.point}.{label}"] = float(v)
        return row

    # -- fields ----------------------------------------------------------------------------------
    def _open(self, directory: Path) -> None:
        comm = self.problem.comm
        names = ["stress.bp"] if self.fmt == "vtx" else ["stress.xdmf", "stress.h5"]
        collective(  # before anything is written (.io.links, .io.paths)
            comm,
            lambda: refuse_links(directory, *(inside(directory, n) for n in names)),
            f"writing the stress in {str(directory)!r}",
            path=directory,
        )
        if comm.rank == 0:
            directory.mkdir(parents=True, exist_ok=True)
        comm.Barrier()
        s = self.stress
        assert s is not None
        if self.fmt == "vtx":
            self.writer = dolfinx.io.VTXWriter(
                comm, directory / "stress.bp", [s.sigma, s.von_mises], engine="BP4"
            )
        else:
            self.writer = dolfinx.io.XDMFFile(comm, directory / "stress.xdmf", "w")
            self.writer.write_mesh(self.problem.mesh)
        self.path = directory / ("stress.bp" if self.fmt == "vtx" else "stress.xdmf")

    def field_bytes(self) -> int:
        """What :meth:`write_fields` writes per step, about (bytes; 0 without stress files)."""
        if self.writer is None or self.stress is None:
            return 0
        n = 0
        for f in (self.stress.sigma, self.stress.von_mises):
            im = f.function_space.dofmap.index_map
            n += im.size_global * f.function_space.dofmap.index_map_bs
        return 8 * n

    def write_fields(self, t: float) -> None:
        """Write the stress of the current state at time ``t`` (collective; with fields only)."""
        if self.writer is None or self.stress is None:
            return
        self.stress.update()
        if self.fmt == "vtx":
            self.writer.write(t)
        else:
            self.writer.write_function(self.stress.sigma, t)
            self.writer.write_function(self.stress.von_mises, t)

    def close(self) -> None:
        """Close the stress file and write its units into it (collective)."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
            units = {"sigma": "MPa", "von_mises": "MPa"}
            if self.fmt == "vtx":
                annotate_vtx(self.problem.comm, self.path, units)
            else:
                collective(
                    self.problem.comm,
                    lambda: annotate_xdmf(self.path, units),
                    f"writing the units into {str(self.path)!r}",
                    path=self.path,
                )
