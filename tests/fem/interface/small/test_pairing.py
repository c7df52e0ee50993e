"""The interface pairing: the same pairs as the all-gather pairing it replaced, with an exchange
that follows each rank's own interface (1 and 2 ranks).

The reference is the pairing as it was on main (``tests/reference_pairing.py``: every rank
all-gathers the secondary side and matches it with Python loops). The package's pairing must give
exactly the same result on every rank: the same primary facets in the same (submesh) order, the
same node points, primary and secondary nodes, the same extra ghosts in the same order with the same
owners, the same split count and facet size. Both are run on the same mesh and partition.
"""

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.compat import adjacency_list, geometry_dofmap
from subfric_dolfinx.fem.interface import InterfaceError, match_points, pair_interface
from subfric_dolfinx.meshing.partitioners import _gmsh_node_data
from tests import reference_pairing
from tests.helpers import MESH_DIR, everywhere, raised_on_every_rank

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)


def build(comm, gdim, cell_type, partitioner, **options):
    if gdim == 2:
        dom, _ = meshing.create_interface_mesh(
            meshing.build_block_on_base,
            comm,
            partitioner=partitioner,
            cell_type=cell_type,
            **{"n_interface": 6, **options},
        )
    else:
        dom, _ = meshing.create_interface_mesh(
            meshing.build_pad_on_plate,
            comm,
            partitioner=partitioner,
            cell_type=cell_type,
            **{"n_interface": 3, **options},
        )
    return dom


def pair(pairing, dom, degree):
    V = dolfinx.fem.functionspace(dom.mesh, ("Lagrange", degree, (dom.gdim,)))
    t = dom.tags
    return pairing(V, dom.cell_tags, dom.facet_tags, t["interface"], t["primary"], t["secondary"])


def differences(new, old) -> list[str]:
    """Names of the fields in which two pairings of this rank differ (empty: identical)."""
    bad = []
    for name in ("facets", "primary_cells", "reference_nodes", "primary_nodes", "secondary_nodes"):
        a, b = getattr(new, name), getattr(old, name)
        if a.shape != b.shape or not np.array_equal(a, b):
            bad.append(name)
    if not np.array_equal(new.node_points, old.node_points):
        bad.append("node_points")
    for name in ("n_extra_ghosts", "n_split", "h_min"):
        if getattr(new, name) != getattr(old, name):
            bad.append(name)
    a, b = new.index_map, old.index_map
    if a.size_local != b.size_local or not np.array_equal(a.ghosts, b.ghosts):
        bad.append("index_map.ghosts")
    if not np.array_equal(a.owners, b.owners):
        bad.append("index_map.owners")
    xa = new.submesh.geometry.x[geometry_dofmap(new.submesh)]
    xb = old.submesh.geometry.x[geometry_dofmap(old.submesh)]
    if not np.array_equal(xa, xb):
        bad.append("submesh")
    return bad


CASES = [
    # gdim, cell, degree, partitioner, builder options
    (2, "triangle", 1, "default", {}),
    (2, "quadrilateral", 1, "bodies", {}),
    (2, "triangle", 2, "together", {"block_x": 0.2}),
    (3, "hexahedron", 1, "default", {}),
    (3, "hexahedron", 1, "bodies", {}),
    (3, "tetrahedron", 1, "together", {}),
    (3, "tetrahedron", 2, "default", {"n_interface": 2}),
]


@pytest.mark.parametrize(("gdim", "cell_type", "degree", "kind", "options"), CASES)
def test_same_pairs_as_the_all_gather_pairing(gdim, cell_type, degree, kind, options):
    comm = MPI.COMM_WORLD
    dom = build(comm, gdim, cell_type, kind, **options)
    new = pair(pair_interface, dom, degree)
    old = pair(reference_pairing.pair_interface, dom, degree)
    bad = differences(new, old)
    assert everywhere(comm, not bad), bad
    n = comm.allreduce(new.facets.size)
    assert n == dom.num_interface_facets > 0
    if comm.size > 1 and kind == "bodies":  # every pair straddles the ranks
        assert comm.allreduce(new.n_split) == n


def interface_on_rank_0(x_cut):
    """A partitioner putting every cell whose centroid has x < ``x_cut`` on rank 0 and the others
    on the last rank."""

    def partition(comm, nparts, cell_types, cells):
        nv = dolfinx.cpp.mesh.cell_num_entities(cell_types[0], 0)
        conn = np.asarray(cells[0], dtype=np.int64).reshape(-1, nv)
        owner = np.zeros(conn.shape[0], dtype=np.int32)
        if conn.shape[0] and nparts > 1:
            _, x, _ = _gmsh_node_data(dolfinx.mesh.cell_dim(cell_types[0]), {}, [])
            owner[x[conn, 0].mean(axis=1) >= x_cut] = nparts - 1
        return adjacency_list(owner.reshape(-1, 1))

    return partition


@pytest.mark.parametrize("cell_type", ["hexahedron", "tetrahedron"])
def test_a_rank_without_interface_receives_nothing(cell_type):
    """The pad at one end of a long plate, the cells near it on rank 0, the rest of the plate on
    the last rank: that rank has no interface facet and receives no secondary facet (the all-gather
    pairing sent it the whole secondary side), and rank 0 has both sides and receives nothing either
    (on 3 ranks the middle one holds no cell at all, and receives nothing)."""
    comm = MPI.COMM_WORLD
    dom = build(
        comm,
        3,
        cell_type,
        interface_on_rank_0(1.5),
        plate_size=(4.0, 1.0, 0.5),
        pad_size=(1.0, 1.0, 0.5),
        pad_origin=(0.0, 0.0),
        n_interface=4,
    )
    new = pair(pair_interface, dom, 1)
    n = comm.allreduce(new.facets.size)
    assert n == dom.num_interface_facets > 0
    mine = comm.allgather(new.facets.size)
    assert mine[0] == n  # the whole interface on rank 0 ...
    cells = comm.allgather(dom.mesh.topology.index_map(3).size_local)
    assert cells[0] > 0 and cells[-1] > 0  # ... and the last rank holds the rest of the plate
    assert comm.allgather(new.n_received) == [0] * comm.size
    assert comm.allreduce(new.n_split) == 0
    old = pair(reference_pairing.pair_interface, dom, 1)
    bad = differences(new, old)
    assert everywhere(comm, not bad), bad


@pytest.mark.parametrize("kind", ["bodies", "together"])
def test_what_each_rank_receives_is_its_own_interface(kind):
    """ "bodies" (primaries on rank 0, secondaries on rank 1): rank 0 receives exactly the
    secondary facets of its primary facets, rank 1 (no primary facet) nothing. "together" (each
    pair on one rank): no rank receives anything, though each has half the interface."""
    comm = MPI.COMM_WORLD
    dom = build(comm, 3, "hexahedron", kind, n_interface=6)
    new = pair(pair_interface, dom, 1)
    received = comm.allgather(new.n_received)
    primaries = comm.allgather(new.facets.size)
    if kind == "bodies" and comm.size > 1:
        assert received == [primaries[0], *[0] * (comm.size - 1)]
        assert primaries[0] == dom.num_interface_facets
    else:
        assert received == [0] * comm.size
        assert min(primaries) > 0


def test_the_same_error_as_the_all_gather_pairing():
    """Sides with equal facet counts whose nodes are at different places (the count mismatch is
    refused by the reader already)."""
    comm = MPI.COMM_WORLD
    dom = meshing.read_interface_mesh(MESH_DIR / "broken_mismatch_coords.msh", comm, 2)
    messages = []
    for pairing in (reference_pairing.pair_interface, pair_interface):
        with raised_on_every_rank(InterfaceError, "do not pair node to node"):
            try:
                pair(pairing, dom, 1)
            except InterfaceError as e:
                messages.append(str(e))
                raise
    assert messages[0] == messages[1]


def test_undivided_nodes_are_refused_on_every_rank_also_where_one_rank_holds_them():
    """An interface group of facets between two cells of one body-split mesh (nodes not
    duplicated) is refused with one message on every rank; the group's facets tagged on one rank
    only (the one owning most of them), so the other ranks hold none: the message's count is
    reduced on every rank."""
    comm = MPI.COMM_WORLD
    mesh = dolfinx.mesh.create_unit_square(
        comm, 4, 4, ghost_mode=dolfinx.mesh.GhostMode.shared_facet
    )
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    ncells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = np.arange(ncells, dtype=np.int32)
    left = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, 0] < 0.5
    cell_tags = dolfinx.mesh.meshtags(mesh, tdim, cells, np.where(left, 1, 2).astype(np.int32))
    middle = dolfinx.mesh.locate_entities(mesh, tdim - 1, lambda x: np.isclose(x[0], 0.5))
    middle = middle[middle < mesh.topology.index_map(tdim - 1).size_local]
    holder = int(np.argmax(comm.allgather(middle.size)))
    tagged = middle if comm.rank == holder else np.zeros(0, dtype=np.int32)
    facet_tags = dolfinx.mesh.meshtags(
        mesh, tdim - 1, tagged, np.full(tagged.size, 3, dtype=np.int32)
    )
    with raised_on_every_rank(
        InterfaceError,
        f"{comm.allreduce(tagged.size)} interface facets have 2 adjacent cells",
        "the interface nodes are not duplicated",
    ):
        pair_interface(V, cell_tags, facet_tags, 3, 1, 2)


@pytest.mark.parametrize("dim", [2, 3])
def test_match_points_agrees_with_the_grid_hash(dim):
    """The k-d tree ``match_points`` (also used to restore checkpoints) finds what the grid hash
    with Python loops found: the nearest key within the tolerance, or none."""
    rng = np.random.default_rng(dim)
    keys = rng.random((500, dim))
    near = keys[rng.choice(500, 300)] + rng.normal(0.0, 2e-4, (300, dim))
    queries = np.concatenate([near, rng.random((200, dim))])
    for tol in (1e-4, 5e-4, 3e-2):
        new, dnew = match_points(keys, queries, tol)
        old, dold = reference_pairing.match_points(keys, queries, tol)
        np.testing.assert_array_equal(new, old)
        np.testing.assert_allclose(dnew, dold, rtol=1e-14)
        assert 0 < np.count_nonzero(new >= 0) < len(queries)
    empty = match_points(keys[:0], queries, 1.0)
    assert np.all(empty[0] == -1) and np.all(np.isinf(empty[1]))
