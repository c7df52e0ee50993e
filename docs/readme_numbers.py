"""The numbers the README and the docs quote from measured results, each tied to its record.

    ./run exec python3 docs/readme_numbers.py           # write them into the pages from the data
    ./run exec python3 docs/readme_numbers.py --check   # list the quotes that differ (exit 1)

A :class:`Quote` finds its place in its page (``README.md`` or a page of ``docs/``) with a
regular expression whose groups are the quoted numbers, and computes their text from the data:

* the demos' runs, ``docs/demo_results.json`` (``docs/demo_results.py``: wall times, warnings and
  what each demo measured, on 2 ranks as the README's table says);
* the report, ``report/data/`` (``./run report``: material point, FE study, stability);
* the scaling benchmark, ``report/data/fe_scaling.csv`` (``benchmarks/fe_scaling.py``).

Only the groups are rewritten: the prose around them is the page's own, so other edits of the
pages merge freely. ``tests/demos/test_readme.py`` fails when a quote is not found or differs from
its data, so a quoted number cannot go stale; ``tests/demos/test_records.py`` re-checks the
records themselves on the current code.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DEMOS_PAGE = "docs/reference/demos.md"
ACCURACY_PAGE = "docs/reference/accuracy.md"
SOLVER_PAGE = "docs/reference/solver.md"
DEMO_RESULTS = ROOT / "docs" / "demo_results.json"
REPORT_DATA = ROOT / "report" / "data"


class Data:
    """The measured results, read once (a missing file is an error when a quote needs it)."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root
        self._cache: dict[str, Any] = {}

    def _json(self, rel: str) -> Any:
        if rel not in self._cache:
            self._cache[rel] = json.loads((self.root / rel).read_text())
        return self._cache[rel]

    @property
    def stamp(self) -> dict[str, Any]:
        """The stamp of ``docs/demo_results.json`` (the last ``./run refresh``)."""
        return self._json("docs/demo_results.json")["stamp"]

    @property
    def demos(self) -> dict[str, Any]:
        """``docs/demo_results.json``'s runs by key."""
        return self._json("docs/demo_results.json")["demos"]

    def demo(self, key: str) -> dict[str, Any]:
        """One demo run's record (its ``numbers``, ``wall_s``, ``warnings``)."""
        try:
            return self.demos[key]
        except KeyError:
            raise KeyError(
                f"docs/demo_results.json has no run '{key}': run "
                f"./run exec python3 docs/demo_results.py --only {key}"
            ) from None

    def report(self, name: str) -> Any:
        """``report/data/<name>.json``."""
        return self._json(f"report/data/{name}.json")

    @property
    def scaling(self) -> list[dict[str, str]]:
        """The rows of ``report/data/fe_scaling.csv``."""
        if "scaling" not in self._cache:
            with open(self.root / "report" / "data" / "fe_scaling.csv", newline="") as f:
                self._cache["scaling"] = list(csv.DictReader(f))
        return self._cache["scaling"]

    def scale(self, strategy: str, ranks: int, dofs: int, steps: int, col: str) -> float:
        """One column of the scaling benchmark's row (strategy, ranks, dofs, program steps)."""
        for r in self.scaling:
            if (r["strategy"], int(r["ranks"]), int(r["dofs"]), int(r["steps_program"])) == (
                strategy,
                ranks,
                dofs,
                steps,
            ):
                return float(r[col])
        raise KeyError(
            f"fe_scaling.csv has no row {strategy}, {ranks} ranks, {dofs} dofs, {steps} steps"
        )


@dataclass(frozen=True)
class Quote:
    """Numbers quoted at one place of the README or of a page of the docs.

    Attributes:
        name: What is quoted (for messages).
        pattern: A regular expression (multiline) matching the place once; each group is a
            quoted number.
        values: The groups' text, computed from the data.
        page: The page, relative to the repository's root.
    """

    name: str
    pattern: str
    values: Callable[[Data], Sequence[str]]
    page: str = "README.md"


def words(text: str) -> str:
    """A pattern from README text: ``{}`` is a quoted number, any whitespace may be a line break.

    A quoted number is one word (no space, ``,``, ``;``, ``(`` or ``)``); ``{s}`` is a quoted
    time with its unit (``5 s``, ``2 min``); ``{t}`` quoted words (on one line, up to the text
    that follows it).
    """
    parts = re.split(r"(\{\}|\{s\}|\{t\})", text)
    out = []
    for p in parts:
        if p == "{}":
            out.append(r"([^\s,;()|]+?)(?!\.?\d)")  # "6.58." is 6.58, not 6
        elif p == "{s}":
            out.append(r"(\d+(?:\.\d+)?\s(?:s|min))")
        elif p == "{t}":
            out.append(r"([^;'\n]+?)")
        elif p:
            inner = r"\s+".join(re.escape(w) for w in p.split())
            out.append(
                (r"\s+" if p[0].isspace() else "")
                + inner
                + (r"\s+" if p[-1].isspace() and inner else "")
            )
    return "".join(out)


# --------------------------------------------------------------------------------------------
# Formats


def f2(x: float) -> str:
    """Two decimals."""
    return f"{x:.2f}"


def sig(x: float, n: int = 2) -> str:
    """``n`` significant digits, fixed notation (0.054, 0.008, 14.27 -> '14')."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    digits = max(n - 1 - math.floor(math.log10(abs(x))), 0)
    return f"{x:.{digits}f}"


def e1(x: float) -> str:
    """Scientific with two significant digits, no '+' and no leading zero: 4.1e-6."""
    m, e = f"{x:.1e}".split("e")
    return f"{m}e{int(e)}"


def wall(seconds: float) -> str:
    """A demo's wall time as the README's table gives it: seconds below 2 min, else minutes.

    Below 1 s, one decimal (0.1 s, not "0 s").
    """
    if seconds < 0.95:
        return f"{seconds:.1f} s"
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min"


def pct(x: float, digits: int) -> str:
    """A relative number as a percentage with ``digits`` decimals."""
    return f"{100 * x:.{digits}f}"


def gib(mib: float) -> str:
    """MiB as GiB with one decimal."""
    return f"{mib / 1024:.1f}"


def kdofs(n: float) -> str:
    """Thousands of dofs, as '3.5k' (below 10k) or '37k'."""
    return f"{n / 1e3:.1f}k" if n < 1e4 else f"{n / 1e3:.0f}k"


# --------------------------------------------------------------------------------------------
# The demos (docs/demo_results.json)


def _table_time(demo: str) -> Quote:
    return Quote(
        f"{demo}: wall time in the demo table",
        rf"^\| \[`{demo}`\]\(demos/{demo}\.py\)[^\n]*\| (\d+(?:\.\d+)? (?:s|min)) \|$",
        lambda d: [wall(d.demo(demo)["wall_s"])],
    )


def _warned(d: Data) -> str:
    names = [f"`{k}`" for k in DEMOS if d.demo(k)["warnings"]]
    if not names:
        return "none"
    return ", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1 else names[0]


def _pad_peaks(d: Data) -> list[str]:
    peaks = sorted(d.demo("pad_on_plate")["numbers"]["peaks"])  # (hold, peak, before, strength)
    return [f"{p[1]:.2f}" for p in peaks]


def _punch(d: Data) -> dict[str, float]:
    return d.demo("punch")["numbers"]


def _lap(d: Data, law: str) -> dict[str, Any]:
    return d.demo("lap_joint")["numbers"][law]


def _bolted(d: Data) -> dict[str, Any]:
    return d.demo("bolted_joint")["numbers"]


def _hertz(d: Data, key: str) -> list[str]:
    runs = ["hertz_n4", "hertz_n8", "hertz"]
    return [d.demo(r)["numbers"]["hertz"][key] for r in runs]


def _hertz_apart(d: Data) -> list[str]:
    apart = [d.demo(f"hertz_apart_n{n}")["numbers"]["hertz"] for n in (4, 8)]
    matched = [d.demo(f"hertz_n{n}")["numbers"]["hertz"] for n in (4, 8)]
    return [
        *(sig(100 * abs(h["err_a_fit"])) for h in apart),
        *(sig(100 * h["err_p_inner"]) for h in apart),
        *(sig(100 * h["err_p_inner"]) for h in matched),
    ]


def _fretting(d: Data) -> list[str]:
    m = d.demo("fretting")["numbers"]["measures"]
    coul, sub = m["coulomb"], m["subloading"]
    depth = max(e["plastic"]["depth_any"] for e in coul["extremes"].values())
    last = max(sub["extremes"], key=float)
    return [
        f2(coul["ratio_max"]),
        f2(depth),
        *(f"{p:.4f}" for p in coul["p_max_by_cycle"]),
        f2(sub["loops"][-1]),
        f2(coul["loops"][-1]),
        f2(1e3 * sub["extremes"][last]["slip_centre"]),
        f"{100 * (1 - sub['p_max_by_cycle'][-1] / coul['p_max_by_cycle'][-1]):.0f}",
        f"{100 * (1 - sub['p_integral_by_cycle'][-1] / coul['p_integral_by_cycle'][-1]):.0f}",
    ]


def _shrink_fit(d: Data) -> list[str]:
    r = d.demo("shrink_fit")["numbers"]["report"]
    return [
        sig(100 * r["p_mean_error"]),
        sig(100 * r["p_max_error"]),
        f"{100 * r['coulomb_onset_error']:+.2g}",
    ]


def _sliding_far(d: Data) -> list[str]:
    r = d.demo("block_sliding_far")["numbers"]
    return [
        f2(r["F_n_end"]),
        f"{r['friction_end']:.5f}",
        f"{r['material_point_end']:.5f}",
        f2(r["compression_offset_max"]),
    ]


def _records(d: Data) -> list[str]:
    return [d.stamp["commit"][:10], d.stamp["date"].split()[0], f"{d.stamp['load'][0]:.1f}"]


def _later(d: Data) -> str:
    """The runs recorded again since the last ``./run refresh``: names, commit, loads."""
    groups: dict[str, list[tuple[str, float]]] = {}
    for key, rec in d.demos.items():
        st = rec.get("stamp") or d.stamp
        if st["commit"] != d.stamp["commit"] and not key.endswith("_small"):
            groups.setdefault(st["commit"][:10], []).append((key, st["load"][0]))
    if not groups:
        return "none"
    parts = []
    for commit, runs in sorted(groups.items(), key=lambda g: min(g[1])):
        loads = sorted(load for _, load in runs)
        span = (
            f"{loads[0]:.1f}" if loads[-1] - loads[0] < 0.05 else f"{loads[0]:.1f}-{loads[-1]:.1f}"
        )
        names = ", ".join(f"`{k}`" for k, _ in sorted(runs))
        parts.append(f"{names} at `{commit}` (load {span})")
    return ", ".join(parts) + " (with their smallest runs)"


def _cm(d: Data) -> dict[str, Any]:
    return d.demo("cattaneo_mindlin")["numbers"]


def _cm_fit(d: Data) -> list[str]:
    runs = ["cattaneo_mindlin_n4", "cattaneo_mindlin", "cattaneo_mindlin_n16"]
    return [f"{100 * abs(d.demo(r)['numbers']['coulomb']['err_c_fit']):.2f}" for r in runs]


def _mp(d: Data) -> list[str]:
    paths = d.report("mp_study")["paths"]
    rev, turn = paths["reversal"], paths["turn"]
    sub = [r for r in rev["runs"] if r["law"] == "subloading"]
    cou = max(r["error"] for r in rev["runs"] if r["law"] == "coulomb")
    return [
        e1(sub[0]["error"]),
        str(sub[0]["steps"]),
        e1(sub[-1]["error"]),
        str(sub[-1]["steps"]),
        f2(rev["order_subloading"]),
        e1(cou),
        f2(turn["order_subloading"]),
        f2(turn["order_subloading_previous"]),
        f2(turn["order_coulomb"]),
    ]


def _fe(d: Data, key: str) -> dict[str, Any]:
    return d.report("fe_summary")[key]


def _fe_block(d: Data) -> list[str]:
    f = _fe(d, "block/subloading")
    split = f["split"]
    big = "time" if split["time"] > split["space"] else "space"
    ratio = max(split.values()) / min(split.values())
    diff = max(x["max_diff12"] for x in d.report("fe_summary").values())
    dofs = [j["dofs"] for j in f["joint"]]
    pays = f["pays_off"]
    if not pays:
        faster = "at no size of the study"
    elif pays == dofs[dofs.index(pays[0]) :]:
        faster = f"from {pays[0]} dofs on"
    else:
        faster = "at " + " and ".join(str(n) for n in pays) + " dofs only"
    return [big, f"{ratio:.1f}", e1(diff), f"{f['newton_mean']:.1f}", faster, f["largest"]["1"]]


def _nan_free(d: Data) -> bool:
    return all(c["nan_free"] for c in d.report("stability_point")) and all(
        c["nan_free"] for n in (1, 2) for c in d.report(f"stability_fe_{n}").values()
    )


DEMOS = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
"""Every demo: its row of the README's table quotes its wall time."""

# fmt: off
QUOTES: list[Quote] = [
    # README.md: the demo table's times and the records they come from
    *(_table_time(demo) for demo in DEMOS),
    Quote("the records' commit and date (README)", words(
        "The times and numbers quoted here were recorded at commit `{}` on {} (load {})"),
        _records),
    # docs/reference/demos.md: what each demo shows
    Quote("runs recorded again since (README)", words(
        "runs recorded again since, each at its own commit: {t}; "
        "`tests/demos/test_readme.py` checks"), lambda d: [_later(d)]),
    Quote("the records' commit and date (demos)", words(
        "recorded at commit `{}` on {} (load {}) by `docs/demo_results.py`"),
        _records, page=DEMOS_PAGE),
    Quote("demos whose default run warns", words(
        "Demos whose default run ends with a warning that the model's validity is at stake (a "
        "penetration, or a slide beyond the small-sliding assumption): {t}."),
        lambda d: [_warned(d)], page=DEMOS_PAGE),
    Quote("pad_on_plate: restored peaks", words("peak grows with the hold ({}, {}, {}, {} MPa for"),
          _pad_peaks, page=DEMOS_PAGE),
    Quote("punch: peaks and saturation", words(
        "(edge peaks about {} MPa), then shear; this law and Coulomb side by side: under the "
        "pressure peaks the tangential stress saturates ({} MPa) where Coulomb's keeps growing "
        "({} MPa)"),
        lambda d: [f"{round(_punch(d)['fn_peak'], -2):.0f}", f"{abs(_punch(d)['ft_sub']):.0f}",
                   f"{abs(_punch(d)['ft_coul']):.0f}"], page=DEMOS_PAGE),
    Quote("lap_joint: slip per cycle", words(
        "slip accumulates cycle by cycle ({} µm in the first, {} µm in the last, {} µm in all), "
        "the loosening Coulomb cannot produce ({} µm, then nothing)"),
        lambda d: [f2(_lap(d, "subloading")["slip_per_cycle_um"][0]),
                   f2(_lap(d, "subloading")["slip_per_cycle_um"][-1]),
                   f"{_lap(d, 'subloading')['total_um']:.0f}",
                   f2(_lap(d, "coulomb")["slip_per_cycle_um"][0])], page=DEMOS_PAGE),
    Quote("bolted_joint: peaks and size", words(
        "shrink from the static peak ({} kN) to a symmetric kinetic loop ({} kN) as `mu` softens. "
        "{} dofs by default"),
        lambda d: [f"{1e-3 * abs(_bolted(d)['strokes'][0][1]):.2f}",
                   f"{1e-3 * abs(_bolted(d)['strokes'][-1][1]):.2f}",
                   kdofs(_bolted(d)["dofs"])], page=DEMOS_PAGE),
    Quote("bolt_clamped_joint: force balance and pretension", words(
        "equals the head's, the joint's and the nut's normal resultants ({} of the pretension); "
        "the pretension changes by {} % under the shear"),
        lambda d: [e1(d.demo("bolt_clamped_joint")["numbers"]["report"]["balance"]),
                   f2(100 * d.demo("bolt_clamped_joint")["numbers"]["report"][
                       "pretension_change"])], page=DEMOS_PAGE),
    Quote("shrink_fit: Lame and Coulomb", words(
        "within {} % on average and {} % at every point; pushed off, Coulomb's fit slides at "
        "`2 pi b L mu p` ({} %)"),
        _shrink_fit, page=DEMOS_PAGE),
    Quote("fretting: plastic strain, loops, microslip", words(
        "at `Q/µP` = {} (µ = 0.6): plastic strain only under the contact edges, in the slip "
        "zones within {} mm of the surface, growing every half cycle (largest `p` {}, {}, {}, {} "
        "at the ends of cycles 0-3 with Coulomb); Coulomb's stick zone against Cattaneo-Mindlin "
        "(`--elastic`: the flat elastic); the subloading law calibrated to the same sliding "
        "force: the same loop ({} against {} N mm/mm dissipated in the last cycle), its centre "
        "slipping by {} µm where Coulomb's sticks, {} % less peak plastic strain and {} % less "
        "`∫p dA` after 3 cycles"),
        _fretting, page=DEMOS_PAGE),
    Quote("hertz: errors at n = 4, 8, 16", words(
        "half-width (fit) within {}, {}, {} %; peak pressure {}, {}, {} %; largest error of "
        "`p(x)` over `|x| <= 0.8a` {}, {}, {} % of `p0`"),
        lambda d: [*(sig(100 * abs(x)) for x in _hertz(d, "err_a_fit")),
                   *(f"{100 * x:+.3f}" for x in _hertz(d, "err_p0")),
                   *(sig(100 * x) for x in _hertz(d, "err_p_inner"))], page=DEMOS_PAGE),
    Quote("hertz --meshed-apart at n = 4, 8", words(
        "at `--n 4, 8` half-width (fit) within {}, {} %, largest error of `p(x)` over "
        "`|x| <= 0.8a` {}, {} % of `p0` (matched meshes: {}, {} %)"),
        _hertz_apart, page=DEMOS_PAGE),
    Quote("cattaneo_mindlin: Q/muP, stick zone, microslip", words(
        "pushed sideways (`Q/µP` = {}, measured): Coulomb's stick zone against "
        "`c = a sqrt(1 - Q/µP)` (fit within {}, {}, {} % at `--n 4, 8, 16`)"),
        lambda d: [f2(_cm(d)["coulomb"]["ratio"]), *_cm_fit(d)], page=DEMOS_PAGE),
    Quote("cattaneo_mindlin: microslip at the centre", words(
        "microslip all over the stick zone ({} µm at the centre)"),
        lambda d: [f"{1e3 * _cm(d)['subloading']['slip_centre']:.3f}"], page=DEMOS_PAGE),
    Quote("block_sliding_far: resultant, friction, compression", words(
        "the normal resultant stays the pressure's ({} N/mm), the friction at the end is the "
        "material point's ({} against {}), and the base's compression 1 mm below its surface "
        "follows the block (its centre within {} mm of the block's"),
        _sliding_far, page=DEMOS_PAGE),
    Quote("block_sliding_far: steps and Newton", words(
        "{} steps, Newton up to {} iterations in a step"),
        lambda d: [str(d.demo("block_sliding_far")["numbers"]["steps"]),
                   str(d.demo("block_sliding_far")["numbers"]["newton_max"])], page=DEMOS_PAGE),
    Quote("block_sliding_far: push against friction", words(
        "The push on the block's top is not quite the interface's friction force: {} against {} "
        "N/mm at the end, apart by up to {} of the peak friction force over the run"),
        lambda d: [f2(d.demo("block_sliding_far")["numbers"]["push_end"]),
                   f2(d.demo("block_sliding_far")["numbers"]["friction_force_end"]),
                   f"{d.demo('block_sliding_far')['numbers']['push_minus_friction_max']:.2g}"],
        page=DEMOS_PAGE),
    # docs/reference/accuracy.md: the report's headlines
    Quote("report: material point", words(
        "error {} of the peak at {} steps down to {} at {}, observed order {} on a 1-D path "
        "(Coulomb's largest error there: {}); order {} where the sliding direction turns (the "
        "previous return map: {}; Coulomb: {})."),
        _mp, page=ACCURACY_PAGE),
    Quote("report: FE orders", words(
        "2-D block {} / {} / {} with this law, {} / {} / {} with Coulomb; 3-D pad {} / {} / {} "
        "and {} / {} / {}."),
        lambda d: [f2(_fe(d, k)[o]) for k in ("block/subloading", "block/coulomb",
                   "pad/subloading", "pad/coulomb") for o in ("p_time", "p_space", "p_joint")],
        page=ACCURACY_PAGE),
    Quote("report: FE block with this law", words(
        "block with this law the {} error is {} times the other; in all four studies 1 and 2 ranks "
        "agree within {} of the peak (the 3-D pad's default, GAMG, is iterative: Newton's "
        "tolerance); {} Newton iterations per step on average; 2 ranks are faster than 1 {t}; "
        "the largest part of the finest run's time is '{t}' (1 rank)."),
        _fe_block, page=ACCURACY_PAGE),
    Quote("report: stability", words(
        "Stability: {} of {} material-point and {} of {} FE cases"),
        lambda d: [str(sum(c["passed"] for c in d.report("stability_point"))),
                   str(len(d.report("stability_point"))),
                   str(min(sum(c["passed"] for c in d.report(f"stability_fe_{n}").values())
                           for n in (1, 2))),
                   str(len(d.report("stability_fe_1")))], page=ACCURACY_PAGE),
    Quote("report: stability on 1 and 2 ranks, NaN", words(
        "(converged, flagged unstable, or a clear error) on 1 and 2 ranks, {t}; each is also a "
        "test."),
        lambda d: ["with no NaN" if _nan_free(d) else "but NaN or inf seen (see the report)"],
        page=ACCURACY_PAGE),
    *(Quote(f"scale ({where})", pattern, values, page) for where, pattern, values, page in [
        ("report headlines", words(
            "37k dofs {} s against {} s with LU at every iteration ({} of 24 steps); 225k dofs "
            "{} s; 184k dofs over 100 steps {} s; 1M dofs over 100 steps {} s at {} GiB per "
            "rank."),
         lambda d: [sig(d.scale("gamg", 2, 37206, 24, "wall_s"), 3),  # auto_choice there
                    sig(d.scale("lu", 2, 37206, 24, "wall_s"), 3),
                    str(int(d.scale("lu", 2, 37206, 24, "steps"))),
                    sig(d.scale("gamg", 2, 224736, 24, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 184050, 100, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 998556, 100, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 998556, 100, "rss_max_mib"))], ACCURACY_PAGE),
        # docs/reference/solver.md: the linear strategies
        ("linear strategies", words(
            "(3-D pad, 24 steps, 2 ranks: {} s at 37k dofs where LU takes {} s for {} of the 24 "
            "steps; {} s at 70k) and robust with stiff interfaces, but its factor grows faster "
            "than the model ({} GiB per rank at 225k dofs in 3-D on 1 rank)"),
         lambda d: [sig(d.scale("reuse", 2, 37206, 24, "wall_s"), 3),
                    sig(d.scale("lu", 2, 37206, 24, "wall_s"), 3),
                    str(int(d.scale("lu", 2, 37206, 24, "steps"))),
                    sig(d.scale("reuse", 2, 70026, 24, "wall_s"), 3),
                    gib(d.scale("reuse", 1, 224736, 24, "rss_max_mib"))], SOLVER_PAGE),
        ("gamg against reuse", words(
            "(118k dofs, 2 ranks: {} s against {} s; 184k dofs, 100 steps: {} s against {} s, {} "
            "GiB per rank against {}) and it is the only one that reaches 1M dofs on a 24 GB "
            "machine (100 steps in {} s, {} GiB per rank)"),
         lambda d: [sig(d.scale("gamg", 2, 118014, 24, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 118014, 24, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 184050, 100, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 184050, 100, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 184050, 100, "rss_max_mib")),
                    gib(d.scale("reuse", 2, 184050, 100, "rss_max_mib")),
                    sig(d.scale("gamg", 2, 998556, 100, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 998556, 100, "rss_max_mib"))], SOLVER_PAGE),
    ]),
]
# fmt: on


# --------------------------------------------------------------------------------------------
# Reading and writing


def find(q: Quote, text: str) -> re.Match:
    """The one place of its page a quote is at.

    Raises:
        LookupError: Not found, or found more than once.
    """
    found = list(re.finditer(q.pattern, text, re.M))
    if len(found) != 1:
        raise LookupError(
            f"{q.name}: {q.page} has {len(found)} places matching its pattern "
            f"(need 1): {q.pattern[:120]}"
        )
    return found[0]


def pages() -> list[str]:
    """The pages that hold quotes (relative to the repository's root)."""
    return sorted({q.page for q in QUOTES})


def differences(text: str, data: Data, page: str = "README.md") -> list[str]:
    """The quotes of ``page`` (text ``text``) not found or not equal to their data."""
    out = []
    for q in QUOTES:
        if q.page != page:
            continue
        try:
            m = find(q, text)
            want = [str(v) for v in q.values(data)]
        except (LookupError, KeyError, FileNotFoundError) as e:
            out.append(f"{page}: {e}")
            continue
        have = [re.sub(r"\s+", " ", g) for g in m.groups()]
        if have != want:
            out.append(f"{page}: {q.name}: the page says {have}, the data {want}")
    return out


def rewrite(text: str, data: Data, page: str = "README.md") -> str:
    """``text`` (of ``page``) with every quote's groups replaced by its data's values."""
    for q in QUOTES:
        if q.page != page:
            continue
        m = find(q, text)
        want = [str(v) for v in q.values(data)]
        if len(want) != len(m.groups()):
            raise ValueError(f"{q.name}: {len(m.groups())} groups, {len(want)} values")
        for i in reversed(range(len(want))):
            text = text[: m.start(i + 1)] + want[i] + text[m.end(i + 1) :]  # from the end
    return text


def main(argv: Sequence[str] | None = None) -> int:
    """Rewrite the pages' quoted numbers from the data, or only check them."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="only list the differences")
    args = ap.parse_args(argv)
    data = Data()
    status = 0
    for page in pages():
        path = ROOT / page
        text = path.read_text()
        if args.check:
            diff = differences(text, data, page)
            for d in diff:
                print(d)
            status |= 1 if diff else 0
            continue
        new = rewrite(text, data, page)
        if new != text:
            path.write_text(new)
        n = sum(q.page == page for q in QUOTES)
        print(f"{path}: {n} quotes, {'rewritten' if new != text else 'unchanged'}")
    return status


if __name__ == "__main__":
    sys.exit(main())
