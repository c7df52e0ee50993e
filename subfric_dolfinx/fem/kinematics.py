"""Small-strain kinematics of the bodies in each modelling mode, in UFL (and the weight of a point).

Modes (:data:`MODES`):

* ``"3d"``: ``gdim = 3``, ``eps = sym(grad u)``;
* ``"plane_strain"``: ``gdim = 2``, ``eps_zz = 0``;
* ``"plane_stress"``: ``gdim = 2``, ``sigma_zz = 0`` (``eps_zz`` follows from the material; for
  linear elasticity the in-plane law has the reduced coefficients, see :func:`elastic_stress`);
* ``"axisymmetric"``: ``gdim = 2``, coordinates ``(r, z)`` with ``r = x[0] >= 0``, displacement
  ``(u_r, u_z)``, hoop strain ``eps_tt = u_r / r``; every integral over the bodies and over the
  interface carries the weight ``2 pi r`` (:func:`weight`, :func:`point_weight`): forces and
  reactions are totals over the whole revolution.

The strain is always the full 3 x 3 tensor (:func:`strain`), so that a bulk law written for 3-D
(e.g. J2 plasticity at quadrature points) serves every mode; in the plane modes its ``zz`` entry is
0 (plane strain) or a placeholder the law must not use (plane stress: the laws shipped here give
``sigma_zz = 0`` by construction).
"""

from __future__ import annotations

import math

import numpy as np
import ufl

__all__ = [
    "MODES",
    "ModeError",
    "check_axisymmetric",
    "check_mode",
    "elastic_stress",
    "point_weight",
    "strain",
    "weight",
]

MODES = ("3d", "plane_strain", "plane_stress", "axisymmetric")


class ModeError(ValueError):
    """A modelling mode that does not fit the mesh (the same message on every rank)."""


def check_axisymmetric(mesh) -> None:
    """Refuse an axisymmetric mesh with a node at ``r = x[0] < 0`` (collective).

    The weight ``2 pi r`` and the hoop strain ``u_r / r`` hold for ``r >= 0`` only: a body at
    ``r < 0`` has negative volume (its forces change sign), and one across the axis cancels its
    own. Nodes on the axis are allowed (up to round-off: ``1e-12`` of the mesh's size).

    Raises:
        ModeError: On every rank, naming the smallest ``r``, where it is, and whether the mesh
            crosses the axis or lies wholly at ``r < 0``.
    """
    from mpi4py import MPI

    comm = mesh.comm
    gdim = mesh.geometry.dim
    x = mesh.geometry.x[:, :gdim]
    n = mesh.geometry.index_map().size_local
    r = x[:n, 0]
    here = (float(r.min()), tuple(float(c) for c in x[int(np.argmin(r))])) if n else None
    size = comm.allreduce(float(np.abs(x[:n]).max()) if n else 0.0, op=MPI.MAX)
    r_max = comm.allreduce(float(r.max()) if n else -math.inf, op=MPI.MAX)
    found = [h for h in comm.allgather(here) if h is not None]
    if not found:
        return
    r_min, at = min(found)
    tol = 1e-12 * max(size, 1e-300)
    if r_min >= -tol:
        return
    where = ", ".join(f"{c:.6g}" for c in at)
    how = (
        f"it crosses the axis (r from {r_min:.6g} to {r_max:.6g})"
        if r_max > tol
        else f"it lies at r < 0 (r from {r_min:.6g} to {r_max:.6g})"
    )
    raise ModeError(
        f"mode 'axisymmetric' needs the mesh in r = x >= 0 (the axis is x = 0): {how}, the "
        f"smallest r at ({where}); mirror or move the mesh to r >= 0"
    )


def check_mode(mode: str, gdim: int) -> str:
    """``mode`` if it is known and fits a mesh of dimension ``gdim``.

    Raises:
        ModeError: An unknown mode, or one that does not fit ``gdim`` (both named).
    """
    if mode not in MODES:
        raise ModeError(f"mode must be one of {MODES}, got {mode!r}")
    want = 3 if mode == "3d" else 2
    if gdim != want:
        raise ModeError(f"mode {mode!r} needs a {want}-D mesh, got a {gdim}-D one")
    return mode


def strain(u, mode: str):
    """The small strain of ``u`` as a 3 x 3 UFL tensor in the given mode."""
    g = ufl.sym(ufl.grad(u))
    if mode == "3d":
        return g
    if mode in ("plane_strain", "plane_stress"):
        return ufl.as_tensor([[g[0, 0], g[0, 1], 0], [g[1, 0], g[1, 1], 0], [0, 0, 0]])
    if mode == "axisymmetric":
        r = ufl.SpatialCoordinate(u.ufl_function_space().mesh)[0]
        return ufl.as_tensor([[g[0, 0], g[0, 1], 0], [g[1, 0], g[1, 1], 0], [0, 0, u[0] / r]])
    raise ValueError(f"mode must be one of {MODES}, got {mode!r}")


def elastic_stress(eps, E: float, nu: float, mode: str):
    """Isotropic linear-elastic stress (3 x 3) of the 3 x 3 strain ``eps`` in the given mode.

    In plane stress the in-plane block has the reduced coefficients (``lambda* = 2 lambda mu /
    (lambda + 2 mu)``) and ``sigma_zz = 0``; elsewhere it is Hooke's law in 3-D.
    """
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    if mode == "plane_stress":
        lam_s = 2 * lam * mu / (lam + 2 * mu)
        tr = eps[0, 0] + eps[1, 1]
        s = 2 * mu * eps + lam_s * tr * ufl.as_tensor([[1, 0, 0], [0, 1, 0], [0, 0, 0]])
        return ufl.as_tensor([[s[0, 0], s[0, 1], 0], [s[1, 0], s[1, 1], 0], [0, 0, 0]])
    return 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(3)


def weight(mesh, mode: str):
    """The weight of integrals over the bodies: ``2 pi r`` (axisymmetric) or 1 (UFL)."""
    if mode == "axisymmetric":
        return 2 * math.pi * ufl.SpatialCoordinate(mesh)[0]
    return 1


def point_weight(points: np.ndarray, mode: str) -> np.ndarray:
    """The same weight at given points ``(n, gdim)`` (numpy): for the interface's quadrature."""
    points = np.asarray(points, dtype=float)
    if mode == "axisymmetric":
        return 2 * math.pi * points[:, 0]
    return np.ones(points.shape[0])
