"""The README quotes measured results, never stale ones or placeholders (issue 24 item 5).

* Every number it quotes from the demos, the report or the scaling benchmark is found where
  ``docs/readme_numbers.py`` says, and equals what the data gives (``docs/demo_results.json``,
  ``report/data/``); ``docs/readme_numbers.py`` writes them, this checks them.
* The demo results measure the code: their stamp (``report/stamp.py``) names the trees of
  ``constitutive/``, ``fem/`` and ``demos/`` of main (or of this branch, when it regenerated
  them), every demo has a run, every run ended without an error on the ranks the README says.
* No placeholder (an all-caps name no source file knows, ``TODO``, a template brace) in the
  README, the docs' pages or the report.
* The quoting itself: a changed number is found and written back, a quote whose place is gone
  is reported.
"""

import json
import re
from pathlib import Path

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.serial  # reads files and git: the same on any number of ranks


def modules():
    from docs import readme_numbers
    from report import stamp

    return readme_numbers, stamp


def test_every_quoted_number_is_its_data():
    rn, _ = modules()
    text = (ROOT / "README.md").read_text()
    diff = rn.differences(text, rn.Data())
    assert not diff, (
        "the README's numbers differ from the measured data (./run exec python3 "
        "docs/readme_numbers.py writes them):\n" + "\n".join(diff)
    )
    # every demo of the repository has its time in the table
    demos = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
    assert sorted(rn.DEMOS) == demos
    assert {q.name.split(":")[0] for q in rn.QUOTES if "wall time" in q.name} == set(demos)


def test_the_demo_results_measure_the_code_on_main():
    _, stamp = modules()
    data = json.loads((ROOT / "docs" / "demo_results.json").read_text())
    demos = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
    for d in demos:
        assert d in data["demos"], f"{d} has no run in docs/demo_results.json"
    for key, run in data["demos"].items():
        assert run["wall_s"] > 0, key
        if run["ranks"] > 1:
            assert run["command"][:3] == ["mpirun", "-n", str(run["ranks"])], key
    try:
        why = stamp.check(data["stamp"], "docs/demo_results.json")
    except stamp.NoHistory as e:
        pytest.skip(f"no git history to compare the demo results' stamp with: {e}")
    assert not why, (
        "docs/demo_results.json is outdated: "
        + "; ".join(why)
        + ". Run ./run exec python3 docs/demo_results.py, then "
        "docs/readme_numbers.py."
    )


# an all-caps name, a to-do word, a template's {{ expression }} or {% tag (not the "}}" that
# closes a nested dict in the README's code)
PLACEHOLDER = re.compile(
    r"\b(?:[A-Z][A-Z0-9]*_[A-Z0-9_]*[A-Z0-9]|TODO|TBD|FIXME|XXX)\b|\{\{[^{}\n]*\}\}|\{%"
)


def known_names():
    """Every all-caps name of the source tree (constants, environment variables)."""
    names = set()
    files = [
        *ROOT.glob("subfric_dolfinx/**/*.py"),
        *ROOT.glob("demos/*.py"),
        *ROOT.glob("benchmarks/**/*.py"),
        *ROOT.glob("report/*.py"),
        *ROOT.glob("tests/**/*.py"),
        ROOT / "run",
        *ROOT.glob(".ci/*"),
        *ROOT.glob("docker/*"),
    ]
    for f in files:
        if f.is_file() and f != Path(__file__).resolve():  # this file names placeholders
            names |= set(re.findall(r"\b[A-Z][A-Z0-9]*_[A-Z0-9_]*[A-Z0-9]\b", f.read_text()))
    return names | {"COMM_WORLD", "PETSC_OPTIONS", "OMPI_ALLOW_RUN_AS_ROOT"}


def test_no_placeholder_reaches_the_pages():
    known = known_names()
    pages = [
        ROOT / "README.md",
        ROOT / "report" / "README.md",
        *sorted((ROOT / "docs").glob("*.md")),
    ]
    pages = [p for p in pages if p.name != "readme.md"]  # the docs' copy of the README
    found = {}
    for page in pages:
        for i, line in enumerate(page.read_text().splitlines(), 1):
            bad = [m for m in PLACEHOLDER.findall(line) if m not in known]
            if bad:
                found[f"{page.relative_to(ROOT)}:{i}"] = bad
    assert not found, found
    # the check sees one
    assert PLACEHOLDER.findall("| two_bodies_api | BJ_TIME |") == ["BJ_TIME"]
    assert PLACEHOLDER.findall("took {{ bj_time }} s") == ["{{ bj_time }}"]
    assert PLACEHOLDER.findall("{% if x %}") == ["{%"]
    assert PLACEHOLDER.findall('{"mesh": {"options": {"n": 16}}}') == []
    assert "BJ_TIME" not in known


def test_a_changed_number_is_found_and_written_back():
    rn, _ = modules()
    text = (ROOT / "README.md").read_text()
    data = rn.Data()
    q = next(q for q in rn.QUOTES if q.name == "lap_joint: slip per cycle")
    m = rn.find(q, text)
    stale = text[: m.start(1)] + "8.97" + text[m.end(1) :]
    if m.group(1) == "8.97":
        stale = text[: m.start(1)] + "9.99" + text[m.end(1) :]
    assert any(d.startswith("lap_joint") for d in rn.differences(stale, data))
    assert rn.rewrite(stale, data) == text
    # a quote whose sentence was reworded is reported, not skipped
    gone = text.replace("slip accumulates cycle by cycle", "slip grows")
    assert any("0 places" in d for d in rn.differences(gone, data))
