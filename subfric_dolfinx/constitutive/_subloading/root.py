"""Step 4: the smallest root of ``phi`` (the radial return), certified.

Newton in ``z`` (``dl = z (2 c + z)``: ``r`` is regular in ``z`` at ``r_0 = 0``), each
iteration solving the quadratic model ``A - alpha_t z (2c + z) - h - h' (z' - z) = 0`` exactly
(``h = g r mu`` linearised; exact for ``r ~ sqrt(dl)`` from ``r = 0`` and for a trial far
outside), safeguarded by a bracket and (geometric) bisection. The root is *certified* smallest by
the slope bound ``alpha_t + g U(r*) mu* - g r* |mu'(0)| > 0`` (``phi`` strictly decreasing on
``[0, dl*]``), else by the branch-and-bound scan of :mod:`.scan` (which also detects folds:
``JUMP``).

The active points live in one compact (fields, points) work array, compressed with one boolean
index whenever some converge; finished points are written to the outputs then.
"""

from __future__ import annotations

import numpy as np

from . import scan
from .branch import Branch, Eval, Row, evaluate
from .common import EPS, TINY

__all__ = ["Root", "smallest_root"]

# rows of the work array after the branch's (.branch.Row): the iteration's state
_Z, _C2A, _TOL, _LO, _HI, _FLO, _FHI, _DZ = range(Row.N, Row.N + 8)
_NW = Row.N + 8


class Root:
    """The roots of k points.

    Slip ``dl``, the branch there (:class:`.branch.Eval`), converged, evaluations of ``phi``,
    and ``jump`` (the smallest root lies beyond a fold).
    """

    __slots__ = ("conv", "dl", "e", "it", "jump")

    def __init__(self, dl, e: Eval, conv, it, jump) -> None:
        self.dl, self.e, self.conv, self.it, self.jump = dl, e, conv, it, jump

    def take(self, i) -> Root:
        return Root(self.dl[i], self.e.take(i), self.conv[i], self.it[i], self.jump[i])


def smallest_root(br: Branch, tol_f, max_iter: int, dl_start=None, e_start: Eval | None = None):
    """The certified smallest root of the branch ``br`` (:class:`Root`).

    ``tol_f``: tolerance on ``|phi|`` per point. ``dl_start``, ``e_start``: start the iteration
    from these slips, where the branch is known (the corrector of :mod:`.rotation` starts from
    the predictor's root: same start state, ``phi`` shifted by ``A_eff - A``); from ``dl = 0``
    without.
    """
    dl, e, conv, it, cert = _solve(br, tol_f, max_iter, dl_start, e_start)
    jump = np.zeros(dl.size, dtype=bool)
    unc = (conv & ~cert).nonzero()[0]
    if unc.size:
        sub = br.take(unc)
        x, ok, its, jp = scan.scan(sub, dl[unc], tol_f[unc], max_iter)
        dl[unc], conv[unc], jump[unc] = x, ok, jp
        it[unc] += its
        e.put(unc, sub.ev(x))
    return Root(dl, e, conv, it, jump)


def _solve(br: Branch, tol_f, max_iter, dl_start, e_start):
    """Newton in ``z``: ``dl, Eval, converged, evaluations, certified``.

    The active points' columns of the work array ``Wk`` are compressed whenever some converge;
    a converged point's rows ``PHI .. SN`` and ``Z`` (contiguous) go to ``out`` then.
    """
    L = br.L
    at = L.at
    k = br.A.size
    Wk = br.work(_NW)
    c = Wk[Row.C]
    np.multiply(c, 2.0 * at, out=Wk[_C2A])
    Wk[_TOL] = tol_f
    dl_max = Wk[Row.A] / at
    hi = dl_max / (np.sqrt(c * c + dl_max) + c)
    if dl_start is None:
        z = 0.0
        Wk[Row.PHI] = br.A - br.g * br.r0 * br.mu_rec
        Wk[Row.R : Row.SN + 1] = Wk[[Row.R0, Row.MUREC, Row.DMU0, Row.C0, Row.SIN0]]
    else:
        z = dl_start / (np.sqrt(c * c + dl_start) + c)
        e = e_start
        Wk[Row.PHI], Wk[Row.R], Wk[Row.MU], Wk[Row.DMU] = e.phi, e.r, e.mu, e.dmu
        Wk[Row.W], Wk[Row.SN] = e.w, e.sn
    Wk[_Z] = z
    phi = Wk[Row.PHI]
    pos = phi > 0.0
    lo, f_lo, hi_, f_hi = Wk[_LO], Wk[_FLO], Wk[_HI], Wk[_FHI]
    lo[:], f_lo[:], hi_[:], f_hi[:] = 0.0, np.inf, z, phi
    np.putmask(lo, pos, z)
    np.putmask(f_lo, pos, phi)
    np.putmask(hi_, pos, hi)
    np.putmask(f_hi, pos, -np.inf)
    np.subtract(hi_, lo, out=Wk[_DZ])
    out = np.empty((_Z + 1 - Row.PHI, k))  # rows PHI .. SN, Z of the converged points
    it_out = np.empty(k, dtype=np.int64)
    conv = np.zeros(k, dtype=bool)
    idx = np.arange(k)  # the points of the columns of Wk
    it = 0
    done = np.abs(phi) <= Wk[_TOL]
    if np.count_nonzero(done):
        out[:, idx[done]] = Wk[Row.PHI : _Z + 1, done]
        it_out[idx[done]] = 0
        conv[idx[done]] = True
        keep = ~done
        Wk, idx = Wk[:, keep], idx[keep]
    halve = False
    ut2 = 2.0 * L.ut
    lim0 = ut2 * L.sqrt2k_inv
    tiny4 = 4.0 * EPS
    while idx.size and it < max_iter:
        za, ca, ga, r, mu, sn = Wk[_Z], Wk[Row.C], Wk[Row.G], Wk[Row.R], Wk[Row.MU], Wk[Row.SN]
        cz = ca + za
        drdz = (ut2 * cz) * Wk[Row.W] / sn
        z0 = sn == 0.0
        if np.count_nonzero(z0):  # r = 0 at z = 0: the limit of 2 (c + z) U(r)
            drdz[z0] = lim0
        gr = ga * r
        hp = ga * mu * drdz + (2.0 * gr) * Wk[Row.DMU] * cz
        Bq = Wk[_C2A] + hp
        Q = Wk[Row.A] - gr * mu + hp * za
        disc = Bq * Bq + (4.0 * at) * Q
        sd = np.sqrt(np.maximum(disc, 0.0))
        zn = np.where(Bq > 0.0, 2.0 * Q / (Bq + sd), (sd - Bq) / (2.0 * at))
        la, ha = Wk[_LO], Wk[_HI]
        bad = ~((disc >= 0.0) & (zn > la) & (zn < ha))
        if halve:
            bad |= np.abs(zn - za) > 0.5 * np.abs(Wk[_DZ])
        if np.count_nonzero(bad):
            geo = np.sqrt(np.maximum(la, TINY)) * np.sqrt(ha)
            mid = np.where(ha > 1e3 * la, geo, 0.5 * (la + ha))
            np.putmask(zn, bad, mid)
        np.subtract(zn, za, out=Wk[_DZ])
        Wk[_Z] = zn
        evaluate(L, Wk, zn * (2.0 * ca + zn))
        it += 1
        ph = Wk[Row.PHI]
        pos = ph > 0.0
        neg = ~pos
        np.putmask(la, pos, zn)  # (la, ha: views of the rows LO, HI)
        np.putmask(ha, neg, zn)
        np.putmask(Wk[_FLO], pos, ph)
        np.putmask(Wk[_FHI], neg, ph)
        tol = Wk[_TOL]
        ok = np.abs(ph) <= tol
        flat = (Wk[_FLO] - Wk[_FHI] <= 2.0 * tol) | (Wk[_HI] - Wk[_LO] <= tiny4 * Wk[_HI])
        done = ok | flat
        if not np.count_nonzero(done):
            halve = True
            continue
        ex = flat & ~ok
        its = it
        if np.count_nonzero(ex):  # bracket exhausted: the end closer to phi = 0 (one more
            Wx = Wk[:, ex]  # evaluation)
            Wx[_Z] = np.where(Wx[_FLO] < -Wx[_FHI], Wx[_LO], Wx[_HI])
            evaluate(L, Wx, Wx[_Z] * (2.0 * Wx[Row.C] + Wx[_Z]))
            Wk[:, ex] = Wx
            its = it + ex[done]
        i = idx[done]
        out[:, i] = Wk[Row.PHI : _Z + 1, done]
        it_out[i] = its
        conv[i] = True
        keep = ~done
        Wk, idx = Wk[:, keep], idx[keep]
        halve = True
    if idx.size:  # iteration limit: not converged
        out[:, idx] = Wk[Row.PHI : _Z + 1]
        it_out[idx] = it
    phi, r, mu, dmu, w, sn, z = out
    e = Eval(phi, r, L.ut * w / sn, mu, dmu, w, sn)  # U = dr/ddl (w > 0; inf at sn = 0)
    dl = z * (2.0 * br.c + z)
    g = br.g
    cert = conv & (at + g * e.U * e.mu - g * e.r * np.abs(br.dmu0) > 0.0)
    return dl, e, conv, it_out, cert
