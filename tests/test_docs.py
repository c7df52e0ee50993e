"""The documentation site builds with Sphinx, warnings as errors, and its index links every demo
and every API page (``./run docs`` runs the same build into ``docs/_build/html``)."""

import re
import subprocess
import sys

import pytest

from tests.helpers import ROOT, singleton_env


@pytest.mark.serial
def test_the_docs_build_without_warnings_and_the_index_links_every_page(tmp_path):
    out = tmp_path / "html"
    p = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", out],
        cwd=ROOT,
        env=singleton_env(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert p.returncode == 0, p.stdout + p.stderr
    index = (out / "index.html").read_text()
    links = set(re.findall(r'href="([^"#]+)"', index))
    demos = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
    for d in demos:
        assert f"demos/{d}.html" in links, d
        page = (out / "demos" / f"{d}.html").read_text()
        assert "highlight-ipython3" in page or "highlight-python" in page, d  # code cells
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        from conf import public_modules  # the list the build wrote its API pages from
    finally:
        sys.path.remove(str(ROOT / "docs"))
    modules = public_modules()
    assert "subfric_dolfinx.io.points" in modules and "subfric_dolfinx.fem.stepping" in modules
    for m in modules:
        assert f"api/{m}.html" in links, m
    assert {"readme.html", "model.html"} <= links
    # the API pages hold the docstrings (a class and a function of two modules)
    stepper = (out / "api" / "subfric_dolfinx.fem.stepping.html").read_text()
    assert 'id="subfric_dolfinx.fem.stepping.LoadStepper"' in stepper
    points = (out / "api" / "subfric_dolfinx.io.points.html").read_text()
    assert 'id="subfric_dolfinx.io.points.InterfacePointsXDMF.write"' in points
    # the README's figures are on its page
    readme = (out / "readme.html").read_text()
    assert readme.count("<img") >= 4 and len(list((out / "_images").glob("*.png"))) >= 4
