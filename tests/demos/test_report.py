"""The report (``report/README.md``) is the code on main, measured (issue 24 item 6).

* The template renders from ``report/data/`` alone (``./run report --reuse`` does this): every
  placeholder is filled, the numbers it quotes are the analysis', and its comparison words follow
  the numbers.
* Every figure carries the stamp of the commit that produced it (PNG text and a visible label).
* The stamp still describes the code: ``constitutive/`` and ``fem/`` on main (or on this branch,
  when it regenerated the report) are the trees the report measured (``report/stamp.py``). An
  outdated report fails here: run ``./run report``.
* :func:`stamp.check` itself, on a scratch repository: a branch that leaves the report alone is
  judged against main, a branch that regenerated it against its own HEAD; merges and rebases
  that keep the measured code keep the stamp valid.
"""

import json
import subprocess

import pytest

from tests.helpers import ROOT

REPORT = ROOT / "report"
pytestmark = pytest.mark.serial  # reads files and git: the same on any number of ranks


def report_modules():
    """The report's modules, imported when a test needs them (matplotlib and the study's code)."""
    from report import analysis, generate, running, stamp
    from report.fe_analysis import fe_analysis

    return analysis, generate, running, stamp, fe_analysis


def test_the_report_template_renders_from_report_data():
    analysis, generate, running, stamp, fe_analysis = report_modules()
    data = REPORT / "data"
    cfg = running.fe_config(False)  # the full study, as report/data was made
    mp = running.material_point(data, quick=False, reuse=True)
    point, fe_stab = running.stability(data, reuse=True)
    stab_tab, stab_sum = analysis.stability_table(point, fe_stab)
    fe, fe_lines, _ = fe_analysis(running.fe_study(data, cfg, reuse=True), cfg)
    ctx = analysis.readme_context(
        mp,
        analysis.mp_tables(mp),
        stab_tab,
        stab_sum,
        fe,
        fe_lines,
        cfg,
        quick=False,
        elapsed=123.0,
        reuse=True,
    )
    st = json.loads((data / "stamp.json").read_text())
    ctx.update(
        scale_section=generate.scale_section(REPORT / "fe_scaling.md"),
        stamp=st,
        stamp_label=stamp.label(st),
        scaling_commit="abc",
        scaling_changed=True,
        mp_section=(data / "mp_section.md").read_text(),
    )
    text = generate.render(ctx)
    assert "{{" not in text and "{%" not in text
    assert "in\n**123 s**" in text and "QUICK MODE" not in text
    assert "Rebuilt from `report/data/` (`--reuse`)" in text
    assert st["commit"][:10] in text
    # the numbers quoted are the analysis'; the words follow them
    for key, f in fe.items():
        case, law = key.split("/")
        assert f"**FE, {case}, {law}**: observed order **{f['p_time']:.2f}** in time" in text
        pays = "are faster\n  at" in text or "are faster at" in text
        assert pays or "are never faster" in text
    assert {k.split("/")[0] for k in fe} == {"block", "pad"}
    assert {k.split("/")[1] for k in fe} == {"subloading", "coulomb"}
    for block in [stab_tab, *fe_lines, *analysis.mp_tables(mp)]:
        assert block in text
    assert "## Scale: the linear strategies" in text and "changed since" in text


def test_every_figure_carries_its_commit():
    from PIL import Image

    st = json.loads((REPORT / "data" / "stamp.json").read_text())
    pngs = sorted(REPORT.glob("*.png"))
    assert len(pngs) >= 6, pngs
    for png in pngs:
        with Image.open(png) as im:
            commit = im.text.get("subfric-dolfinx-commit", "")
        if png.name.startswith("fe_scaling"):  # the benchmark's, of its own commit
            assert len(commit) == 40, png
            continue
        assert commit == st["commit"], (png.name, commit)


def test_the_report_measures_the_code_on_main():
    *_, stamp, _ = report_modules()
    st = json.loads((REPORT / "data" / "stamp.json").read_text())
    try:
        why = stamp.check(st, "report/data/stamp.json")
    except stamp.NoHistory as e:
        pytest.skip(f"no git history to compare the report's stamp with: {e}")
    assert not why, "report/README.md is outdated: " + "; ".join(why) + ". Run ./run report."


def git(repo, *args):
    return subprocess.run(
        ["git", "-C", str(repo), *args], check=True, capture_output=True, text=True
    ).stdout.strip()


def test_stamp_check_judges_a_branch_against_main_unless_it_regenerated(tmp_path, monkeypatch):
    *_, stamp, _ = report_modules()
    monkeypatch.delenv("SUBFRIC_STAMP_BASE", raising=False)
    repo = tmp_path / "repo"
    repo.mkdir()
    git(repo, "init", "-q", "-b", "main")
    git(repo, "config", "user.email", "t@t")
    git(repo, "config", "user.name", "t")
    (repo / "fem").mkdir()
    (repo / "fem" / "a.py").write_text("x = 1\n")
    (repo / "README").write_text("r\n")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "code")
    st = stamp.make(["fem"], root=repo)
    (repo / "stamp.json").write_text(json.dumps(st))
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "report")
    assert stamp.check(st, "stamp.json", root=repo) == []
    # a helper's branch changes fem/ without regenerating: judged against main, fine
    git(repo, "checkout", "-q", "-b", "helper")
    (repo / "fem" / "a.py").write_text("x = 2\n")
    git(repo, "commit", "-qam", "helper's change")
    assert stamp.check(st, "stamp.json", root=repo) == []
    # another file changed on main (not measured): still fine
    git(repo, "checkout", "-q", "main")
    (repo / "README").write_text("r2\n")
    git(repo, "commit", "-qam", "docs")
    assert stamp.check(st, "stamp.json", root=repo) == []
    # the helper's change merged into main: main's report is outdated, named
    git(repo, "merge", "-q", "--no-edit", "helper")
    why = stamp.check(st, "stamp.json", root=repo)
    assert len(why) == 1 and "fem at main" in why[0] and "helper's change" in why[0], why
    # a branch that regenerates the report is judged against its own HEAD
    git(repo, "checkout", "-q", "-b", "owner")
    new = stamp.make(["fem"], root=repo)
    (repo / "stamp.json").write_text(json.dumps(new))
    git(repo, "commit", "-qam", "report again")
    assert stamp.check(new, "stamp.json", root=repo) == []
    (repo / "fem" / "a.py").write_text("x = 3\n")
    git(repo, "commit", "-qam", "later change on the owner's branch")
    assert stamp.check(new, "stamp.json", root=repo)  # HEAD moved on: stale
    # uncommitted changes at generation time are said
    (repo / "fem" / "a.py").write_text("x = 4\n")
    dirty = stamp.make(["fem"], root=repo)
    assert dirty["dirty"] == ["fem/a.py"]
    assert any("uncommitted" in w for w in stamp.check(dirty, "stamp.json", root=repo))
