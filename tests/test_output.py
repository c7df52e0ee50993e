"""Output on request: CSV history (with an equilibrium check), VTX and XDMF fields."""

import csv

import h5py
import numpy as np
import pytest
from mpi4py import MPI
from test_interface_fe import block_problem, prefix

from subfric_dolfinx.fem import FrictionSolver, LoadStepper
from subfric_dolfinx.io import FieldWriter, HistoryCSV, interface_summary


@pytest.mark.parametrize("fmt", ["vtx", "xdmf"])
def test_history_and_fields(shared_tmp, fmt):
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    solver = FrictionSolver(prob, prefix("out"), {"snes_rtol": 1e-12})
    hist = HistoryCSV(shared_tmp / "history.csv", prob)
    fields = FieldWriter(shared_tmp / "fields", prob, fmt)

    def on_step(rec):
        row = hist.write(rec)
        fields.write(rec.t)
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
    if comm.rank == 0:
        rows = list(csv.DictReader(open(shared_tmp / "history.csv")))
        assert len(rows) == len(hist.rows) == 8
        assert [float(r["t"]) for r in rows] == pytest.approx(np.arange(1, 9) * 0.25)
        assert float(rows[-1]["up_norm"]) > 0.05 and float(rows[-1]["mu"]) < 500
        if fmt == "vtx":
            assert (shared_tmp / "fields" / "displacement.bp").is_dir()
            assert (shared_tmp / "fields" / "interface.bp").is_dir()
        else:
            with h5py.File(shared_tmp / "fields" / "interface.h5") as f:
                assert {"f_t", "f_n", "up", "mu", "r"} <= set(f["Function"])
                assert len(f["Function/mu"]) == 8
            assert (shared_tmp / "fields" / "displacement.h5").exists()
    solver.destroy()
