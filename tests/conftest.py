"""Test configuration: MPI hygiene as in DOLFINx's own test suite.

* Collective teardown: garbage-collect and barrier after every test, so that PETSc/DOLFINx objects
  are destroyed collectively and a rank never runs ahead into the next test.
* ``@pytest.mark.serial``: tests that only make sense on one rank are skipped, with that reason,
  when run on more (the suite is run on 1 and on 2 ranks, so they still run).
* ``pytestmark = pytest.mark.numpy_only``: a module that touches neither MPI nor DOLFINx (return
  map, driver, fuzzing, ...) gives the same answer on every rank; on more than one rank its tests
  are deselected (pytest reports them as "deselected"), since the 1-rank run has already run them.
* ``pytestmark = pytest.mark.three_ranks`` (or the mark on a test): an FE module (test) of the
  3-rank leg of ``./run test``
  (``./run test3``: parallel code paths on an odd partition, oversubscribed on these 2-core
  machines, correctness only). The suite is written for 1 and 2 ranks: on more, the tests of the
  other modules are deselected (reported as such).
* ``@pytest.mark.two_ranks``: what only 2 ranks show (records made on 2 ranks, in
  ``test_records.py``; a race between ranks): run in the 2-rank leg only, deselected (reported as
  such) on 1 and 3 ranks.
* ``@pytest.mark.records``: a re-run of a record (``test_records.py``): the records are made on
  the default stack (``report.stamp.RECORD_DOLFINX``) and re-checked there; on the other stack
  these are deselected (reported as such).
* ``@pytest.mark.e2e``: an end-to-end check (a program in a subprocess, an ``mpirun`` job, a pip
  install; every test in ``tests/demos`` and ``tests/verification``: whole demos, the docs, the
  records, results against their references). ``./run test-fast`` leaves them out: the unit
  level of the package, for development; ``./run test`` runs everything.
* The package's warnings are errors (``filterwarnings`` in ``pyproject.toml``): a test whose scene
  leaves the model's validity on purpose says so, with ``@pytest.mark.leaves_validity(
  PenetrationWarning, reason=...)`` or :func:`tests.helpers.leaves_validity` around the run, and
  the warning must then come (on every rank).
* ``shared_tmp``: a temporary directory common to all ranks (``tmp_path`` differs per rank).
* Repeatable partitions: ``SCOTCH_PTHREAD_NUMBER=1`` unless set (see below).
* A broken pipe is an exception again: PETSc's initialisation installs its signal handler for
  SIGPIPE (and SIGHUP), which ends the process with PETSc's error code 59 and no message; Python
  ignores SIGPIPE so that writing to a pipe whose reader has gone raises ``BrokenPipeError``. A test
  that writes to a child job which has ended (``test_stop_signals``) took the whole suite down
  with exit code 59 instead of failing with the job's output (sid, 1 rank, under load).
"""

import faulthandler
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


_DESELECTED = pytest.StashKey[int]()

TESTS = pathlib.Path(__file__).resolve().parent
E2E_FOLDERS = (TESTS / "demos", TESTS / "verification")
"""Every test in these folders is ``e2e``: demos run whole, the docs and the records, results
against their references (see ``pytest_collection_modifyitems``)."""


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False, help="run tests marked slow")


@pytest.hookimpl(tryfirst=True)  # the marks it adds are there for -m
def pytest_collection_modifyitems(config, items):
    size = MPI.COMM_WORLD.size
    from report.stamp import on_record_stack

    other_stack = any("records" in item.keywords for item in items) and not on_record_stack()

    def off(item) -> bool:
        return (
            (other_stack and "records" in item.keywords)
            or (size > 1 and "numpy_only" in item.keywords)
            or (size > 2 and "three_ranks" not in item.keywords)
            or (size != 2 and "two_ranks" in item.keywords)
        )

    dropped = [item for item in items if off(item)]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        config.stash[_DESELECTED] = len(dropped)
        items[:] = [item for item in items if not off(item)]
    for item in items:
        path = pathlib.Path(str(item.path))
        if any(path.is_relative_to(folder) for folder in E2E_FOLDERS):
            item.add_marker(pytest.mark.e2e)
    skip_serial = pytest.mark.skip(reason=f"serial-only test, running on {size} ranks")
    skip_slow = pytest.mark.skip(reason="slow test: give --run-slow to run it")
    for item in items:
        if size > 1 and "serial" in item.keywords:
            item.add_marker(skip_serial)
        if "slow" in item.keywords and not config.getoption("--run-slow"):
            item.add_marker(skip_slow)


def pytest_collection_finish(session):
    """Everything alive once the tests are collected (the imported stack: DOLFINx, UFL, numpy,
    the package, the test modules, the items) stays alive for the whole session: it is moved out
    of the collector's sight (:func:`gc.freeze`), so that the full collection after every test
    traverses only what the tests made (it traversed the whole imported stack every time, a
    large share of the suite's time). Nothing is frozen that a test could make garbage: the
    tests' problems, PETSc objects included, are made after this and collected as before."""
    gc.collect()
    gc.freeze()


def pytest_sessionfinish(session, exitstatus):
    """A selection made only of numpy-only tests (``./run test
    tests/constitutive/test_return_map.py``) runs nothing on 2 ranks, one without a 3-rank module
    nothing on 3: that is expected, not pytest's "no tests collected" failure."""
    if exitstatus == pytest.ExitCode.NO_TESTS_COLLECTED and session.config.stash.get(
        _DESELECTED, 0
    ):
        session.exitstatus = pytest.ExitCode.OK


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    """``@pytest.mark.leaves_validity(Category, ..., reason=...)``: the test's scene leaves the
    model's validity on purpose; the warnings named must come (on every rank), as with
    :func:`tests.helpers.leaves_validity` around the whole test."""
    mark = item.get_closest_marker("leaves_validity")
    if mark is None:
        return (yield)
    if not mark.args or not mark.kwargs.get("reason"):
        raise pytest.UsageError(
            f"{item.nodeid}: leaves_validity needs the warning categories and a reason="
        )
    from tests.helpers import leaves_validity

    with leaves_validity(*mark.args):
        return (yield)


HANG_EXIT_MARGIN = float(os.environ.get("SUBFRIC_TEST_HANG_MARGIN", "60"))
"""Seconds after a test's pytest-timeout at which faulthandler's watchdog ends its process
(``SUBFRIC_TEST_HANG_MARGIN``: the test of the watchdog itself sets it short)."""


def _original_stderr(config) -> object:
    """The file descriptor of the stderr pytest found (its own faulthandler plugin keeps it):
    fd 2 is the capture's file during a test."""
    from _pytest import faulthandler as plugin

    key = getattr(plugin, "fault_handler_stderr_fd_key", None)
    fd = config.stash.get(key, None) if key is not None else None
    return fd if isinstance(fd, int) else sys.stderr


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """A hang ends the job even where pytest-timeout cannot fire. Its thread needs the GIL,
    which a rank waiting in a reduction inside PETSc holds (a vector norm that one rank answered
    from its cache while the other waited kept a 2-rank leg busy until CI's limit): faulthandler's
    watchdog is a C thread; past the test's timeout and a margin it dumps every thread's stack and
    ends the process, and mpirun ends the other ranks."""
    mark = item.get_closest_marker("timeout")
    limit = float(mark.args[0]) if mark and mark.args else float(item.config.getini("timeout"))
    if limit > 0:
        where = _original_stderr(item.config)
        faulthandler.dump_traceback_later(limit + HANG_EXIT_MARGIN, exit=True, file=where)
    try:
        return (yield)
    finally:
        faulthandler.cancel_dump_traceback_later()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item):
    """Collective teardown: every rank collects garbage, then all meet at a barrier.

    After the test's fixtures are torn down, the ranks must have called
    :func:`tests.helpers.prefix` equally often, or the test fails (at its teardown, on every
    rank): a solver's prefix must be the same on every rank, and a test that called it on some
    ranks only gave every later test different prefixes on different ranks (a scene's error
    naming its prefix differed between the ranks). Every rank is put on the same count again,
    so that the next test does not depend on this one."""
    from tests.helpers import _PrefixCounter

    gc.collect()
    MPI.COMM_WORLD.Barrier()
    try:
        return (yield)
    finally:
        counts = MPI.COMM_WORLD.allgather(_PrefixCounter.given)
        _PrefixCounter.given = max(counts)
        if len(set(counts)) > 1:
            raise AssertionError(
                f"{item.nodeid} called tests.helpers.prefix() on some ranks only: the ranks' "
                f"counts are {counts} (a solver's prefix must be the same on every rank)"
            )


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
