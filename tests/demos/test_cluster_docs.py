"""The cluster page's example (``docs/reference/cluster.md``): its job script is valid bash, its
command lines parse with the commands' own parsers, and its scene is a valid scene."""

import json
import re
import shlex
import subprocess

import pytest

from subfric_dolfinx.meshing.partitioned import parser as convert_parser
from subfric_dolfinx.scenes import parse_scene
from subfric_dolfinx.scenes.cli import split_petsc
from subfric_dolfinx.scenes.command import parser as scene_parser
from tests.helpers import ROOT

pytestmark = pytest.mark.serial

PAGE = ROOT / "docs" / "reference" / "cluster.md"


def blocks(language):
    return re.findall(rf"^```{language}\n(.*?)^```$", PAGE.read_text(), re.M | re.S)


def job_script():
    (script,) = [b for b in blocks("bash") if "#SBATCH" in b]
    return script


def commands(script):
    """The package's command lines of the script, continuation lines joined, without what
    launches them (``srun ... apptainer exec IMAGE``)."""
    joined = script.replace("\\\n", " ")
    out = {}
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if "-m" in words:
            i = words.index("-m")
            out[words[i + 1]] = words[i + 2 :]
    return out


def test_the_job_script_is_valid_bash_and_its_commands_parse():
    script = job_script()
    done = subprocess.run(["bash", "-n"], input=script, text=True, capture_output=True)
    assert done.returncode == 0, done.stderr
    cmds = commands(script)
    assert set(cmds) == {"subfric_dolfinx.meshing.partitioned", "subfric_dolfinx.scenes"}
    args = convert_parser().parse_args(cmds["subfric_dolfinx.meshing.partitioned"])
    assert (args.msh, args.xdmf, args.gdim) == ("pad.msh", "pad.xdmf", 3)
    ap = scene_parser()
    own, petsc = split_petsc(ap, cmds["subfric_dolfinx.scenes"])
    args = ap.parse_args(own)
    assert args.scene == "pad.scene.json" and args.out == "out"
    # the PETSc options carry the scene's prefix
    (scene,) = [json.loads(b) for b in blocks("json") if '"kind"' in b]
    prefix = scene["solver"]["prefix"]
    names = [p for p in petsc if p.startswith("-")]
    assert names and all(p.startswith(f"-{prefix}") for p in names), names
    assert scene["mesh"]["file"] == args.scene.replace(".scene.json", ".xdmf")


def test_the_example_scene_is_valid():
    (scene,) = [json.loads(b) for b in blocks("json") if '"kind"' in b]
    parsed = parse_scene(scene)
    assert parsed.mesh.refine == 2 and parsed.mesh.file.endswith(".xdmf")
    assert parsed.outputs.snapshot_file and parsed.solver.linear == "gamg"
