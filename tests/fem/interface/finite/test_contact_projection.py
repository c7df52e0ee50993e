"""Projection of points on contact facets against closed forms.

* A polygon (P1) or a chain of parabolic arcs (P2) inscribed in a circle, and triangles and
  quadrilaterals inscribed in a sphere, with radial nodal normals: the facet is ``y = R n~``, so the
  normal projection of a point is exactly radial (its normal is ``x / |x|``), its reference
  coordinates solve ``n~(xi) || x`` (closed form on a P1 segment and a P1 triangle) and its distance
  is ``|x| - R |n~(xi)|``.
* The closest point of a facet: the analytic clamp on a segment; on curved triangles and
  quadrilaterals no sample of a dense grid of the facet is nearer.
* Normal continuity: a point sweeping round the polygon sees its normal turn continuously (the
  facets' own normals jump by ``2 pi / n``).
* The derivative of the projection (for the consistent tangent) against central differences.
* Fallbacks: a hopeless start still converges; a point beyond its facet is found off it.
"""

import basix
import numpy as np
import pytest

from subfric_dolfinx.fem.interface.finite.closest import closest_point
from subfric_dolfinx.fem.interface.finite.projection import (
    facet_basis,
    normal_projection,
    projection_jacobian,
)
from subfric_dolfinx.fem.interface.finite.search import Candidates, find_projections

pytestmark = pytest.mark.numpy_only  # no MPI: one rank is enough

R = 2.0
INTERVAL, TRIANGLE = basix.CellType.interval, basix.CellType.triangle
QUAD = basix.CellType.quadrilateral


def polygon(n, degree):
    """Facets of a regular n-gon inscribed in the circle of radius R (P2: mid-nodes on the circle).

    Returns nodes (n, nfd, 2), unit radial nodal normals, the start angle of each facet.
    """
    th = 2 * np.pi * np.arange(n) / n
    ang = [th, th + 2 * np.pi / n] + ([th + np.pi / n] if degree == 2 else [])
    N = np.stack([np.stack([np.cos(a), np.sin(a)], axis=1) for a in ang], axis=1)
    return R * N, N, th


def points_round(m, spread, seed=0):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0, 2 * np.pi, m)
    rho = R * (1 + rng.uniform(-spread, spread, m))
    return phi, rho, rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)


@pytest.mark.parametrize("degree", [1, 2])
def test_normal_projection_on_circle_polygon_is_radial(degree):
    n = 12
    Y, N, th = polygon(n, degree)
    phi, rho, x = points_round(2000, 0.05)
    k = np.floor(phi / (2 * np.pi / n)).astype(int) % n
    pr = normal_projection(x, Y[k], N[k], INTERVAL, degree)
    assert pr.converged.all() and pr.inside.all()
    radial = x / rho[:, None]
    np.testing.assert_allclose(pr.normal, radial, atol=1e-14)
    # the projection is on the ray through x, on the facet
    cross = pr.point[:, 0] * radial[:, 1] - pr.point[:, 1] * radial[:, 0]
    np.testing.assert_allclose(cross, 0.0, atol=1e-13)
    B = facet_basis(INTERVAL, degree, pr.xi)[0]
    ntil = np.linalg.norm(np.einsum("mk,mkd->md", B, N[k]), axis=1)
    np.testing.assert_allclose(pr.distance, rho - R * ntil, atol=1e-13)
    if degree == 1:  # n~(xi) || x: xi = sin(phi - t0) / (sin(phi - t0) + sin(t1 - phi))
        a, b = np.sin(phi - th[k]), np.sin(th[k] + 2 * np.pi / n - phi)
        np.testing.assert_allclose(pr.xi[:, 0], a / (a + b), atol=1e-13)
    # the distance to the circle differs by the sag of the facet, at most R (1 - cos(pi / n))
    sag = np.abs(pr.distance - (rho - R))
    assert sag.max() <= R * (1 - np.cos(np.pi / n)) * (1 + 1e-12)
    if degree == 2:  # the parabolic arcs are far closer to the circle
        assert sag.max() < 0.02 * R * (1 - np.cos(np.pi / n))


def sphere_facets(cell, degree, m, seed=1, size=0.3):
    """m small facets inscribed in the sphere of radius R around random directions, with the
    nodes' radial unit normals; a point above each facet's centre region."""
    rng = np.random.default_rng(seed)
    e = basix.create_element(basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.gll_warped)
    P = e.points  # reference nodes (nfd, 2)
    c = rng.normal(size=(m, 3))
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    t1 = np.cross(c, rng.normal(size=(m, 3)))
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(c, t1)
    # a distorted map of the reference cell onto the tangent plane, then radially on the sphere
    A = size * (np.eye(2) + 0.2 * rng.uniform(-1, 1, size=(m, 2, 2)))
    d = np.einsum("mab,kb->mka", A, P - P.mean(axis=0))
    v = c[:, None, :] + d[..., :1] * t1[:, None, :] + d[..., 1:] * t2[:, None, :]
    N = v / np.linalg.norm(v, axis=-1, keepdims=True)
    # points: radial rays through random interior reference points of the P1 (vertex) facet
    xi = rng.uniform(0.1, 0.4, size=(m, 2)) if cell == TRIANGLE else rng.uniform(0.1, 0.9, (m, 2))
    nv = 3 if cell == TRIANGLE else 4
    B1 = facet_basis(cell, 1, xi)[0]
    ray = np.einsum("mk,mkd->md", B1, N[:, :nv])
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    rho = R * (1 + rng.uniform(-0.03, 0.03, m))
    return R * N, N, rho[:, None] * ray, rho


@pytest.mark.parametrize(("cell", "degree"), [(TRIANGLE, 1), (TRIANGLE, 2), (QUAD, 1), (QUAD, 2)])
def test_normal_projection_on_sphere_facets_is_radial(cell, degree):
    Y, N, x, rho = sphere_facets(cell, degree, 500)
    pr = normal_projection(x, Y, N, cell, degree)
    assert pr.converged.all()
    radial = x / rho[:, None]
    np.testing.assert_allclose(pr.normal, radial, atol=1e-13)
    B = facet_basis(cell, degree, pr.xi)[0]
    ntil = np.einsum("mk,mkd->md", B, N)
    np.testing.assert_allclose(pr.point, R * ntil, atol=1e-13)
    np.testing.assert_allclose(pr.distance, rho - R * np.linalg.norm(ntil, axis=1), atol=1e-13)
    if degree == 1 and cell == TRIANGLE:
        # n0 + xi_0 (n1 - n0) + xi_1 (n2 - n0) = s x / |x|: a 3 x 3 linear system per point
        M = np.stack([N[:, 1] - N[:, 0], N[:, 2] - N[:, 0], -radial], axis=-1)
        sol = np.linalg.solve(M, -N[:, 0][..., None])[..., 0]
        np.testing.assert_allclose(pr.xi, sol[:, :2], atol=1e-12)


def test_closest_point_on_segments_is_the_clamped_projection():
    rng = np.random.default_rng(2)
    Y = rng.normal(size=(400, 2, 2))
    x = rng.normal(size=(400, 2)) * 2
    cp = closest_point(x, Y, INTERVAL, 1)
    e = Y[:, 1] - Y[:, 0]
    t = np.clip(np.einsum("md,md->m", x - Y[:, 0], e) / np.einsum("md,md->m", e, e), 0, 1)
    np.testing.assert_allclose(cp.xi[:, 0], t, atol=1e-13)
    np.testing.assert_allclose(cp.distance, np.linalg.norm(x - Y[:, 0] - t[:, None] * e, axis=1))


@pytest.mark.parametrize(("cell", "degree"), [(TRIANGLE, 1), (TRIANGLE, 2), (QUAD, 1), (QUAD, 2)])
def test_closest_point_on_3d_facets_beats_a_dense_grid(cell, degree):
    rng = np.random.default_rng(3)
    m = 40
    Y, _, x, _ = sphere_facets(cell, degree, m, seed=4, size=0.6)
    # points in every direction around the facets: inside, off edges, off corners
    x = Y.mean(axis=1) + rng.normal(size=(m, 3)) * 0.5
    cp = closest_point(x, Y, cell, degree)
    g = np.linspace(0, 1, 161)
    G = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    if cell == TRIANGLE:
        G = G[G.sum(axis=1) <= 1 + 1e-12]
    B = facet_basis(cell, degree, G)[0]
    samples = np.einsum("gk,mkd->mgd", B, Y)
    d_grid = np.linalg.norm(samples - x[:, None, :], axis=-1).min(axis=1)
    assert np.all(cp.distance <= d_grid + 1e-12), (cp.distance - d_grid).max()
    assert np.all(cp.distance >= d_grid - 2e-3 * 0.6), (d_grid - cp.distance).max()
    yb = np.einsum("mk,mkd->md", facet_basis(cell, degree, cp.xi)[0], Y)
    np.testing.assert_allclose(np.linalg.norm(x - yb, axis=1), cp.distance, atol=1e-14)


def circle_candidates(n, degree):
    Y, N, _ = polygon(n, degree)
    nf = Y.shape[0]
    return Candidates(
        cell=INTERVAL,
        degree=degree,
        x=Y,
        normals=N,
        global_nodes=np.zeros((nf, Y.shape[1]), dtype=np.int64),
        owners=np.zeros((nf, Y.shape[1]), dtype=np.int32),
        global_facets=np.arange(nf),
        source=np.zeros(nf, dtype=np.int32),
        rank=0,
    )


@pytest.mark.parametrize("degree", [1, 2])
def test_normal_turns_continuously_across_facets(degree):
    n = 10
    cand = circle_candidates(n, degree)
    m = 4000
    phi = np.linspace(0, 2 * np.pi, m, endpoint=False) + 1e-3
    step = 2 * np.pi / m
    for rho in (0.97 * R, 1.03 * R):  # behind and in front of the surface
        x = rho * np.stack([np.cos(phi), np.sin(phi)], axis=1)
        pr = find_projections(x, cand, 0.2 * R)
        assert pr.found.all()
        cos = np.einsum("md,md->m", pr.normal, np.roll(pr.normal, -1, 0))
        turn = np.arccos(np.clip(cos, -1, 1))
        assert turn.max() <= step * (1 + 1e-6), turn.max() / step
        # the projected point moves continuously too (no jump at the vertices)
        move = np.linalg.norm(np.roll(pr.point, -1, 0) - pr.point, axis=1)
        # (on a chord inclined by up to pi / n to the circle's tangent)
        assert move.max() <= R * step / np.cos(np.pi / n) * 1.001
        # every facet is used: the points cross all vertices
        assert np.unique(pr.facet).size == n
    # the facets' own normals jump by 2 pi / n at a vertex
    t = cand.x[:, 1] - cand.x[:, 0]
    fn = np.stack([t[:, 1], -t[:, 0]], axis=1) / np.linalg.norm(t, axis=1)[:, None]
    jump = np.arccos(np.clip(np.einsum("md,md->m", fn, np.roll(fn, -1, 0)), -1, 1))
    np.testing.assert_allclose(jump, 2 * np.pi / n, rtol=1e-12)


CASES = [(INTERVAL, 1), (INTERVAL, 2), (TRIANGLE, 1), (TRIANGLE, 2), (QUAD, 1), (QUAD, 2)]


@pytest.mark.parametrize(("cell", "degree"), CASES)
def test_projection_jacobian_against_central_differences(cell, degree):
    rng = np.random.default_rng(5)
    if cell == INTERVAL:
        Y, N, _ = polygon(8, degree)
        Y = Y + 0.05 * rng.normal(size=Y.shape)  # a distorted, non-circular curve
        phi = 2 * np.pi * (np.arange(8) + rng.uniform(0.2, 0.8, 8)) / 8
        x = R * 1.02 * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    else:
        Y, N, x, _ = sphere_facets(cell, degree, 8, seed=6)
        Y = Y + 0.02 * rng.normal(size=Y.shape)
    pr = normal_projection(x, Y, N, cell, degree)
    assert pr.converged.all()
    Ainv, B = projection_jacobian(x, Y, N, cell, degree, pr.xi, pr.gamma)

    def z(xx, YY, NN):
        p = normal_projection(xx, YY, NN, cell, degree, xi0=pr.xi)
        return np.concatenate([p.xi, p.gamma[:, None]], axis=1)

    h = 1e-6
    dx, dY, dN = rng.normal(size=x.shape), rng.normal(size=Y.shape), rng.normal(size=N.shape)
    fd = (z(x + h * dx, Y + h * dY, N + h * dN) - z(x - h * dx, Y - h * dY, N - h * dN)) / (2 * h)
    rhs = dx - np.einsum("mk,mkd->md", B, dY + pr.gamma[:, None, None] * dN)
    an = np.einsum("mij,mj->mi", Ainv, rhs)
    np.testing.assert_allclose(fd, an, rtol=1e-6, atol=1e-7 * np.abs(an).max())


def test_fallbacks_bad_start_and_points_beyond_the_facet():
    Y, N, _ = polygon(6, 2)
    Y = Y[:1].repeat(3, axis=0)
    N = N[:1].repeat(3, axis=0)
    # a point over the middle of the arc, started far outside the reference interval and on the
    # wrong side: Newton from there is clipped and restarted
    x = np.array([[R * 1.01 * np.cos(np.pi / 6), R * 1.01 * np.sin(np.pi / 6)]] * 3)
    good = normal_projection(x, Y, N, INTERVAL, 2)
    bad = normal_projection(x, Y, N, INTERVAL, 2, xi0=np.array([[40.0], [-40.0], [np.nan]]))
    assert bad.converged.all() and bad.inside.all()
    np.testing.assert_allclose(bad.xi, good.xi, atol=1e-13)
    # a point beyond the end of the facet projects on its extension: found, not inside
    phi = 2 * np.pi / 6 + 0.2
    far = normal_projection(
        np.array([[R * np.cos(phi), R * np.sin(phi)]]), Y[:1], N[:1], INTERVAL, 2
    )
    assert far.converged.all() and not far.inside.any() and far.xi[0, 0] > 1.0
