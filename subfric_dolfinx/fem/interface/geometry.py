"""Geometry of interface facets: quadrature, push-forward, local frames, point matching."""

from __future__ import annotations

from typing import cast

import basix
import dolfinx
import numpy as np
from scipy.spatial import cKDTree

from ...compat import coordinate_element, geometry_dofmap

__all__ = [
    "basix_cell",
    "coordinate_basis",
    "frames",
    "match_points",
    "push_forward",
    "quadrature_rule",
]


def quadrature_rule(cell: basix.CellType, degree: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points and weights on a reference facet.

    Args:
        cell: Facet cell type.
        degree: Polynomial degree of the displacement (1 or 2).
        kind: ``"gauss"`` (exact for the interface's mass-like terms, degree ``2 p``) or
            ``"nodal"`` (the facet Lagrange nodes with the weights that integrate the Lagrange
            basis exactly, i.e. a lumped scheme, as often preferred against traction oscillations
            of stiff penalty interfaces; degree 1 only on simplices).
    """
    # (basix annotates its arrays as ArrayLike: they are float64 arrays)
    if kind == "gauss":
        X, w = basix.make_quadrature(cell, 2 * degree)
        return cast(np.ndarray, X), cast(np.ndarray, w)
    if kind == "nodal":
        e = basix.create_element(
            basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.gll_warped
        )
        Xg, wg = basix.make_quadrature(cell, 2 * degree)
        w = cast(np.ndarray, e.tabulate(0, cast(np.ndarray, Xg)))[0, :, :, 0].T @ wg
        if np.any(w <= 0.0):
            raise ValueError(
                f"nodal quadrature has non-positive weights for degree {degree} on {cell.name}"
            )
        return cast(np.ndarray, e.points).copy(), w
    raise ValueError(f"quadrature kind must be 'gauss' or 'nodal', got {kind!r}")


def basix_cell(cell_type: dolfinx.mesh.CellType) -> basix.CellType:
    """The basix cell type of a DOLFINx cell type."""
    return basix.CellType[cell_type.name]


def coordinate_basis(sub: dolfinx.mesh.Mesh, X: np.ndarray, nderiv: int = 0) -> np.ndarray:
    """Tabulate the coordinate element of ``sub`` at reference points ``X``."""
    cmap = coordinate_element(sub)
    e = basix.create_element(
        basix.ElementFamily.P,
        basix_cell(sub.topology.cell_type),
        cmap.degree,
        basix.LagrangeVariant(cmap.variant),
    )
    return cast(np.ndarray, e.tabulate(nderiv, X))[..., 0]


def push_forward(sub: dolfinx.mesh.Mesh, X: np.ndarray) -> np.ndarray:
    """Physical coordinates of reference points ``X`` in every cell of ``sub``, (nc, nX, gdim)."""
    gdim = sub.geometry.dim
    phi = coordinate_basis(sub, X)[0]  # (nX, ngeo)
    xg = sub.geometry.x[geometry_dofmap(sub)][..., :gdim]  # (nc, ngeo, gdim)
    return np.einsum("xk,ckd->cxd", phi, xg)


def frames(n: np.ndarray) -> np.ndarray:
    """Rows ``(e1, [e2,] -n)`` of local frames for unit normals ``n`` (..., gdim)."""
    gdim = n.shape[-1]
    Q = np.zeros((*n.shape, gdim))
    if gdim == 2:
        Q[..., 0, :] = np.stack([n[..., 1], -n[..., 0]], axis=-1)
        Q[..., 1, :] = -n
        return Q
    # e1: the projection of x (or of y where n is close to x) on the tangent plane
    ax = np.zeros_like(n)
    use_y = np.abs(n[..., 0]) > 0.9
    ax[..., 0] = np.where(use_y, 0.0, 1.0)
    ax[..., 1] = np.where(use_y, 1.0, 0.0)
    e1 = ax - np.sum(ax * n, axis=-1, keepdims=True) * n
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(n, e1)
    Q[..., 0, :] = e1
    Q[..., 1, :] = e2
    Q[..., 2, :] = -n
    return Q


def match_points(
    keys: np.ndarray, queries: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """For each query point, the nearest key point's index if within ``tol`` (else -1), distance.

    The distance is ``inf`` where there is none. A k-d tree of the keys
    (``scipy.spatial.cKDTree``): O((n + m) log m) for m keys and n queries.
    """
    n = queries.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    dist = np.full(n, np.inf)
    if keys.shape[0] == 0 or n == 0:
        return out, dist
    d, k = cKDTree(keys).query(queries)
    ok = d <= tol
    out[ok], dist[ok] = k[ok], d[ok]
    return out, dist
