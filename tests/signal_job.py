"""An MPI job for ``tests/scenes/test_stop_signals.py``: the same tiny run, again and again, each
stopped by signals that the test sends to ``mpirun`` at random moments.

Usage: ``mpirun -n 2 python3 tests/signal_job.py OUTDIR RUNS``. Rank 0 prints ``STARTED k`` at
the first step of run ``k`` (the test then sends its signals) and, when the run has ended,
``RESULT {json}``: how it ended (``interrupted``, ``completed`` or ``error``), the time of the
last converged step it reports, the time and step of the checkpoint read back (on every rank)
and the last time of ``history.csv``. Between runs a stop signal changes nothing. After the last
run the job waits for a line on its standard input (rank 0; the test writes it once it has sent
its last signal): a signal the test sent just before the job's last ``RESULT`` would otherwise
reach ``mpirun`` while it tears the job down, when its default action ends it (exit 138). A run
still going after 120 s (they take seconds) is a hang: each rank prints its stacks and exits.
"""

from __future__ import annotations

import csv
import faulthandler
import json
import logging
import signal
import sys
from pathlib import Path

from mpi4py import MPI

from demos import block_on_base
from subfric_dolfinx.io import read_checkpoint
from subfric_dolfinx.scenes import SceneInterrupted, run_scene


class _Started(logging.Handler):
    """Prints ``STARTED k`` (rank 0) at the first step log line of a run."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.run = -1
        self.said = True

    def emit(self, record: logging.LogRecord) -> None:
        if not self.said and record.getMessage().startswith("step "):
            self.said = True
            print(f"STARTED {self.run}", flush=True)


def last_history_time(path: Path) -> float | str | None:
    """The time of the last row of ``history.csv``; ``None`` without a row (a run stopped before
    its first step writes nothing); the error's text if it cannot be read."""
    try:
        with open(path) as f:
            rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
        return float(rows[-1][rows[0].index("t")]) if len(rows) > 1 else None
    except FileNotFoundError:
        return None
    except Exception as e:
        return f"{type(e).__name__}: {e}"


def main(out: Path, runs: int) -> None:
    comm = MPI.COMM_WORLD
    for s in (signal.SIGUSR1, signal.SIGUSR2):  # outside a run: nothing
        signal.signal(s, lambda *_: None)
    started = _Started()
    stepping = logging.getLogger("subfric_dolfinx.fem.stepping")
    stepping.setLevel(logging.DEBUG)
    if comm.rank == 0:
        stepping.addHandler(started)
    for k in range(runs):
        scene = block_on_base.scene(n=4, hold=1.0, checkpoint_every=1)
        # The last slide stretched over 2000 s (40,000 steps): a run never ends by itself before
        # the test's signals, which come up to 1 s after its first step (the demo's program, 123
        # steps, took ~0.5 s: the run completed first, 3 times in 4 on a quiet machine)
        scene["program"]["times"][-1] += 2000.0
        scene["solver"]["prefix"] = f"run{k}_"
        outdir = out / f"run{k}"
        started.run, started.said = k, False
        result = {"run": k}
        # A run takes seconds: one still going after 120 s is a hang; every rank then prints
        # its threads' stacks (to the test's output) and exits, which ends the job.
        faulthandler.dump_traceback_later(120, exit=True)
        try:
            run_scene(scene, outdir=outdir, comm=comm)
            result["outcome"] = "completed"
        except SceneInterrupted as e:
            result.update(outcome="interrupted", t=e.t, message=str(e))
        except Exception as e:  # reported, the test fails on it
            result.update(outcome="error", message=f"{type(e).__name__}: {e}")
        ck = outdir / "checkpoint.h5"
        result["checkpoint_exists"] = ck.exists()
        if ck.exists():
            try:
                c = read_checkpoint(ck, comm)
                result.update(
                    checkpoint_t=float(c.attrs["time"]), checkpoint_step=int(c.attrs["step"])
                )
            except Exception as e:
                result["checkpoint_error"] = f"{type(e).__name__}: {e}"
        agreed = comm.allgather(json.dumps(result, sort_keys=True))
        if comm.rank == 0:  # nothing here may raise: rank 1 waits at the barrier below
            result["same_on_every_rank"] = len(set(agreed)) == 1
            result["history_t"] = last_history_time(outdir / "history.csv")
            print("RESULT " + json.dumps(result), flush=True)
        comm.Barrier()
        faulthandler.cancel_dump_traceback_later()
    if comm.rank == 0:
        sys.stdin.readline()  # the test has sent its last signal
    comm.Barrier()


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]))
