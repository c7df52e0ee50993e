"""One function gathers interface values across ranks, in one order whatever the partition."""

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem.interface import InterfaceElements, pair_interface
from subfric_dolfinx.io import gather_interface, interface_order
from tests.helpers import everywhere, on_root

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)


def interface(comm, partitioner=None):
    dom, _ = meshing.create_interface_mesh(
        meshing.build_pad_on_plate,
        comm,
        partitioner=partitioner,
        plate_size=(1.0, 1.0, 0.5),
        pad_size=(1.0, 1.0, 0.5),
        n_interface=3,
        cell_type="hexahedron",
    )
    V = dolfinx.fem.functionspace(dom.mesh, ("Lagrange", 1, (3,)))
    t = dom.tags
    pairs = pair_interface(
        V, dom.cell_tags, dom.facet_tags, t["interface"], t["primary"], t["secondary"]
    )
    return InterfaceElements(pairs, V, preset("sec7"))


def test_the_order_is_by_rounded_coordinates():
    """Points whose coordinates differ in the last bits (the same Gauss point computed on two
    partitions) sort row by row, as the exact points do."""
    rng = np.random.default_rng(3)
    g = np.array([0.5 - 0.5 / np.sqrt(3), 0.5 + 0.5 / np.sqrt(3)])
    exact = np.array([[x + i, y + j] for i in range(3) for j in range(3) for x in g for y in g])
    noisy = exact * (1.0 + rng.choice([-2, -1, 0, 1, 2], exact.shape) * np.finfo(float).eps)
    perm = rng.permutation(len(exact))
    order = interface_order(noisy[perm], 1e-6)
    np.testing.assert_array_equal(perm[order], np.lexsort(exact.T[::-1]))
    # plain sorting of the noisy floats would not give that order
    assert not np.array_equal(perm[np.lexsort(noisy[perm].T[::-1])], np.lexsort(exact.T[::-1]))


def test_one_and_two_ranks_give_the_same_rows():
    comm = MPI.COMM_WORLD
    el = interface(comm, "bodies" if comm.size > 1 else None)
    values = {"x2": el.points.reshape(-1, 3) ** 2, "id": np.full(el.n_elements * el.nq, comm.rank)}
    every = gather_interface(el, values)
    at_root = gather_interface(el, values, root=0)
    n = comm.allreduce(el.n_elements * el.nq)
    assert every["x"].shape == (n, 3) and every["x2"].shape == (n, 3) and every["id"].shape == (n,)
    np.testing.assert_array_equal(every["x2"], every["x"] ** 2)  # values travel with their point
    assert everywhere(comm, (at_root is None) == (comm.rank != 0))

    def compare_with_a_serial_gather():
        np.testing.assert_array_equal(at_root["x"], every["x"])
        serial = gather_interface(interface(MPI.COMM_SELF), {})
        np.testing.assert_allclose(serial["x"], every["x"], rtol=0, atol=1e-14)

    on_root(comm, compare_with_a_serial_gather)
