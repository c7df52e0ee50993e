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
    "check_mode",
    "elastic_stress",
    "point_weight",
    "strain",
    "weight",
]

MODES = ("3d", "plane_strain", "plane_stress", "axisymmetric")


def check_mode(mode: str, gdim: int) -> str:
    """``mode`` if it is known and fits a mesh of dimension ``gdim``.

    Raises:
        ValueError: An unknown mode, or one that does not fit ``gdim`` (both named).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    want = 3 if mode == "3d" else 2
    if gdim != want:
        raise ValueError(f"mode {mode!r} needs a {want}-D mesh, got a {gdim}-D one")
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
