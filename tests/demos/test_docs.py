"""The documentation site builds with Sphinx, warnings as errors (``./run docs`` runs the same
build into ``docs/_build/html``), and the built pages are read back (HTML parsed):

* every equation is a math element MathJax renders (no raw ``\\(``, ``\\[``, ``$$`` or
  ``$...$`` left in the text), and MathJax is the site's own copy (offline), configured to
  process Sphinx's math elements; ``model.html`` has its equations;
* every image a page shows exists in the site; every demo page shows its figures
  (``docs/figures/<demo>/``);
* no duplicates: each demo once in the index's table of contents, one title per page;
* the API lists each parameter once (no separate ``__init__``); intersphinx reads local
  inventories only, and PETSc types link to petsc4py's documentation; it is one page per layer
  of the package, each module on its layer's page;
* every heading of every Markdown page (the README, the index, the model, the design notes, the
  reference) is a heading of its rendered page: an unclosed maths block or fence cannot swallow
  sections unseen (a quick build of the Markdown pages alone, ``sphinx-build -t pages``);
* ``./run docs`` fails on a Sphinx warning.
"""

import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser

import pytest

from docs.pages import API_LAYERS, api_pages, local_inventories, public_modules
from tests.helpers import ROOT, singleton_env

DOCS = ROOT / "docs"
# the build (Sphinx, autodoc importing DOLFINx, MyST-NB) takes 1-2 min alone and over 5 min on a
# loaded machine: the first test, which waits for it, may take that long (a hang still ends)
pytestmark = pytest.mark.timeout(1500)
DEMOS = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")


class Page(HTMLParser):
    """Text outside code, scripts and math; the math elements; images; h1 titles; links."""

    SKIP = frozenset({"script", "style", "pre", "code", "textarea"})

    def __init__(self, html):
        super().__init__(convert_charrefs=True)
        self.stack = []
        self.text, self.math, self.images, self.h1, self.links = [], [], [], [], []
        self._math_depth = None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        classes = (a.get("class") or "").split()
        self.stack.append(tag)
        if tag == "img":
            self.stack.pop()
            self.images.append(a.get("src", ""))
        elif tag in ("span", "div") and "math" in classes and self._math_depth is None:
            self._math_depth = len(self.stack)
            self.math.append("")
        elif tag == "a":
            self.links.append((a.get("href", ""), classes))
        elif tag == "h1":
            self.h1.append("")

    def handle_endtag(self, tag):
        while self.stack:
            top = self.stack.pop()
            if self._math_depth is not None and len(self.stack) < self._math_depth:
                self._math_depth = None
            if top == tag:
                break

    def handle_data(self, data):
        if self._math_depth is not None:
            self.math[-1] += data
        elif not (self.SKIP & set(self.stack)):
            self.text.append(data)
        if self.stack and "h1" in self.stack:
            self.h1[-1] += data


RAW_MATH = re.compile(r"\\\(|\\\[|\$\$|(?<![\w\\])\$[^\s$][^$\n]*[^\s$\\]\$(?!\w)")


# what docs/conf.py writes into its source folder at every build (.gitignore lists them)
GENERATED = ("_build", "api", "demos", "_mathjax", "readme.md", "__pycache__")


def private_source(where):
    """A source tree of the site's own for one build: ``docs/`` copied without what a build
    generates, every other entry of the repository linked. conf.py writes its generated pages
    (``api/``, ``demos/``, ``readme.md``, ``_mathjax/``) beside its sources: two builds at once
    (the two stacks' legs of ``./run test`` side by side) in the repository's one ``docs/``
    would remove each other's pages."""
    shutil.copytree(DOCS, where / "docs", ignore=shutil.ignore_patterns(*GENERATED))
    for entry in ROOT.iterdir():
        if entry.name != "docs":
            (where / entry.name).symlink_to(entry)
    return where


def build(tmp_path_factory, name, *options):
    """The site built by Sphinx from a source tree of its own (``name``: the folders' stem)."""
    out = tmp_path_factory.mktemp(name) / "html"
    p = subprocess.run(
        [sys.executable, "-m", "sphinx", *options, "-q", "-b", "html", "docs", out],
        cwd=private_source(tmp_path_factory.mktemp(f"{name}_source")),
        env=singleton_env(),
        capture_output=True,
        text=True,
        timeout=1400,
    )
    assert p.returncode == 0, p.stdout + p.stderr
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    return build(tmp_path_factory, "docs", "-W", "--keep-going")


def pages(site):
    return {
        str(f.relative_to(site)): Page(f.read_text())
        for f in sorted(site.rglob("*.html"))
        if not f.relative_to(site).parts[0].startswith(("_modules", "_sources"))
    }


@pytest.mark.serial
def test_every_equation_is_rendered_offline(site):
    found = pages(site)
    raw = {name: RAW_MATH.findall(" ".join(p.text)) for name, p in found.items()}
    assert not {k: v for k, v in raw.items() if v}, raw
    for name, p in found.items():
        for m in p.math:
            m = m.strip()
            assert m.startswith(("\\(", "\\[", "\\begin")), (name, m[:80])
    assert len(found["model.html"].math) >= 40, len(found["model.html"].math)
    assert len(found["demos/hertz.html"].math) >= 5
    model = (site / "model.html").read_text()
    (src,) = re.findall(r'<script[^>]*src="([^"]*MathJax\.js[^"]*)"', model)
    assert not src.startswith(("http:", "https:", "//")), src  # the site's own copy
    mathjax = site / src.split("?")[0]
    assert mathjax.is_file()
    config = src.split("config=")[1]
    assert (mathjax.parent / "config" / f"{config}.js").is_file()
    assert (mathjax.parent / "fonts" / "HTML-CSS" / "TeX" / "woff").is_dir()
    (hub,) = re.findall(r"MathJax\.Hub\.Config\((.*?)\)\s*</script>", model, re.S)
    assert re.search(r'"processClass":\s*"[^"]*\bmath\b', hub), hub


@pytest.mark.serial
def test_every_image_exists_and_every_demo_shows_its_figures(site):
    found = pages(site)
    for name, p in found.items():
        for src in p.images:
            if src.startswith(("http:", "https:", "data:")):
                continue
            assert (site / name).parent.joinpath(src).resolve().is_file(), (name, src)
    assert len(found["readme.html"].images) >= 1
    for demo in DEMOS:
        figures = sorted((DOCS / "figures" / demo).glob("*.png"))
        shown = [s for s in found[f"demos/{demo}.html"].images if "_images/" in s]
        assert len(shown) >= len(figures), (demo, figures, shown)
    # every demo that draws figures (writes a .png) has them on its page
    drawing = [d for d in DEMOS if ".png" in (ROOT / "demos" / f"{d}.py").read_text()]
    assert len(drawing) >= 9, drawing  # all but two_bodies_api and elastic_smoke
    for demo in drawing:
        assert list((DOCS / "figures" / demo).glob("*.png")), f"no figure of {demo} in docs/figures"


@pytest.mark.serial
def test_no_duplicate_pages(site):
    found = pages(site)
    index = (site / "index.html").read_text()
    body = index.split('<div class="toctree-wrapper', 1)[1]
    for demo in DEMOS:
        n = len(re.findall(rf'href="demos/{demo}\.html"', body))
        assert n == 1, (demo, n)
    titles = {}
    for name, p in found.items():
        if name.startswith(("demos/", "api/")) or name in ("readme.html", "model.html"):
            # the theme repeats the title (for print), one copy with its permalink sign
            heads = [h.strip().rstrip("#¶").strip() for h in p.h1 if h.strip()]
            assert len(set(heads)) == 1, (name, heads)
            titles.setdefault(heads[0], []).append(name)
    assert {t: n for t, n in titles.items() if len(n) > 1} == {}


@pytest.mark.serial
def test_the_api_lists_each_parameter_once_and_links_petsc(site):
    stepper = (site / "api" / "fem.html").read_text()
    section = stepper.split('id="subfric_dolfinx.fem.stepping.LoadStepper"', 1)[1]
    section = section.split('id="subfric_dolfinx.fem.stepping.LoadStepper.restore"', 1)[0]
    text = re.sub(r"<[^>]+>", " ", section)
    for name in ("dt", "control", "sticky_retry", "predictor"):  # one entry each, documented
        assert len(re.findall(rf"\b{name}\s+–", text)) == 1, (name, text[:2000])
    # the step's bounds are StepControl's fields: one documented entry each
    for name in ("dt_min", "dt_max", "max_cuts"):
        anchor = f'id="subfric_dolfinx.fem.stepping.StepControl.{name}"'
        assert stepper.count(anchor) == 1, name
        entry = re.sub(r"<[^>]+>", " ", stepper.split(anchor, 1)[1].split("</dd>", 1)[0])
        assert re.search(r"[A-Z][a-z]+ \w+", entry), (name, entry)  # a sentence, not a bare name
    assert "LoadStepper.__init__" not in stepper
    for _, (url, inventory) in local_inventories().items():  # conf.py's intersphinx_mapping
        assert url.startswith("https://") and not str(inventory).startswith("http")
        assert (ROOT / inventory).is_file() or __import__("pathlib").Path(inventory).is_file()
    links = " ".join(href for p in pages(site).values() for href, _ in p.links)
    assert "https://petsc.org/release/petsc4py/reference/petsc4py.PETSc.Vec.html" in links


@pytest.mark.serial
def test_the_index_links_every_demo_and_api_page(site):
    index = (site / "index.html").read_text()
    links = set(re.findall(r'href="([^"#]+)"', index))
    for d in DEMOS:
        assert f"demos/{d}.html" in links, d
        page = (site / "demos" / f"{d}.html").read_text()
        assert "highlight-ipython3" in page or "highlight-python" in page, d  # code cells
    modules = public_modules()  # the list the build wrote its API pages from
    assert "subfric_dolfinx.io.points" in modules and "subfric_dolfinx.fem.stepping" in modules
    layers = api_pages()
    assert sorted(m for ms in layers.values() for m in ms) == modules  # each module once
    assert len(layers) == len(API_LAYERS) < 10  # a page per layer, not one per module
    for page, names in layers.items():
        assert f"api/{page}.html" in links, page
        html = (site / "api" / f"{page}.html").read_text()
        for m in names:
            assert f'id="module-{m}"' in html, (page, m)
    assert {"readme.html", "model.html"} <= links
    points = (site / "api" / "io.html").read_text()
    assert 'id="subfric_dolfinx.io.points.InterfacePointsXDMF.write"' in points
    for page in (DOCS / "reference").glob("*.md"):
        assert f"reference/{page.stem}.html" in links, page.name


# --------------------------------------------------------------------------------------------
# Every Markdown heading is a heading of the rendered page (a quick build of the pages alone)


MARKDOWN_PAGES = {
    "readme.html": ROOT / "README.md",
    **{f"{p.stem}.html": p for p in sorted(DOCS.glob("*.md"))},
    **{f"reference/{p.stem}.html": p for p in sorted((DOCS / "reference").glob("*.md"))},
}


class Headings(HTMLParser):
    """The text of every h1-h6 of a page (without the permalink sign)."""

    def __init__(self, html):
        super().__init__(convert_charrefs=True)
        self.headings, self._open = [], 0
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        if re.fullmatch(r"h[1-6]", tag):
            self._open += 1
            self.headings.append("")

    def handle_endtag(self, tag):
        if re.fullmatch(r"h[1-6]", tag):
            self._open -= 1

    def handle_data(self, data):
        if self._open:
            self.headings[-1] += data


def markdown_headings(text):
    """The ATX headings of a Markdown page, outside fenced code (``` or ~~~)."""
    out, fence = [], None
    for line in text.splitlines():
        m = re.match(r"^\s*(```+|~~~+)", line)
        if m:
            if fence is None:
                fence = m.group(1)[0] * 3
            elif m.group(1).startswith(fence):
                fence = None
            continue
        h = re.match(r"^#{1,6}\s+(.+?)\s*#*\s*$", line)
        if fence is None and h:
            out.append(h.group(1))
    return out


def plain(text):
    """Letters and digits only, lower case: a heading's words whatever the markup around them."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link's text
    return re.sub(r"[^0-9a-z]+", "", text.lower().replace("¶", ""))


@pytest.fixture(scope="module")
def pages_site(tmp_path_factory):
    """The Markdown pages alone (no API, no demos: about 10 s)."""
    return build(tmp_path_factory, "pages", "-t", "pages")


@pytest.mark.serial
def test_every_markdown_heading_is_a_heading_of_its_page(pages_site):
    missing = {}
    for html, source in MARKDOWN_PAGES.items():
        rendered = {plain(h) for h in Headings((pages_site / html).read_text()).headings}
        lost = [h for h in markdown_headings(source.read_text()) if plain(h) not in rendered]
        if lost:
            missing[html] = lost
    assert not missing, missing
    model = markdown_headings((DOCS / "model.md").read_text())
    assert any(h.startswith("6.6") for h in model) and any(h.startswith("8.") for h in model)
