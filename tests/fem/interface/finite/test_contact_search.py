"""The contact surface, its averaged nodal normals and the parallel search of the primary facets,
on independently meshed bodies (1 and 2 ranks).

* Nodal normals: radial on a polygon inscribed in a circle (outward on the shaft, inward on the
  hub), +-z on a plate and a block, also at nodes whose facets are on two ranks.
* A block slid along a long base by up to 8 times its width, across the partition boundary (2
  ranks: the base's halves on different ranks): every point finds its projection, which is the
  point right below it, and a rank receives only the base facets near its points.
* Parallel = serial: every rank's projections equal those of one process that has all points and
  all facets (gathered), for a hub turned and shrunk on a shaft and a block on a plate; the
  received facets carry the right nodes (global numbers, owners, positions).
"""

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.fem.interface.finite.search import exchange_facets, find_projections
from subfric_dolfinx.fem.interface.finite.surface import contact_surface, nodal_normals
from tests.contact_meshes import CONTACT, PRIMARY, SECONDARY, annuli, block_on_base, block_on_plate
from tests.helpers import everywhere

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)

COMM = MPI.COMM_WORLD


def space(bodies, degree):
    gdim = bodies.mesh.geometry.dim
    return dolfinx.fem.functionspace(bodies.mesh, ("Lagrange", degree, (gdim,)))


def surfaces(V, bodies):
    args = (V, bodies.cell_tags, bodies.facet_tags, CONTACT)
    return contact_surface(*args, PRIMARY), contact_surface(*args, SECONDARY)


def primary_data(V, ms, x):
    """What exchange_facets needs of this rank's primary facets, at node positions x."""
    imap = V.dofmap.index_map
    owners = np.concatenate([np.full(imap.size_local, COMM.rank), imap.owners]).astype(np.int32)
    nn = nodal_normals(ms, x, imap)
    glob = imap.local_to_global(ms.nodes.ravel()).reshape(ms.nodes.shape)
    return x[ms.nodes], nn[ms.nodes], glob, owners[ms.nodes], ms.global_facets


@pytest.mark.parametrize("degree", [1, 2])
def test_nodal_normals_are_radial_on_an_inscribed_polygon(degree):
    bodies = annuli(COMM, n_inner=14, n_outer=22, split_x=0.0)
    V = space(bodies, degree)
    ms, ss = surfaces(V, bodies)
    x = V.tabulate_dof_coordinates()[:, :2]
    ok = True
    for surf, sign in ((ms, 1.0), (ss, -1.0)):
        n = nodal_normals(surf, x, V.dofmap.index_map)
        nodes = np.unique(surf.nodes)
        radial = x[nodes] / np.linalg.norm(x[nodes], axis=1)[:, None]
        if degree == 1:  # at the vertices of the polygon: exactly radial
            ok &= bool(np.abs(n[nodes] - sign * radial).max(initial=0.0) < 1e-14)
        else:  # P2 mid-nodes lie on the chords: the normal of their chord
            ok &= bool(np.all(np.einsum("nd,nd->n", n[nodes], sign * radial) > np.cos(np.pi / 14)))
            ok &= bool(np.allclose(np.linalg.norm(n[nodes], axis=1), 1.0, atol=1e-14))
        # every node of the surface has a normal, nodes elsewhere none
        others = np.setdiff1d(np.arange(n.shape[0]), nodes)
        ok &= bool(np.all(n[others] == 0.0))
    n_tot = COMM.allreduce(ms.size), COMM.allreduce(ss.size)
    assert everywhere(COMM, ok)
    assert n_tot == (14, 22)


def test_nodal_normals_of_a_plate_and_a_block_in_3d():
    bodies = block_on_plate(COMM, split_x=2.0)
    V = space(bodies, 1)
    ms, ss = surfaces(V, bodies)
    x = V.tabulate_dof_coordinates()
    ok = True
    for surf, nz in ((ms, 1.0), (ss, -1.0)):
        n = nodal_normals(surf, x, V.dofmap.index_map)
        nodes = np.unique(surf.nodes)
        ok &= bool(np.abs(n[nodes] - [0.0, 0.0, nz]).max(initial=0.0) < 1e-14)
    assert everywhere(COMM, ok)
    assert COMM.allreduce(ms.size) == 2 * 8 * 4 and COMM.allreduce(ss.size) == 2 * 3 * 3


@pytest.mark.parametrize("degree", [1, 2])
def test_search_follows_a_block_sliding_along_a_long_base(degree):
    length, n_base, width, radius, depth = 10.0, 20, 1.0, 0.3, 0.01
    bodies = block_on_base(COMM, length=length, n_base=n_base, width=width, x0=0.5, split_x=5.0)
    V = space(bodies, degree)
    ms, ss = surfaces(V, bodies)
    x = V.tabulate_dof_coordinates()[:, :2]
    data = primary_data(V, ms, x)
    nodes = np.unique(ss.nodes)
    ok, received, sizes = True, 0, []
    for s in (0.0, 2.3, 4.4, 6.1, 8.0):  # up to 8 block widths, across x = 5
        pts = x[nodes] + [s, -depth]
        cand = exchange_facets(COMM, pts, ms.cell, ms.degree, *data, radius)
        pr = find_projections(pts, cand, radius)
        ok &= bool(pr.found.all())
        ok &= bool(np.abs(pr.point - pts * [1.0, 0.0]).max(initial=0.0) < 1e-14)
        ok &= bool(np.abs(pr.normal - [0.0, 1.0]).max(initial=0.0) < 1e-14)
        ok &= bool(np.abs(pr.distance + depth).max(initial=0.0) < 1e-14)
        # the facet found holds the point's x between its end nodes
        ends = cand.x[pr.facet][:, :2, 0]
        lo, hi = ends.min(axis=1, initial=np.inf), ends.max(axis=1, initial=-np.inf)
        ok &= bool(np.all((pts[:, 0] >= lo - 1e-14) & (pts[:, 0] <= hi + 1e-14)))
        received += cand.n_received
        sizes.append(cand.size)
    assert everywhere(COMM, ok)
    # locality: a rank with points gets the base facets under its box(es) only (the block spans
    # 2 base facets, the radius reaches one more on each side), never the whole base
    h = length / n_base
    most = int(np.ceil((width + 2 * radius) / h)) + 2
    has_points = nodes.size > 0
    assert everywhere(COMM, not has_points or max(sizes) <= most), (sizes, most)
    if COMM.size == 2:  # the block crossed into the other rank's half of the base
        assert COMM.allreduce(received) > 0


def gathered(arrays):
    return [np.concatenate(COMM.allgather(a)) for a in arrays]


@pytest.mark.parametrize(
    ("case", "degree"), [("annuli", 1), ("annuli", 2), ("plate", 1), ("plate", 2)]
)
def test_parallel_search_equals_the_serial_one(case, degree):
    if case == "annuli":
        bodies = annuli(COMM, n_inner=18, n_outer=25, split_x=0.1)
        radius = 0.2

        def move(p):  # the hub turned by 0.3 rad and shrunk onto the shaft
            c, s = np.cos(0.3), np.sin(0.3)
            return 0.997 * p @ np.array([[c, s], [-s, c]])
    else:
        bodies = block_on_plate(COMM, split_x=2.0)
        radius = 0.2

        def move(p):
            return p + np.array([1.3, 0.45, -0.01])

    V = space(bodies, degree)
    gdim = bodies.mesh.geometry.dim
    ms, ss = surfaces(V, bodies)
    x = V.tabulate_dof_coordinates()[:, :gdim]
    data = primary_data(V, ms, x)
    imap = V.dofmap.index_map
    nodes = np.unique(ss.nodes)
    nodes = nodes[nodes < imap.size_local]  # owned secondary nodes: each point on one rank
    pts = move(x[nodes])
    cand = exchange_facets(COMM, pts, ms.cell, ms.degree, *data, radius)
    pr = find_projections(pts, cand, radius)
    # serial: one process with every point and every facet
    all_pts = np.concatenate(COMM.allgather(pts))
    all_data = gathered(data)
    serial_cand = exchange_facets(MPI.COMM_SELF, all_pts, ms.cell, ms.degree, *all_data, radius)
    serial = find_projections(all_pts, serial_cand, radius)
    start = sum(COMM.allgather(pts.shape[0])[: COMM.rank])
    mine = slice(start, start + pts.shape[0])
    ok = bool(np.array_equal(pr.found, serial.found[mine]))
    f = pr.found
    for name in ("point", "normal", "distance"):
        a, b = getattr(pr, name)[f], getattr(serial, name)[mine][f]
        ok &= bool(np.abs(a - b).max(initial=0.0) < 1e-13)
    same = cand.global_facets[pr.facet[f]] == serial_cand.global_facets[serial.facet[mine][f]]
    ok &= bool(same.all())
    # the received facets carry their nodes' global numbers, owners and positions
    owned = np.arange(imap.size_local)
    table_g, table_x, table_o = gathered(
        [imap.local_to_global(owned), x[owned], np.full(owned.size, COMM.rank)]
    )
    order = np.argsort(table_g)
    k = order[np.searchsorted(table_g, cand.global_nodes.ravel(), sorter=order)]
    ok &= bool(np.array_equal(table_g[k], cand.global_nodes.ravel()))
    # (a node's coordinates on two ranks differ by round-off: DOLFINx tabulates them per cell)
    ok &= bool(np.abs(table_x[k] - cand.x.reshape(-1, gdim)).max(initial=0.0) < 1e-14)
    ok &= bool(np.array_equal(table_o[k], cand.owners.ravel()))
    assert everywhere(COMM, ok)
    assert COMM.allreduce(int(pr.found.sum())) == all_pts.shape[0]


@pytest.mark.parametrize("case", ["annuli", "plate"])
def test_parallel_segments_equal_the_serial_ones(case):
    """The cut of the secondary facets by the primary facets, made on each secondary facet's rank
    from its candidates, equals the cut of one process that has everything."""
    from subfric_dolfinx.fem.interface.finite.segments import overlap_points

    if case == "annuli":
        bodies = annuli(COMM, n_inner=18, n_outer=25, split_x=0.1)
        c, s = np.cos(0.3), np.sin(0.3)
        rot = np.array([[c, s], [-s, c]])

        def move(p):
            return 0.999 * p @ rot
    else:
        bodies = block_on_plate(COMM, split_x=2.0)

        def move(p):
            return p + np.array([1.3, 0.45, -0.01])

    radius = 0.2
    V = space(bodies, 1)
    gdim = bodies.mesh.geometry.dim
    ms, ss = surfaces(V, bodies)
    x = V.tabulate_dof_coordinates()[:, :gdim]
    data = primary_data(V, ms, x)
    secondary_x = move(x[ss.nodes])
    cand = exchange_facets(COMM, secondary_x.reshape(-1, gdim), ms.cell, 1, *data, radius)
    seg = overlap_points(secondary_x, ss.cell, 1, cand.x, cand.normals, ms.cell, 1, radius)

    def table(seg, secondary_ids, primary_ids):
        key = np.stack([secondary_ids[seg.secondary], primary_ids[seg.primary]], axis=1)
        rows = np.concatenate([key, seg.xi_secondary, seg.xi_primary, seg.weight[:, None]], axis=1)
        return rows[np.lexsort(rows.T[::-1])]

    mine = np.concatenate(COMM.allgather(table(seg, ss.global_facets, cand.global_facets)))
    mine = mine[np.lexsort(mine.T[::-1])]
    all_secondary = np.concatenate(COMM.allgather(secondary_x))
    all_ids = np.concatenate(COMM.allgather(ss.global_facets))
    all_data = gathered(data)
    serial = overlap_points(all_secondary, ss.cell, 1, all_data[0], all_data[1], ms.cell, 1, radius)
    ref = table(serial, all_ids, all_data[4])
    assert mine.shape == ref.shape
    np.testing.assert_allclose(mine, ref, atol=1e-13)
    # the pieces cover the whole hub / block bottom
    total = ref[:, -1].sum()
    expected = 25 * 2 * 0.999 * np.sin(np.pi / 25) if case == "annuli" else 1.0
    assert abs(total - expected) < 1e-12


def test_a_curved_mesh_gives_a_round_contact():
    """A shaft and a hub with degree-2 geometry (their contact facets are arcs through three
    points of the circle) and P2 displacements: the hub's nodes, turned and shrunk onto the shaft,
    project radially, at the distance to the circle within a small fraction of what the
    polygons of a straight-sided mesh give (their sag)."""
    errors = {}
    for degree in (1, 2):
        bodies = annuli(COMM, n_inner=12, n_outer=17, split_x=0.0, geometry_degree=degree)
        V = space(bodies, degree)
        ms, ss = surfaces(V, bodies)
        x = V.tabulate_dof_coordinates()[:, :2]
        data = primary_data(V, ms, x)
        nodes = np.unique(ss.nodes)
        c, s = np.cos(0.2), np.sin(0.2)
        pts = 0.997 * x[nodes] @ np.array([[c, s], [-s, c]])
        cand = exchange_facets(COMM, pts, ms.cell, ms.degree, *data, 0.1)
        pr = find_projections(pts, cand, 0.1)
        rho = np.linalg.norm(pts, axis=1)
        radial = pts / rho[:, None]
        ok = bool(pr.found.all())
        ok &= bool(np.abs(pr.normal - radial).max(initial=0.0) < 1e-13)
        assert everywhere(COMM, ok)
        err = np.abs(pr.distance - (rho - 1.0)).max(initial=0.0)
        errors[degree] = COMM.allreduce(err, op=MPI.MAX)
    sag = 1.0 - np.cos(np.pi / 12)  # the polygon's sag
    assert 0.3 * sag < errors[1] <= sag * (1 + 1e-12)
    print(f"distance to the circle: P1 {errors[1]:.3e}, P2 {errors[2]:.3e}, sag {sag:.3e}")
    assert errors[2] < 0.01 * sag, errors
