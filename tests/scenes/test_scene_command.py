"""``python3 -m subfric_dolfinx.scenes SCENE.json --out DIR`` (the console script ``subfric-scene``,
``tests/test_packaging.py``): a JSON scene run from the command line, with the demos' exit codes
(0 done, 1 a step not solved, 2 bad input, 75 stopped), one line each, no traceback; and
``load_scene`` taking a scene as a dict, refusing anything else by name.

The command runs as its own process (``serial``); the scene is small (a few seconds).
"""

import json
import signal
import sys

import pytest

from subfric_dolfinx.scenes import SceneError, load_scene
from subfric_dolfinx.scenes.schema import FEScene
from tests.scenes.test_cli import run

SCENE = {
    "kind": "fe",
    "name": "cmd",
    "mesh": {
        "builder": "block_on_base",
        "options": {
            "n_interface": 4,
            "block_width": 10,
            "block_height": 5,
            "base_width": 20,
            "base_height": 5,
        },
    },
    "law": {"law": "subloading", "params": {"preset": "sec7", "alpha_n": 1e6}},
    "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 7.0e4, "nu": 0.33}},
    "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
    "dirichlet": [
        {"group": "bottom", "value": [0, 0]},
        {"group": "top", "component": 0, "value": 0.5, "amplitude": "slide"},
    ],
    "loads": [{"type": "pressure", "group": "top", "value": 300, "amplitude": "press"}],
    "solver": {"prefix": "cmd_", "dt": 0.1},
    "outputs": {"history": True},
}


def scene_file(tmp_path, scene=SCENE):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return path


def command(path, *args):
    return [sys.executable, "-m", "subfric_dolfinx.scenes", str(path), *map(str, args)]


@pytest.mark.serial
def test_the_command_runs_a_json_scene(tmp_path):
    rc, text = run(command(scene_file(tmp_path), "--out", tmp_path / "out"))
    assert rc == 0, text
    rows = (tmp_path / "out" / "history.csv").read_text().splitlines()
    assert len(rows) > 10 and rows[0].startswith("step,"), rows[:2]
    assert f"cmd: {len(rows) - 1} steps done, files in {tmp_path / 'out'}" in text, text
    assert "Traceback" not in text and len(text.splitlines()) <= 30, text


@pytest.mark.serial
@pytest.mark.parametrize(
    ("change", "args", "code", "words"),
    [
        ({"solver": {"prefix": "cmd_", "dtt": 0.1}}, [], 2, ["scene.solver", "dtt"]),
        ({}, ["--outt", "x"], 2, ["unknown option --outt"]),
        ({}, ["-cmd_snes_max_it", "1"], 1, ["error: no convergence at t = "]),
        ({}, ["--restart", "missing.h5"], 2, ["missing.h5", "does not exist"]),
    ],
    ids=["bad-scene", "bad-option", "step-failure", "missing-checkpoint"],
)
def test_the_command_exit_codes_and_one_line(tmp_path, change, args, code, words):
    path = scene_file(tmp_path, {**SCENE, **change})
    rc, text = run(command(path, "--out", tmp_path / "out", *args))
    assert rc == code, text
    assert "Traceback" not in text, text
    assert all(w in text for w in words), text
    assert len([ln for ln in text.splitlines() if "error: " in ln]) == 1, text
    if code == 2 and not args:
        assert text.startswith("subfric-scene: error: "), text  # named, before any output


@pytest.mark.serial
def test_the_command_names_itself_in_the_package_warnings(tmp_path):
    """A scene with friction coefficients as mu_s, mu_k: the units warning, said by the command
    (not by the launcher's frame, ``<frozen runpy>``), once; the run goes on."""
    trap = {**SCENE, "law": {"params": {"preset": "sec7", "mu_s": 0.3, "mu_k": 0.2}}}
    rc, text = run(command(scene_file(tmp_path, trap), "--out", tmp_path / "out"))
    assert rc == 0, text
    lines = [ln for ln in text.splitlines() if "UnitsWarning" in ln]
    assert len(lines) == 1 and lines[0].startswith("subfric-scene: warning: UnitsWarning: "), text
    assert "are stresses in MPa" in lines[0] and "runpy" not in text, text


@pytest.mark.serial
def test_a_signal_stops_the_command_after_its_step(tmp_path):
    rc, text = run(
        command(scene_file(tmp_path), "--out", tmp_path / "out", "-v"),
        signal_at="step    3",
        sig=signal.SIGTERM,
    )
    assert rc == 75, text
    assert "Traceback" not in text and "interrupted by SIGTERM after step" in text, text


def test_load_scene_takes_a_dict_and_names_what_it_cannot_take(tmp_path):
    assert isinstance(load_scene(SCENE), FEScene)
    assert load_scene(scene_file(tmp_path)) == load_scene(SCENE)
    for bad in (3.5, ["scene.json"], None):
        with pytest.raises(SceneError, match=f"got {type(bad).__name__}"):
            load_scene(bad)
    with pytest.raises(SceneError, match=r"scene.solver: unknown key\(s\) \['dtt'\]"):
        load_scene({**SCENE, "solver": {"dtt": 1}})
