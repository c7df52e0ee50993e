"""The README quotes measured results, never stale ones or placeholders (issue 24 item 5).

* Every number it quotes from the scaling benchmark is found where ``docs/readme_numbers.py``
  says, and equals what ``report/data/fe_scaling.csv`` gives (``docs/readme_numbers.py`` writes
  them, this checks them).
* No placeholder (an all-caps name no source file knows, ``TODO``, a template brace) in the
  README, the docs' pages or the report.
* The quoting itself: a changed number is found and written back, a quote whose place is gone
  is reported.
"""

import re
import sys

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.serial  # reads files: the same on any number of ranks


def readme_numbers():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import readme_numbers
    finally:
        sys.path.remove(str(ROOT / "docs"))
    return readme_numbers


def test_every_quoted_number_is_its_data():
    rn = readme_numbers()
    text = (ROOT / "README.md").read_text()
    diff = rn.differences(text, rn.Data())
    assert not diff, ("the README's numbers differ from the measured data (./run exec python3 "
                      "docs/readme_numbers.py writes them):\n" + "\n".join(diff))  # fmt: skip
    assert len(rn.QUOTES) >= 3


PLACEHOLDER = re.compile(
    r"\b(?:[A-Z][A-Z0-9]*_[A-Z0-9_]*[A-Z0-9]|TODO|TBD|FIXME|XXX)\b"  # BJ_TIME, TODO
    r"|\{\{[^{}]*\}\}|\{%"  # a template's {{ name }} or {% tag
)


def known_names():
    """Every all-caps name of the source tree (constants, environment variables)."""
    names = set()
    files = [*ROOT.glob("subfric_dolfinx/**/*.py"), *ROOT.glob("demos/*.py"),
             *ROOT.glob("benchmarks/**/*.py"), *ROOT.glob("report/*.py"),
             *ROOT.glob("tests/**/*.py"), ROOT / "run", *ROOT.glob(".ci/*"),
             *ROOT.glob("docker/*")]  # fmt: skip
    for f in files:
        if f.is_file() and f.name != "test_readme.py":  # this file names a placeholder
            names |= set(re.findall(r"\b[A-Z][A-Z0-9]*_[A-Z0-9_]*[A-Z0-9]\b", f.read_text()))
    return names | {"COMM_WORLD", "PETSC_OPTIONS"}


def test_no_placeholder_reaches_the_pages():
    known = known_names()
    pages = [ROOT / "README.md", ROOT / "report" / "README.md",
             *sorted((ROOT / "docs").glob("*.md"))]  # fmt: skip
    pages = [p for p in pages if p.name != "readme.md"]  # the docs' copy of the README
    found = {}
    for page in pages:
        for i, line in enumerate(page.read_text().splitlines(), 1):
            bad = [m for m in PLACEHOLDER.findall(line) if m not in known]
            if bad:
                found[f"{page.relative_to(ROOT)}:{i}"] = bad
    assert not found, found
    # the check sees one (the placeholder that reached the demo table once)
    assert PLACEHOLDER.findall("| bolted_joint | BJ_TIME |") == ["BJ_TIME"]
    assert "BJ_TIME" not in known


def test_a_changed_number_is_found_and_written_back():
    rn = readme_numbers()
    text = (ROOT / "README.md").read_text()
    data = rn.Data()
    q = rn.QUOTES[0]
    m = rn.find(q, text)
    stale = text[: m.start(2)] + "63" + text[m.end(2) :]
    if m.group(2) == "63":
        stale = text[: m.start(2)] + "64" + text[m.end(2) :]
    assert [d for d in rn.differences(stale, data) if d.startswith(q.name)]
    assert rn.rewrite(stale, data) == text
    # a quote whose sentence was reworded is reported, not skipped
    gone = text.replace("with the reused factor against", "with reuse against")
    assert any("0 places" in d for d in rn.differences(gone, data))
