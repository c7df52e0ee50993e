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
r"""# The paper's figures at a material point

This demo recomputes, one interface point at a time, the numerical experiments of Hashiguchi et
al. (*Friction*, 2022), "Subloading-friction model with saturation of tangential contact
stress": Figs. 5-9 (Sec. 6, two static hardening levels $\mu_s = 10000$ and $7500$ MPa) and the
computed curves of Figs. 10-11 (Sec. 7, the boric-acid lubricated Al 6111-T4 / tool steel
interface). It uses only the material-point driver (`subfric_dolfinx.driver.run_case`), so it
needs numpy and matplotlib but neither DOLFINx nor MPI:

```bash
python3 demos/paper_figures.py                      # all figures, demos/output/paper_figures
python3 demos/paper_figures.py --quick --only fig10,fig11 --out /tmp/figs
mpirun -n 2 python3 demos/paper_figures.py --quick  # rank 0 computes, the others just exit
```

Each figure is written as `figN.png` with `figN.csv` (the plotted data, one row per point,
columns `panel, series, x, y, ...` named by their quantity) next to it.

## The model in one paragraph

The tangential traction is bounded by the normal-yield surface $|f_t| = g(f_n)\,\mu$ with
$g(f_n) = 1 - e^{-c_n f_n}$: it saturates at $\mu$ as $f_n \to \infty$, where Coulomb's
$\mu_c f_n$ grows without bound. Inside, the subloading surface $|f_t| = r\,g(f_n)\,\mu$ passes
through the current stress; plastic sliding drives $r \to 1$ (smooth elastic-plastic
transition), softens $\mu$ from the static $\mu_s$ towards the kinetic $\mu_k$, and time at rest
recovers it: $\dot\mu = -\kappa(\mu - \mu_k)|\dot u^p| + \xi(\mu_s - \mu)$.

## Parameters and what the paper leaves open

* The parameter sets are the project's presets `sec6-mus10000`, `sec6-mus7500` and `sec7`: the
  paper's values in the *normalised* reading of the evolution law ($\kappa = \kappa_N/\mu_k$,
  $\xi = \xi_N/\mu_s$; read literally the Sec. 6 set has no stable quasi-static solution,
  see `docs/model.md` §2 and §8). Slip rates as in the paper: 1 mm/min in Sec. 6, 1 mm/s in
  Sec. 7.
* The normal stresses of Figs. 5-9 are not given numerically in the text. This demo uses
  **five levels 1000, 2000, 3000, 4000 and 5000 MPa** for Figs. 5-6 and **1000 MPa** for
  Figs. 7-9 (one level: those figures vary the hold time). Up to 5000 MPa the normalised
  set stays clear of the fold $\alpha_t/g(f_n) < \kappa(\mu - \mu_k)$ (at 5000 MPa:
  $\alpha_t/g = 7910 > \kappa(\mu_s - \mu_k) = 6430$ MPa/mm).
* Sliding distances and hold times are not given either: the demo slides far enough for the
  stress to settle (3 mm at 1 mm/min), and uses holds of 0, 20, 60, 180 and 600 s (Figs. 7-8;
  the recovery time $1/\xi$ is 91 s for $\mu_s = 10000$) and 10, 60 and 300 s (Fig. 9).
* "Unloading" always means back to exactly zero tangential stress. Unloading is elastic, so it
  ends where $\bar u_t = u^p$; the demo reads $u^p$ from a run of the path so far and appends the
  unloading leg there (the driver is deterministic, so the prefix is reproduced exactly).
* Fig. 9, "pulsating contact tangential stress": the stress pulses between zero and a maximum,
  with a hold at zero after each unloading. The paper describes the maxima as a *response*
  (higher after longer holds, decreasing from cycle to cycle), so the demo prescribes the
  **displacement**: each cycle slides a fixed 0.6 mm beyond the last zero-stress point, then
  unloads to zero stress and holds. Prescribing the stress instead would fix the maxima by
  construction, and a maximum above the softened strength would run away (the driver reports
  that as an error).
* Figs. 10-11 are the computed curves only (the test data of the paper's Ref. [14] are not
  reproduced). Beside them a penalty Coulomb law, calibrated to the subloading model at
  100 MPa, shows what saturation changes: Coulomb grows linearly with $f_n$.

## Implementation
"""

# %%
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import pathlib
import time
from collections.abc import Iterable, Sequence

import numpy as np

from subfric_dolfinx.commandline import main_block, program_args, summary
from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.driver import run_case
from subfric_dolfinx.logs import launcher_rank
from subfric_dolfinx.scenes.cli import HelpFormatter

SEC6 = ("sec6-mus10000", "sec6-mus7500")
FIGURES = ("fig5", "fig6", "fig7", "fig8", "fig9", "fig10", "fig11")
FN_SEC6 = (1000.0, 2000.0, 3000.0, 4000.0, 5000.0)  # MPa (our choice, see above)
FN_HOLDS = 1000.0  # MPa, Figs. 7-9
HOLDS = (0.0, 20.0, 60.0, 180.0, 600.0)  # s, Figs. 7-8
HOLDS_PULSE = (10.0, 60.0, 300.0)  # s, Fig. 9
FN_SEC7 = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0)  # MPa, Fig. 10 (as in the paper)
SLIPS_FIG11 = (0.5, 1.0, 5.0, 10.0, 20.0)  # mm
DEFAULT_SPM = {"sec6": 50.0, "sec7": 50.0}
QUICK_SPM = {"sec6": 20.0, "sec7": 10.0}

# %% [markdown]
# ### Paths
#
# A path is built leg by leg at the preset's slip rate. Samples are placed along each leg every
# `ds` mm of sliding (they are step boundaries for the driver, so they also bound the step);
# `unload()` runs the path so far to find where the tangential stress is zero.


# %%
class PathBuilder:
    """Build a displacement-controlled 1-D path and its sample times, leg by leg."""

    def __init__(self, name: str, f_n: float, spm: float, ds: float, normal_leg: bool = False):
        p = PRESETS[name].law
        self.name, self.spm, self.ds = name, spm, ds
        self.v = PRESETS[name].slip_rate
        self.un = f_n / p.alpha_n
        if normal_leg:  # approach first (f_t = 0), then slide: the stress path of Fig. 5
            self.rows = [[0.0, 0.0, 0.0, 0.0]]
            self.samples = [0.0]
            self._leg(0.0, self.un, 1.0, n=20)
        else:
            self.rows = [[0.0, 0.0, 0.0, self.un]]
            self.samples = [0.0]

    @property
    def t(self) -> float:
        """Time at the end of the path so far."""
        return self.rows[-1][0]

    @property
    def x(self) -> float:
        """Tangential gap at the end of the path so far."""
        return self.rows[-1][1]

    def _leg(self, x: float, un: float, duration: float, n: int) -> None:
        t0 = self.t
        self.rows.append([t0 + duration, x, 0.0, un])
        self.samples.extend(t0 + duration * np.arange(1, n + 1) / n)

    def slide_to(self, x: float, ds: float | None = None) -> PathBuilder:
        """Slide to ``ubar_t = x`` at the slip rate, sampled every ``ds`` mm."""
        d = abs(x - self.x)
        n = max(1, math.ceil(d / (ds or self.ds) - 1e-9))
        self._leg(x, self.un, d / self.v, n)
        return self

    def hold(self, seconds: float) -> PathBuilder:
        """Keep the gap for ``seconds`` (one sample, at the end)."""
        if seconds > 0.0:
            self._leg(self.x, self.un, seconds, 1)
        return self

    def unload(self) -> PathBuilder:
        """Slide back elastically to zero tangential stress (where ubar_t = up)."""
        res = run_case(self.case(samples=[self.t]), steps_per_mm=self.spm)
        return self.slide_to(float(res.samples["up_t1"][-1]))

    def case(self, samples: Sequence[float] | None = None, law: dict | None = None) -> dict:
        """The driver case of the path so far (the preset's law unless ``law`` is given)."""
        return {
            **(law or {"params": {"preset": self.name}}),
            "control": "disp",
            "path": [list(map(float, r)) for r in self.rows],
            "t_samples": [float(s) for s in (self.samples if samples is None else samples)],
            "n_tangential": 1,
        }

    def run(self, law: dict | None = None) -> dict:
        """Run the path; return the samples (field name -> array)."""
        res = run_case(self.case(law=law), steps_per_mm=self.spm)
        if not res.complete or res.stability_lost is not None:
            raise RuntimeError(f"{self.name}: stability lost at {res.stability_lost}")
        return res.samples


def g_of(name: str, f_n: np.ndarray | float) -> np.ndarray:
    p = PRESETS[name].law
    return -np.expm1(-p.c_n * np.asarray(f_n, dtype=float))


def mu_steady(name: str) -> float:
    """Mu in steady sliding at the preset's slip rate: kappa (mu - mu_k) v = xi (mu_s - mu)."""
    p, v = PRESETS[name].law, PRESETS[name].slip_rate
    return (p.kappa * v * p.mu_k + p.xi * p.mu_s) / (p.kappa * v + p.xi)


COLUMNS: dict[str, tuple[str, str, str]] = {
    "panel": ("string", "", "the figure's panel: the preset of the law"),
    "series": ("string", "", "the plotted series (its legend)"),
    "t_s": ("number", "s", "time"),
    "ubar_t_mm": ("number", "mm", "sliding displacement"),
    "f_n_MPa": ("number", "MPa", "normal contact stress, > 0 in compression"),
    "f_t_MPa": ("number", "MPa", "tangential contact stress"),
    "mu_MPa": ("number", "MPa", "the hardening variable mu (a stress)"),
    "cycle": ("number", "1", "the hold-slide cycle"),
    "ratio": ("number", "1", "(f_t / f_n) over its value at 100 MPa"),
}
"""Each CSV column: its datatype, unit and meaning (the metadata file beside the CSV)."""


def write_csv(path: pathlib.Path, header: Sequence[str], rows: Iterable[Sequence]) -> None:
    """``path`` and its units and meanings in ``<path>-metadata.json`` (CSV on the Web)."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for row in rows:
            w.writerow([f"{v:.9g}" if isinstance(v, float) else v for v in row])
    columns = [
        {"name": c, "titles": c, "datatype": COLUMNS[c][0], "schema:unitText": COLUMNS[c][1]}
        | {"dc:description": COLUMNS[c][2]}
        for c in header
    ]
    meta = {
        "@context": ["http://www.w3.org/ns/csvw", {"@language": "en"}],
        "url": path.name,
        "dc:description": f"subfric-dolfinx paper_figures, {path.stem}: the plotted data, one "
        "row per point; units MPa, mm, s (also in the column names)",
        "tableSchema": {"columns": columns},
    }
    path.with_name(path.name + "-metadata.json").write_text(json.dumps(meta, indent=1) + "\n")


def label(name: str) -> str:
    p = PRESETS[name].law
    return f"$\\mu_s$ = {p.mu_s:g}, $\\mu_k$ = {p.mu_k:g} MPa"


# %% [markdown]
# ### Fig. 5: stress paths at five normal stresses
#
# Normal approach to $f_n$ first ($f_t = 0$), then sliding 3 mm at 1 mm/min: the path climbs
# to its peak (red bar) and falls to the steady-sliding level (black bar). At 1 mm/min recovery
# keeps $\mu$ above $\mu_k$ in steady sliding: $\mu_\infty = (\kappa v \mu_k + \xi \mu_s) /
# (\kappa v + \xi)$ (7707 and 7136 MPa), drawn dashed beside the normal-yield curves
# $g(f_n)\mu_s$ (red) and $g(f_n)\mu_k$ (black).


# %%
def fig5(plt, out: pathlib.Path, spm: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    rows = []
    for ax, name in zip(axes, SEC6, strict=True):
        p = PRESETS[name].law
        fn = np.linspace(0.0, 1.15 * FN_SEC6[-1], 200)
        labels = {  # the series' names in the CSV file, their labels in the figure
            "g mu_s": r"$g(f_n)\,\mu_s$ (static)",
            "g mu_k": r"$g(f_n)\,\mu_k$ (kinetic)",
            "g mu_steady": r"$g(f_n)\,\mu$ in steady sliding",
        }
        for series, mu, style in (
            ("g mu_s", p.mu_s, "r-"),
            ("g mu_k", p.mu_k, "k-"),
            ("g mu_steady", mu_steady(name), "k--"),
        ):
            ax.plot(fn, g_of(name, fn) * mu, style, lw=1, label=labels[series])
            rows += [(name, series, x, y) for x, y in zip(fn, g_of(name, fn) * mu, strict=True)]
        for f_n in FN_SEC6:
            s = PathBuilder(name, f_n, spm["sec6"], 1.0 / spm["sec6"], normal_leg=True)
            s = s.slide_to(3.0).run()
            ft = np.abs(s["f_t1"])
            ax.plot(
                s["f_n"],
                ft,
                lw=1.3,
                label="stress paths (press, then slide)" if f_n == FN_SEC6[0] else None,
            )
            k = int(np.argmax(ft))
            for series, i, color in (("peak", k, "r"), ("end", -1, "k")):
                bar = {"peak": "the path's peak", "end": "its end (3 mm)"}[series]
                first = f_n == FN_SEC6[0]  # one legend entry for each kind of bar
                ax.plot(
                    [s["f_n"][i] - 120, s["f_n"][i] + 120],
                    [ft[i], ft[i]],
                    color=color,
                    lw=3,
                    label=bar if first else None,
                )
                rows.append((name, f"{series} f_n={f_n:g}", float(s["f_n"][i]), float(ft[i])))
            rows += [(name, f"path f_n={f_n:g}", x, y) for x, y in zip(s["f_n"], ft, strict=True)]
        ax.set_title(label(name))
        ax.set_xlabel("normal contact stress $f_n$ (MPa)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tangential contact stress $|f_t|$ (MPa)")
    axes[0].legend(loc="upper left", fontsize=8)
    return save(fig, out, "fig5", ("panel", "series", "f_n_MPa", "f_t_MPa"), rows)


# %% [markdown]
# ### Fig. 6: monotonic, then reverse sliding
#
# Slide to +2 mm, then back to -2 mm. The reverse branch has no static peak: $\mu$ has softened
# and the short unloading leaves little time to recover it.


# %%
def fig6(plt, out: pathlib.Path, spm: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    rows = []
    for ax, name in zip(axes, SEC6, strict=True):
        for f_n in FN_SEC6:
            s = PathBuilder(name, f_n, spm["sec6"], 1.0 / spm["sec6"]).slide_to(2.0)
            s = s.slide_to(-2.0).run()
            ax.plot(s["ubar_t1"], s["f_t1"], lw=1.2, label=f"$f_n$ = {f_n:g} MPa")
            rows += [
                (name, f"f_n={f_n:g}", float(t), u, f)
                for t, u, f in zip(s["t"], s["ubar_t1"], s["f_t1"], strict=True)
            ]
        ax.set_title(label(name))
        ax.set_xlabel(r"sliding displacement $\bar u_t$ (mm)")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tangential contact stress $f_t$ (MPa)")
    axes[0].legend(fontsize=8)
    return save(fig, out, "fig6", ("panel", "series", "t_s", "ubar_t_mm", "f_t_MPa"), rows)


# %% [markdown]
# ### Fig. 7: recovery after holds at zero stress
#
# Slide 1.5 mm, unload to zero stress, hold, then slide 1.5 mm more. During the hold $\mu$
# recovers exactly as $\mu_s - (\mu_s - \mu)e^{-\xi t}$ (one step: the driver integrates a hold
# exactly), so the reloading peak grows with the hold time.


# %%
def fig7(plt, out: pathlib.Path, spm: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    rows = []
    for ax, name in zip(axes, SEC6, strict=True):
        for hold in HOLDS:
            b = PathBuilder(name, FN_HOLDS, spm["sec6"], 1.0 / spm["sec6"]).slide_to(1.5)
            b = b.unload().hold(hold)
            s = b.slide_to(b.x + 1.5).run()
            ax.plot(s["ubar_t1"], s["f_t1"], lw=1.2, label=f"hold {hold:g} s")
            rows += [
                (name, f"hold={hold:g}s", float(t), u, f, m)
                for t, u, f, m in zip(s["t"], s["ubar_t1"], s["f_t1"], s["mu"], strict=True)
            ]
        ax.set_title(f"{label(name)}, $f_n$ = {FN_HOLDS:g} MPa")
        ax.set_xlabel(r"sliding displacement $\bar u_t$ (mm)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tangential contact stress $f_t$ (MPa)")
    axes[0].legend(fontsize=8)
    header = ("panel", "series", "t_s", "ubar_t_mm", "f_t_MPa", "mu_MPa")
    return save(fig, out, "fig7", header, rows)


# %% [markdown]
# ### Fig. 8: reciprocal sliding with holds
#
# Two cycles between +1 and -1 mm, each reversal made of an unloading to zero stress and a hold.


# %%
def fig8(plt, out: pathlib.Path, spm: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    rows = []
    for ax, name in zip(axes, SEC6, strict=True):
        for hold in HOLDS:
            b = PathBuilder(name, FN_HOLDS, spm["sec6"], 1.0 / spm["sec6"])
            for target in (1.0, -1.0, 1.0, -1.0):
                b = b.slide_to(target).unload().hold(hold)
            s = b.slide_to(1.0).run()
            ax.plot(s["ubar_t1"], s["f_t1"], lw=1.0, label=f"hold {hold:g} s")
            rows += [
                (name, f"hold={hold:g}s", float(t), u, f)
                for t, u, f in zip(s["t"], s["ubar_t1"], s["f_t1"], strict=True)
            ]
        ax.set_title(f"{label(name)}, $f_n$ = {FN_HOLDS:g} MPa")
        ax.set_xlabel(r"sliding displacement $\bar u_t$ (mm)")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tangential contact stress $f_t$ (MPa)")
    axes[0].legend(fontsize=8)
    return save(fig, out, "fig8", ("panel", "series", "t_s", "ubar_t_mm", "f_t_MPa"), rows)


# %% [markdown]
# ### Fig. 9: pulsating tangential stress with holds
#
# Five cycles, each sliding 0.6 mm beyond the last zero-stress point, unloading to zero stress
# and holding (displacement control; see the discussion at the top). The cycle maxima are
# written to the CSV as series `max hold=...`.


# %%
def fig9(plt, out: pathlib.Path, spm: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    rows = []
    n_cycles = 5
    for ax, name in zip(axes, SEC6, strict=True):
        for hold in HOLDS_PULSE:
            b = PathBuilder(name, FN_HOLDS, spm["sec6"], 1.0 / spm["sec6"])
            ends = []
            for _ in range(n_cycles):
                b = b.slide_to(b.x + 0.6)
                ends.append(b.t)
                b = b.unload().hold(hold)
            s = b.run()
            ax.plot(s["ubar_t1"], s["f_t1"], lw=1.0, label=f"hold {hold:g} s")
            cycle = np.searchsorted(np.array(ends), s["t"], side="left") + 1
            rows += [
                (name, f"hold={hold:g}s", float(t), u, f, int(c))
                for t, u, f, c in zip(s["t"], s["ubar_t1"], s["f_t1"], cycle, strict=True)
            ]
            for c in range(1, n_cycles + 1):
                f = np.where(cycle == c, s["f_t1"], -np.inf)
                k = int(np.argmax(f))
                row = (name, f"max hold={hold:g}s", float(s["t"][k]), s["ubar_t1"][k], f[k], c)
                rows.append(row)
        ax.set_title(f"{label(name)}, $f_n$ = {FN_HOLDS:g} MPa")
        ax.set_xlabel(r"sliding displacement $\bar u_t$ (mm)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tangential contact stress $f_t$ (MPa)")
    axes[0].legend(fontsize=8)
    header = ("panel", "series", "t_s", "ubar_t_mm", "f_t_MPa", "cycle")
    return save(fig, out, "fig9", header, rows)


# %% [markdown]
# ### Figs. 10-11: the Sec. 7 set, 100-600 MPa, slip up to 20 mm at 1 mm/s
#
# Fig. 10 is stress against slip at six normal stresses; the samples are dense where the peak
# is (every 0.01 mm up to 0.5 mm). Panel (b) is a penalty Coulomb law with the same
# $\alpha_t$, its $\mu_c$ calibrated to the subloading model's kinetic stress at 100 MPa and
# 20 mm: equal there, and without a static peak. Fig. 11 cuts the same runs (and, by default, more
# normal stresses) at slips 0.5, 1, 5, 10 and 20 mm; panel (b) plots the ratio $f_t/f_n$, which
# (relative to its value at 100 MPa) falls with $f_n$, while Coulomb's (dotted, calibrated at
# 100 MPa for each slip) is constant.
# With $c_n = 2 \cdot 10^{-4}$/MPa the saturation is mild in the paper's range
# ($g(600)/600 c_n = 0.94$: 6 % below linear at 600 MPa). At 0.5 mm the ratio even rises a
# little: at the same sliding displacement a higher normal stress leaves more of it elastic
# ($f_t/\alpha_t$), so $\mu$ has softened less; from 1 mm on the ratio falls.


# %%
def sec7_samples(spm: float) -> list[float]:
    v = PRESETS["sec7"].slip_rate
    u = np.union1d(np.arange(0.0, 0.5, 0.01), np.arange(0.5, 2.0, 0.05))
    u = np.union1d(u, np.arange(2.0, 20.0 + 1e-9, 0.25))
    u = np.union1d(u, SLIPS_FIG11)
    return (u / v).tolist()


def sec7_runs(spm: float, levels: Sequence[float], mu_c: float | None = None) -> dict:
    name = "sec7"
    p = PRESETS[name].law
    v = PRESETS[name].slip_rate
    out = {}
    for f_n in levels:
        un = f_n / p.alpha_n
        case = {
            "params": {"preset": name},
            "control": "disp",
            "path": [[0.0, 0.0, 0.0, un], [20.0 / v, 20.0, 0.0, un]],
            "t_samples": sec7_samples(spm),
            "n_tangential": 1,
        }
        if mu_c is not None:
            case["law"] = "coulomb"
            case["params"] = {"alpha_t": p.alpha_t, "alpha_n": p.alpha_n, "mu_c": mu_c}
        res = run_case(case, steps_per_mm=spm)
        assert res.complete and res.stability_lost is None
        out[f_n] = res.samples
    return out


def at_slip(s: dict, slip: float) -> float:
    return float(np.interp(slip, s["ubar_t1"], s["f_t1"]))


def fig10_11(plt, out: pathlib.Path, spm: dict, quick: bool, which: Sequence[str]) -> dict:
    spm7 = spm["sec7"]
    levels11 = FN_SEC7 if quick else (25.0, 50.0, 75.0, *FN_SEC7[:1], 150.0, *FN_SEC7[1:])
    levels = sorted(set(FN_SEC7) | (set(levels11) if "fig11" in which else set()))
    sub = sec7_runs(spm7, levels)
    mu_c20 = at_slip(sub[100.0], 20.0) / 100.0
    written = {}
    if "fig10" in which:
        coul = sec7_runs(spm7, FN_SEC7, mu_c=mu_c20)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
        rows = []
        for ax, (panel, runs) in zip(axes, (("subloading", sub), ("coulomb", coul)), strict=True):
            for f_n in FN_SEC7:
                s = runs[f_n]
                ax.plot(s["ubar_t1"], s["f_t1"], lw=1.2, label=f"$f_n$ = {f_n:g} MPa")
                rows += [
                    (panel, f"f_n={f_n:g}", u, f)
                    for u, f in zip(s["ubar_t1"], s["f_t1"], strict=True)
                ]
            ax.set_xlabel(r"sliding displacement $\bar u_t$ (mm)")
            ax.grid(alpha=0.3)
        axes[0].set_title("subloading friction with saturation (Sec. 7 set)")
        axes[1].set_title(f"penalty Coulomb, $\\mu_c$ = {mu_c20:.4g} (matches at 100 MPa, 20 mm)")
        axes[0].set_ylabel("tangential contact stress $f_t$ (MPa)")
        axes[0].legend(fontsize=8)
        written |= save(fig, out, "fig10", ("panel", "series", "ubar_t_mm", "f_t_MPa"), rows)
    if "fig11" in which:
        fig, (ax, ax_r) = plt.subplots(1, 2, figsize=(11, 4.4))
        rows = []
        fn = np.array(levels11)
        for i, slip in enumerate(SLIPS_FIG11):
            ft = np.array([at_slip(sub[f], slip) for f in levels11])
            mu_c = at_slip(sub[100.0], slip) / 100.0
            kw = {"color": f"C{i}", "ls": "--" if slip == 0.5 else "-"}  # dashed as in the paper
            ax.plot(fn, ft, marker="o", ms=3, label=f"{slip:g} mm", **kw)
            ax.plot(fn, mu_c * fn, ":", color=f"C{i}", lw=1)
            ax_r.plot(fn, ft / fn / mu_c, marker="o", ms=3, label=f"{slip:g} mm", **kw)
            rows += [
                ("subloading", f"slip={slip:g}mm", f, t, t / f) for f, t in zip(fn, ft, strict=True)
            ]
            rows += [("coulomb", f"slip={slip:g}mm", f, mu_c * f, mu_c) for f in fn]
        for a in (ax, ax_r):
            a.set_xlabel("normal contact stress $f_n$ (MPa)")
            a.grid(alpha=0.3)
        ax.set_ylabel("tangential contact stress $f_t$ (MPa)")
        ax_r.axhline(1.0, ls=":", color="k", lw=1, label="Coulomb")
        ax_r.set_ylabel("$(f_t / f_n)$ / its value at 100 MPa")
        ax.set_title("Sec. 7 set; dotted: Coulomb matched at 100 MPa", fontsize=10)
        ax_r.set_title("saturation: the ratio falls with $f_n$; Coulomb's is constant", fontsize=10)
        ax_r.legend(fontsize=8)
        ax.legend(title="sliding displacement", fontsize=8)
        header = ("panel", "series", "f_n_MPa", "f_t_MPa", "ratio")
        written |= save(fig, out, "fig11", header, rows)
    return written


# %% [markdown]
# ### Output and the driver function


# %%
def save(fig, out: pathlib.Path, stem: str, header: Sequence[str], rows: list) -> dict:
    fig.tight_layout()
    png, csv_path = out / f"{stem}.png", out / f"{stem}.csv"
    fig.savefig(png, dpi=110)
    fig.clf()
    import matplotlib.pyplot as plt

    plt.close(fig)
    write_csv(csv_path, header, rows)
    return {stem: (png, csv_path)}


def run_demo(
    out: str | os.PathLike = "demos/output/paper_figures",
    *,
    steps_per_mm: float | None = None,
    only: Sequence[str] | None = None,
    quick: bool = False,
    verbose: bool = True,
) -> dict[str, tuple[pathlib.Path, pathlib.Path]]:
    """Compute the figures and write ``figN.png`` and ``figN.csv`` into ``out``.

    Args:
        out: Output directory (created).
        steps_per_mm: Step density for every run; default 50 (Sec. 6 and Sec. 7), or 20 (Sec. 6)
            and 10 (Sec. 7) with ``quick``.
        only: Subset of ``fig5`` ... ``fig11``; all by default.
        quick: Coarse steps and fewer normal stresses in Fig. 11 (a fast check).
        verbose: Print one line per figure.

    Returns:
        Figure name -> (PNG path, CSV path).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    which = list(FIGURES) if not only else list(only)
    unknown = sorted(set(which) - set(FIGURES))
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; choose from {', '.join(FIGURES)}")
    spm = dict(QUICK_SPM if quick else DEFAULT_SPM)
    if steps_per_mm is not None:
        spm = {k: float(steps_per_mm) for k in spm}
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written: dict = {}
    makers = {"fig5": fig5, "fig6": fig6, "fig7": fig7, "fig8": fig8, "fig9": fig9}
    for name in FIGURES[:5]:
        if name in which:
            t0 = time.perf_counter()
            written |= makers[name](plt, out, spm)
            if verbose:
                print(f"{name}: {time.perf_counter() - t0:.1f} s -> {written[name][0]}")
    late = [f for f in ("fig10", "fig11") if f in which]
    if late:
        t0 = time.perf_counter()
        written |= fig10_11(plt, out, spm, quick, late)
        if verbose:
            print(f"{', '.join(late)}: {time.perf_counter() - t0:.1f} s -> {out}")
    return written


# %% [markdown]
# ### Running under MPI
#
# Every point is independent and cheap, so there is nothing to distribute: under `mpirun`, rank 0
# computes and writes, the other ranks exit at once (`logs.launcher_rank` reads the rank from the
# launcher's environment; MPI is not initialised).


# %%
def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=summary(__doc__), formatter_class=HelpFormatter)
    ap.add_argument("--out", default="demos/output/paper_figures", help="output directory")
    ap.add_argument(
        "--steps-per-mm",
        type=float,
        default=None,
        help="step density of every run (each figure's own when not given)",
    )
    ap.add_argument("--only", default=None, help=f"comma-separated subset of {','.join(FIGURES)}")
    ap.add_argument("--quick", action="store_true", help="coarse and fast (a check, ~10 s)")
    args = ap.parse_args(program_args(argv))  # in a notebook: the defaults
    if args.steps_per_mm is not None and not args.steps_per_mm > 0:
        ap.error("--steps-per-mm must be > 0")
    only = [s.strip() for s in args.only.split(",") if s.strip()] if args.only else None
    if only and set(only) - set(FIGURES):
        ap.error(f"--only: unknown figure(s) {sorted(set(only) - set(FIGURES))}")
    if launcher_rank() != 0:
        return 0
    t0 = time.perf_counter()
    run_demo(args.out, steps_per_mm=args.steps_per_mm, only=only, quick=args.quick)
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    main_block(main)
