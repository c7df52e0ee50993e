"""Output on request: CSV history (with an equilibrium check), VTX and XDMF fields, read back.

The VTX files (ADIOS2 BP4) are read back with ADIOS2's Python bindings (Debian's
``python3-adios2``, MPI build) and compared with what the run computed: the list of times, the
displacement at every dof and the interface fields at every step, block by block (one block per
writing rank, in the writer's local order).
"""

import contextlib
import csv
import errno
import fcntl
import gc
import importlib
import json
import os
import shutil
import subprocess
import sys
from xml.etree import ElementTree

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepFailure
from subfric_dolfinx.io import (
    FieldWriter,
    HistoryCSV,
    OutputDirectory,
    OutputError,
    fields,
    interface_summary,
)
from subfric_dolfinx.io.outdir import MANIFEST
from subfric_dolfinx.io.units import FRAME, interface_units
from subfric_dolfinx.logs import OutputWarning, PenetrationWarning, SlideWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import (
    ROOT,
    SEC7_PENALTY,
    block_problem,
    fill,
    hang_fails,
    mpirun,
    on_root,
    prefix,
    raised_on_every_rank,
    singleton_env,
    small_scene,
    tmpfs,
    warns_on_every_rank,
)

# the module (the package exports its function `collective` under the same name)
collective_module = importlib.import_module("subfric_dolfinx.io.collective")

# a rank waiting in an MPI call for one that failed: the test fails after 10 minutes, with the
# stacks, instead of blocking the suite; the tests running jobs of their own (mpirun, each
# killed after its own timeout) get a longer one of pytest's default kind
pytestmark = hang_fails()
SUBPROCESSES = pytest.mark.timeout(900)


def adios2_module():
    """ADIOS2's Python bindings, the MPI build: the same ADIOS2 library as DOLFINx's (Debian's
    wrapper loads its serial build unless it sees mpirun or ``ADIOS2_ALWAYS_USE_MPI``)."""
    os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")
    import adios2

    return adios2


def read_vtx(path, names):
    """{name: [per step: [per block: array]]} and the list of times of a VTX file (one rank)."""
    adios2 = adios2_module()

    def block(f, name, s, b, info):
        shape = tuple(int(n) for n in info["Count"].split(","))
        if 0 in shape:  # an empty block (a rank without cells): the reader cannot read it
            return np.zeros(shape)
        return np.asarray(f.read(name, block_id=b, step_selection=[s, 1])).reshape(shape)

    with adios2.FileReader(str(path)) as f:
        n_steps = f.num_steps()
        times = [float(np.ravel(f.read("step", step_selection=[s, 1]))[0]) for s in range(n_steps)]
        data = {}
        for name in names:
            blocks = f.all_blocks_info(name)
            assert len(blocks) == n_steps, (name, len(blocks), n_steps)
            data[name] = [
                [block(f, name, s, b, info) for b, info in enumerate(blocks[s])]
                for s in range(n_steps)
            ]
    return data, times


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
@pytest.mark.parametrize("fmt", ["vtx", "xdmf"])
def test_history_and_fields(shared_tmp, fmt):
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    solver = FrictionSolver(prob, prefix("out"), {"snes_rtol": 1e-12})
    hist = HistoryCSV(shared_tmp / "history.csv", prob)
    fields = FieldWriter(shared_tmp / "fields", prob, fmt)
    written = []  # this rank's values at every written step

    def on_step(rec):
        row = hist.write(rec)
        fields.write(rec.t)
        f_n, mu = (fields.fields[k].x.array.copy() for k in ("f_n", "mu"))
        written.append((rec.t, prob.u.x.array.copy(), f_n, mu))
        # equilibrium in x: the block is held at its top and pushed by the interface only,
        # the base is held at its bottom: both reactions balance the interface resultant
        F_t = row["F_t1"]
        assert row["R_top_x"] == pytest.approx(F_t, rel=1e-7, abs=1e-9 * abs(row["F_n"]))
        assert row["R_bottom_x"] == pytest.approx(-F_t, rel=1e-7, abs=1e-9 * abs(row["F_n"]))

    LoadStepper(solver, 0.25, on_step=on_step).run(t_end=2.0)
    hist.close()
    fields.close()
    comm.Barrier()
    s = interface_summary(prob)
    assert s["area"] == pytest.approx(1.0) and s["plastic"] > 0 and s["separated"] == 0
    by_rank = comm.gather(written, root=0)

    def check_files():
        rows = list(csv.DictReader(open(shared_tmp / "history.csv")))
        assert len(rows) == len(hist.rows) == 8
        assert [float(r["t"]) for r in rows] == pytest.approx(np.arange(1, 9) * 0.25)
        assert float(rows[-1]["up_norm"]) > 0.05 and float(rows[-1]["mu"]) < 500
        # every column has its unit and meaning in the CSV-on-the-Web sidecar
        meta = json.loads((shared_tmp / "history.csv-metadata.json").read_text())
        cols = meta["tableSchema"]["columns"]
        assert [c["name"] for c in cols] == list(rows[0])
        units = {c["name"]: c["schema:unitText"] for c in cols}
        assert "?" not in units.values(), units
        assert units["t"] == "s" and units["F_t1"] == "N/mm" and units["f_n"] == "MPa"
        assert units["area"] == "mm" and units["up_t1"] == "mm" and units["mu"] == "MPa"
        assert units["R_top_x"] == "N/mm" and units["plastic"] == "1"
        plastic = meta["status_legend"][str(int(Status.PLASTIC))]
        assert meta["url"] == "history.csv" and Status.PLASTIC.name in plastic
        assert not {"f", "f_t", "f_t1"} & set(units)  # no law variable repeats the traction
        if fmt == "vtx":
            check_vtx(shared_tmp / "fields", by_rank, prob.gdim)
            check_vtx_units(shared_tmp / "fields", interface_units(prob.law, prob.gdim))
        else:
            with h5py.File(shared_tmp / "fields" / "interface.h5") as f:
                want = {"f_t1", "f_n", "traction_global", "up_t1", "up_global", "mu", "r"}
                assert want <= set(f["Function"]), set(f["Function"])
                assert not {"f_t", "up", "f", "f_n_global"} & set(f["Function"])
                assert len(f["Function/mu"]) == 8
                # the units, in the HDF5 file and the XDMF file (each Attribute's Information)
                assert f["Function/mu"].attrs["unit"] == "MPa"
                assert f["Function/up_t1"].attrs["unit"] == "mm"
            with h5py.File(shared_tmp / "fields" / "displacement.h5") as f:
                assert f["Function/displacement"].attrs["unit"] == "mm"
            want = interface_units(prob.law, prob.gdim)
            xdmf = ElementTree.parse(shared_tmp / "fields" / "interface.xdmf").getroot()
            attributes = xdmf.findall(".//Attribute")
            assert len(attributes) == 8 * len(fields.fields), len(attributes)
            for a in attributes:
                (info,) = a.findall("Information")
                assert info.get("Name") == "unit" and info.get("Value") == want[a.get("Name")]
            domain = {i.get("Name"): i.get("Value") for i in xdmf.findall("Domain/Information")}
            assert domain["frame"] == FRAME and Status.PLASTIC.name in domain["status_legend"]
        side = json.loads((shared_tmp / "fields" / "units.json").read_text())
        assert side["units"]["traction_global"] == "MPa" and side["units"]["displacement"] == "mm"

    on_root(comm, check_files)
    solver.destroy()


def check_vtx_units(directory, units):
    """Every function of the VTX files has its unit as the ADIOS2 attribute ``<name>/unit``,
    the files their frame and status legend; the steps are the 8 written."""
    adios2 = adios2_module()
    for name, names in (("displacement.bp", {"displacement"}), ("interface.bp", set(units))):
        with adios2.FileReader(str(directory / name)) as f:
            assert f.num_steps() == 8
            functions = names & set(f.available_variables())
            assert functions >= ({"displacement"} if name[0] == "d" else {"f_n", "mu", "up_t1"})
            want = {"displacement": "mm"} | units
            for v in functions:
                assert f.inquire_attribute(f"{v}/unit").data_string() == want[v], v
            assert f.inquire_attribute("frame").data_string() == FRAME
            legend = json.loads(f.inquire_attribute("status_legend").data_string())
            assert Status.PLASTIC.name in legend[str(int(Status.PLASTIC))]
            assert "vtk.xml" in f.available_attributes()


def check_vtx(directory, by_rank, gdim):
    """The VTX files hold, at every step, the times and the values each rank computed."""
    times = [t for t, *_ in by_rank[0]]
    assert times == list(np.arange(1, 9) * 0.25)
    u_file, u_times = read_vtx(directory / "displacement.bp", ["displacement"])
    i_file, i_times = read_vtx(directory / "interface.bp", ["f_n", "mu"])
    assert u_times == i_times == times
    n_ranks = len(by_rank)
    for s in range(len(times)):
        # one block per writing rank
        assert len(u_file["displacement"][s]) == len(i_file["f_n"][s]) == n_ranks
        for rank in range(n_ranks):
            _, u, f_n, mu = by_rank[rank][s]
            # VTX pads vectors to 3 components
            u3 = np.zeros((u.size // gdim, 3))
            u3[:, :gdim] = u.reshape(-1, gdim)
            np.testing.assert_array_equal(u_file["displacement"][s][rank], u3)
            np.testing.assert_array_equal(i_file["f_n"][s][rank].ravel(), f_n)
            np.testing.assert_array_equal(i_file["mu"][s][rank].ravel(), mu)
    # the values are the run's: the block slid (mu softened somewhere) and was pressed at 300 MPa
    last_mu = np.concatenate([i_file["mu"][-1][r].ravel() for r in range(n_ranks)])
    last_fn = np.concatenate([i_file["f_n"][-1][r].ravel() for r in range(n_ranks)])
    assert last_mu.size == last_fn.size == 8 and last_mu.min() < 500.0
    assert np.mean(last_fn) == pytest.approx(300.0, rel=0.05)


# --------------------------------------------------------------------------------------------
# Faults: every output failure is one clear error on every rank (no hang: every test runs under
# the suite's timeout, and the process tests under their own). Where a fault is produced for
# real, a small tmpfs is mounted (root in the private mount namespace of ./run; where mounting is
# not allowed, e.g. in a container, those tests skip, saying so); an OSError injected
# (monkeypatch) checks the same errors everywhere, as each test says.


def short_scene(**outputs):
    """The small block pressed (1 s) then slid 0.35 mm (1 s): about 20 steps."""
    s = small_scene(short=True)
    s["outputs"] = dict(outputs)
    s["solver"]["prefix"] = prefix("fault")
    return s


def listing(directory):
    return sorted(p.name for p in directory.iterdir()) if directory.is_dir() else []


def test_an_output_directory_under_a_regular_file_fails_on_every_rank(shared_tmp):
    comm = MPI.COMM_WORLD
    on_root(comm, lambda: (shared_tmp / "file").write_text("not a directory"))
    for outputs in ({"history": True}, {"interface_history": True}, {"checkpoint_every": 1}):
        out = shared_tmp / "file" / "run"
        with raised_on_every_rank(OutputError, str(out), "Not a directory"):
            run_scene(short_scene(**outputs), outdir=out, comm=comm)


@pytest.mark.parametrize("fault", ["tmpfs", "injected"])
def test_a_read_only_output_directory_fails_on_every_rank(shared_tmp, fault):
    """A read-only file system, for real (a read-only tmpfs, where mounting is allowed) and
    injected (the probe's test write fails as on a read-only mount, everywhere)."""
    comm = MPI.COMM_WORLD
    ro = shared_tmp / "ro"
    with contextlib.ExitStack() as stack:
        mp = stack.enter_context(pytest.MonkeyPatch.context())
        if fault == "tmpfs":
            if not stack.enter_context(tmpfs(ro, "64k", readonly=True)):
                pytest.skip("mounting a tmpfs is not allowed here (the injected case covers it)")
        else:

            def read_only(*a, **k):
                raise OSError(errno.EROFS, os.strerror(errno.EROFS))

            mp.setattr(collective_module, "_test_write", read_only)
        for outputs in ({"history": True}, {"fields": "vtx"}, {"checkpoint_every": 1}):
            with raised_on_every_rank(OutputError, repr(str(ro / "x")), "Read-only file system"):
                run_scene(short_scene(**outputs), outdir=ro / "x", comm=comm)


def test_a_second_run_into_a_directory_in_use_is_refused(shared_tmp):
    """Another process holds the directory (an OutputDirectory in a subprocess); this run is
    refused on every rank, naming the directory and the process; once the other has finished,
    the directory is free again."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "busy"
    holder = None
    if comm.rank == 0:
        code = (
            "import sys\nfrom mpi4py import MPI\nfrom subfric_dolfinx.io import OutputDirectory\n"
            f"with OutputDirectory({str(out)!r}, MPI.COMM_SELF):\n"
            "    print('LOCKED', flush=True)\n    sys.stdin.read()\n"
        )
        holder = subprocess.Popen(
            [sys.executable, "-c", code],
            cwd=ROOT,
            env=singleton_env(),
            text=True,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        assert holder.stdout.readline().strip() == "LOCKED"
    comm.Barrier()
    try:
        pid = comm.bcast(holder.pid if holder else None, root=0)
        with raised_on_every_rank(OutputError, repr(str(out)), "in use", f"pid {pid}"):
            run_scene(short_scene(history=True), outdir=out, comm=comm)
    finally:
        if holder is not None:
            holder.communicate("", timeout=60)
    res = run_scene(short_scene(history=True), outdir=out, comm=comm)
    assert res.history[-1]["t"] == pytest.approx(2.0)


def lock_is_free(directory):
    """Whether the lock of ``directory`` can be taken now (rank 0 tries; every rank gets it)."""

    def attempt():
        if not (directory / ".subfric.lock").exists():  # removed by the run that held it
            return True
        fd = os.open(directory / ".subfric.lock", os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            return False
        finally:
            os.close(fd)

    return on_root(MPI.COMM_WORLD, attempt)


def test_the_lock_is_held_during_the_run_and_released_however_it_ends(shared_tmp, monkeypatch):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "lock"
    seen = []
    s = short_scene(history=True)  # pulled off: no step can be solved once the contact opens
    s["program"]["channels"]["press"] = [0, 1, -1]
    s["solver"]["max_cuts"] = 2

    def spy(self, record):
        seen.append(lock_is_free(out))
        return real(self, record)

    real = HistoryCSV.write
    monkeypatch.setattr(HistoryCSV, "write", spy)
    run_scene(short_scene(history=True), outdir=out, comm=comm)
    assert seen and not any(seen)  # held at every step
    assert lock_is_free(out)  # released at the end
    with raised_on_every_rank(StepFailure, "no convergence"):
        run_scene(s, outdir=out, comm=comm)
    assert lock_is_free(out)  # released after a failure


def test_a_stale_or_vanishing_lock_file_is_handled(shared_tmp, monkeypatch):
    """A lock file left by a killed run (unlocked) is taken; a lock file removed by the run that
    held it between this run's open and its lock (injected into flock) is not trusted: the run
    locks the file the name leads to. Either way the file is gone when the run ends."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "stale"

    def stale():
        out.mkdir()
        (out / ".subfric.lock").write_text("pid 1 on a machine long gone\n")

    on_root(comm, stale)
    s = short_scene(history=True)
    s["program"]["times"] = [0, 0.5, 1]
    run_scene(s, outdir=out, comm=comm)
    assert on_root(comm, lambda: listing(out)) == [
        MANIFEST,
        "history.csv",
        "history.csv-metadata.json",
    ]
    real = fcntl.flock
    removed = []

    def flock(fd, op):
        if not removed and op & fcntl.LOCK_EX:  # the earlier holder removes it just now
            os.unlink(out / ".subfric.lock")
            removed.append(True)
        return real(fd, op)

    monkeypatch.setattr(fcntl, "flock", flock)
    with OutputDirectory(out, comm, fresh=False):
        held = not lock_is_free(out)  # the file at the name is locked
    monkeypatch.undo()
    assert on_root(comm, lambda: bool(removed)) and held
    assert on_root(comm, lambda: listing(out)) == [
        MANIFEST,
        "history.csv",
        "history.csv-metadata.json",
    ]


@contextlib.contextmanager
def busy_cores(n=2):
    """``n`` processes spinning on rank 0 (the cores shared with the ranks: a machine under load,
    where a rank that returns early is most likely to run ahead)."""
    comm = MPI.COMM_WORLD
    procs = []
    if comm.rank == 0:
        spin = "import time\nt = time.monotonic() + 600\nwhile time.monotonic() < t: pass\n"
        env = singleton_env()
        procs = [subprocess.Popen([sys.executable, "-c", spin], env=env) for _ in range(n)]
    try:
        yield
    finally:
        for p in procs:
            p.kill()
            p.wait()


@pytest.mark.e2e
@pytest.mark.two_ranks  # a race between ranks: one rank has none
@pytest.mark.timeout(600)
def test_every_rank_returns_with_the_directory_in_its_final_state_under_load(shared_tmp):
    """The CI race of issue 23: rank 0 removed the lock file after the other rank had returned
    from run_scene and listed the directory. Every rank lists the directory right after each
    of 8 runs while a process spins beside the two ranks on the two cores (one rank at a time
    runs behind): the lock and the HDF5 spare are gone."""
    comm = MPI.COMM_WORLD
    s = short_scene(history=True, interface_history=True)
    s["program"] = {"times": [0, 0.2], "channels": {"press": [0, 0.2], "slide": [0, 0]}}
    with busy_cores(1):
        for i in range(8):
            out = shared_tmp / f"run{i}"
            run_scene(s, outdir=out, comm=comm)
            assert listing(out) == [
                MANIFEST,
                "history.csv",
                "history.csv-metadata.json",
                "interface_history.h5",
            ], (comm.rank, i)


def test_a_fresh_run_moves_the_earlier_runs_files_aside(shared_tmp):
    """A run with every output, then a fresh run with a history only: the directory holds the
    new run's files (and the user's), the earlier run's are in previous_run/, intact."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "again"
    first = run_scene(
        short_scene(history=True, interface_history=True, fields="xdmf", checkpoint_every=5),
        outdir=out,
        comm=comm,
    )
    on_root(comm, lambda: (out / "notes.txt").write_text("mine"))
    s = short_scene(history=True)
    s["program"]["times"] = [0, 1, 1.5]
    second = run_scene(s, outdir=out, comm=comm)

    def check():
        assert listing(out) == [  # no lock left
            MANIFEST,
            "history.csv",
            "history.csv-metadata.json",
            "notes.txt",
            "previous_run",
        ]
        prev = out / "previous_run"
        assert listing(prev) == [
            ".made-by-subfric-dolfinx",
            MANIFEST,
            "checkpoint.h5",
            "fields",
            "history.csv",
            "history.csv-metadata.json",
            "interface_history.h5",
        ]
        rows = list(csv.DictReader(open(out / "history.csv")))
        assert len(rows) == len(second.history) and float(rows[-1]["t"]) == 1.5
        old = list(csv.DictReader(open(prev / "history.csv")))
        assert len(old) == len(first.history) and float(old[-1]["t"]) == 2.0
        with h5py.File(prev / "interface_history.h5") as f:
            assert f["time"][-1] == 2.0

    on_root(comm, check)
    # a third fresh run replaces previous_run/ with the second run's files
    run_scene(short_scene(interface_history=True), outdir=out, comm=comm)

    def check_third():
        assert listing(out / "previous_run") == [
            ".made-by-subfric-dolfinx",
            MANIFEST,
            "history.csv",
            "history.csv-metadata.json",
        ]
        assert "history.csv" not in listing(out)

    on_root(comm, check_third)


def test_a_failed_history_write_is_one_error_on_every_rank(shared_tmp, monkeypatch):
    """Injected: the 5th row's write on rank 0 raises ENOSPC (as /dev/full would)."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "h"
    real = HistoryCSV._append
    count = [0]

    def full(self, row):
        count[0] += 1
        if count[0] == 5:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, row)

    monkeypatch.setattr(HistoryCSV, "_append", full)
    path = repr(str(out / "history.csv"))
    with raised_on_every_rank(OutputError, f"writing {path} failed: [Errno 28] No space left"):
        run_scene(short_scene(history=True), outdir=out, comm=comm)
    assert lock_is_free(out)


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_a_failed_hdf5_write_on_one_rank_is_one_error_on_every_rank(shared_tmp, monkeypatch):
    """Injected: the last rank's slab write of the 4th step raises ENOSPC, the other ranks'
    succeed. Every rank raises the same error naming the file; the file is closed (h5py's
    finaliser would warn otherwise). (The checkpoint's case: test_checkpoint.py.)"""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "h5"
    real = h5py.Dataset.__setitem__
    count = [0]

    def flaky(self, key, value):
        if self.name == "/f_t":
            count[0] += 1
            if count[0] == 4 and comm.rank == comm.size - 1:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", flaky)
    path = repr(str(out / "interface_history.h5"))
    with raised_on_every_rank(OutputError, f"writing {path} failed: [Errno 28] No space left"):
        run_scene(short_scene(interface_history=True), outdir=out, comm=comm)
    monkeypatch.undo()
    gc.collect()

    def three_steps_kept():
        with h5py.File(out / "interface_history.h5") as f:
            assert f["time"].shape == (3,)

    on_root(comm, three_steps_kept)


@pytest.mark.parametrize("fmt", ["vtx", "xdmf"])
def test_fields_refuse_to_fill_the_disk(shared_tmp, monkeypatch, fmt):
    """Injected: the file system reports 100 kB free (shutil.disk_usage on rank 0), less than
    the space a step of fields asks for: the run ends before the write, on every rank, and the
    field files are closed (an ADIOS2 or DOLFINx HDF5 write cannot recover from a full disk):
    read back, they hold the two steps written before, complete."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / fmt
    real = shutil.disk_usage
    calls = [0]

    def small(path):  # plenty for the creation and two steps, then 100 kB
        calls[0] += 1
        u = real(path)
        free = u.free if calls[0] <= 3 else 100_000
        return type(u)(u.total, u.total - free, free)

    monkeypatch.setattr(shutil, "disk_usage", small)
    # the VTX files closed on the error are left without their units (no room for the copy)
    left = warns_on_every_rank(OutputWarning) if fmt == "vtx" else contextlib.nullcontext()
    with (
        left,
        raised_on_every_rank(
            OutputError, repr(str(out / "fields")), "at t = ", "No space left on device"
        ),
    ):
        run_scene(short_scene(fields=fmt), outdir=out, comm=comm)
    monkeypatch.undo()

    def two_steps_readable():
        d = out / "fields"
        if fmt == "vtx":
            data, times = read_vtx(d / "interface.bp", ["f_n"])
            assert len(times) == len(data["f_n"]) == 2 and times[0] < times[1]
        else:
            with h5py.File(d / "interface.h5") as f:
                assert len(f["Function/f_n"]) == 2
            xdmf = ElementTree.parse(d / "interface.xdmf")  # complete XML
            assert len(xdmf.findall(".//Attribute[@Name='f_n']")) == 2

    on_root(comm, two_steps_readable)


# the fine meshes that make 100 kB a step slide the block over 4-7 interface elements
@pytest.mark.leaves_validity(SlideWarning, reason="a short slide on a fine interface mesh")
@pytest.mark.parametrize(("stress", "n"), [(False, 20), (True, 12)], ids=["fields", "with-stress"])
def test_fields_of_100_kB_a_step_are_written_with_1_MB_free(shared_tmp, monkeypatch, stress, n):
    """Issue 23, item 7: a fixed 1 MiB reserve refused field output with 1 MB free while a step
    wrote 100 kB. The space asked for is four times a step plus 64 KiB: with 1 MiB free
    (injected) a run whose steps write 100 kB and more (the bodies' stress too, written under
    the same check) completes; the space asked for grows with the step it measured."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "room"
    real = shutil.disk_usage
    writers, steps = [], []

    def one_mib(path):
        u = real(path)
        return type(u)(u.total, u.total - (1 << 20), 1 << 20)

    real_write = FieldWriter.write

    def write(self, t, also=()):
        before = fields._dir_bytes(self.dir)
        real_write(self, t, also)
        steps.append(fields._dir_bytes(self.dir) - before)
        writers.append(self)

    monkeypatch.setattr(shutil, "disk_usage", one_mib)
    monkeypatch.setattr(FieldWriter, "write", write)
    s = short_scene(fields="vtx", stress=stress)
    s["mesh"]["options"]["n_interface"] = n
    with warns_on_every_rank(OutputWarning):  # 1 MiB free: no room to copy them with units
        res = run_scene(s, outdir=out, comm=comm)
    assert res.history[-1]["t"] == pytest.approx(2.0)
    largest = comm.allreduce(max(steps), op=MPI.MAX)  # the files are shared: any rank sees them
    print(f"largest step {largest} bytes")
    assert largest >= 100_000, largest
    need = comm.bcast(writers[-1].space_needed(), root=0)  # rank 0 measures and checks
    assert 4 * largest + fields.MARGIN <= need < 1 << 20


# Disk full for real: a 1 MiB tmpfs filled but a few kB, a run on 2 ranks (the fullest on 1 rank
# too) in a process of its own (mpirun, killed after 150 s: a hang fails). Several sizes, so that
# the disk fills up in different places (the probe, the lock, a CSV row, an HDF5 slab, a flush, a
# checkpoint).

CRASH_SIGNS = (
    "Segmentation",
    "Aborted",
    "Exception ignored",
    "MPI_ABORT",
    "core dumped",
    "signal 6",
    "signal 11",
    "killed after",
    "Timeout (",
)

RUN = """
import faulthandler
faulthandler.dump_traceback_later(100, exit=True)  # where a hang is, then exit
from subfric_dolfinx.scenes import run_scene
from tests.io.test_output import short_scene
run_scene(short_scene(**{outputs!r}), outdir={out!r})
print("FINISHED", flush=True)
"""


def outcome(r, n):
    """``None`` for a run that finished, else its one error message (checked: exit 1, the same
    message from each of the ``n`` ranks, no crash)."""
    text = r.stdout + r.stderr
    for sign in CRASH_SIGNS:
        assert sign not in text, f"{sign!r} in the output:\n{text[-3000:]}"
    if r.returncode == 0:
        assert "FINISHED" in r.stdout
        return None
    assert r.returncode == 1, text[-3000:]
    # every rank raises the error; mpirun may kill a rank before it prints it
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("subfric_dolfinx.")]
    assert 1 <= len(errors) <= n and len(set(errors)) == 1, text[-3000:]
    return errors[0]


def disk_full_runs(directory, outputs, leaves, check=None, size="1m"):
    """Run ``outputs`` into a full tmpfs at ``directory`` with each of ``leaves`` bytes left,
    on 2 ranks, and with the first (the least space) on 1 rank too; return the error messages
    (``None`` for runs that finished)."""
    messages = []
    with tmpfs(directory, size) as mounted:
        if not mounted:
            pytest.skip("mounting a tmpfs is not allowed here (the injected faults cover it)")
        for i, leave in enumerate(leaves):
            for n in (1, 2) if i == 0 else (2,):
                for p in list(directory.iterdir()):
                    shutil.rmtree(p) if p.is_dir() else p.unlink()
                fill(directory, leave)
                r = mpirun(RUN.format(outputs=outputs, out=str(directory / "out")), n)
                msg = outcome(r, n)
                if msg is not None:
                    assert "No space left on device" in msg, msg
                if check is not None:
                    check(directory / "out", msg)
                messages.append(msg)
    return messages


@pytest.mark.e2e
@pytest.mark.serial
@SUBPROCESSES
def test_disk_full_with_history_and_interface_history(shared_tmp):
    """Full at the start (the probe), at the HDF5 file's creation (its spare, its first
    reservation), during the run (a CSV row, the HDF5 reservation of a step), or not at all."""
    messages = disk_full_runs(
        shared_tmp / "full",
        {"history": True, "interface_history": True},
        [2048, 4096, 81920, 204800, 307200],
    )
    print(*messages, sep="\n")
    failed = [m for m in messages if m]
    assert any("preparing the output directory" in m for m in failed), failed
    assert any("interface_history.h5" in m for m in failed), failed
    assert None in messages  # the largest size is enough for the run


@pytest.mark.e2e
@pytest.mark.serial
@SUBPROCESSES
@pytest.mark.parametrize("fmt", ["vtx", "xdmf"])
def test_disk_full_with_fields(shared_tmp, fmt):
    """The check before each write refuses it: exit 1, the error, no SIGABRT from ADIOS2."""
    messages = disk_full_runs(
        shared_tmp / "full", {"fields": fmt}, [100_000, 150_000, 400_000], size="4m"
    )
    assert any(m and "writing the" in m and "fields" in m for m in messages), messages


ONE_RANK_METADATA_FAULT = """
import errno, h5py
from mpi4py import MPI
from subfric_dolfinx.scenes import run_scene
from tests.io.test_output import short_scene
real = h5py.Group.create_dataset
def flaky(self, *a, **k):
    if MPI.COMM_WORLD.rank == 1:
        raise OSError(errno.EIO, "injected on rank 1")
    return real(self, *a, **k)
h5py.Group.create_dataset = flaky
run_scene(short_scene(interface_history=True), outdir={out!r})
"""


@pytest.mark.e2e
@pytest.mark.serial
@SUBPROCESSES
def test_a_metadata_call_failing_on_one_rank_ends_the_job_with_the_error(shared_tmp):
    """Injected: creating a dataset (an HDF5 metadata call, collective) fails on rank 1 only.
    The ranks' metadata differ: no close can work (it hangs, even at exit). Instead of a hang,
    every rank prints the error and the job ends (MPI_Abort, exit 1), within the timeout."""
    r = mpirun(ONE_RANK_METADATA_FAULT.format(out=str(shared_tmp / "out")), 2, timeout=120)
    text = r.stdout + r.stderr
    assert r.returncode == 1 and "killed after" not in text, text[-3000:]
    assert "interface_history.h5' failed: [Errno 5] injected on rank 1" in text, text[-3000:]
    assert "no rank can close it" in text


@pytest.mark.e2e
@pytest.mark.serial
@SUBPROCESSES
def test_a_demo_ends_an_output_error_with_one_line_and_exit_1(shared_tmp):
    """The main demo on 2 ranks (mpirun, with a timeout): its output directory under a regular
    file, then a directory another run holds. Exit 1 (a failed output, not bad input), one
    ``error:`` line naming the directory and the reason, no traceback."""
    from tests.scenes.test_cli import demo_cmd, run

    (shared_tmp / "file").write_text("not a directory")
    rc, text = run(demo_cmd("--out", shared_tmp / "file" / "run", ranks=2), timeout=150)
    errors = [ln for ln in text.splitlines() if "error: " in ln]
    assert rc == 1 and "Traceback" not in text and len(errors) == 1, text
    assert "preparing the output directory" in errors[0] and "Not a directory" in errors[0]
    busy = shared_tmp / "busy"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys\nfrom mpi4py import MPI\n"
            "from subfric_dolfinx.io import OutputDirectory\n"
            f"with OutputDirectory({str(busy)!r}, MPI.COMM_SELF):\n"
            "    print('LOCKED', flush=True)\n    sys.stdin.read()\n",
        ],
        cwd=ROOT,
        env=singleton_env(),
        text=True,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
    )
    try:
        assert holder.stdout.readline().strip() == "LOCKED"
        rc, text = run(demo_cmd("--out", busy, ranks=2), timeout=150)
    finally:
        holder.communicate("", timeout=60)
    errors = [ln for ln in text.splitlines() if "error: " in ln]
    assert rc == 1 and "Traceback" not in text and len(errors) == 1, text
    assert f"the output directory {str(busy)!r} is in use" in errors[0], errors
