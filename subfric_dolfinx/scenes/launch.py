"""``mpirun`` with SIGTERM and SIGINT (Ctrl-C) turned into clean stops of the run.

Open MPI's ``mpirun`` (5.0) does not forward SIGTERM or SIGINT to the ranks: it ends the job
itself. It sends them SIGCONT, SIGTERM 0.25 s later and SIGKILL 0.25 s after that, relays none
of their output from then on and exits with 1, whatever the ranks do: a run stopped so says
nothing, and a checkpoint being written is cut short (such a file is refused as incomplete,
:mod:`subfric_dolfinx.io.checkpoint`). SIGUSR1 and SIGUSR2 it forwards: a run stops cleanly on
them (:mod:`.signals`). This launcher runs ``mpirun`` with the given arguments in a session of
its own (a Ctrl-C at the terminal reaches the launcher only) and turns every SIGTERM or SIGINT it
receives into a SIGUSR1 to ``mpirun``: the first stops the run after its step (with a checkpoint
if it writes any), the second within the step; the run prints its one line and the launcher
exits with the job's code (75 when stopped)::

    python3 -m subfric_dolfinx.scenes.launch -n 2 python3 demos/block_sliding_far.py

The job's standard input is not forwarded (the demos read none). ``SUBFRIC_MPIRUN`` names another
``mpirun``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from typing import Any

__all__ = ["main"]

_USAGE = "usage: python3 -m subfric_dolfinx.scenes.launch [mpirun options] PROGRAM [ARGS...]"


def main(argv: list[str] | None = None) -> int:
    """Run ``mpirun ARGV``; SIGTERM and SIGINT become SIGUSR1 to it; its exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(_USAGE, file=sys.stdout if args else sys.stderr)
        return 0 if args else 2
    mpirun = os.environ.get("SUBFRIC_MPIRUN", "mpirun")
    try:
        job = subprocess.Popen([mpirun, *args], stdin=subprocess.DEVNULL, start_new_session=True)
    except OSError as e:
        print(f"launch: cannot start {mpirun!r}: {e.strerror}", file=sys.stderr)
        return 2
    received: list[int] = []

    def forward(signum: int, frame: Any) -> None:
        received.append(signum)
        when = "after its step" if len(received) == 1 else "within its step"
        name = signal.Signals(signum).name
        os.write(2, f"launch: {name}: the run stops {when} (SIGUSR1 to mpirun)\n".encode())
        try:
            job.send_signal(signal.SIGUSR1)
        except ProcessLookupError:  # the job has ended meanwhile
            pass

    for s in (signal.SIGTERM, signal.SIGINT):
        signal.signal(s, forward)
    code = job.wait()
    return code if code >= 0 else 128 - code


if __name__ == "__main__":
    sys.exit(main())
