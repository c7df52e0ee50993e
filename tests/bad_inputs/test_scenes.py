"""Bad scenes and checkpoints: configurations with an unknown key, a wrong type or a value out of
range (the path to it named), files requested without a directory; checkpoints that are missing,
truncated, foreign or written for another law or mesh."""

import copy
import json

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.fem import InterfaceError
from subfric_dolfinx.io import CheckpointError, read_checkpoint
from subfric_dolfinx.scenes import SceneError, load_scene, parse_scene, run_scene
from tests.helpers import everywhere, on_root, prefix, raised_on_every_rank, small_scene


@pytest.mark.parametrize(
    ("mutate", "pattern"),
    [
        (lambda s: s.update(colour="red"), r"scene: unknown key\(s\) \['colour'\]"),
        (lambda s: s["solver"].update(dt="fast"), r"scene.solver.dt: expected a number"),
        (lambda s: s["solver"].update(dt=-1.0), r"scene.solver.dt: must be > 0"),
        (lambda s: s["solver"].pop("dt"), r"scene.solver: missing key 'dt'"),
        (lambda s: s["mesh"].update(builder="teapot"), r"scene.mesh.builder: must be one of"),
        (
            lambda s: s["mesh"]["options"].update(n_interface=4) or s["mesh"].update(file="x.msh"),
            r"scene.mesh: give exactly one",
        ),
        (lambda s: s["dirichlet"][1].update(componnt=0), r"scene.dirichlet\[1\]: unknown key"),
        (lambda s: s["loads"][0].update(type="suction"), r"scene.loads\[0\].type: must be one of"),
        (
            lambda s: s["materials"]["secondary"].update(G=1.0),
            r"scene.materials.secondary: keys must be",
        ),
        (lambda s: s["law"]["params"].update(kappa=-1.0), r"scene.law: .*kappa"),
        (
            lambda s: s["program"]["times"].__setitem__(2, 0.5),
            r"scene.program: times must increase",
        ),
        (
            lambda s: s["outputs"].update(history="yes"),
            r"scene.outputs.history: expected true or false",
        ),
        (lambda s: s.update(degree=3), r"scene.degree: must be one of \[1, 2\]"),
        (lambda s: s.update(kind="movie"), r"scene.kind: must be one of"),
        # types the dataclasses alone would let through (issue 12, item 9)
        (
            lambda s: s["loads"][0].update(value=[300.0, 0.0]),
            r"scene.loads\[0\].value: a pressure is a number, got a list",
        ),
        (
            lambda s: s["loads"][0].update(type="traction"),
            r"scene.loads\[0\].value: a traction is a list",
        ),
        (
            lambda s: s["dirichlet"][1].update(value=[1.0, 0.0]),
            r"scene.dirichlet\[1\].value: a list .*with 'component' = 0",
        ),
        (
            lambda s: s["dirichlet"][0].update(value=0.0),
            r"scene.dirichlet\[0\].value: a number \(0.0\) needs 'component'",
        ),
        (
            lambda s: s["dirichlet"][1].update(component=5),
            r"scene.dirichlet\[1\].component: must be 0, 1 or 2",
        ),
        (
            lambda s: s["loads"][0].update(value=10**400),
            r"scene.loads\[0\].value: expected a finite number, got an integer of 401 digits",
        ),
        (
            lambda s: s["solver"].update(dt=10**400),
            r"scene.solver.dt: expected a finite number, got an integer of 401 digits",
        ),
        (
            lambda s: s["solver"].update(max_cuts=10**400),
            r"scene.solver.max_cuts: integer out of range",
        ),
        (
            lambda s: s["program"]["times"].__setitem__(5, 10**400),
            r"scene.program.times\[5\]: number out of range",
        ),
        (
            lambda s: s["mesh"]["options"].update(n_interface=10**400),
            r"scene.mesh.options.n_interface: number out of range",
        ),
        (
            lambda s: s["materials"]["primary"].update(E=10**400),
            r"scene.materials.primary.E: expected a finite number",
        ),
        (
            lambda s: s["solver"].update(options={"snes_rtol": [1e-8, 1e-9]}),
            r"scene.solver.options.snes_rtol: a PETSc option value is a string, number",
        ),
        (
            lambda s: s["solver"].update(options={"snes_rtol": {"a": 1}}),
            r"scene.solver.options.snes_rtol: a PETSc option value",
        ),
        (
            lambda s: s["solver"].update(options={"-snes_rtol": 1e-8}),
            r"scene.solver.options.-snes_rtol: not a PETSc option name",
        ),
        (
            lambda s: s["solver"].update(linear="cholesky"),
            r"scene.solver.linear: must be one of \['auto', 'reuse', 'lu', 'gamg'\], "
            r"got 'cholesky'",
        ),
        # keys that would be ignored silently
        (
            lambda s: s.update(
                mesh={"file": "meshes/block_on_base_tri.msh", "gdim": 2, "options": {"n": 4}}
            ),
            r"scene.mesh.options: builder options \['n'\] given with a mesh file",
        ),
        (
            lambda s: s["mesh"].update(gdim=3),
            r"scene.mesh.gdim: the builder 'block_on_base' makes a 2-D mesh, got gdim = 3",
        ),
        (
            lambda s: s["outputs"].update(snapshots=[1.0, 99.0]),
            r"scene.outputs.snapshots\[1\]: 99.0 is outside the loading program \[0, 11\]",
        ),
        (
            lambda s: s["outputs"].update(checkpoint_times=[-1.0]),
            r"scene.outputs.checkpoint_times\[0\]: -1.0 is outside the loading program",
        ),
        (
            lambda s: s["outputs"].update(fields="vtx", field_times=[2.0, 12.0]),
            r"scene.outputs.field_times\[1\]: 12.0 is outside the loading program",
        ),
        (
            lambda s: s["outputs"].update(field_times=[2.0]),
            r"scene.outputs.field_times: given, but no fields are written",
        ),
        (lambda s: s["solver"].update(dt_min=1.0), r"scene.solver.dt_min: must be in \[0, dt"),
        (lambda s: s["solver"].update(dt_min=-1e-3), r"scene.solver.dt_min: must be in \[0, dt"),
        (lambda s: s["solver"].update(dt_max=0.01), r"scene.solver.dt_max: must be >= dt"),
        (lambda s: s["solver"].update(max_cuts=-1), r"scene.solver.max_cuts: must be >= 0"),
        (lambda s: s["solver"].update(hold_dt=0.0), r"scene.solver.hold_dt: must be > 0"),
        # issue 23, item 7: before the mesh is built, each naming its key path
        (
            lambda s: s.update(initial_gap={"expression": "1" + "0" * 400 + " * x"}),
            r"scene.initial_gap.expression: a number \(an integer of 401 digits\) is not finite",
        ),
        (
            lambda s: s.update(initial_gap={"expression": "p * x", "parameters": {"p": 10**400}}),
            r"scene.initial_gap.expression: parameter 'p' must be a finite number",
        ),
        (
            lambda s: s.update(initial_gap={"circle": {"R": 10**400, "center": [1, 0.5]}}),
            r"scene.initial_gap.circle.R: must be a positive finite number",
        ),
        (lambda s: s.update(initial_gap=10**400), r"scene.initial_gap: expected a finite number"),
        (
            lambda s: s["loads"].append({"type": "traction", "group": "top", "value": [1, 2, 3]}),
            r"scene.loads\[1\].value: expected a list of 2 traction components",
        ),
        (
            lambda s: s["materials"]["secondary"].update(E=-1.0),
            r"scene.materials.secondary: parameter E = -1.0 is out of range; allowed: E > 0",
        ),
        (
            lambda s: s["materials"]["primary"].update(nu=0.6),
            r"scene.materials.primary: parameter nu = 0.6 is out of range; allowed: -1 < nu < 0.5",
        ),
        (
            lambda s: s["materials"]["secondary"].update(nu=-1.0),
            r"scene.materials.secondary: parameter nu = -1.0 is out of range; "
            r"allowed: -1 < nu < 0.5",
        ),
        # issue 22: an interface's kind and the settings of finite sliding
        (
            lambda s: s.update(interfaces={"interface": {"kinematics": "large_sliding"}}),
            r"scene.interfaces.interface.kinematics: must be one of \['small_sliding', "
            r"'finite_sliding'\], got 'large_sliding'",
        ),
        (
            lambda s: s.update(interfaces={"interface": {"kinematics": 1}}),
            r"scene.interfaces.interface.kinematics: expected str or null, got 1",
        ),
        (
            lambda s: s.update(
                interfaces={"interface": {"kinematics": "finite_sliding", "reach": -0.1}}
            ),
            r"scene.interfaces.interface.reach: must be > 0 \(mm\), got -0.1",
        ),
        (
            lambda s: s.update(
                interfaces={"interface": {"kinematics": "finite_sliding", "search_radius": 0}}
            ),
            r"scene.interfaces.interface.search_radius: must be > 0 \(mm\), got 0",
        ),
        (
            lambda s: s.update(
                interfaces={"interface": {"kinematics": "finite_sliding", "reach": "far"}}
            ),
            r"scene.interfaces.interface.reach: expected float or null, got 'far'",
        ),
        (
            lambda s: s.update(interfaces={"interface": {"reach": 0.5}}),
            r"scene.interfaces.interface.reach: a finite-sliding setting, but the interface "
            r"slides small",
        ),
        (
            lambda s: s.update(
                interfaces={"interface": {"kinematics": "small_sliding", "search_radius": 0.5}}
            ),
            r"scene.interfaces.interface.search_radius: a finite-sliding setting",
        ),
        (
            lambda s: s.update(
                interfaces={
                    "interface": {
                        "kinematics": "finite_sliding",
                        "regions": {"left": {"law": "teapot", "params": {}}},
                    }
                }
            ),
            r"scene.interfaces.interface.regions.left: .*'law'",
        ),
        # a name is a plain file name
        *[
            (lambda s, n=n: s.update(name=n), r"scene.name: must be a plain file name")
            for n in ["../x", "/tmp/x", "a/b", "", ".", "..", "a\x00b", "a\\b", "x" * 101]
        ],
    ],
)
def test_bad_scene_configs_are_named(mutate, pattern):
    s = copy.deepcopy(small_scene())
    mutate(s)
    with raised_on_every_rank(SceneError, match=pattern):
        parse_scene(s)


def test_a_negative_poisson_ratio_is_a_material_like_any_other(shared_tmp):
    """One elastic material, one validation (issue 34 item 5): ``-1 < nu < 0.5``, in the parser
    and in the problem alike (an auxetic ``nu = -0.2`` once passed the parser and was refused
    after the mesh was built). The block is pressed: the interface carries the pressure times
    the 1 mm width."""
    s = copy.deepcopy(small_scene(short=True))
    s["materials"]["secondary"]["nu"] = -0.2
    s["program"] = {"times": [0, 1], "channels": {"press": [0, 1], "slide": [0, 0]}}
    s["solver"]["prefix"] = prefix("nu")
    run = run_scene(s, outdir=shared_tmp, comm=MPI.COMM_WORLD)
    assert abs(run.history[-1]["F_n"] - 300.0) < 1e-8 * 300.0


@pytest.mark.parametrize("name", ["../escaped", "/tmp/absolute", "sub/dir", "", "..", "a\x00"])
def test_a_pointwise_scene_name_is_a_plain_file_name(tmp_path, name):
    """The name becomes ``<outdir>/<name>.json``: it may not leave the output directory."""
    case = {
        "params": {"preset": "sec7"},
        "path": [[0, 0, 0, 1.2], [1, 1, 0, 1.2]],
        "t_samples": [1],
    }
    scene = {"kind": "pointwise", "name": name, "cases": {"a": case}, "save": True}
    with raised_on_every_rank(SceneError, "scene.name: must be a plain file name"):
        run_scene(scene, outdir=tmp_path / "out")
    assert not (tmp_path / "out").exists() and not (tmp_path / "escaped.json").exists()


def test_a_petsc_option_petsc_refuses_is_named():
    """Issue 23, item 7: ``"snes_rtol": "abc"`` ended in "error code 63" without the key. Now
    the scene's key path and the value are named, on every rank (a type name PETSc does not
    know too); through the library, a SolverOptionError naming the prefixed option."""
    from subfric_dolfinx.fem import FrictionSolver, SolverOptionError
    from tests.helpers import block_problem

    for key, value, code in (("snes_rtol", "abc", 63), ("ksp_type", "nosuchksp", 86)):
        s = small_scene()
        s["solver"]["prefix"] = prefix("badopt")
        s["solver"]["options"] = {"snes_max_it": 20, key: value}
        with raised_on_every_rank(
            SceneError,
            f"scene.solver.options.{key}: PETSc refuses the option",
            f"{key} = {value!r}",
            f"error code {code}",
        ):
            run_scene(s)
    prob = block_problem(MPI.COMM_WORLD)
    with raised_on_every_rank(SolverOptionError, "the option badsolver_snes_max_it = 'many'"):
        FrictionSolver(prob, "badsolver_", {"snes_max_it": "many"})
    with FrictionSolver(prob, "badsolver_") as solver:  # the prefix was released
        assert solver.alive


@pytest.mark.parametrize(
    ("old", "new", "path"),
    [
        ('"dt": ', '"dt": 1.0, "dt": ', "scene.solver.dt"),
        ('"type": "pressure"', '"type": "pressure", "type": "traction"', "scene.loads[0].type"),
        ('"kind": "fe"', '"kind": "fe", "kind": "pointwise"', "scene.kind"),
    ],
    ids=["solver", "in-a-list", "top"],
)
def test_a_scene_file_with_a_key_twice_is_refused_naming_its_path(shared_tmp, old, new, path):
    """Issue 23, item 7: a scene file with a key given twice (``json.load`` keeps the last one
    silently) is refused by ``run_scene(file)``/``load_scene``, naming the key path, on every
    rank, before anything is built; the same file without the repetition runs as the dict."""
    comm = MPI.COMM_WORLD
    s = small_scene()
    s["solver"]["prefix"] = prefix("file")
    s["program"] = {"times": [0, 0.2], "channels": {"press": [0, 0.2], "slide": [0, 0]}}
    text = json.dumps(s)
    good, bad = shared_tmp / "scene.json", shared_tmp / "twice.json"

    def write():
        assert text.count(old) == 1, old
        good.write_text(text)
        bad.write_text(text.replace(old, new))

    on_root(comm, write)
    comm.Barrier()
    key = path.rsplit(".", 1)[1]
    with raised_on_every_rank(
        SceneError, repr(str(bad)), f"has the key {key!r} twice in one object: {path} (beside"
    ):
        run_scene(bad, comm=comm)
    assert everywhere(comm, load_scene(good) == parse_scene(s))  # not on one rank: no hang
    assert run_scene(str(good), comm=comm).history[-1]["t"] == pytest.approx(0.2)


def test_a_load_or_spring_on_a_cell_group_says_so():
    """A load or a spring on a group of cells, not facets, is named as such instead of failing
    later as a step that does not converge (a Dirichlet condition on a cell group is a feature:
    every dof of the body is held, ``tests/fem/test_loads_constraints.py``)."""
    for key, entry in (
        ("loads", {"type": "pressure", "group": "primary", "value": 1.0}),
        ("springs", {"group": "secondary", "stiffness": 1.0}),
    ):
        s = small_scene()
        s["solver"]["prefix"] = prefix("cells")
        s.setdefault(key, []).append(entry)
        with raised_on_every_rank(
            InterfaceError, repr(entry["group"]), "a group of cells (dimension 2), not of facets"
        ):
            run_scene(s)


def test_files_requested_without_a_directory_are_refused():
    s = small_scene()
    s["outputs"]["history"] = True
    with raised_on_every_rank(SceneError, "no output directory"):
        run_scene(s)


def scene(**outputs):
    s = small_scene(short=True)
    s["outputs"] = dict(outputs)
    s["solver"]["prefix"] = prefix("ck")
    return s


def test_bad_checkpoints_are_refused(shared_tmp):
    comm = MPI.COMM_WORLD
    run_scene(scene(checkpoint_every=3), outdir=shared_tmp, comm=comm)
    good = shared_tmp / "checkpoint.h5"
    assert read_checkpoint(good, comm).attrs["step"] % 3 == 0

    def write_bad_files():
        data = good.read_bytes()
        (shared_tmp / "truncated.h5").write_bytes(data[: len(data) // 3])
        with h5py.File(shared_tmp / "foreign.h5", "w") as f:
            f["x"] = np.zeros(3)

    on_root(comm, write_bad_files)
    cases = [
        ("missing.h5", "does not exist"),
        ("truncated.h5", "not a readable HDF5 file"),
        ("foreign.h5", "not a subfric-dolfinx checkpoint"),
    ]
    for name, pattern in cases:
        with raised_on_every_rank(CheckpointError, pattern):
            run_scene(scene(), comm=comm, restart=shared_tmp / name)
    other = scene()
    other["law"]["params"]["mu0"] = 400.0
    with raised_on_every_rank(CheckpointError, "was written with law"):
        run_scene(other, comm=comm, restart=good)
    finer = scene()
    finer["mesh"]["options"]["n_interface"] = 12
    with raised_on_every_rank(CheckpointError, "n_cells"):
        run_scene(finer, comm=comm, restart=good)


# --------------------------------------------------------------------------------------------
# The interface beyond its law: initial gaps and regions


@pytest.mark.parametrize(
    ("key", "value", "pattern"),
    [
        ("initial_gap", "0.1", r"scene.initial_gap: expected a number or an object"),
        ("initial_gap", float("nan"), r"scene.initial_gap: expected a finite number"),
        ("initial_gap", {"expression": "__import__('os')"}, r"unknown function '__import__'"),
        ("initial_gap", {"expression": "x.real"}, r"scene.initial_gap.expression: Attribute"),
        ("initial_gap", {"parabola": {"R": 0, "center": [1, 0.5]}}, r"parabola.R: must be"),
        ("regions", [1], r"scene.regions: expected an object"),
        ("regions", {"default": {"law": "coulomb"}}, r"scene.regions: 'default' cannot name"),
        ("regions", {"rough": {"law": "coulomb", "params": {"mu_c": -1}}}, r"scene.regions.rough:"),
        ("regions", {"rough": {"law": "teapot", "params": {}}}, r"scene.regions.rough: .*'law'"),
        ("regions", {"rough": {"laws": "coulomb"}}, r"scene.regions.rough: expected"),
    ],
)
def test_bad_gaps_and_regions_are_named(key, value, pattern):
    s = copy.deepcopy(small_scene())
    s[key] = value
    with raised_on_every_rank(SceneError, match=pattern):
        parse_scene(s)


@pytest.mark.parametrize(
    ("gap", "words"),
    [
        ({"expression": "sqrt(x - 1)"}, "the initial gap is not finite at ("),
        ({"expression": "1 / (x - x)"}, "the initial gap is not finite at ("),
        ({"circle": {"R": 0.2, "center": [1.0, 0.5]}}, "farther than R = 0.2 from the centre"),
        ({"expression": "z"}, "unknown name 'z'"),
    ],
)
def test_a_gap_that_cannot_be_evaluated_is_named(gap, words):
    """Found when the mesh is known (the points, their dimension), on every rank."""
    s = small_scene()
    s["solver"]["prefix"] = prefix("gap")
    s["initial_gap"] = gap
    with raised_on_every_rank((InterfaceError, SceneError), words):
        run_scene(s)
