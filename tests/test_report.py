"""The report's README is a template rendered with numbers computed from ``report/data/`` alone
(``./run report --reuse`` does this and redraws the figures): every placeholder is filled, and
the numbers it quotes are those of the analysis."""

import sys

import pytest

from tests.helpers import ROOT

REPORT = ROOT / "report"


@pytest.mark.serial
def test_the_report_template_renders_from_report_data():
    sys.path.insert(0, str(REPORT))
    try:
        import analysis
        import generate
        import running
        from fe_analysis import fe_analysis
    finally:
        sys.path.remove(str(REPORT))
    data = REPORT / "data"
    cfg = running.fe_config(False)  # the full study, as report/data was made
    mp = running.material_point(data, quick=False, reuse=True)
    point, fe_stab = running.stability(data, reuse=True)
    stab_tab, stab_sum = analysis.stability_table(point, fe_stab)
    fe, fe_lines, _ = fe_analysis(running.fe_study(data, cfg, reuse=True), cfg)
    ctx = analysis.readme_context(
        mp, analysis.mp_tables(mp), stab_tab, stab_sum, fe, fe_lines, cfg,
        quick=False, elapsed=123.0, reuse=True,
    )  # fmt: skip
    ctx["scale_section"] = generate.scale_section(REPORT / "fe_scaling.md")
    text = generate.render(ctx)
    assert "{{" not in text and "{%" not in text
    assert "in\n**123 s**" in text and "REUSE MODE" in text and "QUICK MODE" not in text
    # numbers quoted in the prose are the analysis' (orders, the 1-vs-2-rank difference)
    assert f"observed order in time **{fe['p_time']:.2f}**" in text
    assert f"**{analysis.fmt(fe['max_diff12'], 1)}**" in text
    rev = mp["paths"]["reversal"]
    assert f"observed order **{rev['order_subloading']:.2f}**" in text
    # every table made it in, and every section
    for block in [stab_tab, *fe_lines, *analysis.mp_tables(mp)]:
        assert block in text
    for h in ("## Headline numbers", "## 1. Material point", "## 2. FE", "## 3. Stability"):
        assert h in text
    # the scaling benchmark's tables, one heading level down (benchmarks/fe_scaling.py --table)
    assert "## Scale: the linear strategies" in text and "### 24-step program" in text
    assert "\n# FE scaling" not in text
