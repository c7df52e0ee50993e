"""Checkpoint/restart, interface history in HDF5, and faults (1 and 2 ranks)."""

import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.fem import StepFailure
from subfric_dolfinx.io import CheckpointError, read_checkpoint
from subfric_dolfinx.scenes import run_scene
from tests.helpers import ROOT, on_root, prefix, singleton_env, small_scene

T_CK = 2.5  # checkpoint time: in the middle of the reverse stroke


def scene(**outputs):
    s = small_scene()
    s["outputs"] = dict(outputs)
    s["solver"]["prefix"] = prefix("ck")
    return s


def columns(hist, after):
    rows = [r for r in hist if r["t"] > after + 1e-9]
    keys = ["t", "dt", "F_t1", "F_n", "up_norm", "mu", "r", "R_top_x"]
    return np.array([[r[k] for k in keys] for r in rows])


def test_restart_gives_the_same_history(shared_tmp):
    """1 -> 1 on one rank; 2 -> 2 and 2 -> 1 on two ranks."""
    comm = MPI.COMM_WORLD
    full = run_scene(
        scene(checkpoint_times=[T_CK], history=True, interface_history=True),
        outdir=shared_tmp / "a",
        comm=comm,
    )
    ck = shared_tmp / "a" / "checkpoint.h5"
    ref = columns(full.history, T_CK)
    assert ref.shape[0] > 10
    again = run_scene(
        scene(history=True, interface_history=True),
        outdir=shared_tmp / "a",
        comm=comm,
        restart=ck,
    )
    assert len(again.history) == len(full.history)
    np.testing.assert_allclose(columns(again.history, T_CK), ref, rtol=1e-10, atol=1e-10)

    def check_interface_history():
        """It continues where it stopped: one row per step, times increasing."""
        with h5py.File(shared_tmp / "a" / "interface_history.h5") as f:
            t = f["time"][()]
            assert len(t) == len(full.history) and np.all(np.diff(t) > 0)
            assert f["f_t"].shape == (len(t), 16, 1) and f["x"].shape == (16, 2)
            np.testing.assert_allclose(f["mu"][-1].mean(), again.history[-1]["mu"], rtol=1e-12)

    on_root(comm, check_interface_history)
    if comm.size > 1:  # 2 -> 1

        def restart_on_one_rank():
            one = run_scene(scene(), outdir=shared_tmp / "b", comm=MPI.COMM_SELF, restart=ck)
            diff = np.abs(columns(one.history, T_CK) - ref).max()
            print(f"2 -> 1 restart: max |diff| of the history = {diff:.3g}")
            assert diff < 1e-8 * np.abs(ref).max(), diff

        on_root(comm, restart_on_one_rank)


def test_a_failed_write_leaves_the_previous_checkpoint(shared_tmp, monkeypatch):
    comm = MPI.COMM_WORLD
    run_scene(scene(checkpoint_times=[1.0]), outdir=shared_tmp, comm=comm)
    good = shared_tmp / "checkpoint.h5"
    before = read_checkpoint(good, comm).attrs["time"]

    def broken(*a, **k):
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(h5py.Group, "create_group", broken)
    with pytest.raises(CheckpointError, match="disk full"):
        run_scene(scene(checkpoint_times=[1.0, 2.0]), outdir=shared_tmp, comm=comm)
    monkeypatch.undo()
    assert read_checkpoint(good, comm).attrs["time"] == before == 1.0


def test_an_absurd_step_is_cut_back_and_recovers():
    """Whole strokes in one step with at most 3 Newton iterations: SNES diverges mid-run, the
    stepper cuts the step and recovers."""
    s = scene()
    s["solver"].update(dt=25.0, dt_max=25.0, dt_min=1e-4, options={"snes_max_it": 3})
    res = run_scene(s, comm=MPI.COMM_WORLD)
    assert res.history[-1]["t"] == pytest.approx(11.0)
    assert max(r["cuts"] for r in res.history) > 0


def test_a_failure_leaves_the_last_converged_state_in_the_checkpoint(shared_tmp):
    """Pulling the block off by force: once the contact opens everywhere nothing holds the block
    and no step can be solved. A clear error, and the last converged state in the checkpoint."""
    comm = MPI.COMM_WORLD
    s = scene(checkpoint_every=1000)
    s["solver"].update(dt=0.05, dt_max=0.05, max_cuts=4)
    s["program"] = {
        "times": [0, 1, 2, 3],
        "channels": {"press": [0, 1, 1, -1], "slide": [0, 0, 0.5, 0.5]},
    }
    with pytest.raises(StepFailure, match="no convergence at t = 2") as e:
        run_scene(s, outdir=shared_tmp, comm=comm)
    assert 2.0 < e.value.last_t < 3.0
    ck = read_checkpoint(shared_tmp / "checkpoint.h5", comm)
    assert ck.attrs["time"] == pytest.approx(e.value.last_t)
    assert ck.attrs["step"] == e.value.last_step and len(ck.history) == e.value.last_step
    # the last good step is the last one before the pull: no tension in it (at zero pressure
    # every point may touch: zero traction, the contact band of constitutive/tolerances.py)
    assert ck.history[-1]["F_n"] >= 0.0 and e.value.last_t <= 2.5 + 1e-9


def test_sigterm_leaves_a_restartable_checkpoint(shared_tmp):
    """A 1-rank run in a subprocess gets SIGTERM; it writes a checkpoint and stops; the run
    restarted from it ends where an uninterrupted run ends."""
    comm = MPI.COMM_WORLD
    outdir = shared_tmp / "killed"

    def run_and_interrupt():
        code = (
            "import sys\n"
            "from tests.helpers import small_scene\n"
            "from subfric_dolfinx.scenes import run_scene, SceneInterrupted\n"
            "s = small_scene()\n"
            "from subfric_dolfinx import logs\n"
            "logs.configure(verbosity=1)\n"
            "s['outputs'] = {'checkpoint_every': 1000}\n"
            "s['solver'].update(dt=0.04, dt_max=0.04)\n"
            "try:\n"
            f"    run_scene(s, outdir={str(outdir)!r})\n"
            "except SceneInterrupted as e:\n"
            "    print('INTERRUPTED', e.t, flush=True)\n"
            "    sys.exit(3)\n"
        )
        p = subprocess.Popen(
            [sys.executable, "-c", code],
            cwd=ROOT,
            env=singleton_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        lines = []
        for line in p.stdout:  # wait until it is stepping, then interrupt it
            lines.append(line)
            if line.startswith("step   10"):
                p.send_signal(signal.SIGTERM)
                break
        out, _ = p.communicate(timeout=120)
        lines.append(out)
        return p.returncode, "".join(lines)

    rc, text = on_root(comm, run_and_interrupt)
    assert rc == 3 and "INTERRUPTED" in text, text
    ck = outdir / "checkpoint.h5"
    t_ck = read_checkpoint(ck, comm).attrs["time"]
    assert 0.2 <= t_ck < 11.0
    s = small_scene()
    s["solver"].update(dt=0.04, dt_max=0.04)
    s["solver"]["prefix"] = prefix("ck")
    resumed = run_scene(s, comm=comm, restart=ck)
    s["solver"]["prefix"] = prefix("ck")
    whole = run_scene(s, comm=comm)
    assert resumed.history[-1]["t"] == whole.history[-1]["t"] == pytest.approx(11.0)
    np.testing.assert_allclose(
        columns(resumed.history, t_ck), columns(whole.history, t_ck), rtol=1e-9, atol=1e-9
    )
