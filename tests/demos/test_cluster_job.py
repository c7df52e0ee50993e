"""The cluster example (``cluster/``, docs/reference/cluster.md) runs as it would on a cluster.

The Slurm job script is run as ``sbatch`` would run it, with ``mpirun -n 2`` for ``srun`` and
the environment's own DOLFINx for the container (``LAUNCH``, ``RUNNER``), on the example scene at
a small size: the job ends done, its PETSc options are all used (PETSc's ``-options_left``: a
misspelt option or one the solver never reads would be listed), and the run is the scene's, within
the model's validity (no warning of the package).
"""

import csv
import json
import os
import subprocess
import sys

import pytest

from subfric_dolfinx.scenes import load_scene
from tests.helpers import ROOT, singleton_env

pytestmark = pytest.mark.serial  # starts its own 2-rank job

JOB = ROOT / "cluster" / "job.sh"
SCENE = ROOT / "cluster" / "pad.json"


def job(tmp_path, *args: str) -> subprocess.CompletedProcess:
    env = dict(singleton_env(), LAUNCH="mpirun -n 2", RUNNER="", PYTHON=sys.executable)
    env.pop("IMAGE", None)
    return subprocess.run(
        ["bash", str(JOB), *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_job_script_runs_the_example_scene(tmp_path):
    scene = json.loads(SCENE.read_text())
    assert scene["mesh"]["options"]["n_interface"] == 64  # the documented ~2M-dof model
    scene["mesh"]["options"]["n_interface"] = 2
    (tmp_path / "small.json").write_text(json.dumps(scene))
    p = job(tmp_path, "small.json", "out", "-options_left", "-options_view")
    text = p.stdout + p.stderr
    assert p.returncode == 0, text
    assert "pad_cluster: 100 steps done, files in out" in text, text
    assert "There are no unused options." in text, text
    assert "-pad_pc_gamg_process_eq_limit 200" in text, text
    assert "Warning" not in text, text
    with open(tmp_path / "out" / "history.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 100
    friction = [abs(float(r["F_t1"])) / float(r["area"]) for r in rows]
    assert max(friction) > 10.0  # MPa: the pad slid (the Sec. 7 set at 300 MPa: about 25 MPa)
    assert max(float(r["plastic"]) for r in rows) > 0.0


def test_the_job_script_names_what_it_needs(tmp_path):
    p = job(tmp_path, "scene.json")
    assert p.returncode == 2
    assert "usage: sbatch" in p.stderr and "SCENE.json OUTDIR" in p.stderr


def test_the_example_scene_and_the_image_definition_are_valid():
    load_scene(SCENE)
    definition = (ROOT / "cluster" / "subfric-dolfinx.def").read_text()
    assert "Bootstrap: docker-archive" in definition
    assert "python3 -m subfric_dolfinx.scenes" in definition
    assert os.access(JOB, os.X_OK)
