"""Sizes are checked before anything is allocated (issue 23, item 3). 1 and 2 ranks.

* The mesh builders estimate their cells (volume over ``h^d``, or the integral of the graded
  density) before gmsh runs: the estimate is checked against the cells the builders make, and
  ``n_interface = 1e8`` (``demos/block_on_base.py --n 100000000``, which took all 24 GB of the
  host in a minute) is refused at once, naming the option, on every rank, and by the demo's
  command line with exit 2.
* A scene's program that needs more than ``solver.max_steps`` steps (1e9 steps were accepted:
  87 days) is refused when parsed; a run that reaches it (cuts) stops with a StepFailure.
* The calibration refuses a fit whose driver steps would exceed its ``max_steps`` (a slip to
  1e6 mm ran until killed), before any run.

SIGTERM/SIGINT during the set-up: ``tests/scenes/test_stop_signals.py`` (gmsh meshing for minutes
stops within a second).
"""

from __future__ import annotations

import sys

import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.meshing import _size
from tests.helpers import SEC7_PENALTY, raised_on_every_rank

CASES = [
    (meshing.build_block_on_base, {"n_interface": 32, "cell_type": "triangle"}, 0.8, 1.2),
    (meshing.build_block_on_base, {"n_interface": 32, "cell_type": "quadrilateral"}, 1.0, 1.0),
    (meshing.build_block_on_base, {"n_interface": 32, "far_size": 0.25}, 0.5, 1.5),
    (meshing.build_pad_on_plate, {"n_interface": 6, "cell_type": "tetrahedron"}, 0.8, 2.0),
    (meshing.build_pad_on_plate, {"n_interface": 6, "cell_type": "hexahedron"}, 1.0, 1.0),
    (meshing.build_bolted_lap_joint, {"n_interface": 6}, 0.4, 1.5),
]


@pytest.mark.parametrize(("builder", "options", "lo", "hi"), CASES)
def test_the_cell_estimate_against_the_builders(monkeypatch, builder, options, lo, hi):
    """The estimate the size check uses, against the cells each builder makes: structured
    meshes exactly, triangles within 20 %, tetrahedra 1 to 2 times (unstructured tetrahedra
    are larger than regular ones), graded meshes within a factor of 2; the bolted joint's
    refinement around its hole is not counted (0.43 of its cells at n = 6, 0.74 at 8)."""
    seen = []

    def spy(*args, **kwargs):
        seen.append(_size.estimate_cells(*args, **kwargs))
        return seen[-1]

    module = sys.modules[builder.__module__]
    monkeypatch.setattr(module, "estimate_cells", spy)
    _, info = meshing.create_interface_mesh(builder, MPI.COMM_WORLD, **options)
    cells = sum(info.num_cells.values())
    estimate = MPI.COMM_WORLD.bcast(seen[0] if seen else None, root=0)
    assert lo * cells * (1 - 1e-12) <= estimate <= hi * cells * (1 + 1e-12), (estimate, cells)


@pytest.mark.parametrize(
    ("builder", "option"),
    [
        (meshing.build_block_on_base, {"n_interface": 100_000_000}),
        (meshing.build_pad_on_plate, {"mesh_size": 1e-5}),
        (meshing.build_bolted_lap_joint, {"n_interface": 100_000}),
    ],
)
def test_a_mesh_larger_than_the_machine_is_refused_naming_the_option(builder, option):
    ((name, value),) = option.items()
    with raised_on_every_rank(ValueError, f"{name} = {value!r}", "GiB", "memory"):
        meshing.create_interface_mesh(builder, MPI.COMM_WORLD, **option)


def test_the_memory_check_compares_with_the_machine(monkeypatch):
    """A mesh of 1e6 cells (2 GB at 2 kB each) passes a 4 GB machine and not a 1 GB one."""
    monkeypatch.setattr(_size, "machine_memory", lambda: 4 << 30)
    _size.check_mesh_size(1e6, "n_interface", 1000)
    monkeypatch.setattr(_size, "machine_memory", lambda: 1 << 30)
    with pytest.raises(ValueError, match=r"n_interface = 1000 .the demos' --n. asks for about 1e"):
        _size.check_mesh_size(1e6, "n_interface", 1000)


@pytest.mark.serial
def test_the_demo_refuses_n_1e8_with_exit_2(tmp_path):
    """The command line of the issue's probe: exit 2 at once, one line naming the option."""
    from tests.scenes.test_cli import run

    cmd = [sys.executable, "demos/block_on_base.py", "--n", "100000000", "--out", str(tmp_path)]
    rc, text = run(cmd, timeout=120)
    assert rc == 2, text
    assert "n_interface = 100000000 (the demos' --n)" in text and "Traceback" not in text, text


# --------------------------------------------------------------------------------------------
# Steps


def scene(**solver):
    from demos import block_on_base

    s = block_on_base.scene(n=4, hold=1.0)
    s["outputs"] = {}
    s["solver"] = {"dt": 0.02, **solver}
    return s


def test_a_program_of_1e9_steps_is_refused_when_parsed():
    """dt = 1e-8 s over the demo's 7 s program, hold_dt 1 s: 3e8 steps at the least; refused
    against the default max_steps (1e6), naming scene.solver and the count. With max_steps
    raised it parses; the limit counts holds at hold_dt."""
    from subfric_dolfinx.scenes import SceneError, parse_scene

    with pytest.raises(SceneError, match=r"scene.solver: .* needs at least 6e\+08 steps .*1e\+06"):
        parse_scene(scene(dt=1e-8, hold_dt=1.0))
    parse_scene(scene(dt=1e-8, hold_dt=1.0, max_steps=10**9))
    # 6 s outside the hold at dt_max 0.02: 300 steps, the hold 1 step at hold_dt = 1
    with pytest.raises(SceneError, match="needs at least 301 steps"):
        parse_scene(scene(dt=0.02, hold_dt=1.0, max_steps=300))
    parse_scene(scene(dt=0.02, hold_dt=1.0, max_steps=301))


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_run_that_reaches_max_steps_stops_with_a_step_failure(comm):
    """A 1 s program at dt = 0.1 with max_steps = 3: the stepper stops after step 3 at t = 0.3
    with a StepFailure naming max_steps, every rank alike, the state of step 3 kept."""
    from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepControl, StepFailure
    from tests.helpers import block_problem, prefix

    prob = block_problem(comm)
    with FrictionSolver(prob, prefix("maxsteps")) as solver:
        st = LoadStepper(solver, 0.1, control=StepControl(max_steps=3))
        with raised_on_every_rank(StepFailure, "max_steps = 3", "t = 0.3"):
            st.run()
    assert st.step == 3 and st.t == pytest.approx(0.3)


def test_a_calibration_beyond_max_steps_is_refused_before_any_run(monkeypatch):
    """A curve that slides to 1e5 mm: 5e6 steps per curve at 50 per mm (within the driver's
    limits for one run), times 6 cases per Jacobian and 202 runs: 6e9 steps, refused against
    the default max_steps (1e9) naming the curve, before the driver runs at all. A slide to
    1e6 mm is beyond the driver's own limit of a segment: refused naming the curve too."""
    import importlib

    from subfric_dolfinx import calibrate
    from subfric_dolfinx.calibrate import parse_data
    from subfric_dolfinx.constitutive import preset

    fit_module = importlib.import_module("subfric_dolfinx.calibrate.fit")  # not the function
    true = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}

    def data(end):
        slip = [0.0, 0.5, 1.0, 2.0, 4.0, 10.0, end]
        f_t = [0.0, 40, 50, 55, 57, 58, 60]
        curve = {"f_n": 300.0, "velocity": 1.0, "slip": slip, "f_t": f_t}
        fitted = ["mu_s", "mu_k", "kappa", "u_tilde", "c_n"]
        return parse_data({"params": true, "fit": fitted, "curves": [curve]})

    runs = []
    monkeypatch.setattr(fit_module, "run_cases", lambda *a, **k: runs.append(1) or 1 / 0)
    with pytest.raises(calibrate.CalibrationError, match=r"curves\[0\], slip to 100000 mm"):
        calibrate.fit(data(1e5))
    with pytest.raises(calibrate.CalibrationError, match=r"curves\[0\] \(slip to 1e\+06 mm"):
        calibrate.fit(data(1e6))
    assert not runs
    # the bound: 5e6 steps per curve x (1 + 5 fitted) x (200 + 2) runs
    bound = fit_module.check_steps(data(1e5), 50.0, 200, 1e12)
    assert bound == pytest.approx(5e6 * 6 * 202, rel=1e-6)


def test_the_calibration_command_line_refuses_beyond_max_steps(tmp_path, capsys):
    """``--max-steps``: the same curves (a slide to 10 mm, 500 steps) pass a bound of 1e9 and
    are refused with exit 2 at ``--max-steps 1000``, nothing written (rank 0 computes)."""
    import json

    from subfric_dolfinx.calibrate.cli import main
    from subfric_dolfinx.constitutive import preset
    from subfric_dolfinx.logs import launcher_rank

    true = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}
    curve = {
        "f_n": 300.0,
        "velocity": 1.0,
        "slip": [0.0, 0.5, 1.0, 2.0, 4.0, 10.0],
        "f_t": [0.0, 40, 50, 55, 57, 58],
    }
    path = tmp_path / "data.json"
    path.write_text(json.dumps({"params": true, "fit": ["mu_s"], "curves": [curve]}))
    out = tmp_path / "fit.json"
    rc = main([str(path), "--out", str(out), "--max-steps", "1000", "--quiet"])
    err = capsys.readouterr().err
    if launcher_rank() == 0:
        assert rc == 2 and "more than max_steps = 1000" in err and "curves[0]" in err, err
    else:
        assert rc == 0
    assert not out.exists()
