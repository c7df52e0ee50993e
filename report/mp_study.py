"""Material-point convergence study for the report: error against run time.

The current map, the previous one (before issue 14) and Coulomb side by side.

Two displacement-controlled paths at f_n = 300 MPa (``u_n = 0.6`` mm, Sec. 7 preset):

* ``reversal`` (1-D): forward to +1 mm in 1 s, back to -1 mm in 2 s, hold 20 s, reload to +1 mm
  in 2 s (the loading of the FE demo, at one point);
* ``turn`` (3-D contact, two tangential components): 0.3 mm along e1, then 0.15 mm along e2.

Samples are dense where the gap moves: every 0.04 s on the reversal (0.04 mm of slip: every step
end at 25 steps/mm, and just after each zero crossing of ``f_t``, where the previous map's error
peaked; the 20-s hold only at its ends) and every 0.01 s on the turn (every step end at 100
steps/mm), plus the path's breakpoints.

Laws (labels in the JSON): ``subloading`` the package's map; ``subloading_previous`` the map
before issue 14 (``benchmarks/old_map``: radial return from the step start, no reversal split, no
rotation of the flow direction); ``coulomb`` penalty Coulomb with the subloading kinetic strength.

References: the subloading law against ``tests/reference_ode.py`` (LSODA at rtol 1e-12; its own
error estimated by the difference to Radau at the same tolerance); Coulomb against its exact
solution (1-D: the play operator, exact on every straight leg; the turn: on the circle
``|f_t| = R`` the angle obeys ``d theta / ds = (alpha_t / R) cos theta``, so ``sin theta =
tanh(alpha_t s / R)``). Errors are ``max |f_t - f_t,ref|`` over the samples divided by the peak of
``|f_t,ref|`` along the path; times are the run's thread CPU time (``cpu``, used in the figure and
the tables: the machine is shared, and CPU time is what other jobs disturb least) and the driver's
own wall time (``wall``), best of ``repeats`` runs.

Run ``python3 report/mp_study.py [--quick]``: writes ``report/data/mp_study.json``,
``report/mp_old_new_error_vs_time.png`` and ``report/data/mp_section.md`` (the tables, ready to
paste into the report).
"""

from __future__ import annotations

import itertools
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if not __package__:  # run as a script, not imported as report.mp_study: the repository's packages
    sys.path.insert(0, str(ROOT))

from benchmarks.old_map import old  # noqa: E402
from subfric_dolfinx.constitutive import CoulombLaw, preset  # noqa: E402
from subfric_dolfinx.driver import Case, run_case  # noqa: E402
from tests.reference_ode import solve_reference  # noqa: E402

P = preset("sec7")
PREVIOUS = old(P)
F_N = 300.0
UN = F_N / P.alpha_n
G = -math.expm1(-P.c_n * F_N)
# Coulomb with the same penalty stiffness, its strength equal to the subloading kinetic strength
MU_C = G * P.mu_k / F_N
COULOMB = CoulombLaw(alpha_t=P.alpha_t, alpha_n=P.alpha_n, mu_c=MU_C)
LAWS = ("subloading", "subloading_previous", "coulomb")

PATHS = {
    "reversal": (
        np.array(
            [[0, 0, 0, UN], [1, 1, 0, UN], [3, -1, 0, UN], [23, -1, 0, UN], [25, 1, 0, UN]],
            dtype=float,
        ),
        1,
        [25.0 * 2**k for k in range(7)],
    ),
    "turn": (
        np.array([[0, 0, 0, UN], [0.3, 0.3, 0, UN], [0.45, 0.3, 0.15, UN]], dtype=float),
        2,
        [100.0 * 2**k for k in range(7)],
    ),
}
SAMPLE_EVERY = {"reversal": 0.04, "turn": 0.01}  # s (the paths move at 1 mm/s)


def samples_of(path: np.ndarray, every: float | None = None) -> np.ndarray:
    """Sample times plus the breakpoints.

    Every ``every`` s where the gap moves (a hold gets its ends only), or 40 equal intervals of
    the whole path if ``every`` is None.
    """
    t0, t1 = path[0, 0], path[-1, 0]
    if every is None:
        return np.union1d(np.linspace(t0, t1, 41), path[:, 0])
    ts = [path[:, 0]]
    for a, b in itertools.pairwise(path):
        if np.any(a[1:] != b[1:]):
            n = max(1, round((b[0] - a[0]) / every))
            ts.append(np.round(np.linspace(a[0], b[0], n + 1), 12))
    return np.unique(np.concatenate(ts))


def coulomb_exact(path: np.ndarray, ts: np.ndarray, nt: int) -> np.ndarray:
    """Exact Coulomb tractions at ``ts`` (constant ``u_n``; straight legs)."""
    R = MU_C * COULOMB.alpha_n * path[0, 3]
    a = COULOMB.alpha_t
    out = np.zeros((ts.size, nt))
    if nt == 1:
        # the play operator: exact leg by leg
        knots = np.union1d(path[:, 0], ts)
        u = np.interp(knots, path[:, 0], path[:, 1])
        f = np.zeros(knots.size)
        for i in range(1, knots.size):
            f[i] = np.clip(f[i - 1] + a * (u[i] - u[i - 1]), -R, R)
        out[:, 0] = f[np.searchsorted(knots, ts)]
        return out
    # turn: leg 1 along e1 (elastic, then on the circle), leg 2 along e2 from (R, 0)
    t1 = path[1, 0]
    v1 = path[1, 1] / t1
    v2 = (path[2, 2] - path[1, 2]) / (path[2, 0] - t1)
    assert a * path[1, 1] > R, "leg 1 must reach the circle"
    for i, t in enumerate(ts):
        if t <= t1:
            out[i, 0] = min(a * v1 * t, R)
        else:
            s = v2 * (t - t1)
            x = a * s / R
            out[i] = R / math.cosh(x), R * math.tanh(x)
    return out


def _case(law: str, path: np.ndarray, ts: np.ndarray, nt: int) -> dict | Case:
    """The driver case of ``law`` (a JSON-like dict, or a :class:`Case` for the previous map)."""
    if law == "subloading_previous":
        return Case(PREVIOUS, "disp", path, np.asarray(ts, dtype=float), nt)
    params = {"preset": "sec7"} if law == "subloading" else COULOMB.parameters()
    return {
        "law": law,
        "params": params,
        "control": "disp",
        "path": path.tolist(),
        "t_samples": ts.tolist(),
        "n_tangential": nt,
    }


def lsq_order(steps: list[int], errs: list[float]) -> float:
    """Observed order: minus the least-squares slope of log(error) against log(steps)."""
    x, y = np.log(np.asarray(steps, float)), np.log(np.asarray(errs, float))
    return float(-np.polyfit(x, y, 1)[0])


def run(
    repeats: int = 3,
    log=print,
    laws: tuple[str, ...] = LAWS,
    select: Any = None,
    check_reference: bool = True,
) -> dict:
    """Run the study; return a JSON-ready dictionary.

    Args:
        repeats: Runs of each configuration (the best time is kept).
        log: Where progress lines go.
        laws: The laws to run.
        select: ``select(path, law, spm) -> bool``: run only these configurations (``None``:
            all; the orders are then of the runs made).
        check_reference: Also solve the reference with Radau to estimate its own error.
    """
    out: dict = {
        "f_n": F_N,
        "mu_c": MU_C,
        "g": G,
        "repeats": repeats,
        "sample_every": SAMPLE_EVERY,
        "paths": {},
    }
    for key, (path, nt, spms) in PATHS.items():
        ts = samples_of(path, SAMPLE_EVERY[key])
        t0 = time.perf_counter()
        ref = solve_reference(P, path, ts, n_tangential=nt, rtol=1e-12)
        t_ref = time.perf_counter() - t0
        ref_b = (
            solve_reference(P, path, ts, n_tangential=nt, rtol=1e-12, method="Radau")
            if check_reference
            else ref
        )
        # the peak of |f_t| along the whole path (not only at the samples), for the scale
        dense_ts = np.union1d(np.linspace(path[0, 0], path[-1, 0], 4001), path[:, 0])
        dense = solve_reference(P, path, dense_ts, n_tangential=nt, rtol=1e-10)
        peak = float(np.linalg.norm(dense.f_t, axis=1).max())
        ref_err = float(np.linalg.norm(ref.f_t - ref_b.f_t, axis=1).max() / peak)
        exact_c = coulomb_exact(path, ts, nt)
        peak_c = float(np.linalg.norm(coulomb_exact(path, dense_ts, nt), axis=1).max())
        entry: dict = {
            "path": path.tolist(),
            "n_tangential": nt,
            "n_samples": int(ts.size),
            "reference": {
                "seconds": t_ref,
                "lsoda_vs_radau": ref_err,
                "drift": ref.drift,
                "switches": [[t, k] for t, k in ref.switches],
                "peak": peak,
            },
            "coulomb_peak": peak_c,
            "runs": [],
        }
        refs = {
            "subloading": (ref.f_t, peak),
            "subloading_previous": (ref.f_t, peak),
            "coulomb": (exact_c, peak_c),
        }
        for law in laws:
            refv, pk = refs[law]
            for spm in spms:
                if select is not None and not select(key, law, spm):
                    continue
                case = _case(law, path, ts, nt)
                walls, cpus = [], []
                res = None
                slow = law == "subloading_previous" and spm * path[-1, 0] > 4000
                n_rep = (
                    1 if slow else (repeats if spm * path.shape[0] < 4000 else max(2, repeats - 1))
                )
                for _ in range(n_rep):
                    c0 = time.thread_time()
                    res = run_case(case, steps_per_mm=spm)
                    cpus.append(time.thread_time() - c0)
                    walls.append(res.wall_time)
                assert res is not None and res.complete
                ft = np.column_stack([res.samples["f_t1"], res.samples["f_t2"]])[:, :nt]
                e = np.linalg.norm(ft - refv, axis=1)
                err = float(e.max() / pk)
                i = int(e.argmax())
                entry["runs"].append(
                    {
                        "law": law,
                        "spm": spm,
                        "steps": res.n_steps,
                        "error": err,
                        "t_worst": float(ts[i]),
                        "wall": min(walls),
                        "walls": walls,
                        "cpu": min(cpus),
                        "counts": res.status_counts,
                    }
                )
                log(
                    f"[mp] {key:8s} {law:19s} spm {spm:7.0f}: {res.n_steps:6d} steps, "
                    f"error {err:.3e} (t = {ts[i]:.4g}), best CPU {min(cpus) * 1e3:.1f} ms "
                    f"(wall {min(walls) * 1e3:.1f}) of {n_rep}"
                )
        for law in laws:
            rs = [r for r in entry["runs"] if r["law"] == law]
            errs = [r["error"] for r in rs]
            if len(errs) < 2:
                entry[f"order_{law}"] = None
            elif min(errs) > 1e-13:
                entry[f"order_{law}"] = lsq_order([r["steps"] for r in rs], errs)
            else:
                entry[f"order_{law}"] = None  # exact to round-off at every step
        out["paths"][key] = entry
    return out


def figure(res: dict, where: Path, save: Any = None) -> None:
    """Error against wall time, the three laws on both paths.

    ``save(fig, name)`` writes it (the report's stamped writer); default: ``fig.savefig``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.4))
    styles = {
        "subloading": ("C0", "o", "subloading (current map)"),
        "subloading_previous": ("C7", "v", "subloading (previous map)"),
        "coulomb": ("C3", "s", "Coulomb"),
    }
    for a, key in zip(ax, ("reversal", "turn"), strict=True):
        e = res["paths"][key]
        for law, (c, m, label) in styles.items():
            rs = [r for r in e["runs"] if r["law"] == law]
            if not rs:
                continue
            err = np.maximum([r["error"] for r in rs], 1e-17)
            a.loglog([r["cpu"] for r in rs], err, marker=m, color=c, label=label)
            for r, y in zip(rs, err, strict=True):
                a.annotate(f"{r['steps']}", (r["cpu"], y), fontsize=6, alpha=0.6)
        a.axhline(1e-3, color="k", lw=0.6, ls=":")
        a.set_xlabel("CPU time of the run (s, thread time, best of the repeats)")
        a.set_ylabel(r"max $|f_t - f_t^{ref}|$ / peak (dense samples)")
        a.set_title(f"path '{key}' (labels: number of steps)")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(
        "Material point, Sec. 7 set at 300 MPa: error against run time, "
        "current and previous return map"
    )
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    if save is not None:
        save(fig, where.name)
        return
    fig.savefig(where, dpi=110)
    plt.close(fig)


def _fmt(x: float) -> str:
    return "0" if x == 0 else f"{x:.2e}"


def section(res: dict) -> str:
    """The Markdown tables: per path, the previous and the current map level by level."""
    out = []
    for key, e in res["paths"].items():
        by = {law: {r["spm"]: r for r in e["runs"] if r["law"] == law} for law in LAWS}
        head = (
            "| steps/mm | steps | previous map: error / peak (at t) | CPU us/step | "
            "current map: error / peak (at t) | CPU us/step | Coulomb: error / peak |"
        )
        rows = [head, "|---|---|---|---|---|---|---|"]
        for spm, r in by["subloading"].items():
            p = by["subloading_previous"].get(spm)
            c = by["coulomb"].get(spm)
            cells = [f"{spm:g}", str(r["steps"])]
            if p:
                cells += [
                    f"{_fmt(p['error'])} ({p['t_worst']:.4g})",
                    f"{p['cpu'] / p['steps'] * 1e6:.0f}",
                ]
            else:
                cells += ["-", "-"]
            cells += [
                f"{_fmt(r['error'])} ({r['t_worst']:.4g})",
                f"{r['cpu'] / r['steps'] * 1e6:.0f}",
                _fmt(c["error"]) if c else "-",
            ]
            rows.append("| " + " | ".join(cells) + " |")
        orders = ", ".join(
            f"{law} {e.get('order_' + law):.2f}"
            if e.get("order_" + law) is not None
            else f"{law} exact"
            for law in LAWS
            if f"order_{law}" in e
        )
        ref = e["reference"]
        out.append(
            f"**Path '{key}'** ({'1-D' if e['n_tangential'] == 1 else '3-D contact'}; "
            f"{e['n_samples']} samples every {res['sample_every'][key]:g} s; reference LSODA rtol "
            f"1e-12, {ref['lsoda_vs_radau']:.1e} of the peak {ref['peak']:.4g} MPa from Radau). "
            f"Observed orders (least squares over all levels): {orders}.\n\n" + "\n".join(rows)
        )
    return "\n\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> None:
    """Run the study and write its data, figure and Markdown tables."""
    import argparse
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="three levels per path, 2 repeats")
    ap.add_argument("--reuse", action="store_true", help="figure and tables from the last JSON")
    args = ap.parse_args(argv)
    here = Path(__file__).resolve().parent
    if args.reuse:
        res = json.loads((here / "data" / "mp_study.json").read_text())
        figure(res, here / "mp_old_new_error_vs_time.png")
        (here / "data" / "mp_section.md").write_text(section(res))
        return
    if args.quick:
        PATHS["reversal"] = (*PATHS["reversal"][:2], [25.0, 50.0, 100.0])
        PATHS["turn"] = (*PATHS["turn"][:2], [100.0, 200.0, 400.0])
    res = run(repeats=2 if args.quick else 3)
    (here / "data").mkdir(exist_ok=True)
    (here / "data" / "mp_study.json").write_text(json.dumps(res, indent=1))
    figure(res, here / "mp_old_new_error_vs_time.png")
    (here / "data" / "mp_section.md").write_text(section(res))
    print(section(res))


if __name__ == "__main__":
    main()
