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

from ..fem import FrictionSolver, LoadStepper, StepFailure, format_breakdown, timing_breakdown
from ..io import OutputDirectory, interface_summary, restore_checkpoint
from .build import build_mesh, build_problem
from .derived import DerivedOutputs
from .outputs import SceneOutputs
from .result import SceneResult
from .schema import FEScene, SceneError
from .signals import SceneInterrupted, StopSignals

__all__ = ["restart_settings", "run_fe_scene"]

logger = logging.getLogger(__name__)


def restart_settings(scene: FEScene) -> dict[str, Any]:
    """What a restart must match beyond the mesh, law and program (compared anyway).

    The materials, the Dirichlet conditions and loads (values, components, channels), the
    quadrature, the mesh builder's options (or file) and group names, and, where the scene gives
    them, its bodies, interfaces (sides, quadrature) and mode. Solver settings and the
    partitioner may change.
    """
    mesh: dict[str, Any] = {"builder": scene.mesh.builder, "options": scene.mesh.options}
    if scene.mesh.file is not None:
        mesh = {"file": Path(scene.mesh.file).name, "gdim": scene.mesh.gdim}
    if scene.mesh.names:
        mesh["names"] = scene.mesh.names
    out = {
        "materials": scene.materials,
        "dirichlet": [dataclasses.asdict(d) for d in scene.dirichlet],
        "loads": [dataclasses.asdict(ld) for ld in scene.loads],
        "quadrature": scene.quadrature,
        "mesh": mesh,
    }
    # beyond the classic scene (absent there, so that its checkpoints stay valid)
    if scene.bodies:
        out["bodies"] = scene.bodies
    if scene.interfaces:
        out["interfaces"] = {
            n: {"sides": list(s.sides), "quadrature": s.quadrature}
            for n, s in scene.interfaces.items()
        }
    if scene.mode is not None:
        out["mode"] = scene.mode
    return out


def run_fe_scene(
    scene: FEScene, outdir: str | Path | None, comm: Any, restart: str | Path | None
) -> SceneResult:
    """Run a validated FE scene (see :func:`~.runner.run_scene`)."""
    comm = MPI.COMM_WORLD if comm is None else comm
    out = scene.outputs
    wants_files = out.history or out.fields is not None or out.interface_history or out.checkpoints
    if wants_files and outdir is None:
        raise SceneError("scene.outputs asks for files but no output directory was given")
    outdir = Path(outdir) if outdir is not None else None
    t_start = time.perf_counter()
    PETSc.Log.begin()
    domain = build_mesh(scene.mesh, comm, scene)
    problem = build_problem(scene, domain)
    res = SceneResult(scene.name, "fe")
    tdim = domain.mesh.topology.dim
    res.info = {
        "ranks": comm.size,
        "cells": domain.mesh.topology.index_map(tdim).size_global,
        "dofs": problem.V.dofmap.index_map.size_global * problem.V.dofmap.bs,
        "interface points": comm.allreduce(
            sum(i.elements.n_elements * i.elements.nq for i in problem.interfaces.values())
        ),
        "gdim": domain.mesh.geometry.dim,
    }
    i = res.info
    logger.info(
        "[%s] %d-D, %d cells, %d dofs, %d interface points, %d rank(s)",
        scene.name, i["gdim"], i["cells"], i["dofs"], i["interface points"], i["ranks"],
    )  # fmt: skip
    settings = restart_settings(scene)
    with contextlib.ExitStack() as stack:
        if wants_files:
            stack.enter_context(OutputDirectory(outdir, comm, fresh=restart is None))
        solver = stack.enter_context(
            FrictionSolver(
                problem, scene.solver.prefix, scene.solver.options, linear=scene.solver.linear
            )
        )
        stepper = LoadStepper(
            solver,
            scene.solver.dt,
            dt_max=scene.solver.dt_max,
            dt_min=scene.solver.dt_min,
            max_cuts=scene.solver.max_cuts,
            hold_dt=scene.solver.hold_dt,
        )
        restart_time, restart_history = None, None
        if restart is not None:
            restart_history = restore_checkpoint(restart, problem, stepper, settings)
            restart_time = stepper.t
            logger.info(
                "[%s] restarted from %s at t = %.6g (step %d)",
                scene.name, restart, stepper.t, stepper.step,
            )  # fmt: skip
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
                    scene, problem, outdir / "fields" if out.fields is not None else None
                ),
            )
        )
        guard = stack.enter_context(StopSignals())

        def on_step(rec: Any) -> None:
            stop = guard.requested(comm)
            outputs.on_step(rec, stop)  # with checkpoints: writes one, raises SceneInterrupted
            if stop:
                raise SceneInterrupted(
                    f"interrupted by {guard.name} after step {rec.step} at t = {rec.t:.6g}; "
                    "no checkpoint (the scene writes none)",
                    rec.t,
                    None,
                )

        stepper.on_step = on_step
        try:
            stepper.run(stops=outputs.stops)
        except StepFailure:
            outputs.write_checkpoint()  # the last converged state, for a restart
            raise
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
    logger.info(format_breakdown(t, total))
    its = res.iterations
    if its:
        logger.info(
            "[%s] %d steps, Newton iterations per step: mean %.2f, max %d",
            scene.name, len(its), np.mean(its), max(its),
        )  # fmt: skip
    else:
        logger.info("[%s] no step to take: the program had already ended", scene.name)
    return res
