"""Transfer of the slave points' tractions to the master nodes of a non-matching interface.

The friction law runs at the slave facets' quadrature points (the internal variables stay with
these material points). The slave nodes receive ``int N_s t dA`` by the facet's own rule, as
for a matching interface. The master nodes must receive ``-int (N_m o pi) t dA`` of the same
traction field, and that integral is exact only on the segments of :mod:`.segments`, whose points
are not the law's points. The traction field is therefore the facet-wise discrete L2 projection
``lambda_h`` of the points' tractions on the facet's Lagrange space ``P_p``
(``sum_q w_q (lambda_h(q) - t_q) N_k(q) = 0`` for every ``N_k``): it leaves the slave forces
unchanged (``N_k`` is in ``P_p``), reproduces every traction field of ``P_p`` (a uniform pressure,
a linear one), and is integrated exactly over the segments against the master's shape functions
(``docs/model.md`` §11). So the master nodal forces are ``-B t`` with, per slave facet ``s`` and
master facet ``m``,

    B_lq = sum_{segment points of (s, m)} w N_m,l(xi_m) L_q(xi_s),
    L_q(xi) = sum_kj N_k(xi) (M^-1)_kj w_q N_j(q),   M = sum_q w_q N(q) N(q)^T.

A uniform traction is then transmitted exactly (the non-matching patch test); on a matching
interface ``B_lq = w_q N_l(q)``, today's element.
"""

from __future__ import annotations

import dataclasses

import basix
import numpy as np

from .projection import _element, facet_basis
from .segments import Segments

__all__ = ["Transfer", "l2_projector", "transfer_matrices"]


def l2_projector(N: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The facet-wise discrete L2 projection on the facet's Lagrange space.

    Args:
        N: The facet basis at the quadrature points, (nq, nfd).
        w: Quadrature weights times surface Jacobian of each facet, (nf, nq).

    Returns:
        ``P`` (nf, nfd, nq): the coefficients of ``lambda_h`` in the basis are ``P t`` for point
        values ``t`` (nq,).

    Raises:
        ValueError: The rule does not determine a field of the space (fewer points than nodes,
            or a singular mass matrix).
    """
    nq, nfd = N.shape
    if nq < nfd:
        raise ValueError(f"{nq} quadrature points cannot determine a field of {nfd} nodes")
    M = np.einsum("fq,qk,qj->fkj", w, N, N)
    rhs = np.einsum("fq,qj->fjq", w, N)
    try:
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError as e:
        raise ValueError("the facet mass matrix of the quadrature rule is singular") from e


@dataclasses.dataclass
class Transfer:
    """Master-side transfer matrices of slave facets, one per (slave facet, master facet) pair.

    Attributes:
        slave: Slave facet of each pair, (npair,).
        master: Master facet of each pair, (npair,).
        B: ``B_lq`` of each pair, (npair, nfd_m, nq): the master nodal force of the pair is
            ``-B t`` for the tractions ``t`` (nq, gdim) at the slave facet's points.
    """

    slave: np.ndarray
    master: np.ndarray
    B: np.ndarray


def transfer_matrices(
    segments: Segments,
    projector: np.ndarray,
    slave_cell: basix.CellType,
    slave_degree: int,
    master_cell: basix.CellType,
    master_degree: int,
) -> Transfer:
    """The matrices ``B`` of every pair of facets the segments join (not collective).

    Args:
        segments: The segment points (:func:`.segments.overlap_points`).
        projector: ``P`` of :func:`l2_projector` for the slave facets, (ns, nfd_s, nq).
        slave_cell: The slave facets' basix cell.
        slave_degree: Their Lagrange degree.
        master_cell: The master facets' basix cell.
        master_degree: Their Lagrange degree.
    """
    nq = projector.shape[2]
    if segments.size == 0:
        nfd_m = _element(master_cell, master_degree).dim
        z = np.zeros(0, dtype=np.int64)
        return Transfer(z, z.copy(), np.zeros((0, nfd_m, nq)))
    key = segments.slave.astype(np.int64) * (int(segments.master.max()) + 1) + segments.master
    pairs, pair_of = np.unique(key, return_inverse=True)
    Ns = facet_basis(slave_cell, slave_degree, segments.xi_slave)[0]  # (np, nfd_s)
    Nm = facet_basis(master_cell, master_degree, segments.xi_master)[0]  # (np, nfd_m)
    L = np.einsum("pk,pkq->pq", Ns, projector[segments.slave])  # (np, nq)
    B = np.zeros((pairs.size, Nm.shape[1], nq))
    contrib = segments.weight[:, None, None] * Nm[:, :, None] * L[:, None, :]
    np.add.at(B, pair_of.reshape(-1), contrib)
    first = np.zeros(pairs.size, dtype=np.int64)
    first[pair_of.reshape(-1)[::-1]] = np.arange(segments.size)[::-1]
    return Transfer(segments.slave[first], segments.master[first], B)
