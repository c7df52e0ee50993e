"""The subloading return map over a batch: the steps of :mod:`..subloading` in order.

Points go through numpy in chunks of ``CHUNK`` points (the temporaries stay in cache); results
do not depend on the chunking or on the batch size (no cross-point logic). Per chunk: the trial
(step 1, :mod:`.trial`), the split of the elastic trial segment (step 2, :mod:`.switch`), the
loading test on the closed-form branch (step 3, :mod:`.branch`), the predictor's certified root
(step 4, :mod:`.root`), the rotation of the flow direction with the corrector (step 5,
:mod:`.rotation`) and the consistent tangent (step 6, :mod:`.tangent`).
"""

from __future__ import annotations

import numpy as np

from .branch import Branch, unstable
from .common import CHUNK, EPS, JUMP, PLASTIC, Inputs, Law, Outputs, Settings
from .root import Root, smallest_root
from .rotation import rotate, rotates
from .switch import Start, start_state
from .tangent import fixed_direction, root_derivative, start_derivatives
from .trial import Trial

__all__ = ["integrate"]


def integrate(L: Law, inp: Inputs, out: Outputs, cfg: Settings, chunk: int = CHUNK) -> None:
    """Integrate the step of every point of ``inp`` into ``out``.

    ``out``'s traction, tangent, iterations and unstable hold zeros on entry.
    """
    n = inp.up.shape[0]
    with np.errstate(all="ignore"):
        if n <= chunk:
            _chunk(L, inp, out, cfg)
            return
        for a in range(0, n, chunk):
            sl = slice(a, min(a + chunk, n))
            part = Inputs(
                inp.gap[sl],
                inp.up[sl],
                inp.mu[sl],
                inp.r[sl],
                None if inp.f0 is None else inp.f0[sl],
                inp.dt if np.ndim(inp.dt) == 0 else inp.dt[sl],
            )
            _chunk(L, part, out.rows(sl), cfg)


def _chunk(L: Law, inp: Inputs, out: Outputs, cfg: Settings) -> None:
    t = Trial(L, inp, cfg)  # step 1
    st = start_state(L, t, inp.f0)  # step 2
    # step 3, the loading test: plastic only when the trial leaves the loading surface (at the
    # start of the plastic part) by more than tol g mu
    gm = t.g * st.mu_rec
    plastic = t.contact & (t.A > 0.0) & (t.A - gm * st.r > cfg.tol * gm)
    t.write(L, t.contact & ~plastic, out)
    P = plastic.nonzero()[0]
    if P.size:
        _plastic(L, Plastic(L, t, st, P, cfg.tol), out, cfg.max_iter)


class Plastic:
    """The plastic points of a chunk (rows ``P``) and what steps 4-6 work on.

    Attributes:
        P: Their rows in the chunk.
        ft, A, fn, g, t: Trial tangential traction, its magnitude, normal traction, saturation,
            direction ``t* = f_t* / A``.
        up: Plastic slip at the start of the step.
        mu_c, r_c, b: ``mu`` and ``r`` at the start of the step, the step's ``xi dt`` (before
            any split).
        tol: Tolerance on ``|phi|``, ``max(tol g mu_s, 8 eps A)``.
        kind, s, f0t, fn0, f_s, fn_s, g_s, rho_s: The split and the start traction (the
            attributes of :class:`.switch.Start`; the traction ones None without one).
        br: The branch from the start state of the plastic part (step 3).
        root: The predictor's root (step 4), once solved.
    """

    __slots__ = (
        "A",
        "P",
        "b",
        "br",
        "f0t",
        "f_s",
        "fn",
        "fn0",
        "fn_s",
        "ft",
        "g",
        "g_s",
        "kind",
        "mu_c",
        "r_c",
        "rho_s",
        "root",
        "s",
        "t",
        "tol",
        "up",
    )
    _start = ("kind", "s", "f0t", "fn0", "f_s", "fn_s", "g_s", "rho_s")

    root: Root | None

    def __init__(self, L: Law, t: Trial, st: Start, P: np.ndarray, tol: float) -> None:
        self.P = P
        sel = P if P.size < t.A.size else slice(None)  # (all: views, not copies)
        self.ft, self.A, self.fn, self.g = t.ft[sel], t.A[sel], t.fn[sel], t.g[sel]
        self.t = self.ft / self.A[:, None]
        self.up, self.mu_c, self.r_c, self.b = t.up[sel], t.mu[sel], t.r[sel], t.b[sel]
        self.tol = np.maximum(tol * self.g * L.mu_s, 8.0 * EPS * self.A)
        for k in Plastic._start:
            v = getattr(st, k)
            setattr(self, k, None if v is None else v[sel])
        self.br = Branch.start(L, self.A, self.g, st.r[sel], st.mu[sel], st.b[sel], st.d[sel])
        self.root = None

    def take(self, i) -> Plastic:
        """Points ``i`` of these (themselves when ``i`` holds them all, in order)."""
        if i.size == self.A.size:
            return self
        o = object.__new__(Plastic)
        for k in Plastic.__slots__:
            v = getattr(self, k)
            setattr(o, k, None if v is None else v.take(i) if k in ("br", "root") else v[i])
        return o


def _plastic(L: Law, pl: Plastic, out: Outputs, max_iter: int) -> None:
    """Steps 4-6 for the plastic points of a chunk; their outputs."""
    pl.root = root0 = smallest_root(pl.br, pl.tol, max_iter)  # step 4: the predictor
    conv = root0.conv
    rot = rotates(L, pl)
    i = (conv & ~rot).nonzero()[0]  # the traction along the trial direction
    if i.size:
        p = pl.take(i)
        assert p.root is not None  # (taken from pl)
        tr, D = fixed_direction(L, p, start_derivatives(L, p))  # step 6
        P = p.P
        out.tr[P], out.tan[P] = tr, D
        out.up[P] = p.up + p.root.dl[:, None] * p.t
        _finish(L, out, p, p.root)
    q = rot.nonzero()[0]  # step 5: the rotation of the flow direction, the corrector
    if q.size:
        p = pl.take(q)
        assert p.root is not None  # (taken from pl)
        sd = start_derivatives(L, p)
        dA = np.zeros((q.size, 3))
        dA[:, :2] = L.at * p.t
        ddl0 = root_derivative(L, p.br, p.root, dA, sd)
        tr, D, root = rotate(L, p, sd, ddl0, max_iter)
        root.it += p.root.it
        P = p.P
        out.tr[P], out.tan[P] = tr, D
        out.up[P] = p.up + (p.ft - tr[:, :2]) / L.at
        _finish(L, out, p, root)
        conv = conv.copy()
        conv[q] = root.conv
        root0.it[q] = root.it
    bad = (~conv).nonzero()[0]
    if bad.size:  # no converged root: the last state kept
        P = pl.P[bad]
        out.fail(P, pl.up[bad], pl.mu_c[bad], pl.r_c[bad], root0.it[bad])


def _finish(L: Law, out: Outputs, p: Plastic, root: Root) -> None:
    """The state, status and stability flag of converged plastic points ``p``."""
    P, e = p.P, root.e
    out.mu[P] = e.mu
    out.r[P] = np.minimum(np.maximum(e.r, 0.0), 1.0)
    out.status[P] = np.where(root.jump, JUMP, PLASTIC)
    out.unstable[P] = unstable(L, p.g, e)
    out.iters[P] = root.it
