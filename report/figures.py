"""The report's figures (PNG, next to ``report/README.md``), from the raw results and the analysis.

The reversal-path figure recomputes its two curves (the reference integration and a coarse run
of the return map at 25 steps/mm: a few seconds).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

HERE = Path(__file__).resolve().parent


def mp_figures(res: dict[str, Any]) -> None:
    """Error against wall time on both paths; the reversal path itself."""
    import mp_study

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = {"subloading": ("C0", "o"), "coulomb": ("C3", "s")}
    for a, key in zip(ax, ("reversal", "turn"), strict=True):
        e = res["paths"][key]
        for law, (c, m) in styles.items():
            rs = [r for r in e["runs"] if r["law"] == law]
            err = np.maximum([r["error"] for r in rs], 1e-17)
            a.loglog([r["wall"] for r in rs], err, marker=m, color=c, label=law)
            for r, y in zip(rs, err, strict=True):
                a.annotate(f"{r['steps']}", (r["wall"], y), fontsize=6, alpha=0.6)
        a.set_xlabel("wall time of the run (s, best of 2-3)")
        a.set_ylabel(r"max $|f_t - f_t^{ref}|$ / peak")
        a.set_title(f"path '{key}' (labels: number of steps)")
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.suptitle("Material point, Sec. 7 set at 300 MPa: error against wall time")
    fig.tight_layout()
    fig.savefig(HERE / "mp_error_vs_time.png", dpi=110)
    plt.close(fig)

    path = mp_study.PATHS["reversal"][0]
    ts = np.union1d(np.linspace(0.0, 25.0, 2001), path[:, 0])
    from subfric_dolfinx.driver import run_case
    from tests.reference_ode import solve_reference

    ref = solve_reference(mp_study.P, path, ts, rtol=1e-10)
    coarse = run_case(mp_study._case("subloading", path, ts, 1), steps_per_mm=25)
    cou = mp_study.coulomb_exact(path, ts, 1)
    u = np.interp(ts, path[:, 0], path[:, 1])
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].plot(ts, ref.f_t[:, 0], label="subloading, reference (LSODA 1e-10)")
    ax[0].plot(ts, cou[:, 0], "--", label=f"Coulomb, exact ($\\mu_c$ = {mp_study.MU_C:.4f})")
    ax[0].set_xlabel("t (s)")
    ax[0].set_ylabel("$f_t$ (MPa)")
    ax[1].plot(u, ref.f_t[:, 0], label="reference")
    ax[1].plot(u, coarse.samples["f_t1"], ":", label="return map, 25 steps/mm")
    ax[1].set_xlabel(r"$\bar u_t$ (mm)")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle("The 'reversal' path: forward 1 mm, back to -1 mm, hold 20 s, reload")
    fig.tight_layout()
    fig.savefig(HERE / "mp_reversal_path.png", dpi=110)
    plt.close(fig)


def fe_figures(fe: dict[str, Any], curves: dict[str, Any], cfg: dict[str, Any]) -> None:
    """Error against wall time of the grid; convergence in time and space; the histories."""
    grid = fe["grid"]
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for i, n in enumerate(cfg["ns"]):
        g = [x for x in grid if x["n"] == n]
        ax.loglog([x["wall1"] for x in g], [x["err1"] for x in g], "-o", color=f"C{i}",
                  label=f"n = {n}, 1 rank")  # fmt: skip
        ax.loglog([x["wall2"] for x in g], [x["err2"] for x in g], "--^", color=f"C{i}",
                  label=f"n = {n}, 2 ranks")  # fmt: skip
        for x in g:
            ax.annotate(f"{x['dt']:g}", (x["wall1"], x["err1"]), fontsize=6, alpha=0.7)
    ax.set_xlabel("wall time of the run (s; n <= 16 best of 2)")
    ax.set_ylabel(r"max$_t$ |$F_{t1}/A - $ ref| / peak")
    ax.set_title(
        "Block on base: error of the mean tangential traction history\n"
        "(labels: dt in s; reference: fine in time and space)",
        fontsize=10,
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(HERE / "fe_error_vs_time.png", dpi=110)
    plt.close(fig)

    time_n, dt_ref, space_dt, n_ref = cfg["time_n"], cfg["dt_ref"], cfg["space_dt"], cfg["n_ref"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    d = [x for x, _ in fe["time_rows"]]
    e = [y for _, y in fe["time_rows"]]
    detail = fe["time_detail"]
    ax[0].loglog(d, e, "o-", label=f"max over time, n = {time_n} vs dt = {dt_ref:g}")
    ax[0].loglog(d, [e[-1] * (x / d[-1]) ** 2 for x in d], "k:", label="slope 2")
    ax[0].loglog(d, [e[-1] * (x / d[-1]) for x in d], "k--", label="slope 1")
    ax[0].set_xlabel("dt (s) = slide per step (mm)")
    ax[0].set_ylabel("error / peak")
    ax[0].loglog(d, [x["rms"] for x in detail], "o--", color="C1", ms=4, label="rms over time")
    ax[0].loglog(d, [x["forward"] for x in detail], "v--", color="C4", ms=4,
                 label="max over the forward slide")  # fmt: skip
    ax[0].set_title(
        f"time: observed order {fe['p_time']:.2f} (max), {fe['p_time_cols']['rms']:.2f} (rms)",
        fontsize=10,
    )
    h = [1.0 / n for n, _ in fe["space_rows"]]
    es = [y for _, y in fe["space_rows"]]
    ax[1].loglog(h, es, "s-", color="C2", label=f"dt = {space_dt:g} vs n = {n_ref}")
    ax[1].loglog(h, [es[-1] * (x / h[-1]) ** 2 for x in h], "k:", label="slope 2")
    ax[1].loglog(h, [es[-1] * (x / h[-1]) for x in h], "k--", label="slope 1")
    ax[1].set_xlabel("h = 1 / n_interface (mm)")
    ax[1].set_title(f"space: observed order {fe['p_space']:.2f}", fontsize=10)
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(HERE / "fe_convergence.png", dpi=110)
    plt.close(fig)

    tc = curves["tc"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    ax[0].plot(tc, curves["ref"], "k-", lw=1.2, label="reference")
    for dt, r in curves["histories"]:
        ax[0].plot(r["t"], r["ft"], "--", lw=0.9, label=f"n = {time_n}, dt = {dt:g}")
    ax[0].set_xlabel("t (s)")
    ax[0].set_ylabel("$F_{t1}$ / area (MPa)")
    ax[0].set_title(f"block_on_base, 300 MPa, hold {cfg['hold']:g} s", fontsize=10)
    for dt, err in curves["err_curves"]:
        ax[1].semilogy(tc, np.maximum(err, 1e-14), lw=0.8, label=f"dt = {dt:g}")
    ax[1].set_xlabel("t (s)")
    ax[1].set_ylabel(f"|error| / peak (n = {time_n})")
    ax[1].set_ylim(1e-12, 1e-1)
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(HERE / "fe_history.png", dpi=110)
    plt.close(fig)
