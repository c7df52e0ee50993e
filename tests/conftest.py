"""Test configuration: MPI hygiene as in DOLFINx's own test suite.

* Collective teardown: garbage-collect and barrier after every test, so that PETSc/DOLFINx objects
  are destroyed collectively and a rank never runs ahead into the next test.
* ``@pytest.mark.serial``: tests that only make sense on one rank are skipped, with that reason,
  when run on more (the suite is run on 1 and on 2 ranks, so they still run).
* ``shared_tmp``: a temporary directory common to all ranks (``tmp_path`` differs per rank).
"""

import gc
import pathlib
import tempfile

import pytest
from mpi4py import MPI


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False, help="run tests marked slow")


def pytest_collection_modifyitems(config, items):
    size = MPI.COMM_WORLD.size
    skip_serial = pytest.mark.skip(reason=f"serial-only test, running on {size} ranks")
    skip_slow = pytest.mark.skip(reason="slow test: give --run-slow to run it")
    for item in items:
        if size > 1 and "serial" in item.keywords:
            item.add_marker(skip_serial)
        if "slow" in item.keywords and not config.getoption("--run-slow"):
            item.add_marker(skip_slow)


def pytest_runtest_teardown(item):
    """Collective teardown: every rank collects garbage, then all meet at a barrier."""
    gc.collect()
    MPI.COMM_WORLD.Barrier()


@pytest.fixture
def comm():
    return MPI.COMM_WORLD


@pytest.fixture
def shared_tmp():
    """A fresh directory, the same on all ranks, removed after the test."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="subfric-") if comm.rank == 0 else None
    path = pathlib.Path(comm.bcast(path, root=0))
    yield path
    comm.Barrier()
    if comm.rank == 0:
        import shutil

        shutil.rmtree(path, ignore_errors=True)
