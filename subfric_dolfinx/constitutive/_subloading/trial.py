"""Step 1: validation, the elastic trial, contact, and the outputs of a step without slip.

``f_t* = alpha_t (ubar_t - up_n)``, ``A = |f_t*|``, ``f_n = alpha_n ubar_n``,
``g = 1 - exp(-c_n f_n)``, ``mu`` recovered over the step. A point *touches* within the contact
band of :mod:`..tolerances` and is out of contact for ``ubar_n < 0`` (zero traction, ``r = 0``,
``up`` frozen, ``mu`` recovering). A point with a non-finite input, ``r`` or ``mu`` out of range
is FAILED with the virgin state; an overflowing trial is FAILED with its last state.
"""

from __future__ import annotations

import numpy as np

from ..tolerances import contact_band
from .branch import g_of
from .common import ELASTIC, FAILED, SEPARATED, Inputs, Law, Outputs, Settings, norm_t

__all__ = ["Trial"]


class Trial:
    """The elastic trial of a chunk of n points.

    Attributes:
        ok, all_ok: Valid inputs; every input valid.
        up, mu, r: The start state, made safe (virgin where not ``ok``; ``mu``, ``r`` clipped).
        ft, A, fn, g: Trial tangential traction (n, nt), its magnitude, normal traction,
            saturation.
        b: ``xi dt`` (n,); ``mu_rec``: ``mu`` recovered over the step.
        touching, contact, separated, finite: Masks: in the contact band; in contact (and not
            touching); valid and not in contact; a finite trial magnitude.
    """

    __slots__ = (
        "A",
        "all_ok",
        "b",
        "contact",
        "finite",
        "fn",
        "ft",
        "g",
        "mu",
        "mu_rec",
        "ok",
        "r",
        "separated",
        "touching",
        "up",
    )

    def __init__(self, L: Law, inp: Inputs, cfg: Settings) -> None:
        gap, up, mu, r, f0, dt = inp.gap, inp.up, inp.mu, inp.r, inp.f0, inp.dt
        n, nt = up.shape
        mu_k, mu_s = L.mu_k, L.mu_s
        ok = (
            np.isfinite(gap).all(axis=1)
            & np.isfinite(up).all(axis=1)
            & (r >= -1e-9)  # (the comparisons are False for NaN and refuse inf)
            & (r <= 1.0 + 1e-9)
            & (mu >= mu_k * (1 - 1e-12))
            & (mu <= mu_s * (1 + 1e-12))
        )
        if f0 is not None:
            ok &= np.isfinite(f0).all(axis=1)
        self.ok = ok
        self.all_ok = all_ok = np.count_nonzero(ok) == n
        if not all_ok:  # (made safe: virgin where not ok)
            gap = np.where(ok[:, None], gap, 0.0)
            up = np.where(ok[:, None], up, 0.0)
        self.up = up
        mu_c = np.minimum(np.maximum(mu, mu_k), mu_s)
        r_c = np.minimum(np.maximum(r, 0.0), 1.0)
        self.mu = mu_c = mu_c if all_ok else np.where(ok, mu_c, mu_s)
        self.r = r_c if all_ok else np.where(ok, r_c, 0.0)
        self.ft = ft = L.at * (gap[:, :nt] - up)
        self.A = A = norm_t(ft)
        un = gap[:, nt]
        self.fn = fn = L.an * un
        self.g = g = g_of(L, fn)
        if cfg.contact_tol > 0.0:
            touching = ok & (np.abs(un) <= contact_band(gap, up, L.len_n, cfg.contact_tol))
        else:
            touching = ok & (un == 0.0)
        self.touching = touching
        contact = ok & ~touching & (un > 0.0) & (g > 0.0)
        self.finite = np.isfinite(A)
        self.separated = ok & ~contact
        self.contact = contact & self.finite  # an overflowing trial fails: last state kept
        self.b = b = np.full(n, L.xi * dt) if isinstance(dt, float) else L.xi * dt
        self.mu_rec = np.minimum(mu_c + (mu_s - mu_c) * (-np.expm1(-b)), mu_s)

    def write(self, L: Law, elastic: np.ndarray, out: Outputs) -> None:
        """Outputs of every point as if no point slipped.

        The elastic trial where ``elastic``, zero traction where separated or failed, the state
        recovered (``r`` of the trial in contact, 0 when separated); the one-sided elastic
        tangent where elastic or touching.
        ``out.tr``, ``out.tan``, ``out.iters`` and ``out.unstable`` hold zeros on entry.
        """
        nt = self.ft.shape[1]
        n = elastic.size
        status, sep = out.status, self.separated
        n_el, n_sep = np.count_nonzero(elastic), np.count_nonzero(sep)
        if n_el == n:
            status[:] = ELASTIC
        elif n_sep == n:
            status[:] = SEPARATED
        else:
            status[:] = FAILED
            if n_el:
                status[elastic] = ELASTIC
            if n_sep:
                status[sep] = SEPARATED
        out.up[:] = self.up
        fin = self.finite if self.all_ok else self.ok & self.finite
        all_fin = np.count_nonzero(fin) == n
        out.mu[:] = self.mu_rec if all_fin else np.where(fin, self.mu_rec, self.mu)
        A, gm = self.A, self.g * self.mu_rec
        r_el = np.where(A == 0.0, 0.0, np.where(A < gm, A / gm, 1.0))
        out.r[:] = np.where(self.contact, r_el, np.where(sep, 0.0, self.r))
        if n_el == n:
            out.tr[:, :nt] = self.ft
            out.tr[:, nt] = self.fn
        elif n_el:
            out.tr[elastic, :nt] = self.ft[elastic]
            out.tr[elastic, nt] = self.fn[elastic]
        one_sided = elastic | self.touching
        n_os = np.count_nonzero(one_sided)
        if n_os == n:
            out.tan[:] = L.elastic_tangent(nt)
        elif n_os:
            out.tan[one_sided] = L.elastic_tangent(nt)
