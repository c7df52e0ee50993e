"""Regenerate the report (``report/README.md`` and its PNGs) from scratch.

    ./run report            # = python3 report/generate.py inside the environment
    ./run report --quick    # a small version of every study (development only, ~2 min)
    ./run report --reuse    # only redo figures, tables and README from report/data (development)

Three stages: :mod:`running` runs the studies one at a time and writes the raw results to
``report/data/*.json``; :mod:`analysis` and :mod:`fe_analysis` turn them into orders, errors,
tables and numbers, :mod:`figures` into the PNGs; the prose is the Jinja2 template
``templates/README.md.j2``, rendered with those numbers (its sentences choose their words from
the numbers: nothing in it can be contradicted by a rerun). Old outputs (``README.md``, ``*.png``
but the scaling benchmark's, and ``data/`` but the scaling benchmarks' data unless ``--reuse``) are
deleted first.

Stamp (``report/stamp.py``): the commit, date and machine load of the run, in
``data/stamp.json``, printed on every figure and in the README (a label, not a check:
``tests/demos/test_records.py`` re-checks the report's cheap accuracy figures on the current code).
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
if not __package__:  # run as a script, not imported as report.generate: the repository's packages
    sys.path.insert(0, str(ROOT))

from report import analysis, figures, mp_study, running  # noqa: E402
from report import stamp as stamps  # noqa: E402
from report.fe_analysis import fe_analysis  # noqa: E402
from report.running import say  # noqa: E402

SCALING = "fe_scaling"  # benchmarks/fe_scaling.py's table and figure (hours to rerun: kept)
KEPT = (SCALING, "weak_scaling")  # data of the benchmarks this script does not run
SOLVER_CODE = ("subfric_dolfinx/constitutive", "subfric_dolfinx/fem", "subfric_dolfinx/compat.py")
"""The code whose change since the scaling benchmark's commit the report mentions."""


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


def scaling_stamp() -> dict[str, Any] | None:
    """The commit that committed the scaling benchmark's data (it is not rerun here)."""
    try:
        commit = stamps.git("log", "-1", "--format=%H", "--", f"report/data/{SCALING}.csv")
        date = stamps.git("log", "-1", "--format=%cs", "--", f"report/data/{SCALING}.csv")
    except stamps.NoHistory:
        return None
    return {"commit": commit, "date": date, "dirty": []} if commit else None


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
    try:
        stamps.require_record_stack()
    except stamps.WrongStack as e:
        print(f"report: {e}", file=sys.stderr)
        return 2
    data = HERE / "data"
    old = [p for p in HERE.glob("*.png") if not p.name.startswith(SCALING)]
    for f in [HERE / "README.md", *old]:
        f.unlink(missing_ok=True)
    if args.reuse:
        stamp = json.loads((data / "stamp.json").read_text())
    else:
        kept = {p.name: p.read_bytes() for k in KEPT for p in data.glob(f"{k}*")}
        shutil.rmtree(data, ignore_errors=True)
        data.mkdir()
        for name, content in kept.items():
            (data / name).write_bytes(content)
        stamp = stamps.make()
        (data / "stamp.json").write_text(json.dumps(stamp, indent=1) + "\n")
    figures.STAMP.update(stamp)
    cfg = running.fe_config(args.quick)
    say("material-point convergence study")
    mp = running.material_point(data, args.quick, args.reuse)
    figures.mp_figures(mp)
    mp_study.figure(mp, HERE / "mp_old_new_error_vs_time.png", save=figures.stamped)
    (data / "mp_section.md").write_text(mp_study.section(mp))
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
        mp,
        mp_lines,
        stab_tab,
        stab_sum,
        fe,
        fe_lines,
        cfg,
        quick=args.quick,
        elapsed=elapsed,
        reuse=args.reuse,
    )
    section = data / "mp_section.md"  # written by report/mp_study.py (previous and current map)
    context["mp_section"] = section.read_text() if section.exists() else ""
    context["scale_section"] = scale_section(HERE / "fe_scaling.md")
    context["stamp"] = stamp
    context["stamp_label"] = stamps.label(stamp)
    scaling = scaling_stamp()
    context["scaling_commit"] = scaling["commit"][:10] if scaling else None
    context["scaling_changed"] = bool(scaling) and bool(
        stamps.git("diff", "--name-only", scaling["commit"], stamp["commit"], "--", *SOLVER_CODE)
    )
    if scaling and (HERE / f"{SCALING}.png").exists():
        figures.stamp_existing(HERE / f"{SCALING}.png", scaling, "benchmarks/fe_scaling.py,")
    (HERE / "README.md").write_text(render(context))
    say(f"wrote {HERE / 'README.md'} and {len(list(HERE.glob('*.png')))} PNGs in {elapsed:.0f} s")
    if any(stab_sum[k][0] < stab_sum[k][1] for k in ("point", "fe1", "fe2")):
        say("WARNING: some stability cases did not end as they must (see the table)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
