"""The properties the fuzzed return maps must have (see ``tests/fuzz_support.py``).

:func:`check_invariants`: no NaN or inf in the result, no FAILED point, ``mu`` in
``[mu_k, mu_s]``, ``r`` in ``[0, 1]``, separated points (and points in the contact band) carry no
traction, elastic points the exact trial, plastic points slip along the trial direction (where
the flow direction cannot rotate) with non-negative dissipation, stay inside the yield surface
and lie on the subloading surface, the end-of-step traction stored as the start traction ``f``.
:func:`check_frame_invariance`: invariance under rotations and reflections of the tangential
plane (start tractions rotated with it).

Where the flow direction may rotate (nt = 2 with a start traction) three radial-return
properties do not hold and are replaced: slip is not along the trial direction;
``|f_t| <= |f_t*|`` becomes ``|f_t| <= |f_t0| + |f_t* - f_t0|`` (the length of the elastic path:
slip across the trial raises ``|f_t|``, as in the exact rate solution); the end-point work
``f_t . (up - up_n)``, >= 0 for the exact solution, is allowed ``-1e-6 g mu_s |dup|`` (the
rotation's accuracy relative to the yield surface) and the work of a slip of the rounding of the
traction path, ``|f_t| 64 eps (|f_t0| + |f_t* - f_t0| + |f_t|) / alpha_t`` (after a reversal
from a traction far larger than the end one, the direction of a tiny slip is rounding).
"""

from __future__ import annotations

import numpy as np

from subfric_dolfinx.constitutive import Status, SubloadingLaw
from tests.fuzz_support import (
    EPS,
    ILL_CONDITIONED,
    SURFACE_TOL,
    TINY,
    Batch,
    assert_nowhere,
    maybe_rotated,
    mu_r,
    rnorm,
    rotation_ill_conditioned,
    saturation,
    slope_ratio,
    split_phi0,
    touching,
    yield_scales,
    yield_size,
)


@np.errstate(divide="ignore", invalid="ignore", over="ignore")
def check_invariants(b, res, *, surface=True):
    """Assert the properties of the module docstring on one evaluated batch.

    ``surface``: assert that every plastic point lies on the subloading surface (``False``: skip
    that check, for inputs whose magnitudes make the tolerance meaningless).
    """
    law, nt, gap, s0 = b.law, b.nt, b.gap, b.state
    sub = isinstance(law, SubloadingLaw)
    _, _, mu_k, mu_s = yield_scales(law)
    n = gap.shape[0]
    status, tr, s1 = res.status, res.traction, res.state
    assert tr.shape == (n, nt + 1) and res.tangent.shape == (n, nt + 1, nt + 1)
    assert s1.names == s0.names
    mu1, r1 = mu_r(law, s1, tr)
    assert s1.up.shape == (n, nt) and mu1.shape == (n,) and r1.shape == (n,)
    for name, a in [("traction", tr), ("tangent", res.tangent), ("up", s1.up)]:
        assert_nowhere(~np.isfinite(a.reshape(n, -1)).all(axis=1), f"non-finite {name}", b, res)
    for name, a in [("mu", mu1), ("r", r1)]:
        assert_nowhere(~np.isfinite(a), f"non-finite {name}", b, res)
    assert_nowhere(status == Status.FAILED, "FAILED for finite input", b, res)
    assert_nowhere(~np.isin(status, [s.value for s in Status]), "unknown status", b, res)
    assert_nowhere((mu1 < mu_k) | (mu1 > mu_s), "mu outside [mu_k, mu_s]", b, res)
    assert_nowhere((r1 < -1e-15) | (r1 > 1.0 + 1e-15), "r outside [0, 1]", b, res)

    ft, fn, un = tr[:, :nt], tr[:, nt], gap[:, nt]
    trial = law.alpha_t * (gap[:, :nt] - s0.up)
    A = rnorm(trial)
    slip = s1.up - s0.up
    ft_mag, dl = rnorm(ft), rnorm(slip)
    g = saturation(law, law.alpha_n * un)
    gmu_s = g * mu_s if sub else g
    # resolution of subnormal results (tractions, g, Coulomb's ratio mu_c f_n / |f_t*|)
    floor = 4.0 * TINY * (1.0 + mu_s + A)

    sep = status == Status.SEPARATED
    ela = status == Status.ELASTIC
    pla = (status == Status.PLASTIC) | (status == Status.JUMP)
    assert_nowhere((un <= 0.0) & ~sep, "not separated at ubar_n <= 0", b, res)
    assert_nowhere(touching(b) & ~sep, "not separated in the contact band", b, res)
    if "f" in s1:  # the start traction of the next step: this step's traction, exactly
        assert_nowhere(np.any(s1["f"] != tr, axis=1), "f != traction", b, res)
    assert_nowhere(sep & np.any(tr != 0.0, axis=1), "traction on a separated point", b, res)
    assert_nowhere(sep & (r1 != 0.0), "r != 0 on a separated point", b, res)
    assert_nowhere(~pla & np.any(slip != 0.0, axis=1), "slip without plastic status", b, res)
    assert_nowhere(res.unstable & ~pla, "unstable flag on a non-plastic point", b, res)
    if sub:  # separated and elastic points: mu recovers exactly over dt (and never decreases)
        mu_rec = s0.mu + (law.mu_s - s0.mu) * -np.expm1(-law.xi * b.dt)
        bad = ~pla & (np.abs(s1.mu - mu_rec) > 4 * EPS * law.mu_s)
        assert_nowhere(bad | (~pla & (s1.mu < s0.mu)), "mu recovery", b, res, expected=mu_rec)

    # elastic: the exact trial, inside the surface, r = F / mu
    assert_nowhere(
        ela[:, None] & (np.abs(ft - trial) > 2 * EPS * np.abs(trial)),
        "elastic tangential traction != trial",
        b,
        res,
    )
    in_contact = ela | pla
    fn_ok = np.abs(fn - law.alpha_n * un) <= 2 * EPS * np.abs(law.alpha_n * un)
    assert_nowhere(in_contact & ~fn_ok, "normal traction != alpha_n ubar_n", b, res)
    cap = (mu1 if sub else 1.0) * g
    assert_nowhere(
        in_contact & (ft_mag > cap * (1.0 + 1e-12) + floor),
        "outside the yield surface",
        b,
        res,
    )
    r_err = np.abs(ft_mag - cap * r1)
    assert_nowhere(
        ela & (r_err > 1e-12 * gmu_s + floor),
        "elastic r != F / mu",
        b,
        res,
        err=r_err / gmu_s,
    )

    # plastic: slip along the trial direction, |f_t| <= |f_t*|, non-negative dissipation (up to
    # the rounding of up_new - up_old, which is large against the slip when |up| is large)
    du = 2.0 * EPS * (rnorm(s0.up) + rnorm(s1.up))
    mr = maybe_rotated(b)
    along = np.einsum("ij,ij->i", slip, trial)
    assert_nowhere(
        pla & ~mr & (along < (1.0 - 1e-9) * dl * A - 2.0 * du * A),
        "slip not along the trial direction",
        b,
        res,
    )
    cap_path = A.copy()
    path = A + ft_mag  # (rounding scale of the return: its traction path)
    if mr.any():  # the length of the elastic path
        f0 = s0["f"][:, :nt]
        cap_path[mr] = (rnorm(f0) + rnorm(trial - f0))[mr]
        path = np.where(mr, cap_path + ft_mag, path)
    assert_nowhere(pla & (ft_mag > cap_path * (1.0 + 1e-12)), "|f_t| > |f_t*|", b, res)
    work = np.einsum("ij,ij->i", ft, slip)
    assert_nowhere(
        work
        < -1e-12 * ft_mag * dl
        - ft_mag * du
        - np.where(mr, 1e-6 * gmu_s * dl + ft_mag * 64.0 * EPS * path / law.alpha_t, 0.0),
        "negative dissipation",
        b,
        res,
        work=work,
    )

    # on the subloading surface, and f_t = alpha_t (ubar_t - up_new) (the return itself)
    mask = pla.copy()
    if surface:
        on = np.abs(ft_mag - cap * r1)
        # rounding of ubar_t - up (large |up|, small |f_t*|) on top of the tolerance
        rnd = 8 * EPS * law.alpha_t * (rnorm(gap[:, :nt]) + rnorm(s0.up) + rnorm(s1.up))
        tol = SURFACE_TOL * np.maximum(gmu_s, A) + rnd + floor
        assert_nowhere(mask & (on > tol), "off the subloading surface", b, res, err=on / gmu_s)
        ret = rnorm(ft - law.alpha_t * (gap[:, :nt] - s1.up))
        assert_nowhere(mask & (ret > tol), "f_t != alpha_t (ubar_t - up)", b, res, err=ret / gmu_s)
    surf = mask if surface else np.zeros(n, dtype=bool)
    parts = [("separated", sep), ("elastic", ela), ("plastic", pla), ("on surface", surf)]
    return {k: int(np.count_nonzero(v)) for k, v in parts}


def random_orthogonal(rng, n, nt):
    """Per-point rotations and reflections of the tangential plane, shape (n, nt, nt), and a
    mask of the exact ones (quarter turns and axis reflections: no rounding in ``Q x``)."""
    if nt == 1:
        return np.where(rng.random(n) < 0.5, -1.0, 1.0)[:, None, None], np.ones(n, dtype=bool)
    th = rng.uniform(0.0, 2.0 * np.pi, n)
    exact = rng.random(n) < 0.25
    th[exact] = 0.5 * np.pi * rng.integers(0, 4, np.count_nonzero(exact))
    c, s = np.cos(th), np.sin(th)
    c[exact], s[exact] = np.round(c[exact]), np.round(s[exact])
    Q = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    Q[rng.random(n) < 0.3, :, 1] *= -1.0  # a reflection
    return Q, exact


@np.errstate(divide="ignore", invalid="ignore", over="ignore")
def check_frame_invariance(b, res, seed):
    """Rotating the tangential plane rotates traction, slip and tangent; mu, r, status stay.

    Exact symmetries (sign flips in 2-D; quarter turns and axis reflections in 3-D) must give
    bit-identical results. General rotations round the inputs at ``eps |ubar_t|``, which is
    amplified where the root is ill-conditioned; there the comparison is on points whose trial
    is resolved (the rounding below 1e-9 |f_t*|), not within that rounding of the loading
    surface, not at a fold (JUMP, unstable) and not where the root is ill-conditioned
    (``|phi'| / alpha_t > ILL_CONDITIONED``, see :func:`slope_ratio`).
    """
    rng = np.random.default_rng(seed ^ 0x5EED)
    n, nt, law = b.gap.shape[0], b.nt, b.law
    sub = isinstance(law, SubloadingLaw)
    Q, exact = random_orthogonal(rng, n, nt)
    rot = lambda a: np.einsum("nij,nj->ni", Q, a)  # noqa: E731
    st_q = b.state.copy()
    st_q.up[:] = rot(b.state.up)
    if b.has_start:
        st_q["f"][:, :nt] = rot(b.state["f"][:, :nt])
    gap_q = np.column_stack([rot(b.gap[:, :nt]), b.gap[:, nt]])
    rq = Batch(law, gap_q, st_q, b.dt, b.contact_tol).run()
    P = np.zeros((n, nt + 1, nt + 1))
    P[:, :nt, :nt], P[:, nt, nt] = Q, 1.0
    D_rot = np.einsum("nij,njk,nlk->nil", P, res.tangent, P)
    tr_rot = np.column_stack([rot(res.traction[:, :nt]), res.traction[:, nt]])
    pairs = [
        ("status", res.status, rq.status),
        ("unstable flag", res.unstable, rq.unstable),
        *((k, res.state[k], rq.state[k]) for k in res.state.names if k not in ("up", "f")),
        ("traction", tr_rot, rq.traction),
        ("slip", rot(res.state.up), rq.state.up),
        ("tangent", D_rot.reshape(n, -1), rq.tangent.reshape(n, -1)),
    ]
    if b.has_start:
        f1 = res.state["f"]
        pairs.append(("f", np.column_stack([rot(f1[:, :nt]), f1[:, nt]]), rq.state["f"]))
    for name, a, q in pairs:
        differ = (a != q).reshape(n, -1).any(axis=1)
        assert_nowhere(exact & differ, f"{name} changed by an exact symmetry", b, res)

    fn = res.traction[:, nt]
    g, size = saturation(law, fn), yield_size(law, fn)
    A = rnorm(law.alpha_t * (b.gap[:, :nt] - b.state.up))
    rnd = 64 * EPS * law.alpha_t * (rnorm(b.gap[:, :nt]) + rnorm(b.state.up))
    if sub:
        mu_rec = b.state.mu + (law.mu_s - b.state.mu) * -np.expm1(-law.xi * b.dt)
        phi0 = A - g * b.state.r * mu_rec
        r_lo = np.minimum(b.state.r, res.state.r)
        ill = slope_ratio(law, g, r_lo, b.state.mu) > ILL_CONDITIONED
        mr = maybe_rotated(b)
        if mr.any():
            ill |= mr & rotation_ill_conditioned(b)
    else:
        phi0, ill = A - g, np.zeros(n, dtype=bool)
    cmp = ~exact & (rnd <= 1e-9 * A) & (np.abs(phi0) > 1e-6 * np.maximum(A, size))
    if b.has_start:  # not within rounding of the loading test after a split, nor of the split
        cmp &= np.abs(split_phi0(b, A)) > 1e-6 * np.maximum(A, size)
        cmp &= 64 * EPS * rnorm(b.state["f"][:, :nt]) <= 1e-9 * A  # f0 + s w resolved
    assert_nowhere(cmp & (rq.status != res.status), "status changed by a rotation", b, res)
    cmp &= (res.status != Status.JUMP) & ~res.unstable & ~ill
    assert_nowhere(cmp & (rq.unstable != res.unstable), "unstable changed by a rotation", b, res)
    ft_err = rnorm(rq.traction[:, :nt] - rot(res.traction[:, :nt]))
    scale = np.maximum(A, size)
    assert_nowhere(cmp & (ft_err > 1e-8 * scale), "traction not rotated", b, res, err=ft_err)
    assert_nowhere(rq.traction[:, nt] != fn, "f_n changed by a rotation", b, res)
    up_err = rnorm(rq.state.up - rot(res.state.up))
    up_tol = 1e-8 * (scale / law.alpha_t) + 8 * EPS * rnorm(res.state.up)
    assert_nowhere(cmp & (up_err > up_tol), "slip not rotated", b, res, err=up_err)
    if sub:  # (Coulomb stores no mu or r: its traction is compared above)
        mu_err, r_err = np.abs(rq.state.mu - res.state.mu), np.abs(rq.state.r - res.state.r)
        mu_s = law.mu_s
        assert_nowhere(cmp & (mu_err > 1e-8 * mu_s), "mu changed by a rotation", b, res, err=mu_err)
        assert_nowhere(cmp & (r_err > 1e-8), "r changed by a rotation", b, res, err=r_err)
    if b.has_start:
        f_rot = np.column_stack([rot(res.state["f"][:, :nt]), res.state["f"][:, nt]])
        assert_nowhere(np.any(rq.state["f"] != rq.traction, axis=1), "f != traction", b, res)
        f_err = rnorm(rq.state["f"] - f_rot)
        assert_nowhere(cmp & (f_err > 1e-8 * scale), "f not rotated", b, res, err=f_err)
    D_err = np.abs(rq.tangent - D_rot).reshape(n, -1).max(axis=1)
    D_scale = np.abs(res.tangent).reshape(n, -1).max(axis=1)
    # not where the tangential block cancels (alpha_t (1 - alpha_t / H) with H within 1e-6 of
    # alpha_t): the radial return differs by 1e-3 between frames there too
    cancels = np.abs(res.tangent[:, :nt, :nt]).reshape(n, -1).max(axis=1) <= 1e-6 * law.alpha_t
    bad = cmp & ~cancels & (D_err > 1e-7 * D_scale)
    assert_nowhere(bad, "tangent not rotated", b, res, err=D_err / D_scale)
    return {"exact symmetry": int(np.count_nonzero(exact)), "rotated": int(np.count_nonzero(cmp))}
