"""What the documentation site is built from, for ``conf.py`` and the tests alike (no side effects).

* :func:`public_modules`: the modules the API reference documents, and :func:`api_pages`, the
  page of each (one per layer of the package, :data:`API_LAYERS`);
* :func:`local_inventories`: the intersphinx inventories installed on this machine (the build
  never reads the network); links point to the projects' sites.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from pathlib import Path

PACKAGE = "subfric_dolfinx"

INVENTORIES = {
    "petsc4py": (
        "https://petsc.org/release/petsc4py/",
        ["/usr/share/doc/python-petsc4py-doc/html/objects.inv"],
    ),
    "mpi4py": (
        "https://mpi4py.readthedocs.io/en/stable/",
        ["/usr/share/doc/python-mpi4py-doc/html/objects.inv"],
    ),
    "python": (
        "https://docs.python.org/3/",
        [
            "/usr/share/doc/python3/html/objects.inv",
            f"/usr/share/doc/python3.{sys.version_info[1]}/html/objects.inv",
        ],
    ),
    "numpy": (
        "https://numpy.org/doc/stable/",
        [
            "/usr/share/doc/python-numpy-doc/html/objects.inv",
            "/usr/share/doc/python-numpy/html/objects.inv",
        ],
    ),
}
"""Project name -> (its site, candidate paths of its inventory, first found wins)."""


def local_inventories() -> dict[str, tuple[str, str]]:
    """Sphinx's ``intersphinx_mapping``: each project of :data:`INVENTORIES` installed here."""
    return {
        name: (url, path)
        for name, (url, paths) in INVENTORIES.items()
        for path in paths[:1] + [q for q in paths[1:] if not Path(paths[0]).exists()]
        if Path(path).exists()
    }


def public_modules() -> list[str]:
    """Every importable module of the package whose dotted name has no part starting with '_'."""
    pkg = importlib.import_module(PACKAGE)
    names = [PACKAGE]
    for info in pkgutil.walk_packages(pkg.__path__, prefix=PACKAGE + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


API_LAYERS: list[tuple[str, str, tuple[str, ...]]] = [
    ("constitutive", "Friction laws and the bulk J2 law (numpy only)", ("constitutive",)),
    ("driver", "Material-point driver and calibration", ("driver", "calibrate")),
    ("meshing", "Meshing: gmsh models, duplicated nodes, reading into DOLFINx", ("meshing",)),
    ("fem", "Finite elements: interfaces, problem, solver, load stepping", ("fem",)),
    ("io", "Output: history, fields, interface history, checkpoints", ("io",)),
    ("scenes", "Scenes: schema, parser, runner, command line", ("scenes",)),
    ("package", "Loading programs, logs, values, command lines, DOLFINx versions", ("",)),
]
"""The API reference's pages, one per layer: (page, title, subpackages of ``subfric_dolfinx``;
``""``: the package and its top-level modules, the rest)."""


def api_pages() -> dict[str, list[str]]:
    """Page -> the public modules it documents (each module on the first layer that holds it)."""
    pages: dict[str, list[str]] = {page: [] for page, _, _ in API_LAYERS}
    for name in public_modules():
        rel = name[len(PACKAGE) + 1 :]
        for page, _, subpackages in API_LAYERS:
            if any(rel == s or rel.startswith(s + ".") if s else True for s in subpackages):
                pages[page].append(name)
                break
    return pages
