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

``--help`` prints the help and exits with 0, as with argparse. Standard library only.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["EXIT_USAGE", "ArgumentError", "ArgumentParser", "error_line"]

EXIT_USAGE = 2
"""Exit code of a bad command line or bad input (argparse's code for a usage error)."""


class ArgumentError(Exception):
    """A bad command line; the message is argparse's, naming the argument (one line)."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse whose usage errors raise :class:`ArgumentError` (the caller prints one line)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        """Raise the usage error instead of printing the usage and exiting.

        Raises:
            ArgumentError: Always, with argparse's message.
        """
        raise ArgumentError(message)


def error_line(message: str, code: int = EXIT_USAGE) -> int:
    """Print ``error: message`` to stderr (one line); return the exit code ``code``."""
    print(f"error: {message}", file=sys.stderr)
    return code
