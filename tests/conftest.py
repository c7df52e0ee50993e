"""Test configuration: MPI hygiene as in DOLFINx's own test suite.

* Collective teardown: garbage-collect and barrier after every test, so that PETSc/DOLFINx objects
  are destroyed collectively and a rank never runs ahead into the next test.
* ``@pytest.mark.serial``: tests that only make sense on one rank are skipped, with that reason,
  when run on more (the suite is run on 1 and on 2 ranks, so they still run).
* ``pytestmark = pytest.mark.numpy_only``: a module that touches neither MPI nor DOLFINx (return
  map, driver, fuzzing, ...) gives the same answer on every rank; on more than one rank its tests
  are deselected (pytest reports them as "deselected"), since the 1-rank run has already run them.
* ``shared_tmp``: a temporary directory common to all ranks (``tmp_path`` differs per rank).
* Repeatable partitions: ``SCOTCH_PTHREAD_NUMBER=1`` unless set (see below).
* A broken pipe is an exception again: PETSc's initialisation installs its signal handler for
  SIGPIPE (and SIGHUP), which ends the process with PETSc's error code 59 and no message; Python
  ignores SIGPIPE so that writing to a pipe whose reader has gone raises ``BrokenPipeError``. A test
  that writes to a child job which has ended (``test_stop_signals``) took the whole suite down
  with exit code 59 instead of failing with the job's output (sid, 1 rank, under load).
"""

import gc
import os
import pathlib
import signal
import sys
import tempfile

import pytest
from mpi4py import MPI
from petsc4py import PETSc  # noqa: F401  (initialises PETSc here: its handlers are installed now)

signal.signal(signal.SIGPIPE, signal.SIG_IGN)  # Python's own setting, which PETSc replaced

# Two meshes built alike are partitioned alike (tests compare two problems row by row): sid's
# threaded PT-Scotch gives a different partition at every call (compat.repeatable_partitions);
# the tests' child jobs (mpirun) inherit the variable.
os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", "1")

# The `tests` and `demos` packages live at the repository root. It is appended to sys.path, not
# prepended: `subfric_dolfinx` must come from wherever the environment provides it (the package
# installed with pip in ./run's test legs, see .ci/pytest-installed), never silently from the tree.
_ROOT = str(pathlib.Path(__file__).resolve().parents[1])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)


_NUMPY_ONLY_DESELECTED = pytest.StashKey[int]()


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False, help="run tests marked slow")


def pytest_collection_modifyitems(config, items):
    size = MPI.COMM_WORLD.size
    if size > 1:
        numpy_only = [item for item in items if "numpy_only" in item.keywords]
        if numpy_only:
            config.hook.pytest_deselected(items=numpy_only)
            config.stash[_NUMPY_ONLY_DESELECTED] = len(numpy_only)
            items[:] = [item for item in items if "numpy_only" not in item.keywords]
    skip_serial = pytest.mark.skip(reason=f"serial-only test, running on {size} ranks")
    skip_slow = pytest.mark.skip(reason="slow test: give --run-slow to run it")
    for item in items:
        if size > 1 and "serial" in item.keywords:
            item.add_marker(skip_serial)
        if "slow" in item.keywords and not config.getoption("--run-slow"):
            item.add_marker(skip_slow)


def pytest_sessionfinish(session, exitstatus):
    """A selection made only of numpy-only tests (``./run test tests/test_return_map.py``) runs
    nothing on 2 ranks: that is expected, not pytest's "no tests collected" failure."""
    if exitstatus == pytest.ExitCode.NO_TESTS_COLLECTED and session.config.stash.get(
        _NUMPY_ONLY_DESELECTED, 0
    ):
        session.exitstatus = pytest.ExitCode.OK


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
