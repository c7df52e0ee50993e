"""Helpers shared by the tests (MPI-aware assertions and paths)."""

from pathlib import Path

from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]


def everywhere(comm: MPI.Comm, ok: bool) -> bool:
    """True on every rank iff ``ok`` holds on every rank (collective)."""
    return comm.allreduce(bool(ok), op=MPI.LAND)
