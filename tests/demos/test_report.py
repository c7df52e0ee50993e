"""The report (``report/README.md``) is the code on main, measured (issue 24 item 6).

* The template renders from ``report/data/`` alone (``./run report --reuse`` does this): every
  placeholder is filled, the numbers it quotes are the analysis', and its comparison words follow
  the numbers.
* Every figure carries the stamp of the commit that produced it (PNG text and a visible label).
* The report and the demos' records are records of a commit of this history, made from committed
  code (``report/stamp.py``; a label, not a check of the code: whether they still describe it is
  checked on results, ``tests/demos/test_records.py``).
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


@pytest.mark.parametrize("record", ["report/data/stamp.json", "docs/demo_results.json"])
def test_the_records_are_of_a_commit_of_this_history(record):
    *_, stamp, _ = report_modules()
    data = json.loads((ROOT / record).read_text())
    stamps = [data.get("stamp", data)]
    stamps += [run["stamp"] for run in data.get("demos", {}).values()]
    for st in stamps:
        assert set(st) >= {"commit", "date", "load", "dirty"}, st
        try:
            why = stamp.on_history(st)
        except stamp.NoHistory as e:
            pytest.skip(f"no git history to look for the record's commit in: {e}")
        assert why is None, f"{record}: {why}. Run ./run refresh on a commit of main."


def test_a_stamp_names_its_commit_date_and_load(tmp_path):
    *_, stamp, _ = report_modules()
    repo = tmp_path / "repo"
    repo.mkdir()
    git(repo, "init", "-q", "-b", "main")
    git(repo, "config", "user.email", "t@t")
    git(repo, "config", "user.name", "t")
    (repo / "subfric_dolfinx").mkdir()
    (repo / "subfric_dolfinx" / "a.py").write_text("x = 1\n")
    git(repo, "add", ".")
    git(repo, "commit", "-q", "-m", "code")
    st = stamp.make(root=repo)
    assert st["commit"] == git(repo, "rev-parse", "HEAD") and st["dirty"] == []
    assert len(st["load"]) == 2 and st["cores"] >= 1
    assert stamp.on_history(st, root=repo) is None
    label = stamp.label(st)
    assert st["commit"][:10] in label and "load" in label and "uncommitted" not in label
    # uncommitted changes are said, and such a stamp is no record of the history
    (repo / "subfric_dolfinx" / "a.py").write_text("x = 2\n")
    dirty = stamp.make(root=repo)
    assert dirty["dirty"] == ["subfric_dolfinx/a.py"]
    assert "uncommitted" in stamp.label(dirty) and "uncommitted" in stamp.on_history(dirty, repo)
    # a commit of another branch is not of this history
    git(repo, "checkout", "-q", "-b", "other")
    git(repo, "commit", "-qam", "elsewhere")
    other = stamp.make(root=repo)
    git(repo, "checkout", "-q", "main")
    assert "not an ancestor" in stamp.on_history(other, root=repo)
    assert "not in this repository" in stamp.on_history({**other, "commit": "f" * 40}, repo)


def git(repo, *args):
    return subprocess.run(
        ["git", "-C", str(repo), *args], check=True, capture_output=True, text=True
    ).stdout.strip()
