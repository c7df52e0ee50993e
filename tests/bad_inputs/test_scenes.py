"""Bad scenes and checkpoints: configurations with an unknown key, a wrong type or a value out of
range (the path to it named), files requested without a directory; checkpoints that are missing,
truncated, foreign or written for another law or mesh."""

import copy

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.io import CheckpointError, read_checkpoint
from subfric_dolfinx.scenes import SceneError, parse_scene, run_scene
from tests.helpers import on_root, prefix, raised_on_every_rank, small_scene


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
        (lambda s: s["materials"]["slave"].update(G=1.0), r"scene.materials.slave: keys must be"),
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
    ],
)
def test_bad_scene_configs_are_named(mutate, pattern):
    s = copy.deepcopy(small_scene())
    mutate(s)
    with raised_on_every_rank(SceneError, match=pattern):
        parse_scene(s)


def test_files_requested_without_a_directory_are_refused():
    s = small_scene()
    s["outputs"]["history"] = True
    with raised_on_every_rank(SceneError, "no output directory"):
        run_scene(s)


def scene(**outputs):
    s = small_scene()
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
