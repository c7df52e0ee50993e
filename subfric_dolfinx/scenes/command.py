"""``subfric-scene SCENE.json --out DIR``: run a scene kept in a JSON file.

The same as ``python3 -m subfric_dolfinx.scenes SCENE.json --out DIR``, on any number of ranks
(``mpirun -n 2 subfric-scene ...``). The scene is read strictly (:func:`~.parser.load_scene`) and
run by :func:`~.runner.run_scene`; its files go to ``--out``. Options with one dash go to PETSc
(``-<prefix>snes_monitor``, the prefix being the scene's ``solver.prefix``), ``-v`` prints a line
per step. Exit codes as the demos' (:mod:`~subfric_dolfinx.scenes.cli`): 0 done, 1 a step that
could not be solved or an I/O error, 2 bad input (the scene, its mesh, the command line), 75
stopped by a signal (SIGUSR1 to ``mpirun``; after the current step, with a checkpoint if the scene
writes any).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence
from typing import Any, TextIO

from . import cli

__all__ = ["main", "parser"]


def parser() -> argparse.ArgumentParser:
    """The command line (anything with one dash goes to PETSc)."""
    ap = cli.demo_parser(
        "Run a scene kept in a JSON file. Exit codes: 0 done, 1 a step not solved (or an I/O "
        "error), 2 bad input, 75 stopped by a signal (SIGUSR1 to mpirun).",
        prog="subfric-scene",
    )
    ap.add_argument("scene", help="the scene: a JSON file")
    ap.add_argument(
        "--out", default=None, help="output directory (required if the scene writes files)"
    )
    ap.add_argument("--restart", default=None, help="continue from this checkpoint")
    return ap


def run(argv: Sequence[str] | None = None, comm: Any = None) -> Any:
    """Parse the command line and run the scene; the :class:`~.result.SceneResult`.

    Raises:
        SystemExit: ``--help`` (0) or a bad command line (2).
        SceneError: A bad scene (and the other errors of :func:`~.runner.run_scene`).
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    args = cli.parse_args(parser(), argv, comm)
    from .runner import run_scene

    result = run_scene(args.scene, outdir=args.out, comm=comm, restart=args.restart)
    if comm.rank == 0:
        steps = len(result.history) if result.kind == "fe" else len(result.cases)
        what = "steps" if result.kind == "fe" else "cases"
        where = f", files in {args.out}" if args.out is not None else ""
        print(f"{result.name}: {steps} {what} done{where}", flush=True)
    return result


def main(argv: list[str] | None = None) -> int:
    """The console script ``subfric-scene``: its exit code.

    The package's warnings (a scene leaving the model's validity, ``mu_s`` given as a friction
    coefficient) are shown as ``subfric-scene: warning: <Category>: <text>``: the line of Python
    they would name otherwise is the launcher's (``<frozen runpy>`` under ``python3 -m``).
    """
    from ..logs import SubfricWarning

    shown = warnings.showwarning

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        if isinstance(category, type) and issubclass(category, SubfricWarning):
            print(f"subfric-scene: warning: {category.__name__}: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        return cli.run_main(run, argv, prog="subfric-scene")
    finally:
        warnings.showwarning = shown
