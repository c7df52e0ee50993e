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


def test_progress_lines_grow_with_the_logarithm_of_the_run(monkeypatch):
    """A long run's progress lines: never closer than PROGRESS_SECONDS, each gap at least the
    time elapsed over PROGRESS_SPREAD, so a 7-minute demo prints a dozen, an hour's run 19: a
    demo's default output stays short however slow the machine (a clock stepped by hand)."""
    import math

    now = [0.0]
    monkeypatch.setattr(logs.time, "monotonic", lambda: now[0])
    clock = logs.Progress()
    lines = []
    while now[0] < 3600.0:
        now[0] += 0.25
        if clock.due():
            lines.append(now[0])
    gaps = [b - a for a, b in zip([0.0, *lines], lines, strict=False)]
    assert lines[:3] == [10.0, 20.0, 30.0]
    assert min(gaps) >= logs.PROGRESS_SECONDS
    assert all(g >= a / logs.PROGRESS_SPREAD - 0.25 for a, g in zip(lines, gaps[1:], strict=False))
    spread = 1.0 + 1.0 / logs.PROGRESS_SPREAD
    for seconds in (441.0, 3600.0):  # bolt_clamped_joint's default run; an hour
        count = sum(t <= seconds for t in lines)
        assert count <= 4 + math.log(seconds / 30.0) / math.log(spread), (seconds, count)
    assert sum(t <= 441.0 for t in lines) <= 12 and len(lines) <= 19
    every = logs.Progress(0.0)  # no interval: every call a line, however long the run
    now[0] += 1e4
    assert all(every.due() for _ in range(5))
