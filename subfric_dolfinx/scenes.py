"""Declarative scenes and one runner that builds only what a scene needs.

A scene is a small JSON-like configuration (or the dataclasses below), validated strictly:
an unknown key or a wrong type is an error naming its path (``scene.solver.dt``).

* ``{"kind": "pointwise", ...}``: material-point cases run by the driver. No mesh, no MPI, no
  DOLFINx: running one imports numpy and the constitutive core only.
* ``{"kind": "fe", ...}``: two bodies with a frictional interface. The mesh comes from a builder of
  :mod:`subfric_dolfinx.meshing` or a ``.msh`` file; its dimension decides the number of
  components (a 2-D scene has no third one). Output files (CSV history, VTX/XDMF fields) exist only
  if the scene asks for them; interface profiles at chosen times are returned in memory.

Example (the skeleton of the main demo)::

    scene = parse_scene({
        "kind": "fe", "name": "block",
        "mesh": {"builder": "block_on_base", "options": {"n_interface": 16}},
        "law": {"params": {"preset": "sec7"}},
        "materials": {"master": {"E": 2.1e5, "nu": 0.3}, "slave": {"E": 2.1e5, "nu": 0.3}},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
        "dirichlet": [{"group": "bottom", "value": [0, 0]},
                      {"group": "top", "component": 0, "value": 0.5, "amplitude": "slide"}],
        "loads": [{"type": "pressure", "group": "top", "value": 200, "amplitude": "press"}],
        "solver": {"prefix": "block_", "dt": 0.05},
        "outputs": {"history": True, "snapshots": [1.0, 2.0]},
    })
    result = run_scene(scene, outdir="output/block")
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
import types
import typing
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "DirichletSpec",
    "FEScene",
    "LoadSpec",
    "MeshSpec",
    "OutputSpec",
    "PointScene",
    "SceneError",
    "SceneInterrupted",
    "SceneResult",
    "SolverSpec",
    "parse_scene",
    "run_scene",
]


class SceneError(ValueError):
    """An invalid scene; the message names the offending key by its path."""


class SceneInterrupted(RuntimeError):
    """The run was stopped by SIGTERM after writing a checkpoint.

    Attributes:
        t: Time of the checkpoint.
        checkpoint: Its path.
    """

    def __init__(self, message: str, t: float, checkpoint: str) -> None:
        super().__init__(message)
        self.t, self.checkpoint = t, checkpoint


@dataclasses.dataclass(frozen=True)
class MeshSpec:
    """Where the mesh comes from.

    Attributes:
        builder: ``"block_on_base"`` (2-D) or ``"pad_on_plate"`` (3-D), built with gmsh.
        file: Or a ``.msh`` file (relative to the working directory).
        gdim: Geometric dimension of ``file``.
        options: Keyword arguments of the builder.
        partitioner: ``None``, ``"default"``, ``"bodies"`` or ``"together"``.
    """

    builder: str | None = None
    file: str | None = None
    gdim: int | None = None
    options: dict[str, Any] = dataclasses.field(default_factory=dict)
    partitioner: str | None = None


@dataclasses.dataclass(frozen=True)
class DirichletSpec:
    """Prescribed displacement ``(value + gradient . x) * amplitude(t)`` on a facet group.

    ``value`` is a list (all components) or a number with ``component``.
    """

    group: str
    value: float | list[float]
    component: int | None = None
    amplitude: str | None = None
    gradient: list[float] | None = None


@dataclasses.dataclass(frozen=True)
class LoadSpec:
    """A pressure (``value`` a number, positive inwards) or traction (``value`` a vector)."""

    type: str
    group: str
    value: float | list[float]
    amplitude: str | None = None


@dataclasses.dataclass(frozen=True)
class SolverSpec:
    """SNES prefix and load-stepping controls."""

    prefix: str
    dt: float
    dt_max: float | None = None
    dt_min: float | None = None
    max_cuts: int = 10
    options: dict[str, Any] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class OutputSpec:
    """What to produce; nothing by default.

    Attributes:
        history: Write ``history.csv`` (one row per converged step).
        fields: ``"vtx"`` or ``"xdmf"`` field output, or ``None``.
        field_times: Times at which fields are written (all steps if empty).
        snapshots: Times at which interface profiles are gathered and returned (steps end there).
        interface_history: Write ``interface_history.h5`` (every field at every step, see
            :class:`~subfric_dolfinx.output.InterfaceHistoryH5`).
        checkpoint_every: Write ``checkpoint.h5`` every so many converged steps (0: never).
        checkpoint_times: And at these times (steps end there).
        progress: Print a progress line per step on rank 0.

    With checkpoints enabled, SIGTERM makes the run write a checkpoint after the current step and
    stop (:class:`SceneInterrupted`), and a step that cannot be solved leaves the last converged
    state in the checkpoint.
    """

    history: bool = False
    fields: str | None = None
    field_times: list[float] = dataclasses.field(default_factory=list)
    snapshots: list[float] = dataclasses.field(default_factory=list)
    interface_history: bool = False
    checkpoint_every: int = 0
    checkpoint_times: list[float] = dataclasses.field(default_factory=list)
    progress: bool = True

    @property
    def checkpoints(self) -> bool:
        """Whether checkpoints are written."""
        return self.checkpoint_every > 0 or bool(self.checkpoint_times)


@dataclasses.dataclass(frozen=True)
class FEScene:
    """A finite-element scene: two elastic bodies and a frictional interface."""

    name: str
    mesh: MeshSpec
    law: dict[str, Any]
    materials: dict[str, dict[str, float]]
    program: dict[str, Any]
    solver: SolverSpec
    dirichlet: list[DirichletSpec] = dataclasses.field(default_factory=list)
    loads: list[LoadSpec] = dataclasses.field(default_factory=list)
    degree: int = 1
    quadrature: str = "gauss"
    outputs: OutputSpec = dataclasses.field(default_factory=OutputSpec)
    kind: str = "fe"


@dataclasses.dataclass(frozen=True)
class PointScene:
    """A pointwise scene: named material-point cases (see :mod:`subfric_dolfinx.driver`)."""

    name: str
    cases: dict[str, dict[str, Any]]
    steps_per_mm: float | None = None
    on_instability: str = "stop"
    save: bool = False
    kind: str = "pointwise"


# ----------------------------------------------------------------------------------------------
# Strict parsing


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp)).replace("NoneType", "null")


def _convert(value: Any, tp: Any, path: str) -> Any:
    origin = typing.get_origin(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        errors = []
        for option in typing.get_args(tp):
            try:
                return _convert(value, option, path)
            except SceneError as e:
                errors.append(str(e))
        names = " or ".join(_type_name(a) for a in typing.get_args(tp))
        raise SceneError(f"{path}: expected {names}, got {value!r}")
    if tp is type(None):
        if value is None:
            return None
        raise SceneError(f"{path}: expected null, got {value!r}")
    if dataclasses.is_dataclass(tp):
        return _from_dict(tp, value, path)
    if origin is list:
        if not isinstance(value, list | tuple):
            raise SceneError(f"{path}: expected a list, got {type(value).__name__} {value!r}")
        (item,) = typing.get_args(tp)
        return [_convert(v, item, f"{path}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise SceneError(f"{path}: expected an object, got {type(value).__name__} {value!r}")
        _, item = typing.get_args(tp)
        return {str(k): _convert(v, item, f"{path}.{k}") for k, v in value.items()}
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise SceneError(f"{path}: expected true or false, got {value!r}")
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise SceneError(f"{path}: expected an integer, got {value!r}")
    if tp is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            if not math.isfinite(float(value)):
                raise SceneError(f"{path}: expected a finite number, got {value!r}")
            return float(value)
        raise SceneError(f"{path}: expected a number, got {value!r}")
    if tp is str:
        if isinstance(value, str):
            return value
        raise SceneError(f"{path}: expected a string, got {value!r}")
    raise TypeError(f"unsupported annotation {tp!r} at {path}")


def _from_dict(cls: type, obj: Any, path: str) -> Any:
    if isinstance(obj, cls):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"{path}: expected an object, got {type(obj).__name__} {obj!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(obj) - set(fields))
    if unknown:
        raise SceneError(f"{path}: unknown key(s) {unknown}; allowed: {sorted(fields)}")
    kwargs = {}
    for name, f in fields.items():
        if name in obj:
            kwargs[name] = _convert(obj[name], hints[name], f"{path}.{name}")
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise SceneError(f"{path}: missing key '{name}'")
    return cls(**kwargs)


def _choice(path: str, value: Any, allowed: tuple) -> None:
    if value not in allowed:
        raise SceneError(f"{path}: must be one of {list(allowed)}, got {value!r}")


def parse_scene(obj: dict[str, Any] | FEScene | PointScene) -> FEScene | PointScene:
    """Validate a scene configuration.

    Raises:
        SceneError: Unknown key, missing key, wrong type or value; the message gives its path.
    """
    if isinstance(obj, FEScene | PointScene):
        return obj
    if not isinstance(obj, dict):
        raise SceneError(f"scene: expected an object, got {type(obj).__name__}")
    kind = obj.get("kind")
    _choice("scene.kind", kind, ("fe", "pointwise"))
    if kind == "pointwise":
        scene = _from_dict(PointScene, obj, "scene")
        _choice("scene.on_instability", scene.on_instability, ("stop", "continue"))
        from .driver import CaseError, parse_case

        for name, case in scene.cases.items():
            try:
                parse_case(case)
            except CaseError as e:
                raise SceneError(f"scene.cases.{name}: {e}") from None
        return scene
    scene = _from_dict(FEScene, obj, "scene")
    m = scene.mesh
    if (m.builder is None) == (m.file is None):
        raise SceneError("scene.mesh: give exactly one of 'builder' and 'file'")
    if m.builder is not None:
        _choice("scene.mesh.builder", m.builder, ("block_on_base", "pad_on_plate"))
    if m.file is not None and m.gdim not in (2, 3):
        raise SceneError(f"scene.mesh.gdim: must be 2 or 3 with a mesh file, got {m.gdim!r}")
    _choice("scene.mesh.partitioner", m.partitioner, (None, "default", "bodies", "together"))
    _choice("scene.degree", scene.degree, (1, 2))
    _choice("scene.quadrature", scene.quadrature, ("gauss", "nodal"))
    _choice("scene.outputs.fields", scene.outputs.fields, (None, "vtx", "xdmf"))
    for i, ld in enumerate(scene.loads):
        _choice(f"scene.loads[{i}].type", ld.type, ("pressure", "traction"))
    for body in ("master", "slave"):
        mat = scene.materials.get(body)
        if mat is None:
            raise SceneError(f"scene.materials: missing key '{body}'")
        if set(mat) != {"E", "nu"}:
            raise SceneError(
                f"scene.materials.{body}: keys must be 'E' and 'nu', got {sorted(mat)}"
            )
    extra = sorted(set(scene.materials) - {"master", "slave"})
    if extra:
        raise SceneError(f"scene.materials: unknown key(s) {extra}; allowed: ['master', 'slave']")
    prog = scene.program
    if set(prog) != {"times", "channels"}:
        raise SceneError(f"scene.program: keys must be 'times' and 'channels', got {sorted(prog)}")
    if scene.outputs.checkpoint_every < 0:
        raise SceneError(
            f"scene.outputs.checkpoint_every: must be >= 0, got {scene.outputs.checkpoint_every!r}"
        )
    if scene.solver.dt <= 0:
        raise SceneError(f"scene.solver.dt: must be > 0, got {scene.solver.dt!r}")
    # validate the law and program now (clear errors before any mesh is built)
    _build_law(scene.law)
    _build_program(prog)
    return scene


def _build_law(obj: dict[str, Any]) -> Any:
    from .driver import CaseError, parse_law

    allowed = {"law", "params"}
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise SceneError(f"scene.law: unknown key(s) {unknown}; allowed: {sorted(allowed)}")
    try:
        return parse_law(obj)
    except CaseError as e:
        raise SceneError(f"scene.law: {e}") from None


def _build_program(obj: dict[str, Any]) -> Any:
    from .loading import LoadingError, LoadingProgram

    try:
        return LoadingProgram(obj["times"], obj["channels"])
    except (LoadingError, TypeError, ValueError) as e:
        raise SceneError(f"scene.program: {e}") from None


# ----------------------------------------------------------------------------------------------
# Running


@dataclasses.dataclass
class SceneResult:
    """What a scene produced.

    Attributes:
        name: Scene name.
        kind: ``"fe"`` or ``"pointwise"``.
        cases: Pointwise: case name -> :class:`~subfric_dolfinx.driver.DriverResult`.
        history: FE: one dict per converged step (see :class:`~subfric_dolfinx.output.HistoryCSV`).
        snapshots: FE: time -> interface profile (arrays over all interface points, sorted by
            coordinates: ``x``, ``f_t``, ``f_n``, ``slip``, ``mu``, ``r``, ``status``).
        timing: FE: seconds per section (max over ranks) and ``total``.
        iterations: FE: Newton iterations per step.
        files: Paths written.
        info: Sizes (cells, dofs, interface points, ranks).
    """

    name: str
    kind: str
    cases: dict[str, Any] = dataclasses.field(default_factory=dict)
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)
    snapshots: dict[float, dict[str, np.ndarray]] = dataclasses.field(default_factory=dict)
    timing: dict[str, float] = dataclasses.field(default_factory=dict)
    iterations: list[int] = dataclasses.field(default_factory=list)
    files: list[str] = dataclasses.field(default_factory=list)
    info: dict[str, Any] = dataclasses.field(default_factory=dict)


def run_scene(
    scene: dict[str, Any] | FEScene | PointScene,
    *,
    outdir: str | Path | None = None,
    comm: Any = None,
    log: Any = print,
    restart: str | Path | None = None,
) -> SceneResult:
    """Run a scene, building only what it needs.

    Args:
        scene: The scene (validated with :func:`parse_scene`).
        outdir: Directory of the files the scene asks for (required if it asks for any).
        comm: MPI communicator of an FE scene (default ``COMM_WORLD``); unused for pointwise.
        log: Progress printer (rank 0); ``None`` for silence.
        restart: A checkpoint of this scene to continue from (any number of ranks).

    Raises:
        SceneError: Invalid scene, or outputs requested without ``outdir``.
        SceneInterrupted: SIGTERM received; a checkpoint was written.
        subfric_dolfinx.solver.StepFailure: A step could not be solved (with checkpoints enabled,
            the last converged state is in the checkpoint).
        subfric_dolfinx.checkpoint.CheckpointError: An unusable ``restart`` file.
    """
    scene = parse_scene(scene)
    if isinstance(scene, PointScene):
        if restart is not None:
            raise SceneError("a pointwise scene cannot be restarted")
        return _run_pointwise(scene, outdir)
    return _run_fe(scene, outdir, comm, log, restart)


def _run_pointwise(scene: PointScene, outdir: str | Path | None) -> SceneResult:
    from .driver import run_case

    if scene.save and outdir is None:
        raise SceneError("scene.save is true but no output directory was given")
    res = SceneResult(scene.name, "pointwise")
    for name, case in scene.cases.items():
        res.cases[name] = run_case(
            case, steps_per_mm=scene.steps_per_mm, on_instability=scene.on_instability
        )
    if scene.save:
        out = Path(outdir) / f"{scene.name}.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({k: v.to_dict() for k, v in res.cases.items()}, indent=1))
        res.files.append(str(out))
    return res


def _dirichlet(spec: DirichletSpec, gdim: int, path: str) -> Any:
    from .problem import Dirichlet

    if spec.gradient is None:
        return Dirichlet(spec.group, spec.value, spec.component, spec.amplitude)
    grad = np.asarray(spec.gradient, dtype=float)
    base = np.asarray(spec.value, dtype=float)
    if spec.component is not None:
        if grad.shape != (gdim,) or base.shape != ():
            raise SceneError(f"{path}: with a component, value is a number and gradient has {gdim}")

        def scalar(x: np.ndarray) -> np.ndarray:
            return base + grad @ x[:gdim]

        return Dirichlet(spec.group, scalar, spec.component, spec.amplitude)
    if grad.shape != (gdim, gdim) and grad.shape != (gdim * gdim,):
        raise SceneError(f"{path}.gradient: expected {gdim}x{gdim} values for a vector value")
    G = grad.reshape(gdim, gdim)

    def vector(x: np.ndarray) -> np.ndarray:
        return base[:, None] + G @ x[:gdim]

    return Dirichlet(spec.group, vector, None, spec.amplitude)


def _run_fe(
    scene: FEScene, outdir: str | Path | None, comm: Any, log: Any, restart: Any
) -> SceneResult:
    import signal
    import threading

    from mpi4py import MPI
    from petsc4py import PETSc

    from . import meshing
    from .checkpoint import restore_checkpoint, write_checkpoint
    from .output import FieldWriter, HistoryCSV, InterfaceHistoryH5, interface_summary
    from .problem import InterfaceProblem, Material, Pressure, Traction
    from .solver import FrictionSolver, LoadStepper, StepFailure, timing_breakdown

    comm = MPI.COMM_WORLD if comm is None else comm
    out = scene.outputs
    wants_files = out.history or out.fields is not None or out.interface_history or out.checkpoints
    if wants_files and outdir is None:
        raise SceneError("scene.outputs asks for files but no output directory was given")
    say = log if (log is not None and comm.rank == 0) else None
    t_start = time.perf_counter()
    PETSc.Log.begin()
    law = _build_law(scene.law)
    program = _build_program(scene.program)
    m = scene.mesh
    if m.builder is not None:
        builder = {
            "block_on_base": meshing.build_block_on_base,
            "pad_on_plate": meshing.build_pad_on_plate,
        }
        dom, _ = meshing.create_interface_mesh(
            builder[m.builder], comm, partitioner=m.partitioner, **m.options
        )
    else:
        dom = meshing.read_interface_mesh(m.file, comm, m.gdim, partitioner=m.partitioner)
    gdim = dom.mesh.geometry.dim
    bcs = [_dirichlet(d, gdim, f"scene.dirichlet[{i}]") for i, d in enumerate(scene.dirichlet)]
    loads = [
        Pressure(ld.group, float(ld.value), ld.amplitude)  # type: ignore[arg-type]
        if ld.type == "pressure"
        else Traction(ld.group, ld.value, ld.amplitude)  # type: ignore[arg-type]
        for ld in scene.loads
    ]
    mats = {k: Material(v["E"], v["nu"]) for k, v in scene.materials.items()}
    problem = InterfaceProblem(
        dom, law, mats, program, bcs, loads, degree=scene.degree, quadrature=scene.quadrature
    )
    solver = FrictionSolver(problem, scene.solver.prefix, scene.solver.options)
    res = SceneResult(scene.name, "fe")
    tdim = dom.mesh.topology.dim
    res.info = {
        "ranks": comm.size,
        "cells": dom.mesh.topology.index_map(tdim).size_global,
        "dofs": problem.V.dofmap.index_map.size_global * problem.V.dofmap.bs,
        "interface points": comm.allreduce(problem.interface.n_elements * problem.interface.nq),
        "gdim": gdim,
    }
    outdir = Path(outdir) if outdir is not None else None
    stepper = LoadStepper(
        solver,
        scene.solver.dt,
        dt_max=scene.solver.dt_max,
        dt_min=scene.solver.dt_min,
        max_cuts=scene.solver.max_cuts,
        log=say if out.progress else None,
    )
    history = HistoryCSV(outdir / "history.csv" if out.history else None, problem)
    restart_time = None
    if restart is not None:
        history.preload(restore_checkpoint(restart, problem, stepper))
        restart_time = stepper.t
        if say:
            say(
                f"[{scene.name}] restarted from {restart} at t = {stepper.t:.6g} "
                f"(step {stepper.step})"
            )
    fields = FieldWriter(outdir / "fields", problem, out.fields) if out.fields else None
    ihist = (
        InterfaceHistoryH5(outdir / "interface_history.h5", problem, restart_time)
        if out.interface_history
        else None
    )
    ck_path = outdir / "checkpoint.h5" if out.checkpoints else None
    ck_times = np.asarray(out.checkpoint_times, dtype=float)
    field_times = np.asarray(out.field_times, dtype=float)
    snaps = np.asarray(out.snapshots, dtype=float)
    stop = threading.Event()

    def on_step(rec: Any) -> None:
        history.write(rec)
        res.iterations.append(rec.iterations)
        if ihist is not None:
            ihist.write(rec.t)
        if fields is not None and (
            field_times.size == 0 or np.any(np.isclose(field_times, rec.t, atol=1e-9))
        ):
            fields.write(rec.t)
        hit = np.isclose(snaps, rec.t, atol=1e-9)
        if np.any(hit):
            res.snapshots[float(snaps[hit][0])] = _profile(problem)
        if ck_path is not None:
            due = (out.checkpoint_every and rec.step % out.checkpoint_every == 0) or np.any(
                np.isclose(ck_times, rec.t, atol=1e-9)
            )
            stopping = comm.allreduce(stop.is_set(), op=MPI.LOR)
            if due or stopping:
                write_checkpoint(ck_path, problem, stepper, history.rows)
                res.files.append(str(ck_path))
            if stopping:
                raise SceneInterrupted(
                    f"interrupted by SIGTERM after step {rec.step} at t = {rec.t:.6g}; "
                    f"checkpoint written to {ck_path}",
                    rec.t,
                    str(ck_path),
                )

    stepper.on_step = on_step
    previous = None
    if ck_path is not None and threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, lambda *_: stop.set())

    if say:
        i = res.info
        say(
            f"[{scene.name}] {i['gdim']}-D, {i['cells']} cells, {i['dofs']} dofs, "
            f"{i['interface points']} interface points, {i['ranks']} rank(s)"
        )
    try:
        stepper.run(stops=[*out.snapshots, *out.field_times, *out.checkpoint_times])
    except StepFailure:
        if ck_path is not None:  # the last converged state, for a restart with other settings
            write_checkpoint(ck_path, problem, stepper, history.rows)
            res.files.append(str(ck_path))
        raise
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        history.close()
        if fields is not None:
            fields.close()
        if ihist is not None:
            ihist.close()
            res.files.append(str(outdir / "interface_history.h5"))
        res.history = history.rows
        res.timing = timing_breakdown(problem, solver)
        res.timing["total"] = comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
        res.info["summary"] = interface_summary(problem)
        if out.history:
            res.files.append(str(outdir / "history.csv"))
        if fields is not None:
            res.files.append(str(outdir / "fields"))
        solver.destroy()
    if say:
        from .solver import format_breakdown

        t = dict(res.timing)
        total = t.pop("total")
        say(format_breakdown(t, total))
        its = res.iterations
        say(
            f"[{scene.name}] {len(its)} steps, Newton iterations per step: mean "
            f"{np.mean(its):.2f}, max {max(its)}"
        )
    return res


def _profile(problem: Any) -> dict[str, np.ndarray]:
    """Interface fields at all points, gathered on every rank and sorted by coordinates."""
    el = problem.interface
    comm = problem.comm
    nt = el.nt
    st = el.state.old
    tr = el.last.traction
    local = np.column_stack(
        [el.points.reshape(-1, el.gdim), tr[:, :nt], tr[:, nt], st.up, st.mu, st.r, el.last.status]
    )
    allp = np.concatenate(comm.allgather(local)).reshape(-1, local.shape[1])
    gd = el.gdim
    order = np.lexsort(allp[:, :gd].T[::-1])
    allp = allp[order]
    c = gd
    return {
        "x": allp[:, :gd],
        "f_t": allp[:, c : c + nt],
        "f_n": allp[:, c + nt],
        "slip": allp[:, c + nt + 1 : c + 2 * nt + 1],
        "mu": allp[:, c + 2 * nt + 1],
        "r": allp[:, c + 2 * nt + 2],
        "status": allp[:, c + 2 * nt + 3].astype(int),
    }
