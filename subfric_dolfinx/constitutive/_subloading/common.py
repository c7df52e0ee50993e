"""Constants of the subloading return map, the law's floats, the settings and the chunk's data.

The map's data are grouped as MGIS's behaviour data are: the law's parameters (:class:`Law`),
the settings of the integration (:class:`Settings`), the inputs of a chunk of points (the
state at the start of the step and the gap at its end, :class:`Inputs`) and its outputs (the
state at the end, the traction and the tangent, :class:`Outputs`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..result import Status

EPS = float(np.finfo(float).eps)
TINY = float(np.finfo(float).tiny)
S_SERIES = 1e-3  # E'(s): series below, closed form above (see branch.E_dE)
KD_CAP = 36.0  # cap of k * d_n in the offset c of the Newton variable (r_n = 1 - O(1e-16))
ROT_LO, ROT_HI = 1e-100, 1e100  # rotation only for tractions (MPa) and g in this range
HERMITE_MIN = 0.5  # model of |f_t| in a step used when its minimum >= this * end values
SPLIT_EPS = 8.0 * EPS  # a split needs (1 - s*) |w| > SPLIT_EPS (|f0| + |f*|)
CHUNK = 8192  # points per chunk: the arrays of a chunk stay within a core's cache
# Gauss-Legendre on [0, 1]: 3 outer points (C = int cos theta; plus x = 1 for theta_1) and 2
# inner points per outer node (J(x) = int_0^x dy / rho): 8 inner nodes. With the elastic path
# subtracted the integrands are smooth; 4 x 4 points gave the same errors (to 3 digits) on the
# turn, turn45 and early paths and on the extreme fuzz points checked.
GXO = np.array([0.1127016653792583, 0.5, 0.8872983346207417])
GWO = np.array([0.2777777777777778, 0.4444444444444444, 0.2777777777777778])
GXI = np.array([0.2113248654051871, 0.7886751345948129])
GWI = np.array([0.5, 0.5])
NO, NI = GXO.size, GXI.size  # outer points (C), inner points per outer node (J)

# Status codes: the values of ``Status``, as plain ints
ELASTIC, PLASTIC, SEPARATED, JUMP, FAILED = (
    int(s) for s in (Status.ELASTIC, Status.PLASTIC, Status.SEPARATED, Status.JUMP, Status.FAILED)
)


class Law:
    """The floats of a :class:`~subfric_dolfinx.constitutive.SubloadingLaw`, with derived constants.

    Built once per law object (cached on it) so that a call of the map does no attribute work.

    Attributes:
        at, an, mu_s, mu_k, kappa, xi, ut, cn: ``alpha_t``, ``alpha_n``, ``mu_s``, ``mu_k``,
            ``kappa``, ``xi``, ``u_tilde``, ``c_n``.
        k: ``pi u_tilde / 2``.
        sqrt2k_inv: ``1 / sqrt(2 k)`` (the slope of ``r`` in ``z`` at ``r = 0``).
        zc_cap: Cap of the offset ``c`` of the Newton variable, ``sqrt(KD_CAP / k)``.
        len_n: The law's normal length ``1 / (c_n alpha_n)`` (the contact band's floor).
    """

    __slots__ = (
        "_diag",
        "an",
        "at",
        "cn",
        "k",
        "kappa",
        "len_n",
        "mu_k",
        "mu_s",
        "sqrt2k_inv",
        "ut",
        "xi",
        "zc_cap",
    )

    def __init__(self, p: Any) -> None:
        self.at, self.an = float(p.alpha_t), float(p.alpha_n)
        self.mu_s, self.mu_k = float(p.mu_s), float(p.mu_k)
        self.kappa, self.xi = float(p.kappa), float(p.xi)
        self.ut, self.cn = float(p.u_tilde), float(p.c_n)
        self.k = 0.5 * math.pi * self.ut
        self.sqrt2k_inv = 1.0 / math.sqrt(2.0 * self.k)
        self.zc_cap = math.sqrt(KD_CAP / self.k)
        with np.errstate(over="ignore"):
            self.len_n = float(np.float64(1.0) / (np.float64(self.cn) * self.an))
        self._diag: dict[int, np.ndarray] = {}

    def elastic_tangent(self, nt: int) -> np.ndarray:
        """The one-sided elastic tangent ``diag(alpha_t, .., alpha_n)`` (m, m), read-only."""
        d = self._diag.get(nt)
        if d is None:
            d = np.diag([self.at] * nt + [self.an])
            d.flags.writeable = False
            self._diag[nt] = d
        return d


class Settings:
    """How a call integrates.

    The consistency tolerance and loading margin ``tol`` (relative to ``g mu_s``), the root
    finders' iteration limit ``max_iter``, the contact band ``contact_tol``
    (:mod:`..tolerances`).
    """

    __slots__ = ("contact_tol", "max_iter", "tol")

    def __init__(self, tol: float, max_iter: int, contact_tol: float) -> None:
        self.tol, self.max_iter, self.contact_tol = tol, max_iter, contact_tol


class Inputs:
    """One chunk's inputs.

    The gap at the end of the step (n, m), the state at its start (``up`` (n, nt), ``mu``,
    ``r``; ``f0`` (n, m) or None: the start traction) and ``dt`` (a float or (n,)).
    """

    __slots__ = ("dt", "f0", "gap", "mu", "r", "up")

    def __init__(self, gap, up, mu, r, f0, dt) -> None:
        self.gap, self.up, self.mu, self.r, self.f0, self.dt = gap, up, mu, r, f0, dt


class Outputs:
    """One chunk's outputs, written in place.

    Traction (n, m), tangent (n, m, m), the end state (``up``, ``mu``, ``r``), status (int8),
    unstable (bool) and the evaluations of ``phi``.
    """

    __slots__ = ("iters", "mu", "r", "status", "tan", "tr", "unstable", "up")

    def __init__(self, tr, tan, up, mu, r, status, unstable, iters) -> None:
        self.tr, self.tan, self.up, self.mu, self.r = tr, tan, up, mu, r
        self.status, self.unstable, self.iters = status, unstable, iters

    def rows(self, sl: slice) -> Outputs:
        """Views of the rows ``sl``."""
        return Outputs(*(getattr(self, k)[sl] for k in Outputs._order))

    _order = ("tr", "tan", "up", "mu", "r", "status", "unstable", "iters")

    def fail(self, i, up, mu, r, iters) -> None:
        """Points ``i`` could not be integrated: zero traction and tangent, the given state."""
        self.tr[i] = 0.0
        self.tan[i] = 0.0
        self.up[i], self.mu[i], self.r[i] = up, mu, r
        self.status[i] = FAILED
        self.unstable[i] = False
        self.iters[i] = iters


def norm_t(v: np.ndarray) -> np.ndarray:
    """Row norms of tangential vectors (k, 1) or (k, 2) (``hypot``: no overflow, no underflow)."""
    return np.abs(v[:, 0]) if v.shape[1] == 1 else np.hypot(v[:, 0], v[:, 1])


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row dot products of (k, j) arrays."""
    return np.einsum("ij,ij->i", a, b)
