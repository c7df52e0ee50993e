"""Code_Aster's SSNV503 (sliding skate on a rigid plane), the setting of its modelling J (a
Coulomb joint between skate and frame), with real springs and default solver options (issue 16,
item 4). 1 and 2 ranks.

The skate (40 mm wide, 20 mm high, plane strain, 1 mm thick) sits on a frame held as a whole (a
cell group: every dof). It is pressed by ``Pn = 300 MPa`` on its top CD (``Fn = 12,000 N``), then
pushed sideways by ``Pt`` on its side AD (20 mm): ``Pt = 178.2 MPa`` (``Ft = 3,564 N = 0.99 mu
Fn``, it sticks), then ``Pt = 181.8 MPa`` (``Ft = 3,636 N = 1.01 mu Fn``, it slides) with ``mu =
0.3``. Two lateral springs of 2 N/mm (``RES_LAT``, Robin conditions of 0.1 MPa/mm on the two
20 mm sides, their far ends fixed) and a weak vertical one of 0.005 N/mm on the top
(``RES_HAUT``) hold the skate; sliding stops when they carry ``Ft - mu Fn = 36 N``, i.e. after
``36 / 4 = 9 mm``. Code_Aster's checks (reference V6.04.503, deformation of the skate neglected):
the pressure transmitted through the contact zone AB equals the applied pressure; under the
sticking load the nodes of AB do not move tangentially; under the sliding load they move by 9 mm.

Not given in the peer's text we could find: the materials and the joint's stiffnesses. Taken
here: the reference's hypothesis, a skate whose deformation is negligible (E = 2.1e7 MPa, a
hundred times steel's, nu = 0.3; the frame, held as a whole, does not deform anyway) and
``alpha_n = alpha_t = 1e4 MPa/mm``. What the finite stiffnesses add to the rigid reference, and
the tolerances they call for: the side load tilts the skate (the moment ``Ft h / 2`` makes the
pressure vary linearly along AB, 166 to 434 MPa, so near A the ratio ``f_t / f_n`` reaches ``mu``
first: under the sticking load most of AB slips a little and a stick zone remains at B, which is
the reference's check, "at least one node of the contact zone does not move"); AB moves by the
joint's tangential compliance under the sticking load (about 0.012 mm) and, tilted, by 9 mm less
``theta h / 2`` (0.0067 mm) under the sliding load.

The scene passes no solver option: the run must converge with the defaults. A skate this stiff
under loads of 12,000 N puts the residual's round-off floor above the old absolute tolerance
(``snes_atol = 1e-10``): with that test Newton stalls at the start of sliding (30 iterations,
the step cut to failure); the load-scaled convergence test (issue 13) converges in 1 to 4
iterations per step.
"""

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import leaves_validity, prefix

PN, PT_STICK, PT_SLIDE, MU = 300.0, 178.2, 181.8, 0.3
WIDTH, HEIGHT = 40.0, 20.0  # the skate: AB = CD = 40 mm, AD = 20 mm
K_LAT = 2.0  # N/mm, each lateral spring
ALPHA = 1e4  # MPa/mm, joint stiffnesses (normal and tangential)
Y0 = 10.0  # the frame's height: the contact zone AB is at y = 10


def scene() -> dict:
    """The SSNV503 modelling J setting as a scene, with no solver option."""
    return {
        "kind": "fe",
        "name": "ssnv503",
        "mesh": {
            "builder": "block_on_base",
            "options": {
                "base_width": 60.0,
                "base_height": Y0,
                "block_width": WIDTH,
                "block_height": HEIGHT,
                "n_interface": 8,
                "cell_type": "quadrilateral",
            },
        },
        "law": {"law": "coulomb", "params": {"alpha_n": ALPHA, "alpha_t": ALPHA, "mu_c": MU}},
        "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 2.1e7, "nu": 0.3}},
        # 0-1: the pressure; 1-2: the sticking shear; 2-3: on to the sliding shear
        "program": {
            "times": [0, 1, 2, 3],
            "channels": {"pn": [0, 1, 1, 1], "pt": [0, 0, PT_STICK, PT_SLIDE]},
        },
        "dirichlet": [{"group": "primary", "value": [0.0, 0.0]}],  # the frame, built in
        "loads": [
            {"type": "pressure", "group": "top", "value": PN, "amplitude": "pn"},
            {"type": "traction", "group": "secondary_left", "value": [1.0, 0.0], "amplitude": "pt"},
        ],
        "springs": [
            {"group": "secondary_left", "stiffness": [K_LAT / HEIGHT, 0.0]},  # RES_LAT
            {"group": "secondary_right", "stiffness": [K_LAT / HEIGHT, 0.0]},  # RES_LAT
            {"group": "top", "stiffness": [0.0, 0.005 / WIDTH]},  # RES_HAUT
        ],
        "points": {
            "A": {"x": [10.0, Y0], "body": "secondary"},
            "M": {"x": [30.0, Y0], "body": "secondary"},
            "B": {"x": [50.0, Y0], "body": "secondary"},
        },
        "solver": {"prefix": prefix("ssnv503"), "dt": 0.25},
        "outputs": {
            "snapshots": [1.0, 2.0, 3.0],
            "probes": [{"point": p, "fields": ["u", "f_n", "f_t"]} for p in "AMB"],
        },
    }


@pytest.fixture(scope="module")
def result():
    with leaves_validity(PenetrationWarning):  # SSNV503's joint stiffness, as the benchmark has it
        return run_scene(scene(), comm=MPI.COMM_WORLD)


def at(result, t):
    return next(r for r in result.history if abs(r["t"] - t) < 1e-9)


def test_pressure_transmission(result):
    """Load 1: the contact zone transmits Pn: f_n = 300 MPa at every interface point (within
    1e-4; measured 2.5e-5), F_n = 12,000 N (less the 1.5e-4 N of the vertical spring), and AB
    sinks by the joint's compliance Pn / alpha_n."""
    row = at(result, 1.0)
    assert row["F_n"] + row["S_top_y"] == pytest.approx(PN * WIDTH, rel=1e-9)
    assert 0.0 < row["S_top_y"] < 1e-3
    fn = result.snapshots[1.0]["f_n"]
    assert np.allclose(fn, PN, rtol=1e-4), (fn.min(), fn.max())
    for p in "AMB":
        assert row[f"{p}.u_y"] == pytest.approx(-PN / ALPHA, rel=1e-4)
        assert row[f"{p}.f_n"] == pytest.approx(PN, rel=1e-4)


def test_sticking_at_099_mu(result):
    """Load 2 (Ft = 0.99 mu Fn): the skate does not slide: the interface carries the whole shear,
    the springs almost nothing (below 0.5 N of the 36 N they carry when it slides), the nodes of
    AB move by the joint's elastic compliance only (below 0.02 mm, against the 9 mm of the
    sliding load), and a stick zone (points that did not slip) remains at B."""
    row = at(result, 2.0)
    assert row["F_t1"] - row["S_secondary_left_x"] - row["S_secondary_right_x"] == pytest.approx(
        PT_STICK * HEIGHT, rel=1e-9
    )
    assert abs(row["S_secondary_left_x"] + row["S_secondary_right_x"]) < 0.5
    for p in "AMB":
        assert 0.0 < row[f"{p}.u_x"] < 0.02
    snap = result.snapshots[2.0]
    stick = snap["status"] == Status.ELASTIC  # no slip in the step
    assert np.any(stick) and np.all(snap["x"][stick, 0] > 30.0), snap["x"][stick, 0]
    assert row["B.f_t1"] < MU * row["B.f_n"] * (1 - 1e-3)  # B sticks


def test_sliding_at_101_mu(result):
    """Load 3 (Ft = 1.01 mu Fn): the skate slides until the springs carry Ft - mu Fn = 36 N
    (within 1e-5), the nodes of AB move by 36 N / 4 N/mm = 9 mm (within 1e-3: the tilt), the
    interface carries mu Fn at every point."""
    row = at(result, 3.0)
    springs = row["S_secondary_left_x"] + row["S_secondary_right_x"]
    assert springs == pytest.approx(-(PT_SLIDE * HEIGHT - MU * PN * WIDTH), rel=1e-5)
    assert row["F_t1"] == pytest.approx(MU * row["F_n"], rel=1e-9)
    for p in "AMB":
        assert row[f"{p}.u_x"] == pytest.approx(9.0, rel=1e-3)
        assert row[f"{p}.f_t1"] == pytest.approx(MU * row[f"{p}.f_n"], rel=1e-9)
    assert np.all(result.snapshots[3.0]["status"] == Status.PLASTIC)  # all of AB slides


def test_it_ran_with_default_options(result):
    """No solver option in the scene, no step cut, every step converged."""
    assert "options" not in scene()["solver"]
    assert all(r["cuts"] == 0 for r in result.history)
    assert result.history[-1]["t"] == 3.0
