"""Bad checkpoints: damaged contents (shapes, dtypes, non-finite values, attribute types) and
checkpoints of another setting (materials, loads, boundary values, program). Each is refused on
every rank with a ``CheckpointError`` naming the file and the item or the setting, before the run
takes anything from it; solver settings may change across a restart.

One good checkpoint is written per module (at t = 1 s of a 2 s program: press, then slide
0.35 mm); each case copies it and damages the copy with plain h5py on rank 0.
"""

import json
import shutil
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.io import CheckpointError
from subfric_dolfinx.scenes import run_scene
from tests.helpers import (
    SHORT_SLIDE,
    hang_fails,
    on_root,
    prefix,
    raised_on_every_rank,
    small_scene,
)

pytestmark = hang_fails()

T_CK, T_END = 1.0, 2.0


def scene(**outputs):
    s = small_scene(short=True)  # press (1 s), slide (1 s)
    s["outputs"] = dict(outputs)
    s["solver"]["prefix"] = prefix("badck")
    return s


@pytest.fixture(scope="module")
def good():
    """A checkpoint at ``T_CK``, in a directory common to all ranks."""
    comm = MPI.COMM_WORLD
    d = Path(comm.bcast(tempfile.mkdtemp(prefix="subfric-ck-") if comm.rank == 0 else None))
    run_scene(scene(checkpoint_times=[T_CK]), outdir=d / "run", comm=comm)
    yield d / "run" / "checkpoint.h5"
    comm.Barrier()
    if comm.rank == 0:
        shutil.rmtree(d, ignore_errors=True)


IFACE = "interfaces/interface"  # the classic scene's interface in a checkpoint (format 3)


def replace(f, key, data):
    del f[key]
    f[key] = data


def _shorter_up(f):  # a row missing: the IndexError on one rank of old
    replace(f, IFACE + "/up", f[IFACE + "/up"][:-1])


def _mu_nan(f):
    mu = f[IFACE + "/mu"][()]
    mu[-1] = np.nan  # on the last rank's slab
    replace(f, IFACE + "/mu", mu)


def _columns(f):
    f["history"].attrs["columns"] = json.dumps(["t"])


def _increment(shape=None, dt=1.0, nan=False):
    """An ``increment`` dataset (the load stepper's predictor) added, damaged."""

    def mutate(f):
        u = f["displacement"][()]
        inc = np.zeros(shape if shape is not None else u.shape)
        if nan:
            inc[-1] = np.nan  # on the last rank's slab
        if "increment" in f:  # the stepper's predictor wrote one
            del f["increment"]
        f["increment"] = inc
        if dt is not None:
            f["increment"].attrs["dt"] = dt

    return mutate


def _set(key, value):
    def mutate(f):
        f.attrs[key] = value

    return mutate


DAMAGED = {
    "up one row short": (_shorter_up, f"'{IFACE}/up' has shape (15, 1), expected (16, *)"),
    "r of dtype int": (
        lambda f: replace(f, IFACE + "/r", f[IFACE + "/r"][()].astype(np.int64)),
        f"'{IFACE}/r' has dtype int64, not float",
    ),
    "NaN in mu": (_mu_nan, f"'{IFACE}/mu' holds non-finite values"),
    "inf in u": (
        lambda f: f["displacement"].__setitem__((0, 0, 0), np.inf),
        "'displacement' holds non-finite values",
    ),
    "no displacement": (
        lambda f: f.__delitem__("displacement"),
        "lacks the dataset 'displacement'",
    ),
    "u of another dimension": (
        lambda f: replace(f, "displacement", f["displacement"][()][..., :1]),
        "'displacement' has shape",
    ),
    "time as text": (_set("time", "soon"), "attribute 'time' is 'soon', not a number"),
    "time NaN": (_set("time", np.nan), "attribute 'time' = nan is not finite"),
    "step as float": (_set("step", 2.5), "attribute 'step' is 2.5, not an integer"),
    "negative dt": (_set("dt", -0.1), "attribute 'dt' = -0.1 is not > 0"),
    "law not JSON": (_set("law", "{subloading"), "attribute 'law' is not JSON"),
    "settings a list": (_set("settings", "[1, 2]"), "attribute 'settings' is not a JSON object"),
    "more points claimed": (
        lambda f: f[IFACE].attrs.__setitem__("n_points", 17),
        f"'{IFACE}/x' has shape (16, 2), expected",
    ),
    "no interface": (lambda f: f.__delitem__("interfaces"), "holds no interface"),
    "old version": (_set("version", 1), "has version 1, this code reads versions 2, 3 and 4"),
    "no stepper": (lambda f: f.attrs.__delitem__("stepper"), "lacks the attribute(s) ['stepper']"),
    "stepper without keep_retry": (
        _set("stepper", '{"hold_step": null, "retry_run": 0}'),
        "attribute 'stepper' has the keys ['hold_step', 'retry_run'], expected ['hold_step', "
        "'keep_retry', 'retry_run']",
    ),
    "negative hold step": (
        _set("stepper", '{"hold_step": -0.5, "keep_retry": false, "retry_run": 0}'),
        "attribute 'stepper.hold_step' = -0.5 is not > 0",
    ),
    "keep_retry a number": (
        _set("stepper", '{"hold_step": null, "keep_retry": 1, "retry_run": 0}'),
        "attribute 'stepper.keep_retry' is 1, not a boolean",
    ),
    "retry_run a float": (
        _set("stepper", '{"hold_step": null, "keep_retry": false, "retry_run": 1.5}'),
        "attribute 'stepper.retry_run' is 1.5, not an integer",
    ),
    "geometry as text": (_set("geometry", "a mesh"), "'geometry' is not 9 finite numbers"),
    "geometry NaN": (_set("geometry", np.full(9, np.nan)), "'geometry' is not 9 finite numbers"),
    "history columns": (_columns, "1 history columns for"),
    "increment of another shape": (_increment(shape=(3, 2)), "'increment' has shape (3, 2)"),
    "increment without dt": (_increment(dt=None), "and dt None (> 0 wanted)"),
    "increment with dt 0": (_increment(dt=0.0), "and dt 0.0 (> 0 wanted)"),
    "NaN in the increment": (_increment(nan=True), "'increment' holds non-finite values"),
}


@pytest.mark.parametrize("case", list(DAMAGED))
def test_damaged_checkpoints_are_refused_on_every_rank(good, case):
    comm = MPI.COMM_WORLD
    mutate, words = DAMAGED[case]
    bad = good.with_name(case.replace(" ", "_") + ".h5")

    def damage():
        shutil.copy(good, bad)
        with h5py.File(bad, "r+") as f:
            mutate(f)

    on_root(comm, damage)
    with raised_on_every_rank(CheckpointError, repr(str(bad)), words):
        run_scene(scene(), comm=comm, restart=bad)


def _secondary_E(s):
    s["materials"]["secondary"]["E"] = 75000.0


def _pressure(s):
    s["loads"][0]["value"] = 250.0


def _slide_value(s):
    s["dirichlet"][1]["value"] = 0.8


def _bottom_held(s):
    s["dirichlet"][0]["value"] = [0.0, 0.01]


def _slide_channel(s):
    s["program"]["channels"]["slide"][2] = 0.6


OTHER_SETTINGS = {
    "Young's modulus": (_secondary_E, "materials.secondary.E = 70000.0, this run has 75000.0"),
    "pressure": (_pressure, "loads[0].value = 300.0, this run has 250.0"),
    "slide amplitude": (_slide_value, "dirichlet[1].value = 1.0, this run has 0.8"),
    "boundary value": (_bottom_held, "dirichlet[0].value[1] = 0.0, this run has 0.01"),
    "program": (_slide_channel, f"program.slide[2] = {SHORT_SLIDE}, this run has 0.6"),
}


@pytest.mark.parametrize("case", list(OTHER_SETTINGS))
def test_a_restart_with_other_settings_is_refused_naming_the_setting(good, case):
    comm = MPI.COMM_WORLD
    change, words = OTHER_SETTINGS[case]
    s = scene()
    change(s)
    with raised_on_every_rank(CheckpointError, repr(str(good)), "was written with", words):
        run_scene(s, comm=comm, restart=good)


def supported(**outputs):
    """The scene with a spring, a point force and a point held (issue 23, item 4)."""
    s = scene(**outputs)
    s["springs"] = [{"group": "secondary_left", "stiffness": [2.0, 0.0]}]
    s["points"] = {"A": {"x": [1.0, 0.75]}, "P": {"x": [0.0, 0.0]}}
    s["point_forces"] = [{"point": "A", "value": [0.0, -1.0], "amplitude": "press"}]
    s["dirichlet"].append({"group": "P", "value": [0.0, 0.0]})
    return s


@pytest.fixture(scope="module")
def good_supported(good):
    d = good.parent.parent
    run_scene(supported(checkpoint_times=[T_CK]), outdir=d / "supported", comm=MPI.COMM_WORLD)
    return d / "supported" / "checkpoint.h5"


def _stiffer(s):
    s["springs"][0]["stiffness"] = [2e4, 0.0]


def _force(s):
    s["point_forces"][0]["value"] = [0.0, -500.0]


def _moved(s):
    s["points"]["A"]["x"] = [1.2, 0.75]


def _held_moved(s):
    s["points"]["P"]["x"] = [2.0, 0.0]


MODEL_INPUTS = {
    "spring x1e4": (_stiffer, "springs[0].stiffness[0] = 2.0, this run has 20000.0"),
    "no spring": (lambda s: s.pop("springs"), 'springs = [{"group": "secondary_left"'),
    "force x500": (_force, "point_forces[0].value[1] = -1.0, this run has -500.0"),
    "force moved": (_moved, "point_forces[0].at.x[0] = 1.0, this run has 1.2"),
    "no force": (lambda s: s.pop("point_forces"), "point_forces = [{"),
    "held point moved": (_held_moved, "dirichlet_points.P.x[0] = 0.0, this run has 2.0"),
}


@pytest.mark.parametrize("case", list(MODEL_INPUTS))
def test_a_restart_with_other_springs_or_point_forces_is_refused(good_supported, case):
    """Springs, point forces, their points and held points are model inputs: a restart that
    changes one (the issue's probe: stiffness x1e4, force x500, a moved or removed point: all
    accepted before) is refused naming the first difference; the same scene restarts."""
    comm = MPI.COMM_WORLD
    change, words = MODEL_INPUTS[case]
    s = supported()
    change(s)
    ck = good_supported
    with raised_on_every_rank(CheckpointError, repr(str(ck)), "was written with", words):
        run_scene(s, comm=comm, restart=ck)


def test_the_settings_leave_defaults_out_and_store_any_scene_value():
    """A scene without springs, point forces or held points stores none of these keys (a
    checkpoint written before they were compared still fits); values that are not JSON (code
    of a Python scene, objects) are stored by a fixed label, so every scene can checkpoint."""
    import dataclasses

    from subfric_dolfinx.io.checkpoint import jsonable
    from subfric_dolfinx.scenes import parse_scene
    from subfric_dolfinx.scenes.fe import restart_settings

    plain = restart_settings(parse_scene(scene()))
    assert set(plain) == {"materials", "dirichlet", "loads", "quadrature", "mesh"}
    full = restart_settings(parse_scene(supported()))
    assert full["springs"][0]["stiffness"] == [2.0, 0.0]
    assert full["point_forces"][0]["at"] == {"x": [1.0, 0.75], "body": None}
    assert full["dirichlet_points"] == {"P": {"x": [0.0, 0.0], "body": None}}
    odd = dataclasses.replace(parse_scene(supported()), springs=[lambda x: x, object()])
    labels = ["<a Python function>", "<a object object>"]
    assert jsonable(restart_settings(odd))["springs"] == labels


def test_the_same_supported_scene_restarts(good_supported):
    res = run_scene(supported(), comm=MPI.COMM_WORLD, restart=good_supported)
    assert res.history[-1]["t"] == pytest.approx(T_END)


def test_solver_settings_may_change_across_a_restart(good):
    """Other step sizes and PETSc options: accepted; the run goes on from the checkpoint with
    the new ones and carries the checkpoint's history."""
    comm = MPI.COMM_WORLD
    s = scene()
    s["solver"].update(dt=0.02, dt_max=0.02, options={"snes_rtol": 1e-11})
    res = run_scene(s, comm=comm, restart=good)
    t = np.array([r["t"] for r in res.history])
    before, after = t[t <= T_CK + 1e-12], [r for r in res.history if r["t"] > T_CK + 1e-12]
    assert before.size > 0 and before[-1] == pytest.approx(T_CK)
    assert len(after) >= 50 and max(r["dt"] for r in after) <= 0.02 + 1e-12
    assert res.history[-1]["t"] == pytest.approx(T_END)


def test_a_restart_on_another_mesh_of_the_same_counts_is_refused(shared_tmp):
    """The same cells and interface points, the base's bottom nodes 25 mm lower: the geometry
    fingerprint stored in the checkpoint tells them apart (the counts and the interface points
    alone did not); the same mesh built again restores."""
    from subfric_dolfinx.fem import FrictionSolver, LoadStepper
    from subfric_dolfinx.io import restore_checkpoint, write_checkpoint
    from tests.helpers import block_problem

    comm = MPI.COMM_WORLD
    path = shared_tmp / "ck.h5"
    p = block_problem(comm)
    with FrictionSolver(p, prefix("geo"), linear="lu") as solver:
        write_checkpoint(path, p, LoadStepper(solver, 0.5), [])
    for moved in (True, False):
        q = block_problem(comm)
        x = q.mesh.geometry.x
        if moved:
            x[x[:, 1] < 1e-9, 1] -= 25.0
        with FrictionSolver(q, prefix("geo"), linear="lu") as solver:
            if moved:
                with raised_on_every_rank(
                    CheckpointError, repr(str(path)), "is for another mesh", "node coordinates"
                ):
                    restore_checkpoint(path, q, LoadStepper(solver, 0.5))
            else:
                restore_checkpoint(path, q, LoadStepper(solver, 0.5))


def test_a_checkpoint_write_cut_short_is_refused_as_incomplete(shared_tmp, monkeypatch):
    """A write killed in its middle (mpirun kills the ranks 0.25 s after forwarding SIGTERM)
    left ``checkpoint.h5.tmp`` with every attribute, a later time included: it read back as a
    valid checkpoint. The ``format`` mark is now written last: the cut file is refused as
    incomplete, on every rank; the previous checkpoint is intact."""
    from subfric_dolfinx.fem import FrictionSolver, LoadStepper
    from subfric_dolfinx.io import checkpoint, read_checkpoint, write_checkpoint
    from tests.helpers import block_problem

    class Killed(BaseException):
        """The process killed (nothing of this package sees it)."""

    comm = MPI.COMM_WORLD
    path = shared_tmp / "checkpoint.h5"
    p = block_problem(comm)
    real = checkpoint.write_extras

    def cut(f, extras, comm_, create):
        if not create:  # the datasets made, their values being written
            raise Killed
        return real(f, extras, comm_, create=create)

    with FrictionSolver(p, prefix("cut"), linear="lu") as solver:
        st = LoadStepper(solver, 0.5)
        write_checkpoint(path, p, st, [])  # the previous one, at t = 0
        st.t = 0.75
        monkeypatch.setattr(checkpoint, "write_extras", cut)
        with pytest.raises(Killed):
            write_checkpoint(path, p, st, [])
        monkeypatch.undo()
    tmp = path.with_name("checkpoint.h5.tmp")
    assert on_root(comm, tmp.exists)
    with raised_on_every_rank(CheckpointError, repr(str(tmp)), "is incomplete", "interrupted"):
        read_checkpoint(tmp, comm)
    assert read_checkpoint(path, comm).attrs["time"] == 0.0
