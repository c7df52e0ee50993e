"""Analysis of the report's raw results (``report/data/*.json``).

Orders, errors, tables, and the numbers the README's template (``templates/README.md.j2``)
quotes.

Nothing here runs a study (:mod:`running`) or draws (:mod:`figures`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# --------------------------------------------------------------------------------------------
# Helpers


def fmt(x: float | None, digits: int = 2) -> str:
    """``x`` in scientific notation, ``-`` for None, NaN or inf."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}e}"


def lsq_order(h: list[float], err: list[float]) -> float:
    """Observed order: least-squares slope of log(error) against log(h) (nan below 2 levels)."""
    if len(h) < 2:
        return float("nan")
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


def pair_order(e0: float, e1: float, h0: float, h1: float) -> str:
    """The order between two levels, two decimals (``-0.00`` shown as ``0.00``; "-" for none)."""
    if e0 <= 0 or e1 <= 0:
        return "-"
    return f"{math.log(e0 / e1) / math.log(h0 / h1):.2f}".replace("-0.00", "0.00")


def table(header: list[str], rows: list[list[Any]]) -> str:
    """A Markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def key_t(t: float) -> float:
    """A time as a dictionary key (rounded to 1e-9 s)."""
    return round(float(t), 9)


# --------------------------------------------------------------------------------------------
# Material point


MP_HEAD = [
    "law",
    "steps/mm",
    "steps",
    "error / peak",
    "worst at t (s)",
    "wall (ms)",
    "us/step",
    "order (pairwise)",
]


def mp_tables(res: dict[str, Any]) -> list[str]:
    """One paragraph and table per path of the material-point study."""
    lines = []
    for key, e in res["paths"].items():
        rows = []
        for law in ("subloading", "coulomb"):
            prev = None
            for r in (r for r in e["runs"] if r["law"] == law):
                ok = prev is not None and prev["error"] > 1e-14 and r["error"] > 1e-14
                o_s = (
                    pair_order(prev["error"], r["error"], r["steps"], prev["steps"]) if ok else "-"
                )
                rows.append(
                    [
                        law,
                        f"{r['spm']:g}",
                        r["steps"],
                        fmt(r["error"]),
                        f"{r['t_worst']:.4g}",
                        f"{r['wall'] * 1e3:.1f}",
                        f"{r['wall'] / r['steps'] * 1e6:.0f}",
                        o_s,
                    ]
                )
                prev = r
        ordr, ordc = e["order_subloading"], e["order_coulomb"]
        ref = e["reference"]
        lines.append(
            f"**Path '{key}'** ({'1-D' if e['n_tangential'] == 1 else '3-D contact, 2 tangents'}; "
            f"reference: LSODA rtol 1e-12, its difference to Radau {fmt(ref['lsoda_vs_radau'], 1)} "
            f"of the peak {ref['peak']:.4g} MPa; switches "
            + ", ".join(f"{k} at {t:.5g} s" for t, k in ref["switches"])
            + f"). Observed order (least squares over all levels): subloading **{ordr:.2f}**, "
            "Coulomb "
            + ("**exact** (round-off at every step)" if ordc is None else f"**{ordc:.2f}**")
            + ".\n\n"
            + table(MP_HEAD, rows)
        )
    return lines


# --------------------------------------------------------------------------------------------
# Stability


def stability_table(point: list[dict], fe: dict[int, dict]) -> tuple[str, dict[str, Any]]:
    """The stability table and its counts (FE cases of the catalogue found in the data)."""
    from tests import stability as stability_cases

    def short(s: str, n: int = 150) -> str:
        s = s.replace("|", "/").replace("\n", " ")
        return s if len(s) <= n else s[: n - 3] + "..."

    rows = []
    for d in point:
        rows.append(
            [
                "point",
                d["name"],
                d["what"],
                d["expect"],
                f"**{d['outcome']}**" + ("" if d["passed"] else " (NOT AS EXPECTED)"),
                f"{d['it_mean']:.2f} / {d['it_max']} (return map)",
                "yes" if d["nan_free"] else "**NO**",
                short(d["detail"] + (f"; *{d['message']}*" if d["message"] else "")),
            ]
        )
    missing = []
    for case in stability_cases.FE_CASES:
        if case.name not in fe[1] or case.name not in fe[2]:
            missing.append(case.name)  # added to the catalogue after the data was made
            continue
        a, b = fe[1][case.name], fe[2][case.name]
        oc = a["outcome"] if a["outcome"] == b["outcome"] else f"{a['outcome']} / {b['outcome']}"
        ok = a["passed"] and b["passed"]
        rows.append(
            [
                "FE",
                case.name,
                case.what,
                case.expect,
                f"**{oc}**" + ("" if ok else " (NOT AS EXPECTED)"),
                f"{a['it_mean']:.2f} / {a['it_max']} ; {b['it_mean']:.2f} / {b['it_max']} (Newton)",
                "yes" if (a["nan_free"] and b["nan_free"]) else "**NO**",
                short(a["detail"] + (f"; *{a['message']}*" if a["message"] else "")),
            ]
        )
    summary = {
        "point": (sum(d["passed"] for d in point), len(point)),
        "fe1": (sum(v["passed"] for v in fe[1].values()), len(fe[1])),
        "fe2": (sum(v["passed"] for v in fe[2].values()), len(fe[2])),
        "point_cases": point,
        "fe_cases": fe,
        "missing": missing,
        "nan_free": all(d["nan_free"] for d in point)
        and all(v["nan_free"] for k in (1, 2) for v in fe[k].values()),
    }
    head = [
        "level",
        "case",
        "setting",
        "must be",
        "outcome (FE: 1 / 2 ranks)",
        "iterations mean / max (FE: 1 rank ; 2 ranks)",
        "no NaN",
        "what happened (1 rank)",
    ]
    return table(head, rows), summary


# --------------------------------------------------------------------------------------------
# The README's numbers


def readme_context(
    mp: dict[str, Any],
    mp_lines: list[str],
    stab_tab: str,
    stab_sum: dict[str, Any],
    fe: dict[str, Any],
    fe_lines: list[str],
    cfg: dict[str, Any],
    *,
    quick: bool,
    elapsed: float,
    reuse: bool,
) -> dict[str, Any]:
    """Everything ``templates/README.md.j2`` quotes, by name.

    The words its sentences choose (which error dominates, where 2 ranks pay off) are decided
    here, from the numbers.
    """
    rev, turn = mp["paths"]["reversal"], mp["paths"]["turn"]

    def runs(e: dict[str, Any], law: str) -> list[dict[str, Any]]:
        return [r for r in e["runs"] if r["law"] == law]

    sub_rev, cou_rev = runs(rev, "subloading"), runs(rev, "coulomb")
    pc = {d["name"]: d for d in stab_sum["point_cases"]}
    lit = stab_sum["fe_cases"][1].get("FE sec7 literal 600 MPa, l2", {}).get("data", {})
    cases = []
    for key, f in fe.items():
        j = f["joint"]
        best = min(j, key=lambda x: x["err1"])
        split = f["split"]
        cases.append(
            {
                "key": key,
                "case": f["case"],
                "law": f["law"],
                "f": f,
                "best": best,
                "first": j[0],
                "last": j[-1],
                "dominant": None
                if split is None
                else ("time" if split["time"] > split["space"] else "space"),
                "ratio": None
                if split is None or min(split.values()) <= 0
                else max(split.values()) / min(split.values()),
                "pays": f["pays_off"],
                "speedup_last": j[-1]["wall1"] / j[-1]["wall2"],
            }
        )
    return {
        "quick": quick,
        "reuse": reuse,
        "elapsed": elapsed,
        "mp": mp,
        "mp_lines": mp_lines,
        "rev": rev,
        "turn": turn,
        "sub_rev": sub_rev,
        "cou_rev": cou_rev,
        "sub_turn": runs(turn, "subloading"),
        "cou_turn": runs(turn, "coulomb"),
        "cou_rev_max": max(r["error"] for r in cou_rev),
        "us_sub": float(np.median([r["wall"] / r["steps"] for r in sub_rev]) * 1e6),
        "us_cou": float(np.median([r["wall"] / r["steps"] for r in cou_rev]) * 1e6),
        "cfg": cfg,
        "fe": fe,
        "fe_lines": fe_lines,
        "fe_cases": cases,
        "max_diff12": max(f["max_diff12"] for f in fe.values()),
        "stab_tab": stab_tab,
        "stab": stab_sum,
        "r_kx": pc.get("large kappa and xi", {}).get("data", {}).get("lost_r", float("nan")),
        "t_run": pc.get("stress ramp past the peak", {}).get("data", {}).get("t", float("nan")),
        "it_lit": pc.get("sec7 literal 600 MPa", {}).get("it_mean", float("nan")),
        "lit": lit,
    }
