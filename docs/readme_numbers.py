"""The numbers the README quotes from measured results, each tied to the data it comes from.

    ./run exec python3 docs/readme_numbers.py           # write them into README.md from the data
    ./run exec python3 docs/readme_numbers.py --check   # list the quotes that differ (exit 1)

A :class:`Quote` finds its place in the README with a regular expression whose groups are the
quoted numbers, and computes their text from the data: today the scaling benchmark's,
``report/data/fe_scaling.csv`` (``benchmarks/fe_scaling.py``). Only the groups are rewritten:
the prose around them is the README's own, so other edits of the README merge freely.
``tests/test_readme.py`` fails when a quote is not found or differs from its data, so these
numbers cannot go stale. (The demos' and the report's numbers are to follow the same way, from
``docs/demo_results.json`` and ``report/data/``, once those are regenerated on main's code.)
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


class Data:
    """The measured results, read once (a missing file is an error when a quote needs it)."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root
        self._cache: dict[str, Any] = {}

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
                strategy, ranks, dofs, steps
            ):  # fmt: skip
                return float(r[col])
        raise KeyError(f"fe_scaling.csv has no row {strategy}, {ranks} ranks, {dofs} dofs, "
                       f"{steps} steps")  # fmt: skip


@dataclass(frozen=True)
class Quote:
    """Numbers quoted at one place of the README.

    Attributes:
        name: What is quoted (for messages).
        pattern: A regular expression (multiline) matching the place once; each group is a
            quoted number.
        values: The groups' text, computed from the data.
    """

    name: str
    pattern: str
    values: Callable[[Data], Sequence[str]]


def words(text: str) -> str:
    """A pattern from README text: ``{}`` is a quoted number, any whitespace may be a line break.

    A quoted number is one word (no space, ``,``, ``;``, ``(``, ``)`` or ``|``).
    """
    parts = re.split(r"(\{\})", text)
    out = []
    for p in parts:
        if p == "{}":
            out.append(r"([^\s,;()|]+?)")
        elif p:
            inner = r"\s+".join(re.escape(w) for w in p.split())
            out.append((r"\s+" if p[0].isspace() else "") + inner
                       + (r"\s+" if p[-1].isspace() and inner else ""))  # fmt: skip
    return "".join(out)


# --------------------------------------------------------------------------------------------
# Formats


def sig(x: float, n: int = 2) -> str:
    """``n`` significant digits, fixed notation (0.054, 0.008, 14.27 -> '14')."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    digits = max(n - 1 - math.floor(math.log10(abs(x))), 0)
    return f"{x:.{digits}f}"


def gib(mib: float) -> str:
    """MiB as GiB with one decimal."""
    return f"{mib / 1024:.1f}"


# fmt: off
QUOTES: list[Quote] = [
    *(Quote(f"scale ({where})", pattern, values) for where, pattern, values in [
        ("report headlines", words(
            "37k dofs {} s with the reused factor against {} s with LU at every iteration; 225k "
            "dofs {}–{} s; 184k dofs over 100 steps {} s (GAMG); 1M dofs over 10 steps {} s at {} "
            "GiB per rank (GAMG)"),
         lambda d: [sig(d.scale("reuse", 2, 37206, 24, "wall_s"), 3),
                    sig(d.scale("lu", 2, 37206, 24, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 224736, 24, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 224736, 24, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 184050, 100, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 998556, 10, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 998556, 10, "rss_max_mib"))]),
        ("linear strategies", words(
            "(3-D pad, 24 steps, 2 ranks: {} s at 37k dofs where LU takes {} s; {} s at 70k), and "
            "robust with stiff interfaces, but its factor grows faster than the model ({} GiB per "
            "rank at 225k dofs"),
         lambda d: [sig(d.scale("reuse", 2, 37206, 24, "wall_s"), 3),
                    sig(d.scale("lu", 2, 37206, 24, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 70026, 24, "wall_s"), 3),
                    gib(d.scale("reuse", 2, 224736, 24, "rss_max_mib"))]),
        ("gamg against reuse", words(
            "(225k dofs: {} s against {} s, {} GiB per rank against {}; 184k dofs, 100 steps: {} s "
            "against {} s) and it is the only one that reaches 1M dofs on this 24 GB machine (10 "
            "steps in {} s, {} GiB per rank)"),
         lambda d: [sig(d.scale("gamg", 2, 224736, 24, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 224736, 24, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 224736, 24, "rss_max_mib")),
                    gib(d.scale("reuse", 2, 224736, 24, "rss_max_mib")),
                    sig(d.scale("gamg", 2, 184050, 100, "wall_s"), 3),
                    sig(d.scale("reuse", 2, 184050, 100, "wall_s"), 3),
                    sig(d.scale("gamg", 2, 998556, 10, "wall_s"), 3),
                    gib(d.scale("gamg", 2, 998556, 10, "rss_max_mib"))]),
    ]),
]
# fmt: on


# --------------------------------------------------------------------------------------------
# Reading and writing


def find(q: Quote, text: str) -> re.Match:
    """The one place of the README a quote is at.

    Raises:
        LookupError: Not found, or found more than once.
    """
    found = list(re.finditer(q.pattern, text, re.M))
    if len(found) != 1:
        raise LookupError(f"{q.name}: the README has {len(found)} places matching its pattern "
                          f"(need 1): {q.pattern[:120]}")  # fmt: skip
    return found[0]


def differences(text: str, data: Data) -> list[str]:
    """Every quote of ``text`` that is not found or differs from its data (empty: all agree)."""
    out = []
    for q in QUOTES:
        try:
            m = find(q, text)
            want = [str(v) for v in q.values(data)]
        except (LookupError, KeyError, FileNotFoundError) as e:
            out.append(str(e))
            continue
        have = [re.sub(r"\s+", " ", g) for g in m.groups()]
        if have != want:
            out.append(f"{q.name}: the README says {have}, the data {want}")
    return out


def rewrite(text: str, data: Data) -> str:
    """``text`` with every quote's groups replaced by its data's values."""
    for q in QUOTES:
        m = find(q, text)
        want = [str(v) for v in q.values(data)]
        if len(want) != len(m.groups()):
            raise ValueError(f"{q.name}: {len(m.groups())} groups, {len(want)} values")
        for i in reversed(range(len(want))):
            text = text[: m.start(i + 1)] + want[i] + text[m.end(i + 1) :]  # from the end
    return text


def main(argv: Sequence[str] | None = None) -> int:
    """Rewrite the README's quoted numbers from the data, or only check them."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="only list the differences")
    args = ap.parse_args(argv)
    text = README.read_text()
    data = Data()
    if args.check:
        diff = differences(text, data)
        for d in diff:
            print(d)
        return 1 if diff else 0
    new = rewrite(text, data)
    if new != text:
        README.write_text(new)
    print(f"{README}: {len(QUOTES)} quotes, {'rewritten' if new != text else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
