"""Every interface stored alike (format 3 on), the stepper's memory stored (format 4);
checkpoints of formats 2 and 3 still read (issue 34 item 5).

``tests/data/checkpoint_v2/`` holds a checkpoint of format version 2 (the first interface under
``/interface``, the others under ``/interfaces/<name>``), written at t = 1.5 by the code of
that version from the three stacked blocks of ``tests/fem/test_multibody.py`` (two interfaces,
mesh ``stack.msh`` beside it, built with ``h = 0.25``), and the mesh file itself;
``tests/data/checkpoint_v3/`` one of format version 3 (without the stepper's memory beyond
``dt`` and ``easy``), written at the same time of the same run by the code of that version. A
restart from either continues the run as the uninterrupted run of this code does.
"""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from subfric_dolfinx.io import read_checkpoint
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import everywhere, on_root
from tests.scenes.test_scene_bodies import stack_scene

DATA = Path(__file__).resolve().parent.parent / "data"
MESH = DATA / "checkpoint_v2" / "stack.msh"
T_CK = 1.5


def scene(**outputs):
    s = stack_scene(MESH, **outputs)
    s["outputs"].pop("probes")
    s.pop("points")
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on 1 mm bodies"
)
@pytest.mark.parametrize("version", [2, 3])
def test_an_older_checkpoint_restarts_the_run(comm, shared_tmp, version):
    path = DATA / f"checkpoint_v{version}" / "checkpoint.h5"
    ck = read_checkpoint(path, comm)
    assert ck.attrs["version"] == version and ck.attrs["time"] == T_CK
    # the stepper's memory beyond dt and easy: the defaults
    assert ck.attrs["stepper"] == {"hold_step": None, "keep_retry": False, "retry_run": 0}
    full = run_scene(scene(history=True), outdir=shared_tmp / "a", comm=comm)
    again = run_scene(scene(history=True), outdir=shared_tmp / "b", comm=comm, restart=path)
    keys = ["low.F_t1", "high.F_t1", "low.up_norm", "high.F_n", "R_lid_x"]
    a = np.array([[r[k] for k in keys] for r in full.history if r["t"] > T_CK + 1e-9])
    b = np.array([[r[k] for k in keys] for r in again.history if r["t"] > T_CK + 1e-9])
    assert everywhere(comm, a.shape == b.shape and a.shape[0] == 2)
    assert everywhere(comm, np.abs(a - b).max() <= 1e-10 * np.abs(a).max()), np.abs(a - b)


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on 1 mm bodies"
)
def test_every_interface_is_stored_alike(comm, shared_tmp):
    """Format 4: ``/interfaces/<name>`` for the first interface as for the second (the same
    datasets, each with its points and law); nothing at format 2's ``/interface``; the
    stepper's memory in the attribute ``stepper``."""
    run_scene(scene(checkpoint_times=[T_CK]), outdir=shared_tmp, comm=comm)
    ck = read_checkpoint(shared_tmp / "checkpoint.h5", comm)
    assert ck.attrs["version"] == 4 and set(ck.interfaces) == {"low", "high"}
    assert ck.attrs["stepper"] == {"hold_step": None, "keep_retry": False, "retry_run": 0}

    def layout():
        with h5py.File(shared_tmp / "checkpoint.h5") as f:
            assert "interface" not in f and "point_data" not in f
            assert json.loads(f.attrs["stepper"])["retry_run"] == 0
            low, high = f["interfaces/low"], f["interfaces/high"]
            assert set(low) == set(high) == {"x", "up", "point_data"}
            assert low.attrs["n_points"] == 12 and high.attrs["n_points"] == 8
            assert '"mu_c": 0.2' in low.attrs["law"] and '"mu_c": 0.5' in high.attrs["law"]

    on_root(comm, layout)
