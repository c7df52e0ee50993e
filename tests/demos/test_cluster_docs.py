"""The cluster page's examples (``docs/reference/cluster.md``): its command lines parse with the
commands' own parsers, it shows the job script (``cluster/job.sh``, run by
``tests/demos/test_cluster_job.py``), and its scene is a valid scene."""

import json
import re
import shlex

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


def commands():
    """The package's command lines of the page's shell blocks, continuation lines joined,
    without what launches them (``srun ... apptainer exec IMAGE``)."""
    out = {}
    for block in blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if "-m" in words:
                i = words.index("-m")
                out.setdefault(words[i + 1], []).append(words[i + 2 :])
    return out


def test_the_pages_command_lines_parse():
    """The page's own command lines (the job script itself is run by test_cluster_job.py)."""
    cmds = commands()
    assert set(cmds) == {"subfric_dolfinx.meshing.partitioned", "subfric_dolfinx.scenes"}
    converted = [
        convert_parser().parse_args(c) for c in cmds["subfric_dolfinx.meshing.partitioned"]
    ]
    assert ("pad.msh", "pad.xdmf", 3) in [(a.msh, a.xdmf, a.gdim) for a in converted]
    ap = scene_parser()
    for line in cmds["subfric_dolfinx.scenes"]:
        own, _ = split_petsc(ap, line)
        assert ap.parse_args(own).out == "out"
    assert "```{literalinclude} ../../cluster/job.sh" in PAGE.read_text()


def test_the_example_scene_is_valid():
    (scene,) = [json.loads(b) for b in blocks("json") if '"kind"' in b]
    parsed = parse_scene(scene)
    assert parsed.mesh.refine == 2 and parsed.mesh.file.endswith(".xdmf")
    assert parsed.outputs.snapshot_file and parsed.solver.linear == "gamg"
