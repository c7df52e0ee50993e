"""The demos' command line (subfric_dolfinx.scenes.cli): options, PETSc's share, exit codes.

The exit codes are checked on real processes: a demo run by ``mpirun -n 2`` that gets SIGUSR1
(sent to mpirun, which forwards it) stops after its step with a checkpoint, one line and exit
code 75, and restarts from it; SIGTERM and SIGUSR2 to a single process alike; a step that cannot
be solved exits 1, bad input 2, a misspelt option 2 before anything runs. These start their own
processes, so they run in the 1-rank suite only (``serial``); each has a timeout.
"""

import signal
import subprocess
import sys

import pytest
from mpi4py import MPI

from demos import (
    block_on_base,
    bolted_joint,
    cattaneo_mindlin,
    fretting,
    hertz,
    lap_joint,
    pad_on_plate,
    punch,
)
from subfric_dolfinx.scenes import cli
from tests.helpers import ROOT, everywhere, singleton_env

DEMOS = [
    block_on_base,
    pad_on_plate,
    punch,
    lap_joint,
    hertz,
    cattaneo_mindlin,
    bolted_joint,
    fretting,
]
SMALL = ["--n", "4", "--hold", "1", "--no-figures"]


def test_petsc_options_are_split_from_the_demos_options():
    ap = cli.demo_parser("test")
    ap.add_argument("--n", type=int)
    ap.add_argument("--amplitude", type=float)
    argv = ["--n", "8", "-block_snes_monitor", "-block_ksp_type", "gmres", "-v", "-vv", "-q"]
    argv += ["-log_view", "-block_snes_linesearch_damping", "-0.5", "--amplitude", "-1", "-h"]
    demo, petsc = cli.split_petsc(ap, argv)
    assert demo == ["--n", "8", "-v", "-vv", "-q", "--amplitude", "-1", "-h"]
    assert petsc == [
        "-block_snes_monitor",
        "-block_ksp_type",
        "gmres",
        "-log_view",
        "-block_snes_linesearch_damping",
        "-0.5",
    ]


@pytest.mark.parametrize("demo", DEMOS, ids=[d.__name__.split(".")[-1] for d in DEMOS])
@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--chekpoint-every", "5"], ["unknown option --chekpoint-every", "one dash"]),
        (["--n"], ["expected one argument"]),
        (["--n", "4", "stray"], ["unexpected argument(s): stray"]),
        (["--ou", "x"], ["unknown option --ou"]),  # no abbreviations
    ],
    ids=["misspelt", "no-value", "stray", "abbreviated"],
)
def test_every_demo_refuses_unknown_long_options(demo, argv, words, capsys):
    """On every rank, before anything is built: exit code 2 and the option named (rank 0)."""
    comm = MPI.COMM_WORLD
    with pytest.raises(SystemExit) as e:
        demo.main(argv, comm)
    assert e.value.code == 2
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert all(w in err for w in words), err
    else:
        assert err == ""  # one message, from rank 0


def test_the_guard_turns_a_signal_into_a_request_every_rank_sees():
    """Rank 0 alone gets SIGUSR2: every rank sees the request and agrees on the signal; a second
    (SIGINT) is counted too (urgent: stop within the step), nothing is raised and the handler in
    place before the guard is not called; on exit that handler is back."""
    import os

    from subfric_dolfinx.scenes.signals import StopSignals, guard_active

    comm = MPI.COMM_WORLD
    seen = []
    checks = []
    before = signal.signal(signal.SIGUSR2, lambda s, f: seen.append(s))
    try:
        with StopSignals() as guard:
            checks.append(not guard.requested(comm) and guard_active())
            if comm.rank == 0:
                os.kill(os.getpid(), signal.SIGUSR2)
            checks.append(guard.requested(comm) and guard.name == "SIGUSR2" and seen == [])
            checks.append(not guard.urgent)
            if comm.rank == 0:
                os.kill(os.getpid(), signal.SIGINT)  # the second: no KeyboardInterrupt
                checks.append(seen == [] and guard.urgent and guard.count == 2)
        checks.append(signal.getsignal(signal.SIGUSR2) is not guard._handler)
        checks.append(not guard_active())
        os.kill(os.getpid(), signal.SIGUSR2)
        checks.append(seen == [signal.SIGUSR2])
    finally:
        signal.signal(signal.SIGUSR2, before)
    assert everywhere(comm, all(checks)), checks


LATE_SIGNAL = """
import os, signal, sys
from subfric_dolfinx.scenes import cli
from subfric_dolfinx.scenes.signals import SceneInterrupted

def main(argv):
    raise SceneInterrupted("interrupted by SIGUSR1 after step 3", 3.0, None)

code = cli.run_main(main, [], prog="late")
os.kill(os.getpid(), signal.SIGUSR1)  # as mpirun forwards a second signal, late
os.kill(os.getpid(), signal.SIGTERM)
print("alive", code, flush=True)
sys.exit(code)
"""


@pytest.mark.serial
def test_a_signal_after_the_run_stopped_keeps_the_exit_code():
    """A run stopped by a signal ends with exit code 75 even when another stop signal arrives
    after the run, while the process ends: it is ignored (its default action ended the process
    with the signal's code instead: a rank of a launcher's job, SIGINT 50 ms after SIGTERM)."""
    p = subprocess.run(
        [sys.executable, "-c", LATE_SIGNAL],
        cwd=ROOT,
        env=singleton_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == cli.EXIT_INTERRUPTED, (p.returncode, p.stdout, p.stderr)
    assert "alive 75" in p.stdout and "late: interrupted by SIGUSR1" in p.stderr, p.stderr


def run(cmd, signal_at=None, sig=signal.SIGUSR1, timeout=180):
    """Run ``cmd`` from the repository root; send ``sig`` once a line starts with
    ``signal_at``. Returns (exit code, output)."""
    p = subprocess.Popen(
        cmd,
        cwd=ROOT,
        env=singleton_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    try:
        if signal_at is not None:
            for line in p.stdout:
                lines.append(line)
                if line.startswith(signal_at):
                    p.send_signal(sig)
                    break
        out, _ = p.communicate(timeout=timeout)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    return p.returncode, "".join(lines) + out


def demo_cmd(*args, ranks=1):
    cmd = [sys.executable, "demos/block_on_base.py", *SMALL, *map(str, args)]
    return ["mpirun", "-n", str(ranks), *cmd] if ranks > 1 else cmd


@pytest.mark.e2e
@pytest.mark.serial
def test_sigusr1_to_mpirun_stops_after_the_step_and_the_run_restarts(tmp_path):
    """The documented way to stop an MPI job: SIGUSR1 to mpirun. Both ranks finish the step,
    write the checkpoint, and exit 75 with one line; the restart from it completes."""
    out = tmp_path / "run"
    rc, text = run(
        demo_cmd("--out", out, "-v", "--checkpoint-every", 1000, ranks=2), signal_at="step   10"
    )
    assert rc == cli.EXIT_INTERRUPTED, text
    assert "Traceback" not in text, text
    lines = [ln for ln in text.splitlines() if "interrupted" in ln]
    assert len(lines) == 1 and "checkpoint written to" in lines[0], text
    assert (out / "checkpoint.h5").is_file()
    rc, text = run(demo_cmd("--out", out, "--restart", out / "checkpoint.h5", ranks=2))
    assert rc == 0, text
    assert "restarted from" in text


@pytest.mark.e2e
@pytest.mark.serial
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGUSR2], ids=["SIGTERM", "SIGUSR2"])
def test_a_signal_stops_a_run_without_checkpoints_cleanly(tmp_path, sig):
    rc, text = run(demo_cmd("--out", tmp_path, "-v"), signal_at="step   10", sig=sig)
    assert rc == cli.EXIT_INTERRUPTED, text
    assert "Traceback" not in text, text
    assert f"interrupted by {sig.name} after step" in text and "no checkpoint" in text, text


@pytest.mark.e2e
@pytest.mark.serial
def test_a_signal_before_the_stepping_stops_at_once(tmp_path):
    """Sent while the problem is being built (after the first log line): exit 75, one line."""
    rc, text = run(demo_cmd("--out", tmp_path), signal_at="[block_on_base]")
    assert rc == cli.EXIT_INTERRUPTED, text
    assert "Traceback" not in text and "interrupted by SIGUSR1" in text, text


@pytest.mark.e2e
@pytest.mark.serial
@pytest.mark.parametrize(
    ("args", "code", "words"),
    [
        (["-block_snes_max_it", "1"], 1, ["error: no convergence at t = ", "worst point"]),
        (["--restart", "missing.h5"], 2, ["error: ", "missing.h5", "does not exist"]),
        (["--chekpoint-every", "5"], 2, ["unknown option --chekpoint-every"]),
        (["--n", "-3"], 2, ["error: "]),
    ],
    ids=["step-failure", "missing-checkpoint", "misspelt-option", "bad-builder-option"],
)
def test_exit_codes_and_one_line(tmp_path, args, code, words):
    """A PETSc option on the command line reaches the solver (here: one Newton iteration, so no
    step converges): exit 1; bad input: exit 2; each with one line, no traceback."""
    rc, text = run(demo_cmd("--out", tmp_path, *args))
    assert rc == code, text
    assert "Traceback" not in text, text
    assert all(w in text for w in words), text
    assert len([ln for ln in text.splitlines() if "error: " in ln]) == 1, text
