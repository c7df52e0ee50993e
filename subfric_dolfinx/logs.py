"""The package's log: one logger, a handler printing on rank 0, the rank of a serial program.

Under ``mpirun``, a numpy-only program finds its rank with :func:`launcher_rank`; a child process
started from a rank gets :func:`singleton_environment` so that it does not join the job.

Every module logs to a child of the ``subfric_dolfinx`` logger (``logging.getLogger(__name__)``).
As a library, the package installs no output handler of its own; a program (a demo, a script)
calls :func:`configure` once to see the log::

    from subfric_dolfinx import logs
    logs.configure(verbosity=0, comm=MPI.COMM_WORLD)   # -1 warnings, 0 info, 1 debug

Levels: WARNING for things a user must see (e.g. a large penetration), INFO for one line per
segment of the loading program and the run's summary, DEBUG for one line per load step and per
failed attempt.
"""

from __future__ import annotations

import logging
import os
import sys
from typing import Any, TextIO

__all__ = ["LOGGER_NAME", "configure", "launcher_rank", "level_for", "singleton_environment"]

LOGGER_NAME = "subfric_dolfinx"
logging.getLogger(LOGGER_NAME).addHandler(logging.NullHandler())


def level_for(verbosity: int) -> int:
    """Logging level of a verbosity: <= -1 WARNING, 0 INFO, >= 1 DEBUG."""
    if verbosity <= -1:
        return logging.WARNING
    return logging.INFO if verbosity == 0 else logging.DEBUG


class _RankFilter(logging.Filter):
    def __init__(self, rank: int) -> None:
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        return self.rank == 0


def configure(
    verbosity: int = 0, comm: Any = None, stream: TextIO | None = None
) -> logging.Handler:
    """Print the package's log on rank 0 of ``comm`` (all processes print if ``comm`` is None).

    Calling it again replaces the handler it installed before.

    Args:
        verbosity: -1 (warnings only), 0 (info: a line per segment and the summary), 1 (debug:
            a line per step).
        comm: MPI communicator; only its rank 0 prints.
        stream: Where to print (default ``sys.stdout``).

    Returns:
        The installed handler.
    """
    logger = logging.getLogger(LOGGER_NAME)
    for h in list(logger.handlers):
        if getattr(h, "_subfric", False):
            logger.removeHandler(h)
    handler = logging.StreamHandler(stream or sys.stdout)
    handler._subfric = True  # type: ignore[attr-defined]
    handler.setFormatter(logging.Formatter("%(message)s"))
    handler.addFilter(_RankFilter(0 if comm is None else comm.rank))
    logger.addHandler(handler)
    logger.setLevel(level_for(verbosity))
    logger.propagate = False
    return handler


_LAUNCHED = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK")
_RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK")


def launcher_rank() -> int:
    """This process's rank when an MPI launcher started it, else 0; MPI is not initialised.

    The numpy-only programs (the material-point driver, the calibration, their demos) have
    nothing to distribute: under ``mpirun -n N`` rank 0 computes and writes, and the others
    return at once instead of writing the same files side by side. The rank is read from the
    launcher's environment (Open MPI, MPICH/Hydra, PMIx), so mpi4py is not needed.
    """
    if not any(k in os.environ for k in _LAUNCHED):
        return 0
    for k in _RANK_VARIABLES:
        value = os.environ.get(k, "")
        if value.isdigit():
            return int(value)
    return 0


_LAUNCHER_PREFIXES = ("OMPI_", "PMI_", "PMIX_", "PRTE_", "HYDRA_")
_LAUNCHER_KEEP = {"OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "OMPI_MCA_btl"}


def singleton_environment() -> dict[str, str]:
    """This process's environment without the variables of the MPI job that started it.

    A child started from an MPI rank would otherwise try to join the parent's job; without them
    it starts as an MPI singleton (or as its own ``mpirun``). Open MPI's settings that are not
    about the job (running as root, the transport) are kept.
    """
    return {
        k: v
        for k, v in os.environ.items()
        if k in _LAUNCHER_KEEP or not k.startswith(_LAUNCHER_PREFIXES)
    }
