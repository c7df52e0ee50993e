"""Checkpoint/restart, interface history in HDF5, and faults (1 and 2 ranks)."""

import dataclasses
import errno
import gc
import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepControl, StepFailure
from subfric_dolfinx.io import (
    CheckpointWriteError,
    read_checkpoint,
    restore_checkpoint,
    write_checkpoint,
)
from subfric_dolfinx.logs import SlideWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import (
    DEMO_SLIDES,
    ROOT,
    SHORT_SLIDE,
    block_problem,
    everywhere,
    hang_fails,
    on_root,
    prefix,
    raised_on_every_rank,
    singleton_env,
    small_scene,
)
from tests.io.test_output import SUBPROCESSES, disk_full_runs

pytestmark = hang_fails()  # a hang fails (see tests/io/test_output.py)

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


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
@pytest.mark.parametrize("linear", ["lu", "reuse"])
@pytest.mark.three_ranks  # the distributed write and read (N -> N, N -> 1) on 3 ranks too
def test_restart_gives_the_same_history(shared_tmp, linear):
    """1 -> 1 on one rank; N -> N and N -> 1 on N ranks (2, and 3 in the 3-rank leg). To
    round-off with LU, and with the reused factor on one rank (a checkpoint refreshes it, as a
    restart does); on more ranks MUMPS's factors differ from run to run in the last bits, which
    GMRES's inexact solves turn into differences of the order of Newton's tolerance (measured
    5e-9 to 1e-8 of the peak between two identical runs on 2): 1e-7 of each column's largest
    value there."""
    comm = MPI.COMM_WORLD

    def scene_(**outputs):
        s = scene(**outputs)
        s["solver"]["linear"] = linear
        return s

    full = run_scene(
        scene_(checkpoint_times=[T_CK], history=True, interface_history=True),
        outdir=shared_tmp / "a",
        comm=comm,
    )
    ck = shared_tmp / "a" / "checkpoint.h5"
    ref = columns(full.history, T_CK)
    assert ref.shape[0] > 10
    again = run_scene(
        scene_(history=True, interface_history=True),
        outdir=shared_tmp / "a",
        comm=comm,
        restart=ck,
    )
    assert len(again.history) == len(full.history)
    got = columns(again.history, T_CK)
    if linear == "lu" or comm.size == 1:
        np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-10)
    else:
        assert np.all(np.abs(got - ref) <= 1e-7 * np.abs(ref).max(axis=0)), np.abs(got - ref)

    def check_interface_history():
        """It continues where it stopped: one row per step, times increasing."""
        with h5py.File(shared_tmp / "a" / "interface_history.h5") as f:
            t = f["time"][()]
            assert len(t) == len(full.history) and np.all(np.diff(t) > 0)
            assert f["f_t"].shape == (len(t), 16, 1) and f["x"].shape == (16, 2)
            np.testing.assert_allclose(f["mu"][-1].mean(), again.history[-1]["mu"], rtol=1e-12)

    on_root(comm, check_interface_history)
    if comm.size > 1:  # 2 -> 1
        alone = scene()  # on every rank: the ranks' prefix counts stay equal (tests/conftest.py)

        def restart_on_one_rank():
            one = run_scene(alone, outdir=shared_tmp / "b", comm=MPI.COMM_SELF, restart=ck)
            diff = np.abs(columns(one.history, T_CK) - ref).max()
            print(f"2 -> 1 restart: max |diff| of the history = {diff:.3g}")
            assert diff < 1e-8 * np.abs(ref).max(), diff

        on_root(comm, restart_on_one_rank)


def test_the_steppers_memory_comes_back_from_a_checkpoint(shared_tmp):
    """Everything that decides the stepper's next steps comes back whole (format 4): the step,
    its size and growth counter, the predictor's increment, and the ``stepper`` attribute's
    hold step after a cut, the retry options kept for the segment and the steps that took them
    (set here to values a run reaches in a hold after a cut, on a segment kept on the retry)."""
    comm = MPI.COMM_WORLD
    prob = block_problem(comm, law=CoulombLaw(alpha_t=1e5, alpha_n=1e6, mu_c=0.3))
    with FrictionSolver(prob, prefix("memory"), linear="lu") as solver:
        st = LoadStepper(solver, 0.25)
        st.run(t_end=1.5)
        st._hold_step, st._keep_retry, st._retry_run, st.easy = 0.0625, True, 1, 1
        path = shared_tmp / "memory.h5"
        write_checkpoint(path, prob, st, [{"t": r.t} for r in st.records])
        again = LoadStepper(solver, 0.125, control=StepControl(dt_max=0.5))
        assert again.memory().t != st.memory().t  # (a fresh stepper's differs)
        restore_checkpoint(path, prob, again)
        a, b = st.memory(), again.memory()
    assert a.increment is not None and b.increment is not None
    assert everywhere(comm, np.array_equal(a.increment, b.increment))
    assert dataclasses.replace(a, increment=None) == dataclasses.replace(b, increment=None)
    assert (b.hold_step, b.keep_retry, b.retry_run, b.easy, b.t) == (0.0625, True, 1, 1, 1.5)
    prob.destroy()


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_a_failed_write_leaves_the_previous_checkpoint(shared_tmp, monkeypatch):
    """Injected (monkeypatch of h5py's Dataset.__setitem__): the last rank's slab write of the
    second checkpoint raises ENOSPC, the other ranks' succeed. Every rank raises the same
    CheckpointWriteError (an OutputError: a failed output, not a bad input) naming the file and
    the OS error; the first checkpoint is intact, no
    temporary file is left, no HDF5 handle is left open (h5py's finaliser would warn)."""
    comm = MPI.COMM_WORLD
    real = h5py.Dataset.__setitem__
    count = [0]

    def flaky(self, key, value):
        if self.name == "/displacement":
            count[0] += 1
            if count[0] == 2 and comm.rank == comm.size - 1:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", flaky)
    good = shared_tmp / "checkpoint.h5"
    message = f"writing the checkpoint {str(good)!r} failed: [Errno 28] No space left"
    with raised_on_every_rank(CheckpointWriteError, message):
        run_scene(scene(checkpoint_times=[1.0, 2.0]), outdir=shared_tmp, comm=comm)
    monkeypatch.undo()
    assert read_checkpoint(good, comm).attrs["time"] == 1.0
    assert on_root(comm, lambda: not (shared_tmp / "checkpoint.h5.tmp").exists())
    gc.collect()


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
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
        "channels": {"press": [0, 1, 1, -1], "slide": [0, 0, SHORT_SLIDE, SHORT_SLIDE]},
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


@pytest.mark.e2e
@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
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
            "s['solver'].update(dt=0.04, dt_max=0.04, linear='lu')\n"
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
    # LU: compared to round-off (with the reused factor, whole and resumed runs differ by
    # Newton's tolerance on two ranks: test_restart_gives_the_same_history)
    s["solver"].update(dt=0.04, dt_max=0.04, linear="lu")
    s["solver"]["prefix"] = prefix("ck")
    resumed = run_scene(s, comm=comm, restart=ck)
    s["solver"]["prefix"] = prefix("ck")
    whole = run_scene(s, comm=comm)
    assert resumed.history[-1]["t"] == whole.history[-1]["t"] == pytest.approx(11.0)
    np.testing.assert_allclose(
        columns(resumed.history, t_ck), columns(whole.history, t_ck), rtol=1e-9, atol=1e-9
    )


@pytest.mark.e2e
@pytest.mark.serial
@SUBPROCESSES
def test_disk_full_keeps_the_previous_checkpoint(shared_tmp):
    """For real: a 1 MiB tmpfs filled but 130-400 kB (the first checkpoint needs about 200), a
    checkpoint after every step, runs on 2 ranks (the fullest on 1 rank too) in processes of their
    own (mpirun, killed after 150 s). A checkpoint that does not fit is one CheckpointWriteError
    on every rank, exit 1, no crash; the previous checkpoint is intact and restartable, no
    temporary file is left."""
    kept = []

    def check(out, msg):
        if msg is None:
            return
        assert "writing the checkpoint" in msg and "checkpoint.h5" in msg, msg
        assert msg.startswith("subfric_dolfinx.io.checkpoint.CheckpointWriteError: "), msg
        assert not (out / "checkpoint.h5.tmp").exists()
        if (out / "checkpoint.h5").exists():
            kept.append(read_checkpoint(out / "checkpoint.h5", MPI.COMM_SELF).attrs["step"])

    messages = disk_full_runs(
        shared_tmp / "full",
        {"checkpoint_every": 1, "history": True},
        [210_000, 260_000, 400_000],
        check=check,
    )
    assert kept and min(kept) >= 1, (kept, messages)  # failed after at least one checkpoint
    assert None in messages, messages  # 400 kB are enough
