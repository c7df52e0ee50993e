"""The JSON Schema of scenes (issue 24 item 7), published for editors as
``docs/scene.schema.json``: it is the one generated from the schema module now (regenerate with
``python3 -m subfric_dolfinx.scenes.jsonschema --out docs/scene.schema.json``), it is a valid
Draft 2020-12 schema, every demo's scene and the README's example pass it, and what the strict
parser refuses structurally (an unknown or misspelt key, a wrong type, a missing key, an unknown
law or preset) it refuses too."""

import ast
import copy
import json

import jsonschema
import pytest

from demos import block_on_base, bolted_joint, hertz, lap_joint, pad_on_plate, punch
from subfric_dolfinx.scenes import parse_scene
from subfric_dolfinx.scenes.jsonschema import scene_schema
from subfric_dolfinx.scenes.schema import SceneError
from tests.helpers import ROOT

pytestmark = pytest.mark.serial  # the schema is the same on any number of ranks

PUBLISHED = ROOT / "docs" / "scene.schema.json"


def plain(scene):
    return json.loads(json.dumps(scene, default=float))


def demo_scenes():
    law = lap_joint.laws()
    return {
        "block_on_base": block_on_base.scene(),
        "bolted_joint": bolted_joint.scene(),
        "hertz": hertz.scene(),
        "lap_joint": lap_joint.scene(law["subloading"], "lap"),
        "pad_on_plate": pad_on_plate.scene(),
        "punch": punch.scene(punch.subloading_law(), "punch"),
        "pointwise": {
            "kind": "pointwise",
            "name": "p",
            "cases": {
                "a": {
                    "params": {"preset": "sec7"},
                    "control": "disp",
                    "path": [[0, 0, 0, 0.5], [1, 1, 0, 0.5]],
                    "t_samples": [1],
                }
            },
        },
    }


def validator():
    schema = scene_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_the_published_schema_is_the_generated_one(monkeypatch):
    # the package's own laws only: a law registered by another test module (test_third_law, at
    # its import) is in this process's schema, rightly, but not in the published one
    from subfric_dolfinx.constitutive import LAWS
    from subfric_dolfinx.scenes import jsonschema as module

    own = {k: v for k, v in LAWS.items() if v.__module__.startswith("subfric_dolfinx.")}
    monkeypatch.setattr(module, "LAWS", own)
    assert json.loads(PUBLISHED.read_text()) == scene_schema(), (
        "docs/scene.schema.json is behind subfric_dolfinx/scenes/schema.py: regenerate it with "
        "python3 -m subfric_dolfinx.scenes.jsonschema --out docs/scene.schema.json"
    )


@pytest.mark.parametrize("name", sorted(demo_scenes()))
def test_every_demo_scene_passes_the_schema_and_the_parser(name):
    scene = plain(demo_scenes()[name])
    errors = [e.message for e in validator().iter_errors(scene)]
    assert not errors, errors
    parse_scene(scene)  # and the parser accepts it


def test_the_readme_example_passes():
    text = (ROOT / "README.md").read_text()
    block = "{" + text.split("scene = {", 1)[1].split("\nresult = run_scene(", 1)[0]
    scene = ast.literal_eval(block)  # the README's literal dict
    assert not [e.message for e in validator().iter_errors(plain(scene))]


BAD = {
    "misspelt key": (["solver", "dtt"], 0.1, "Additional properties"),
    "wrong type": (["solver", "dt"], "0.1", "is not of type 'number'"),
    "unknown law": (["law", "law"], "coulomb2", ""),
    "unknown preset": (["law", "params", "preset"], "sec8", ""),
    "mu_s as text": (["law", "params", "mu_s"], "500 MPa", ""),
    "misspelt output": (["outputs", "histroy"], True, "Additional properties"),
    "material without nu": (["materials", "secondary"], {"E": 7e4}, "'nu' is a required property"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_what_the_parser_refuses_the_schema_refuses(case):
    path, value, words = BAD[case]
    scene = plain(block_on_base.scene())
    node = scene
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = copy.deepcopy(value)
    errors = list(validator().iter_errors(scene))
    assert errors, case
    text = " ".join(e.message for err in errors for e in [err, *err.context])
    assert words in text, text
    with pytest.raises((SceneError, ValueError)):
        parse_scene(scene)


def test_a_registered_law_is_in_the_schema_of_its_process(monkeypatch):
    from subfric_dolfinx.constitutive import LAWS, CoulombLaw

    class Other(CoulombLaw):
        name = "other-coulomb"

    monkeypatch.setitem(LAWS, Other.name, Other)
    assert "other-coulomb" in scene_schema()["$defs"]["Law"]["properties"]["law"]["enum"]
