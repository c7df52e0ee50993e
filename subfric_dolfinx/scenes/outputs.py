"""The outputs of an FE scene, as one object fed once per converged step.

:class:`SceneOutputs` holds what the scene's ``outputs`` asked for and nothing else: the history
(always kept in memory, written as ``history.csv`` on request), field output, the HDF5 interface
history, checkpoints, and the interface profiles (snapshots): returned in memory (gathered on
every rank), or written to ``interface_profiles.h5`` (``snapshot_file``: each rank writes its
slab of the points, nothing is gathered). The runner calls
:meth:`SceneOutputs.on_step` after each converged step and :meth:`SceneOutputs.close` at the end
(it is a context manager).

Every file operation is collective (:mod:`subfric_dolfinx.io.collective`): a failure on any rank
is an :class:`~subfric_dolfinx.io.OutputError` (a :class:`~subfric_dolfinx.io.CheckpointError`
for checkpoints) on every rank, naming the file and the OS error, and every file is closed
however the run ends. The output directory itself is prepared (probed, locked, cleared of an
earlier run's files) by :class:`~subfric_dolfinx.io.OutputDirectory` in the runner.
"""

from __future__ import annotations

from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from ..io import (
    FieldWriter,
    HistoryCSV,
    InterfaceHistoryH5,
    InterfacePointsXDMF,
    gather_interface,
    interface_of,
    write_checkpoint,
)
from ..io.paths import inside, interface_stems
from .schema import OutputSpec
from .signals import SceneInterrupted

__all__ = ["SceneOutputs", "interface_profile", "planned_files"]


def _stems(names: list[str]) -> tuple[dict[str, str], dict[str, str], dict[str, str]]:
    """The stems of the point clouds, the interface histories and the profiles, per interface."""
    return (
        interface_stems("interface_points", names),
        interface_stems("interface_history", names),
        interface_stems("interface_profiles", names),
    )


def planned_files(spec: OutputSpec, names: list[str]) -> list[str]:
    """Every name a run with these outputs may write in its output directory (``/`` inside).

    With the temporary names and the HDF5 spares (:mod:`subfric_dolfinx.io.h5`); the names of
    interfaces made safe (:mod:`subfric_dolfinx.io.paths`). ``fields/`` is the directory of the
    field output, made by the run for its files (:class:`~subfric_dolfinx.io.OutputDirectory`:
    only the listed names in it are the run's).

    Raises:
        OutputError: Two interface names map to the same file.
    """
    points, ihist, profiles = _stems(names)
    files: list[str] = []
    if spec.history:
        meta = "history.csv-metadata.json"
        files += ["history.csv", meta, f"{meta}.tmp"]
    if spec.interface_history:
        files += [n for s in ihist.values() for n in (f"{s}.h5", f".{s}.h5.spare")]
    if spec.snapshot_file:
        files += [n for s in profiles.values() for n in (f"{s}.h5", f".{s}.h5.spare")]
    if spec.checkpoints:
        files += ["checkpoint.h5", "checkpoint.h5.tmp", ".checkpoint.h5.tmp.spare"]
    if spec.fields:
        vtx = ["stress.bp", "stress.bp.tmp", "stress.bp.old"]  # .tmp, .old: .io.vtx
        stress = vtx if spec.fields == "vtx" else ["stress.xdmf", "stress.h5"]
        inner = [*FieldWriter.file_names(spec.fields, names), *stress]
        inner += [n for s in points.values() for n in (f"{s}.xdmf", f"{s}.h5", f"{s}.xdmf.tmp")]
        files += ["fields/", *(f"fields/{n}" for n in inner)]
    return files


def interface_profile(problem: Any, interface: str | None = None) -> dict[str, np.ndarray]:
    """Interface fields at all points of an interface, gathered on every rank (collective).

    Every rank receives the whole interface: at scale, write the profiles to a file instead
    (the scene's ``outputs.snapshot_file``: the same rows, each rank writing its own).

    In the order of :func:`~subfric_dolfinx.io.gather_interface`: ``x``, ``f_t`` (n, nt), ``f_n``,
    ``status``, every internal variable of the law by name (e.g. ``up`` (n, nt), ``mu``, ``r``),
    the law's input gap ``gap`` (n, nt + 1: ``ubar_t``, ``ubar_n - g0``) and the fixed point data
    (``g0``, and ``region`` with regions). ``interface``: its name (``None``: the first).
    """
    el, _ = interface_of(problem, interface)
    nt = el.nt
    tr = el.last.traction
    values = {"f_t": tr[:, :nt], "f_n": tr[:, nt], "status": el.last.status}
    values.update(dict(el.state.old.items()))
    values["gap"] = el.last_gap
    values.update(el.point_data)
    out = gather_interface(el, values)
    out["status"] = out["status"].astype(int)
    if "region" in out:
        out["region"] = out["region"].astype(int)
    return out


class SceneOutputs:
    """What a scene asked for, written step by step.

    Args:
        spec: The scene's ``outputs``.
        outdir: Output directory (required when files are asked for).
        problem: The problem.
        stepper: The load stepper (its position goes into checkpoints).
        restart_time: Time of the checkpoint a restarted run continues from.
        restart_history: History rows of that checkpoint.
        settings: What a restart from its checkpoints must match (see
            :func:`~subfric_dolfinx.io.write_checkpoint`).
        derived: The scene's :class:`~.derived.DerivedOutputs` (history columns, stress fields).

    Attributes:
        history: The :class:`~subfric_dolfinx.io.HistoryCSV` (rows in memory).
        snapshots: Time -> :func:`interface_profile`, at the requested times (with several
            interfaces: time -> interface name -> profile); empty with ``snapshot_file`` (the
            profiles are in the file).
        iterations: Newton iterations per step.
        files: Paths written.
    """

    def __init__(
        self,
        spec: OutputSpec,
        outdir: Path | None,
        problem: Any,
        stepper: Any,
        *,
        restart_time: float | None = None,
        restart_history: list[dict[str, float]] | None = None,
        settings: dict[str, Any] | None = None,
        derived: Any = None,
    ) -> None:
        self.spec, self.problem, self.stepper = spec, problem, stepper
        self.settings = settings
        self.outdir = outdir
        self.files: list[str] = []
        self.snapshots: dict[float, dict[str, Any]] = {}
        self.iterations: list[int] = []
        self.fields: FieldWriter | None = None
        self.points: list[InterfacePointsXDMF] | None = None  # quadrature points (per interface)
        self.ihist: list[InterfaceHistoryH5] | None = None  # one file per interface
        self.profiles: list[InterfaceHistoryH5] | None = None  # snapshots, one file each
        self.derived = derived
        self.history = HistoryCSV(
            inside(outdir, "history.csv") if spec.history and outdir is not None else None,
            problem,
            derived.columns if derived is not None else None,
        )
        if restart_history:
            self.history.preload(restart_history)
        names = list(getattr(problem, "interfaces", None) or {"interface": None})
        self.interface_names = names
        points, ihist, profiles = _stems(names)
        self._names = {n: (f"fields/{points[n]}.xdmf", f"{ihist[n]}.h5") for n in names}
        self._profile_names = {n: f"{profiles[n]}.h5" for n in names}
        try:
            if spec.fields:
                assert outdir is not None
                extra = derived.field_bytes() if derived is not None else 0
                self.fields = FieldWriter(inside(outdir, "fields"), problem, spec.fields, extra)
                self.points = [
                    InterfacePointsXDMF(
                        inside(outdir, self._names[n][0]), problem, n if len(names) > 1 else None
                    )
                    for n in names
                ]
            if spec.interface_history:
                assert outdir is not None
                self.ihist = [
                    InterfaceHistoryH5(
                        inside(outdir, self._names[n][1]),
                        problem,
                        restart_time,
                        n if len(names) > 1 else None,
                    )
                    for n in names
                ]
            if spec.snapshot_file:
                assert outdir is not None
                self.profiles = [
                    InterfaceHistoryH5(
                        inside(outdir, self._profile_names[n]),
                        problem,
                        restart_time,
                        n if len(names) > 1 else None,
                        profiles=True,
                    )
                    for n in names
                ]
        except BaseException:
            try:
                self.close()
            except Exception:
                pass
            raise
        self.checkpoint_path = (
            inside(outdir, "checkpoint.h5") if spec.checkpoints and outdir is not None else None
        )
        self._ck_times = np.asarray(spec.checkpoint_times, dtype=float)
        self._field_times = np.asarray(spec.field_times, dtype=float)
        self._snaps = np.asarray(spec.snapshots, dtype=float)

    @property
    def stops(self) -> list[float]:
        """Times at which steps must end (snapshots, field and checkpoint times)."""
        return [*self.spec.snapshots, *self.spec.field_times, *self.spec.checkpoint_times]

    def write_checkpoint(self) -> None:
        """Write the converged state now (collective); nothing without checkpoints."""
        if self.checkpoint_path is not None:
            write_checkpoint(
                self.checkpoint_path, self.problem, self.stepper, self.history.rows, self.settings
            )
            self.files.append(str(self.checkpoint_path))

    def on_step(self, rec: Any, stopping: bool | str = False) -> None:
        """Record a converged step (collective).

        Args:
            rec: The :class:`~subfric_dolfinx.fem.StepRecord`.
            stopping: A stop was requested (true, or the signal's name): write a checkpoint and
                raise :class:`~.signals.SceneInterrupted`.
        """
        self.history.write(rec)
        self.iterations.append(rec.iterations)
        for h in self.ihist or []:
            h.write(rec.t)
        if self.fields is not None and (
            self._field_times.size == 0 or np.any(np.isclose(self._field_times, rec.t, atol=1e-9))
        ):
            derived = self.derived
            stress = () if derived is None else (lambda: derived.write_fields(rec.t),)
            self.fields.write(rec.t, also=stress)  # one space check, one collective outcome
            for pts in self.points or []:
                pts.write(rec.t)
        hit = np.isclose(self._snaps, rec.t, atol=1e-9)
        if np.any(hit) and self.profiles is not None:
            for p in self.profiles:
                p.write(float(self._snaps[hit][0]))
        elif np.any(hit):
            names = self.interface_names
            snap: dict[str, Any]  # one interface's profile, or each interface's by name
            if len(names) == 1:
                snap = interface_profile(self.problem)
            else:
                snap = {n: interface_profile(self.problem, n) for n in names}
            self.snapshots[float(self._snaps[hit][0])] = snap
        if self.checkpoint_path is None:
            return
        every = self.spec.checkpoint_every
        due = (every and rec.step % every == 0) or np.any(
            np.isclose(self._ck_times, rec.t, atol=1e-9)
        )
        if due or stopping:
            self.write_checkpoint()
        if stopping:
            raise SceneInterrupted(
                f"interrupted by {stopping if isinstance(stopping, str) else 'a signal'} after "
                f"step {rec.step} at t = {rec.t:.6g}; "
                f"checkpoint written to {self.checkpoint_path}",
                rec.t,
                str(self.checkpoint_path),
            )

    def close(self) -> None:
        """Close the files (collective) and list them in :attr:`files`.

        Every file is closed even if closing another failed; the first failure is then raised
        (on every rank).
        """
        first: Exception | None = None
        closers = [("history", self.history.close)]
        names = self.interface_names
        for n, pts in zip(names, self.points or [], strict=False):
            closers.append((self._names[n][0], pts.close))
        if self.fields is not None:
            closers.append(("fields", self.fields.close))
        for n, h in zip(names, self.ihist or [], strict=False):
            closers.append((self._names[n][1], h.close))
        for n, h in zip(names, self.profiles or [], strict=False):
            closers.append((self._profile_names[n], h.close))
        if self.derived is not None and self.derived.writer is not None:
            closers.append((str(self.derived.path), self.derived.close))
        for name, close in closers:
            try:
                close()
            except Exception as e:  # collective errors: the same on every rank
                first = first or e
            if self.outdir is None:
                continue
            if name == "history" and self.spec.history:
                self.files.append(str(self.outdir / "history.csv"))
            elif name != "history":
                self.files.append(str(self.outdir / name))
        self.fields = None
        self.points = None
        self.ihist = None
        self.profiles = None
        if first is not None:
            raise first

    def __enter__(self) -> SceneOutputs:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
            return
        try:  # the run's own error comes first
            self.close()
        except Exception:
            pass
