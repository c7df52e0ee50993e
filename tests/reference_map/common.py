"""Constants of the reference map and the per-law floats it works with."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

EPS = float(np.finfo(float).eps)
TINY = float(np.finfo(float).tiny)
S_SERIES = 1e-3  # E'(s): series below, closed form above (see scan.dE)
KD_CAP = 36.0  # cap of k * d_n in the offset c of the Newton variable (r_n = 1 - O(1e-16))
ROT_LO, ROT_HI = 1e-100, 1e100  # rotation only for tractions (MPa) and g in this range
HERMITE_MIN = 0.5  # model of |f_t| in a step used when its minimum >= this * end values
SPLIT_EPS = 8.0 * EPS  # a split needs (1 - s*) |w| > SPLIT_EPS (|f0| + |f*|)
# Gauss-Legendre on [0, 1]: 3 outer points (C = int cos theta; plus x = 1 for theta_1) and 2
# inner points per outer node (J(x) = int_0^x dy / rho): 8 inner nodes. With the elastic path
# subtracted the integrands are smooth; 4 x 4 points gave the same errors (to 3 digits) on the
# turn, turn45 and early paths and on the extreme fuzz points checked.
GXO = (0.1127016653792583, 0.5, 0.8872983346207417)
GWO = (0.2777777777777778, 0.4444444444444444, 0.2777777777777778)
GXI = (0.2113248654051871, 0.7886751345948129)
GWI = (0.5, 0.5)
NO, NI = len(GXO), len(GXI)  # outer points (C), inner points per outer node (J)

# Status codes (as ``Status``)
ELASTIC, PLASTIC, SEPARATED, JUMP, FAILED = 0, 1, 2, 3, 4


class Law:
    """The floats of a :class:`~subfric_dolfinx.constitutive.SubloadingLaw`, with derived constants.

    Built once per law object (cached on it) so that a call of the map does no attribute work.

    Attributes:
        p: The law itself (for the branch-and-bound scan).
        at, an, mu_s, mu_k, kappa, xi, ut, cn: ``alpha_t``, ``alpha_n``, ``mu_s``, ``mu_k``,
            ``kappa``, ``xi``, ``u_tilde``, ``c_n``.
        k: ``pi u_tilde / 2``.
        sqrt2k_inv: ``1 / sqrt(2 k)`` (the slope of ``r`` in ``z`` at ``r = 0``).
        zc_cap: Cap of the offset ``c`` of the Newton variable, ``sqrt(KD_CAP / k)``.
        len_n: The law's normal length ``1 / (c_n alpha_n)`` (the contact band's floor).
    """

    __slots__ = (
        "an",
        "at",
        "cn",
        "k",
        "kappa",
        "len_n",
        "mu_k",
        "mu_s",
        "p",
        "sqrt2k_inv",
        "ut",
        "xi",
        "zc_cap",
    )

    def __init__(self, p: Any) -> None:
        self.p = p
        self.at, self.an = float(p.alpha_t), float(p.alpha_n)
        self.mu_s, self.mu_k = float(p.mu_s), float(p.mu_k)
        self.kappa, self.xi = float(p.kappa), float(p.xi)
        self.ut, self.cn = float(p.u_tilde), float(p.c_n)
        self.k = 0.5 * math.pi * self.ut
        self.sqrt2k_inv = 1.0 / math.sqrt(2.0 * self.k)
        self.zc_cap = math.sqrt(KD_CAP / self.k)
        with np.errstate(over="ignore"):
            self.len_n = float(np.float64(1.0) / (np.float64(self.cn) * self.an))
