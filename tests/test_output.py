"""Output on request: CSV history (with an equilibrium check), VTX and XDMF fields, read back.

The VTX files (ADIOS2 BP4) are read back with ADIOS2's Python bindings (Debian's
``python3-adios2``, MPI build) and compared with what the run computed: the list of times, the
displacement at every dof and the interface fields at every step, block by block (one block per
writing rank, in the writer's local order).
"""

import csv
import os

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.fem import FrictionSolver, LoadStepper
from subfric_dolfinx.io import FieldWriter, HistoryCSV, interface_summary
from tests.helpers import block_problem, on_root, prefix


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
        if fmt == "vtx":
            check_vtx(shared_tmp / "fields", by_rank, prob.gdim)
        else:
            with h5py.File(shared_tmp / "fields" / "interface.h5") as f:
                assert {"f_t", "f_n", "up", "mu", "r"} <= set(f["Function"])
                assert len(f["Function/mu"]) == 8
            assert (shared_tmp / "fields" / "displacement.h5").exists()

    on_root(comm, check_files)
    solver.destroy()


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
