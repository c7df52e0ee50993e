"""Step 6: the consistent tangent ``D = d(f_t, f_n) / d(ubar_t, ubar_n)``, forward derivatives.

The exact derivative of what the step computes, so that FE Newton converges quadratically
(``docs/model.md`` §6.8). Derivatives are arrays with a last axis over the m gap components:

* the start state of the plastic part (:func:`start_derivatives`): zero without a split, else
  through the split point (:func:`.switch.split_ds`);
* a root (:func:`root_derivative`): the implicit function theorem on ``phi(dl) = 0``, with the
  branch's partials (:func:`.branch.partials`);
* a traction along a fixed direction ``t* = f_t* / |f_t*|`` (:func:`fixed_direction`: the
  radial return, with or without a split; without a split it is the closed form
  ``D_tt = alpha_t [(1 - alpha_t / H) t* t*^T + (|f_t| / A)(I - t* t*^T)]``,
  ``D_tn = alpha_t alpha_n g' r mu / H t*``); the rotated direction's derivatives are chained
  in :mod:`.rotation`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .branch import Branch, partials
from .common import Law
from .root import Root
from .switch import ROOT, Segment, split_ds

__all__ = ["StartDerivatives", "fixed_direction", "root_derivative", "start_derivatives"]


class StartDerivatives:
    """Derivatives over the gap of the plastic part's start state, k points.

    The traction ``df_s`` (k, nt, m), its magnitude ``drho_s``, normal component ``dfn_s``,
    saturation ``dg_s``, and ``dr0``, ``dmu0``, ``db`` (the rest of the step's ``xi dt``), each
    (k, m).
    """

    __slots__ = ("db", "df_s", "dfn_s", "dg_s", "dmu0", "dr0", "drho_s")

    db: npt.NDArray[np.float64]
    df_s: npt.NDArray[np.float64]
    dfn_s: npt.NDArray[np.float64]
    dg_s: npt.NDArray[np.float64]
    dmu0: npt.NDArray[np.float64]
    dr0: npt.NDArray[np.float64]
    drho_s: npt.NDArray[np.float64]

    def take(self, i) -> StartDerivatives:
        """Points ``i``."""
        o = StartDerivatives()
        for k in StartDerivatives.__slots__:
            setattr(o, k, getattr(self, k)[i])
        return o


def start_derivatives(L: Law, pl) -> StartDerivatives | None:
    """The start state's derivatives of the plastic points ``pl`` (a ``Plastic``).

    None when none of them has a split (then they are all zero).
    """
    si = pl.kind.nonzero()[0]
    if si.size == 0:
        return None
    at, an, cn = L.at, L.an, L.cn
    k, nt = pl.ft.shape
    m = nt + 1
    sd = StartDerivatives()
    sd.df_s = np.zeros((k, nt, m))
    for name in ("drho_s", "dr0", "dmu0", "db", "dg_s", "dfn_s"):
        setattr(sd, name, np.zeros((k, m)))
    b = pl.b[si]
    kind = pl.kind[si]
    sg = Segment(pl.f0t[si], pl.fn0[si], pl.ft[si], pl.fn[si], pl.A[si], pl.mu_c[si], b)
    s = pl.s[si]
    ds = split_ds(L, sg, s, kind)
    dfs = ds[:, None, :] * sg.w[:, :, None]
    for i in range(nt):
        dfs[:, i, i] += s * at
    dfns = ds * sg.dfn[:, None]
    dfns[:, nt] += s * an
    g_s = pl.g_s[si]
    dgs = (cn * (1.0 - g_s))[:, None] * dfns
    br = pl.br
    r0, m0 = br.r0[si], br.mu0[si]
    dm0 = (-br.d_s[si] * b)[:, None] * ds  # mu_s - mu0 without cancellation
    f_s, rho_s = pl.f_s[si], pl.rho_s[si]
    rp = rho_s > 0.0
    drh = np.einsum("ki,kij->kj", f_s, dfs) / np.where(rp, rho_s, 1.0)[:, None]
    drh = np.where(rp[:, None], drh, 0.0)
    okr = rp & (r0 < 1.0)
    gsm = np.where(okr, g_s * m0, 1.0)
    # (ROOT: r0 = r_n rho_s g_0 mu_n / (rho_0 g_s mu0): d r0 / d rho_s = r0 / rho_s)
    gsm = np.where(kind == ROOT, np.where(okr, rho_s / r0, 1.0), gsm)
    gs1 = np.where(okr, g_s, 1.0)
    dr0 = drh / gsm[:, None] - r0[:, None] * (dgs / gs1[:, None] + dm0 / m0[:, None])
    sd.dr0[si] = np.where(okr[:, None], dr0, 0.0)
    sd.df_s[si], sd.drho_s[si], sd.dmu0[si], sd.db[si] = dfs, drh, dm0, -b[:, None] * ds
    sd.dg_s[si], sd.dfn_s[si] = dgs, dfns
    return sd


def root_derivative(L: Law, br: Branch, root: Root, dA, sd: StartDerivatives | None):
    """``d dl`` (k, m) of the roots of ``br`` for a trial magnitude changing by ``dA`` (k, m).

    ``d dl = (dA - d(g r mu) at fixed dl) / H`` (``H = -phi'``), through the normal traction
    (``g``) and, with ``sd``, the start state.
    """
    e = root.e
    g = br.g
    H, R, Mmu, Mb = partials(br, root.dl, e, sd is not None)
    Hc = H[:, None]
    ddl = dA / Hc
    if sd is not None:
        dstart = (g * e.mu * R)[:, None] * sd.dr0
        dstart += (g * e.r)[:, None] * (Mmu[:, None] * sd.dmu0 + Mb[:, None] * sd.db)
        ddl -= dstart / Hc
    ddl[:, -1] -= L.cn * (1.0 - g) * L.an * e.r * e.mu / H
    return ddl


def fixed_direction(L: Law, pl, sd: StartDerivatives | None):
    """Traction (k, m) and tangent (k, m, m) of points ``pl`` keeping the trial direction.

    ``|f_t| = min(g r mu, A)`` from the predictor's root.
    """
    at = L.at
    k, nt = pl.ft.shape
    m = nt + 1
    e = pl.root.e
    t, A = pl.t, pl.A
    rho1 = np.minimum(pl.g * e.r * e.mu, A)
    dA = np.zeros((k, m))
    dA[:, :nt] = at * t
    drho1 = dA - at * root_derivative(L, pl.br, pl.root, dA, sd)
    D = np.zeros((k, m, m))
    D[:, :nt, :] = t[:, :, None] * drho1[:, None, :]
    proj = np.eye(nt) - t[:, :, None] * t[:, None, :]
    D[:, :nt, :nt] += (rho1 * at / A)[:, None, None] * proj
    D[:, nt, nt] = L.an
    tr = np.empty((k, m))
    tr[:, :nt] = rho1[:, None] * t
    tr[:, nt] = pl.fn
    return tr, D
