"""The cut of secondary facets by the primary facets they face, against exact integrals.

* 2-D, flat, non-matching (3 : 2 and random nodes, P1 and P2): the mortar integrals
  ``int N_s,k N_m,l`` equal those of an independent integration on the merged breakpoints of the
  two meshes; each secondary facet's weights sum to its length.
* 2-D, curved: a hub polygon on a shaft polygon (25 and 18 sides): the pieces tile every secondary
  facet and every point projects on its own primary facet.
* 3-D, flat, non-matching triangles on quadrilaterals and on triangles: the weights sum to each
  secondary facet's area, per primary facet to its area, and the points reproduce the integrals of
  quadratic polynomials and of the primary shape functions (linear reproduction).
* Matching facets give the facet's own Gauss rule.
* The transfer with a nodal rule (the exact facet mass: the dual basis) is the lumped element on
  matching facets and gives the primary the secondary's forces on non-matching ones.
* Clipping: areas of polygons cut by the reference triangle and square.
"""

import itertools

import basix
import numpy as np
import pytest

from subfric_dolfinx.fem.interface.finite.projection import facet_basis
from subfric_dolfinx.fem.interface.finite.segments import clip_to_reference, overlap_points

pytestmark = pytest.mark.numpy_only  # no MPI: one rank is enough

INTERVAL, TRIANGLE = basix.CellType.interval, basix.CellType.triangle
QUAD = basix.CellType.quadrilateral


def line_facets(xn, y, degree):
    F = []
    for a, b in itertools.pairwise(xn):
        pts = [a, b] + ([0.5 * (a + b)] if degree == 2 else [])
        F.append([[p, y] for p in pts])
    return np.array(F)


def mortar(seg, S, M, cell_s, cell_m, degree):
    """Matrix int N_s,k N_m,l over all facets (global node numbering: facet-major)."""
    nfd = S.shape[1]
    Ns = facet_basis(cell_s, degree, seg.xi_secondary)[0]
    Nm = facet_basis(cell_m, degree, seg.xi_primary)[0]
    A = np.zeros((S.shape[0], nfd, M.shape[0], M.shape[1]))
    prod = seg.weight[:, None, None] * Ns[:, :, None] * Nm[:, None, :]
    np.add.at(A, (seg.secondary, slice(None), seg.primary), prod)
    return A


def reference_mortar_1d(xs, xm, degree):
    """The same integrals by Gauss-Legendre on the merged breakpoints (x-coordinates)."""
    br = np.unique(np.concatenate([xs, xm]))
    br = br[(br >= max(xs[0], xm[0])) & (br <= min(xs[-1], xm[-1]))]
    X, w = np.polynomial.legendre.leggauss(6)
    A = np.zeros((xs.size - 1, degree + 1, xm.size - 1, degree + 1))
    for a, b in itertools.pairwise(br):
        x = 0.5 * (a + b) + 0.5 * (b - a) * X
        ww = 0.5 * (b - a) * w
        s = np.searchsorted(xs, 0.5 * (a + b)) - 1
        m = np.searchsorted(xm, 0.5 * (a + b)) - 1
        ts = (x - xs[s]) / (xs[s + 1] - xs[s])
        tm = (x - xm[m]) / (xm[m + 1] - xm[m])
        Ns = facet_basis(INTERVAL, degree, ts[:, None])[0]
        Nm = facet_basis(INTERVAL, degree, tm[:, None])[0]
        A[s, :, m, :] += np.einsum("q,qk,ql->kl", ww, Ns, Nm)
    return A


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("mesh", ["3:2", "random"])
def test_mortar_integrals_on_flat_non_matching_lines(degree, mesh):
    if mesh == "3:2":
        xs, xm = np.linspace(0, 1, 4), np.linspace(0, 1, 3)
    else:
        rng = np.random.default_rng(7)
        xs = np.sort(np.concatenate([[0, 1], rng.uniform(0, 1, 6)]))
        xm = np.sort(np.concatenate([[-0.3, 1.4], rng.uniform(-0.3, 1.4, 9)]))
    S = line_facets(xs, 0.002, degree)
    M = line_facets(xm, 0.0, degree)
    N = np.zeros_like(M)
    N[..., 1] = 1.0
    seg = overlap_points(S, INTERVAL, degree, M, N, INTERVAL, degree, 0.1)
    assert seg.converged.all()
    per_secondary = np.bincount(seg.secondary, seg.weight, S.shape[0])
    np.testing.assert_allclose(per_secondary, np.diff(xs), rtol=1e-13)
    A = mortar(seg, S, M, INTERVAL, INTERVAL, degree)
    np.testing.assert_allclose(A, reference_mortar_1d(xs, xm, degree), atol=1e-15)


def polygon_facets(n, radius, degree, phase=0.0):
    th = phase + 2 * np.pi * np.arange(n) / n
    ang = [th, th + 2 * np.pi / n] + ([th + np.pi / n] if degree == 2 else [])
    N = np.stack([np.stack([np.cos(a), np.sin(a)], axis=1) for a in ang], axis=1)
    return radius * N, N


@pytest.mark.parametrize("degree", [1, 2])
def test_pieces_tile_the_secondary_facets_of_a_hub_on_a_shaft(degree):
    M, N = polygon_facets(18, 1.0, degree)
    S, _ = polygon_facets(25, 1.0, degree, phase=0.1)
    S = S[:, [1, 0, 2][: S.shape[1]]] if degree == 2 else S[:, ::-1]  # the hub's orientation
    seg = overlap_points(S, INTERVAL, degree, M, N, INTERVAL, degree, 0.1)
    assert seg.converged.all()
    # every point projects on its own primary facet (the cut is exact in 2-D)
    assert np.all((seg.xi_primary > -1e-12) & (seg.xi_primary < 1 + 1e-12))
    # the weights sum to each secondary facet's length (its arc length for P2)
    X, w = basix.make_quadrature(INTERVAL, 8)
    B = facet_basis(INTERVAL, degree, X, 1)
    length = np.einsum("q,fq->f", w[:], np.linalg.norm(np.einsum("qk,fkd->fqd", B[1], S), axis=-1))
    # (P2: |y'| is not a polynomial, the pieces' rules and the 8-point rule differ a little)
    rtol = 1e-12 if degree == 1 else 1e-7
    np.testing.assert_allclose(
        np.bincount(seg.secondary, seg.weight, S.shape[0]), length, rtol=rtol
    )
    # each secondary facet meets one or two primary facets
    pairs = np.unique(seg.secondary * 100 + seg.primary)
    assert np.all(np.bincount(pairs // 100, minlength=25) <= 2)


def grid_facets(lo, hi, n, cell, z, jitter=0.0, seed=0):
    """Flat facets of a structured grid on z = const (triangles: two per square)."""
    rng = np.random.default_rng(seed)
    g = [np.linspace(lo[k], hi[k], n[k] + 1) for k in range(2)]
    P = np.stack(np.meshgrid(*g, indexing="ij"), axis=-1)
    inner = np.zeros(P.shape[:2], dtype=bool)
    inner[1:-1, 1:-1] = True
    P[inner] += jitter * rng.uniform(-1, 1, (inner.sum(), 2)) * (np.array(hi) - lo) / n
    F = []
    for i in range(n[0]):
        for j in range(n[1]):
            a, b, c, d = P[i, j], P[i + 1, j], P[i, j + 1], P[i + 1, j + 1]
            if cell == QUAD:
                F.append([a, b, c, d])
            else:
                F += [[a, b, d], [a, d, c]]
    F = np.array(F)
    return np.concatenate([F, np.full((*F.shape[:2], 1), z)], axis=-1)


def area(F, cell):
    X, w = basix.make_quadrature(cell, 4)
    B = facet_basis(cell, 1, X, 1)
    dy = np.einsum("aqk,fkd->fqda", B[1:], F)
    return np.linalg.norm(np.cross(dy[..., 0], dy[..., 1]), axis=-1) @ w


@pytest.mark.parametrize("primary_cell", [QUAD, TRIANGLE])
def test_cut_of_flat_non_matching_3d_facets(primary_cell):
    S = grid_facets((0, 0), (1, 1), (5, 4), TRIANGLE, 0.001, jitter=0.3, seed=1)
    M = grid_facets((-0.25, -0.3), (1.3, 1.2), (3, 4), primary_cell, 0.0, jitter=0.3, seed=2)
    N = np.zeros_like(M)
    N[..., 2] = 1.0
    seg = overlap_points(S, TRIANGLE, 1, M, N, primary_cell, 1, 0.1)
    assert seg.converged.all()
    per_secondary = np.bincount(seg.secondary, seg.weight, S.shape[0])
    np.testing.assert_allclose(per_secondary, area(S, TRIANGLE), rtol=1e-12)
    # primary facets wholly under the secondary square get their whole area
    Bm = facet_basis(primary_cell, 1, seg.xi_primary)[0]
    xm = np.einsum("pk,pkd->pd", Bm, M[seg.primary])
    inside = (M[..., :2] >= 0) & (M[..., :2] <= 1)
    under = np.all(inside, axis=(1, 2))
    per_primary = np.bincount(seg.primary, seg.weight, M.shape[0])
    np.testing.assert_allclose(per_primary[under], area(M, primary_cell)[under], rtol=1e-12)
    # quadratic polynomials over the unit square, evaluated at the primary projections
    x, y = xm[:, 0], xm[:, 1]
    cases = [(1.0 + 0 * x, 1.0), (x, 0.5), (x * y, 0.25), (y * y, 1 / 3), (x * x - y, -1 / 6)]
    for f, exact in cases:
        assert abs(np.sum(seg.weight * f) - exact) < 1e-13
    # the primary shape functions reproduce linear fields: sum_l (int N_m,l) x_l = int x
    Wl = np.zeros(M.shape[:2])
    np.add.at(Wl, seg.primary, seg.weight[:, None] * Bm)
    assert abs(np.sum(Wl * M[..., 0]) - 0.5) < 1e-13
    assert abs(np.sum(Wl * M[..., 1]) - 0.5) < 1e-13


@pytest.mark.parametrize(
    ("cell", "degree"), [(INTERVAL, 1), (INTERVAL, 2), (TRIANGLE, 1), (QUAD, 1)]
)
def test_matching_facets_give_the_facet_rule(cell, degree):
    if cell == INTERVAL:
        M = line_facets(np.linspace(0, 1, 5), 0.0, degree)
    else:
        M = grid_facets((0, 0), (1, 1), (3, 2), cell, 0.0, jitter=0.2)
    gdim = M.shape[2]
    N = np.zeros_like(M)
    N[..., gdim - 1] = 1.0
    seg = overlap_points(M.copy(), cell, degree, M, N, cell, degree, 0.1)
    assert np.array_equal(seg.secondary, seg.primary)
    np.testing.assert_allclose(seg.xi_primary, seg.xi_secondary, atol=1e-13)
    ref = area(M, cell) if cell != INTERVAL else np.diff(np.linspace(0, 1, 5))
    np.testing.assert_allclose(np.bincount(seg.secondary, seg.weight, M.shape[0]), ref, rtol=1e-13)


def test_clipping_areas():
    def poly_area(P, c):
        x, y = P[:c, 0], P[:c, 1]
        return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

    polys = np.array(
        [
            [[0.1, 0.1], [0.3, 0.1], [0.1, 0.3], [0, 0]],  # inside both
            [[-1, -1], [2, -1], [2, 2], [-1, 2]],  # covers both: the cell itself
            [[0.5, -0.5], [1.5, 0.5], [0.5, 0.5], [0, 0]],  # a triangle cut by x + y = 1 / x = 1
            [[2, 2], [3, 2], [2, 3], [0, 0]],  # outside
        ]
    )
    count = np.array([3, 4, 3, 3])
    tri, ct = clip_to_reference(polys, count, TRIANGLE)
    sq, cq = clip_to_reference(polys, count, QUAD)
    a_tri = [poly_area(tri[i], ct[i]) if ct[i] >= 3 else 0.0 for i in range(4)]
    a_sq = [poly_area(sq[i], cq[i]) if cq[i] >= 3 else 0.0 for i in range(4)]
    # the third: the part of the triangle (0.5,-0.5),(1.5,0.5),(0.5,0.5) in the cell
    np.testing.assert_allclose(a_tri, [0.02, 0.5, 0.125, 0.0], atol=1e-15)
    np.testing.assert_allclose(a_sq, [0.02, 1.0, 0.25, 0.0], atol=1e-15)


# --------------------------------------------------------------------------------------------
# Transfer of the secondary points' tractions to the primary nodes


def secondary_rule(S, cell, degree):
    """The secondary facets' own Gauss rule (degree 2p): points, basis, weights x Jacobian."""
    X, w = basix.make_quadrature(cell, 2 * degree)
    B = facet_basis(cell, degree, X, 1)
    dy = np.einsum("aqk,fkd->fqda", B[1:], S)
    if S.shape[2] == 2:
        jac = np.linalg.norm(dy[..., 0], axis=-1)
    else:
        jac = np.linalg.norm(np.cross(dy[..., 0], dy[..., 1]), axis=-1)
    x = np.einsum("qk,fkd->fqd", B[0], S)
    return B[0], jac * w, x


def primary_forces(tr, t, shape):
    F = np.zeros(shape)
    np.add.at(F, tr.primary, np.einsum("plq,pq->pl", tr.B, t[tr.secondary]))
    return F


@pytest.mark.parametrize("degree", [1, 2])
def test_transfer_of_uniform_and_linear_tractions_on_non_matching_lines(degree):
    from subfric_dolfinx.fem.interface.finite.transfer import l2_projector, transfer_matrices

    xs, xm = np.linspace(0, 1, 4), np.linspace(0, 1, 3)  # 3 : 2
    S, M = line_facets(xs, 0.0, degree), line_facets(xm, 0.0, degree)
    N = np.zeros_like(M)
    N[..., 1] = 1.0
    seg = overlap_points(S, INTERVAL, degree, M, N, INTERVAL, degree, 0.1)
    Nq, wq, xq = secondary_rule(S, INTERVAL, degree)
    P = l2_projector(Nq, wq)
    tr = transfer_matrices(seg, P, INTERVAL, degree, INTERVAL, degree)
    ref = reference_mortar_1d(xs, xm, degree)  # (s, k, m, l)
    # a uniform traction: the primary nodes get int N_m,l exactly
    F = primary_forces(tr, np.ones(wq.shape), M.shape[:2])
    np.testing.assert_allclose(F, ref.sum(axis=(0, 1)), atol=1e-15)
    # a linear traction t = 2 + 3 x: int t N_m,l, with t = sum_k t(x_k) N_s,k (exact for P1, P2)
    t_nodes = 2 + 3 * S[..., 0]
    F = primary_forces(tr, 2 + 3 * xq[..., 0], M.shape[:2])
    np.testing.assert_allclose(F, np.einsum("sk,skml->ml", t_nodes, ref), atol=1e-15)
    # the secondary nodes' forces are those of the points' own tractions, whatever they are
    t = np.random.default_rng(8).normal(size=wq.shape)
    lam = np.einsum("qk,fkj,fj->fq", Nq, P, t)
    np.testing.assert_allclose(
        np.einsum("fq,qk,fq->fk", wq, Nq, lam), np.einsum("fq,qk,fq->fk", wq, Nq, t), atol=1e-15
    )


@pytest.mark.parametrize(("cell", "degree"), [(INTERVAL, 1), (INTERVAL, 2), (TRIANGLE, 1)])
def test_transfer_on_matching_facets_is_the_matching_element(cell, degree):
    from subfric_dolfinx.fem.interface.finite.transfer import l2_projector, transfer_matrices

    if cell == INTERVAL:
        M = line_facets(np.linspace(0, 1, 5), 0.0, degree)
    else:
        M = grid_facets((0, 0), (1, 1), (3, 2), cell, 0.0, jitter=0.2)
    N = np.zeros_like(M)
    N[..., -1] = 1.0
    seg = overlap_points(M.copy(), cell, degree, M, N, cell, degree, 0.1)
    Nq, wq, _ = secondary_rule(M, cell, degree)
    tr = transfer_matrices(seg, l2_projector(Nq, wq), cell, degree, cell, degree)
    assert np.array_equal(tr.secondary, tr.primary) and tr.secondary.size == M.shape[0]
    np.testing.assert_allclose(tr.B, np.einsum("fq,ql->flq", wq[tr.secondary], Nq), atol=1e-15)


def nodal_rule(S, cell, degree):
    """The secondary facets' nodal (lumped) rule: basis at the nodes, weights x Jacobian, points."""
    from subfric_dolfinx.fem.interface.geometry import quadrature_rule

    X, w = quadrature_rule(cell, degree, "nodal")
    B = facet_basis(cell, degree, X, 1)
    dy = np.einsum("aqk,fkd->fqda", B[1:], S)
    if S.shape[2] == 2:
        jac = np.linalg.norm(dy[..., 0], axis=-1)
    else:
        jac = np.linalg.norm(np.cross(dy[..., 0], dy[..., 1]), axis=-1)
    return B[0], jac * w, np.einsum("qk,fkd->fqd", B[0], S)


@pytest.mark.parametrize(("cell", "degree"), [(INTERVAL, 1), (INTERVAL, 2), (TRIANGLE, 1)])
def test_nodal_rule_transfer_is_the_lumped_element_and_the_secondarys_forces(cell, degree):
    """With a nodal rule the primary nodes get what the secondary nodes get (the dual basis).

    The rule's own (lumped) mass made the transfer the consistent mass ``int N_q N_l``: on a
    matching interface not the lumped element of the secondary side, and on a non-matching one a
    field the secondary does not carry (the contact's edge of ``demos/hertz.py --meshed-apart``).
    """
    from subfric_dolfinx.fem.interface.finite.transfer import (
        facet_mass,
        l2_projector,
        transfer_matrices,
    )

    if cell == INTERVAL:
        M = line_facets(np.linspace(0, 1, 5), 0.0, degree)
    else:
        M = grid_facets((0, 0), (1, 1), (3, 2), cell, 0.0, jitter=0.2)
    N = np.zeros_like(M)
    N[..., -1] = 1.0
    Nq, wq, _ = nodal_rule(M, cell, degree)
    P = l2_projector(Nq, wq, facet_mass(cell, degree, M))
    seg = overlap_points(M.copy(), cell, degree, M, N, cell, degree, 0.1)
    tr = transfer_matrices(seg, P, cell, degree, cell, degree)
    assert np.array_equal(tr.secondary, tr.primary) and tr.secondary.size == M.shape[0]
    # matching: B_lq = w_q delta_lq (the nodes are the points)
    np.testing.assert_allclose(
        tr.B, np.einsum("fq,ql->flq", wq[tr.secondary], np.eye(Nq.shape[0])), atol=1e-14
    )
    if cell != INTERVAL:
        return
    # non-matching 3 : 2: the primary gets exactly int N_m t of a uniform traction, and of any
    # point values the moments the secondary gets: int lambda_h N_s,k = sum_q w_q N_k(q) t_q
    S = line_facets(np.linspace(0, 1, 4), 0.0, degree)
    Nq, wq, _ = nodal_rule(S, cell, degree)
    P = l2_projector(Nq, wq, facet_mass(cell, degree, S))
    seg = overlap_points(S, INTERVAL, degree, M, N, INTERVAL, degree, 0.1)
    tr = transfer_matrices(seg, P, INTERVAL, degree, INTERVAL, degree)
    ref = reference_mortar_1d(np.linspace(0, 1, 4), np.linspace(0, 1, 5), degree)
    F = primary_forces(tr, np.ones(wq.shape), M.shape[:2])
    np.testing.assert_allclose(F, ref.sum(axis=(0, 1)), atol=1e-14)
    t = np.random.default_rng(3).normal(size=wq.shape)
    lam = np.einsum("fkq,fq->fk", P, t)  # lambda_h's coefficients
    np.testing.assert_allclose(
        np.einsum("fj,fjk->fk", lam, facet_mass(cell, degree, S)),
        np.einsum("fq,qk,fq->fk", wq, Nq, t),
        atol=1e-14,
    )


def test_transfer_of_a_uniform_pressure_in_3d():
    from subfric_dolfinx.fem.interface.finite.transfer import l2_projector, transfer_matrices

    S = grid_facets((0, 0), (1, 1), (5, 4), TRIANGLE, 0.0, jitter=0.3, seed=1)
    M = grid_facets((-0.25, -0.3), (1.3, 1.2), (3, 4), QUAD, 0.0, jitter=0.3, seed=2)
    N = np.zeros_like(M)
    N[..., 2] = 1.0
    seg = overlap_points(S, TRIANGLE, 1, M, N, QUAD, 1, 0.1)
    Nq, wq, xq = secondary_rule(S, TRIANGLE, 1)
    tr = transfer_matrices(seg, l2_projector(Nq, wq), TRIANGLE, 1, QUAD, 1)
    F = primary_forces(tr, np.ones(wq.shape), M.shape[:2])
    assert abs(F.sum() - 1.0) < 1e-13  # the whole load arrives
    # and where it arrives: its first moments are those of the unit square
    assert abs(np.sum(F * M[..., 0]) - 0.5) < 1e-13 and abs(np.sum(F * M[..., 1]) - 0.5) < 1e-13
    # a linear pressure t = 1 + x - 2 y: total int t = 1 + 0.5 - 1, moment int t x = 0.5 + 1/3 - 0.5
    t = 1 + xq[..., 0] - 2 * xq[..., 1]
    F = primary_forces(tr, t, M.shape[:2])
    assert abs(F.sum() - 0.5) < 1e-13
    assert abs(np.sum(F * M[..., 0]) - (0.5 + 1 / 3 - 0.5)) < 1e-13
