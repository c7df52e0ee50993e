"""Bad problems and solvers: boundary conditions naming an unknown loading channel or group;
options prefixes that are empty, malformed or already in use."""

import pytest
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceError,
    InterfaceProblem,
    Material,
    Pressure,
    ProblemSettings,
    Traction,
)
from subfric_dolfinx.loading import LoadingError, LoadingProgram
from tests.helpers import MESH_DIR, block_problem, prefix, raised_on_every_rank

PROGRAM = LoadingProgram([0.0, 1.0, 2.0, 3.0], {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})
MATERIALS = {"primary": Material(2.0e4, 0.3), "secondary": Material(2.0e4, 0.3)}


@pytest.fixture(scope="module")
def block_mesh():
    return meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, 2)


@pytest.mark.parametrize(
    ("condition", "words"),
    [
        (Dirichlet("top", 0.3, component=0, amplitude="slyde"), ["'slyde'", "'slide'"]),
        (Pressure("top", 300.0, amplitude="pres"), ["'pres'", "['press', 'slide']"]),
        (Traction("top", (1.0, -1.0), amplitude="Press"), ["'Press'"]),
    ],
    ids=["dirichlet", "pressure", "traction"],
)
def test_condition_with_unknown_loading_channel(block_mesh, condition, words):
    bcs = [Dirichlet("bottom", (0.0, 0.0))]
    loads = []
    (bcs if isinstance(condition, Dirichlet) else loads).append(condition)
    with raised_on_every_rank(LoadingError, "unknown loading channel", *words):
        InterfaceProblem(block_mesh, preset("sec7"), MATERIALS, PROGRAM, bcs, loads)


def test_condition_on_unknown_group(block_mesh):
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("clamp", (0.0, 0.0))]
    with raised_on_every_rank(InterfaceError, "lacks the physical group(s) ['clamp']"):
        InterfaceProblem(block_mesh, preset("sec7"), MATERIALS, PROGRAM, bcs)


# --------------------------------------------------------------------------------------------
# Options prefixes of the solver


@pytest.fixture(scope="module")
def problem():
    return block_problem(MPI.COMM_WORLD)


def options_under(pfx):
    return sorted(k for k in PETSc.Options().getAll() if k.startswith(pfx))


@pytest.mark.parametrize(
    ("pfx", "words"),
    [
        ("", ["options prefix", "non-empty string ending in '_'", "''"]),
        ("block", ["ending in '_'", "'block'"]),
        ("block-1_", ["must not contain spaces or '-'", "'block-1_'"]),
        ("-block_", ["must not contain spaces or '-'", "'-block_'"]),
        ("my block_", ["must not contain spaces or '-'", "'my block_'"]),
        (7, ["non-empty string", "7"]),
    ],
    ids=["empty", "no-underscore", "dash", "leading-dash", "space", "int"],
)
def test_bad_options_prefix(problem, pfx, words):
    before = PETSc.Options().getAll()
    with raised_on_every_rank(ValueError, *words):
        FrictionSolver(problem, pfx)
    assert PETSc.Options().getAll() == before  # nothing set under the bad prefix


def test_options_prefix_in_use(problem):
    name = prefix("dup")
    first = FrictionSolver(problem, name)
    before = options_under(name)
    try:
        with raised_on_every_rank(ValueError, f"{name!r} is already used"):
            FrictionSolver(problem, name, {"snes_max_it": 1})
        assert options_under(name) == before  # the live solver's options are untouched
        assert first.snes.getTolerances()[3] == 30  # max_it: not the refused {"snes_max_it": 1}
    finally:
        first.destroy()
    FrictionSolver(problem, name).destroy()  # usable again once released


# --------------------------------------------------------------------------------------------
# Axisymmetric meshes: r >= 0 (issue 36)


@pytest.mark.parametrize(
    ("shift", "words"),
    [
        (-1.0, ["it lies at r < 0", "r from -1 to 0"]),
        (-0.5, ["it crosses the axis", "r from -0.5 to 0.5"]),
        (-1e-9, ["it crosses the axis", "r from -1e-09"]),
    ],
    ids=["r<0", "across the axis", "a hair across"],
)
def test_an_axisymmetric_mesh_at_negative_radius_is_refused(shift, words):
    """The column of tests/fem/test_bulk.py (r in [0, 1]) moved along r: pressed, it gave
    F_n = -3769.9 (r < 0) or 2.9e-10 (across the axis) where p pi R^2 is due."""
    from subfric_dolfinx.fem.kinematics import ModeError
    from tests.helpers import column

    dom, bcs = column("axisymmetric", MPI.COMM_WORLD)

    def pressed() -> InterfaceProblem:
        return InterfaceProblem(
            dom,
            preset("sec7"),
            MATERIALS,
            PROGRAM,
            bcs,
            [Pressure("top", 1.0, "press")],
            settings=ProblemSettings(mode="axisymmetric"),
        )

    dom.mesh.geometry.x[:, 0] += shift
    with raised_on_every_rank(
        ModeError, "mode 'axisymmetric' needs the mesh in r = x >= 0", *words
    ):
        pressed()
    dom.mesh.geometry.x[:, 0] -= shift + 1e-13  # on the axis up to round-off: accepted
    pressed()
