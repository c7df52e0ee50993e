"""Finite-sliding kinematics of a secondary point on the primary surface (``docs/model.md`` §11).

A secondary point ``x`` projects on the primary surface at ``y(xi)`` along the smooth normal:
``x = y(xi) + gamma n~(xi)`` (:mod:`.projection`). With the unit normal ``n = n~ / |n~|`` and the
frame ``Q = (e1, [e2,] -n)`` of :func:`.geometry.frames`:

* the normal gap (penetration positive) is ``ubar_n = -gamma |n~| = -(x - y) . n``;
* the tangential slip of a step is the convected one, ``ds = y_{n+1}(xi_{n+1}) - y_{n+1}(xi_n)``:
  the path on the primary surface in its current configuration from the material point the secondary
  point faced at the step's start to the one it faces now. A rigid motion of both bodies leaves
  ``xi`` unchanged and gives no slip (objective), whatever the gap;
* tangent vectors of the internal state (total tangential gap, plastic slip) are convected with
  the primary surface at the material point they were attached to (their components on its
  tangent basis ``y_,a`` kept, the length kept), then carried to the tangent plane of the new
  projection by the smallest rotation between the two normals (:func:`transport_matrix`): a
  rigid motion of both bodies, spin about the normal included, leaves their local components in
  a frame that moves with the bodies unchanged. In 2-D it is the identity on the one component
  (``e1`` turns with ``n``).

:func:`gap_operator` gives the derivative of the local gap (tangential slip and normal gap) with
respect to the secondary point and the primary nodes, through the derivative of the projection, with
the primary's nodal normals held (their change is of the order of the gap times the facet's
rotation).
"""

from __future__ import annotations

import basix
import numpy as np

from .projection import facet_basis, projection_jacobian

__all__ = [
    "frame_jacobian",
    "frame_rate",
    "gap_operator",
    "transport",
    "transport_angle_rates",
    "transport_matrix",
]


def gap_operator(
    x: np.ndarray,
    Y: np.ndarray,
    Nn: np.ndarray,
    cell: basix.CellType,
    degree: int,
    xi: np.ndarray,
    gamma: np.ndarray,
    Q: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Derivative of the local gap of each point with respect to its motion relative to the primary.

    ``d(gap) = G (dx - sum_l N_l(xi) dy_l)`` with ``gap = (Q_t . ds, ubar_n)``: the tangential
    rows are the convected slip's ``Q_t y_,a dxi^a``, the normal row ``ubar_n = -gamma |n~|``'s.

    Args:
        x: Secondary points, (m, gdim).
        Y: Nodes of each point's primary facet, (m, nfd, gdim).
        Nn: Their nodal normals, (m, nfd, gdim).
        cell: The primary facets' basix cell.
        degree: Their Lagrange degree.
        xi: The points' projections (reference coordinates), (m, fdim).
        gamma: Their ``gamma`` (:class:`.projection.FacetProjection`), (m,).
        Q: The frames at the projections, rows ``(e1, [e2,] -n)``, (m, gdim, gdim).

    Returns:
        ``G`` (m, gdim, gdim), the primary basis ``N_l(xi)`` (m, nfd) and the projection's
        ``dxi`` rows ``R`` (m, fdim, gdim): ``dxi = R (dx - sum_l N_l(xi) dy_l)``
        (:func:`.projection.projection_jacobian`, the nodal normals held).
    """
    fdim = x.shape[1] - 1
    Ainv, N = projection_jacobian(x, Y, Nn, cell, degree, xi, gamma)
    B = facet_basis(cell, degree, xi, 1)
    dy = np.einsum("amk,mkd->mda", B[1:], Y)  # y_,a
    nt = np.einsum("mk,mkd->md", B[0], Nn)
    dnt = np.einsum("amk,mkd->mda", B[1:], Nn)
    size = np.linalg.norm(nt, axis=1)
    n = nt / size[:, None]
    G = np.empty_like(Q)
    # tangential: e_b . y_,a dxi^a
    G[:, :fdim, :] = np.einsum("mbd,mda,mac->mbc", Q[:, :fdim, :], dy, Ainv[:, :fdim, :])
    # normal: -(|n~| dgamma + gamma n . n~_,a dxi^a)
    tilt = np.einsum("md,mda->ma", n, dnt)
    G[:, fdim, :] = -(
        size[:, None] * Ainv[:, fdim, :]
        + gamma[:, None] * np.einsum("ma,mac->mc", tilt, Ainv[:, :fdim, :])
    )
    return G, N, Ainv[:, :fdim, :]


def frame_rate(Nn: np.ndarray, cell: basix.CellType, degree: int, xi: np.ndarray) -> np.ndarray:
    """How a 2-D frame ``(e1, -n)`` turns as the projection moves along the facet (2-D only).

    The normal ``n = n~(xi) / |n~(xi)|`` turns with the projection (the nodal normals held):
    ``dn = a dxi`` with ``a = dn/dxi``, and ``dxi = r . (dx - sum_l N_l(xi) dy_l)`` with ``r``
    the projection's ``dxi`` row (the third result of :func:`gap_operator`); ``e1 = (n_y, -n_x)``
    (:func:`.geometry.frames`) turns with it.

    Args:
        Nn: Nodal normals of each point's primary facet, (m, nfd, 2).
        cell: The primary facets' basix cell (interval).
        degree: Their Lagrange degree.
        xi: The points' projections, (m, 1).

    Returns:
        ``a`` (m, 2), ``dn/dxi``.
    """
    B = facet_basis(cell, degree, xi, 1)
    nt = np.einsum("mk,mkd->md", B[0], Nn)
    dnt = np.einsum("mk,mkd->md", B[1], Nn)
    size = np.linalg.norm(nt, axis=1)
    n = nt / size[:, None]
    return (dnt - n * np.einsum("md,md->m", n, dnt)[:, None]) / size[:, None]


def transport(v: np.ndarray, n_old: np.ndarray, n_new: np.ndarray) -> np.ndarray:
    """Rotate vectors by the smallest rotation taking the unit normals ``n_old`` to ``n_new``.

    Args:
        v: Vectors (global components), (m, gdim).
        n_old: Unit normals before, (m, gdim).
        n_new: Unit normals after, (m, gdim).

    Returns:
        The rotated vectors: tangent to ``n_new`` where ``v`` was tangent to ``n_old``, with the
        same length. Opposite normals (a half turn, no smallest rotation) leave ``v`` unchanged.
    """
    gdim = v.shape[1]
    c = np.einsum("md,md->m", n_old, n_new)
    if gdim == 2:
        s = n_old[:, 0] * n_new[:, 1] - n_old[:, 1] * n_new[:, 0]
        return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)
    k = np.cross(n_old, n_new)  # sin(angle) times the axis
    ok = c > -1.0 + 1e-12
    f = np.where(ok, 1.0 / np.where(ok, 1.0 + c, 1.0), 0.0)
    # Rodrigues: v c + k x v + k (k . v) / (1 + c)
    out = c[:, None] * v + np.cross(k, v) + (f * np.einsum("md,md->m", k, v))[:, None] * k
    return np.where(ok[:, None], out, v)


def transport_matrix(
    Q_old: np.ndarray,
    Q_new: np.ndarray,
    tangents_old: np.ndarray,
    tangents_now: np.ndarray,
    normal_now: np.ndarray,
) -> np.ndarray:
    """The map of tangential local components from the old frames to the new ones.

    Args:
        Q_old: Frames at the step's start, rows ``(e1, [e2,] -n)``, (m, gdim, gdim).
        Q_new: Frames at the new projections, likewise.
        tangents_old: Tangent basis ``y_,a`` of the primary at the old projection, at the step's
            start, (m, gdim, fdim).
        tangents_now: The same material point's tangent basis now, (m, gdim, fdim).
        normal_now: The unit normal there now, (m, gdim).

    Returns:
        ``T`` (m, nt, nt): new components ``T v`` of the vectors of old components ``v``.
    """
    m, gdim = Q_old.shape[:2]
    nt = gdim - 1
    if gdim == 2:
        return np.ones((m, 1, 1))
    # convected: the old frame's tangents -> components on the old basis -> the basis now,
    # in the plane normal to the normal now
    G = np.einsum("mda,mdb->mab", tangents_old, tangents_old)
    dual = np.linalg.solve(G, np.swapaxes(tangents_old, 1, 2))  # (m, fdim, gdim)
    E = np.swapaxes(Q_old[:, :nt, :], 1, 2)  # old tangents as columns (m, gdim, nt)
    W = np.einsum("mda,mak->mdk", tangents_now, np.einsum("mad,mdk->mak", dual, E))
    W -= normal_now[:, :, None] * np.einsum("md,mdk->mk", normal_now, W)[:, None, :]
    # keep lengths and angles: W (W^T W)^(-1/2), the rotation part
    lam, V = np.linalg.eigh(np.einsum("mdk,mdl->mkl", W, W))
    W = np.einsum("mdk,mkj,mj,mlj->mdl", W, V, 1.0 / np.sqrt(lam), V)
    # the smallest rotation from the material point's normal now to the new one
    cols = [transport(W[:, :, k], normal_now, -Q_new[:, nt, :]) for k in range(nt)]
    R = np.stack(cols, axis=-1)  # (m, gdim, nt)
    return np.einsum("mbd,mdk->mbk", Q_new[:, :nt, :], R)


_STEP = 1e-30  # the complex step: derivatives to round-off (no difference is taken)


def _frames_3d(n: np.ndarray) -> np.ndarray:
    """:func:`.geometry.frames` in 3-D, for complex ``n`` too (the complex-step derivatives).

    The same frames for real ``n``: the axis chosen by the real part, the norms without
    ``abs``.
    """
    ax = np.zeros_like(n)
    use_y = np.abs(n[..., 0].real) > 0.9
    ax[..., 0] = np.where(use_y, 0.0, 1.0)
    ax[..., 1] = np.where(use_y, 1.0, 0.0)
    e1 = ax - np.sum(ax * n, axis=-1, keepdims=True) * n
    e1 = e1 / np.sqrt(np.sum(e1 * e1, axis=-1, keepdims=True))
    return np.stack([e1, np.cross(n, e1), -n], axis=-2)


def frame_jacobian(n: np.ndarray) -> np.ndarray:
    """3-D: the derivative of the frame's rows ``(e1, e2, -n)`` with the normal ``n``.

    Args:
        n: Unit normals, (m, 3).

    Returns:
        ``dQ`` (m, 3, 3, 3): ``dQ[:, i, j, k] = d Q_ij / d n_k`` (:func:`.geometry.frames`).
    """
    out = np.zeros((n.shape[0], 3, 3, 3))
    for k in range(3):
        z = n.astype(complex)
        z[:, k] += 1j * _STEP
        out[..., k] = _frames_3d(z).imag / _STEP
    return out


def _convected(Q_old: np.ndarray, tangents_old: np.ndarray) -> np.ndarray:
    """The old frame's tangents' components on the old tangent basis, (m, fdim, nt).

    The part of :func:`_transport_3d` that depends on the step's start alone (real).
    """
    G = np.matmul(np.swapaxes(tangents_old, 1, 2), tangents_old)
    dual = np.linalg.solve(G, np.swapaxes(tangents_old, 1, 2))
    return np.matmul(dual, np.swapaxes(Q_old[:, :2, :], 1, 2))


def _transport_3d(
    Q_old: np.ndarray,
    tangents_old: np.ndarray,
    tangents_now: np.ndarray,
    normal_now: np.ndarray,
    n_new: np.ndarray,
) -> np.ndarray:
    """:func:`transport_matrix` in 3-D as a function of the new normal, for complex inputs too.

    The polar factor by the closed form of a 2 x 2 matrix's square root, the smallest rotation
    by Rodrigues' formula; the same matrix for real inputs (to round-off).
    """
    return _transport_from(_convected(Q_old, tangents_old), tangents_now, normal_now, n_new)


def _transport_from(
    DE: np.ndarray, tangents_now: np.ndarray, normal_now: np.ndarray, n_new: np.ndarray
) -> np.ndarray:
    """:func:`_transport_3d` from the step start's part ``DE`` (:func:`_convected`)."""
    W = np.matmul(tangents_now, DE)
    W = W - normal_now[:, :, None] * np.matmul(normal_now[:, None, :], W)
    S = np.matmul(np.swapaxes(W, 1, 2), W)
    det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    r = np.sqrt(det)
    t = np.sqrt(S[:, 0, 0] + S[:, 1, 1] + 2.0 * r)
    a, b, c, d = S[:, 0, 0] + r, S[:, 0, 1], S[:, 1, 0], S[:, 1, 1] + r
    inv = (
        np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2)
        * (t / (a * d - b * c))[:, None, None]
    )
    W = np.matmul(W, inv)  # W S^(-1/2)
    k = _cross(normal_now, n_new)
    cos = np.sum(normal_now * n_new, axis=1)
    kW = np.matmul(k[:, None, :], W)[:, 0]  # (m, 2): k . v of both columns
    R = (
        cos[:, None, None] * W
        + _cross(k[:, :, None], W, axis=1)
        + (kW / (1.0 + cos)[:, None])[:, None, :] * k[:, :, None]
    )
    return np.matmul(_frames_3d(n_new)[:, :2, :], R)


def _cross(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
    """``a x b`` along ``axis`` (3 components), broadcast; complex too."""
    a0, a1, a2 = (np.take(a, i, axis=axis) for i in range(3))
    b0, b1, b2 = (np.take(b, i, axis=axis) for i in range(3))
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=axis)


def transport_angle_rates(
    Q_old: np.ndarray,
    tangents_old: np.ndarray,
    tangents_now: np.ndarray,
    normal_now: np.ndarray,
    n_new: np.ndarray,
    slots: tuple[int, ...] = (4, 2, 3),
) -> list[np.ndarray]:
    """3-D: how the transport's rotation turns with the geometry (the tangent's frame turn).

    The transport :func:`transport_matrix` of a point is a rotation of its tangential
    components by an angle ``theta``, a function of the step start's frame ``Q_old`` and tangent
    basis ``tangents_old`` of the material point it is convected with, that point's tangent
    basis now ``tangents_now`` and normal now ``normal_now``, and the new projection's normal
    ``n_new``. Complex-step derivatives.

    Args:
        Q_old: Frames at the step's start, (m, 3, 3).
        tangents_old: The material point's tangent basis at the step's start, (m, 3, 2).
        tangents_now: Its tangent basis now, (m, 3, 2).
        normal_now: Its unit normal now, (m, 3).
        n_new: The unit normal at the new projection, (m, 3).
        slots: The arguments (their positions above) to differentiate by.

    Returns:
        ``d theta / d`` each argument of ``slots``, of the argument's shape.
    """
    args = [Q_old, tangents_old, tangents_now, normal_now, n_new]
    T = _transport_3d(*args).real
    m = n_new.shape[0]
    # the step start's part once (real) unless its arguments are differentiated too
    DE = None if (0 in slots or 1 in slots) else _convected(Q_old, tangents_old)

    def evaluate(z: list[np.ndarray]) -> np.ndarray:
        if DE is None:
            return _transport_3d(*z)
        return _transport_from(np.tile(DE, (z[2].shape[0] // m, 1, 1)), *z[2:])

    # the complex steps: every component of every slot, stacked (step k of all points together),
    # one evaluation
    sizes = [args[slot][0].size for slot in slots]
    K = sum(sizes)
    z = []
    for i, arg in enumerate(args):
        if DE is not None and i < 2:  # (not read)
            z.append(arg)
            continue
        zi = np.tile(arg.astype(complex)[None], (K,) + (1,) * arg.ndim)  # (K, m, ...)
        if i in slots:
            off = sum(sizes[: slots.index(i)])
            flat = zi.reshape(K, m, -1)
            for k in range(arg[0].size):
                flat[off + k, :, k] += 1j * _STEP
        z.append(zi.reshape(K * m, *arg.shape[1:]))
    dT = (evaluate(z).imag / _STEP).reshape(K, m, 2, 2)
    rate = T[None, :, 0, 0] * dT[:, :, 1, 0] - T[None, :, 1, 0] * dT[:, :, 0, 0]  # (K, m)
    rates, off = [], 0
    for slot, size in zip(slots, sizes, strict=True):
        rates.append(rate[off : off + size].T.reshape(args[slot].shape))
        off += size
    return rates
