"""Finite-sliding kinematics: the gap's derivative, objectivity of the slip and of the transport of
tangential state.

* The derivative of the local gap (convected slip and normal gap) through the projection's, against
  central differences (2-D P1/P2, 3-D triangles and quadrilaterals P1/P2, curved).
* A rigid motion of both bodies (rotation about any axis and translation) leaves the projection's
  reference coordinates unchanged: no slip, the same normal gap.
* The transport of tangential components: under a rigid rotation (spin about the normal included)
  the transported vectors are the rotated ones, whatever the frames (the fixed-axis frames of
  ``frames`` jump); lengths are kept; flat sliding without rotation is the identity.
"""

import basix
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from subfric_dolfinx.fem.interface.finite.projection import facet_basis, normal_projection
from subfric_dolfinx.fem.interface.finite.sliding import gap_operator, transport, transport_matrix
from subfric_dolfinx.fem.interface.geometry import frames
from tests.fem.interface.finite.test_contact_projection import polygon, sphere_facets

pytestmark = pytest.mark.numpy_only  # no MPI: one rank is enough

INTERVAL, TRIANGLE = basix.CellType.interval, basix.CellType.triangle
QUAD = basix.CellType.quadrilateral
R = 2.0
CASES = [(INTERVAL, 1), (INTERVAL, 2), (TRIANGLE, 1), (TRIANGLE, 2), (QUAD, 1), (QUAD, 2)]


def curved_case(cell, degree, seed=9):
    rng = np.random.default_rng(seed)
    if cell == INTERVAL:
        Y, N, _ = polygon(8, degree)
        Y = Y + 0.03 * rng.normal(size=Y.shape)
        phi = 2 * np.pi * (np.arange(8) + rng.uniform(0.2, 0.8, 8)) / 8
        x = R * 1.01 * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    else:
        Y, N, x, _ = sphere_facets(cell, degree, 8, seed=seed)
        Y = Y + 0.01 * rng.normal(size=Y.shape)
    return x, Y, N


def local_gap(x, Y, N, cell, degree, xi0, Q):
    """(Q_t . convected slip from xi0, ubar_n) at x for primary nodes Y."""
    pr = normal_projection(x, Y, N, cell, degree, xi0=xi0)
    y_new = np.einsum("mk,mkd->md", facet_basis(cell, degree, pr.xi)[0], Y)
    y_old = np.einsum("mk,mkd->md", facet_basis(cell, degree, xi0)[0], Y)
    nt = x.shape[1] - 1
    slip = np.einsum("mbd,md->mb", Q[:, :nt], y_new - y_old)
    return np.concatenate([slip, -pr.distance[:, None]], axis=1)


@pytest.mark.parametrize(("cell", "degree"), CASES)
def test_gap_operator_against_central_differences(cell, degree):
    x, Y, N = curved_case(cell, degree)
    pr = normal_projection(x, Y, N, cell, degree)
    assert pr.converged.all()
    Q = frames(pr.normal)
    G, Nl, _ = gap_operator(x, Y, N, cell, degree, pr.xi, pr.gamma, Q)
    rng = np.random.default_rng(10)
    dx, dY = rng.normal(size=x.shape), rng.normal(size=Y.shape)
    h = 1e-6
    fd = (
        local_gap(x + h * dx, Y + h * dY, N, cell, degree, pr.xi, Q)
        - local_gap(x - h * dx, Y - h * dY, N, cell, degree, pr.xi, Q)
    ) / (2 * h)
    an = np.einsum("mij,mj->mi", G, dx - np.einsum("mk,mkd->md", Nl, dY))
    np.testing.assert_allclose(fd, an, rtol=1e-6, atol=1e-7 * np.abs(an).max())


@pytest.mark.parametrize(("cell", "degree"), CASES)
def test_rigid_motion_gives_no_slip(cell, degree):
    x, Y, N = curved_case(cell, degree, seed=11)
    gdim = x.shape[1]
    pr = normal_projection(x, Y, N, cell, degree)
    if gdim == 2:
        a = 0.7
        Rm = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    else:
        Rm = Rotation.from_rotvec([0.3, -0.5, 0.9]).as_matrix()
    t = np.arange(1, gdim + 1) * 0.37
    moved = normal_projection(x @ Rm.T + t, Y @ Rm.T + t, N @ Rm.T, cell, degree, xi0=pr.xi)
    np.testing.assert_allclose(moved.xi, pr.xi, atol=1e-12)
    np.testing.assert_allclose(moved.distance, pr.distance, atol=1e-13)
    np.testing.assert_allclose(moved.normal, pr.normal @ Rm.T, atol=1e-13)


def test_transport_turns_normals_and_keeps_tangent_vectors():
    rng = np.random.default_rng(12)
    for gdim in (2, 3):
        a = rng.normal(size=(50, gdim))
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b = a + 0.5 * rng.normal(size=(50, gdim))
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        np.testing.assert_allclose(transport(a, a, b), b, atol=1e-14)
        v = rng.normal(size=(50, gdim))
        v -= np.einsum("md,md->m", v, a)[:, None] * a
        w = transport(v, a, b)
        np.testing.assert_allclose(np.einsum("md,md->m", w, b), 0.0, atol=1e-14)
        np.testing.assert_allclose(np.linalg.norm(w, axis=1), np.linalg.norm(v, axis=1))


def test_transported_state_rotates_with_a_rigid_rotation_in_3d():
    rng = np.random.default_rng(13)
    x, Y, N = curved_case(QUAD, 1, seed=14)
    pr = normal_projection(x, Y, N, QUAD, 1)
    Q_old = frames(pr.normal)
    B = facet_basis(QUAD, 1, pr.xi, 1)
    tangents = np.einsum("amk,mkd->mda", B[1:], Y)
    v = rng.normal(size=(x.shape[0], 2))  # tangential components in the old frames
    for rotvec in ([0.0, 0.0, 1.2], [0.4, -1.1, 0.3], [2.5, 0.2, -0.6]):
        Rm = Rotation.from_rotvec(rotvec).as_matrix()
        n_new = pr.normal @ Rm.T
        Q_new = frames(n_new)  # not Rm Q_old: the fixed-axis frames turn their own way
        T = transport_matrix(Q_old, Q_new, tangents, np.einsum("ij,mja->mia", Rm, tangents), n_new)
        got = np.einsum("mbd,mb->md", Q_new[:, :2], np.einsum("mij,mj->mi", T, v))
        want = np.einsum("mbd,mb->md", Q_old[:, :2], v) @ Rm.T
        np.testing.assert_allclose(got, want, atol=1e-13)
    # sliding on a flat surface without rotation: the identity; lengths kept when it stretches
    n = np.tile([0.0, 0.0, 1.0], (5, 1))
    Q = frames(n)
    flat = np.tile(np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]), (5, 1, 1))
    T = transport_matrix(Q, Q, flat, flat, n)
    np.testing.assert_allclose(T, np.tile(np.eye(2), (5, 1, 1)), atol=1e-15)
    T = transport_matrix(Q, Q, flat, flat * [[1.3, 1.0], [1.0, 0.8], [1, 1]], n)
    np.testing.assert_allclose(np.einsum("mki,mkj->mij", T, T), np.tile(np.eye(2), (5, 1, 1)))
    # 2-D: the one component is kept
    assert np.all(transport_matrix(np.zeros((4, 2, 2)), None, None, None, None) == 1.0)
