"""Units inside VTX files as ADIOS2 attributes (:func:`subfric_dolfinx.io.vtx.annotate_vtx`).

A VTX file DOLFINx wrote (a degree-2 displacement on a mesh, DG0 interface fields on a submesh
that one rank of two has no cell of: empty blocks) is given its units after it was closed. Read
back with ADIOS2 (random access, as the tests and scripts read, and step by step, as ParaView's
VTX reader opens a file), against a copy of the file taken before: the number of steps is the
number written, every variable's blocks have their dimensions and values at every step, bit for
bit, DOLFINx's ``vtk.xml`` is unchanged, and the attributes ``<name>/unit``, ``frame`` are
there. A fault on one rank in the middle of the copy, a file system without room for the copy,
and missing ADIOS2 bindings leave the file as it was.
"""

import shutil
import warnings

import dolfinx
import dolfinx.fem
import dolfinx.io
import dolfinx.mesh
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.io import OutputError
from subfric_dolfinx.io import vtx as vtx_module
from subfric_dolfinx.io.vtx import adios2_module, annotate_vtx
from subfric_dolfinx.logs import OutputWarning
from tests.helpers import hang_fails, on_root, raised_on_every_rank

pytestmark = hang_fails()

STEPS = 3
UNITS = {"displacement": "mm", "f_n": "MPa", "traction_global": "MPa", "sigma": "MPa"}
FRAME = {"frame": "local components (t1, n)"}


def write_files(directory):
    """Two VTX files of 3 steps (BP4, as the package writes them); their paths."""
    comm = MPI.COMM_WORLD
    mesh = dolfinx.mesh.create_unit_square(comm, 4, 3)
    u = dolfinx.fem.Function(
        dolfinx.fem.functionspace(mesh, ("Lagrange", 2, (2,))), name="displacement"
    )
    n_local = mesh.topology.index_map(2).size_local
    cells = np.arange(n_local if comm.rank == 0 else 0, dtype=np.int32)  # rank 1: no cell
    sub = dolfinx.mesh.create_submesh(mesh, 2, cells)[0]
    f_n = dolfinx.fem.Function(dolfinx.fem.functionspace(sub, ("DG", 0)), name="f_n")
    tr = dolfinx.fem.Function(
        dolfinx.fem.functionspace(sub, ("DG", 0, (2,))), name="traction_global"
    )
    paths = directory / "displacement.bp", directory / "interface.bp"
    writers = [
        dolfinx.io.VTXWriter(comm, paths[0], [u], engine="BP4"),
        dolfinx.io.VTXWriter(comm, paths[1], [f_n, tr], engine="BP4"),
    ]
    for k in range(STEPS):
        for f in (u, f_n, tr):
            f.x.array[:] = np.arange(f.x.array.size) + 100.0 * k + 1000.0 * comm.rank
        for w in writers:
            w.write(0.25 * (k + 1))
    for w in writers:
        w.close()
    comm.Barrier()
    return paths


def keep_copies(paths):
    """Copies of the files as written (rank 0), for comparison."""
    comm = MPI.COMM_WORLD
    kept = [p.with_name("written_" + p.name) for p in paths]
    if comm.rank == 0:
        for p, k in zip(paths, kept, strict=True):
            shutil.copytree(p, k)
    comm.Barrier()
    return kept


def contents(path):
    """Steps, every variable's blocks (dimensions, values) at every step, and the attributes
    of a BP file read with random access (one rank)."""
    adios2 = adios2_module(MPI.COMM_SELF)
    with adios2.FileReader(str(path)) as f:
        steps = f.num_steps()
        variables = {}
        for name in sorted(f.available_variables()):
            per_step = []
            for s, blocks in enumerate(f.all_blocks_info(name)):
                got = []
                for b, info in enumerate(blocks):
                    count = info["Count"]
                    if info["IsValue"] == "True":  # a value ("Count" 0)
                        got.append(("value", np.ravel(f.read(name, step_selection=[s, 1]))))
                        continue
                    # an empty 1-d block has no dimensions: "Count" is ""
                    shape = tuple(int(c) for c in count.split(",")) if count else (0,)
                    a = np.zeros(shape)
                    if 0 not in shape:  # an empty block cannot be read
                        a = np.asarray(f.read(name, block_id=b, step_selection=[s, 1]))
                    got.append((count, a.reshape(shape)))
                per_step.append(got)
            variables[name] = per_step
        attributes = {}
        for name in f.available_attributes():
            a = f.inquire_attribute(name)
            # one string: a str; several: a list
            attributes[name] = a.data_string() if a.type() == "string" else list(a.data())
    return steps, variables, attributes


def streaming_steps(path):
    """As ParaView's VTX reader opens a file (``Mode.Read``): the attributes seen before the
    first step, and the steps counted by begin_step/end_step."""
    adios2 = adios2_module(MPI.COMM_SELF)
    ad = adios2.Adios()
    io = ad.declare_io("stream")
    e = io.open(str(path), adios2.bindings.Mode.Read)
    first = sorted(io.available_attributes())
    n = 0
    while e.begin_step() == adios2.bindings.StepStatus.OK:
        n += 1
        e.end_step()
    e.close()
    return first, n


def same_data(a, b):
    """Two contents() alike but for the attributes: steps, variables, blocks, values."""
    assert a[0] == b[0]
    assert sorted(a[1]) == sorted(b[1])
    for name in a[1]:
        assert len(a[1][name]) == len(b[1][name]), name
        for s, (x, y) in enumerate(zip(a[1][name], b[1][name], strict=True)):
            assert [k for k, _ in x] == [k for k, _ in y], (name, s)  # each block's "Count"
            for (_, u), (_, v) in zip(x, y, strict=True):
                np.testing.assert_array_equal(u, v, err_msg=f"{name} at step {s}")


def test_units_become_attributes_of_the_vtx_files(shared_tmp):
    comm = MPI.COMM_WORLD
    paths = write_files(shared_tmp)
    kept = keep_copies(paths)
    for p in paths:
        assert annotate_vtx(comm, p, UNITS, FRAME)

    def check():
        for p, k in zip(paths, kept, strict=True):
            new, old = contents(p), contents(k)
            assert new[0] == old[0] == STEPS  # the steps written, no more
            same_data(new, old)
            assert new[2]["vtk.xml"] == old[2]["vtk.xml"]  # DOLFINx's schema as it was
            units = {n[: -len("/unit")]: v for n, v in new[2].items() if n.endswith("/unit")}
            want = {n: u for n, u in UNITS.items() if n in new[1]}
            assert units == want and "sigma" not in units, units
            assert new[2]["frame"] == FRAME["frame"]
            assert set(new[2]) == set(old[2]) | {f"{n}/unit" for n in want} | {"frame"}
            # one block per rank at every step (an empty one on a rank without cells)
            assert [len(b) for b in new[1]["step"]] == [comm.size] * STEPS
            times = [float(v[0][1][0]) for v in new[1]["step"]]
            assert times == [0.25, 0.5, 0.75]
            # as ParaView opens it: vtk.xml before the first step (where DOLFINx's file has
            # it), as many steps as written
            (old_first, old_n), (new_first, new_n) = streaming_steps(k), streaming_steps(p)
            assert new_n == old_n == STEPS
            assert "vtk.xml" in new_first and set(old_first) <= set(new_first)
            assert not p.with_name(p.name + ".tmp").exists()
            assert not p.with_name(p.name + ".old").exists()
        # the empty blocks are there: rank 1 (of 2) has no cell of the submesh
        blocks = contents(paths[1])[1]["f_n"][0]
        assert [count[0] == "0" for count, _ in blocks] == [r > 0 for r in range(comm.size)]

    on_root(comm, check)
    # annotated again: a unit given anew replaces the file's, the others stay
    assert annotate_vtx(comm, paths[0], {"displacement": "m"})

    def again():
        new, old = contents(paths[0]), contents(kept[0])
        same_data(new, old)
        assert new[2]["displacement/unit"] == "m" and new[2]["frame"] == FRAME["frame"]
        assert new[2]["vtk.xml"] == old[2]["vtk.xml"]

    on_root(comm, again)


@pytest.mark.parametrize("where", ["read_step", "put_step"])
def test_a_fault_during_the_copy_leaves_the_file_as_written(shared_tmp, monkeypatch, where):
    """A failure on the last rank at the second step, reading it (every rank between two steps
    of the copy) or putting it (rank 0 of 2 within the step, the last not): the same error on
    every rank, no hang, the file as DOLFINx wrote it, no copy left."""
    comm = MPI.COMM_WORLD
    paths = write_files(shared_tmp)
    kept = keep_copies(paths)
    real = getattr(vtx_module._Copy, where)

    def flaky(self, step, *args):
        if step == 1 and comm.rank == comm.size - 1:
            raise OSError(5, "Input/output error (injected)")
        return real(self, step, *args)

    monkeypatch.setattr(vtx_module._Copy, where, flaky)
    with raised_on_every_rank(OutputError, "writing the units into", "injected"):
        annotate_vtx(comm, paths[1], UNITS, FRAME)
    monkeypatch.undo()

    def unchanged():
        same_data(contents(paths[1]), contents(kept[1]))
        assert contents(paths[1])[2] == contents(kept[1])[2]  # no attribute added
        assert not paths[1].with_name(paths[1].name + ".tmp").exists()

    on_root(comm, unchanged)


@pytest.mark.parametrize("missing", ["room", "bindings"])
def test_without_room_or_bindings_the_file_is_left_and_said_so(shared_tmp, monkeypatch, missing):
    comm = MPI.COMM_WORLD
    paths = write_files(shared_tmp)
    kept = keep_copies(paths)
    if missing == "room":
        real = shutil.disk_usage

        def small(path):  # 10 kB free: less than the file
            u = real(path)
            return type(u)(u.total, u.total - 10_000, 10_000)

        monkeypatch.setattr(shutil, "disk_usage", small)
        why = "bytes, 10000 are free"
    else:
        monkeypatch.setattr(vtx_module, "adios2_module", lambda comm: None)
        why = "Python bindings"
    with warnings.catch_warnings():  # raised on every rank alike (logs.warn)
        warnings.simplefilter("error", OutputWarning)
        with pytest.raises(OutputWarning, match=why):
            annotate_vtx(comm, paths[0], UNITS, FRAME)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutputWarning)
        assert annotate_vtx(comm, paths[0], UNITS, FRAME) is False
    monkeypatch.undo()

    def unchanged():
        assert contents(paths[0])[2] == contents(kept[0])[2]
        same_data(contents(paths[0]), contents(kept[0]))

    on_root(comm, unchanged)
