"""The argument parser of the package's command lines: a bad argument is one line, exit code 2.

The material-point driver (``subfric-driver``), the calibration (``subfric-calibrate``) and the
demos (:func:`subfric_dolfinx.scenes.cli.demo_parser`) parse their arguments with
:class:`ArgumentParser`. A usage error (an unknown option, a missing or malformed value, a stray
argument) raises :class:`ArgumentError` instead of printing argparse's usage paragraph and
exiting; the command prints it as one line naming the argument, ``error: argument --n: invalid
int value: 'abc'``, and exits with :data:`EXIT_USAGE` (2, argparse's own code for it)::

    ap = ArgumentParser(prog="subfric-driver", description="...")
    ap.add_argument("case")
    try:
        args = ap.parse_args(argv)
    except ArgumentError as e:
        return error_line(str(e))

``--help`` prints the help and exits with 0, as with argparse; its description is one line
(:func:`summary`: a program's docstring is its documentation, not its help).

A program that may also be opened as a notebook (the demos: jupytext sources) ends with
``main_block(main)`` under ``if __name__ == "__main__":`` and parses
:func:`program_args`: as a program it exits with ``main``'s code; in a Jupyter kernel, where the
command line is the kernel's and ``sys.exit`` would end the cell with ``SystemExit``, it runs
``main`` with the defaults and returns its result. Standard library only.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

__all__ = [
    "EXIT_USAGE",
    "ArgumentError",
    "ArgumentParser",
    "error_line",
    "in_notebook",
    "main_block",
    "program_args",
    "summary",
]

EXIT_USAGE = 2
"""Exit code of a bad command line or bad input (argparse's code for a usage error)."""


class ArgumentError(Exception):
    """A bad command line; the message is argparse's, naming the argument (one line)."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse whose usage errors raise :class:`ArgumentError` (the caller prints one line)."""

    def error(self, message: str) -> NoReturn:
        """Raise the usage error instead of printing the usage and exiting.

        Raises:
            ArgumentError: Always, with argparse's message.
        """
        raise ArgumentError(message)


def error_line(message: str, code: int = EXIT_USAGE) -> int:
    """Print ``error: message`` to stderr (one line); return the exit code ``code``."""
    print(f"error: {message}", file=sys.stderr)
    return code


def summary(doc: str | None) -> str:
    """The first line of a docstring, without a Markdown title's ``#``: a ``--help`` description."""
    for line in (doc or "").splitlines():
        if line.strip():
            return line.strip().lstrip("#").strip()
    return ""


def in_notebook() -> bool:
    """True in a Jupyter kernel (a program opened as a notebook): ``sys.argv`` is the kernel's."""
    return "ipykernel" in sys.modules


def program_args(argv: Sequence[str] | None = None) -> list[str]:
    """The arguments a program parses: ``argv``, else its command line (none in a notebook)."""
    if argv is not None:
        return list(argv)
    return [] if in_notebook() else sys.argv[1:]


def main_block(main: Callable[[], Any]) -> Any:
    """A program's ``__main__`` block: exits with ``main()``'s code, in a notebook returns it.

    As a program the exit code is ``main()``'s return value if it is an integer, else 0 (a
    ``main`` that returns its results). In a Jupyter kernel ``sys.exit`` raises ``SystemExit``
    into the cell, which the notebook shows as an error even for 0: there ``main()`` runs with
    its defaults (see :func:`program_args`) and its result is returned; call ``main([...])`` in
    a cell for other options.

    Raises:
        SystemExit: As a program, always.
    """
    if in_notebook():
        return main()
    result = main()
    sys.exit(result if isinstance(result, int) else 0)
