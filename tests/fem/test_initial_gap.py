"""The initial gap g0 of the interface against closed forms (1 and 2 ranks).

A block on a base, both nearly rigid (E = 1e8 MPa against a normal penalty of 1e4 MPa/mm over a
block 1 mm wide), the top of the block moved down by ``d(t)``:

* a uniform gap g0: no force and every point SEPARATED while ``d < g0``; from ``d = g0`` on the
  force is the penalty's, ``alpha_n w (d - g0)``;
* a gap growing linearly along the block: the contact closes progressively; at every step the
  points with ``g0(x) < d`` are in contact with ``f_n = alpha_n (d - g0(x))`` and the others
  SEPARATED; when the contact front lies on an element boundary the total force equals the
  closed form ``alpha_n (d - g0_min)^2 / (2 s)`` (the Gauss rule is exact on each side);
* the gap is in the snapshots, the interface history and the checkpoint; a restart continues the
  uninterrupted run and refuses a checkpoint written with another gap.
"""

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.io import CheckpointError
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import SOFT_GAP, on_root, prefix, raised_on_every_rank

ALPHA = 1e4  # MPa/mm
G0 = 0.01  # mm
SLOPE = 0.01  # mm/mm, the linear gap's growth along x
X0 = 0.5  # the block spans [0.5, 1.5]


def scene(gap, name="gap", **outputs):
    """Block on a base; the block's top moved down by ``2 G0 t`` over 0 <= t <= 1."""
    return {
        "kind": "fe",
        "name": name,
        "mesh": {"builder": "block_on_base", "options": {"n_interface": 8}},
        "law": {"law": "coulomb", "params": {"alpha_t": ALPHA, "alpha_n": ALPHA, "mu_c": 0.3}},
        "materials": {"primary": {"E": 1e8, "nu": 0.3}, "secondary": {"E": 1e8, "nu": 0.3}},
        "program": {"times": [0, 1], "channels": {"press": [0, 1]}},
        "dirichlet": [
            {"group": "bottom", "value": [0, 0]},
            {"group": "top", "component": 0, "value": 0.0},
            {"group": "top", "component": 1, "value": -2 * G0, "amplitude": "press"},
        ],
        "solver": {"prefix": prefix(name), "dt": 0.05},
        "initial_gap": gap,
        "outputs": outputs,
    }


LINEAR = {"expression": "g + s*(x - x0)", "parameters": {"g": G0, "s": SLOPE, "x0": X0}}


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_a_uniform_gap_closes_at_u_equal_g0():
    comm = MPI.COMM_WORLD
    res = run_scene(scene(G0, snapshots=[0.25, 0.5, 1.0]), comm=comm)
    assert len(res.history) == 20
    for row in res.history:
        d = 2 * G0 * row["t"]
        R = -row["R_top_y"]
        assert R == pytest.approx(row["F_n"], rel=1e-9, abs=1e-6)  # equilibrium (round-off 1e-9)
        if d < G0 * (1 - 1e-9):
            assert abs(R) < 1e-6 and row["separated"] == 1.0, row
        elif d > G0 * (1 + 1e-9):
            assert R == pytest.approx(ALPHA * 1.0 * (d - G0), rel=1e-4), row
            assert row["separated"] == 0.0
    early = res.snapshots[0.25]
    assert np.all(early["status"] == Status.SEPARATED)
    np.testing.assert_allclose(early["g0"], G0, rtol=1e-15)
    np.testing.assert_allclose(early["gap"][:, 1], 0.5 * G0 - G0, rtol=1e-5)  # d - g0 < 0
    assert np.all(early["f_n"] == 0.0)
    np.testing.assert_allclose(res.snapshots[1.0]["f_n"], ALPHA * G0, rtol=1e-4)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_a_linear_gap_closes_progressively():
    comm = MPI.COMM_WORLD
    res = run_scene(scene(LINEAR, snapshots=[0.625, 0.75, 1.0]), comm=comm)
    for t, snap in res.snapshots.items():
        d = 2 * G0 * t
        x = snap["x"][:, 0]
        g0 = G0 + SLOPE * (x - X0)
        np.testing.assert_allclose(snap["g0"], g0, rtol=1e-14, atol=1e-17)
        touching = g0 < d
        assert 0 < touching.sum() <= touching.size
        assert np.all((snap["status"] == Status.SEPARATED) == ~touching), t
        np.testing.assert_allclose(
            snap["f_n"], ALPHA * np.maximum(d - g0, 0.0), rtol=0, atol=2e-4 * ALPHA * G0
        )
        row = next(r for r in res.history if abs(r["t"] - t) < 1e-9)
        # the front x = X0 + (d - G0) / SLOPE lies on an element boundary (spacing 0.125)
        assert row["F_n"] == pytest.approx(ALPHA * (d - G0) ** 2 / (2 * SLOPE), rel=2e-4)
        assert row["separated"] == pytest.approx(np.mean(~touching), abs=1e-12)
    for row in res.history:  # every step: the contact fraction follows d (nothing before G0)
        d = 2 * G0 * row["t"]
        front = np.clip((d - G0) / SLOPE, 0.0, 1.0)  # length in contact, of 1
        assert 1.0 - row["separated"] == pytest.approx(front, abs=1 / 16 + 1e-12), row


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_the_gap_is_kept_in_outputs_and_on_restart(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "a"
    full = run_scene(
        scene(LINEAR, checkpoint_times=[0.6], history=True, interface_history=True),
        outdir=out,
        comm=comm,
    )

    def check_files():
        with h5py.File(out / "interface_history.h5") as f:
            x = f["x"][()]
            np.testing.assert_allclose(f["g0"][()], G0 + SLOPE * (x[:, 0] - X0), rtol=1e-14)
        with h5py.File(out / "checkpoint.h5") as f:
            assert "g0" in f["interfaces/interface/point_data"]

    on_root(comm, check_files)
    again = run_scene(scene(LINEAR), comm=comm, restart=out / "checkpoint.h5")
    after = [r for r in full.history if r["t"] > 0.6 + 1e-9]
    assert len(again.history) == len(full.history)
    for a, b in zip(again.history[-len(after) :], after, strict=True):
        assert a["F_n"] == pytest.approx(b["F_n"], rel=1e-10, abs=1e-10)
        assert a["separated"] == b["separated"]
    other = {**LINEAR, "parameters": {**LINEAR["parameters"], "g": 1.1 * G0}}
    with raised_on_every_rank(CheckpointError, "another initial gap g0"):
        run_scene(scene(other), comm=comm, restart=out / "checkpoint.h5")
    with raised_on_every_rank(CheckpointError, "another initial gap g0"):
        run_scene(scene(None), comm=comm, restart=out / "checkpoint.h5")
