"""The closest point of a facet to a point, vectorised over point-facet pairs.

The classical projection (the contact itself uses :func:`.projection.normal_projection`, see its
module): the point of the facet, its boundary included, nearest to ``x``. Newton in the interior,
then the nearest point of each edge of the reference cell (the vertices of a segment).
"""

from __future__ import annotations

import basix
import numpy as np

from .projection import (
    SINGULAR,
    FacetProjection,
    clip_reference,
    facet_basis,
    facet_geometry,
    facet_size,
    inside_reference,
    parametric_normal,
    planar_start,
    reference_vertices,
)

__all__ = ["closest_point"]


def closest_point(
    x: np.ndarray, Y: np.ndarray, cell: basix.CellType, degree: int, *, maxit: int = 30
) -> FacetProjection:
    """The point of each facet (boundary included) nearest to each point.

    Newton on the stationarity of ``|x - y(xi)|^2`` in the facet's interior; where its solution
    is outside the reference cell, the nearest point of the facet's boundary (1-D Newton along
    each reference edge, clamped to it; the vertices for a segment).

    Args:
        x: Points, (m, gdim).
        Y: Nodes of each point's facet, (m, nfd, gdim).
        cell: The facet's basix cell.
        degree: The facet's Lagrange degree.
        maxit: Newton iterations.

    Returns:
        The projections (``inside`` is True for all: the point is on the facet; ``gamma`` is the
        distance; ``normal`` the unit vector from the point found to ``x``, or the facet's own
        normal where ``x`` is on it).
    """
    m, gdim = x.shape
    fdim = gdim - 1
    h = facet_size(Y) if m else np.zeros(0)
    xi = planar_start(cell, x, Y) if m else np.zeros((0, fdim))
    xi, ok = _closest_newton(cell, degree, x, Y, xi, h, maxit)
    inside = ok & inside_reference(cell, xi, 0.0)
    best_xi = np.where(inside[:, None], xi, np.nan)
    y, _, _, _ = facet_geometry(cell, degree, Y, None, np.where(inside[:, None], xi, 0.0), 0)
    best_d = np.where(inside, np.linalg.norm(x - y, axis=1), np.inf)
    # boundary: every edge of the reference cell (segments: its two vertices)
    V = reference_vertices(cell)
    topo = basix.topology(cell)
    if fdim == 1:
        for v in V:
            cand = np.tile(v, (m, 1))
            yc, _, _, _ = facet_geometry(cell, degree, Y, None, cand, 0)
            d = np.linalg.norm(x - yc, axis=1)
            take = d < best_d
            best_d[take], best_xi[take] = d[take], cand[take]
    else:
        for a, b in topo[1]:
            t = _edge_newton(cell, degree, x, Y, V[a], V[b], maxit)
            cand = V[a] + t[:, None] * (V[b] - V[a])
            yc, _, _, _ = facet_geometry(cell, degree, Y, None, cand, 0)
            d = np.linalg.norm(x - yc, axis=1)
            take = d < best_d
            best_d[take], best_xi[take] = d[take], cand[take]
    y, dy, _, _ = facet_geometry(cell, degree, Y, None, best_xi, 1)
    r = x - y
    dist = np.linalg.norm(r, axis=1)
    unit = r / np.where(dist > 0, dist, 1.0)[:, None]
    on = dist <= 1e-14 * (h + 1e-300)
    if np.any(on):
        assert dy is not None  # (asked for: nderiv 1)
        n = parametric_normal(dy[on])
        unit[on] = n / np.linalg.norm(n, axis=1, keepdims=True)
    return FacetProjection(
        xi=best_xi,
        point=y,
        normal=unit,
        distance=dist,
        gamma=dist,
        converged=np.ones(m, dtype=bool),
        inside=np.ones(m, dtype=bool),
    )


def _closest_newton(cell, degree, x, Y, xi, h, maxit):
    """Newton on the stationarity of ``|x - y(xi)|^2 / 2``.

    Its Hessian is replaced by Gauss-Newton's ``y_,a . y_,b`` where it is not positive definite
    (towards a minimum, never a saddle).
    """
    m, gdim = x.shape
    fdim = gdim - 1
    curved = degree > 1 or cell == basix.CellType.quadrilateral
    xi = xi.copy()
    ok = np.zeros(m, dtype=bool)
    active = np.arange(m)
    for _ in range(maxit):
        if active.size == 0:
            break
        B = facet_basis(cell, degree, xi[active], 2 if curved else 1)
        Ya = Y[active]
        y = np.einsum("mk,mkd->md", B[0], Ya)
        dy = np.einsum("amk,mkd->mda", B[1 : 1 + fdim], Ya)
        r = y - x[active]
        g = np.einsum("mda,md->ma", dy, r)
        H = np.einsum("mda,mdb->mab", dy, dy)
        if curved:
            # second derivatives in basix's order: xx, (xy, yy)
            pairs = [(0, 0)] if fdim == 1 else [(0, 0), (0, 1), (1, 1)]
            Hf = H.copy()
            for i, (a, b) in enumerate(pairs):
                c = np.einsum("mk,mkd,md->m", B[1 + fdim + i], Ya, r)
                Hf[:, a, b] += c
                if a != b:
                    Hf[:, b, a] += c
            ev = np.linalg.eigvalsh(Hf)
            pd = ev.min(axis=1) > 1e-8 * np.maximum(ev.max(axis=1), 1e-300)
            H[pd] = Hf[pd]
        det = np.linalg.det(H)
        regular = np.abs(det) > SINGULAR * np.maximum(np.abs(H).max(axis=(1, 2)) ** fdim, 1e-300)
        dxi = np.zeros((active.size, fdim))
        if np.any(regular):
            dxi[regular] = -np.linalg.solve(H[regular], g[regular][..., None])[..., 0]
        big = np.abs(dxi).max(axis=1)
        dxi *= np.where(big > 1.0, 1.0 / np.maximum(big, 1e-300), 1.0)[:, None]
        xi[active] = clip_reference(cell, xi[active] + dxi, 2.0)
        done = regular & (np.abs(dxi).max(axis=1) <= 1e-12)
        ok[active[done]] = True
        active = active[regular & ~done]
    return xi, ok


def _edge_newton(cell, degree, x, Y, va, vb, maxit):
    """Closest point of the facet edge ``va -> vb`` (reference vertices): a parameter in [0, 1].

    Clamped Newton from the edge's middle and (P2, whose distance along an edge may have two
    minima) from both ends; the nearest result.
    """
    m = x.shape[0]
    e = vb - va
    fdim = e.size
    best_t, best_d = np.full(m, 0.5), np.full(m, np.inf)
    for t0 in (0.5, 0.0, 1.0) if degree > 1 else (0.5,):
        t = np.full(m, t0)
        for _ in range(maxit):
            B = facet_basis(cell, degree, va + t[:, None] * e, 2 if degree > 1 else 1)
            y = np.einsum("mk,mkd->md", B[0], Y)
            dy = np.einsum("amk,mkd->mda", B[1 : 1 + fdim], Y) @ e  # (m, gdim)
            r = y - x
            g = np.einsum("md,md->m", dy, r)
            H = np.einsum("md,md->m", dy, dy)
            if degree > 1:
                # d^2 y / dt^2 = e_a e_b y_,ab; basix's second derivatives: xx, xy, yy
                d2 = np.einsum("amk,mkd->amd", B[1 + fdim :], Y)
                ytt = e[0] ** 2 * d2[0] + 2 * e[0] * e[1] * d2[1] + e[1] ** 2 * d2[2]
                H = H + np.einsum("md,md->m", ytt, r)
            # where the distance is concave along the edge: to the end it descends to
            step = np.where(H > 0, -g / np.where(H > 0, H, 1.0), -np.sign(g))
            t_new = np.clip(t + step, 0.0, 1.0)
            moved = np.abs(t_new - t).max() if m else 0.0
            t = t_new
            if moved <= 1e-14:
                break
        B = facet_basis(cell, degree, va + t[:, None] * e, 0)
        d = np.linalg.norm(np.einsum("mk,mkd->md", B[0], Y) - x, axis=1)
        take = d < best_d
        best_t[take], best_d[take] = t[take], d[take]
    return best_t
