"""Regenerate the report (``report/README.md`` and its PNGs) from scratch.

    ./run report            # = python3 report/generate.py inside the environment
    ./run report --quick    # a small version of every study (development only, ~2 min)
    ./run report --reuse    # only redo figures, tables and README from report/data (development)

Three stages: :mod:`running` runs the studies one at a time and writes the raw results to
``report/data/*.json``; :mod:`analysis` and :mod:`fe_analysis` turn them into orders, errors,
tables and numbers, :mod:`figures` into the PNGs; the prose is the Jinja2 template
``templates/README.md.j2``, rendered with those numbers. Old outputs (``README.md``, ``*.png``,
and ``data/`` unless ``--reuse``) are deleted first.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

import analysis  # noqa: E402
import figures  # noqa: E402
import running  # noqa: E402
from fe_analysis import fe_analysis  # noqa: E402
from running import say  # noqa: E402


def scale_section(path: Path) -> str:
    """The tables of ``benchmarks/fe_scaling.py --table``, or "" before it has run.

    Its title is dropped and its headings go one level down.
    """
    if not path.exists():
        return ""
    lines = path.read_text().splitlines()
    if lines and lines[0].startswith("# "):
        lines = lines[1:]
    return "\n".join("#" + ln if ln.startswith("## ") else ln for ln in lines).strip()


def render(context: dict[str, Any]) -> str:
    """The README text: the template with the analysis' numbers."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(HERE / "templates"),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,  # Markdown, not HTML
    )
    env.filters["sci"] = analysis.fmt
    env.filters["fixed"] = lambda x, digits=2: (
        f"{x:.{digits}f}" if x is not None and math.isfinite(x) else "-"
    )
    env.filters["g"] = lambda x: f"{x:g}"
    return env.get_template("README.md.j2").render(**context)


def main() -> int:
    """Run (or reuse), analyse, draw, write."""
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    ap.add_argument("--quick", action="store_true", help="reduced studies (development only)")
    ap.add_argument(
        "--reuse",
        action="store_true",
        help="do not rerun anything: rebuild figures, tables and README from report/data "
        "(development only; the README then states it)",
    )
    args = ap.parse_args()
    data = HERE / "data"
    kept = "mp_old_new"  # report/mp_study.py's figure, not regenerated here
    for f in [HERE / "README.md", *(p for p in HERE.glob("*.png") if not p.name.startswith(kept))]:
        f.unlink(missing_ok=True)
    if not args.reuse:
        shutil.rmtree(data, ignore_errors=True)
        data.mkdir()
    cfg = running.fe_config(args.quick)
    say("material-point convergence study")
    mp = running.material_point(data, args.quick, args.reuse)
    figures.mp_figures(mp)
    mp_lines = analysis.mp_tables(mp)
    say("stability cases")
    point, fe_stab = running.stability(data, args.reuse)
    stab_tab, stab_sum = analysis.stability_table(point, fe_stab)
    say("FE convergence and timing study")
    raw = running.fe_study(data, cfg, args.reuse)
    fe, fe_lines, curves = fe_analysis(raw, cfg)
    figures.fe_figures(fe, curves, cfg)
    (data / "fe_summary.json").write_text(json.dumps(fe, indent=1, default=float))
    elapsed = time.perf_counter() - running.T_START
    context = analysis.readme_context(
        mp, mp_lines, stab_tab, stab_sum, fe, fe_lines, cfg,
        quick=args.quick, elapsed=elapsed, reuse=args.reuse,
    )  # fmt: skip
    section = data / "mp_section.md"  # written by report/mp_study.py (previous and current map)
    context["mp_section"] = section.read_text() if section.exists() else ""
    context["scale_section"] = scale_section(HERE / "fe_scaling.md")
    (HERE / "README.md").write_text(render(context))
    say(f"wrote {HERE / 'README.md'} and {len(list(HERE.glob('*.png')))} PNGs in {elapsed:.0f} s")
    if any(stab_sum[k][0] < stab_sum[k][1] for k in ("point", "fe1", "fe2")):
        say("WARNING: some stability cases did not end as they must (see the table)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
