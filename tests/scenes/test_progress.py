"""Library use shows progress with one call: ``logs.show_progress(comm)`` prints a line per
converged load step on rank 0 (a scene run from a script, no output files)."""

import io
import logging

from mpi4py import MPI

from subfric_dolfinx import logs
from subfric_dolfinx.scenes import run_scene
from tests.scenes.test_scene_command import SCENE

QUIET = {**SCENE, "outputs": {}, "solver": {"prefix": "progress_", "dt": 0.25}}


def test_show_progress_prints_a_line_per_step_on_rank_0():
    comm = MPI.COMM_WORLD
    logger = logging.getLogger(logs.LOGGER_NAME)
    before = (logger.level, logger.propagate, list(logger.handlers))
    stream = io.StringIO()
    try:
        logs.show_progress(comm, stream)
        result = run_scene(QUIET, comm=comm)
    finally:
        logger.handlers[:] = before[2]
        logger.setLevel(before[0])
        logger.propagate = before[1]
    lines = stream.getvalue().splitlines()
    steps = [ln for ln in lines if ln.startswith("step ")]
    if comm.rank == 0:
        assert len(steps) == len(result.history) > 5, lines
        assert all("newton" in ln and " t = " in ln for ln in steps), steps
    else:
        assert lines == []
