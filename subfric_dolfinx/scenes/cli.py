"""The command line of the demos (and of programs like them), in one place.

A demo defines its options with :func:`demo_parser` and, in its ``main(argv, comm)``, reads them
with :func:`parse_args`; its ``__main__`` block is :func:`main_block` (as a program
``sys.exit(run_main(main))``; in a Jupyter kernel, a demo opened as a notebook, ``main()``):

* Options with two dashes are the demo's; an unknown one (``--chekpoint-every 5``) is an error
  (exit 2). Options with one dash (``-block_snes_monitor``, ``-log_view``) and their values go to
  PETSc, which is initialised with them, before it is imported.
* ``-v``/``-q`` set the log level (:func:`subfric_dolfinx.logs.configure`, rank 0 prints).
* :func:`run_main` turns the way a run ends into one line on rank 0 and an exit code: 0 done,
  1 a step that could not be solved or an I/O error, 2 bad input (scene, mesh, checkpoint, law,
  command line, any ``ValueError``), :data:`EXIT_INTERRUPTED` (75) stopped by SIGTERM, SIGINT,
  SIGUSR1 or SIGUSR2 (after the current step, with a checkpoint if the run writes any).
  Anything else is a bug: its traceback.

Stopping a run under ``mpirun``: send SIGUSR1 to ``mpirun`` (see :mod:`.signals`); a single
process also stops cleanly on SIGINT (Ctrl-C) and SIGTERM.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from .. import logs
from ..commandline import (
    EXIT_USAGE,
    ArgumentError,
    ArgumentParser,
    in_notebook,
    program_args,
    summary,
)
from .signals import STOP_SIGNALS, SceneInterrupted, guard_active, note_stop

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "HelpFormatter",
    "demo_parser",
    "main_block",
    "parse_args",
    "run_main",
    "split_petsc",
]

EXIT_FAILED = 1
EXIT_BAD_INPUT = EXIT_USAGE
EXIT_INTERRUPTED = 75  # EX_TEMPFAIL of sysexits.h: stopped on request, restart later

logger = logging.getLogger(__name__)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """``--help`` with every option's default."""


class _Parser(ArgumentParser):
    """The package's one-line-error argparse, printing on rank 0 only (every rank exits alike)."""

    rank = 0

    def _print_message(self, message: str, file: Any = None) -> None:
        if self.rank == 0:
            super()._print_message(message, file)


def demo_parser(description: str, prog: str | None = None) -> argparse.ArgumentParser:
    """An argument parser with ``-v``/``--verbose`` and ``-q``/``--quiet``.

    Add the demo's own (long) options to it. Abbreviated options are not accepted.

    Args:
        description: The demo's docstring: ``--help`` shows its first line (the title), the
            options and their defaults; the rest is the demo's documentation (its page).
        prog: The program's name (default: the script's).
    """
    ap = _Parser(
        description=summary(description),
        prog=prog,
        allow_abbrev=False,
        formatter_class=HelpFormatter,
    )
    ap.epilog = "Options with one dash (e.g. -<prefix>snes_monitor, -log_view) go to PETSc."
    ap.add_argument("-v", "--verbose", action="count", default=0, help="a log line per step")
    ap.add_argument("-q", "--quiet", action="count", default=0, help="warnings only")
    return ap


def _short_flags(parser: argparse.ArgumentParser) -> set[str]:
    return {
        s[1]
        for a in parser._actions
        for s in a.option_strings
        if len(s) == 2 and s[0] == "-" and s[1] != "-"
    }


def _is_option(token: str) -> bool:
    return len(token) > 1 and token[0] == "-" and (token[1].isalpha() or token[1] == "-")


def split_petsc(
    parser: argparse.ArgumentParser, argv: Sequence[str]
) -> tuple[list[str], list[str]]:
    """Split a command line into the demo's part and PETSc's part.

    A token with one dash and a letter (``-ksp_type``) is a PETSc option unless it is made of
    the parser's one-letter flags only (``-v``, ``-vv``, ``-q``, ``-h``); the next token is its
    value unless it looks like an option (a negative number is a value).
    """
    shorts = _short_flags(parser)
    demo: list[str] = []
    petsc: list[str] = []
    args = list(argv)
    i = 0
    while i < len(args):
        a = args[i]
        if a == "--":
            demo.extend(args[i:])
            break
        if _is_option(a) and a[1] != "-" and not set(a[1:]) <= shorts:
            petsc.append(a)
            if i + 1 < len(args) and not _is_option(args[i + 1]):
                petsc.append(args[i + 1])
                i += 1
        else:
            demo.append(a)
        i += 1
    return demo, petsc


def _init_petsc(petsc_args: list[str]) -> None:
    """Initialise PETSc with ``petsc_args``; if it is running already, add them to its options."""
    if "petsc4py.PETSc" not in sys.modules:
        import petsc4py

        petsc4py.init([sys.argv[0] if sys.argv and sys.argv[0] else "python3", *petsc_args])
        return
    if petsc_args:
        from petsc4py import PETSc

        PETSc.Options().insertString(" ".join(petsc_args))


def parse_args(
    parser: argparse.ArgumentParser, argv: Sequence[str] | None = None, comm: Any = None
) -> argparse.Namespace:
    """Parse a demo's command line: its options, PETSc's options, the log level.

    Args:
        parser: From :func:`demo_parser`, with the demo's options.
        argv: The arguments (default ``sys.argv[1:]``).
        comm: MPI communicator (rank 0 prints the log and any usage message).

    Returns:
        The demo's options.

    Raises:
        SystemExit: ``--help`` (0), or a usage error (2, one line on rank 0 naming the
            argument): an unknown option with two dashes (PETSc options start with one), a
            missing or malformed value.
    """
    if isinstance(parser, _Parser) and comm is not None:
        parser.rank = comm.rank
    demo, petsc = split_petsc(parser, program_args(argv))  # in a notebook: no command line
    try:
        args, unknown = parser.parse_known_args(demo)
        if unknown:
            long_ = [u for u in unknown if u.startswith("--")]
            if long_:
                known = sorted(
                    s for a in parser._actions for s in a.option_strings if s[:2] == "--"
                )
                parser.error(
                    f"unknown option {long_[0]} (the options are {', '.join(known)}; PETSc "
                    "options start with one dash, e.g. -<prefix>snes_monitor)"
                )
            parser.error(f"unexpected argument(s): {' '.join(unknown)}")
    except ArgumentError as e:  # one line on rank 0, exit code 2 on every rank
        if comm is None or comm.rank == 0:
            print(f"{parser.prog}: error: {e}", file=sys.stderr, flush=True)
        raise SystemExit(EXIT_USAGE) from None
    _init_petsc(petsc)
    logs.configure(args.verbose - args.quiet, comm)
    return args


def _exit_code(e: BaseException) -> int | None:
    """Exit code of an expected way for a run to end, or ``None`` (a bug: let it raise)."""
    from ..constitutive import LawError
    from ..driver import CaseError
    from ..loading import LoadingError
    from .schema import SceneError

    if isinstance(e, SceneInterrupted):
        return EXIT_INTERRUPTED
    if isinstance(e, SceneError | LawError | LoadingError | CaseError | FileNotFoundError):
        return EXIT_BAD_INPUT
    if "subfric_dolfinx.fem" in sys.modules:  # only then can these have been raised
        from ..fem import InterfaceError, StepFailure
        from ..io import CheckpointError, OutputError
        from ..meshing import InterfaceMeshError

        if isinstance(e, OutputError):  # a file not written (a checkpoint's too): disk full, ...
            return EXIT_FAILED
        if isinstance(e, InterfaceError | InterfaceMeshError | CheckpointError):
            return EXIT_BAD_INPUT
        if isinstance(e, StepFailure):
            return EXIT_FAILED
    if isinstance(e, OSError):
        return EXIT_FAILED
    if isinstance(e, ValueError):  # an argument refused by a builder, a material, ...
        return EXIT_BAD_INPUT
    return None


class _StopWatch:
    """Outside an FE run's signal guard, a stop signal ends the process within a second.

    There is nothing to save then (the set-up builds the mesh and the problem; the output
    directory and its files exist only under the guard, :mod:`.signals`), but the main thread
    may be inside a long call that Python's signal handlers wait for (gmsh meshing ``--n 600``
    for 7 minutes, a collective that another rank has left): a thread woken by the signal
    (``signal.set_wakeup_fd``) prints the one line (rank 0) and ends the process with
    :data:`EXIT_INTERRUPTED` (``os._exit``; under ``mpirun`` every rank gets the signal, or
    ``mpirun`` ends the others; ranks other than 0 wait 0.5 s, so that rank 0's line is out
    before ``mpirun`` ends the job).
    """

    def __init__(self, prog: str, rank: int) -> None:
        self.prog, self.rank = prog, rank
        self._numbers = {int(s) for s in STOP_SIGNALS}
        self._previous: dict[signal.Signals, Any] = {}
        self._thread: threading.Thread | None = None
        self.stopping = False  # the run was stopped: later signals change nothing

    def __enter__(self) -> _StopWatch:
        if threading.current_thread() is not threading.main_thread():
            return self
        self._r, self._w = os.pipe()
        os.set_blocking(self._w, False)
        self._old_fd = signal.set_wakeup_fd(self._w, warn_on_full_buffer=False)
        self._previous = {s: signal.signal(s, _noted) for s in STOP_SIGNALS}
        self._thread = threading.Thread(target=self._watch, name="subfric-stop", daemon=True)
        self._thread.start()
        return self

    def _watch(self) -> None:
        while True:
            try:
                data = os.read(self._r, 64)
            except OSError:
                return
            if not data:  # closed: the run is over
                return
            for b in data:
                if b in self._numbers and not guard_active() and not self.stopping:
                    self._stop(signal.Signals(b))

    def _stop(self, sig: signal.Signals) -> None:
        if self.rank == 0:
            line = f"{self.prog}: interrupted by {sig.name} outside the load stepping "
            line += "(no checkpoint written)\n"
            os.write(2, line.encode())
        else:  # let rank 0 say why first (mpirun ends the job when a rank exits)
            time.sleep(0.5)
        flush = threading.Thread(target=_flush, daemon=True)  # never wait on a held stream
        flush.start()
        flush.join(1.0)
        os._exit(EXIT_INTERRUPTED)

    def __exit__(self, *exc: object) -> None:
        if self._thread is None:
            return
        # A stopped run's process is ending with EXIT_INTERRUPTED: a later stop signal is
        # ignored (mpirun forwards a second one late; its default action, to end the process,
        # would replace that exit code by the signal's)
        for s, h in self._previous.items():
            signal.signal(s, signal.SIG_IGN if self.stopping else h)
        signal.set_wakeup_fd(self._old_fd)
        os.close(self._w)  # the watcher reads the end of the pipe and returns
        self._thread.join()
        os.close(self._r)
        self._thread = None


def _noted(signum: int, frame: Any) -> None:
    """Python's part of a stop signal outside the guard: noted, for a guard taking over.

    The watcher thread acts otherwise.
    """
    note_stop(signum)


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass


def run_main(
    main: Callable[[list[str] | None], Any], argv: list[str] | None = None, prog: str | None = None
) -> int:
    """Run a demo's ``main(argv)``; return its exit code, the way it ended in one line.

    Use as ``sys.exit(run_main(main))``. SIGTERM, SIGINT, SIGUSR1 and SIGUSR2 stop the run:
    during an FE run after the current step (with a checkpoint if the run writes any; a second
    signal within the step, :mod:`.signals`), elsewhere (building the mesh and the problem,
    drawing figures) within a second (:class:`_StopWatch`); either way exit code
    :data:`EXIT_INTERRUPTED`, one line, no traceback. ``prog`` names the program in that line
    (default: the script's name).
    """
    from mpi4py import MPI

    rank = MPI.COMM_WORLD.rank
    if prog is None:
        prog = (sys.argv[0].rsplit("/", 1)[-1] if sys.argv and sys.argv[0] else "") or "demo"
    with _StopWatch(prog, rank) as watch:
        try:
            main(argv)
        except Exception as e:
            code = _exit_code(e)
            if code is None:
                raise
            watch.stopping = code == EXIT_INTERRUPTED
            if rank == 0:
                what = "" if code == EXIT_INTERRUPTED else "error: "
                print(f"{prog}: {what}{e}", file=sys.stderr, flush=True)
            return code
    return 0


def main_block(main: Callable[..., Any]) -> Any:
    """A demo's ``if __name__ == "__main__":`` block.

    As a program: ``sys.exit(run_main(main))``. In a Jupyter kernel (the demo opened as a
    notebook), where ``sys.exit`` would end the cell with ``SystemExit``: ``main()`` with the
    defaults, its result returned and any error shown as the notebook shows it (call
    ``main(["--n", "8"])`` in a cell for other options).

    Raises:
        SystemExit: As a program, always, with :func:`run_main`'s exit code.
    """
    if in_notebook():
        return main()
    sys.exit(run_main(main))
