"""The README and the docs quote their records, never stale numbers or placeholders.

* Every number they quote from the demos, the report or the scaling benchmark is found where
  ``docs/readme_numbers.py`` says, and equals what its record gives (``docs/demo_results.json``,
  ``report/data/``); ``docs/readme_numbers.py`` writes them, this checks them. (Whether the
  records still describe the code is ``test_records.py``'s question.)
* No placeholder (an all-caps name no source file knows, ``TODO``, a template brace) in the
  README, the docs' pages or the report.
* The quoting itself: a changed number is found and written back, a quote whose place is gone
  is reported.
* Every image the README and the docs' pages show is a record: a figure of a demo's recorded run
  (``docs/figures/<demo>/``, written by ``docs/demo_results.py``), never a copy that no script
  rewrites (a stale figure beside current numbers).
* The README is a quick start: at most :data:`README_LINES` lines, its Python example runs as
  written (on the suite's ranks, as ``mpirun -n 2 python3 example.py`` runs it), its install
  line works offline (``tests/test_packaging.py`` runs the same), and it links every page of
  ``docs/reference/``.
"""

import re
from pathlib import Path

import pytest

from tests.helpers import ROOT

SERIAL = pytest.mark.serial  # reads files and git: the same on any number of ranks


def modules():
    from docs import readme_numbers
    from report import stamp

    return readme_numbers, stamp


@SERIAL
def test_every_quoted_number_is_its_record():
    rn, _ = modules()
    data = rn.Data()
    diff = []
    for page in rn.pages():
        diff += rn.differences((ROOT / page).read_text(), data, page)
    assert not diff, (
        "the pages' numbers differ from their records (./run exec python3 "
        "docs/readme_numbers.py writes them):\n" + "\n".join(diff)
    )
    # every demo of the repository has its time in the table
    demos = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
    assert sorted(rn.DEMOS) == demos
    assert {q.name.split(":")[0] for q in rn.QUOTES if "wall time" in q.name} == set(demos)


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


@SERIAL
def test_no_placeholder_reaches_the_pages():
    known = known_names()
    pages = [
        ROOT / "README.md",
        ROOT / "report" / "README.md",
        *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "docs" / "reference").glob("*.md")),
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


@SERIAL
def test_a_changed_number_is_found_and_written_back():
    rn, _ = modules()
    q = next(q for q in rn.QUOTES if q.name == "lap_joint: slip per cycle")
    text = (ROOT / q.page).read_text()
    data = rn.Data()
    m = rn.find(q, text)
    stale = text[: m.start(1)] + "8.97" + text[m.end(1) :]
    if m.group(1) == "8.97":
        stale = text[: m.start(1)] + "9.99" + text[m.end(1) :]
    assert any("lap_joint" in d for d in rn.differences(stale, data, q.page))
    assert rn.rewrite(stale, data, q.page) == text
    # a quote whose sentence was reworded is reported, not skipped
    gone = text.replace("slip accumulates cycle by cycle", "slip grows")
    assert any("0 places" in d for d in rn.differences(gone, data, q.page))


@SERIAL
def test_every_image_shown_is_a_recorded_figure():
    figures = (ROOT / "docs" / "figures").resolve()
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    pages = [p for p in pages if "_build" not in p.parts and p.name != "readme.md"]
    shown = 0
    for page in pages:
        for target in re.findall(
            r"!\[[^\]]*\]\(([^)\s]+)\)|<img src=\"([^\"]+)\"", page.read_text()
        ):
            target = next(t for t in target if t)
            if re.match(r"^[a-z]+:", target):
                continue
            path = (page.parent / target).resolve()
            assert path.is_relative_to(figures) and path.is_file(), (page.name, target)
            shown += 1
    assert shown >= 4
    # no picture in docs/ outside the records (the site's build output aside)
    stray = [
        p.relative_to(ROOT)
        for p in (ROOT / "docs").rglob("*.png")
        if not p.resolve().is_relative_to(figures) and "_build" not in p.parts
    ]
    assert not stray, stray


README_LINES = 300
"""The README's length at most: a quick start, the reference is the docs' (``docs/reference/``)."""


def readme_blocks(language):
    """The README's fenced code blocks in ``language``."""
    text = (ROOT / "README.md").read_text()
    return re.findall(rf"^```{language}\n(.*?)^```$", text, re.M | re.S)


@SERIAL
def test_the_readme_is_a_quick_start_that_links_the_reference():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= README_LINES, len(text.splitlines())
    first_python = text.index("```python")
    assert text[:first_python].count("\n") < 80  # the example near the top
    for page in sorted((ROOT / "docs" / "reference").glob("*.md")):
        assert f"(docs/reference/{page.name})" in text, page.name
    (install,) = [ln for b in readme_blocks("bash") for ln in b.splitlines() if "pip install" in ln]
    assert "--no-build-isolation" in install  # offline: the environment's setuptools
    assert "these hosts" not in text
    # the one call that turns on a line per step for library use, named where users look first
    from subfric_dolfinx import logs

    assert "logs.show_progress(MPI.COMM_WORLD)" in text and callable(logs.show_progress)
    assert "python3 -m subfric_dolfinx.scenes" in text  # the scene command without installing


@pytest.mark.timeout(300)
def test_the_readme_example_runs_as_written(shared_tmp, monkeypatch, capsys):
    """Every Python block of the README, run as a script is (``__name__`` ``"__main__"``), in an
    empty folder: the example writes its history there and prints its line on rank 0."""
    from mpi4py import MPI

    (code,) = readme_blocks("python")
    monkeypatch.chdir(shared_tmp)
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out
    comm = MPI.COMM_WORLD
    comm.Barrier()
    rows = (shared_tmp / "output" / "block" / "history.csv").read_text().splitlines()
    if comm.rank == 0:
        assert re.fullmatch(r"\d+ steps; peak mean friction stress [\d.]+ MPa\n", out), out
        assert out.startswith(f"{len(rows) - 1} steps"), (out, len(rows))
