"""Stability cases on stiff and extreme settings: ONE definition for the report and the tests.

``report/generate.py`` runs every case and tabulates the outcome; ``tests/test_stability.py`` runs
the same cases (on 1 and on 2 MPI ranks) and asserts what must hold. Each :class:`Case` has

* ``run(comm)`` returning an :class:`Outcome`: ``"converged"``, ``"flagged"`` (the code says there
  is no stable quasi-static solution: a rate-form denominator ``den <= 0``, a ``JUMP`` at a fold)
  or ``"error"`` (a clear exception, its message kept), the iteration counts (return-map
  iterations per plastic point-step at the material point, Newton iterations per step in FE) and
  ``nan_free`` (every traction, state and displacement seen was finite);
* ``expect``: the outcome that must occur, and ``check(outcome)``: further assertions (raising
  ``AssertionError`` with a message) on the numbers the run recorded in ``outcome.data``.

Material-point cases (``level = "point"``) use numpy only and ignore ``comm``; FE cases
(``level = "fe"``) run a small block-on-base problem (8 interface elements) on ``comm``.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from subfric_dolfinx.constitutive import (
    InterfaceState,
    Status,
    SubloadingLaw,
    preset,
)
from subfric_dolfinx.driver import RunawayError, run_case

# --------------------------------------------------------------------------------------------
# Outcome and case


@dataclasses.dataclass
class Outcome:
    """What a case did.

    Attributes:
        outcome: ``"converged"``, ``"flagged"`` or ``"error"``.
        detail: One line of what happened, with numbers.
        it_mean: Mean iterations (return map per plastic point-step, or Newton per step).
        it_max: Largest iteration count.
        it_kind: ``"return map"`` or ``"Newton"``.
        nan_free: No NaN or inf anywhere in the outputs seen.
        message: The error message, or the reason of the flag.
        data: Numbers for the checks.
    """

    outcome: str
    detail: str
    it_mean: float
    it_max: int
    it_kind: str
    nan_free: bool
    message: str = ""
    data: dict[str, Any] = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (numpy scalars converted)."""
        d = dataclasses.asdict(self)
        d["data"] = {k: _plain(v) for k, v in self.data.items()}
        d["it_mean"] = float(self.it_mean)
        d["it_max"] = int(self.it_max)
        return d


def _plain(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


@dataclasses.dataclass(frozen=True)
class Case:
    """A stability case (see the module docstring)."""

    name: str
    level: str
    what: str
    expect: str
    must: str
    run: Callable[[Any], Outcome]
    check: Callable[[Outcome], None]


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise AssertionError(message)


# --------------------------------------------------------------------------------------------
# Material point helpers


class _Counting:
    """A law that forwards to ``law`` and records the return-map iterations and finiteness.

    ``isinstance(proxy, SubloadingLaw)`` holds (the driver's runaway message asks).
    """

    def __init__(self, law: Any) -> None:
        self._law = law
        self.iterations: list[int] = []
        self.finite = True

    @property
    def __class__(self) -> type:  # type: ignore[override]
        return type(self._law)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._law, name)

    def return_map(self, gap: Any, state: Any, dt: float, **kw: Any) -> Any:
        res = self._law.return_map(gap, state, dt, **kw)
        plastic = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
        self.iterations.extend(res.iterations[plastic].tolist())
        self.finite &= _finite(res)
        return res


def _finite(res: Any) -> bool:
    arrays = (res.traction, res.tangent, res.state.up, res.state.mu, res.state.r)
    return bool(all(np.all(np.isfinite(a)) for a in arrays))


def _its(its: list[int] | np.ndarray) -> tuple[float, int]:
    a = np.asarray(its, dtype=float)
    return (float(a.mean()), int(a.max())) if a.size else (0.0, 0)


def _g(p: SubloadingLaw, f_n: float) -> float:
    return -math.expm1(-p.c_n * max(f_n, 0.0))


def _drive(
    law: Any,
    path: list[list[float]],
    samples: list[float] | None = None,
    *,
    control: str = "disp",
    spm: float = 200.0,
    on_instability: str = "stop",
) -> tuple[Outcome, Any]:
    """Run the material-point driver on ``law`` (counted); classify the result."""
    from subfric_dolfinx.driver import Case as DriverCase

    counting = _Counting(law)
    path_a = np.asarray(path, dtype=float)
    ts = np.asarray(samples if samples is not None else path_a[:, 0], dtype=float)
    case = DriverCase(counting, control, path_a, ts, 1, spm)  # type: ignore[arg-type]
    try:
        res = run_case(case, on_instability=on_instability)
    except RunawayError as e:
        m, k = _its(counting.iterations)
        part = e.partial
        fin = counting.finite and (
            part is None or all(np.all(np.isfinite(v)) for v in part.samples.values())
        )
        out = Outcome("error", f"RunawayError at t = {e.t:.6g} s", m, k, "return map", fin, str(e))
        out.data.update(t=e.t)
        return out, e
    m, k = _its(counting.iterations)
    fin = counting.finite and all(np.all(np.isfinite(v)) for v in res.samples.values())
    lost = res.stability_lost
    if lost is not None:
        detail = (
            f"stability lost at t = {lost['t']:.4g} s ({lost['reason']}, r = {lost['r']:.3g}, "
            f"f_t = {lost['f_t1']:.4g} MPa); {res.n_steps} steps"
        )
        out = Outcome("flagged", detail, m, k, "return map", fin, lost["reason"])
        out.data.update({f"lost_{q}": lost[q] for q in ("t", "r", "f_t1", "mu")})
    else:
        counts = ", ".join(f"{q} {v}" for q, v in res.status_counts.items() if v)
        out = Outcome("converged", f"{res.n_steps} steps ({counts})", m, k, "return map", fin)
    out.data.update(
        mu_min=float(res.samples["mu"].min()) if res.samples["mu"].size else float("nan"),
        complete=res.complete,
        n_steps=res.n_steps,
        unstable_steps=res.status_counts["UNSTABLE"],
        jump_steps=res.status_counts["JUMP"],
    )
    return out, res


def _one_step(
    law: SubloadingLaw, gaps: np.ndarray, state: InterfaceState, dt: float
) -> tuple[Any, list[int], bool]:
    res = law.return_map(gaps, state, dt)
    plastic = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
    return res, res.iterations[plastic].tolist(), _finite(res)


SEC7 = preset("sec7")
UN300 = 300.0 / SEC7.alpha_n  # normal gap of 300 MPa


def _legs(un: float, *legs: tuple[float, float], t0: float = 0.0) -> list[list[float]]:
    """Rows ``[t, x, 0, un]``: legs ``(duration, x_end)``, x linear in between."""
    rows = [[t0, 0.0, 0.0, un]]
    for dur, x in legs:
        rows.append([rows[-1][0] + dur, x, 0.0, un])
    return rows


# --------------------------------------------------------------------------------------------
# Material-point cases


def mp_penalty_1e8(comm: Any = None) -> Outcome:
    """sec7 with alpha_t = alpha_n = 1e8 MPa/mm at 300 MPa: forward 1 mm and back, each step
    ~1000 times the elastic range g mu / alpha_t."""
    law = SEC7.replace(alpha_t=1e8, alpha_n=1e8)
    un = 300.0 / law.alpha_n
    out, res = _drive(law, _legs(un, (1.0, 1.0), (2.0, -1.0)), spm=500)
    if out.outcome == "converged":
        s = res.samples
        g = _g(law, 300.0)
        # rigid-plastic limit: f_t = g r mu on the surface, |f_t| <= g mu
        bound = float(np.max(np.abs(s["f_t1"]) - g * s["mu"] * (1 + 1e-12)))
        out.data.update(bound_excess=bound, ft_end=float(s["f_t1"][-1]), r_end=float(s["r"][-1]))
        out.detail += f"; f_t at the end {s['f_t1'][-1]:.4g} MPa, r {s['r'][-1]:.6f}"
    return out


def _check_penalty(o: Outcome) -> None:
    _require(o.data["bound_excess"] <= 0.0, f"|f_t| above g mu: {o.data}")
    _require(o.data["ft_end"] < 0.0 and o.data["r_end"] > 0.99, f"not sliding back: {o.data}")
    _require(o.it_max <= 100, f"too many return-map iterations: {o.it_max}")


def mp_large_kappa(comm: Any = None) -> Outcome:
    """sec7 with kappa = 1000 /mm (643 times the preset): alpha_t/g << kappa (mu_s - mu_k), yet mu
    collapses to mu_k within microns of slip, long before r nears 1: no fold."""
    law = SEC7.replace(kappa=1000.0)
    out, _ = _drive(law, _legs(UN300, (1.0, 1.0)), [0.0, 0.5, 1.0], spm=1000)
    if out.outcome == "converged":
        out.detail += f"; mu at 0.5 mm {out.data['mu_min']:.5g} MPa (mu_k {law.mu_k:g})"
    return out


def _check_large_kappa(o: Outcome) -> None:
    _check_stable_complete(o)
    # steady sliding at 1 mm/s: kappa (mu - mu_k) = xi (mu_s - mu)
    k, x = 1000.0, SEC7.xi
    mu_ss = (k * SEC7.mu_k + x * SEC7.mu_s) / (k + x)
    _require(abs(o.data["mu_min"] - mu_ss) < 1e-6 * mu_ss, f"mu not at {mu_ss}: {o.data}")


def _check_flag_early(o: Outcome) -> None:
    _require(o.message in ("den <= 0", "jump at a fold"), f"unexpected reason {o.message!r}")
    _require(not o.data["complete"], "the driver should stop at the loss of stability")
    _require(0.0 < o.data["lost_r"] < 1.0, f"r at the loss {o.data['lost_r']}")


def mp_large_xi(comm: Any = None) -> Outcome:
    """sec7 with xi = 1000 /s: recovery outpaces softening, mu stays at mu_s."""
    law = SEC7.replace(xi=1000.0)
    out, res = _drive(law, _legs(UN300, (1.0, 1.0), (2.0, -1.0)), spm=400)
    if out.outcome == "converged":
        mu_min = float(res.samples["mu"].min())
        out.data.update(mu_min=mu_min)
        out.detail += f"; min mu {mu_min:.6g} MPa (mu_s {law.mu_s:g})"
    return out


def _check_large_xi(o: Outcome) -> None:
    _require(o.data["mu_min"] > 0.99 * SEC7.mu_s, f"mu softened: {o.data['mu_min']}")


def mp_large_kappa_and_xi(comm: Any = None) -> Outcome:
    """kappa = 1000 /mm and xi = 1000 /s together: recovery keeps mu high while the strong
    softening acts, as in the literal Sec. 6 set: a snap-back early in the slide."""
    law = SEC7.replace(kappa=1000.0, xi=1000.0)
    out, _ = _drive(law, _legs(UN300, (1.0, 1.0), (2.0, -1.0)), spm=1000)
    return out


def mp_tiny_steps(comm: Any = None) -> Outcome:
    """From a sliding state (0.2 mm), 1000 steps of 1e-9 mm and 1e-9 s, against one step of
    1e-6 mm; and a zero step (dt = 0, no motion)."""
    law = SEC7
    st = law.initial_state(1, 1)
    its: list[int] = []
    fin = True
    for u in np.linspace(0.0, 0.2, 201)[1:]:
        res, it, f = _one_step(law, np.array([[u, UN300]]), st, 0.001)
        st, fin = res.state, fin and f
        its += it
    start = st.copy()
    for k in range(1, 1001):
        res, it, f = _one_step(law, np.array([[0.2 + k * 1e-9, UN300]]), st, 1e-9)
        st, fin = res.state, fin and f
        its += it
    tiny = res
    one, it, f = _one_step(law, np.array([[0.2 + 1e-6, UN300]]), start, 1e-6)
    its += it
    zero, _, f2 = _one_step(law, np.array([[0.2, UN300]]), start, 0.0)
    fin = fin and f and f2
    d_ft = abs(tiny.traction[0, 0] - one.traction[0, 0]) / abs(one.traction[0, 0])
    d_up = abs(tiny.state.up[0, 0] - one.state.up[0, 0])
    # the zero step must reproduce the start state (r = F/mu there)
    d_zero = abs(zero.state.up[0, 0] - start.up[0, 0]) + abs(zero.state.mu[0] - start.mu[0])
    m, k = _its(its)
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


def _check_tiny(o: Outcome) -> None:
    _require(o.data["d_ft"] < 1e-9 and o.data["d_up"] < 1e-13, f"tiny steps drift: {o.data}")
    _require(o.data["d_zero"] < 1e-12, f"a zero step changed the state: {o.data}")


def mp_huge_steps(comm: Any = None) -> Outcome:
    """Single steps: 10 mm of slip in one step, a slip of 1e6 mm, a hold of 1e9 s."""
    law = SEC7
    st0 = law.initial_state(1, 1)
    its: list[int] = []
    r1, it, f1 = _one_step(law, np.array([[10.0, UN300]]), st0, 10.0)
    its += it
    r2, it, f2 = _one_step(law, np.array([[1e6, UN300]]), st0, 1.0)
    its += it
    r3, _, f3 = _one_step(law, np.array([[10.0, UN300]]), r1.state, 1e9)  # hold
    g = _g(law, 300.0)
    ok = all(r.converged for r in (r1, r2, r3))
    excess = max(abs(r.traction[0, 0]) - g * r.state.mu[0] * (1 + 1e-12) for r in (r1, r2, r3))
    m, k = _its(its)
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


def _check_huge(o: Outcome) -> None:
    _require(o.data["excess"] <= 0.0, f"|f_t| above g mu: {o.data}")
    _require(o.data["mu_hold"] == SEC7.mu_s, f"a 1e9 s hold must recover mu_s: {o.data}")
    _require(o.data["r_big"] > 1.0 - 1e-9, f"r after 1e6 mm: {o.data}")


def mp_fn_to_zero(comm: Any = None) -> Outcome:
    """One sliding step of 0.1 mm at normal gaps 1e-3 ... 1e-300 mm, 5e-324 (denormal), 0 and -0:
    F = |f_t|/g is 0/0 in the limit."""
    law = SEC7
    uns = np.array([1e-3, 1e-9, 1e-15, 1e-100, 1e-300, 5e-324, 0.0, -0.0])
    st = law.initial_state(uns.size, 1)
    gaps = np.column_stack([np.full(uns.size, 0.1), uns])
    res, it, fin = _one_step(law, gaps, st, 0.1)
    g = -np.expm1(-law.c_n * law.alpha_n * np.maximum(uns, 0.0))
    excess = float(np.max(np.abs(res.traction[:, 0]) - g * res.state.mu * (1 + 1e-12)))
    m, k = _its(it)
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


def _check_fn0(o: Outcome) -> None:
    _require(o.data["excess"] <= 1e-300, f"|f_t| above g mu: {o.data}")
    _require(o.data["max_ft"] < 1e-3, f"traction not vanishing with f_n: {o.data}")
    _require(o.data["statuses"][-2:] == ["SEPARATED", "SEPARATED"], f"{o.data['statuses']}")
    _require(o.data["r_max"] <= 1.0, "r above 1")


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
    out, res = _drive(SEC7, rows, samples, spm=400)
    if out.outcome == "converged":
        s = res.samples
        sep = [i for i, st in enumerate(res.sample_status) if st == "SEPARATED"]
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


def _check_separation(o: Outcome) -> None:
    _require(o.data["sep_samples"] == [1, 2, 3], f"separated samples {o.data['sep_samples']}")
    _require(o.data["sep_zero"] and o.data["sep_r"] == 0.0, "traction or r not zero when apart")
    _require(o.data["mu_err"] < 1e-12, f"recovery while apart not exact: {o.data['mu_err']}")
    _require(o.data["ft_end"] > 0.0, "no sliding after recontact")


def mp_r_to_one(comm: Any = None) -> Outcome:
    """A 20 mm slide: r -> 1, where U(r) = 0 and cos(pi r/2) underflows."""
    out, res = _drive(SEC7, _legs(UN300, (20.0, 20.0)), [0.0, 1.0, 5.0, 10.0, 20.0], spm=50)
    if out.outcome == "converged":
        r = res.samples["r"]
        out.data.update(r_end=float(r[-1]), r_max=float(r.max()))
        out.detail += f"; r at 20 mm: 1 - {1.0 - r[-1]:.1e}"
    return out


def _check_r1(o: Outcome) -> None:
    _require(o.data["r_max"] <= 1.0 and o.data["r_end"] > 1.0 - 1e-12, f"r: {o.data}")


def mp_reversal(comm: Any = None) -> Outcome:
    """Forward 1 mm, back to -1 mm at coarse steps (the zero crossing of f_t inside a step), and
    a single step from +0.5 mm to -0.5 mm (a full reversal within one step)."""
    out, res = _drive(SEC7, _legs(UN300, (1.0, 1.0), (2.0, -1.0)), spm=20)
    st = SEC7.initial_state(1, 1)
    r1, _, f1 = _one_step(SEC7, np.array([[0.5, UN300]]), st, 0.5)
    r2, _, f2 = _one_step(SEC7, np.array([[-0.5, UN300]]), r1.state, 1.0)
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


def _check_reversal(o: Outcome) -> None:
    ft = o.data["ft"]
    _require(ft[1] > 0.0 > ft[2], f"no reversal: {ft}")
    a, b = o.data["one_step"]
    _require(a > 0.0 > b and o.data["one_status"] == "PLASTIC", f"one-step reversal: {o.data}")


def mp_sec6_literal(comm: Any = None) -> Outcome:
    """The literal Sec. 6 set (kappa = 15000 /mm, xi = 110 /s) at 1000 MPa, 1 mm/min."""
    rows = _legs(0.2, (90.0, 1.5))
    out, _ = _drive(preset("sec6-mus10000-literal"), rows, [0, 15, 30, 45, 60, 75, 90], spm=1000)
    return out


def _check_sec6(o: Outcome) -> None:
    _check_flag_early(o)
    _require(0.03 < o.data["lost_r"] < 0.08, f"MODEL.md: r ~ 0.05 at the loss, got {o.data}")


def _sec7_literal(f_n: float) -> Outcome:
    law = preset("sec7-literal")
    out, _ = _drive(law, _legs(f_n / law.alpha_n, (2.0, 2.0)), [0.0, 1.0, 2.0], spm=200)
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


def _check_stable_complete(o: Outcome) -> None:
    _require(o.data["complete"] and o.data["unstable_steps"] == 0, f"{o.data}")
    _require(o.data["jump_steps"] == 0, f"{o.data}")


def _check_fold_615(o: Outcome) -> None:
    _require(o.message == "den <= 0", f"reason {o.message!r}")
    _require(o.data["lost_r"] > 0.99 and o.data["lost_t"] < 1.0, f"{o.data}")


def mp_high_fn_normalised(comm: Any = None) -> Outcome:
    """The normalised Sec. 7 set at 20000 MPa, 5 mm: alpha_t/g = 500 < kappa (mu_s - mu_k) = 680
    (the crude fold bound is violated), yet mu has softened before r nears 1."""
    out, _ = _drive(SEC7, _legs(20000.0 / SEC7.alpha_n, (5.0, 5.0)), spm=100)
    return out


FOLD_SET = SubloadingLaw(
    alpha_t=100.0, alpha_n=100.0, mu_s=1000.0, mu_k=500.0, kappa=1.0, xi=0.0, u_tilde=15.0, c_n=2e-4
)


def _fold_set(f_n: float) -> Outcome:
    out, _ = _drive(FOLD_SET, _legs(f_n / FOLD_SET.alpha_n, (12.0, 12.0)), spm=50)
    return out


def mp_fold_high_fn(comm: Any = None) -> Outcome:
    """A softening set (alpha_t = 100, mu_s = 1000, mu_k = 500, kappa = 1, xi = 0) at 10000 MPa:
    alpha_t/g = 116 < kappa (mu_s - mu_k) = 500, a fold near r = 1 (at ~8 mm)."""
    return _fold_set(10000.0)


def mp_fold_low_fn(comm: Any = None) -> Outcome:
    """The same set at 1000 MPa: alpha_t/g = 552 > 500, clear of the fold."""
    return _fold_set(1000.0)


def _check_fold(o: Outcome) -> None:
    _require(o.message in ("den <= 0", "jump at a fold"), f"reason {o.message!r}")
    _require(o.data["lost_r"] > 0.9 and 7.5 < o.data["lost_t"] < 8.5, f"{o.data}")


def _stress_case(rows: list[list[float]]) -> tuple[Outcome, Any]:
    return _drive(SEC7, rows, control="stress", spm=200)


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


def _check_stress_hold(o: Outcome) -> None:
    up, mu = o.data["up"], o.data["mu"]
    _require(up[1] > 0.0 and up[2] == up[1], f"slip during the hold: {up}")
    _require(mu[2] > mu[1] and abs(mu[2] - SEC7.mu_s) < 1e-6 * SEC7.mu_s, f"mu: {mu}")
    _require(o.data["last"] == "ELASTIC", "hold should be elastic")


def mp_stress_ramp(comm: Any = None) -> Outcome:
    """Stress control at 600 MPa: ramp f_t at 1 MPa/s to 60 MPa > g mu_s = 56.5 MPa."""
    out, _ = _stress_case([[0.0, 0.0, 0.0, UN600], [60.0, 60.0, 0.0, UN600]])
    return out


def _check_runaway(o: Outcome) -> None:
    _require("runaway" in o.message and "cannot be sustained" in o.message, o.message)
    _require(45.0 < o.data["t"] < 50.0, f"runaway time {o.data['t']}")


def mp_non_finite(comm: Any = None) -> Outcome:
    """A NaN gap, an inf gap and a NaN state among good points; then an infinite parameter."""
    law = SEC7
    gap = np.array([[0.1, UN300], [np.nan, UN300], [np.inf, UN300], [0.1, np.nan]])
    res = law.return_map(gap, law.initial_state(4, 1), 0.1)
    fin = _finite(res)
    failed = res.failed_indices.tolist()
    try:
        law.replace(alpha_t=math.inf)
        message = ""
    except ValueError as e:
        message = str(e)
    m, k = _its(res.iterations[res.status == Status.PLASTIC])
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


def _check_non_finite(o: Outcome) -> None:
    _require(o.data["failed"] == [1, 2, 3] and o.data["zero"], f"{o.data}")
    _require("alpha_t" in o.message and "not finite" in o.message, o.message)


# --------------------------------------------------------------------------------------------
# FE cases: a block (1 x 0.5 mm) on a base (2 x 0.5 mm), 8 elements along the interface

_prefixes = itertools.count()


def _fe_run(
    comm: Any,
    law: Any,
    times: list[float],
    channels: dict[str, list[float]],
    *,
    dt: float,
    pressure: float | None = 300.0,
    slide: float | None = 0.3,
    push: float | None = None,
    lift: Callable[[np.ndarray], np.ndarray] | None = None,
    dt_max: float | None = None,
    max_cuts: int = 6,
    n: int = 8,
    options: dict[str, Any] | None = None,
) -> Outcome:
    """Run the block problem; classify: error (StepFailure) > flagged > converged."""
    from mpi4py import MPI

    from subfric_dolfinx import meshing
    from subfric_dolfinx.loading import LoadingProgram
    from subfric_dolfinx.fem import (
        Dirichlet,
        DirichletField,
        InterfaceProblem,
        Material,
        Pressure,
        Traction,
    )
    from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepFailure

    program = LoadingProgram(times, channels)
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=n, cell_type="triangle"
    )
    bcs: list[Any] = [Dirichlet("bottom", (0.0, 0.0))]
    if slide is not None:
        bcs.append(Dirichlet("top", slide, component=0, amplitude="slide"))
    loads: list[Any] = []
    if pressure is not None:
        loads.append(Pressure("top", pressure, amplitude="press"))
    if push is not None:
        loads.append(Traction("top", (push, 0.0), amplitude="push"))
    if lift is not None:

        def vertical(x: np.ndarray, t: float) -> np.ndarray:
            return -0.25 * program.amplitude("press", t) + program.amplitude("lift", t) * lift(x)

        bcs.append(DirichletField("top", vertical, component=1))
    mats = {"master": Material(2.1e5, 0.3), "slave": Material(7.0e4, 0.33)}
    prob = InterfaceProblem(dom, law, mats, program, bcs, loads)
    solver = FrictionSolver(prob, f"stab{next(_prefixes)}_", options)
    el = prob.interface
    rec: dict[str, Any] = {
        "finite": True,
        "unstable_steps": 0,
        "jump_steps": 0,
        "sep": [],
        "tension": False,
        "sep_traction": 0.0,
        "ft_mean": [],
        "t": [],
        "r_max": 0.0,
        "fn_max": 0.0,
        "ft_abs_max": 0.0,
        "cuts": 0,
    }

    def on_step(r: Any) -> None:
        tr, st, res = el.last.traction, el.state.old, el.last
        ok = all(np.all(np.isfinite(a)) for a in (tr, st.up, st.mu, st.r, prob.u.x.array))
        rec["finite"] &= bool(comm.allreduce(ok, op=MPI.LAND))
        rec["unstable_steps"] += int(r.counts.get("UNSTABLE", 0) > 0)
        rec["jump_steps"] += int(r.counts.get("JUMP", 0) > 0)
        rec["sep"].append(int(r.counts.get("SEPARATED", 0)))
        rec["cuts"] += r.cuts
        sep = res.status == Status.SEPARATED
        rec["tension"] |= bool(comm.allreduce(bool(np.any(tr[:, -1] < 0.0)), op=MPI.LOR))
        s_tr = float(np.abs(tr[sep]).max()) if np.any(sep) else 0.0
        rec["sep_traction"] = max(rec["sep_traction"], comm.allreduce(s_tr, op=MPI.MAX))
        w = el.weights.ravel()
        num = comm.allreduce(float(np.sum(w * tr[:, 0])))
        area = comm.allreduce(float(np.sum(w)))
        rec["ft_mean"].append(num / area)
        rec["t"].append(r.t)
        r_loc = float(st.r.max()) if st.r.size else 0.0
        rec["r_max"] = max(rec["r_max"], comm.allreduce(r_loc, op=MPI.MAX))
        fn_loc = float(tr[:, -1].max()) if tr.size else 0.0
        rec["fn_max"] = max(rec["fn_max"], comm.allreduce(fn_loc, op=MPI.MAX))
        ft_loc = float(np.abs(tr[:, 0]).max()) if tr.size else 0.0
        rec["ft_abs_max"] = max(rec["ft_abs_max"], comm.allreduce(ft_loc, op=MPI.MAX))

    stepper = LoadStepper(solver, dt, dt_max=dt_max, max_cuts=max_cuts, on_step=on_step)
    error = None
    try:
        stepper.run()
    except StepFailure as e:
        error = e
    finally:
        solver.destroy()
    its = [r.iterations for r in stepper.records]
    m, k = _its(its)
    n_steps = len(stepper.records)
    if error is not None:
        out = Outcome(
            "error",
            f"StepFailure after {n_steps} steps (last converged t = {error.last_t:.4g}); "
            f"{rec['unstable_steps']} earlier step(s) with unstable points",
            m,
            k,
            "Newton",
            rec["finite"],
            str(error),
        )
        out.data.update(t_fail=error.t, last_t=error.last_t)
    elif rec["unstable_steps"] or rec["jump_steps"]:
        out = Outcome(
            "flagged",
            f"{n_steps} steps, {rec['unstable_steps']} with unstable points, "
            f"{rec['jump_steps']} with JUMP points",
            m,
            k,
            "Newton",
            rec["finite"],
            "den <= 0" if rec["unstable_steps"] else "jump at a fold",
        )
    else:
        out = Outcome("converged", f"{n_steps} steps", m, k, "Newton", rec["finite"])
    if rec["cuts"]:
        out.detail += f", {rec['cuts']} step cut(s)"
    out.data.update(rec, n_steps=n_steps)
    return out


PRESS_SLIDE = ([0.0, 1.0, 2.0, 4.0], {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})


def fe_penalty_1e8(comm: Any) -> Outcome:
    """sec7 with alpha_t = alpha_n = 1e8 MPa/mm: press 300 MPa, slide 0.3 mm and back."""
    law = SEC7.replace(alpha_t=1e8, alpha_n=1e8)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def _check_fe_conv(o: Outcome) -> None:
    _require(o.data["cuts"] == 0, f"{o.data['cuts']} cuts")
    _require(o.it_max <= 30, f"Newton max {o.it_max}")


def _check_fe_penalty(o: Outcome) -> None:
    _check_fe_conv(o)
    ft = o.data["ft_mean"]
    _require(max(ft) > 10.0 and min(ft) < -3.0, f"no sliding both ways: {max(ft)}, {min(ft)}")


def fe_huge_step(comm: Any) -> Outcome:
    """sec7: press in one step, slide 0.3 mm forward in one step and back in one step."""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=2.0, dt_max=2.0)


def fe_tiny_steps(comm: Any) -> Outcome:
    """sec7: press 300 MPa in 10 steps of 1e-6 s, then 20 steps of 1e-6 s (3e-7 mm each) into
    the slide."""
    times = [0.0, 1e-5, 3e-5]
    ch = {"press": [0, 1, 1], "slide": [0, 0, 2e-5]}
    return _fe_run(comm, SEC7, times, ch, dt=1e-6, dt_max=1e-6)


def _check_fe_tiny(o: Outcome) -> None:
    _check_fe_conv(o)
    _require(o.data["n_steps"] == 30, f"steps: {o.data['n_steps']}")


def fe_fn_to_zero(comm: Any) -> Outcome:
    """sec7 with a pressure of 1e-9 MPa: the block slides on a vanishing normal stress."""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=0.25, pressure=1e-9)


def _check_fe_fn0(o: Outcome) -> None:
    _check_fe_conv(o)
    d = o.data
    # |f_t| <= g(f_n) mu_s <= c_n f_n mu_s, with f_n ~ 1e-6 MPa at most
    bound = SEC7.c_n * d["fn_max"] * SEC7.mu_s * (1.0 + 1e-9)
    _require(d["fn_max"] < 1e-4 and d["ft_abs_max"] <= bound, f"traction not vanishing: {d}")


def fe_separation(comm: Any) -> Outcome:
    """Press by displacement, slide, lift the left part of the block's top (the contact opens
    there), lower it again (recontact)."""
    times = [0.0, 1.0, 2.0, 3.0, 4.0]
    ch = {"press": [0, 1, 1, 1, 1], "slide": [0, 0, 0.5, 0.5, 1.0], "lift": [0, 0, 0, 1, 0]}
    return _fe_run(
        comm,
        SEC7,
        times,
        ch,
        dt=0.25,
        pressure=None,
        lift=lambda x: 0.6 * np.clip((1.25 - x[0]) / 0.75, 0.0, 1.0),
    )


def _check_fe_separation(o: Outcome) -> None:
    _check_fe_conv(o)
    sep, t = o.data["sep"], o.data["t"]
    at = {round(a, 6): s for a, s in zip(t, sep, strict=True)}
    _require(at[2.0] == 0 and at[3.0] > 0 and at[4.0] == 0, f"separated points {at}")
    _require(not o.data["tension"] and o.data["sep_traction"] == 0.0, "traction when apart")


def fe_r_to_one(comm: Any) -> Outcome:
    """sec7 at 300 MPa: a 5 mm slide in steps of 0.25 mm, r -> 1 everywhere."""
    times, ch = [0.0, 1.0, 6.0], {"press": [0, 1, 1], "slide": [0, 0, 5.0 / 0.3]}
    return _fe_run(comm, SEC7, times, ch, dt=0.25)


def _check_fe_r1(o: Outcome) -> None:
    _check_fe_conv(o)
    _require(o.data["r_max"] <= 1.0 and o.data["r_max"] > 1.0 - 1e-9, f"r {o.data['r_max']}")


def fe_reversal(comm: Any) -> Outcome:
    """sec7: slide 0.3 mm forward and back past zero in steps of 0.25 s (0.075 mm)."""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=0.25)


def _check_fe_reversal(o: Outcome) -> None:
    _check_fe_conv(o)
    ft = o.data["ft_mean"]
    _require(max(ft) > 3.0 and ft[-1] < -3.0, f"no reversal: {max(ft)}, {ft[-1]}")


def fe_sec6_literal(comm: Any) -> Outcome:
    """The literal Sec. 6 set, 1000 MPa pressure, slide 0.3 mm in 18 s, steps of 0.5 s."""
    law = preset("sec6-mus10000-literal")
    times = [0.0, 1.0, 19.0]
    ch = {"press": [0, 1, 1], "slide": [0, 0, 1.0]}
    return _fe_run(comm, law, times, ch, dt=0.5, pressure=1000.0)


def _check_fe_flag(o: Outcome) -> None:
    _require(o.data["unstable_steps"] + o.data["jump_steps"] > 0, f"{o.data}")


def fe_large_kappa(comm: Any) -> Outcome:
    """sec7 with kappa = 1000 /mm: instant softening to mu_k, no fold (as at the point)."""
    law = SEC7.replace(kappa=1000.0)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def fe_large_kappa_and_xi(comm: Any) -> Outcome:
    """sec7 with kappa = 1000 /mm and xi = 1000 /s: the point-level snap-back, in FE."""
    law = SEC7.replace(kappa=1000.0, xi=1000.0)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def fe_sec7_literal_600(comm: Any) -> Outcome:
    """The literal Sec. 7 set at 600 MPa pressure: slide 0.3 mm and back, default Newton (full
    steps)."""
    return _fe_run(comm, preset("sec7-literal"), *PRESS_SLIDE, dt=0.1, pressure=600.0)


def fe_sec7_literal_600_l2(comm: Any) -> Outcome:
    """The same with the l2 line search (``-<prefix>snes_linesearch_type l2``)."""
    return _fe_run(
        comm,
        preset("sec7-literal"),
        *PRESS_SLIDE,
        dt=0.1,
        pressure=600.0,
        options={"snes_linesearch_type": "l2"},
    )


def _check_fe_newton_fails(o: Outcome) -> None:
    _require("no convergence at t = " in o.message and "SNES reason" in o.message, o.message)
    _require(1.2 < o.data["t_fail"] < 2.0, f"failure away from the peak: {o.data['t_fail']}")


def _check_fe_literal_l2(o: Outcome) -> None:
    _check_fe_flag(o)
    _require(o.data["n_steps"] > 0 and o.data["t"][-1] == PRESS_SLIDE[0][-1], "incomplete run")
    # the flagged points are those where the block's edge raises f_n beyond the point fold
    _require(o.data["fn_max"] > 615.0, f"largest f_n {o.data['fn_max']}")


def fe_stress_hold(comm: Any) -> Outcome:
    """Tangential traction on the block's top (no prescribed slide), 300 MPa pressure: ramp to
    12 MPa (> g mu_k = 3.7 MPa, below the peak) and hold 20 s."""
    times = [0.0, 1.0, 3.0, 23.0]
    ch = {"press": [0, 1, 1, 1], "push": [0, 0, 1, 1]}
    return _fe_run(comm, SEC7, times, ch, dt=0.25, slide=None, push=12.0)


def fe_stress_ramp(comm: Any) -> Outcome:
    """Tangential traction on the block's top ramped to 30 MPa > g mu_s = 29.1 MPa."""
    times = [0.0, 1.0, 4.0]
    ch = {"press": [0, 1, 1], "push": [0, 0, 1]}
    return _fe_run(comm, SEC7, times, ch, dt=0.1, slide=None, push=30.0, max_cuts=4)


def _check_fe_runaway(o: Outcome) -> None:
    _require("no convergence at t = " in o.message, o.message)
    _require("last converged step" in o.message, o.message)


# --------------------------------------------------------------------------------------------

CASES: list[Case] = [
    Case(
        "penalty 1e8",
        "point",
        "alpha = 1e8 MPa/mm, 300 MPa, slide +-1 mm",
        "converged",
        "|f_t| <= g mu, slides back",
        mp_penalty_1e8,
        _check_penalty,
    ),
    Case(
        "large kappa",
        "point",
        "kappa = 1000 /mm, 300 MPa, 1 mm",
        "converged",
        "mu -> mu_k at once, no fold",
        mp_large_kappa,
        _check_large_kappa,
    ),
    Case(
        "large xi",
        "point",
        "xi = 1000 /s, 300 MPa, slide +-1 mm",
        "converged",
        "mu stays at mu_s",
        mp_large_xi,
        _check_large_xi,
    ),
    Case(
        "large kappa and xi",
        "point",
        "kappa = 1000 /mm, xi = 1000 /s, 300 MPa",
        "flagged",
        "snap-back reported early, driver stops",
        mp_large_kappa_and_xi,
        _check_flag_early,
    ),
    Case(
        "tiny steps",
        "point",
        "1000 steps of 1e-9 mm / 1e-9 s; a zero step",
        "converged",
        "equal to one 1e-6 mm step",
        mp_tiny_steps,
        _check_tiny,
    ),
    Case(
        "huge steps",
        "point",
        "10 mm and 1e6 mm in one step; a 1e9 s hold",
        "converged",
        "|f_t| <= g mu, mu = mu_s after the hold",
        mp_huge_steps,
        _check_huge,
    ),
    Case(
        "f_n -> 0",
        "point",
        "u_n = 1e-3 ... 5e-324, 0, -0 mm",
        "converged",
        "f_t -> 0 with g(f_n), separated at 0",
        mp_fn_to_zero,
        _check_fn0,
    ),
    Case(
        "separation and recontact",
        "point",
        "slide, lift off 20 s, press, slide",
        "converged",
        "f = 0, r = 0 apart; exact recovery",
        mp_separation,
        _check_separation,
    ),
    Case(
        "r -> 1",
        "point",
        "20 mm slide",
        "converged",
        "r <= 1, 1 - r < 1e-12",
        mp_r_to_one,
        _check_r1,
    ),
    Case(
        "reversal",
        "point",
        "+-1 mm at 0.05 mm steps; +0.5 -> -0.5 mm in one step",
        "converged",
        "f_t changes sign",
        mp_reversal,
        _check_reversal,
    ),
    Case(
        "sec6 literal",
        "point",
        "1000 MPa, 1 mm/min",
        "flagged",
        "flagged early, r ~ 0.05",
        mp_sec6_literal,
        _check_sec6,
    ),
    Case(
        "sec7 literal 600 MPa",
        "point",
        "2 mm at 1 mm/s",
        "converged",
        "stable, complete",
        mp_sec7_literal_600,
        _check_stable_complete,
    ),
    Case(
        "sec7 literal 610 MPa",
        "point",
        "2 mm at 1 mm/s",
        "converged",
        "stable, complete",
        mp_sec7_literal_610,
        _check_stable_complete,
    ),
    Case(
        "sec7 literal 615 MPa",
        "point",
        "2 mm at 1 mm/s",
        "flagged",
        "fold near r = 1 reported",
        mp_sec7_literal_615,
        _check_fold_615,
    ),
    Case(
        "sec7 at 20000 MPa",
        "point",
        "normalised set, 5 mm",
        "converged",
        "stable, complete",
        mp_high_fn_normalised,
        _check_stable_complete,
    ),
    Case(
        "fold set at 10000 MPa",
        "point",
        "alpha_t = 100, kappa = 1, xi = 0, 12 mm",
        "flagged",
        "fold at ~8 mm reported",
        mp_fold_high_fn,
        _check_fold,
    ),
    Case(
        "fold set at 1000 MPa",
        "point",
        "same set, 12 mm",
        "converged",
        "stable, complete",
        mp_fold_low_fn,
        _check_stable_complete,
    ),
    Case(
        "stress hold above g mu_k",
        "point",
        "f_t = 40 MPa held 1000 s at 600 MPa",
        "converged",
        "sustained: no slip while held, mu recovers",
        mp_stress_hold,
        _check_stress_hold,
    ),
    Case(
        "stress ramp past the peak",
        "point",
        "f_t ramp to 60 MPa at 600 MPa",
        "error",
        "RunawayError naming the stress",
        mp_stress_ramp,
        _check_runaway,
    ),
    Case(
        "non-finite input",
        "point",
        "NaN/inf gap or state; alpha_t = inf",
        "error",
        "FAILED points with zero traction; parameter named",
        mp_non_finite,
        _check_non_finite,
    ),
    Case(
        "FE penalty 1e8",
        "fe",
        "alpha = 1e8 MPa/mm, slide +-0.3 mm, dt 0.1 s",
        "converged",
        "no cuts, slides both ways",
        fe_penalty_1e8,
        _check_fe_penalty,
    ),
    Case(
        "FE huge steps",
        "fe",
        "press, slide, back: one step each",
        "converged",
        "no cuts",
        fe_huge_step,
        _check_fe_conv,
    ),
    Case(
        "FE tiny steps",
        "fe",
        "20 steps of 1e-6 s into the slide",
        "converged",
        "no cuts",
        fe_tiny_steps,
        _check_fe_tiny,
    ),
    Case(
        "FE f_n -> 0",
        "fe",
        "pressure 1e-9 MPa, slide +-0.3 mm",
        "converged",
        "traction ~ 0, no cuts",
        fe_fn_to_zero,
        _check_fe_fn0,
    ),
    Case(
        "FE separation and recontact",
        "fe",
        "lift part of the block, lower it",
        "converged",
        "opens and closes, no tension",
        fe_separation,
        _check_fe_separation,
    ),
    Case(
        "FE r -> 1", "fe", "5 mm slide", "converged", "r -> 1, no cuts", fe_r_to_one, _check_fe_r1
    ),
    Case(
        "FE reversal",
        "fe",
        "slide +-0.3 mm, steps 0.075 mm",
        "converged",
        "mean traction changes sign",
        fe_reversal,
        _check_fe_reversal,
    ),
    Case(
        "FE sec6 literal",
        "fe",
        "1000 MPa, slide 0.3 mm",
        "flagged",
        "unstable points reported",
        fe_sec6_literal,
        _check_fe_flag,
    ),
    Case(
        "FE large kappa",
        "fe",
        "kappa = 1000 /mm, 300 MPa",
        "converged",
        "no cuts",
        fe_large_kappa,
        _check_fe_conv,
    ),
    Case(
        "FE large kappa and xi",
        "fe",
        "kappa = 1000 /mm, xi = 1000 /s, 300 MPa",
        "flagged",
        "unstable points reported",
        fe_large_kappa_and_xi,
        _check_fe_flag,
    ),
    Case(
        "FE sec7 literal 600 MPa",
        "fe",
        "slide +-0.3 mm, default Newton",
        "error",
        "StepFailure near the peak, named",
        fe_sec7_literal_600,
        _check_fe_newton_fails,
    ),
    Case(
        "FE sec7 literal 600 MPa, l2",
        "fe",
        "same, l2 line search",
        "flagged",
        "completes; points beyond the fold flagged",
        fe_sec7_literal_600_l2,
        _check_fe_literal_l2,
    ),
    Case(
        "FE traction hold above g mu_k",
        "fe",
        "12 MPa held 20 s at 300 MPa",
        "converged",
        "sustained",
        fe_stress_hold,
        _check_fe_conv,
    ),
    Case(
        "FE traction ramp past the peak",
        "fe",
        "ramp to 30 MPa at 300 MPa",
        "error",
        "StepFailure naming the time",
        fe_stress_ramp,
        _check_fe_runaway,
    ),
]
"""All cases, material point first."""

POINT_CASES = [c for c in CASES if c.level == "point"]
FE_CASES = [c for c in CASES if c.level == "fe"]
