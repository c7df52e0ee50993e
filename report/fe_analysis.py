"""Analysis of the FE study (``report/data/fe_study_<n>.json``).

Errors against a composite reference, observed orders in time and space, 1 against 2 ranks, the
timing table.

Returns the numbers (a JSON-ready summary, also written to ``report/data/fe_summary.json``), the
Markdown tables and the curves :mod:`figures` draws.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from analysis import fmt, key_t, lsq_order, pair_order, table

TIMING_ORDER = [
    "mesh generation",
    "setup",
    "bulk assembly",
    "return map",
    "interface assembly",
    "factorisation",
    "linear solve",
]


def fe_analysis(
    raw: dict[int, list[dict]], cfg: dict[str, Any]
) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """Summary, tables (time, space, grid, timing) and the curves of the figures."""
    runs1, runs2 = raw[1], raw[2]
    time_n, dt_ref, space_dt, n_ref = cfg["time_n"], cfg["dt_ref"], cfg["space_dt"], cfg["n_ref"]

    def find(runs, n, dt):
        for r in runs:
            if r["n"] == n and abs(r["dt"] - dt) < 1e-12:
                return r
        raise KeyError((n, dt))

    def at(r, tc):
        idx = {key_t(t): i for i, t in enumerate(r["t"])}
        missing = [t for t in tc if key_t(t) not in idx]
        if missing:
            raise RuntimeError(f"run n={r['n']} dt={r['dt']} misses times {missing[:3]}")
        return np.array([r["ft"][idx[key_t(t)]] for t in tc])

    coarse = find(runs1, time_n, space_dt)
    tc = np.array(coarse["t"])  # the common time grid (every run steps through it)
    T_ref = at(find(runs1, time_n, dt_ref), tc)
    S_ref = at(find(runs1, n_ref, space_dt), tc)
    S_n = at(coarse, tc)
    ref = T_ref + (S_ref - S_n)  # composite reference: fine in time and in space
    peak = float(np.abs(ref).max())

    def err(r, against):
        return float(np.abs(at(r, tc) - against).max() / peak)

    # time: n = time_n against its own fine-step run; max, rms and max per phase
    hold = cfg["hold"]
    phases = {
        "forward": (tc > 1.0) & (tc <= 2.0),
        "back": (tc > 2.0) & (tc <= 4.0),
        "hold": (tc > 4.0) & (tc <= 4.0 + hold),
        "reload": tc > 4.0 + hold,
    }
    time_rows, time_detail, err_curves = [], [], []
    for dt in cfg["time_dts"]:
        r = find(runs1, time_n, dt)
        e = np.abs(at(r, tc) - T_ref) / peak
        time_rows.append((dt, float(e.max()), r))
        err_curves.append((dt, e))
        time_detail.append(
            {"rms": float(np.sqrt(np.mean(e**2)))}
            | {k: float(e[m].max()) for k, m in phases.items()}
        )
    dts_t = [d for d, _, _ in time_rows]
    p_time_cols = {
        k: lsq_order(dts_t, [max(x[k], 1e-300) for x in time_detail]) for k in ("rms", *phases)
    }
    # space: dt = space_dt against the finest mesh at the same step
    space_rows = [(n, err(find(runs1, n, space_dt), S_ref), find(runs1, n, space_dt))
                  for n in cfg["ns"]]  # fmt: skip
    p_time = lsq_order([d for d, _, _ in time_rows], [e for _, e, _ in time_rows])
    p_space = lsq_order([1.0 / n for n, _, _ in space_rows], [e for _, e, _ in space_rows])
    p_time_fine = (
        math.log(time_rows[-2][1] / time_rows[-1][1])
        / math.log(time_rows[-2][0] / time_rows[-1][0])
        if len(time_rows) >= 2
        else None
    )
    ref_space_corr = float(np.abs(S_ref - S_n).max() / peak)

    # total error of the grid, 1 and 2 ranks; 1-vs-2 difference
    grid = []
    for n in cfg["ns"]:
        for dt in cfg["dts"]:
            a, b = find(runs1, n, dt), find(runs2, n, dt)
            fa, fb = np.array(a["ft"]), np.array(b["ft"])
            diff = float(np.abs(fa - fb).max() / peak) if fa.shape == fb.shape else float("nan")
            grid.append(
                {
                    "n": n,
                    "dt": dt,
                    "steps": len(a["t"]),
                    "err1": err(a, ref),
                    "err2": err(b, ref),
                    "wall1": a["wall"],
                    "wall2": b["wall"],
                    "rep1": len(a["walls"]),
                    "rep2": len(b["walls"]),
                    "newton1": (float(np.mean(a["newton"])), int(max(a["newton"]))),
                    "newton2": (float(np.mean(b["newton"])), int(max(b["newton"]))),
                    "cuts": (a["cuts"], b["cuts"]),
                    "diff12": diff,
                    "dofs": a["info"]["dofs"],
                }
            )
    rep_n, rep_dt = cfg["rep"]
    rep = {1: find(runs1, rep_n, rep_dt), 2: find(runs2, rep_n, rep_dt)}

    lines = [
        _time_table(time_rows, time_detail, p_time, p_time_cols, phases, time_n),
        _space_table(space_rows, space_dt),
        _grid_table(grid),
    ]
    tim = {n: dict(rep[n]["timing"]) for n in (1, 2)}
    for n in (1, 2):
        tim[n]["other"] = tim[n]["total"] - sum(tim[n][k] for k in TIMING_ORDER)
        rep[n]["timing"] = tim[n]
    lines.append(_timing_table(tim))
    summary = {
        "p_time": p_time,
        "p_time_fine": p_time_fine,
        "p_time_cols": p_time_cols,
        "time_detail": time_detail,
        "p_space": p_space,
        "time_rows": [(d, e) for d, e, _ in time_rows],
        "space_rows": [(n, e) for n, e, _ in space_rows],
        "grid": grid,
        "max_diff12": max(g["diff12"] for g in grid),
        "peak": peak,
        "ref_space_corr": ref_space_corr,
        "rep": {
            n: {
                "timing": rep[n]["timing"],
                "walls": rep[n]["walls"],
                "newton": (float(np.mean(rep[n]["newton"])), int(max(rep[n]["newton"]))),
                "info": rep[n]["info"],
                "steps": len(rep[n]["t"]),
            }
            for n in (1, 2)
        },
        "n_steps_ref": len(find(runs1, time_n, dt_ref)["t"]),
        "ref_wall": find(runs1, time_n, dt_ref)["wall"],
        "space_ref_wall": find(runs1, n_ref, space_dt)["wall"],
        "space_ref_dofs": find(runs1, n_ref, space_dt)["info"]["dofs"],
    }
    curves = {
        "tc": tc,
        "ref": ref,
        "err_curves": err_curves,
        "histories": [(dt, find(runs1, time_n, dt)) for dt in cfg["time_dts"][:2]],
    }
    return summary, lines, curves


def _time_table(time_rows, time_detail, p_time, p_time_cols, phases, time_n) -> str:
    rows = []
    for i, ((dt, e, r), x) in enumerate(zip(time_rows, time_detail, strict=True)):
        prev = time_rows[i - 1] if i else None
        rows.append(
            [
                f"{dt:g}",
                len(r["t"]),
                f"**{fmt(e)}**",
                "-" if prev is None else pair_order(prev[1], e, prev[0], dt),
                fmt(x["rms"]),
                fmt(x["forward"]),
                fmt(x["back"]),
                fmt(x["hold"]),
                fmt(x["reload"]),
                f"{np.mean(r['newton']):.2f} / {max(r['newton'])}",
            ]
        )
    rows.append(
        ["order (least squares)", "", f"**{p_time:.2f}**", "",
         *(f"{p_time_cols[k]:.2f}" for k in ("rms", *phases)), ""]
    )  # fmt: skip
    head = ["dt (s)", "steps", f"max error / peak (n = {time_n})", "order (pairwise)",
            "rms over time", "max, forward slide", "max, back slide", "max, hold", "max, reload",
            "Newton mean / max"]  # fmt: skip
    return table(head, rows)


def _space_table(space_rows, space_dt) -> str:
    rows = []
    for i, (n, e, r) in enumerate(space_rows):
        prev = space_rows[i - 1] if i else None
        o = "-" if prev is None else f"{math.log(prev[1] / e) / math.log(n / prev[0]):.2f}"
        rows.append([n, r["info"]["dofs"], fmt(e), o])
    return table(["n_interface", "dofs", f"error / peak (dt = {space_dt:g})", "order"], rows)


def _grid_table(grid) -> str:
    head = ["n", "dofs", "dt (s)", "steps", "error 1 rank", "error 2 ranks", "wall 1 rank (s)",
            "wall 2 ranks (s)", "Newton mean / max (1; 2)", "cuts", "1 vs 2 ranks"]  # fmt: skip
    rows = [
        [
            g["n"],
            g["dofs"],
            f"{g['dt']:g}",
            g["steps"],
            fmt(g["err1"]),
            fmt(g["err2"]),
            f"{g['wall1']:.2f} (best of {g['rep1']})",
            f"{g['wall2']:.2f} (best of {g['rep2']})",
            f"{g['newton1'][0]:.2f} / {g['newton1'][1]} ; "
            f"{g['newton2'][0]:.2f} / {g['newton2'][1]}",
            f"{g['cuts'][0]} ; {g['cuts'][1]}",
            fmt(g["diff12"], 1),
        ]
        for g in grid
    ]
    return table(head, rows)


def _timing_table(tim) -> str:
    def cell(n: int, k: str) -> str:
        return f"{tim[n][k]:.3f} ({100 * tim[n][k] / tim[n]['total']:.0f} %)"

    rows = [[k, cell(1, k), cell(2, k)] for k in TIMING_ORDER]
    rows.append(["other (Python stepping, history, forms)", cell(1, "other"), cell(2, "other")])
    rows.append(["**total**"] + [f"**{tim[n]['total']:.3f}**" for n in (1, 2)])
    return table(["section (s, max over ranks)", "1 rank", "2 ranks"], rows)
