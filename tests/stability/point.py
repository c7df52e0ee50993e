"""Material-point stability cases (numpy only; ``comm`` is ignored)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from subfric_dolfinx.constitutive import Status, SubloadingLaw, preset

from .core import (
    SEC7,
    UN300,
    Outcome,
    drive,
    finite,
    g_factor,
    iteration_stats,
    leg_path,
    one_step,
    require,
)


def mp_penalty_1e8(comm: Any = None) -> Outcome:
    """sec7 with alpha_t = alpha_n = 1e8 MPa/mm at 300 MPa: forward 1 mm and back, each step
    ~1000 times the elastic range g mu / alpha_t."""
    law = SEC7.replace(alpha_t=1e8, alpha_n=1e8)
    un = 300.0 / law.alpha_n
    out, res = drive(law, leg_path(un, (1.0, 1.0), (2.0, -1.0)), spm=500)
    if out.outcome == "converged":
        s = res.samples
        g = g_factor(law, 300.0)
        # rigid-plastic limit: f_t = g r mu on the surface, |f_t| <= g mu
        bound = float(np.max(np.abs(s["f_t1"]) - g * s["mu"] * (1 + 1e-12)))
        out.data.update(bound_excess=bound, ft_end=float(s["f_t1"][-1]), r_end=float(s["r"][-1]))
        out.detail += f"; f_t at the end {s['f_t1'][-1]:.4g} MPa, r {s['r'][-1]:.6f}"
    return out


def check_penalty(o: Outcome) -> None:
    require(o.data["bound_excess"] <= 0.0, f"|f_t| above g mu: {o.data}")
    require(o.data["ft_end"] < 0.0 and o.data["r_end"] > 0.99, f"not sliding back: {o.data}")
    require(o.it_max <= 100, f"too many return-map iterations: {o.it_max}")


def mp_large_kappa(comm: Any = None) -> Outcome:
    """sec7 with kappa = 1000 /mm (643 times the preset): alpha_t/g << kappa (mu_s - mu_k), yet mu
    collapses to mu_k within microns of slip, long before r nears 1: no fold."""
    law = SEC7.replace(kappa=1000.0)
    out, _ = drive(law, leg_path(UN300, (1.0, 1.0)), [0.0, 0.5, 1.0], spm=1000)
    if out.outcome == "converged":
        out.detail += f"; mu at 0.5 mm {out.data['mu_min']:.5g} MPa (mu_k {law.mu_k:g})"
    return out


def check_large_kappa(o: Outcome) -> None:
    check_stable_complete(o)
    # steady sliding at 1 mm/s: kappa (mu - mu_k) = xi (mu_s - mu)
    k, x = 1000.0, SEC7.xi
    mu_ss = (k * SEC7.mu_k + x * SEC7.mu_s) / (k + x)
    require(abs(o.data["mu_min"] - mu_ss) < 1e-6 * mu_ss, f"mu not at {mu_ss}: {o.data}")


def check_flag_early(o: Outcome) -> None:
    require(o.message in ("den <= 0", "jump at a fold"), f"unexpected reason {o.message!r}")
    require(not o.data["complete"], "the driver should stop at the loss of stability")
    require(0.0 < o.data["lost_r"] < 1.0, f"r at the loss {o.data['lost_r']}")


def mp_large_xi(comm: Any = None) -> Outcome:
    """sec7 with xi = 1000 /s: recovery outpaces softening, mu stays at mu_s."""
    law = SEC7.replace(xi=1000.0)
    out, res = drive(law, leg_path(UN300, (1.0, 1.0), (2.0, -1.0)), spm=400)
    if out.outcome == "converged":
        mu_min = float(res.samples["mu"].min())
        out.data.update(mu_min=mu_min)
        out.detail += f"; min mu {mu_min:.6g} MPa (mu_s {law.mu_s:g})"
    return out


def check_large_xi(o: Outcome) -> None:
    require(o.data["mu_min"] > 0.99 * SEC7.mu_s, f"mu softened: {o.data['mu_min']}")


def mp_large_kappa_and_xi(comm: Any = None) -> Outcome:
    """kappa = 1000 /mm and xi = 1000 /s together: recovery keeps mu high while the strong
    softening acts, as in the literal Sec. 6 set: a snap-back early in the slide."""
    law = SEC7.replace(kappa=1000.0, xi=1000.0)
    out, _ = drive(law, leg_path(UN300, (1.0, 1.0), (2.0, -1.0)), spm=1000)
    return out


def mp_tiny_steps(comm: Any = None) -> Outcome:
    """From a sliding state (0.2 mm), 1000 steps of 1e-9 mm and 1e-9 s, against one step of
    1e-6 mm; and a zero step (dt = 0, no motion)."""
    law = SEC7
    st = law.initial_state(1, 1)
    its: list[int] = []
    fin = True
    for u in np.linspace(0.0, 0.2, 201)[1:]:
        res, it, f = one_step(law, np.array([[u, UN300]]), st, 0.001)
        st, fin = res.state, fin and f
        its += it
    start = st.copy()
    for k in range(1, 1001):
        res, it, f = one_step(law, np.array([[0.2 + k * 1e-9, UN300]]), st, 1e-9)
        st, fin = res.state, fin and f
        its += it
    tiny = res
    one, it, f = one_step(law, np.array([[0.2 + 1e-6, UN300]]), start, 1e-6)
    its += it
    zero, _, f2 = one_step(law, np.array([[0.2, UN300]]), start, 0.0)
    fin = fin and f and f2
    d_ft = abs(tiny.traction[0, 0] - one.traction[0, 0]) / abs(one.traction[0, 0])
    d_up = abs(tiny.state.up[0, 0] - one.state.up[0, 0])
    # the zero step must reproduce the start state (r = F/mu there)
    d_zero = abs(zero.state.up[0, 0] - start.up[0, 0]) + abs(zero.state.mu[0] - start.mu[0])
    m, k = iteration_stats(its)
    ok = all(s in (Status.PLASTIC, Status.ELASTIC) for s in (tiny.status[0], one.status[0]))
    out = Outcome(
        "converged" if ok else "error",
        f"1000 steps of 1e-9 mm vs one of 1e-6 mm: |df_t|/f_t = {d_ft:.1e}, "
        f"|d up| = {d_up:.1e} mm; zero step changes the state by {d_zero:.1e}",
        m,
        k,
        "return map",
        fin,
    )
    out.data.update(d_ft=d_ft, d_up=d_up, d_zero=d_zero)
    return out


def check_tiny(o: Outcome) -> None:
    require(o.data["d_ft"] < 1e-9 and o.data["d_up"] < 1e-13, f"tiny steps drift: {o.data}")
    require(o.data["d_zero"] < 1e-12, f"a zero step changed the state: {o.data}")


def mp_huge_steps(comm: Any = None) -> Outcome:
    """Single steps: 10 mm of slip in one step, a slip of 1e6 mm, a hold of 1e9 s."""
    law = SEC7
    st0 = law.initial_state(1, 1)
    its: list[int] = []
    r1, it, f1 = one_step(law, np.array([[10.0, UN300]]), st0, 10.0)
    its += it
    r2, it, f2 = one_step(law, np.array([[1e6, UN300]]), st0, 1.0)
    its += it
    r3, _, f3 = one_step(law, np.array([[10.0, UN300]]), r1.state, 1e9)  # hold
    g = g_factor(law, 300.0)
    ok = all(r.converged for r in (r1, r2, r3))
    excess = max(abs(r.traction[0, 0]) - g * r.state.mu[0] * (1 + 1e-12) for r in (r1, r2, r3))
    m, k = iteration_stats(its)
    out = Outcome(
        "converged" if ok else "error",
        f"10 mm in one step: f_t {r1.traction[0, 0]:.4g} MPa, r {r1.state.r[0]:.6f}, "
        f"mu {r1.state.mu[0]:.4g}; 1e6 mm: f_t {r2.traction[0, 0]:.4g} MPa; "
        f"hold 1e9 s: mu {r3.state.mu[0]:.6g}",
        m,
        k,
        "return map",
        f1 and f2 and f3,
    )
    out.data.update(excess=excess, mu_hold=float(r3.state.mu[0]), r_big=float(r2.state.r[0]))
    return out


def check_huge(o: Outcome) -> None:
    require(o.data["excess"] <= 0.0, f"|f_t| above g mu: {o.data}")
    require(o.data["mu_hold"] == SEC7.mu_s, f"a 1e9 s hold must recover mu_s: {o.data}")
    require(o.data["r_big"] > 1.0 - 1e-9, f"r after 1e6 mm: {o.data}")


def mp_fn_to_zero(comm: Any = None) -> Outcome:
    """One sliding step of 0.1 mm at normal gaps 1e-3 ... 1e-300 mm, 5e-324 (denormal), 0 and -0:
    F = |f_t|/g is 0/0 in the limit."""
    law = SEC7
    uns = np.array([1e-3, 1e-9, 1e-15, 1e-100, 1e-300, 5e-324, 0.0, -0.0])
    st = law.initial_state(uns.size, 1)
    gaps = np.column_stack([np.full(uns.size, 0.1), uns])
    res, it, fin = one_step(law, gaps, st, 0.1)
    g = -np.expm1(-law.c_n * law.alpha_n * np.maximum(uns, 0.0))
    excess = float(np.max(np.abs(res.traction[:, 0]) - g * res.state.mu * (1 + 1e-12)))
    m, k = iteration_stats(it)
    names = [Status(s).name for s in res.status]
    out = Outcome(
        "converged" if res.converged else "error",
        "statuses " + ", ".join(f"{u:.0e}: {s}" for u, s in zip(uns, names, strict=True)),
        m,
        k,
        "return map",
        fin,
    )
    out.data.update(
        excess=excess,
        max_ft=float(np.abs(res.traction[1:, 0]).max()),
        statuses=names,
        r_max=float(res.state.r.max()),
    )
    return out


def check_fn0(o: Outcome) -> None:
    require(o.data["excess"] <= 1e-300, f"|f_t| above g mu: {o.data}")
    require(o.data["max_ft"] < 1e-3, f"traction not vanishing with f_n: {o.data}")
    sep2 = [Status.SEPARATED.name] * 2
    require(o.data["statuses"][-2:] == sep2, f"{o.data['statuses']}")
    require(o.data["r_max"] <= 1.0, "r above 1")


def mp_separation(comm: Any = None) -> Outcome:
    """Slide 1 mm (mu softens), lift off for 20 s (f = 0, r = 0, mu recovers), press again and
    slide 1 mm."""
    rows = [
        [0.0, 0.0, 0.0, UN300],
        [1.0, 1.0, 0.0, UN300],
        [1.1, 1.0, 0.0, -0.1],
        [21.1, 1.0, 0.0, -0.1],
        [21.2, 1.0, 0.0, UN300],
        [22.2, 2.0, 0.0, UN300],
    ]
    samples = [1.0, 1.1, 11.1, 21.1, 21.2, 22.2]
    out, res = drive(SEC7, rows, samples, spm=400)
    if out.outcome == "converged":
        s = res.samples
        sep = [i for i, st in enumerate(res.sample_status) if st == Status.SEPARATED.name]
        mu1, mu2 = float(s["mu"][1]), float(s["mu"][3])
        exact = SEC7.mu_s - (SEC7.mu_s - mu1) * math.exp(-SEC7.xi * 20.0)
        out.data.update(
            sep_samples=sep,
            sep_zero=bool(all(s["f_t1"][i] == 0 and s["f_n"][i] == 0 for i in sep)),
            sep_r=float(max(s["r"][i] for i in sep)) if sep else -1.0,
            mu_err=abs(mu2 - exact) / exact,
            ft_end=float(s["f_t1"][-1]),
        )
        out.detail += f"; mu {mu1:.4g} -> {mu2:.4g} MPa while apart (exact {exact:.4g})"
    return out


def check_separation(o: Outcome) -> None:
    require(o.data["sep_samples"] == [1, 2, 3], f"separated samples {o.data['sep_samples']}")
    require(o.data["sep_zero"] and o.data["sep_r"] == 0.0, "traction or r not zero when apart")
    require(o.data["mu_err"] < 1e-12, f"recovery while apart not exact: {o.data['mu_err']}")
    require(o.data["ft_end"] > 0.0, "no sliding after recontact")


def mp_r_to_one(comm: Any = None) -> Outcome:
    """A 20 mm slide: r -> 1, where U(r) = 0 and cos(pi r/2) underflows."""
    out, res = drive(SEC7, leg_path(UN300, (20.0, 20.0)), [0.0, 1.0, 5.0, 10.0, 20.0], spm=50)
    if out.outcome == "converged":
        r = res.samples["r"]
        out.data.update(r_end=float(r[-1]), r_max=float(r.max()))
        out.detail += f"; r at 20 mm: 1 - {1.0 - r[-1]:.1e}"
    return out


def check_r1(o: Outcome) -> None:
    require(o.data["r_max"] <= 1.0 and o.data["r_end"] > 1.0 - 1e-12, f"r: {o.data}")


def mp_reversal(comm: Any = None) -> Outcome:
    """Forward 1 mm, back to -1 mm at coarse steps (the zero crossing of f_t inside a step), and
    a single step from +0.5 mm to -0.5 mm (a full reversal within one step)."""
    out, res = drive(SEC7, leg_path(UN300, (1.0, 1.0), (2.0, -1.0)), spm=20)
    st = SEC7.initial_state(1, 1)
    r1, _, f1 = one_step(SEC7, np.array([[0.5, UN300]]), st, 0.5)
    r2, _, f2 = one_step(SEC7, np.array([[-0.5, UN300]]), r1.state, 1.0)
    out.nan_free &= f1 and f2
    if out.outcome == "converged":
        out.data.update(
            ft=res.samples["f_t1"].tolist(),
            one_step=[float(r1.traction[0, 0]), float(r2.traction[0, 0])],
            one_status=Status(int(r2.status[0])).name,
        )
        out.detail += (
            f"; one step +0.5 -> -0.5 mm: f_t {r1.traction[0, 0]:.4g} -> "
            f"{r2.traction[0, 0]:.4g} MPa ({out.data['one_status']})"
        )
    return out


def check_reversal(o: Outcome) -> None:
    ft = o.data["ft"]
    require(ft[1] > 0.0 > ft[2], f"no reversal: {ft}")
    a, b = o.data["one_step"]
    one = o.data["one_status"]
    require(a > 0.0 > b and one == Status.PLASTIC.name, f"one-step reversal: {o.data}")


def mp_sec6_literal(comm: Any = None) -> Outcome:
    """The literal Sec. 6 set (kappa = 15000 /mm, xi = 110 /s) at 1000 MPa, 1 mm/min."""
    rows = leg_path(0.2, (90.0, 1.5))
    out, _ = drive(preset("sec6-mus10000-literal"), rows, [0, 15, 30, 45, 60, 75, 90], spm=1000)
    return out


def check_sec6(o: Outcome) -> None:
    check_flag_early(o)
    require(0.03 < o.data["lost_r"] < 0.08, f"docs/model.md §8: r ~ 0.05 at the loss, got {o.data}")


def _sec7_literal(f_n: float) -> Outcome:
    law = preset("sec7-literal")
    out, _ = drive(law, leg_path(f_n / law.alpha_n, (2.0, 2.0)), [0.0, 1.0, 2.0], spm=200)
    return out


def mp_sec7_literal_600(comm: Any = None) -> Outcome:
    """The literal Sec. 7 set at 600 MPa, 2 mm at 1 mm/s."""
    return _sec7_literal(600.0)


def mp_sec7_literal_610(comm: Any = None) -> Outcome:
    """The literal Sec. 7 set at 610 MPa (just below the fold)."""
    return _sec7_literal(610.0)


def mp_sec7_literal_615(comm: Any = None) -> Outcome:
    """The literal Sec. 7 set at 615 MPa (beyond the fold)."""
    return _sec7_literal(615.0)


def check_stable_complete(o: Outcome) -> None:
    require(o.data["complete"] and o.data["unstable_steps"] == 0, f"{o.data}")
    require(o.data["jump_steps"] == 0, f"{o.data}")


def check_fold_615(o: Outcome) -> None:
    require(o.message == "den <= 0", f"reason {o.message!r}")
    require(o.data["lost_r"] > 0.99 and o.data["lost_t"] < 1.0, f"{o.data}")


def mp_high_fn_normalised(comm: Any = None) -> Outcome:
    """The normalised Sec. 7 set at 20000 MPa, 5 mm: alpha_t/g = 500 < kappa (mu_s - mu_k) = 680
    (the crude fold bound is violated), yet mu has softened before r nears 1."""
    out, _ = drive(SEC7, leg_path(20000.0 / SEC7.alpha_n, (5.0, 5.0)), spm=100)
    return out


FOLD_SET = SubloadingLaw(
    alpha_t=100.0, alpha_n=100.0, mu_s=1000.0, mu_k=500.0, kappa=1.0, xi=0.0, u_tilde=15.0, c_n=2e-4
)


def _fold_set(f_n: float) -> Outcome:
    out, _ = drive(FOLD_SET, leg_path(f_n / FOLD_SET.alpha_n, (12.0, 12.0)), spm=50)
    return out


def mp_fold_high_fn(comm: Any = None) -> Outcome:
    """A softening set (alpha_t = 100, mu_s = 1000, mu_k = 500, kappa = 1, xi = 0) at 10000 MPa:
    alpha_t/g = 116 < kappa (mu_s - mu_k) = 500, a fold near r = 1 (at ~8 mm)."""
    return _fold_set(10000.0)


def mp_fold_low_fn(comm: Any = None) -> Outcome:
    """The same set at 1000 MPa: alpha_t/g = 552 > 500, clear of the fold."""
    return _fold_set(1000.0)


def check_fold(o: Outcome) -> None:
    require(o.message in ("den <= 0", "jump at a fold"), f"reason {o.message!r}")
    require(o.data["lost_r"] > 0.9 and 7.5 < o.data["lost_t"] < 8.5, f"{o.data}")


def _stress_case(rows: list[list[float]]) -> tuple[Outcome, Any]:
    return drive(SEC7, rows, control="stress", spm=200)


UN600 = 600.0 / SEC7.alpha_n


def mp_stress_hold(comm: Any = None) -> Outcome:
    """Stress control at 600 MPa: ramp f_t to 40 MPa (5.6 g mu_k) in 40 s, hold 1000 s."""
    rows = [[0.0, 0.0, 0.0, UN600], [40.0, 40.0, 0.0, UN600], [1040.0, 40.0, 0.0, UN600]]
    out, res = _stress_case(rows)
    if out.outcome == "converged":
        s = res.samples
        out.data.update(up=s["up_t1"].tolist(), mu=s["mu"].tolist(), last=res.sample_status[-1])
        out.detail += (
            f"; slip {s['up_t1'][1]:.4g} mm while loading, {s['up_t1'][2] - s['up_t1'][1]:.1g} "
            f"while held; mu {s['mu'][1]:.4g} -> {s['mu'][2]:.4g} MPa"
        )
    return out


def check_stress_hold(o: Outcome) -> None:
    up, mu = o.data["up"], o.data["mu"]
    require(up[1] > 0.0 and up[2] == up[1], f"slip during the hold: {up}")
    require(mu[2] > mu[1] and abs(mu[2] - SEC7.mu_s) < 1e-6 * SEC7.mu_s, f"mu: {mu}")
    require(o.data["last"] == Status.ELASTIC.name, "hold should be elastic")


def mp_stress_ramp(comm: Any = None) -> Outcome:
    """Stress control at 600 MPa: ramp f_t at 1 MPa/s to 60 MPa > g mu_s = 56.5 MPa."""
    out, _ = _stress_case([[0.0, 0.0, 0.0, UN600], [60.0, 60.0, 0.0, UN600]])
    return out


def check_runaway(o: Outcome) -> None:
    require("runaway" in o.message and "cannot be sustained" in o.message, o.message)
    require(45.0 < o.data["t"] < 50.0, f"runaway time {o.data['t']}")


def mp_non_finite(comm: Any = None) -> Outcome:
    """A NaN gap, an inf gap and a NaN state among good points; then an infinite parameter."""
    law = SEC7
    gap = np.array([[0.1, UN300], [np.nan, UN300], [np.inf, UN300], [0.1, np.nan]])
    res = law.return_map(gap, law.initial_state(4, 1), 0.1)
    fin = finite(res)
    failed = res.failed_indices.tolist()
    try:
        law.replace(alpha_t=math.inf)
        message = ""
    except ValueError as e:
        message = str(e)
    m, k = iteration_stats(res.iterations[res.status == Status.PLASTIC])
    out = Outcome(
        "error",
        f"points {failed} FAILED with zero traction, point 0 {Status(int(res.status[0])).name}; "
        "alpha_t = inf refused",
        m,
        k,
        "return map",
        fin,
        message,
    )
    out.data.update(failed=failed, zero=bool(np.all(res.traction[1:] == 0.0)))
    return out


def check_non_finite(o: Outcome) -> None:
    require(o.data["failed"] == [1, 2, 3] and o.data["zero"], f"{o.data}")
    require("alpha_t" in o.message and "not finite" in o.message, o.message)
