"""Interface regions with their own laws (1 and 2 ranks).

A nearly rigid block (E = 1e8 MPa) on a base, its interface split into two halves by the
builder's ``interface_regions``: ``rough`` (x < 1, Coulomb mu = 0.5) and the rest under the
scene's law (Coulomb mu = 0.2). Pressed by a prescribed approach ``d`` and slid until both halves
slide:

* each half carries ``F_n = alpha_n d A`` and, sliding, ``F_t = mu F_n`` with its own mu (the
  per-region columns of the history), the total is their sum;
* the points carry the region of their facet (snapshots); the 2-rank run equals the serial one to
  round-off;
* a restart with regions continues the uninterrupted run; a checkpoint written with other region
  laws is refused; a region the mesh does not have is named with the ones it has.
"""

import copy

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.fem import InterfaceError
from subfric_dolfinx.io import CheckpointError
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import SOFT_GAP, on_root, prefix, raised_on_every_rank

ALPHA = 1e4
D = 0.01  # mm, the approach: f_n = 100 MPa
MU = {"default": 0.2, "rough": 0.5}


def coulomb(mu):
    return {"law": "coulomb", "params": {"alpha_t": ALPHA, "alpha_n": ALPHA, "mu_c": mu}}


def scene(regions=None, name="regions", **outputs):
    return {
        "kind": "fe",
        "name": name,
        "mesh": {
            "builder": "block_on_base",
            "options": {"n_interface": 8, "interface_regions": {"rough": [0.5, 1.0]}},
        },
        "law": coulomb(MU["default"]),
        "regions": {"rough": coulomb(MU["rough"])} if regions is None else regions,
        "materials": {"primary": {"E": 1e8, "nu": 0.3}, "secondary": {"E": 1e8, "nu": 0.3}},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
        "dirichlet": [
            {"group": "bottom", "value": [0, 0]},
            {"group": "top", "component": 0, "value": 0.05, "amplitude": "slide"},
            {"group": "top", "component": 1, "value": -D, "amplitude": "press"},
        ],
        "solver": {"prefix": prefix(name), "dt": 0.25},
        "outputs": {"snapshots": [2.0], **outputs},
    }


def slides_at_each_regions_own_coefficient(snap):
    """The profile at the end: the left half (x < 1) the region ``rough`` (number 1), the rest
    the interface's law, every point sliding at its own region's coefficient."""
    x = snap["x"][:, 0]
    np.testing.assert_array_equal(snap["region"], np.where(x < 1.0, 1, 0))
    assert np.all(snap["status"] == Status.PLASTIC)
    ratio = np.abs(snap["f_t"][:, 0]) / snap["f_n"]
    np.testing.assert_allclose(ratio, np.where(x < 1.0, MU["rough"], MU["default"]), rtol=1e-9)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_each_region_slides_at_its_own_friction_coefficient():
    comm = MPI.COMM_WORLD
    res = run_scene(scene(), comm=comm)
    end = res.history[-1]
    for name in MU:
        assert end[f"{name}.area"] == pytest.approx(0.5, rel=1e-12)
        assert end[f"{name}.F_n"] == pytest.approx(ALPHA * D * 0.5, rel=2e-4)
        assert end[f"{name}.plastic"] == 1.0 and end[f"{name}.separated"] == 0.0
        # sliding: F_t = mu F_n in each region, to round-off
        assert abs(end[f"{name}.F_t1"]) == pytest.approx(MU[name] * end[f"{name}.F_n"], rel=1e-9)
    total = sum(MU[k] * ALPHA * D * 0.5 for k in MU)
    assert abs(end["F_t1"]) == pytest.approx(total, rel=2e-4)
    assert end["F_t1"] == pytest.approx(end["default.F_t1"] + end["rough.F_t1"], rel=1e-12)
    assert abs(end["R_top_x"]) == pytest.approx(abs(end["F_t1"]), rel=1e-8)
    slides_at_each_regions_own_coefficient(res.snapshots[2.0])
    if comm.size > 1:  # the same on one rank, to round-off
        alone = scene()  # on every rank: the ranks' prefix counts stay equal (tests/conftest.py)

        def serial():
            one = run_scene(alone, comm=MPI.COMM_SELF)
            keys = ["F_t1", "F_n", "rough.F_t1", "default.F_t1", "R_top_x"]
            a = np.array([[r[k] for k in keys] for r in one.history])
            b = np.array([[r[k] for k in keys] for r in res.history])
            diff = np.abs(a - b).max(axis=0)
            # the interface to 1e-12; the reaction, a residual of a stiff problem (E = 1e8),
            # carries the round-off of K u (measured 1e-8 on 25)
            tol = np.array([1e-12, 1e-12, 1e-12, 1e-12, 1e-9]) * np.abs(a).max()
            assert np.all(diff < tol), dict(zip(keys, diff, strict=True))
            return dict(zip(keys, diff, strict=True))

        print(f"1 vs 2 ranks: largest differences {on_root(comm, serial)}")


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_restart_with_regions(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "a"
    full = run_scene(scene(checkpoint_times=[1.5], history=True), outdir=out, comm=comm)
    again = run_scene(scene(), comm=comm, restart=out / "checkpoint.h5")
    keys = ["t", "F_t1", "rough.F_t1", "default.F_n"]
    a = np.array([[r[k] for k in keys] for r in again.history])
    b = np.array([[r[k] for k in keys] for r in full.history])
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
    other = scene(regions={"rough": coulomb(0.45)})
    with raised_on_every_rank(CheckpointError, "was written with law", "0.5", "0.45"):
        run_scene(other, comm=comm, restart=out / "checkpoint.h5")


def test_a_region_the_mesh_lacks_is_named():
    with raised_on_every_rank(InterfaceError, "['smooth']", "['rough']"):
        run_scene(scene(regions={"smooth": coulomb(0.3)}), comm=MPI.COMM_WORLD)


SLIDE = 0.02  # mm: the end facet's last point (0.026 mm from its end) stays on the interface


def slid(s):
    """The scene slid :data:`SLIDE` only."""
    s = copy.deepcopy(s)
    s["dirichlet"][1]["value"] = SLIDE
    return s


def finite(s, regions=None):
    """The scene with its interface finite-sliding, the regions given on it."""
    s = slid(s)
    regs = s.pop("regions")
    s["interfaces"] = {
        "interface": {
            "kinematics": "finite_sliding",
            "regions": regs if regions is None else regions,
            "search_radius": 0.05,
        }
    }
    return s


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_regions_with_finite_sliding_each_point_its_own_law():
    """The same scene, its interface finite-sliding: each secondary point slides at its region's
    friction coefficient (F_t = mu F_n per region and per point, to round-off); the forces are the
    small-sliding ones of the same slide (0.02 mm on facets of 0.125: the builder's interface is
    the base's top under the block only, and the block's end facet slides 0.16 of it past its end,
    its points still on it)."""
    comm = MPI.COMM_WORLD
    res = run_scene(finite(scene(name="regions_finite")), comm=comm)
    small = run_scene(slid(scene(name="regions_small")), comm=comm)
    end, ref = res.history[-1], small.history[-1]
    for name in MU:
        assert end[f"{name}.area"] == pytest.approx(0.5, rel=1e-12)
        assert end[f"{name}.plastic"] == 1.0 and end[f"{name}.separated"] == 0.0
        assert abs(end[f"{name}.F_t1"]) == pytest.approx(MU[name] * end[f"{name}.F_n"], rel=1e-9)
        assert end[f"{name}.F_n"] == pytest.approx(ref[f"{name}.F_n"], rel=1e-6)
    assert end["F_t1"] == pytest.approx(end["default.F_t1"] + end["rough.F_t1"], rel=1e-12)
    assert end["F_t1"] == pytest.approx(ref["F_t1"], rel=1e-6)
    # F_t1 is along the frame of the base's current normals, which the press tilts a little
    assert abs(end["R_top_x"]) == pytest.approx(abs(end["F_t1"]), rel=1e-6)
    slides_at_each_regions_own_coefficient(res.snapshots[2.0])


def test_a_finite_sliding_region_the_mesh_lacks_is_named():
    with raised_on_every_rank(InterfaceError, "'interface'", "['smooth']", "['rough']"):
        run_scene(finite(scene(), regions={"smooth": coulomb(0.3)}), comm=MPI.COMM_WORLD)


@pytest.mark.parametrize(
    "group, words",
    [
        ([[0.25, 0.0]], ("'contact'", "'r'", "none of its facets is a secondary facet")),
        ([[0.6, 0.0]], ("'contact'", "'r'", "1 of its 1 facets are not facets of the interface")),
    ],
)
def test_a_finite_sliding_region_is_a_group_of_secondary_facets(group, words):
    """A base wider than its block (4 facets under 2, meshed apart): a group of base facets only
    has no point to give a law; a group of no facet of the interface is named."""
    import dolfinx

    from subfric_dolfinx.constitutive import CoulombLaw
    from subfric_dolfinx.fem.interface import SlidingInterface, SlidingOptions
    from tests.contact_meshes import tagged_blocks

    comm = MPI.COMM_WORLD
    dom = tagged_blocks(
        comm, base=(0.0, 2.0, -1.0, 0.0), block=(0.5, 1.5, 0.0, 1.0), n_base=(4, 1), n_block=(2, 1)
    )
    V = dolfinx.fem.functionspace(dom.mesh, ("Lagrange", 1, (2,)))
    law = CoulombLaw(alpha_t=1e4, alpha_n=1e4, mu_c=0.2)

    def with_region(region_law, centroids):
        return SlidingInterface(
            V,
            dom.cell_tags,
            dom.facet_tags,
            law,
            tag=dom.tags["contact"],
            primary=dom.tags["base"],
            secondary=dom.tags["block"],
            options=SlidingOptions(
                name="contact", regions={"r": region_law}, groups={"r": np.array(centroids)}
            ),
        )

    with raised_on_every_rank(InterfaceError, *words):
        with_region(law, group)
    # both sides' facets in one group (a mesh made apart): the block's facet gives the region
    iface = with_region(CoulombLaw(alpha_t=1e4, alpha_n=1e4, mu_c=0.5), [[0.25, 0.0], [0.75, 0.0]])
    pts = iface.law_points
    left = pts.points[:, 0] < 1.0
    assert np.array_equal(pts.point_data["region"], np.where(left, 1.0, 0.0))
    assert pts.region_names == ("default", "r")
    total = comm.allreduce(np.array([left.sum(), left.size]))
    assert total[0] * 2 == total[1] > 0
    iface.destroy()
