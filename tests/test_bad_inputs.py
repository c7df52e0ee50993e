"""A catalogue of bad inputs, one test each, on 1 and 2 ranks.

Every bad input must fail with a message that names the offending value (and the field, file,
channel or prefix it came in), raised on every rank alike (a rank raising alone would leave the
others waiting in the next collective), and leave no partial output (no output file, no
registered options prefix, no options set). :func:`raised_on_every_rank` gathers the outcome of
every rank and checks that all raised the same error with the same message.

Covered: parameters of both laws (every field out of range, NaN, +-inf, wrong type), NaN and inf
in a driver case (path, t_samples, steps_per_mm, params) by library and CLI with ``--out``, bad
``--steps-per-mm``, loading programs (non-increasing, non-finite or too few times, non-finite
channel values, channels of the wrong length, unknown channels), boundary conditions naming an
unknown channel or group, mesh files (missing, not a file, not a mesh, a required physical group
missing, interface sides that do not pair by count or by position, wrong dimension, bad gdim),
and options prefixes (empty, without the trailing '_', with '-' or spaces, not a string, in use).
Driver cases whose path needs an absurd number of steps (more than 1e7 between two knots,
or an overflowing magnitude) are refused before any step.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import pathlib
import subprocess
import sys

import pytest
from mpi4py import MPI
from petsc4py import PETSc
from test_interface_fe import block_problem, prefix

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import CoulombLaw, SubloadingLaw, preset
from subfric_dolfinx.driver import CaseError, load_case, main, parse_case, run_case
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceError,
    InterfaceProblem,
    Material,
    Pressure,
    Traction,
)
from subfric_dolfinx.loading import LoadingError, LoadingProgram

REPO = pathlib.Path(__file__).resolve().parents[1]
MESH_DIR = REPO / "meshes"
NAN, INF = float("nan"), float("inf")


@contextlib.contextmanager
def raised_on_every_rank(exc_type, *words):
    """Expect ``exc_type`` from the block on every rank, with the same message containing
    ``words``. The outcome is gathered from all ranks, so a rank that did not raise makes every
    rank fail (instead of hanging)."""
    comm = MPI.COMM_WORLD
    outcome = None
    try:
        yield
    except Exception as e:
        outcome = (type(e).__name__, isinstance(e, exc_type), str(e))
    everyone = comm.allgather(outcome)
    missing = [rank for rank, o in enumerate(everyone) if o is None]
    assert not missing, f"{exc_type.__name__} not raised on rank(s) {missing}: {everyone}"
    for rank, (name, ok, msg) in enumerate(everyone):
        assert ok, f"rank {rank} raised {name} ({msg}), expected {exc_type.__name__}"
    messages = {msg for _, _, msg in everyone}
    assert len(messages) == 1, f"the ranks raised different messages: {messages}"
    (msg,) = messages
    for w in words:
        assert w in msg, f"{w!r} not in the message {msg!r}"


# --------------------------------------------------------------------------------------------
# Parameters of the friction laws

SUB = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}
COUL = {"alpha_t": 1000.0, "alpha_n": 2000.0, "mu_c": 0.3}
OUT_OF_RANGE = {
    # field: values outside the allowed range, and the words of the range in the message
    "alpha_t": ([0.0, -500.0], "alpha_t > 0"),
    "alpha_n": ([0.0, -1e-300], "alpha_n > 0"),
    "mu_k": ([0.0, -63.0], "mu_k > 0"),
    "mu_s": ([62.9, -500.0], "mu_s >= mu_k = 63.0"),
    "kappa": ([-1e-3], "kappa >= 0"),
    "xi": ([-1.0], "xi >= 0"),
    "u_tilde": ([0.0, -15.0], "u_tilde > 0"),
    "c_n": ([0.0, -2e-4], "c_n > 0"),
    "mu0": ([500.1, 62.0], "mu_k <= mu0 <= mu_s = [63.0, 500.0]"),
    "mu_c": ([0.0, -0.3], "mu_c > 0"),
}
WRONG_TYPES = ["500", True, None, 1 + 0j, [500.0]]


def law_of(field):
    return (CoulombLaw, COUL) if field == "mu_c" else (SubloadingLaw, SUB)


def parameter_cases():
    """(field, value, exception, words) for every field of both laws; the kind is in the id."""
    cases = []

    def case(field, value, exc, words, kind):
        cases.append(pytest.param(field, value, exc, words, id=f"{field}-{kind}"))

    for field, (values, allowed) in OUT_OF_RANGE.items():
        for v in values:
            case(field, v, ValueError, [f"{field} = {v!r}", allowed], f"range{v!r}")
        for v in (NAN, INF, -INF):
            case(field, v, ValueError, [f"{field} = {v!r}", "not finite"], repr(v))
        for v in WRONG_TYPES:
            if not (field == "mu0" and v is None):  # None is mu0's default (mu_s)
                case(field, v, TypeError, [field, "real number", repr(v)], type(v).__name__)
    # the Coulomb law's penalties are validated as well
    for field in ("alpha_t", "alpha_n"):
        for v, exc in [(-1.0, ValueError), (NAN, ValueError), (INF, ValueError), ("1", TypeError)]:
            case(f"coulomb.{field}", v, exc, [f"parameter {field}", repr(v)], repr(v))
    return cases


@pytest.mark.parametrize(("field", "value", "exc", "words"), parameter_cases())
def test_invalid_parameter(field, value, exc, words):
    if field.startswith("coulomb."):
        cls, valid, field = CoulombLaw, COUL, field.split(".", 1)[1]
    else:
        cls, valid = law_of(field)
    with raised_on_every_rank(exc, *words):
        cls(**{**valid, field: value})


def test_invalid_parameter_through_replace():
    with raised_on_every_rank(ValueError, "kappa = -1.0", "kappa >= 0"):
        preset("sec7").replace(kappa=-1.0)


def test_missing_parameter():
    with raised_on_every_rank(TypeError, "c_n"):
        SubloadingLaw(**{k: v for k, v in SUB.items() if k != "c_n"})


# --------------------------------------------------------------------------------------------
# Driver: CASE.json (library and CLI with --out)

CASE = {
    "params": {"preset": "sec7"},
    "control": "disp",
    "path": [[0.0, 0.0, 0.0, 1.2], [0.3, 0.3, 0.0, 1.2], [0.5, 0.3, 0.2, 1.2]],
    "t_samples": [0.0, 0.3, 0.5],
    "n_tangential": 2,
    "steps_per_mm": 100,
}


def mutated(where, value):
    """A copy of CASE with the item at ``where`` (a tuple of keys/indices) set to ``value``."""
    case = json.loads(json.dumps(CASE))
    obj = case
    for k in where[:-1]:
        obj = obj[k]
    obj[where[-1]] = value
    return case


def run_cli(tmp_path, case, *args):
    """Write ``case`` (NaN and inf as JSON's NaN/Infinity) and run the CLI's main in-process
    with ``--out``; return (exit code, out path)."""
    f = tmp_path / "case.json"
    f.write_text(json.dumps(case))  # allow_nan: the tokens NaN, Infinity, -Infinity
    out = tmp_path / "result.json"
    return main([str(f), "--out", str(out), *args]), out


NON_FINITE_CASES = [
    (("path", 1, 0), NAN, "path[1][0]"),
    (("path", 1, 1), NAN, "path[1][1]"),
    (("path", 2, 2), INF, "path[2][2]"),
    (("path", 0, 3), -INF, "path[0][3]"),
    (("path", 2, 0), INF, "path[2][0]"),
    (("t_samples", 1), NAN, "t_samples[1]"),
    (("t_samples", 2), INF, "t_samples[2]"),
    (("t_samples", 0), -INF, "t_samples[0]"),
    (("steps_per_mm",), INF, "steps_per_mm"),
    (("steps_per_mm",), NAN, "steps_per_mm"),
]


@pytest.mark.parametrize(
    ("where", "value", "field"),
    NON_FINITE_CASES,
    ids=[f"{f}={v!r}" for _, v, f in NON_FINITE_CASES],
)
def test_case_with_non_finite_value(tmp_path, capsys, where, value, field):
    case = mutated(where, value)
    words = [f"'{field}'", repr(value)]
    with raised_on_every_rank(CaseError, *words):
        parse_case(case)
    (tmp_path / "c.json").write_text(json.dumps(case))
    with raised_on_every_rank(CaseError, *words):
        load_case(tmp_path / "c.json")
    code, out = run_cli(tmp_path, case)
    err = capsys.readouterr()
    assert code == 2 and err.out == "" and err.err.startswith("error: ")
    assert all(w in err.err for w in words), err.err
    assert not out.exists(), "a bad case created the output file"


@pytest.mark.parametrize("value", [NAN, INF, -1.0])
def test_case_with_invalid_parameter_value(tmp_path, capsys, value):
    case = mutated(("params", "kappa"), value)
    with raised_on_every_rank(CaseError, "'params'", f"kappa = {value!r}"):
        parse_case(case)
    code, out = run_cli(tmp_path, case)
    assert code == 2 and f"kappa = {value!r}" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("value", ["0", "-5", "nan", "inf"])
def test_cli_bad_steps_per_mm(tmp_path, capsys, value):
    code, out = run_cli(tmp_path, CASE, "--steps-per-mm", value)
    err = capsys.readouterr().err
    assert code == 2 and "--steps-per-mm" in err and repr(float(value)) in err, err
    assert not out.exists()


@pytest.mark.parametrize("value", [1e300, 1e100, 1e12])
def test_case_with_absurd_path_magnitude(tmp_path, capsys, value):
    """A path change needing more than 1e7 steps per segment (overflowing at 1e300 mm)."""
    case = mutated(("path", 1, 1), value)
    with raised_on_every_rank(CaseError, "field 'path'", f"{value:g} mm", "steps_per_mm = 100"):
        run_case(case)
    code, out = run_cli(tmp_path, case)
    err = capsys.readouterr().err
    assert code == 2 and "field 'path'" in err and f"{value:g} mm" in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("where", "value", "field"), [(("path", 1, 1), NAN, "path[1][1]"), (("t_samples", 1), INF,
                                                                         "t_samples[1]")]
)  # fmt: skip
def test_cli_process_on_a_bad_case_writes_nothing(tmp_path, where, value, field):
    """The real command line (a separate process): exit code 2, the field named, no file."""
    f = tmp_path / "case.json"
    f.write_text(json.dumps(mutated(where, value)))
    out = tmp_path / "result.json"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run(
        [sys.executable, "-m", "subfric_dolfinx.driver", str(f), "--out", str(out)],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert f"'{field}'" in proc.stderr and repr(value) in proc.stderr
    assert proc.stdout == "" and not out.exists()


# --------------------------------------------------------------------------------------------
# Loading programs

TIMES = [0.0, 1.0, 2.0, 3.0]
LOADING_CASES = {
    # name: (times, channels, words)
    "times-equal": ([0.0, 1.0, 1.0, 2.0], {}, ["times[2] = 1.0 after times[1] = 1.0"]),
    "times-decreasing": ([0.0, 2.0, 1.0, 3.0], {}, ["times[2] = 1.0 after times[1] = 2.0"]),
    "times-nan": ([0.0, NAN, 2.0, 3.0], {}, ["times[1] = nan", "not finite"]),
    "times-inf": ([0.0, 1.0, 2.0, INF], {}, ["times[3] = inf", "not finite"]),
    "times-minus-inf": ([-INF, 1.0, 2.0, 3.0], {}, ["times[0] = -inf", "not finite"]),
    "times-single": ([0.0], {}, ["at least two breakpoints", "[0.0]"]),
    "times-empty": ([], {}, ["at least two breakpoints", "[]"]),
    "times-2d": ([[0.0, 1.0], [2.0, 3.0]], {}, ["at least two breakpoints", "[[0.0, 1.0]"]),
    "channel-nan": (TIMES, {"slide": [0.0, NAN, 1.0, 1.0]}, ["'slide'", "[1] = nan"]),
    "channel-inf": (TIMES, {"slide": [0.0, 1.0, 1.0, -INF]}, ["'slide'", "[3] = -inf"]),
    "channel-short": (
        TIMES,
        {"press": [0, 1, 1, 1], "slide": [0, 1, 1]},
        ["'slide'", "3 values for 4 breakpoint times"],
    ),
    "channel-long": (TIMES, {"slide": [0, 1, 1, 1, 1]}, ["'slide'", "5 values for 4"]),
    "channel-scalar": (TIMES, {"slide": 1.0}, ["'slide'", "1 values for 4"]),
}


@pytest.mark.parametrize("name", list(LOADING_CASES))
def test_bad_loading_program(name):
    times, channels, words = LOADING_CASES[name]
    with raised_on_every_rank(LoadingError, *words):
        LoadingProgram(times, channels)


def test_unknown_channel_of_a_loading_program():
    program = LoadingProgram(TIMES, {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})
    with raised_on_every_rank(LoadingError, "'slyde'", "['press', 'slide']"):
        program.amplitude("slyde", 0.5)


# --------------------------------------------------------------------------------------------
# Boundary conditions of a problem

PROGRAM = LoadingProgram(TIMES, {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})
MATERIALS = {"master": Material(2.0e4, 0.3), "slave": Material(2.0e4, 0.3)}


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
    with raised_on_every_rank(InterfaceError, "['clamp']"):
        InterfaceProblem(block_mesh, preset("sec7"), MATERIALS, PROGRAM, bcs)


# --------------------------------------------------------------------------------------------
# Mesh files

MESH_CASES = {
    # name: (file, gdim, exception, words)
    "missing-file": ("no_such_mesh.msh", 2, FileNotFoundError, ["mesh file not found"]),
    "no-interface-group": (
        "broken_no_interface.msh", 2, meshing.InterfaceMeshError,
        ["required physical group 'interface' not found"],
    ),
    "sides-count-differ": (
        "broken_mismatch_count.msh", 2, meshing.InterfaceMeshError,
        ["8 on the 'master' side, 9 on the 'slave' side"],
    ),
    "3d-mesh-read-as-2d-tet": (
        "pad_on_plate_tet.msh", 2, meshing.InterfaceMeshError,
        ["expected a 2-D mesh", "found cells of topological dimension 3"],
    ),
    "3d-mesh-read-as-2d-hex": (
        "pad_on_plate_hex.msh", 2, meshing.InterfaceMeshError,
        ["expected a 2-D mesh", "found cells of topological dimension 3"],
    ),
    "2d-mesh-read-as-3d": (
        "block_on_base_quad.msh", 3, meshing.InterfaceMeshError,
        ["expected a 3-D mesh", "found cells of topological dimension 2"],
    ),
}  # fmt: skip


@pytest.mark.parametrize("name", list(MESH_CASES))
def test_bad_mesh_file(name):
    file, gdim, exc, words = MESH_CASES[name]
    path = MESH_DIR / file
    with raised_on_every_rank(exc, str(path), *words):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, gdim)


def test_mesh_without_a_required_boundary_group():
    path = MESH_DIR / "block_on_base_tri.msh"
    required = (*meshing.REQUIRED_GROUPS, "clamp")
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path), "'clamp' not found"):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2, required=required)


def test_mesh_path_is_a_directory():
    with raised_on_every_rank(FileNotFoundError, "mesh file not found", str(MESH_DIR)):
        meshing.read_interface_mesh(MESH_DIR, MPI.COMM_WORLD, 2)


@pytest.mark.parametrize("content", ["this is not a mesh\n", ""], ids=["garbage", "empty"])
def test_file_that_is_not_a_mesh(shared_tmp, content):
    path = shared_tmp / "not_a_mesh.msh"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(content)
    MPI.COMM_WORLD.Barrier()
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path)):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)


@pytest.mark.parametrize("gdim", [1, 4, 2.5, "2"])
def test_bad_gdim(gdim):
    with raised_on_every_rank(ValueError, f"gdim must be 2 or 3, got {gdim!r}"):
        meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, gdim)


def test_interface_sides_that_do_not_pair_node_to_node():
    """Equal facet counts (the reader accepts it) but nodes at different places."""
    path = MESH_DIR / "broken_mismatch_coords.msh"
    dom = meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)
    with raised_on_every_rank(InterfaceError, "do not pair node to node", "at ["):
        InterfaceProblem(dom, preset("sec7"), MATERIALS, PROGRAM)


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
        ("", ["non-empty string ending in '_'", "''"]),
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


def test_every_field_of_both_laws_is_in_the_catalogue():
    """Guard: a new parameter field must get its bad-input cases here."""
    fields = {f.name for c in (SubloadingLaw, CoulombLaw)
              for f in dataclasses.fields(c)}  # fmt: skip
    assert fields == set(OUT_OF_RANGE), sorted(fields ^ set(OUT_OF_RANGE))
