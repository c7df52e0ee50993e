"""Sphinx configuration of the documentation site (``./run docs`` builds it into ``_build/html``).

Pages: the index, the README (rewritten for its links: ``readme.md``), ``model.md``, the demos
rendered from their jupytext sources (copied here from ``demos/`` at every build, not executed:
see ``index.md``) and one API page per public module (generated here at every build:
``automodule`` with its members). The generated folders (``demos/``, ``api/``) and ``readme.md``
are rebuilt from the sources each time and not kept in git.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

project = "subfric-dolfinx"
author = "the subfric-dolfinx developers"
copyright = "2026, the subfric-dolfinx developers"

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
exclude_patterns = ["_build", "conf.py", "**/.ipynb_checkpoints", "Thumbs.db", ".DS_Store"]

# -- MyST and MyST-NB: Markdown pages, demos as notebooks from their jupytext (percent) source
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = "off"  # the demos run in the test suite (tests/test_demos_run.py), not here
source_suffix = {".md": "myst-nb", ".py": "myst-nb"}

# -- autodoc with Google-style docstrings
autodoc_default_options = {"members": True, "show-inheritance": True, "member-order": "bysource"}
autodoc_typehints = "description"
autodoc_class_signature = "separated"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_attr_annotations = True
suppress_warnings = ["myst.header"]  # the README starts at level 2 below its title

html_theme = "sphinx_book_theme"
html_title = "subfric-dolfinx"
html_static_path: list[str] = []
html_theme_options = {"show_toc_level": 2, "navigation_with_keys": False}

DEMOS = ROOT / "demos"
PACKAGE = "subfric_dolfinx"


def public_modules() -> list[str]:
    """Every importable module of the package whose dotted name has no part starting with '_'."""
    pkg = importlib.import_module(PACKAGE)
    names = [PACKAGE]
    for info in pkgutil.walk_packages(pkg.__path__, prefix=PACKAGE + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def write_api_pages() -> list[str]:
    """``api/<module>.md`` for every public module.

    A package's page has its docstring only: its members are documented in their modules.
    """
    out = HERE / "api"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    names = public_modules()
    for name in names:
        is_package = hasattr(importlib.import_module(name), "__path__")
        options = "   :no-members:\n" if is_package else ""
        (out / f"{name}.md").write_text(
            f"# `{name}`\n\n```{{eval-rst}}\n.. automodule:: {name}\n{options}```\n"
        )
    return names


def copy_demos() -> list[str]:
    """``demos/<name>.py`` copied from the repository's ``demos/`` (the jupytext sources)."""
    out = HERE / "demos"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    names = []
    for src in sorted(DEMOS.glob("*.py")):
        if src.name == "__init__.py":
            continue
        shutil.copy2(src, out / src.name)
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


API_MODULES = write_api_pages()
DEMO_NAMES = copy_demos()
write_readme()
