"""Analysis of the FE study (``report/data/fe_study_<n>.json``), per case and law.

Cases: the 2-D block, the 3-D pad; laws: this one, Coulomb.

The quantity is the mean tangential traction ``F_t1 / A`` at the times every run of the case and
law stepped through (the program's breakpoints and the coarsest run's steps). Errors (max over
those times, relative to the peak) against a composite reference, fine in time and in space:
``ref = T + (S - S_coarse)``, ``T`` the run at the time study's mesh with the finest step, ``S``
the finest mesh at the space study's step and ``S_coarse`` the time study's mesh at that step.
Observed orders in time, in space and along the **joint** sequence (time and space refined
together: the error a user buys with run time), 1 against 2 ranks, the coarsest step that
converges without a cut, and the timing breakdown of the finest joint level.

Returns the numbers (JSON-ready, also written to ``report/data/fe_summary.json``), the Markdown
tables and the curves :mod:`figures` draws. Every sentence of the README's FE section is computed
from this summary.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from report.analysis import fmt, key_t, lsq_order, pair_order, table

TIMING_ORDER = [
    "mesh generation",
    "setup",
    "bulk assembly",
    "return map",
    "interface assembly",
    "factorisation",
    "linear solve",
]


def _find(runs: list[dict], n: int, dt: float) -> dict:
    """The converged run of the study (not a probe) with ``n`` and ``dt``."""
    for r in runs:
        if r["n"] == n and abs(r["dt"] - dt) < 1e-12 and "max_cuts" not in r and r["converged"]:
            return r
    raise KeyError(f"no converged run n = {n}, dt = {dt}")


def _ok(runs: list[dict], n: int, dt: float) -> bool:
    """Whether the study's run with ``n`` and ``dt`` converged."""
    try:
        _find(runs, n, dt)
    except KeyError:
        return False
    return True


def fe_analysis(
    raw: dict[int, list[dict]], cfg: dict[str, Any]
) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    """Summary per ``"<case>/<law>"``, the tables, and the curves of the figures."""
    summary: dict[str, Any] = {}
    lines: list[str] = []
    curves: dict[str, Any] = {}
    for case, c in cfg["cases"].items():
        for law in cfg["laws"]:
            key = f"{case}/{law}"
            r1 = [r for r in raw[1] if r["case"] == case and r["law"] == law]
            r2 = [r for r in raw[2] if r["case"] == case and r["law"] == law]
            s, tables, cv = _one(r1, r2, c, case, law)
            summary[key] = s
            lines += tables
            curves[key] = cv
    return summary, lines, curves


def _one(runs1: list[dict], runs2: list[dict], c: dict[str, Any], case: str, law: str):
    time_n, dt_ref, space_dt, n_ref = c["time_n"], c["dt_ref"], c["space_dt"], c["n_ref"]
    used1 = [r for r in runs1 if r["converged"] and "max_cuts" not in r]
    used2 = [r for r in runs2 if r["converged"]]
    common = set.intersection(*({key_t(t) for t in r["t"]} for r in used1 + used2))
    coarse = _find(runs1, time_n, space_dt)
    tc = np.array(sorted(t for t in coarse["t"] if key_t(t) in common))

    def at(r: dict) -> np.ndarray:
        idx = {key_t(t): i for i, t in enumerate(r["t"])}
        return np.array([r["ft"][idx[key_t(t)]] for t in tc])

    T_ref = at(_find(runs1, time_n, dt_ref))
    S_ref = at(_find(runs1, n_ref, space_dt))
    ref = T_ref + (S_ref - at(coarse))
    peak = float(np.abs(ref).max())

    def err(r: dict, against: np.ndarray) -> float:
        return float(np.abs(at(r) - against).max() / peak)

    # runs that did not converge (a step failed after every cut) are listed, not used
    failed_runs = sorted(
        {(r["n"], r["dt"]) for r in runs1 + runs2 if not r["converged"] and "max_cuts" not in r}
    )
    time_rows = [
        (dt, err(_find(runs1, time_n, dt), T_ref), _find(runs1, time_n, dt))
        for dt in c["time_dts"]
        if _ok(runs1, time_n, dt)
    ]
    space_rows = [
        (n, err(_find(runs1, n, space_dt), S_ref), _find(runs1, n, space_dt))
        for n in c["ns"]
        if _ok(runs1, n, space_dt)
    ]
    p_time = lsq_order([d for d, _, _ in time_rows], [max(e, 1e-300) for _, e, _ in time_rows])
    p_space = lsq_order(
        [1.0 / n for n, _, _ in space_rows], [max(e, 1e-300) for _, e, _ in space_rows]
    )
    joint = []
    for n, dt in c["joint"]:
        if not (_ok(runs1, n, dt) and _ok(runs2, n, dt)):
            continue
        a, b = _find(runs1, n, dt), _find(runs2, n, dt)
        fa, fb = at(a), at(b)
        joint.append(
            {
                "n": n,
                "dt": dt,
                "dofs": a["info"]["dofs"],
                "steps": len(a["t"]),
                "err1": err(a, ref),
                "err2": err(b, ref),
                "wall1": a["wall"],
                "wall2": b["wall"],
                "rep1": len(a["walls"]),
                "rep2": len(b["walls"]),
                "diff12": float(np.abs(fa - fb).max() / peak),
                "newton1": (float(np.mean(a["newton"])), int(max(a["newton"]))),
                "newton2": (float(np.mean(b["newton"])), int(max(b["newton"]))),
                "cuts": (a["cuts"], b["cuts"]),
                # the parts of the joint level's error: time at the coarse mesh, space at the
                # coarse step (both measured above when this level is in those studies)
            }
        )
    p_joint = lsq_order([1.0 / j["n"] for j in joint], [max(j["err1"], 1e-300) for j in joint])
    probes = [r for r in runs1 if "max_cuts" in r]
    tried = sorted({r["dt"] for r in probes} | {d for d in c["time_dts"]}, reverse=True)
    converged = {r["dt"]: r["converged"] for r in probes}
    converged.update({d: _ok(runs1, time_n, d) for d in c["time_dts"]})
    coarsest = next((d for d in tried if converged.get(d)), None)
    failed = [d for d in tried if not converged.get(d)]
    last = joint[-1]
    tim = {
        1: dict(_find(runs1, last["n"], last["dt"])["timing"]),
        2: dict(_find(runs2, last["n"], last["dt"])["timing"]),
    }
    for k in (1, 2):
        tim[k]["other"] = tim[k]["total"] - sum(tim[k][s] for s in TIMING_ORDER)
    largest = {k: max([*TIMING_ORDER, "other"], key=lambda s: tim[k][s]) for k in (1, 2)}
    t_space = {n: e for n, e, _ in space_rows}
    t_time = {d: e for d, e, _ in time_rows}
    split = None  # at the coarse joint level: is the time or the space error larger?
    n0, d0 = joint[0]["n"], joint[0]["dt"]
    if n0 == time_n and d0 in t_time and n0 in t_space and d0 == space_dt:
        split = {"time": t_time[d0], "space": t_space[n0]}
    s = {
        "case": case,
        "law": law,
        "peak": peak,
        "times": len(tc),
        "p_time": p_time,
        "p_space": p_space,
        "p_joint": p_joint,
        "time_rows": [(d, e) for d, e, _ in time_rows],
        "space_rows": [(n, e) for n, e, _ in space_rows],
        "joint": joint,
        "max_diff12": max(j["diff12"] for j in joint),
        "pays_off": [j["dofs"] for j in joint if j["wall2"] < j["wall1"]],
        "coarsest_dt": coarsest,
        "failed_dts": failed,
        "probe_n": time_n,
        "failed_runs": failed_runs,
        "timing": tim,
        "largest": largest,
        "split": split,
        "newton_mean": float(np.mean([j["newton1"][0] for j in joint])),
        "newton_max": max(max(j["newton1"][1], j["newton2"][1]) for j in joint),
        "no_cuts": all(tuple(j["cuts"]) == (0, 0) for j in joint),
        "ref": {"time": (time_n, dt_ref), "space": (n_ref, space_dt)},
    }
    title = f"**{case}, {law}**"
    tables = [
        f"{title}: time (n = {time_n} against dt = {dt_ref:g})\n\n" + _time_table(time_rows),
        f"{title}: space (dt = {space_dt:g} against n = {n_ref})\n\n" + _space_table(space_rows),
        f"{title}: time and space refined together, 1 and 2 ranks\n\n" + _joint_table(joint),
        f"{title}: timing of the finest joint level (n = {last['n']}, dt = {last['dt']:g})\n\n"
        + _timing_table(tim),
    ]
    cv = {
        "tc": tc,
        "ref": ref,
        "time_rows": s["time_rows"],
        "space_rows": s["space_rows"],
        "joint": joint,
    }
    return s, tables, cv


def _time_table(rows) -> str:
    out = []
    for i, (dt, e, r) in enumerate(rows):
        prev = rows[i - 1] if i else None
        order = "-" if prev is None else pair_order(prev[1], e, prev[0], dt)
        newton = f"{np.mean(r['newton']):.2f} / {max(r['newton'])}"
        out.append([f"{dt:g}", len(r["t"]), fmt(e), order, newton, f"{r['wall']:.2f}"])
    return table(
        ["dt (s)", "steps", "max error / peak", "order", "Newton mean / max", "wall (s)"], out
    )


def _space_table(rows) -> str:
    out = []
    for i, (n, e, r) in enumerate(rows):
        prev = rows[i - 1] if i else None
        o = "-" if prev is None else f"{math.log(prev[1] / e) / math.log(n / prev[0]):.2f}"
        out.append([n, r["info"]["dofs"], fmt(e), o, f"{r['wall']:.2f}"])
    return table(["n", "dofs", "max error / peak", "order", "wall (s)"], out)


def _joint_table(joint) -> str:
    head = [
        "n",
        "dofs",
        "dt (s)",
        "steps",
        "error 1 rank",
        "error 2 ranks",
        "wall 1 rank (s)",
        "wall 2 ranks (s)",
        "Newton mean / max (1; 2)",
        "cuts",
        "1 vs 2 ranks",
    ]
    rows = [
        [
            j["n"],
            j["dofs"],
            f"{j['dt']:g}",
            j["steps"],
            fmt(j["err1"]),
            fmt(j["err2"]),
            f"{j['wall1']:.2f} (best of {j['rep1']})",
            f"{j['wall2']:.2f} (best of {j['rep2']})",
            f"{j['newton1'][0]:.2f} / {j['newton1'][1]} ; {j['newton2'][0]:.2f} / "
            f"{j['newton2'][1]}",
            f"{j['cuts'][0]} ; {j['cuts'][1]}",
            fmt(j["diff12"], 1),
        ]
        for j in joint
    ]
    return table(head, rows)


def _timing_table(tim) -> str:
    def cell(n: int, k: str) -> str:
        return f"{tim[n][k]:.3f} ({100 * tim[n][k] / tim[n]['total']:.0f} %)"

    rows = [[k, cell(1, k), cell(2, k)] for k in TIMING_ORDER]
    rows.append(["other (Python stepping, history, forms)", cell(1, "other"), cell(2, "other")])
    rows.append(["**total**"] + [f"**{tim[n]['total']:.3f}**" for n in (1, 2)])
    return table(["section (s, max over ranks)", "1 rank", "2 ranks"], rows)
