"""Uniform refinement on the ranks (1, 2 and 3 ranks).

* A stored model (2-D triangles, 3-D tetrahedra) refined keeps its groups: every group's number
  of entities times 2^dim per refinement, every group's length/area/volume (assembled), the
  interface's vertices each there twice (gathered: the nodes stay duplicated, the sides pair),
  equal numbers of facets on both sides; the cells stay on their parents' ranks.
* The patch test on a coarse model refined twice equals, to the Newton tolerance, the same
  model meshed fine directly: the uniform state of the exact solution, step by step.
* Interface regions follow the refinement (their facets' children), and the region scene
  refined gives each region its area and its own friction.
* The main demo's scene (small, a shorter slide) refined k times converges with the directly
  meshed one: their histories' difference (tangential force, mean slip) shrinks from k = 1 to
  k = 2 (by 2.6-2.8 times here).
* Tetrahedra refined still pair across the interface (facet by facet, and the pairing accepts
  them): Plaza's tie-break by vertex index is taken out of the choice (the affine map).
* Quadrilaterals, a refinement count out of range and a ghosted mesh are refused on every rank.
"""

import dolfinx
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.mesh import GhostMode
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    StepControl,
)
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.meshing import InterfaceMeshError
from subfric_dolfinx.scenes import run_scene
from tests.fem.test_regions import scene as region_scene
from tests.helpers import (
    LAW,
    MESH_DIR,
    PROGRAM,
    SEC7_PENALTY,
    SOFT_GAP,
    global_spread,
    interface_vertex_multiplicity,
    prefix,
    raised_on_every_rank,
    small_scene,
)

pytestmark = pytest.mark.three_ranks


def measures(dom):
    """Group name -> its length/area/volume (assembled, the same on every rank)."""
    tdim = dom.tdim
    dx = ufl.Measure("dx", domain=dom.mesh, subdomain_data=dom.cell_tags)
    ds = ufl.Measure("ds", domain=dom.mesh, subdomain_data=dom.facet_tags)
    one = fem.Constant(dom.mesh, 1.0)
    out = {}
    for name, tag in sorted(dom.tags.items()):
        if dom.dims[name] < tdim - 1:
            continue
        m = dx(tag) if dom.dims[name] == tdim else ds(tag)
        out[name] = dom.mesh.comm.allreduce(fem.assemble_scalar(fem.form(one * m)))
    return out


def counts(dom):
    out = {}
    for name, tag in sorted(dom.tags.items()):
        dim = dom.dims[name]
        if dim < dom.tdim - 1:
            continue
        mt = dom.cell_tags if dim == dom.tdim else dom.facet_tags
        owned = mt.find(tag) < dom.mesh.topology.index_map(dim).size_local
        out[name] = dom.mesh.comm.allreduce(int(np.count_nonzero(owned)))
    return out


@pytest.mark.parametrize(
    ("name", "gdim", "times"), [("block_on_base_tri.msh", 2, 2), ("pad_on_plate_tet.msh", 3, 1)]
)
def test_a_refined_model_keeps_its_groups_and_duplicated_nodes(name, gdim, times):
    comm = MPI.COMM_WORLD
    coarse = meshing.read_interface_mesh(MESH_DIR / name, comm, gdim)
    n0 = coarse.mesh.topology.index_map(gdim).size_local
    fine = meshing.refine_interface_mesh(coarse, times)
    assert fine.tags == coarse.tags and fine.topology == coarse.topology
    c0, c1 = counts(coarse), counts(fine)
    for g, n in c0.items():
        assert c1[g] == n * 2 ** (coarse.dims[g] * times), g
    m0, m1 = measures(coarse), measures(fine)
    for g in m0:
        assert m1[g] == pytest.approx(m0[g], rel=1e-12), g
    # every refined cell on its parent's rank
    assert fine.mesh.topology.index_map(gdim).size_local == n0 * 2 ** (gdim * times)
    mult = interface_vertex_multiplicity(fine)
    assert mult.size > interface_vertex_multiplicity(coarse).size and np.all(mult == 2)
    p = fine.interface_facets("primary", owned_only=True)
    s = fine.interface_facets("secondary", owned_only=True)
    n_p, n_s = comm.allreduce(p.size), comm.allreduce(s.size)
    assert (
        n_p
        == n_s
        == fine.num_interface_facets
        == coarse.num_interface_facets * 2 ** ((gdim - 1) * times)
    )
    assert meshing.refine_interface_mesh(coarse, 0) is coarse


def side_centroids(dom, side):
    """The centroids of an interface side's facets, gathered and sorted (rounded)."""
    comm, tdim = dom.mesh.comm, dom.tdim
    f = dom.interface_facets(side, owned_only=True)
    dom.mesh.topology.create_connectivity(tdim - 1, tdim)
    c = np.zeros((0, 3))
    if f.size:
        geo = dolfinx.mesh.entities_to_geometry(dom.mesh, tdim - 1, f, False)
        c = dom.mesh.geometry.x[geo[:, :tdim]].mean(axis=1)
    allc = np.round(np.concatenate(comm.allgather(c)), 9)
    return allc[np.lexsort(allc.T[::-1])]


def test_tetrahedra_refined_twice_still_pair_across_the_interface():
    """Plaza splits a face from its longest edge, a tie broken by vertex indices that differ
    between the sides: refined as it is, this pad (6 elements along its side, refined once)
    has 3 of its 1080 interface facets split differently on the two sides (1 rank); refined
    under the affine map, every facet has its twin."""
    comm = MPI.COMM_WORLD
    dom, _ = meshing.create_interface_mesh(meshing.build_pad_on_plate, comm, n_interface=6)
    fine = meshing.refine_interface_mesh(dom, 1)
    a, b = side_centroids(fine, "primary"), side_centroids(fine, "secondary")
    assert a.shape == b.shape == (fine.num_interface_facets, 3)
    np.testing.assert_array_equal(a, b)
    # and the pairing accepts it (a small-sliding interface pairs its sides node to node)
    prob = InterfaceProblem(
        fine,
        LAW,
        {"primary": Material(2e5, 0.3), "secondary": Material(2e5, 0.3)},
        PROGRAM,
        [Dirichlet("bottom", (0.0, 0.0, 0.0))],
        [Pressure("top", 1.0, amplitude="press")],
    )
    assert comm.allreduce(prob.interface.n_elements) == fine.num_interface_facets


def patch_history(dom):
    """The patch test of tests/fem/test_interface_fe.py (2-D) on ``dom``: each step's uniform
    tractions, slip, mu and r (their spread over the interface checked to the Newton tolerance)."""
    comm = dom.mesh.comm
    E, P, H = 2.0e4, 300.0, 0.5
    ey, un = -P / E, P / LAW.alpha_n
    bcs = [Dirichlet("bottom", (0.0, 0.0))]
    bcs += [
        Dirichlet(g, lambda x: ey * x[1], component=1, amplitude="press")
        for g in ("primary_left", "primary_right")
    ]
    bcs += [
        Dirichlet(g, lambda x: ey * H - un + ey * (x[1] - H), component=1, amplitude="press")
        for g in ("secondary_left", "secondary_right")
    ]
    bcs += [Dirichlet("top", 0.4, component=0, amplitude="slide")]
    mats = {"primary": Material(E, 0.0), "secondary": Material(E, 0.0)}
    prob = InterfaceProblem(dom, LAW, mats, PROGRAM, bcs, [Pressure("top", P, amplitude="press")])
    solver = FrictionSolver(prob, prefix("refpatch"), {"snes_rtol": 1e-12})
    el = prob.interface
    hist = []

    def on_step(rec):
        tr, st = el.last.traction, el.state.old
        row = [rec.t]
        tols = [1e-9 * P] * 2 + [1e-9, 1e-9 * LAW.mu_s, 1e-6]
        for a, tol in zip((*tr.T, *st.up.T, st.mu, st.r), tols, strict=True):
            spread, value = global_spread(comm, a)
            assert spread <= tol, (rec.t, spread)
            row.append(value)
        hist.append(row)

    LoadStepper(solver, 0.125, control=StepControl(dt_max=0.125), on_step=on_step).run()
    solver.destroy()
    return np.array(hist)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_the_patch_test_refined_twice_equals_the_fine_mesh():
    comm = MPI.COMM_WORLD
    geometry = {"base_width": 1.0, "block_width": 1.0, "base_height": 0.5, "block_height": 0.5}
    coarse, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=1, **geometry
    )
    refined = meshing.refine_interface_mesh(coarse, 2)
    fine, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=4, **geometry
    )
    assert refined.num_interface_facets == fine.num_interface_facets == 4, (
        refined.num_interface_facets,
        fine.num_interface_facets,
    )
    a, b = patch_history(refined), patch_history(fine)
    assert a.shape == b.shape == (40, 6)
    np.testing.assert_allclose(a[:, 0], b[:, 0])
    scale = np.array([1.0, 300.0, 300.0, 1.0, LAW.mu_s, 1.0])
    np.testing.assert_allclose(a / scale, b / scale, rtol=0, atol=1e-8)
    assert a[:, 3].max() > 0.1  # it slid


@pytest.mark.leaves_validity(PenetrationWarning, reason=SOFT_GAP)
def test_the_regions_follow_the_refinement():
    comm = MPI.COMM_WORLD
    s = region_scene(name="refregions")
    s["mesh"]["options"]["n_interface"] = 4
    s["mesh"]["refine"] = 1
    res = run_scene(s, comm=comm)
    end = res.history[-1]
    for name, mu in {"default": 0.2, "rough": 0.5}.items():
        assert end[f"{name}.area"] == pytest.approx(0.5, rel=1e-12)
        assert abs(end[f"{name}.F_t1"]) == pytest.approx(mu * end[f"{name}.F_n"], rel=1e-9)
    snap = res.snapshots[2.0]
    x = snap["x"][:, 0]
    np.testing.assert_array_equal(snap["region"], np.where(x < 1.0, 1, 0))
    assert x.size == 8 * 2  # 8 elements (4 refined once), 2 Gauss points each


def demo_history(n, refine):
    s = small_scene(short=True)
    s["program"]["channels"]["slide"] = [0, 0, 0.15]  # within 3 elements at n = 16
    s["mesh"]["options"]["n_interface"] = n
    s["mesh"]["refine"] = refine
    s["solver"]["prefix"] = prefix("refdemo")
    res = run_scene(s, comm=MPI.COMM_WORLD)
    t = np.array([r["t"] for r in res.history])
    return t, np.array([[r["F_t1"], r["up_t1"]] for r in res.history])


def test_the_demo_refined_converges_with_the_directly_meshed_one():
    diffs = []
    for k in (1, 2):
        ta, a = demo_history(4, k)
        tb, b = demo_history(4 * 2**k, 0)
        np.testing.assert_allclose(ta, tb)
        scale = np.abs(b).max(axis=0)
        diffs.append(np.abs(a - b).max(axis=0) / scale)
    print("relative difference, refined vs meshed fine (F_t1, up_t1):", diffs)
    # both discretisations converge to the same solution: their difference shrinks
    assert np.all(diffs[1] < diffs[0] / 1.5), diffs
    assert np.all(diffs[1] < 1e-3), diffs


def test_what_cannot_be_refined_is_refused():
    comm = MPI.COMM_WORLD
    quad = meshing.read_interface_mesh(MESH_DIR / "block_on_base_quad.msh", comm, 2)
    with raised_on_every_rank(InterfaceMeshError, "triangles and tetrahedra only", "quadrilateral"):
        meshing.refine_interface_mesh(quad, 1)
    tri = meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", comm, 2)
    for bad in (-1, 9, 1.5, True):
        with raised_on_every_rank(InterfaceMeshError, "refine: expected an integer from 0 to 8"):
            meshing.refine_interface_mesh(tri, bad)
    if comm.size > 1:
        ghosted = meshing.read_interface_mesh(
            MESH_DIR / "block_on_base_tri.msh", comm, 2, ghost_mode=GhostMode.shared_facet
        )
        with raised_on_every_rank(InterfaceMeshError, "ghost cells", "ghost mode none"):
            meshing.refine_interface_mesh(ghosted, 1)
