"""Running an FE scene: build, solve step by step, write what was asked for, clean up.

Everything from the solver's creation on is guarded: whatever ends the run (a finished program, a
:class:`~subfric_dolfinx.fem.StepFailure`, a stop signal, a bad restart file, a failed write), the
files are closed, the output directory's lock is released and the solver is destroyed (its
options prefix released).

Output directory: once the mesh and the problem are built (bad input writes nothing), the
directory is created, probed with a test write and locked for this run
(:class:`~subfric_dolfinx.io.OutputDirectory`); a fresh run moves an earlier run's files to
``previous_run/``. Checkpoints carry the scene's settings (:func:`restart_settings`), and a
restart refuses a checkpoint whose settings differ, naming the setting.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import logs
from ..constitutive import FrictionLaw, law_description
from ..fem import (
    FrictionSolver,
    LoadStepper,
    SolverOptionError,
    StepControl,
    StepFailure,
    StepInterrupted,
    format_breakdown,
    timing_breakdown,
)
from ..io import OutputDirectory, interface_summary, restore_checkpoint
from ..io.paths import inside
from .build import build_mesh, build_problem
from .derived import DerivedOutputs
from .outputs import SceneOutputs, planned_files
from .result import SceneResult
from .schema import FEScene, SceneError
from .signals import SceneInterrupted, StopSignals

__all__ = ["restart_settings", "run_fe_scene"]

logger = logging.getLogger(__name__)


# FEScene fields a restart does not compare here: the run's name and outputs, the solver (may
# change), the law and program (compared by restore_checkpoint), the points (compared where a
# condition uses them), the initial gap and regions (their point data g0 and region numbers are
# compared at every interface point, and the region laws with the law), and the parsed form of
# these (model)
_NOT_SETTINGS = {"name", "kind", "outputs", "solver", "law", "program", "points"}
_NOT_SETTINGS |= {"initial_gap", "regions", "model"}


def _plain(value: Any) -> Any:
    """A scene value as JSON-ready data (laws described, Python functions by a fixed label)."""
    if isinstance(value, FrictionLaw):
        return law_description(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: _plain(getattr(value, f.name))
            for f in dataclasses.fields(value)
            if not (f.metadata.get("omit_if_none") and getattr(value, f.name) is None)
        }
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    if value is None or isinstance(value, str | int | float | bool):
        return value
    if callable(value):  # code in a Python scene: compared through what it produces, if at all
        return "<a Python function>"
    return f"<a {type(value).__name__} object>"  # e.g. a UFL expression: by its kind only


def restart_settings(scene: FEScene) -> dict[str, Any]:
    """What a restart must match beyond the mesh, law and program (compared anyway).

    Every model input of the scene: the materials, the Dirichlet conditions and loads (values,
    components, channels), the springs, the point forces with their points' coordinates and
    bodies, the points Dirichlet conditions hold, the degree, the quadrature, the mesh builder's
    options (or the mesh file's name) and group names, and any other field of the scene (bodies,
    interfaces, mode) except the solver, the outputs and the name. Solver settings and the
    partitioner may change. The initial gap and the regions are compared point by point (``g0``,
    region numbers and laws). A field at its default is left out, so checkpoints written before
    it was compared still fit a run that does not use it.
    """
    mesh: dict[str, Any] = {"builder": scene.mesh.builder, "options": scene.mesh.options}
    if scene.mesh.file is not None:
        mesh = {"file": Path(scene.mesh.file).name, "gdim": scene.mesh.gdim}
    if scene.mesh.names:
        mesh["names"] = scene.mesh.names
    out: dict[str, Any] = {
        "materials": scene.materials,
        "dirichlet": [dataclasses.asdict(d) for d in scene.dirichlet],
        "loads": [dataclasses.asdict(ld) for ld in scene.loads],
        "quadrature": scene.quadrature,
        "mesh": mesh,
    }
    for f in dataclasses.fields(scene):
        if f.name in _NOT_SETTINGS or f.name in out:
            continue
        value = getattr(scene, f.name)
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        if value is default or (isinstance(value, list | dict | str | int) and value == default):
            continue
        if f.name == "point_forces":
            value = [{**_plain(pf), "at": _plain(scene.points.get(pf.point))} for pf in value]
        out[f.name] = _plain(value)
    held = [d.group for d in scene.dirichlet if d.group in scene.points]
    if held:
        out["dirichlet_points"] = {name: _plain(scene.points[name]) for name in held}
    return out


def largest_pressure(scene: FEScene) -> float | None:
    """The largest normal stress the scene's pressure loads apply (MPa), ``None`` if none.

    A load's value times the largest magnitude of its amplitude channel over the program.
    """
    channels = scene.model.program.channels if scene.model is not None else {}
    found = []
    for load in scene.loads:
        if load.type != "pressure":
            continue
        amp = load.amplitude
        assert not isinstance(load.value, list)  # (a pressure is a number: parser.py checks)
        scale = float(np.max(np.abs(channels[amp]))) if isinstance(amp, str) else 1.0
        found.append(abs(float(load.value)) * scale)
    return max(found) if found else None


def warn_units(scene: FEScene, comm: Any) -> None:
    """Warn about the laws whose ``mu_s``, ``mu_k`` look like friction coefficients.

    A :class:`~subfric_dolfinx.logs.UnitsWarning` per such law, at the scene's largest pressure
    (:func:`largest_pressure`), before anything is built: the law's ``units_check``
    (:meth:`.SubloadingLaw.units_check`). A scene without pressure loads is not checked.
    """
    f_n = largest_pressure(scene)
    model = scene.model
    if f_n is None or model is None:
        return
    laws: list[tuple[str, Any]] = [("scene.law", model.law)]
    laws += [(f"scene.regions.{k}", v) for k, v in model.regions.items()]
    for name, iface in model.interfaces.items():
        laws.append((f"scene.interfaces.{name}.law", iface.law))
        laws += [(f"scene.interfaces.{name}.regions.{k}", v) for k, v in iface.regions.items()]
    seen: list[Any] = []
    for where, law in laws:
        check = getattr(law, "units_check", None)
        if check is None or any(law is s for s in seen):
            continue
        seen.append(law)
        message = check(f_n)
        if message is not None:
            text = f"{where} (the largest pressure: {f_n:g} MPa): {message}"
            logs.warn(text, logs.UnitsWarning, comm)


def run_fe_scene(
    scene: FEScene, outdir: str | Path | None, comm: Any, restart: str | Path | None
) -> SceneResult:
    """Run a validated FE scene (see :func:`~.runner.run_scene`)."""
    comm = MPI.COMM_WORLD if comm is None else comm
    warn_units(scene, comm)
    out = scene.outputs
    wants_files = (
        out.history
        or out.fields is not None
        or out.interface_history
        or out.checkpoints
        or out.snapshot_file
    )
    if wants_files and outdir is None:
        raise SceneError("scene.outputs asks for files but no output directory was given")
    outdir = Path(outdir) if outdir is not None else None
    t_start = time.perf_counter()
    PETSc.Log.begin()
    what = scene.mesh.builder or scene.mesh.file
    logger.debug("[%s] building the mesh (%s) on %d rank(s)", scene.name, what, comm.size)
    domain = build_mesh(scene.mesh, comm, scene)
    problem = build_problem(scene, domain)
    res = SceneResult(scene.name, "fe")
    tdim = domain.mesh.topology.dim
    res.info = {
        "ranks": comm.size,
        "cells": domain.mesh.topology.index_map(tdim).size_global,
        "dofs": problem.global_dofs,
        "interface points": comm.allreduce(
            sum(i.law_points.n_elements * i.law_points.nq for i in problem.interfaces.values())
        ),
        "gdim": domain.mesh.geometry.dim,
    }
    i = res.info
    logger.info(
        "[%s] %d-D, %d cells, %d dofs, %d interface points, %d rank(s)",
        scene.name,
        i["gdim"],
        i["cells"],
        i["dofs"],
        i["interface points"],
        i["ranks"],
    )
    settings = restart_settings(scene)
    # the names of every file the run may write (an interface's name made safe; two names of
    # the same file refused): before anything is written
    planned = planned_files(out, list(problem.interfaces)) if wants_files else []
    with contextlib.ExitStack() as stack:
        # first in, last out: a stop signal is a request until every file is closed (.signals)
        guard = stack.enter_context(StopSignals())
        if wants_files:
            assert outdir is not None  # (checked above)
            stack.enter_context(OutputDirectory(outdir, comm, fresh=restart is None, files=planned))
        try:
            solver = stack.enter_context(
                FrictionSolver(
                    problem, scene.solver.prefix, scene.solver.options, linear=scene.solver.linear
                )
            )
        except SolverOptionError as e:
            if e.key not in scene.solver.options:  # the command line's or PETSC_OPTIONS'
                raise
            raise SceneError(f"scene.solver.options.{e.key}: {e}") from None
        stepper = LoadStepper(
            solver,
            scene.solver.dt,
            control=StepControl(
                dt_max=scene.solver.dt_max,
                dt_min=scene.solver.dt_min,
                max_cuts=scene.solver.max_cuts,
                hold_dt=scene.solver.hold_dt,
                max_steps=scene.solver.max_steps,
            ),
            keep_records=False,
        )
        restart_time, restart_history = None, None
        if restart is not None:
            restart_history = restore_checkpoint(restart, problem, stepper, settings)
            restart_time = stepper.t
            logger.info(
                "[%s] restarted from %s at t = %.6g (step %d)",
                scene.name,
                restart,
                stepper.t,
                stepper.step,
            )
        outputs = stack.enter_context(
            SceneOutputs(
                out,
                outdir,
                problem,
                stepper,
                restart_time=restart_time,
                restart_history=restart_history,
                settings=settings,
                derived=DerivedOutputs(
                    scene,
                    problem,
                    # (fields are files: outdir given, checked above)
                    inside(outdir, "fields")
                    if out.fields is not None and outdir is not None
                    else None,
                ),
            )
        )
        solver.interrupt = lambda: guard.urgent

        def on_step(rec: Any) -> None:
            stop = guard.requested(comm)
            # with checkpoints: writes one, raises SceneInterrupted
            outputs.on_step(rec, guard.name if stop else False)
            if stop:
                raise SceneInterrupted(
                    f"interrupted by {guard.name} after step {rec.step} at t = {rec.t:.6g}; "
                    "no checkpoint (the scene writes none)",
                    rec.t,
                    None,
                )

        stepper.on_step = on_step
        try:
            if guard.requested(comm):  # during the set-up of the outputs or the restart
                raise SceneInterrupted(
                    f"interrupted by {guard.name} before the first step (t = {stepper.t:.6g}); "
                    "nothing written",
                    None,
                    None,
                )
            stepper.run(stops=outputs.stops)
        except StepFailure:
            outputs.write_checkpoint()  # the last converged state, for a restart
            raise
        except StepInterrupted as e:  # a second stop signal: the step abandoned, state reverted
            guard.requested(comm)  # agree on the signal's name
            outputs.write_checkpoint()
            where = (
                f"checkpoint written to {outputs.checkpoint_path}"
                if outputs.checkpoint_path is not None
                else "no checkpoint (the scene writes none)"
            )
            raise SceneInterrupted(
                f"interrupted by {guard.name} during the step to t = {e.t:.6g} (abandoned); "
                f"state of step {e.last_step} at t = {e.last_t:.6g}; {where}",
                e.last_t,
                str(outputs.checkpoint_path) if outputs.checkpoint_path is not None else None,
            ) from None
        finally:  # the files are closed by the exit stack (a close error never hides the run's)
            res.history = outputs.history.rows
            res.snapshots = outputs.snapshots
            res.iterations = outputs.iterations
            res.files = outputs.files
            res.timing = timing_breakdown(problem, solver.event_start)
            res.timing["total"] = comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
            res.info["summary"] = interface_summary(problem)
    t = dict(res.timing)
    total = t.pop("total")
    logger.debug(format_breakdown(t, total))  # -v: the whole breakdown
    its = res.iterations
    if its:
        part = max(t, key=lambda k: t[k]) if t else "run"
        logger.info(
            "[%s] %d steps, Newton iterations per step: mean %.2f, max %d; %.3g s, the largest "
            "part %s (%.3g s)",
            scene.name,
            len(its),
            np.mean(its),
            max(its),
            total,
            part,
            t.get(part, total),
        )
    else:
        logger.info("[%s] no step to take: the program had already ended", scene.name)
    return res
