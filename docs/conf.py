"""Sphinx configuration of the documentation site (``./run docs`` builds it into ``_build/html``).

Pages: the index, the README (rewritten for its links: ``readme.md``), ``model.md``, the demos
rendered from their jupytext sources (copied here from ``demos/`` at every build, not executed:
see ``index.md``), each with the figures and numbers of its last full run (``figures/<demo>/``
and ``demo_results.json``, made by ``docs/demo_results.py``), the reference pages
(``reference/``), and the API reference, one page per layer of the package (generated here at
every build: ``automodule`` of each public module with its members; ``pages.API_LAYERS``).
The generated folders (``demos/``, ``api/``, ``_mathjax/``) and ``readme.md`` are rebuilt from
the sources each time and not kept in git. The pages link the repository's files as on GitHub
(:func:`repository_links` makes those links work here).

Offline: equations are rendered by the MathJax of Debian's ``libjs-mathjax`` (the part it needs
is copied into the site: no CDN), and intersphinx reads only inventories installed on this
machine (``INVENTORIES`` in ``pages.py``: PETSc's in both stacks), never the network.
"""

from __future__ import annotations

import importlib
import json
import os
import re
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

from docs.pages import API_LAYERS, api_pages, local_inventories  # noqa: E402

project = "subfric-dolfinx"
author = "the subfric-dolfinx developers"
copyright = "2026, the subfric-dolfinx developers"

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.intersphinx",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
exclude_patterns = [
    "_build",
    "_mathjax",
    "__init__.py",
    "conf.py",
    "pages.py",
    "demo_results.py",
    "readme_numbers.py",
    "figures",
    "**/.ipynb_checkpoints",
    "Thumbs.db",
    ".DS_Store",
]

# -- MyST and MyST-NB: Markdown pages, demos as notebooks from their jupytext (percent) source
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
# the demos run in the test suite (tests/demos/test_demos_run.py), not here
nb_execution_mode = "off"
source_suffix = {".md": "myst-nb", ".py": "myst-nb"}

# -- autodoc with Google-style docstrings: each parameter once (its text from the docstring's
# Args, its type in the signature; a class's signature on the class, no separate __init__)
autodoc_default_options = {"members": True, "show-inheritance": True, "member-order": "bysource"}
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_class_signature = "mixed"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_attr_annotations = True
suppress_warnings = ["myst.header"]  # the README starts at level 2 below its title

html_theme = "sphinx_book_theme"
html_title = "subfric-dolfinx"
html_static_path: list[str] = ["_mathjax"]
html_theme_options = {"show_toc_level": 2, "navigation_with_keys": False}

# -- MathJax from Debian's libjs-mathjax (2.7), copied into the site: equations render offline
MATHJAX_SOURCE = Path("/usr/share/javascript/mathjax")
MATHJAX_PARTS = [  # what the TeX-AMS_CHTML configuration loads (TeX in, CommonHTML out)
    "MathJax.js",
    "config/TeX-AMS_CHTML.js",
    "config/local",
    "jax/input/TeX",
    "jax/output/CommonHTML",
    "jax/element",
    "extensions",
    "fonts/HTML-CSS/TeX/woff",
    "fonts/HTML-CSS/TeX/otf",
    "localization/en",
]
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS_CHTML"
# MathJax 2 skips what lies inside class tex2jax_ignore (the page body, set by MyST-NB) unless the
# element's class matches processClass: Sphinx's math elements have class "math"
mathjax2_config = {
    "tex2jax": {
        "processClass": "tex2jax_process|mathjax_process|math|output_area",
        "ignoreClass": "tex2jax_ignore|mathjax_ignore",
    },
}

# -- intersphinx: only inventories installed here (docs/pages.py)
intersphinx_mapping = local_inventories()
intersphinx_timeout = 1

DEMOS = ROOT / "demos"


def write_api_pages() -> list[str]:
    """``api/<layer>.md`` for every layer of the package (``pages.API_LAYERS``).

    Each documents its public modules one after the other, under a heading each; a package's
    section has its docstring only (its members are documented in their modules).
    """
    out = HERE / "api"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    titles = {page: title for page, title, _ in API_LAYERS}
    written = []
    for page, names in api_pages().items():
        parts = [f"# {titles[page]}\n"]
        for name in names:
            is_package = hasattr(importlib.import_module(name), "__path__")
            options = "   :no-members:\n" if is_package else ""
            parts.append(f"## `{name}`\n\n```{{eval-rst}}\n.. automodule:: {name}\n{options}```\n")
        (out / f"{page}.md").write_text("\n".join(parts))
        written += names
    return written


def copy_mathjax() -> None:
    """The part of Debian's MathJax the site needs, into ``_mathjax/mathjax`` (its static files).

    Raises:
        RuntimeError: libjs-mathjax is not installed (debian-packages.txt lists it).
    """
    if not (MATHJAX_SOURCE / "MathJax.js").is_file():
        raise RuntimeError(
            f"MathJax is not installed at {MATHJAX_SOURCE} (Debian package libjs-mathjax, in "
            "debian-packages.txt): the site renders its equations with a local copy"
        )
    out = HERE / "_mathjax" / "mathjax"
    shutil.rmtree(out.parent, ignore_errors=True)
    for part in MATHJAX_PARTS:
        src = MATHJAX_SOURCE / part
        if src.is_dir():
            shutil.copytree(src, out / part)
        elif src.exists():
            (out / part).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, out / part)


RESULTS = HERE / "demo_results.json"
FIGURES = HERE / "figures"


def results_cell(name: str) -> str:
    """A Markdown cell (percent format) with a demo's figures and numbers from its last run."""
    data = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"demos": {}}
    run = data["demos"].get(name)
    figures = sorted((FIGURES / name).glob("*.png"))
    if run is None and not figures:
        return ""
    lines = ["## Results of the last full run", ""]
    if run is not None:
        stamp = data.get("stamp", {})
        lines += [
            f"`{' '.join(run['command'])}`: {run['wall_s']:.0f} s on {run['ranks']} rank(s) of "
            f"the documentation's machine, at commit `{stamp.get('commit', '?')[:10]}` "
            "(`docs/demo_results.py` runs every demo and writes these figures and "
            "`docs/demo_results.json`).",
            "",
        ]
        if run["warnings"]:  # what a user running it sees first (their first sentences)
            lines += ["The default run warns:", ""]
            lines += [f"- `{w.split('. ')[0].split(' (at ')[0]}`" for w in run["warnings"]]
            lines += [""]
    for f in figures:
        lines += [f"![{name}: {f.stem.replace('_', ' ')}](../figures/{name}/{f.name})", ""]
    return "\n# %% [markdown]\n" + "".join(f"# {ln}\n".replace("# \n", "#\n") for ln in lines)


def copy_demos() -> list[str]:
    """``demos/<name>.py`` copied from the repository's ``demos/`` (the jupytext sources).

    Each gets a last cell with the figures and numbers of its last full run.
    """
    out = HERE / "demos"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    names = []
    for src in sorted(DEMOS.glob("*.py")):
        if src.name == "__init__.py":
            continue
        (out / src.name).write_text(src.read_text() + results_cell(src.stem))
        names.append(src.stem)
    return names


def write_readme() -> None:
    """``readme.md``: the repository's README with its links made to work from ``docs/``.

    Links to the demos go to their pages here, images under ``docs/`` are local, links to other
    files of the repository become downloads (``path:../<file>``).
    """
    text = (ROOT / "README.md").read_text()

    def link(m: re.Match) -> str:
        target = m.group(2)
        if re.match(r"^[a-z]+:|^#|^/", target):
            return m.group(0)
        if target.startswith("docs/"):
            target = target[len("docs/") :]
        elif not re.match(r"^demos/[a-z_]+\.py$", target):
            target = "path:../" + target
        return f"{m.group(1)}({target})"

    text = re.sub(r"(!?\[[^\]]*\])\(([^)\s]+)\)", link, text)
    # raw <img> tags (side by side in the README) as Markdown images, so that Sphinx copies them
    text = re.sub(
        r'<img src="docs/([^"]+)"[^>]*alt="([^"]*)"[^>]*>', lambda m: f"![{m[2]}]({m[1]})", text
    )
    (HERE / "readme.md").write_text(text)


# ``sphinx-build -t pages``: the Markdown pages only (no API reference, no demos): the tests' quick
# build of the pages (tests/demos/test_docs.py); the toctrees' globs then match nothing
PAGES_ONLY = "tags" in globals() and globals()["tags"].has("pages")
if PAGES_ONLY:
    exclude_patterns += ["api", "demos"]
    API_MODULES: list[str] = []
    DEMO_NAMES: list[str] = []
else:
    API_MODULES = write_api_pages()
    DEMO_NAMES = copy_demos()
write_readme()
copy_mathjax()


LINK = re.compile(r"(!?\[[^\]]*\])\(([^)\s]+)\)")


def repository_links(app: object, docname: str, source: list[str]) -> None:
    """Links of the Markdown pages written for the repository (GitHub), made to work here.

    The pages link files by their place in the repository (``../../demos/hertz.py`` from
    ``reference/``): a demo becomes its page of this site, a file outside ``docs/`` a download
    (``path:``); links within ``docs/`` and to the web stay as they are. (Sphinx's
    ``source-read`` event: the page's text before it is parsed.)
    """
    if docname.startswith(("api/", "demos/")) or docname == "readme":
        return
    here = (HERE / docname).parent

    def link(m: re.Match) -> str:
        target = m.group(2)
        if re.match(r"^[a-z]+:|^#|^/", target):
            return m.group(0)
        path, _, anchor = target.partition("#")
        full = Path(os.path.normpath(here / path))  # lexical: a linked entry stays in the tree
        if full.is_relative_to(HERE):
            return m.group(0)
        rel = full.relative_to(ROOT) if full.is_relative_to(ROOT) else None
        if rel is None:
            return m.group(0)
        if rel.parts[0] == "demos" and rel.suffix == ".py" and len(rel.parts) == 2:
            page = Path(os.path.relpath(HERE / "demos" / rel.name, here)).as_posix()
            return f"{m.group(1)}({page}{'#' + anchor if anchor else ''})"
        return f"{m.group(1)}(path:{Path(os.path.relpath(full, here)).as_posix()})"

    source[0] = LINK.sub(link, source[0])


def setup(app: object) -> None:
    """Sphinx's hook: :func:`repository_links` on every page read."""
    app.connect("source-read", repository_links)  # type: ignore[attr-defined]
