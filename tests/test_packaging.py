"""The package as users install it into an environment that already has DOLFINx.

* ``./run test`` runs the whole suite against the package installed with ``pip install .`` into a
  fresh virtual environment of the stack (``.ci/pytest-installed``): the first test checks that
  the package the tests import, in this process and in a child ``python3``, is that one.
* ``pip install .`` and ``pip install -e .`` into a virtual environment that sees the system's
  DOLFINx (``--system-site-packages``, no package index: nothing may be downloaded) install this
  package alone: DOLFINx, PETSc, numpy... stay the system's, and ``pip check`` finds the declared
  dependencies (``fenics-dolfinx>=0.9,<0.12``, ...) satisfied.
"""

import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement

import subfric_dolfinx
from subfric_dolfinx import compat
from tests.helpers import ROOT, python_env

INSTALLED = os.environ.get("SUBFRIC_TEST_INSTALLED")


def test_the_tests_import_the_package_they_are_meant_to(tmp_path):
    """Installed-package runs import the installed copy (here and in a child started from the
    repository root); source runs import the tree."""
    here = Path(subfric_dolfinx.__file__).resolve()
    code = "import subfric_dolfinx; print(subfric_dolfinx.__file__)"
    child = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        env=python_env(),
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    there = Path(child.stdout.strip()).resolve()
    if INSTALLED:
        venv = Path(INSTALLED).resolve()
        assert here.is_relative_to(venv), here
        assert there.is_relative_to(venv), there
        assert not here.is_relative_to(ROOT)
    else:
        assert here.is_relative_to(ROOT / "subfric_dolfinx"), here
        assert there == here


def test_the_dolfinx_in_use_is_a_supported_version_and_pyproject_says_which():
    assert compat.DOLFINX_VERSION in compat.SUPPORTED, compat.DOLFINX_VERSION
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    (spec,) = [Requirement(d).specifier for d in deps if Requirement(d).name == "fenics-dolfinx"]
    for v in ("0.9.0", "0.11.0.post0", importlib.metadata.version("fenics-dolfinx")):
        assert spec.contains(v, prereleases=True), (spec, v)
    for v in ("0.8.0", "0.12.0"):
        assert not spec.contains(v), (spec, v)
    if INSTALLED:  # the installed metadata declares the same
        req = importlib.metadata.requires("subfric-dolfinx")
        assert any(Requirement(r).specifier == spec for r in req), req


@pytest.mark.numpy_only
def test_the_package_is_marked_typed():
    """PEP 561: ``py.typed`` in the package the tests import (the installed one under ``./run
    test``), declared as package data so that every install has it."""
    assert (Path(subfric_dolfinx.__file__).parent / "py.typed").is_file()
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "py.typed" in data["package-data"]["subfric_dolfinx"]
    if INSTALLED:
        files = [str(f) for f in importlib.metadata.files("subfric-dolfinx") or []]
        assert "subfric_dolfinx/py.typed" in files, files


def source_copy(tmp_path: Path) -> Path:
    """The files a ``pip install`` of the repository reads, copied (setuptools writes build/
    and *.egg-info beside the sources)."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(
        ROOT / "subfric_dolfinx",
        src / "subfric_dolfinx",
        ignore=shutil.ignore_patterns("__pycache__"),
    )
    return src


def venv_python(tmp_path: Path, name: str) -> Path:
    """A new virtual environment that sees the system's packages; its python.

    Without a pip of its own (``--without-pip``: ensurepip copies one in, seconds of work):
    ``python -m pip`` in it is the system's pip, which installs into the environment."""
    venv = tmp_path / name
    subprocess.run(
        [sys.executable, "-m", "venv", "--without-pip", "--system-site-packages", str(venv)],
        check=True,
        capture_output=True,
        timeout=900,
    )
    return venv / "bin" / "python"


def run(py: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSAFEPATH")}
    return subprocess.run(
        [str(py), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=900
    )


PROBE = (
    "import json, importlib.metadata as m, subfric_dolfinx, dolfinx, numpy, petsc4py\n"
    "print(json.dumps({'pkg': subfric_dolfinx.__file__, 'dolfinx': dolfinx.__file__,\n"
    "  'numpy': numpy.__file__, 'petsc4py': petsc4py.__file__,\n"
    "  'version': m.version('subfric-dolfinx'), 'license': m.metadata('subfric-dolfinx')\n"
    "  .get('License-Expression')}))\n"
)


@pytest.mark.e2e
@pytest.mark.numpy_only  # no MPI in this process: one rank is enough
@pytest.mark.timeout(1800)  # a venv and a pip install: minutes on a loaded machine
@pytest.mark.parametrize("editable", [False, True], ids=["pip-install", "pip-install-e"])
def test_pip_install_into_an_environment_with_dolfinx_touches_nothing_else(tmp_path, editable):
    if (
        shutil.which("pip") is None
        and run(Path(sys.executable), "-m", "pip", "--version", cwd=tmp_path).returncode != 0
    ):
        pytest.fail("pip is not available in this environment (debian-packages.txt: python3-pip)")
    src = source_copy(tmp_path)
    py = venv_python(tmp_path, "venv")
    cmd = [
        "-m",
        "pip",
        "install",
        "--no-build-isolation",
        "--no-index",
        "--disable-pip-version-check",
    ]
    r = run(py, *cmd, *(["-e", str(src)] if editable else [str(src)]), cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    # what pip put into the environment: this package only
    site = run(py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=tmp_path)
    listed = run(
        py, "-m", "pip", "list", "--path", site.stdout.strip(), "--format", "json", cwd=tmp_path
    )
    names = sorted(d["name"].lower() for d in json.loads(listed.stdout))
    assert names == ["subfric-dolfinx"], names
    # our declared dependencies are all satisfied by the system's packages (pip check also
    # reports on Debian's own packages, e.g. typeshed stubs without their libraries: not ours)
    check = run(py, "-m", "pip", "check", cwd=tmp_path)
    ours = [ln for ln in check.stdout.splitlines() if ln.lower().startswith("subfric-dolfinx")]
    assert not ours, ours
    probe = run(py, "-c", PROBE, cwd=tmp_path)
    assert probe.returncode == 0, probe.stderr
    got = json.loads(probe.stdout)
    import dolfinx
    import numpy
    import petsc4py

    for mod in (dolfinx, numpy, petsc4py):  # the system's, unchanged
        assert Path(got[mod.__name__]).resolve() == Path(mod.__file__).resolve(), got
    pkg = Path(got["pkg"]).resolve()
    if editable:
        assert pkg == (src / "subfric_dolfinx" / "__init__.py").resolve(), pkg
    else:
        assert pkg.is_relative_to((tmp_path / "venv").resolve()), pkg
    assert got["license"] == "MIT"
    assert (pkg.parent / "py.typed").is_file()  # PEP 561: typed, in the installed package too
    # the command lines work from the installed package, and as console scripts
    r = run(py, "-m", "subfric_dolfinx.driver", "--help", cwd=tmp_path)
    assert r.returncode == 0 and "usage" in r.stdout.lower(), r.stdout + r.stderr
    for script in ("subfric-driver", "subfric-calibrate", "subfric-scene"):
        r = run(py.parent / script, "--help", cwd=tmp_path)
        assert r.returncode == 0 and f"usage: {script}" in r.stdout, r.stdout + r.stderr


@pytest.mark.numpy_only
def test_citation_cff_cites_the_software_and_the_article():
    """CITATION.cff (Citation File Format 1.2): the software with pyproject's version and
    licence, and the article whose law it implements."""
    import yaml

    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert str(cff["version"]) == project["version"] and cff["license"] == project["license"]
    assert cff["title"].startswith("subfric-dolfinx") and cff["authors"] and cff["message"]
    (article,) = [r for r in cff["references"] if r["type"] == "article"]
    assert article["title"] == (
        "Subloading-friction model with saturation of tangential contact stress"
    )
    assert article["journal"] == "Friction" and article["year"] == 2022
    assert article["authors"][0]["family-names"] == "Hashiguchi"
