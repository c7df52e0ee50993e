"""Step 3: the plastic branch in closed form, ``phi(dl)``, and its partials at a root.

For a plastic slip ``dl`` at a constant rate over the (rest of the) step from the start state
``(r_0, mu_0)``, ``r`` and ``mu`` integrate exactly:
``cos(pi r / 2) = cos(pi r_0 / 2) exp(-k dl)`` (``k = pi u_tilde / 2``; written with
``q = sin^2(pi r / 4)`` so that ``r`` stays accurate near 0 and 1) and
``mu = mu_0 - (a (mu_0 - mu_k) + b (mu_0 - mu_s)) E(a + b)``, ``a = kappa dl``, ``b = xi dt``,
``E(s) = (1 - exp(-s)) / s``; then ``phi(dl) = A - alpha_t dl - g r(dl) mu(dl)``.

:class:`Branch` holds the per-point constants of the closed forms in one (fields, points) block,
so that a subset is one gather and the root finder's work array (:mod:`.root`) one copy;
:func:`evaluate` is the one evaluation of the closed forms, used by the root finder, the
certification scan and the tangent.
"""

from __future__ import annotations

import numpy as np

from .common import S_SERIES, Law

__all__ = ["Branch", "E_dE", "Eval", "Row", "evaluate", "g_of", "partials", "unstable"]

_PI = np.pi
_4PI = 4.0 / _PI


class Row:
    """Rows of a branch's block and of the work arrays made from it (fields, points).

    The branch's constants (with the folded ``0.5 c0``, ``kappa d_k``, ``b d_s`` that
    :func:`evaluate` uses), then the rows :func:`evaluate` writes; the root finder appends its
    own rows (:mod:`.root`).
    """

    C0, HC0, S0, KDK, BDS, B, MU0, A, G = range(9)  # read by evaluate()
    DK, DS, C, R0, SIN0, MUREC, DMU0 = range(9, 16)
    PHI, R, MU, DMU, W, SN = range(16, 22)  # written by evaluate()
    N = 22


def E_dE(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``E(s) = (1 - exp(-s)) / s`` and ``E'(s)`` for ``s >= 0`` (series below ``S_SERIES``).

    The closed form of ``E'`` loses ``eps / s`` absolutely to cancellation; it only enters
    ``mu'`` multiplied by ``D = O(s)``, so the series' error ``s^3 / 30`` keeps ``mu'`` exact.
    """
    em = np.expm1(-s)
    E = -em / s
    small = s < S_SERIES
    n_small = np.count_nonzero(small)
    if n_small == s.size:  # (the closed form of E' not formed where the series replaces it)
        dE = -0.5 + s * (1.0 / 3.0 - 0.125 * s)
    else:
        dE = (em * (1.0 + s) + s) / (s * s)
        if n_small:
            ss = s[small]
            dE[small] = -0.5 + ss * (1.0 / 3.0 - 0.125 * ss)
    if n_small and np.count_nonzero(s == 0.0):
        E[s == 0.0] = 1.0
    return E, dE


def g_of(L: Law, fn: np.ndarray) -> np.ndarray:
    """Saturation ``g(f_n) = 1 - exp(-c_n f_n)`` (0 for ``f_n <= 0``)."""
    return -np.expm1(-L.cn * np.maximum(fn, 0.0))


class Eval:
    """The branch at slips ``dl``.

    ``phi``, ``r``, ``U = dr/ddl``, ``mu``, ``dmu = dmu/ddl``, ``w = cos(pi r / 2)``,
    ``sn = sin(pi r / 2)`` (arrays of one shape).
    """

    __slots__ = ("U", "dmu", "mu", "phi", "r", "sn", "w")

    def __init__(self, phi, r, U, mu, dmu, w, sn) -> None:
        self.phi, self.r, self.U, self.mu, self.dmu, self.w, self.sn = phi, r, U, mu, dmu, w, sn

    def take(self, i) -> Eval:
        return Eval(*(getattr(self, k)[i] for k in Eval._order))

    def put(self, i, other: Eval) -> None:
        for k in Eval._order:
            getattr(self, k)[i] = getattr(other, k)

    _order = ("phi", "r", "U", "mu", "dmu", "w", "sn")


# rows of Branch.Pm
class Branch:
    """The closed-form branch of k plastic points from their start states.

    Per-point constants (views of the rows of one block ``Pm``, laid out as :class:`Row`):
    ``c0 = cos(pi r_0 / 2)``, ``s0 = sin^2(pi r_0 / 4)``, ``sin0 = sin(pi r_0 / 2)``,
    ``b = xi dt`` (of the rest of the step), ``d_k = mu_0 - mu_k``, ``d_s = mu_0 - mu_s``,
    ``mu0``, ``A`` (the trial magnitude), ``g``, ``c`` (the offset of the Newton variable ``z``,
    ``dl = z (2 c + z)``: the square root of the slip that takes ``r`` from 0 to ``r_0``,
    capped), ``r0``, ``mu_rec`` (``mu`` at ``dl = 0``: recovered over the step) and ``dmu0``
    (``dmu/ddl`` there).
    """

    __slots__ = (
        "A",
        "L",
        "Pm",
        "b",
        "c",
        "c0",
        "d_k",
        "d_s",
        "dmu0",
        "g",
        "mu0",
        "mu_rec",
        "r0",
        "s0",
        "sin0",
    )

    def __init__(self, L: Law, Pm: np.ndarray) -> None:
        self.L, self.Pm = L, Pm
        self.c0, self.s0, self.b = Pm[Row.C0], Pm[Row.S0], Pm[Row.B]
        self.mu0, self.A, self.g = Pm[Row.MU0], Pm[Row.A], Pm[Row.G]
        (self.d_k, self.d_s, self.c, self.r0, self.sin0, self.mu_rec, self.dmu0) = Pm[
            Row.DK : Row.DMU0 + 1
        ]

    @classmethod
    def start(cls, L: Law, A, g, r0, mu0, b, d_s=None) -> Branch:
        """The branch from ``(r0, mu0)`` with the recovery ``b`` still to come.

        ``d_s``: ``mu0 - mu_s`` when known without cancellation.
        """
        Pm = np.empty((Row.N, A.size))
        Pm[Row.B] = b
        b = Pm[Row.B]
        qq = 0.25 * _PI * r0
        c0 = Pm[Row.C0]
        c0[:] = np.cos(2.0 * qq)
        np.multiply(c0, 0.5, out=Pm[Row.HC0])
        s0 = Pm[Row.S0]
        s0[:] = np.sin(qq) ** 2
        Pm[Row.SIN0] = 2.0 * np.sqrt(s0 * (1.0 - s0))
        d_k = Pm[Row.DK]
        d_k[:] = mu0 - L.mu_k
        np.multiply(d_k, L.kappa, out=Pm[Row.KDK])
        ds = Pm[Row.DS]
        ds[:] = mu0 - L.mu_s if d_s is None else d_s
        np.multiply(b, ds, out=Pm[Row.BDS])
        Pm[Row.MU0], Pm[Row.A], Pm[Row.G], Pm[Row.R0] = mu0, A, g, r0
        Eb, dEb = E_dE(b)
        Pm[Row.MUREC] = np.minimum(np.maximum(mu0 - b * ds * Eb, L.mu_k), L.mu_s)
        Pm[Row.DMU0] = L.kappa * (-d_k * Eb - b * ds * dEb)
        dn = -np.log1p(-2.0 * np.where(s0 < 0.5, s0, 0.25)) / L.k
        Pm[Row.C] = np.where(s0 < 0.5, np.minimum(np.sqrt(dn), L.zc_cap), L.zc_cap)
        return cls(L, Pm)

    def take(self, i) -> Branch:
        """Points ``i``."""
        return Branch(self.L, self.Pm[:, i])

    def with_A(self, A) -> Branch:
        """The same start states with other trial magnitudes ``A`` (a copy)."""
        Pm = self.Pm.copy()
        Pm[Row.A] = A
        return Branch(self.L, Pm)

    def work(self, nf: int, cols=None) -> np.ndarray:
        """A work array of ``nf >= Row.N`` rows for the columns ``cols``.

        Its first ``Row.N`` rows are the branch's block; ``cols``: all by default, an index
        array may repeat columns.
        """
        Pm = self.Pm if cols is None else self.Pm[:, cols]
        Wk = np.empty((nf, Pm.shape[1]))
        Wk[: Row.N] = Pm
        return Wk

    def ev(self, dl: np.ndarray, cols=None) -> Eval:
        """The branch at slips ``dl``.

        ``dl``: (k,) for the columns ``cols`` (k of them, all by default), or (k, K) for K slips
        per column.
        """
        shape = dl.shape
        if dl.ndim == 2:
            cols = np.repeat(np.arange(self.A.size) if cols is None else cols, shape[1])
        Wk = self.work(Row.N, cols)
        evaluate(self.L, Wk, dl.ravel())
        phi, r, mu, dmu, w, sn = Wk[Row.PHI :].reshape((Row.N - Row.PHI, *shape))
        with np.errstate(divide="ignore", invalid="ignore"):
            U = np.where(w > 0.0, self.L.ut * w / sn, 0.0)  # inf at r = 0
        return Eval(phi, r, U, mu, dmu, w, sn)


def evaluate(L: Law, Wk: np.ndarray, dl: np.ndarray) -> None:
    """The closed forms at ``dl`` for the columns of the work array ``Wk``: rows PHI..SN."""
    em = np.expm1(dl * -L.k)
    np.multiply(Wk[Row.C0], 1.0 + em, out=Wk[Row.W])
    q = np.minimum(np.maximum(Wk[Row.S0] - Wk[Row.HC0] * em, 0.0), 1.0)
    np.multiply(np.arcsin(np.sqrt(q)), _4PI, out=Wk[Row.R])
    np.multiply(np.sqrt(q * (1.0 - q)), 2.0, out=Wk[Row.SN])
    E, dE = E_dE(dl * L.kappa + Wk[Row.B])
    kdk = Wk[Row.KDK]
    D = dl * kdk + Wk[Row.BDS]  # kappa dl (mu0 - mu_k) + b (mu0 - mu_s)
    np.minimum(np.maximum(Wk[Row.MU0] - D * E, L.mu_k), L.mu_s, out=Wk[Row.MU])
    np.negative(kdk * E + (L.kappa * D) * dE, out=Wk[Row.DMU])
    np.subtract(Wk[Row.A] - L.at * dl, Wk[Row.G] * Wk[Row.R] * Wk[Row.MU], out=Wk[Row.PHI])


def partials(br: Branch, dl: np.ndarray, e: Eval, full: bool = True):
    """At a root: ``H = -phi'`` (floored) and, if ``full``, ``dr/dr0``, ``dmu/dmu0``, ``dmu/db``.

    Without ``full`` the last three are None.
    """
    L = br.L
    H = L.at + br.g * (e.U * e.mu + e.r * e.dmu)
    H = np.maximum(np.where(np.isfinite(H), H, L.at), 1e-12 * L.at)
    if not full:
        return H, None, None, None
    c0, sin0, sn = br.c0, br.sin0, e.sn
    okR = (sn > 0.0) & (c0 > 0.0)
    R = np.where(
        okR,
        (e.w / np.where(okR, c0, 1.0)) * sin0 / np.where(okR, sn, 1.0),
        np.where(dl == 0.0, 1.0, 0.0),
    )
    a = L.kappa * dl
    b = br.b
    E, dE = E_dE(a + b)
    Mmu = np.exp(-(a + b))
    D = a * br.d_k + b * br.d_s
    Mb = -br.d_s * E - D * dE
    return H, R, Mmu, Mb


def unstable(L: Law, g: np.ndarray, e: Eval) -> np.ndarray:
    """Loss of stability at the end state (``docs/model.md`` §8).

    The rate-form denominator ``den = -kappa (mu - mu_k) r + U mu + alpha_t / g`` is not
    positive.
    """
    return -L.kappa * (e.mu - L.mu_k) * e.r + e.U * e.mu + L.at / g <= 0.0
