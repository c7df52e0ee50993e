"""The change of the primary's averaged nodal normals with its nodes: for the tangent.

The nodal normal at a node ``k`` is ``n_k = S_k / |S_k|`` with ``S_k = sum_f c_fk`` over the
primary facets ``f`` around ``k``, ``c_fk = o_f m_f p_f(xi_k) / |p_f(xi_k)|``
(:func:`.surface.nodal_normals`: the facet's measure ``m_f`` times its unit outward normal at
the node, ``p_f`` the parametric normal, ``o_f`` the orientation). Its derivative with respect to
the nodes ``Y_j`` of those facets is ``dn_k = (I - n_k n_k^T) / |S_k| sum_f dc_fk``, with
``dc = o (p^ dm + m (I - p^ p^^T) dp / |p|)`` and ``dm = sum_q w_q p^_q . dp(q)``; 2-D
``p = R y_,0`` (``dp = R dy_,0``), 3-D ``p = y_,0 x y_,1`` (``dp = dy_,0 x y_,1 + y_,0 x
dy_,1``).

The facets around a node may be on other ranks: the derivative is taken from the facets of the
reach (:class:`~.reach.Reach`), where they are all there (their number, over every rank, is the
reach's ``node_facets``); elsewhere it is left out (the tangent then misses it at that node).
"""

from __future__ import annotations

from typing import cast

import basix
import numpy as np

from ..geometry import quadrature_rule
from .projection import facet_basis, lagrange_element, parametric_normal

__all__ = ["normal_rates"]

_R = np.array([[0.0, 1.0], [-1.0, 0.0]])  # p = R t: parametric_normal in 2-D


def _skew(a: np.ndarray) -> np.ndarray:
    """``[a]x``: the matrix of ``a x .``, (..., 3, 3)."""
    z = np.zeros_like(a[..., 0])
    return np.stack(
        [
            np.stack([z, -a[..., 2], a[..., 1]], -1),
            np.stack([a[..., 2], z, -a[..., 0]], -1),
            np.stack([-a[..., 1], a[..., 0], z], -1),
        ],
        -2,
    )


def _normal_jacobian(dB: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """``dp / dY_j`` of the parametric normal at some points, (npf, npt, nfd, gdim, gdim).

    ``dB`` (fdim, npt, nfd): the basis' derivatives at the points; ``dy`` (npf, npt, gdim,
    fdim): ``y_,a`` there.
    """
    if dB.shape[0] == 1:  # p = R y_,0
        return np.einsum("ij,bc->ijbc", dB[0], _R)[None].repeat(dy.shape[0], axis=0)
    # p = y_,0 x y_,1: dp = -[y_,1]x dy_,0 + [y_,0]x dy_,1
    return -np.einsum("ij,fibc->fijbc", dB[0], _skew(dy[..., 1])) + np.einsum(
        "ij,fibc->fijbc", dB[1], _skew(dy[..., 0])
    )


def normal_rates(
    cell: basix.CellType,
    degree: int,
    nodes: np.ndarray,
    node_facets: np.ndarray,
    Y: np.ndarray,
    normals: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The derivative of every reach facet's nodal normals with respect to the nodes around them.

    Args:
        cell: The primary facets' basix cell (interval, triangle or quadrilateral).
        degree: Their Lagrange degree.
        nodes: The reach's facets' nodes (local in its index map), (npf, nfd).
        node_facets: The number of primary facets around each local node (every rank's), (n,).
        Y: The facets' nodes' current positions, (npf, nfd, gdim).
        normals: Their nodal normals (the iterate's), (npf, nfd, gdim).

    Returns:
        ``facets`` (npf, nfd, A): for node ``l`` of facet ``f``, the facets around it (-1: none,
        or the node's facets are not all in the reach), and ``D`` (npf, nfd, A, nfd, gdim, gdim):
        the derivative of the nodal normal at node ``l`` of ``f`` with respect to node ``j`` of
        ``facets[f, l, a]``.
    """
    nfd, gdim = Y.shape[1:]
    # the nodes' reference points (basix annotates an ArrayLike)
    X = cast(np.ndarray, lagrange_element(cell, degree).points)
    Bn = facet_basis(cell, degree, X, 1)  # at the nodes: (1 + fdim, nfd, nfd)
    Xq, wq = quadrature_rule(cell, max(degree, 1), "gauss")
    Bq = facet_basis(cell, degree, Xq, 1)
    dyn = np.einsum("aik,fkd->fida", Bn[1:], Y)  # y_,a at the nodes, (npf, nfd, gdim, fdim)
    pn = parametric_normal(dyn)  # (npf, nfd, gdim)
    dyq = np.einsum("aqk,fkd->fqda", Bq[1:], Y)
    pq = parametric_normal(dyq)
    lq = np.linalg.norm(pq, axis=-1)
    m = lq @ wq  # (npf,)
    # orientation: the parametric normal against the nodal normals
    o = np.where(np.einsum("fd,fd->f", pn.mean(axis=1), normals.mean(axis=1)) < 0.0, -1.0, 1.0)
    # dm / dY_j = sum_q w_q p^_q . dp_q / dY_j, (npf, nfd, gdim)
    dm = np.einsum("q,fqb,fqjbc->fjc", wq, pq / lq[..., None], _normal_jacobian(Bq[1:], dyq))
    ln = np.linalg.norm(pn, axis=-1)
    ph = pn / ln[..., None]  # (npf, nfd_i, gdim)
    I2 = np.eye(gdim)
    Pp = I2 - np.einsum("fia,fib->fiab", ph, ph)
    # dc_i / dY_j = o (p^_i (x) dm_j + m (I - p^ p^T) dp_i / dY_j / |p_i|),
    # (npf, nfd_i, nfd_j, gdim, gdim)
    scale = (m[:, None] / ln)[:, :, None, None, None]
    dc = ph[:, :, None, :, None] * dm[:, None, :, None, :] + scale * np.matmul(
        Pp[:, :, None], _normal_jacobian(Bn[1:], dyn)
    )
    dc *= o[:, None, None, None, None]
    c = o[:, None, None] * m[:, None, None] * ph  # (npf, nfd, 2)
    # S_k from the reach's facets, and which nodes have all their facets here
    n_nodes = max(int(nodes.max(initial=-1)) + 1, 0)
    S = np.zeros((n_nodes, gdim))
    np.add.at(S, nodes.ravel(), c.reshape(-1, gdim))
    here = np.bincount(nodes.ravel(), minlength=n_nodes)
    complete = here == node_facets[:n_nodes]
    # the (facet, slot) pairs around each node, padded
    A = int(here.max(initial=0))
    order = np.argsort(nodes.ravel(), kind="stable")
    flat_node = nodes.ravel()[order]
    start = np.searchsorted(flat_node, np.arange(n_nodes))
    rank = np.arange(order.size) - start[flat_node]
    adj_f = np.full((n_nodes, max(A, 1)), -1, dtype=np.int64)
    adj_i = np.zeros((n_nodes, max(A, 1)), dtype=np.int64)
    adj_f[flat_node, rank] = order // nfd
    adj_i[flat_node, rank] = order % nfd
    adj_f[~complete] = -1
    # dn_k / dY = (I - n n^T) / |S_k| dc, per node k and slot a
    nk = S / np.maximum(np.linalg.norm(S, axis=1, keepdims=True), 1e-300)
    Pk = (I2 - np.einsum("ka,kb->kab", nk, nk)) / np.maximum(np.linalg.norm(S, axis=1), 1e-300)[
        :, None, None
    ]
    valid = adj_f >= 0
    fa, ia = np.maximum(adj_f, 0), adj_i
    Dk = np.matmul(Pk[:, None, None], dc[fa, ia]) * valid[:, :, None, None, None]
    facets = adj_f[nodes]  # (npf, nfd, A)
    D = Dk[nodes]  # (npf, nfd, A, nfd, 2, 2)
    return facets, D
