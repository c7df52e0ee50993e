# ---
# jupyter:
#   jupytext:
#     cell_markers: '"""'
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.16.4
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
"""# Fretting: a cylinder on an elastic-plastic (J2) flat, cyclic partial slip (2-D plane strain).

The Hertz contact of ``hertz.py`` with a J2 flat (``"model": "j2"`` in the scene's materials): a
normal approach, then the top moved back and forth sideways below gross sliding. Plastic strain
accumulates in the flat under the contact edges, cycle after cycle; Coulomb's law against the
subloading-friction law on the same contact. With an elastic flat the stick zone is compared
with Cattaneo-Mindlin's at both ends of every cycle.
"""

# %% [markdown]
r"""
## The model

**The contact.** The cylinder ($R$ = 50 mm) and the flat of `hertz.py` (two $2L\times L$ boxes
whose interface starts open by $x^2/2R$, P2 triangles refined around the contact, nodal interface
quadrature, stiff penalties $10^8$ MPa/mm), pressed by the top's approach $\delta = 50$ µm
($P \approx 1980$ N/mm, Hertz: $a \approx 1.05$ mm, $p_0 \approx 1210$ MPa), then the top is moved
sideways by $\pm s$ in `--cycles` full cycles (0 → $+s$ → $-s$ → $+s$ ...). The tangential load
$Q$ (the top's reaction) stays below $\mu P$: no gross sliding, a central stick zone
$|x| < c$ and slip zones at both edges of the contact.

**The flat** is J2-plastic (`"model": "j2"`, $\sigma_y$ = 850 MPa, linear kinematic hardening
$H_{kin}$ = 10 GPa, no isotropic hardening); the cylinder stays elastic (steel). With the friction
coefficient $\mu$ = 0.6 of steel on steel in partial slip, the normal load alone does not yield
the flat: Hertz's largest von Mises stress, $0.56\,p_0 \approx 680$ MPa at the depth $0.7a$, stays
below $\sigma_y$. The tangential traction changes that at the surface, under the contact edges:
with the slip zones carrying $\mu p$, the surface stress at $x = \mp a$ is
$\sigma_{xx} = \pm 2\mu p_0\sqrt{Q/\mu P}$ (the two half-plane solutions of Cattaneo's traction),
about $p_0$ for $Q/\mu P$ = 0.7, and in plane strain its von Mises stress is
$0.89\,|\sigma_{xx}|$: about 1080 MPa. Each half cycle yields the edge that trails (tension) and
the one that leads (compression); the next half cycle reverses both: with kinematic hardening the
stress range there ($\approx 2 \times 1080$ MPa) exceeds $2\sigma_y$, so the plastic strain
reverses every half cycle and the accumulated (equivalent) plastic strain $p$ grows each cycle
(alternating plasticity, the low-cycle fatigue of fretting).

**The laws.** Coulomb ($\mu$ = 0.6) and the subloading-friction law calibrated, as in
`cattaneo_mindlin.py`, to carry the same sliding force over Hertz's pressure (saturation
$c_n = 10^{-3}$ 1/MPa, $\tilde u$ = 2000 1/mm, no softening, no recovery). Its smooth transition
lets every loaded point slip a little (no sharp stick zone), its saturation flattens the strength
profile.

**Measured** at every extreme of the cycle: $Q$, $P$, the stick zone (Coulomb: the ELASTIC points
around the centre; its half-width by the edge and by fitting the slack $\mu p - |q|$, an ellipse
of half-width $c$ in Cattaneo-Mindlin's solution), $|Q|/\mu P$; the equivalent plastic strain $p$
at the flat's quadrature points: its largest value, where it is, its integral over the flat
$\int p\,dA$ (mm², per unit thickness), and its growth from cycle to cycle; the energy dissipated
per cycle $\oint Q\,ds$ (the fretting loop's area). Force balance is checked at every step: the
top's reaction, the interface's resultant and the bottom's reaction agree (to Newton's tolerance:
each difference is a sum of residual entries of free dofs).

**With `--elastic`** the flat's yield stress is set out of reach ($10^5$ MPa, still a J2 body):
the stick zone at both extremes is compared with Cattaneo-Mindlin's $c = a\sqrt{1 - |Q|/\mu P}$
(Mindlin and Deresiewicz: after a reversal from $+Q^*$ to $-Q^*$ the traction is the mirror image
of the first loading, with the same stick zone).

## What it gives

At the defaults (`--n 8`, 3 cycles, 8 steps a leg; $P$ = 1981 N/mm, $a_H$ = 1.05 mm,
$p_0$ = 1204 MPa; $|Q|/\mu P$ = 0.698 at every extreme):

* **No yield under the normal load**; from the first sideways leg on, plastic strain only under
  the contact edges: the yielded points lie in $0.41 \le |x| \le 1.11$ mm and within 0.31 mm
  of the surface (0.14 mm for $p$ above 1 % of its largest, after 3 cycles), 98-99 % of the sum
  of $p$ beyond $a/2$, the largest $p$ at $|x|$ = 0.72-0.78 mm and 0.017 mm below the surface
  (Coulomb), i.e. in the slip zones between $c$ = 0.575 mm and $a$.
* **Growing with the cycles** (Coulomb): the largest $p$ at the ends of cycles 0-3 is 0.0037,
  0.0136, 0.0222, 0.0302 (about 0.008 a cycle, alternating plasticity, no shakedown),
  $\int p\,dA$ 1.42, 5.15, 7.91, 10.48 $\times 10^{-4}$ mm²; the dissipated energy per cycle
  1.70, 1.64, 1.63 N mm/mm.
* **Stick zone** (Coulomb, plastic flat): $c$ (fit) 0.601 mm against Cattaneo-Mindlin's 0.576 at
  the first extreme (+4.3 %; the elastic theory does not hold there), then within
  0.2-1.2 % at every later extreme; the centre never slips. With `--elastic` at `--n 4`
  (`--slide 0.02`, $|Q|/\mu P$ = 0.47, the test's case): +0.67 % and +1.50 % at the two
  extremes, the edge within half a point spacing, the traction's RMS error 3.0 and 3.2 % of
  $\mu p_0$.
* **The subloading law** (calibrated to the same sliding force, $\mu_s$ from Hertz's pressure):
  the same loop (1.72, 1.63, 1.62 N mm/mm per cycle, $|Q|/\mu P$ 0.696-0.702), but its centre
  slips (0.11-0.12 µm at $+s$, 0.01 µm at $-s$) where Coulomb's sticks, and less plastic strain:
  largest $p$ 0.0249 against 0.0302 after 3 cycles (-18 %), $\int p\,dA$ 8.28 against
  10.48 $\times 10^{-4}$ mm² (-21 %), the peak nearer the contact edge ($|x|$ = 0.90-1.03 mm).

The run takes about 5 min on the 2 cores shared with other test suites (1 rank). The test
`tests/demos/test_fretting.py` runs it at `--n 4` with 4 steps a leg and one cycle.

    mpirun -n 2 python3 demos/fretting.py [--n 8] [--cycles 3] [--out DIR]

PETSc options go under the prefixes `fretting_coulomb_` and `fretting_subloading_`.
"""

# %%
import argparse
import math
from pathlib import Path

# %%
import dolfinx
import numpy as np
import ufl
from mpi4py import MPI

# %%
from demos import cattaneo_mindlin, hertz
from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.fem import FrictionSolver, LoadStepper
from subfric_dolfinx.io import interface_summary, write_history_file
from subfric_dolfinx.scenes import cli, parse_scene
from subfric_dolfinx.scenes.build import build_mesh, build_problem
from subfric_dolfinx.scenes.outputs import interface_profile

# %%
MU = 0.6  # Coulomb's coefficient (steel on steel, partial slip)
SIGMA_Y = 850.0  # MPa, the flat's yield stress
H_KIN = 1.0e4  # MPa, its kinematic hardening
ELASTIC_SIGMA_Y = 1.0e5  # MPa: --elastic
SLIDE = 0.03  # mm, the top's sideways amplitude
SUBLOADING_SNES = cattaneo_mindlin.SUBLOADING_SNES


# %% [markdown]
"""
## The scene: Hertz's, with a J2 flat and a cyclic sideways program
"""


# %%
def program(cycles: int) -> dict:
    """Press (0 - 1 s), then 0 -> +1 (1 - 2 s) and ``cycles`` cycles of -1, +1 (1 s each leg)."""
    times = [0.0, 1.0, 2.0]
    press, slide = [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]
    for k in range(2 * cycles):
        times.append(3.0 + k)
        press.append(1.0)
        slide.append(-1.0 if k % 2 == 0 else 1.0)
    return {"times": times, "channels": {"press": press, "slide": slide}}


# %%
def scene(
    n: int,
    cycles: int,
    *,
    law: dict,
    name: str,
    sigma_y: float = SIGMA_Y,
    slide: float = SLIDE,
    steps: int = 4,
) -> dict:
    """Hertz's scene (``n`` elements per half-width), the flat J2, the top moved cyclically."""
    sc = hertz.scene(n, law=law, name=name, slide=slide, steps=steps)
    sc["materials"]["primary"] = {
        "model": "j2",
        "E": hertz.E,
        "nu": hertz.NU,
        "sigma_y": sigma_y,
        "H_kin": H_KIN,
    }
    sc["program"] = program(cycles)
    sc["outputs"] = {}
    return sc


# %%
def laws(P: float) -> dict:
    """Coulomb (``MU``) and the subloading law calibrated to the same sliding force at ``P``."""
    coulomb = {
        "law": "coulomb",
        "params": {"alpha_t": hertz.ALPHA, "alpha_n": hertz.ALPHA, "mu_c": MU},
    }
    mu_s = cattaneo_mindlin.calibrated_mu_s(P, mu=MU)
    return {"coulomb": coulomb, "subloading": cattaneo_mindlin.subloading_law(mu_s)}


# %% [markdown]
"""
## Running: the scene's mesh and problem, our own step loop (to read the flat's plastic strain)
"""


# %%
def extremes(cycles: int) -> list[float]:
    """Times of the extremes of the sideways program: +s, -s, +s, ..."""
    return [2.0 + k for k in range(2 * cycles + 1)]


# %%
def run(sc: dict, comm: MPI.Comm, options: dict | None = None) -> dict:
    """Run a scene; the history of every step, interface and plastic snapshots at the extremes."""
    spec = parse_scene(sc)
    domain = build_mesh(spec.mesh, comm, spec)
    problem = build_problem(spec, domain)
    bulk = problem.bulk
    slide = next(d["value"] for d in sc["dirichlet"] if d.get("amplitude") == "slide")
    prog = spec.program
    rows, snaps, plastic = [], {}, {}
    # the integral of p over the bodies (zero in the elastic cylinder), at the J2 points
    p_area = dolfinx.fem.form(bulk.functions["p"] * ufl.dx(domain=problem.mesh))
    ends = extremes((len(prog["times"]) - 3) // 2)

    def on_step(rec):
        s = interface_summary(problem)
        r = problem.reactions
        amp = float(np.interp(rec.t, prog["times"], prog["channels"]["slide"]))
        rows.append(
            {
                "t": rec.t,
                "s": slide * amp,
                "Q": r["top"][0],
                "P": r["top"][1],
                "R_bottom_x": r["bottom"][0],
                "R_bottom_y": r["bottom"][1],
                "F_t": s["F_t1"],
                "F_n": s["F_n"],
                "plastic_points": bulk.plastic_points,
                "iterations": rec.iterations,
                "residual": rec.residuals[-1],
            }
        )
        if any(abs(rec.t - e) < 1e-9 for e in ends):
            snaps[round(rec.t, 9)] = interface_profile(problem)
            plastic[round(rec.t, 9)] = {
                **gather_plastic(bulk, comm),
                "integral": comm.allreduce(dolfinx.fem.assemble_scalar(p_area)),
            }

    with FrictionSolver(problem, spec.solver.prefix, options or {}, linear="lu") as solver:
        LoadStepper(solver, spec.solver.dt, on_step=on_step).run()
    dofs = problem.global_dofs
    return {
        "history": rows,
        "snapshots": snaps,
        "plastic": plastic,
        "dofs": dofs,
        "problem": problem,
    }


# %%
def gather_plastic(bulk, comm: MPI.Comm) -> dict:
    """The flat's J2 points (x and p) of all ranks, sorted by x, y."""
    x = bulk.points
    p = bulk.at_points("p")
    xs = np.concatenate(comm.allgather(x))
    ps = np.concatenate(comm.allgather(p))
    order = np.lexsort((xs[:, 1], xs[:, 0]))
    return {"x": xs[order], "p": ps[order]}


# %% [markdown]
"""
## Measuring
"""


# %%
def stick_zone(snap: dict, Q: float, P: float) -> dict:
    """Coulomb's stick zone at an extreme against Cattaneo-Mindlin for the measured ``|Q|/mu P``."""
    x = snap["x"][:, 0] - hertz.L
    fn, ft = snap["f_n"], np.abs(snap["f_t"][:, 0])
    a, p0 = hertz.hertz(P)
    ratio = abs(Q) / (MU * P)
    c = a * math.sqrt(max(1.0 - ratio, 0.0))
    elastic = (snap["status"] == Status.ELASTIC) & (fn > 0)
    lo = hi = int(np.argmin(np.abs(x)))
    if not elastic[lo]:
        return {
            "ratio": ratio,
            "c": c,
            "c_edge": 0.0,
            "c_fit": 0.0,
            "a": a,
            "p0": p0,
            "stick": False,
        }
    while lo > 0 and elastic[lo - 1]:
        lo -= 1
    while hi < x.size - 1 and elastic[hi + 1]:
        hi += 1
    c_edge = 0.25 * ((x[hi] + x[min(hi + 1, x.size - 1)]) - (x[lo] + x[max(lo - 1, 0)]))
    stick = np.zeros_like(elastic)
    stick[lo : hi + 1] = True
    slack = np.where(stick, MU * fn - ft, 0.0)
    c_fit, _, _ = hertz.fit_ellipse(x, slack)
    q = cattaneo_mindlin.cattaneo_mindlin(x, a, p0, MU, min(ratio, 1.0))
    inside = np.abs(x) <= a
    return {
        "ratio": ratio,
        "c": c,
        "c_edge": c_edge,
        "c_fit": c_fit,
        "a": a,
        "p0": p0,
        "stick": True,
        "err_c_fit": c_fit / c - 1.0,
        "err_c_edge": c_edge / c - 1.0,
        "err_q_rms": float(np.sqrt(np.mean((ft - q)[inside] ** 2)) / (MU * p0)),
    }


# %%
def plastic_measures(plastic: dict, a: float) -> dict:
    """Largest p and where; the plastic zone's extent and the sum of p.

    Extent: ``|x|`` from the centre and the depth below the top of the flat, of the points with p
    above 1 % of the largest and of any yielded point; the sum of p over all points and over
    those beyond ``a / 2`` from the centre.
    """
    x = plastic["x"][:, 0] - hertz.L
    depth = hertz.L - plastic["x"][:, 1]
    p = plastic["p"]
    i = int(np.argmax(p))
    yielded = p > 1e-3 * p[i] if p[i] > 0 else np.zeros(p.size, dtype=bool)
    return {
        "p_max": float(p[i]),
        "x_max": float(x[i]),
        "depth_max": float(depth[i]),
        "p_sum": float(p.sum()),
        "p_integral": float(plastic["integral"]),
        "n_yielded": int(np.count_nonzero(p > 0)),
        "x_abs_min": float(np.abs(x[yielded]).min()) if yielded.any() else 0.0,
        "x_abs_max": float(np.abs(x[yielded]).max()) if yielded.any() else 0.0,
        "depth_max_zone": float(depth[p > 1e-2 * p[i]].max()) if p[i] > 0 else 0.0,
        "depth_any": float(depth[p > 0].max()) if p[i] > 0 else 0.0,
        "p_centre": float(p[np.abs(x) < 0.5 * a].max(initial=0.0)),
        "p_sum_edges": float(p[np.abs(x) >= 0.5 * a].sum()),
    }


# %%
def loop_energy(rows: list[dict], t0: float, t1: float) -> float:
    """``oint Q ds`` over ``[t0, t1]`` (trapezoids over the steps), N mm/mm."""
    r = [row for row in rows if t0 - 1e-9 <= row["t"] <= t1 + 1e-9]
    s = np.array([row["s"] for row in r])
    Q = np.array([row["Q"] for row in r])
    return float(np.sum(0.5 * (Q[1:] + Q[:-1]) * np.diff(s)))


# %%
def measure(res: dict, cycles: int, coulomb: bool) -> dict:
    """Stick zones (Coulomb), plastic strain, loops and force balance of one run."""
    rows = res["history"]
    scale = max(abs(r["P"]) for r in rows)
    balance = (
        max(
            max(
                abs(r["Q"] + r["R_bottom_x"]),
                abs(abs(r["Q"]) - abs(r["F_t"])),
                abs(r["P"] + r["R_bottom_y"]),
                abs(abs(r["P"]) - r["F_n"]),
            )
            for r in rows
        )
        / scale
    )
    # what Newton's stop allows: each difference is a sum of free dofs' residual entries, at most
    # sqrt(dofs) |F| (Cauchy-Schwarz) with |F| the step's last residual norm
    newton = math.sqrt(res["dofs"]) * max(r["residual"] for r in rows) / scale
    out: dict = {"balance": balance, "balance_newton": newton, "extremes": {}}
    ratio_max = 0.0
    for t in extremes(cycles):
        row = next(r for r in rows if abs(r["t"] - t) < 1e-9)
        P, Q = abs(row["P"]), row["Q"]
        a, _ = hertz.hertz(P)
        ext = {"Q": Q, "P": P, "ratio": abs(Q) / (MU * P)}
        ratio_max = max(ratio_max, ext["ratio"])
        if coulomb:
            ext["stick"] = stick_zone(res["snapshots"][round(t, 9)], Q, P)
        ext["plastic"] = plastic_measures(res["plastic"][round(t, 9)], a)
        snap = res["snapshots"][round(t, 9)]
        x = snap["x"][:, 0] - hertz.L
        ext["slip_centre"] = float(np.abs(snap["up"][np.argmin(np.abs(x)), 0]))
        out["extremes"][t] = ext
    out["ratio_max"] = ratio_max
    out["loops"] = [loop_energy(rows, 2.0 + 2 * k, 4.0 + 2 * k) for k in range(cycles)]
    ends = [2.0 + 2 * k for k in range(cycles + 1)]
    out["p_sum_by_cycle"] = [out["extremes"][t]["plastic"]["p_sum"] for t in ends]
    out["p_max_by_cycle"] = [out["extremes"][t]["plastic"]["p_max"] for t in ends]
    out["p_integral_by_cycle"] = [out["extremes"][t]["plastic"]["p_integral"] for t in ends]
    return out


# %%
def report(name: str, m: dict, detail: bool = False) -> str:
    """The numbers of one run: a few lines, or every extreme's with ``detail`` (``-v``)."""
    lines = [
        f"[fretting] {name}: force balance {m['balance']:.2e} of P; largest |Q|/mu P = "
        f"{m['ratio_max']:.4f}"
    ]
    if not detail:
        ends = list(m["extremes"].values())
        slips = [1e3 * e["slip_centre"] for e in ends]
        sticks = [e["stick"] for e in ends if e.get("stick") and e["stick"]["stick"]]
        if sticks:
            lines.append(
                f"[fretting]   stick zone against Cattaneo-Mindlin: c (fit) "
                f"{sticks[0]['err_c_fit']:+.2%} at the first extreme, "
                f"{sticks[-1]['err_c_fit']:+.2%} at the last"
            )
        depth = max(e["plastic"]["depth_any"] for e in ends)
        lines.append(
            f"[fretting]   slip at the centre at the extremes: {min(slips):.4f} to "
            f"{max(slips):.4f} µm; plastic strain within {depth:.3f} mm of the surface"
        )
    for t, e in m["extremes"].items() if detail else ():
        pl = e["plastic"]
        lines.append(
            f"[fretting]   t = {t:g}: Q = {e['Q']:+8.2f} N/mm, P = {e['P']:.2f} N/mm, "
            f"|Q|/mu P = {e['ratio']:.4f}; slip at the centre {e['slip_centre'] * 1e3:.4f} µm"
        )
        lines.append(
            f"[fretting]     plastic: p max {pl['p_max']:.3e} at x = {pl['x_max']:+.3f} mm, "
            f"depth {pl['depth_max']:.3f} mm; int p dA {pl['p_integral']:.4e} mm2; sum p "
            f"{pl['p_sum']:.4e} ({pl['n_yielded']} points; "
            f"{pl['p_sum_edges'] / max(pl['p_sum'], 1e-300):.1%} beyond a/2); |x| in "
            f"[{pl['x_abs_min']:.3f}, {pl['x_abs_max']:.3f}] mm; depth <= "
            f"{pl['depth_max_zone']:.3f} mm (p > 1 % of max), {pl['depth_any']:.3f} mm (p > 0)"
        )
        st = e.get("stick")
        if st is not None and st["stick"]:
            lines.append(
                f"[fretting]     stick zone: c (fit) {st['c_fit']:.4f} mm "
                f"({st['err_c_fit']:+.2%}), c (edge) {st['c_edge']:.4f} mm "
                f"({st['err_c_edge']:+.2%}), Cattaneo-Mindlin {st['c']:.4f} mm; q RMS "
                f"{st['err_q_rms']:.2%} of mu p0"
            )
        elif st is not None:
            lines.append("[fretting]     no stick zone")
    lines.append(
        "[fretting]   per cycle: loop energy (N mm/mm) "
        + ", ".join(f"{v:.4f}" for v in m["loops"])
        + "; p max at the cycle ends "
        + ", ".join(f"{v:.3e}" for v in m["p_max_by_cycle"])
        + "; int p dA "
        + ", ".join(f"{v:.3e}" for v in m["p_integral_by_cycle"])
    )
    return "\n".join(lines)


# %% [markdown]
"""
## Figure
"""


# %%
ZOOM = (1.4, 0.4)
"""The strain panels' window (mm): |x| from the centre, depth below the surface (the plastic zone
lies within 0.4 - 1.1 mm of the centre and 0.3 mm of the surface at the default size)."""
DEPTH_SCALE = 2.0
"""The strain panels' depth drawn this many times its length (the layer is thin)."""


def figure(results: dict, cycles: int, outdir: Path) -> str:
    """Fretting loops, their opening, and the flat's plastic strain (one scale for both laws)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(results)
    fig = plt.figure(figsize=(12, 4.0 + 2.2 * len(names)))
    grid = fig.add_gridspec(len(names), 2, width_ratios=[1.0, 1.35])
    loops = fig.add_subplot(grid[: max(len(names) // 2, 1), 0])
    opening = fig.add_subplot(grid[max(len(names) // 2, 1) :, 0]) if len(names) > 1 else None
    t_end = extremes(cycles)[-1]
    styles = ["-", "--", ":"]
    fields = {}
    for k, name in enumerate(names):
        rows = [r for r in results[name]["history"] if r["t"] >= 1.0]
        s = np.array([1e3 * r["s"] for r in rows])
        Q = np.array([r["Q"] for r in rows])
        style = {"ls": styles[k % 3], "color": f"C{k}", "lw": 1.4, "label": name}
        loops.plot(s, Q, **style)
        # the loop's opening: Q less the secant through the last cycle's extremes, so that the
        # hysteresis (the dissipation) shows instead of the bodies' elastic compliance
        last = np.array([r["t"] >= extremes(cycles)[-3] - 1e-9 for r in rows])
        k_sec = np.ptp(Q[last]) / max(np.ptp(s[last]), 1e-300)
        if opening is not None:
            opening.plot(s, Q - k_sec * s, **style)
        pl = results[name]["plastic"][round(t_end, 9)]
        x, y = pl["x"][:, 0] - hertz.L, pl["x"][:, 1] - hertz.L
        near = (np.abs(x) < ZOOM[0]) & (y > -ZOOM[1])  # the surface layer that yields
        fields[name] = (x[near], y[near], pl["p"][near])
    top = max(float(np.max(f[2])) if f[2].size else 0.0 for f in fields.values()) or 1.0
    panels = []
    for k, (name, (x, y, p)) in enumerate(fields.items()):
        a = fig.add_subplot(grid[k, 1])
        sc = a.scatter(x, y, c=p, s=14, cmap="viridis", vmin=0.0, vmax=top)
        a.set_title(
            f"{name}: the flat's plastic strain after {cycles} cycle(s) (depth x{DEPTH_SCALE:g})",
            fontsize=9,
        )
        a.set_ylabel("depth y (mm)")
        a.set_xlim(-ZOOM[0], ZOOM[0])
        a.set_ylim(-ZOOM[1], 0.02)
        a.set_aspect(DEPTH_SCALE)
        panels.append(a)
    panels[-1].set_xlabel("x from the contact's centre (mm)")
    fig.colorbar(sc, ax=panels, label="equivalent plastic strain p (same scale)", shrink=0.9)
    loops.set_ylabel("tangential load Q (N/mm)")
    loops.set_title("fretting loops", fontsize=9)
    loops.legend(fontsize=8)
    loops.grid(True, alpha=0.3)
    bottom = opening if opening is not None else loops
    bottom.set_xlabel("sideways displacement of the top s (µm)")
    if opening is not None:
        opening.set_ylabel("Q - k s (N/mm)")
        opening.set_title("the loops' opening (k: each loop's secant stiffness)", fontsize=9)
        opening.axhline(0.0, color="k", lw=0.5)
        opening.grid(True, alpha=0.3)
    path = outdir / "fretting.png"
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return str(path)


# %%
COLUMNS = {
    "s": ("mm", "sideways displacement of the cylinder's top"),
    "Q": ("N/mm", "tangential load: the reaction at the cylinder's top, x"),
    "P": ("N/mm", "normal load: the reaction at the cylinder's top, y"),
    "F_t": ("N/mm", "tangential interface resultant"),
    "F_n": ("N/mm", "normal interface resultant, > 0 in compression"),
    "plastic_points": ("1", "J2 quadrature points that have yielded"),
    "iterations": ("1", "Newton iterations of the step"),
    "residual": ("N/mm", "Newton's last residual norm"),
}
"""Units and meanings of the history's own columns (the others: the package's names)."""


def write_history(results: dict, outdir: Path) -> None:
    """One CSV per law with every step's row, and its units (``<law>.csv-metadata.json``)."""
    for name, res in results.items():
        write_history_file(outdir / f"{name}.csv", res["history"], res["problem"], COLUMNS)


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=8, help="elements per contact half-width")
    ap.add_argument("--cycles", type=int, default=3, help="full sideways cycles")
    ap.add_argument("--slide", type=float, default=SLIDE, help="sideways amplitude, mm")
    ap.add_argument("--steps", type=int, default=8, help="steps per leg (quarter/half cycle)")
    ap.add_argument("--sigma-y", type=float, default=SIGMA_Y, help="the flat's yield stress, MPa")
    ap.add_argument("--elastic", action="store_true", help="the flat elastic (sigma_y 1e5 MPa)")
    ap.add_argument("--no-subloading", action="store_true", help="the Coulomb run only")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    ap.add_argument("--out", default="demos/output/fretting", help="output directory")
    return ap


# %%
def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)
    if args.cycles < 1 or args.n < 1 or args.steps < 1:
        raise ValueError("--n, --cycles and --steps must be >= 1")
    sigma_y = ELASTIC_SIGMA_Y if args.elastic else args.sigma_y
    P_guess = 1980.0  # N/mm, Hertz's load at the default approach (for the calibration only)
    chosen = laws(P_guess)
    if args.no_subloading:
        chosen.pop("subloading")
    results, measures = {}, {}
    for name, law in chosen.items():
        sc = scene(
            args.n,
            args.cycles,
            law=law,
            name=f"fretting_{name}",
            sigma_y=sigma_y,
            slide=args.slide,
            steps=args.steps,
        )
        options = SUBLOADING_SNES if name == "subloading" else None
        results[name] = run(sc, comm, options)
        measures[name] = measure(results[name], args.cycles, coulomb=name == "coulomb")
    if comm.rank == 0:
        for name, m in measures.items():
            print(report(name, m, detail=args.verbose > 0))
        outdir = Path(args.out)
        outdir.mkdir(parents=True, exist_ok=True)
        write_history(results, outdir)
        if not args.no_figures:
            print(f"wrote {figure(results, args.cycles, outdir)}")
    comm.Barrier()
    return {"results": results, "measures": measures, "sigma_y": sigma_y}


# %%


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
