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
    from report import mp_study

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
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    stamped(fig, "mp_error_vs_time.png")

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
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    stamped(fig, "mp_reversal_path.png")


def fe_figures(fe: dict[str, Any], curves: dict[str, Any], cfg: dict[str, Any]) -> None:
    """Error against wall time, convergence in time and in space, the reference histories.

    Error against wall time: the joint sequences, 1 and 2 ranks, both laws, 2-D and 3-D.
    """
    cases = list(cfg["cases"])
    styles = {"subloading": ("C0", "o"), "coulomb": ("C3", "s")}
    fig, ax = plt.subplots(1, len(cases), figsize=(5.6 * len(cases), 4.6), squeeze=False)
    for a, case in zip(ax[0], cases, strict=True):
        for law in cfg["laws"]:
            s = fe[f"{case}/{law}"]
            c, m = styles[law]
            j = s["joint"]
            a.loglog(
                [x["wall1"] for x in j],
                [max(x["err1"], 1e-16) for x in j],
                "-" + m,
                color=c,
                label=f"{law}, 1 rank",
            )
            a.loglog(
                [x["wall2"] for x in j],
                [max(x["err2"], 1e-16) for x in j],
                "--" + m,
                color=c,
                mfc="none",
                label=f"{law}, 2 ranks",
            )
            for x in j:
                a.annotate(
                    f"{x['dofs']} dofs, dt {x['dt']:g}",
                    (x["wall1"], max(x["err1"], 1e-16)),
                    fontsize=6,
                    alpha=0.7,
                )
        a.set_xlabel("wall time of the run (s)")
        a.set_ylabel(r"max$_t$ |$F_{t1}/A$ - ref| / peak")
        a.set_title(f"{case}: time and space refined together", fontsize=10)
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    stamped(fig, "fe_error_vs_time.png")

    fig, ax = plt.subplots(2, len(cases), figsize=(5.6 * len(cases), 8), squeeze=False)
    for k, case in enumerate(cases):
        for law in cfg["laws"]:
            s = fe[f"{case}/{law}"]
            c, m = styles[law]
            d = [x for x, _ in s["time_rows"]]
            e = [max(y, 1e-16) for _, y in s["time_rows"]]
            ax[0, k].loglog(d, e, "-" + m, color=c, label=f"{law}: order {s['p_time']:.2f}")
            h = [1.0 / n for n, _ in s["space_rows"]]
            es = [max(y, 1e-16) for _, y in s["space_rows"]]
            ax[1, k].loglog(h, es, "-" + m, color=c, label=f"{law}: order {s['p_space']:.2f}")
        ax[0, k].set_xlabel("dt (s)")
        ax[0, k].set_title(f"{case}: time (n = {cfg['cases'][case]['time_n']})", fontsize=10)
        ax[1, k].set_xlabel("h = 1 / n")
        ax[1, k].set_title(
            f"{case}: space (dt = {cfg['cases'][case]['space_dt']:g} s)", fontsize=10
        )
        for a in ax[:, k]:
            a.set_ylabel("max error / peak")
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    stamped(fig, "fe_convergence.png")

    fig, ax = plt.subplots(1, len(cases), figsize=(5.6 * len(cases), 4.2), squeeze=False)
    for a, case in zip(ax[0], cases, strict=True):
        for law in cfg["laws"]:
            cv = curves[f"{case}/{law}"]
            a.plot(cv["tc"], cv["ref"], "-", color=styles[law][0], lw=1.0, label=law)
        a.set_xlabel("t (s)")
        a.set_ylabel("$F_{t1}$ / A (MPa), reference")
        a.set_title(f"{case}, 300 MPa, hold {cfg['hold']:g} s", fontsize=10)
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    stamped(fig, "fe_history.png")


STAMP: dict[str, Any] = {}
"""The stamp of this run (report/stamp.py), set by generate.py: printed on every figure."""


def stamped(fig: Any, name: str) -> None:
    """Write a figure with the commit that produced it in its lower left corner."""
    from report import stamp as stamps

    text = f"subfric-dolfinx {stamps.label(STAMP)}" if STAMP else "subfric-dolfinx (no stamp)"
    fig.text(0.005, 0.005, text, fontsize=6, color="0.4", ha="left", va="bottom")
    fig.savefig(HERE / name, dpi=110, metadata={"Comment": text, **png_stamp(STAMP)})
    plt.close(fig)


def png_stamp(stamp: dict[str, Any]) -> dict[str, str]:
    """The PNG text entry that records the commit (``tests/demos/test_report.py`` reads it)."""
    return {"subfric-dolfinx-commit": stamp.get("commit", "")} if stamp else {}


def stamp_existing(png: Path, stamp: dict[str, Any], what: str) -> None:
    """Stamp a figure another program drew (once): its commit in a corner and in its metadata."""
    from PIL import Image

    with Image.open(png) as im:
        if im.text.get("subfric-dolfinx-commit") == stamp["commit"]:
            return
    from report import stamp as stamps

    img = plt.imread(png)
    h, w = img.shape[:2]
    fig = plt.figure(figsize=(w / 100, h / 100), dpi=100)
    fig.figimage(img, 0, 0)
    text = f"{what} {stamps.label(stamp)}"
    fig.text(0.005, 0.005, text, fontsize=6, color="0.4", ha="left", va="bottom")
    fig.savefig(png, dpi=100, metadata={"Comment": text, **png_stamp(stamp)})
    plt.close(fig)
