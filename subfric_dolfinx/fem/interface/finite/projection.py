"""Projection of points onto the facets of a contact surface, vectorised over point-facet pairs.

A facet of a contact surface is the Lagrange interpolation of its ``nfd`` nodes (degree 1 or 2:
segments in 2-D, triangles and quadrilaterals in 3-D; ``y(xi) = sum_k N_k(xi) y_k``), and carries a
smooth normal field interpolated from unit nodal normals ``n_k`` (:mod:`.surface` averages them
over the facets around each node): ``n~(xi) = sum_k N_k(xi) n_k``, unnormalised.

Two projections of a point ``x`` (``docs/model.md`` §11):

* :func:`normal_projection`, the one contact uses: the point ``y(xi)`` of the facet whose smooth
  normal passes through ``x``, ``x = y(xi) + gamma n~(xi)``. Neighbouring facets share the nodal
  normals, so the map from ``x`` to the surface is continuous across facets (no point projects on
  two facets, none on no facet, near a convex or a concave vertex alike), and the gap
  ``x - y`` is along the smooth normal, so an interference on a curved surface gives no
  tangential gap. On a flat surface it is the closest-point projection.
* :func:`.closest.closest_point`: the point of the facet (its boundary included) nearest to
  ``x``, the classical definition.

Both are solved by Newton's method on the facet's reference coordinates, all pairs at once, with
fallbacks where Newton fails (a closed form for straight segments, restarts from a lattice of
reference points). :func:`projection_jacobian` gives the derivative of ``(xi, gamma)`` with respect
to the point and the facet's nodes, for the consistent tangent.

Pure numpy and basix (no MPI, no mesh): the parallel search is :mod:`.search`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import cast

import basix
import numpy as np

__all__ = [
    "SINGULAR",
    "FacetProjection",
    "clip_reference",
    "facet_basis",
    "facet_geometry",
    "facet_size",
    "inside_reference",
    "lagrange_element",
    "normal_projection",
    "parametric_normal",
    "planar_start",
    "projection_jacobian",
    "ray_start",
    "reference_vertices",
]

SINGULAR = 1e-14
"""A Newton system whose determinant is below this (relative) is singular: the iteration stops."""


def _det_small(A: np.ndarray) -> np.ndarray:
    """Determinants of a stack of 2 x 2 or 3 x 3 matrices, (m,), written out.

    ``np.linalg.det`` goes through an LU factorisation per matrix: for the thousands of tiny
    systems of a projection the written-out cofactors are several times faster.
    """
    if A.shape[-1] == 2:
        return A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    return (
        A[:, 0, 0] * (A[:, 1, 1] * A[:, 2, 2] - A[:, 1, 2] * A[:, 2, 1])
        - A[:, 0, 1] * (A[:, 1, 0] * A[:, 2, 2] - A[:, 1, 2] * A[:, 2, 0])
        + A[:, 0, 2] * (A[:, 1, 0] * A[:, 2, 1] - A[:, 1, 1] * A[:, 2, 0])
    )


def _solve_small(A: np.ndarray, b: np.ndarray, det: np.ndarray) -> np.ndarray:
    """``A^-1 b`` for a stack of regular 2 x 2 or 3 x 3 matrices (Cramer's rule), (m, d).

    ``det`` is :func:`_det_small` of ``A`` (non-zero).
    """
    if A.shape[-1] == 2:
        x0 = b[:, 0] * A[:, 1, 1] - A[:, 0, 1] * b[:, 1]
        x1 = A[:, 0, 0] * b[:, 1] - b[:, 0] * A[:, 1, 0]
        return np.stack([x0, x1], axis=1) / det[:, None]
    out = np.empty(b.shape)
    for j in range(3):
        Aj = A.copy()
        Aj[:, :, j] = b
        out[:, j] = _det_small(Aj)
    return out / det[:, None]


@functools.cache
def lagrange_element(cell: basix.CellType, degree: int) -> basix.finite_element.FiniteElement:
    """The facets' Lagrange element of ``degree`` on ``cell`` (GLL-warped points, cached)."""
    return basix.create_element(
        basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.gll_warped
    )


def facet_basis(cell: basix.CellType, degree: int, xi: np.ndarray, nderiv: int = 0) -> np.ndarray:
    """The facet Lagrange basis at reference points ``xi`` (m, fdim).

    Returns:
        (1 + fdim * (nderiv > 0) [+ second derivatives], m, nfd): values, then the first
        derivatives along each reference direction (basix's order), then the second ones if
        ``nderiv == 2``; no points give an empty array of that shape (basix wants points).
    """
    e = lagrange_element(cell, degree)
    xi = np.ascontiguousarray(xi, dtype=float)
    if xi.shape[0] == 0:
        fdim = len(basix.topology(cell)) - 1
        count = math.comb(fdim + nderiv, nderiv)
        return np.zeros((count, 0, e.dim))
    return cast(np.ndarray, e.tabulate(nderiv, xi))[..., 0]  # (basix annotates an ArrayLike)


def reference_vertices(cell: basix.CellType) -> np.ndarray:
    """The vertices of the reference ``cell``, (nv, fdim)."""
    return np.asarray(basix.geometry(cell), dtype=float)


def inside_reference(cell: basix.CellType, xi: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    """Whether reference points ``xi`` (m, fdim) lie in the reference cell (grown by ``tol``)."""
    if cell == basix.CellType.triangle:
        return (xi[:, 0] >= -tol) & (xi[:, 1] >= -tol) & (xi.sum(axis=1) <= 1.0 + tol)
    return np.all((xi >= -tol) & (xi <= 1.0 + tol), axis=1)


def clip_reference(cell: basix.CellType, xi: np.ndarray, margin: float) -> np.ndarray:
    """Keep Newton iterates within ``margin`` of the reference cell (a box, or the triangle's)."""
    out = np.clip(xi, -margin, 1.0 + margin)
    if cell == basix.CellType.triangle:
        s = out.sum(axis=1)
        over = s > 1.0 + margin
        out[over] *= ((1.0 + margin) / s[over])[:, None]
    return out


@dataclasses.dataclass
class FacetProjection:
    """Projections of ``m`` points, each on its own facet.

    Attributes:
        xi: Reference coordinates of the projection, (m, fdim).
        point: The projection ``y(xi)``, (m, gdim).
        normal: Unit smooth normal at the projection, (m, gdim) (:func:`normal_projection`), or
            the unit vector from the projection to the point (:func:`closest_point`; the facet
            normal where the point is on the facet).
        distance: Signed distance ``(x - y) . normal`` (> 0 on the side the normals point to).
        gamma: The coefficient of the unnormalised normal, ``x = y + gamma n~`` (normal
            projection; the distance for the closest point).
        converged: Whether the projection was found (to round-off).
        inside: Whether ``xi`` lies in the reference cell (within the tolerance given).
    """

    xi: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    gamma: np.ndarray
    converged: np.ndarray
    inside: np.ndarray


def facet_geometry(
    cell: basix.CellType,
    degree: int,
    Y: np.ndarray,
    Nn: np.ndarray | None,
    xi: np.ndarray,
    nderiv: int,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """Position, normal field and their first derivatives at ``xi`` on each pair's facet.

    The derivatives are ``None`` for ``nderiv`` 0, the normal field's without ``Nn``.
    """
    B = facet_basis(cell, degree, xi, nderiv)
    if not nderiv:
        y = np.einsum("mk,mkd->md", B[0], Y)
        n = np.einsum("mk,mkd->md", B[0], Nn) if Nn is not None else None
        return y, None, n, None
    Bt = B.transpose(1, 0, 2)  # (m, 1 + fdim, nfd): values and derivatives per point
    V = np.matmul(Bt, Y)
    y, dy = V[:, 0], V[:, 1:].transpose(0, 2, 1)  # (m, gdim), (m, gdim, fdim)
    if Nn is None:
        return y, dy, None, None
    W = np.matmul(Bt, Nn)
    return y, dy, W[:, 0], W[:, 1:].transpose(0, 2, 1)


def facet_size(Y: np.ndarray) -> np.ndarray:
    """A facet's size: the distance between its first two (vertex) nodes."""
    return np.linalg.norm(Y[:, 1] - Y[:, 0], axis=-1)


def _segment_start(x: np.ndarray, Y: np.ndarray, Nn: np.ndarray) -> np.ndarray:
    """The normal projection on the straight chord of a segment (end nodes 0 and 1), exactly.

    With ``y = Y0 + s e`` and ``n~ = n0 + s dn``, ``(x - y) x n~ = 0`` is the quadratic
    ``a + b s + c s^2 = 0``; of its real roots the one nearest to ``[0, 1]`` is taken (0.5 if
    none).
    """

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    r = x - Y[:, 0]
    e = Y[:, 1] - Y[:, 0]
    dn = Nn[:, 1] - Nn[:, 0]
    a = cross(r, Nn[:, 0])
    b = cross(r, dn) - cross(e, Nn[:, 0])
    c = -cross(e, dn)
    scale = np.abs(a) + np.abs(b) + np.abs(c) + 1e-300
    s = np.full(x.shape[0], 0.5)
    lin = np.abs(c) <= 1e-12 * scale
    ok = lin & (np.abs(b) > 1e-14 * scale)
    s[ok] = -a[ok] / b[ok]
    quad = ~lin
    disc = b**2 - 4 * a * c
    real = quad & (disc >= 0)
    if np.any(real):
        sq = np.sqrt(disc[real])
        bb = b[real]
        # numerically stable pair of roots
        qq = -0.5 * (bb + np.copysign(sq, bb))
        r1 = np.where(qq != 0, qq / c[real], 0.5)
        r2 = np.where(qq != 0, a[real] / np.where(qq != 0, qq, 1.0), 0.5)

        def off(t):
            return np.maximum(np.maximum(-t, t - 1.0), 0.0) + 1e-3 * np.abs(t - 0.5)

        s[real] = np.where(off(r1) <= off(r2), r1, r2)
    return s[:, None]


def ray_start(cell: basix.CellType, x: np.ndarray, Y: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Where the lines ``x + s n`` meet the line (plane) of each facet's vertex nodes 0, 1 (, 2).

    Reference coordinates of the affine map of those vertices: the exact preimage on straight
    segments, flat triangles and parallelograms; a start for Newton on the others.
    """
    m, gdim = x.shape
    fdim = gdim - 1
    P0 = Y[:, 0]
    A = np.empty((m, gdim, gdim))
    for a in range(fdim):
        A[:, :, a] = Y[:, 1 + a] - P0
    A[:, :, fdim] = -n
    det = _det_small(A)
    good = np.abs(det) > 1e-300
    lam = np.full((m, gdim), 0.5)
    if np.any(good):
        lam[good] = _solve_small(A[good], (x - P0)[good], det[good])
    return lam[:, :fdim]


def planar_start(cell: basix.CellType, x: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Reference coordinates of the closest point of the facet's vertex plane (a Newton start).

    The plane (line) through the nodes of the reference vertices 0, 1 (and 2), with the affine
    map of those vertices.
    """
    V = reference_vertices(cell)
    fdim = V.shape[1]
    # affine map from vertices 0, 1 and (2-D) 2 of the reference cell
    P0 = Y[:, 0]
    E = np.stack([Y[:, 1 + a] - P0 for a in range(fdim)], axis=-1)  # (m, gdim, fdim)
    G = np.einsum("mda,mdb->mab", E, E)
    rhs = np.einsum("mda,md->ma", E, x - P0)
    det = np.linalg.det(G)
    good = np.abs(det) > 1e-300
    lam = np.full((x.shape[0], fdim), 1.0 / (fdim + 1))
    if np.any(good):
        lam[good] = np.linalg.solve(G[good], rhs[good][..., None])[..., 0]
    # reference vertices 1..fdim minus vertex 0 are the unit vectors for all three cells
    return V[0] + lam


def normal_projection(
    x: np.ndarray,
    Y: np.ndarray,
    Nn: np.ndarray,
    cell: basix.CellType,
    degree: int,
    *,
    xi0: np.ndarray | None = None,
    inside_tol: float = 1e-10,
    maxit: int = 30,
    margin: float = 2.0,
) -> FacetProjection:
    """Project each point along the facet's smooth normal field: ``x = y(xi) + gamma n~(xi)``.

    Args:
        x: Points, (m, gdim).
        Y: Nodes of each point's facet, (m, nfd, gdim), in the facet element's order.
        Nn: Unit nodal normals at those nodes, (m, nfd, gdim).
        cell: The facet's basix cell (interval, triangle or quadrilateral).
        degree: The facet's Lagrange degree (1 or 2).
        xi0: Starting reference coordinates (m, fdim), e.g. the last projection; default: the
            exact projection on the straight chord (segments), the closest point of the plane
            through the vertices (triangles, quadrilaterals).
        inside_tol: Tolerance of :attr:`FacetProjection.inside`, in reference coordinates.
        maxit: Newton iterations per start.
        margin: How far (in reference coordinates) Newton's iterates may leave the reference
            cell; a solution beyond is not found.

    Returns:
        The projections; a pair whose projection could not be found has ``converged`` False
        (e.g. a point near the focal point of a strongly curved facet, or far from it).
    """
    m, gdim = x.shape
    fdim = gdim - 1
    h = facet_size(Y) if m else np.zeros(0)
    xi = np.zeros((m, fdim))
    todo = np.ones(m, dtype=bool)
    if xi0 is not None:  # the given starts, where they are numbers
        xi[:] = np.asarray(xi0, dtype=float).reshape(m, fdim)
        todo = ~np.all(np.isfinite(xi), axis=1)
    if np.any(todo):
        if cell == basix.CellType.interval:
            xi[todo] = _segment_start(x[todo], Y[todo], Nn[todo])
        else:
            xi[todo] = planar_start(cell, x[todo], Y[todo])
    xi, gamma, ok = _normal_newton(cell, degree, x, Y, Nn, xi, h, maxit, margin)
    # Fallback: restart the failures from a lattice of reference points, keeping the solution
    # nearest to the reference cell.
    bad = np.flatnonzero(~ok)
    if bad.size:
        for start in _lattice(cell):
            start = np.tile(start, (bad.size, 1))
            xb, gb, okb = _normal_newton(
                cell, degree, x[bad], Y[bad], Nn[bad], start, h[bad], maxit, margin
            )
            take = okb & (~ok[bad] | (_outside(cell, xb) < _outside(cell, xi[bad])))
            xi[bad[take]], gamma[bad[take]], ok[bad[take]] = xb[take], gb[take], True
    y, _, n, _ = facet_geometry(cell, degree, Y, Nn, xi, 0)
    assert n is not None  # (Nn given)
    nrm = np.linalg.norm(n, axis=1)
    safe = np.where(nrm > 0, nrm, 1.0)
    unit = n / safe[:, None]
    return FacetProjection(
        xi=xi,
        point=y,
        normal=unit,
        distance=gamma * nrm,
        gamma=gamma,
        converged=ok & (nrm > 0),
        inside=ok & inside_reference(cell, xi, inside_tol),
    )


def _outside(cell: basix.CellType, xi: np.ndarray) -> np.ndarray:
    """How far reference points are outside the reference cell (0 inside)."""
    d = np.maximum(np.maximum(-xi, xi - 1.0), 0.0).max(axis=1)
    if cell == basix.CellType.triangle:
        d = np.maximum(d, np.maximum(xi.sum(axis=1) - 1.0, 0.0))
    return d


def _lattice(cell: basix.CellType) -> list[np.ndarray]:
    if cell == basix.CellType.interval:
        return [np.array([t]) for t in (0.5, 0.0, 1.0, 0.25, 0.75)]
    t = (0.1, 0.5, 0.9) if cell == basix.CellType.quadrilateral else (0.1, 0.45, 0.8)
    pts = [np.array([a, b]) for a in t for b in t]
    if cell == basix.CellType.triangle:
        pts = [p for p in pts if p.sum() <= 1.0] + [np.array([1 / 3, 1 / 3])]
    return pts


def _normal_newton(cell, degree, x, Y, Nn, xi, h, maxit, margin):
    """Newton on ``F(xi, gamma) = y(xi) + gamma n~(xi) - x`` for all pairs at once.

    ``gamma`` starts as the distance along the normal at the starting ``xi``.
    """
    m, gdim = x.shape
    fdim = gdim - 1
    xi = xi.copy()
    gamma = np.zeros(m)
    ok = np.zeros(m, dtype=bool)
    active = np.arange(m)
    for it in range(maxit):
        if active.size == 0:
            break
        xa = xi[active]
        xx = x[active]
        y, dy, n, dn = facet_geometry(cell, degree, Y[active], Nn[active], xa, 1)
        if it == 0:
            nn = np.einsum("md,md->m", n, n)
            gamma[:] = np.einsum("md,md->m", xx - y, n) / np.where(nn > 0, nn, 1.0)
        ga = gamma[active]
        F = y + ga[:, None] * n - xx
        J = np.empty((active.size, gdim, gdim))
        J[:, :, :fdim] = dy + ga[:, None, None] * dn
        J[:, :, fdim] = n
        det = _det_small(J)
        scale = np.prod(np.sqrt(np.einsum("mij,mij->mj", J, J)), axis=1)
        regular = np.abs(det) > SINGULAR * np.where(scale > 0, scale, 1.0)
        dz = np.zeros((active.size, gdim))
        if np.any(regular):
            dz[regular] = -_solve_small(J[regular], F[regular], det[regular])
        # damping: at most one reference cell per step
        big = np.abs(dz[:, :fdim]).max(axis=1)
        dz *= np.where(big > 1.0, 1.0 / np.maximum(big, 1e-300), 1.0)[:, None]
        xi[active] = clip_reference(cell, xa + dz[:, :fdim], margin)
        gamma[active] = ga + dz[:, fdim]
        # converged: a step of round-off size, or a residual at the round-off of evaluating
        # y(xi) (coordinates times the basis' size, which grows like |xi|^p outside the cell)
        res = np.linalg.norm(F, axis=1)
        grow = (1.0 + np.abs(xa).max(axis=1)) ** degree
        floor = 1e-14 * (np.abs(xx).sum(axis=1) + h[active]) * grow
        done = regular & ((big <= 1e-13) | (res <= floor))
        ok[active[done]] = True
        active = active[regular & ~done]
    # the last update of the pairs that converged on the residual test is kept (tiny)
    return xi, gamma, ok


def parametric_normal(dy: np.ndarray) -> np.ndarray:
    """Unnormalised normal of a parametrised facet from its tangents ``y_,a`` (..., gdim, fdim).

    ``(y_,0[1], -y_,0[0])`` in 2-D, ``y_,0 x y_,1`` in 3-D.
    """
    if dy.shape[-2] == 2:
        t = dy[..., 0]
        return np.stack([t[..., 1], -t[..., 0]], axis=-1)
    return np.cross(dy[..., 0], dy[..., 1])


def projection_jacobian(
    x: np.ndarray,
    Y: np.ndarray,
    Nn: np.ndarray,
    cell: basix.CellType,
    degree: int,
    xi: np.ndarray,
    gamma: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Derivative of a normal projection ``(xi, gamma)`` with respect to the point and the nodes.

    From ``F(xi, gamma) = y(xi) + gamma n~(xi) - x = 0`` (implicit function theorem):
    ``A d(xi, gamma) = dx - sum_k N_k (dy_k + gamma dn_k)`` with
    ``A = [y_,a + gamma n~_,a | n~]``.

    Returns:
        ``A^-1`` (m, gdim, gdim) (rows: ``xi_a``..., ``gamma``) and the basis ``N_k(xi)``
        (m, nfd), so that ``d(xi, gamma) = A^-1 (dx - sum_k N_k (dy_k + gamma dn_k))``.
    """
    fdim = x.shape[1] - 1
    B = facet_basis(cell, degree, xi, 1)
    Bt = B.transpose(1, 0, 2)  # (m, 1 + fdim, nfd)
    dy = np.matmul(Bt[:, 1:], Y).transpose(0, 2, 1)
    W = np.matmul(Bt, Nn)
    n, dn = W[:, 0], W[:, 1:].transpose(0, 2, 1)
    A = np.empty((x.shape[0], x.shape[1], x.shape[1]))
    A[:, :, :fdim] = dy + gamma[:, None, None] * dn
    A[:, :, fdim] = n
    return np.linalg.inv(A), B[0]
