"""Probes and derived fields (issue 16, item 5): values at named points against known fields,
reactions in local frames against the rotated global ones, the Cauchy and von Mises stresses of
known states (a plane-strain bar under F/A, an affine displacement) in the history and in the
field output. 1 and 2 ranks (the same numbers)."""

import copy
import os

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import on_root, prefix, small_scene

E = {"primary": 2.1e5, "secondary": 7.0e4}
NU = {"primary": 0.3, "secondary": 0.33}
G = np.array([[1.0e-3, 2.0e-3], [-0.5e-3, -1.5e-3]])  # displacement gradient of both bodies
D = np.array([0.001, -0.002])  # the block's extra translation: a gap across the interface
COULOMB = {"law": "coulomb", "params": {"alpha_t": 1e4, "alpha_n": 1e4, "mu_c": 0.3}}


def plane_strain_stress(grad, E, nu):
    """Cauchy stress (3 x 3) of a 2-D displacement gradient, plane strain, written out."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    exx, eyy, exy = grad[0, 0], grad[1, 1], 0.5 * (grad[0, 1] + grad[1, 0])
    tr = exx + eyy
    return np.array(
        [
            [2 * mu * exx + lam * tr, 2 * mu * exy, 0.0],
            [2 * mu * exy, 2 * mu * eyy + lam * tr, 0.0],
            [0.0, 0.0, lam * tr],
        ]
    )


def von_mises(s):
    """The textbook formula, component by component."""
    return np.sqrt(
        0.5 * ((s[0, 0] - s[1, 1]) ** 2 + (s[1, 1] - s[2, 2]) ** 2 + (s[2, 2] - s[0, 0]) ** 2)
        + 3 * (s[0, 1] ** 2 + s[1, 2] ** 2 + s[0, 2] ** 2)
    )


def affine_scene(degree):
    """Both bodies held as wholes (cell groups) on u = G x, the block moved by D besides."""
    s = copy.deepcopy(small_scene())
    s["law"] = COULOMB
    s["degree"] = degree
    s["program"] = {"times": [0, 1], "channels": {"a": [0, 1]}}
    s["solver"] = {"prefix": prefix("affine"), "dt": 1.0}
    s["loads"] = []
    s["dirichlet"] = [
        {"group": "primary", "value": [0, 0], "gradient": G.ravel().tolist(), "amplitude": "a"},
        {
            "group": "secondary",
            "value": D.tolist(),
            "gradient": G.ravel().tolist(),
            "amplitude": "a",
        },
    ]
    s["points"] = {
        "A": {"x": [1.13, 0.77]},  # inside the block, off the vertices
        "B": {"x": [0.31, 0.22]},  # inside the base
        "Cs": {"x": [0.9, 0.5], "body": "secondary"},  # on the interface, each side
        "Cm": {"x": [0.9, 0.5], "body": "primary"},
    }
    every = ["u", "sigma", "von_mises"]
    s["outputs"] = {
        "probes": [
            {"point": "A", "fields": every},
            {"point": "B", "fields": every},
            {"point": "Cs", "fields": ["u", "f_t", "f_n", "gap", "up", "status"]},
            {"point": "Cm", "fields": ["u"]},
        ]
    }
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm block"
)
@pytest.mark.parametrize("degree", [1, 2])
def test_probes_of_an_affine_field_and_its_stress(degree):
    """u = G x (+ D in the block) prescribed on both bodies: the probes give u at the points
    (each side of the interface its own), the stress and von Mises of G in each body (plane
    strain, written out by hand), and at the interface the gap D: f_n = alpha_n D_n = 20 MPa,
    |f_t| = mu f_n = 6 MPa (sliding)."""
    res = run_scene(affine_scene(degree), comm=MPI.COMM_WORLD)
    row = res.history[-1]
    pts = {"A": ([1.13, 0.77], "secondary"), "B": ([0.31, 0.22], "primary")}
    for name, (x, body) in pts.items():
        u = G @ np.array(x) + (D if body == "secondary" else 0.0)
        assert [row[f"{name}.u_x"], row[f"{name}.u_y"]] == pytest.approx(u, rel=1e-12, abs=1e-15)
        sigma = plane_strain_stress(G, E[body], NU[body])
        got = np.array(
            [
                row[f"{name}.sigma_{c}"]
                for c in ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz")
            ]
        )
        assert got.reshape(3, 3) == pytest.approx(sigma, rel=1e-9, abs=1e-9)
        assert row[f"{name}.von_mises"] == pytest.approx(von_mises(sigma), rel=1e-9)
    xc = np.array([0.9, 0.5])
    assert [row["Cs.u_x"], row["Cs.u_y"]] == pytest.approx(G @ xc + D, rel=1e-12)
    assert [row["Cm.u_x"], row["Cm.u_y"]] == pytest.approx(G @ xc, rel=1e-12)
    assert row["Cs.gap_t1"] == pytest.approx(D[0], rel=1e-9)
    assert row["Cs.gap_n"] == pytest.approx(-D[1], rel=1e-9)
    assert row["Cs.f_n"] == pytest.approx(1e4 * -D[1], rel=1e-9)
    assert row["Cs.f_t1"] == pytest.approx(0.3 * 1e4 * -D[1], rel=1e-9)
    assert row["Cs.status"] == Status.PLASTIC


def uniaxial_scene(degree=1, fields=None):
    """The block pressed by p on its top, on a nearly frictionless interface (mu = 1e-9), the
    base held as a whole: a plane-strain bar in uniaxial compression, sigma_yy = -F/A."""
    s = copy.deepcopy(small_scene())
    s["law"] = {"law": "coulomb", "params": {"alpha_t": 1e4, "alpha_n": 1e4, "mu_c": 1e-9}}
    s["degree"] = degree
    s["program"] = {"times": [0, 1], "channels": {"press": [0, 1]}}
    s["solver"] = {"prefix": prefix("bar"), "dt": 0.5}
    s["dirichlet"] = [
        {"group": "primary", "value": [0.0, 0.0]},
        {"group": "mid", "component": 0, "value": 0.0},  # the block's sideways rigid mode
    ]
    s["loads"] = [{"type": "pressure", "group": "top", "value": 120.0, "amplitude": "press"}]
    s["points"] = {"mid": {"x": [1.0, 1.0], "body": "secondary"}, "A": {"x": [1.21, 0.66]}}
    s["outputs"] = {
        "probes": [{"point": "A", "fields": ["sigma", "von_mises"]}],
        "reaction_frames": [
            {"group": "primary", "normal": [0.6, 0.8], "tangent": [0.8, -0.6], "name": "tilted"}
        ],
    }
    if fields:
        s["outputs"].update(fields=fields, stress=True, history=True)
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm block"
)
def test_the_stress_of_a_bar_in_uniaxial_compression_is_force_over_area(shared_tmp):
    """sigma_yy = -F/A (F = p w, A = w), sigma_xx = sigma_xy = 0, sigma_zz = -nu F/A (plane
    strain), von Mises sqrt(((p)^2 + (p (1 - nu))^2 + (nu p)^2) / 2); in the probe and in every
    cell of the block of the written stress field (DG0). The reaction of the base resolved in a
    frame turned by atan(3/4) equals the global reaction turned."""
    comm = MPI.COMM_WORLD
    p, nu = 120.0, NU["secondary"]
    res = run_scene(uniaxial_scene(fields="vtx"), outdir=shared_tmp, comm=comm)
    row = res.history[-1]
    assert row["A.sigma_yy"] == pytest.approx(-p, rel=1e-7)
    assert abs(row["A.sigma_xx"]) < 1e-6 * p and abs(row["A.sigma_xy"]) < 1e-6 * p
    assert row["A.sigma_zz"] == pytest.approx(-nu * p, rel=1e-7)
    vm = np.sqrt(0.5 * (p**2 + (p * (1 - nu)) ** 2 + (nu * p) ** 2))
    assert row["A.von_mises"] == pytest.approx(vm, rel=1e-7)
    # the frame (t, n) = ((0.8, -0.6), (0.6, 0.8)): rows of the rotation
    R = np.array([row["R_primary_x"], row["R_primary_y"]])
    assert R[1] == pytest.approx(p * 1.0, rel=1e-7)
    Q = np.array([[0.8, -0.6], [0.6, 0.8]])
    assert [row["R_tilted_t"], row["R_tilted_n"]] == pytest.approx(Q @ R, rel=1e-12, abs=1e-9)
    assert str(shared_tmp / "fields" / "stress.bp") in res.files

    def read_back():
        """The last step's values, all blocks (one per writing rank), with ADIOS2's MPI build."""
        os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")
        import adios2

        with adios2.FileReader(str(shared_tmp / "fields" / "stress.bp")) as f:
            for name in ("sigma", "von_mises"):  # the units, as ADIOS2 attributes
                assert f.inquire_attribute(f"{name}/unit").data_string() == "MPa"
            last = f.num_steps() - 1
            out = []
            for name, width in (("sigma", 9), ("von_mises", 1)):
                parts = []
                for b, info in enumerate(f.all_blocks_info(name)[last]):
                    shape = tuple(int(n) for n in info["Count"].split(","))
                    if 0 not in shape:
                        parts.append(f.read(name, block_id=b, step_selection=[last, 1]))
                out.append(np.concatenate([np.ravel(a) for a in parts]).reshape(-1, width))
        return out[0], out[1].ravel()

    sig, vms = on_root(comm, read_back)
    block = np.isclose(sig[:, 4], -p, rtol=1e-7)  # the block's cells; the base is unstressed
    assert np.count_nonzero(block) > 0.2 * block.size
    assert np.allclose(sig[block][:, 8], -nu * p, rtol=1e-7)
    assert np.allclose(vms[block], vm, rtol=1e-7)
    assert np.allclose(sig[~block], 0.0, atol=1e-9)  # held as a whole: no strain in the base


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e4 MPa/mm Coulomb penalty on the 1 mm pad"
)
def test_reactions_in_a_3d_frame_are_the_rotated_global_reactions():
    """3-D: the plate's bottom reaction in a frame (t1, t2 = n x t1, n) with an oblique normal
    equals the global reaction turned by the rotation with those rows."""
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    t1 = np.array([2.0, 1.0, -2.0]) / 3.0
    s = {
        "kind": "fe",
        "name": "frame3d",
        "mesh": {"builder": "pad_on_plate", "options": {"n_interface": 2}},
        "law": COULOMB,
        "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 7e4, "nu": 0.33}},
        "program": {"times": [0, 1], "channels": {"p": [0, 1]}},
        "dirichlet": [{"group": "bottom", "value": [0, 0, 0]}],
        "loads": [
            {"type": "traction", "group": "top", "value": [5.0, -2.0, -50.0], "amplitude": "p"}
        ],
        "solver": {"prefix": prefix("f3d"), "dt": 1.0},
        "outputs": {
            "reaction_frames": [{"group": "bottom", "normal": n.tolist(), "tangent": t1.tolist()}]
        },
    }
    row = run_scene(s, comm=MPI.COMM_WORLD).history[-1]
    R = np.array([row[f"R_bottom_{c}"] for c in "xyz"])
    assert R == pytest.approx([-5.0, 2.0, 50.0], rel=1e-8)  # the pad's top is 1 x 1
    Q = np.array([t1, np.cross(n, t1), n])
    local = [row[f"R_bottom_{c}"] for c in ("t1", "t2", "n")]
    assert local == pytest.approx(Q @ R, rel=1e-12, abs=1e-9)


def test_probes_are_the_same_on_any_partition():
    """A pressed and slid block (non-uniform stress, a structured quadrilateral mesh): probes at a
    vertex, on an edge between two cells (where the DG0 stress jumps: the cell is chosen by its
    midpoint, not by the rank) and on the interface, run on all ranks and again serially on rank
    0: the same values to round-off."""
    comm = MPI.COMM_WORLD
    s = copy.deepcopy(small_scene())
    s["mesh"]["options"]["cell_type"] = "quadrilateral"
    s["program"] = small_scene(short=True)["program"]
    s["solver"] = {"dt": 0.25}
    s["points"] = {
        "V": {"x": [1.0, 1.0]},
        "E": {"x": [1.0, 0.5625], "body": "secondary"},
        "I": {"x": [0.8, 0.5], "body": "secondary"},
    }
    s["outputs"] = {
        "probes": [
            {"point": "V", "fields": ["u"]},
            {"point": "E", "fields": ["u", "sigma", "von_mises"]},
            {"point": "I", "fields": ["f_t", "f_n", "mu", "up"]},
        ]
    }

    def with_prefix():  # on every rank: the ranks' prefix counts stay equal (tests/conftest.py)
        scene = copy.deepcopy(s)
        scene["solver"]["prefix"] = prefix("part")
        return scene

    parallel = run_scene(with_prefix(), comm=comm).history
    alone = with_prefix()
    serial = on_root(comm, lambda: run_scene(alone, comm=MPI.COMM_SELF).history)
    assert len(parallel) == len(serial)
    for a, b in zip(parallel, serial, strict=True):
        for k in a:
            if "." in k:
                assert a[k] == pytest.approx(b[k], rel=1e-8, abs=1e-10 * max(1.0, abs(b[k]))), k
    assert abs(parallel[-1]["I.f_t1"]) > 1.0 and parallel[-1]["E.von_mises"] > 10.0
