"""The package's layers, checked by walking its imports (statically, with ``ast``).

Layers, lowest first; a module may import its own subpackage and lower layers only:

0. ``constitutive/``, ``loading.py``, ``logs.py``, ``values.py`` (the strict number checks and
   the quoting of bad values, for every parser of user input), ``commandline.py`` (the argument
   parser of every command line): numpy and the standard library only; ``compat.py``: the
   differences between the supported DOLFINx versions (DOLFINx, PETSc, MPI);
1. ``driver/`` (numpy only, on the constitutive core), ``meshing/`` (gmsh, DOLFINx);
2. ``fem/`` (DOLFINx, PETSc, MPI), ``calibrate/`` (scipy, on the driver);
3. ``io/``;
4. ``scenes/`` (the top).

Function-level imports count like module-level ones: a lazy import is still an import.

A module imports another subpackage's public names only: ``from ..driver.case import _number``
would tie the calibration to a helper the driver may change at will (a helper two subpackages
need has one public home, e.g. :mod:`subfric_dolfinx.values`).
"""

import ast
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.numpy_only

PKG = ROOT / "subfric_dolfinx"
NAME = "subfric_dolfinx"

LAYERS = {
    f"{NAME}.constitutive": 0,
    f"{NAME}.loading": 0,
    f"{NAME}.logs": 0,
    f"{NAME}.values": 0,
    f"{NAME}.commandline": 0,
    f"{NAME}.compat": 0,
    f"{NAME}.driver": 1,
    f"{NAME}.meshing": 1,
    f"{NAME}.fem": 2,
    f"{NAME}.calibrate": 2,
    f"{NAME}.io": 3,
    f"{NAME}.scenes": 4,
}
NUMPY_ONLY = [
    f"{NAME}.constitutive",
    f"{NAME}.loading",
    f"{NAME}.logs",
    f"{NAME}.values",
    f"{NAME}.commandline",
    f"{NAME}.driver",
]
HEAVY = {"dolfinx", "petsc4py", "mpi4py", "gmsh", "basix", "ufl", "ffcx", "h5py", "adios2"}
LONG_LINES = 1000
"""Modules longer than this are named in a warning: a sign to look for a second concept (modules
are sized by concept, not by length: issue 26 relaxed the former 500-line cap to this warning)."""
MAX_LINES = 2000
"""Modules longer than this fail: twice the warning's length holds several concepts for sure."""


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def is_package(mod: str) -> bool:
    return MODULES[mod].name == "__init__.py"


def resolve(mod: str, node: ast.AST) -> list[str]:
    """Absolute names of what an import statement in module ``mod`` imports."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    assert isinstance(node, ast.ImportFrom)
    if node.level:
        base = mod.split(".") if is_package(mod) else mod.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module
    out = []
    for a in node.names:
        sub = f"{target}.{a.name}"
        out.append(sub if sub in MODULES else target)
    return out


def imports_of(mod: str) -> set[str]:
    tree = ast.parse(MODULES[mod].read_text())
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            # imports only for type checkers do not run
            found.update(resolve(mod, node))
    for node in ast.walk(tree):  # drop `if TYPE_CHECKING:` blocks
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for sub in ast.walk(node):
                if isinstance(sub, ast.Import | ast.ImportFrom):
                    found.difference_update(resolve(mod, sub))
    return found


def internal_targets(mod: str) -> set[str]:
    """Package modules ``mod`` makes Python execute: each import and its parent packages, except
    ``mod``'s own ancestors (already executing when ``mod`` runs)."""
    own = {".".join(mod.split(".")[:i]) for i in range(1, mod.count(".") + 1)}
    out = set()
    for name in imports_of(mod):
        if not name.startswith(NAME):
            continue
        parts = name.split(".")
        for i in range(1, len(parts) + 1):
            t = ".".join(parts[:i])
            if t in MODULES and t not in own and t != mod:
                out.add(t)
    return out


GRAPH = {m: internal_targets(m) for m in MODULES}


def group(mod: str) -> str | None:
    for g in LAYERS:
        if mod == g or mod.startswith(g + "."):
            return g
    return None


def test_the_layers_are_what_ls_shows():
    top = sorted(p.name for p in PKG.iterdir() if not p.name.startswith(("_", ".")))
    assert top == sorted(
        ["commandline.py", "compat.py", "constitutive", "driver", "fem", "io", "loading.py"]
        + ["logs.py", "meshing", "py.typed", "scenes", "values.py"]
        + (["calibrate"] if (PKG / "calibrate").is_dir() else [])
    )
    for m in MODULES:
        assert m == NAME or group(m) is not None, f"{m} belongs to no layer"


def test_no_upward_or_sideways_import():
    bad = []
    for m, targets in GRAPH.items():
        gm = group(m)
        if gm is None:
            continue
        for t in targets:
            gt = group(t)
            if gt is None or gt == gm:
                continue
            if LAYERS[gt] >= LAYERS[gm]:
                bad.append(f"{m} -> {t}")
    assert not bad, "imports against the layering:\n" + "\n".join(sorted(bad))


def test_no_import_cycle():
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in sorted(GRAPH[m]):
            if state.get(t) == 1:
                cycles.append(" -> ".join([*stack[stack.index(t) :], t]))
            elif t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(GRAPH):
        if m not in state:
            visit(m)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def closure(start: str) -> set[str]:
    todo = [m for m in MODULES if m == start or m.startswith(start + ".")]
    seen = set(todo)
    while todo:
        for t in GRAPH[todo.pop()]:
            if t not in seen:
                seen.add(t)
                todo.append(t)
    return seen


@pytest.mark.parametrize("start", NUMPY_ONLY)
def test_numpy_only_layers_reach_nothing_else(start):
    """No DOLFINx, PETSc, MPI, gmsh (or anything but numpy and the standard library) is reachable
    from the constitutive core, the loading programs, the logs or the material-point driver."""
    reach = closure(start)
    external = set()
    for m in reach:
        assert group(m) in (*NUMPY_ONLY, None) or m == NAME, f"{start} reaches {m}"
        external |= {n.split(".")[0] for n in imports_of(m) if not n.startswith(NAME)}
    allowed = set(sys.stdlib_module_names) | {"numpy", "__future__"}
    assert external <= allowed, f"{start} reaches {sorted(external - allowed)}"


def test_numpy_only_layers_at_run_time():
    """The same, for real: importing them loads none of the heavy modules."""
    code = (
        "import sys\n"
        "import subfric_dolfinx.constitutive, subfric_dolfinx.driver, subfric_dolfinx.loading\n"
        "import subfric_dolfinx.logs, subfric_dolfinx.scenes, subfric_dolfinx.values\n"
        "import subfric_dolfinx.commandline\n"
        f"print(sorted(m for m in {sorted(HEAVY)!r} if m in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_imports(mod: str, tree: ast.AST) -> list[str]:
    """``from <another subpackage> import _name`` (or from its private module) in ``mod``."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        for a, target in zip(node.names, resolve(mod, node), strict=True):
            if not target.startswith(NAME) or group(target) == group(mod):
                continue
            hidden = [p for p in target.split(".")[1:] if is_private(p)]
            if is_private(a.name) or hidden:
                found.append(f"{mod}:{node.lineno}: {target} import {a.name}")
    return found


def test_no_private_name_crosses_a_subpackage():
    """A helper another subpackage needs is public in one home (issue 26): no module imports a
    ``_private`` name, or from a ``_private`` module, of another subpackage."""
    bad = [f for m, p in MODULES.items() for f in private_imports(m, ast.parse(p.read_text()))]
    assert not bad, "private names imported across subpackages:\n" + "\n".join(bad)


def test_the_private_import_check_sees_what_it_must():
    """Stand-in sources: the imports the calibration once made are caught, an import of a
    private name inside its own subpackage is not."""
    cases = {
        (f"{NAME}.calibrate.data", "from ..driver.case import _number, read_json"): 1,
        (f"{NAME}.calibrate.cli", "from subfric_dolfinx.driver.cli import _Parser"): 1,
        (f"{NAME}.scenes.build", "from ..meshing._msh import build"): 1,
        (f"{NAME}.driver.cli", "from .case import _parse"): 0,
        (f"{NAME}.scenes.parser", "from ..values import short_repr"): 0,
        (f"{NAME}.fem.solver", "from ..constitutive import __all__"): 0,
    }
    for (mod, source), n in cases.items():
        assert len(private_imports(mod, ast.parse(source))) == n, (mod, source)


def test_every_subpackage_says_what_it_is_and_may_import():
    for m, p in MODULES.items():
        if is_package(m) and m != NAME and group(m) == m:
            doc = ast.get_docstring(ast.parse(p.read_text())) or ""
            assert doc and "May import:" in doc, f"{m}: docstring without 'May import:'"


def test_no_module_is_too_long():
    sizes = {m: len(p.read_text().splitlines()) for m, p in MODULES.items()}
    too_long = {m: n for m, n in sizes.items() if n > MAX_LINES}
    assert not too_long, f"modules over {MAX_LINES} lines: {too_long}"
    long = {m: n for m, n in sizes.items() if n > LONG_LINES}
    if long:
        warnings.warn(f"modules over {LONG_LINES} lines: {long}", stacklevel=1)


TESTS = ROOT / "tests"
BEYOND_THE_PACKAGE = {"verification", "demos", "bad_inputs"}
"""Test folders that are no subpackage: reference comparisons, the repository's programs, the
catalogue of bad inputs."""
CROSS_CUTTING = {
    "test_architecture",
    "test_packaging",
    "test_runner",
    "test_commandline",
    "test_loading",
    "test_text",
}
"""The test modules at the top of tests/: the repository as a whole (layers, packaging, the
runner) and the package's top-level modules (commandline, loading, values)."""


def test_the_tests_mirror_the_package():
    """A test module lives in the folder of what it tests: ``tests/fem/interface/`` for
    :mod:`subfric_dolfinx.fem.interface`, or in a folder of :data:`BEYOND_THE_PACKAGE`; every
    folder is a package (its modules import as ``tests.<folder>.<module>``)."""
    for d in sorted({p.parent for p in TESTS.rglob("test_*.py")} - {TESTS}):
        rel = d.relative_to(TESTS)
        assert (d / "__init__.py").is_file(), f"tests/{rel} has no __init__.py"
        mirrored = (PKG / rel / "__init__.py").is_file()
        assert mirrored or (len(rel.parts) == 1 and rel.parts[0] in BEYOND_THE_PACKAGE), (
            f"tests/{rel} is no subpackage of {NAME} and none of {sorted(BEYOND_THE_PACKAGE)}"
        )
    top = {p.stem for p in TESTS.glob("test_*.py")}
    assert top == CROSS_CUTTING, f"test modules at the top of tests/: {sorted(top ^ CROSS_CUTTING)}"


LOADS_BY_PATH = {
    "spec_from_file_location",
    "SourceFileLoader",
    "module_from_spec",
    "run_path",
    "runpy",
    "importlib.util",
    "importlib.machinery",
}


def path_tricks(tree: ast.AST) -> list[str]:
    """Where a source touches ``sys.path`` or loads a file by its path (line numbers)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            dotted = f"{node.value.id}.{node.attr}"
            if dotted == "sys.path" or dotted in LOADS_BY_PATH or node.attr in LOADS_BY_PATH:
                found.append(f"line {node.lineno}: {dotted}")
        elif isinstance(node, ast.Name) and node.id in LOADS_BY_PATH:
            found.append(f"line {node.lineno}: {node.id}")
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            names = [a.name for a in node.names]
            names += [module, *(f"{module}.{a.name}" for a in node.names)] if module else []
            found += [f"line {node.lineno}: import {n}" for n in names if n in LOADS_BY_PATH]
    return found


def test_no_test_edits_sys_path_or_loads_a_file_by_path():
    """Tests import what they test by name (``docs.pages``, ``report.stamp``, ``demos.hertz``); a
    script is run as a process, never loaded into the test's. The one exception: conftest.py
    appends the repository to sys.path for a run without ``.ci/pytest-installed``'s .pth file."""
    bad = {
        str(p.relative_to(ROOT)): found
        for p in sorted(TESTS.rglob("*.py"))
        if p != TESTS / "conftest.py" and (found := path_tricks(ast.parse(p.read_text())))
    }
    assert not bad, bad
    for source in (
        "import sys\nsys.path.insert(0, 'x')",
        "from importlib.util import spec_from_file_location",
        "import runpy",
        "import importlib.util",
    ):
        assert path_tricks(ast.parse(source)), source
    assert not path_tricks(ast.parse("from docs.pages import public_modules\nimport os.path"))


def test_the_walker_sees_what_it_must():
    """The checks above are only as good as the graph: spot-check known edges."""
    assert f"{NAME}.constitutive.protocol" in GRAPH[f"{NAME}.constitutive.subloading"]
    assert f"{NAME}.fem.solver" in GRAPH[f"{NAME}.fem.stepping"]
    assert f"{NAME}.scenes.fe" in GRAPH[f"{NAME}.scenes.runner"]  # a function-level import
    assert f"{NAME}.constitutive" in GRAPH[f"{NAME}.io.checkpoint"]
    # an import of a module deep in another package runs its parent packages too (no module
    # of the package imports that way today: the rule is checked on a stand-in import)
    deep = f"{NAME}.fem.interface.small.element"
    real = globals()["imports_of"]
    globals()["imports_of"] = lambda mod: {deep}
    try:
        found = internal_targets(f"{NAME}.io.checkpoint")
    finally:
        globals()["imports_of"] = real
    assert found == {f"{NAME}.fem", f"{NAME}.fem.interface", f"{NAME}.fem.interface.small", deep}
