"""A scene is parsed once into objects (issue 26 item 5): :func:`parse_scene` makes its law,
loading program, initial gap and regions (``FEScene.model``), and the problem is built from these
very objects, not from the scene's dictionaries again."""

import dataclasses

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import build_law
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import SceneError, parse_scene
from subfric_dolfinx.scenes import build as build_mod
from subfric_dolfinx.scenes.interface_spec import gap_function
from subfric_dolfinx.scenes.parser import scene_model
from tests.helpers import small_scene

COULOMB = {"law": "coulomb", "params": {"alpha_t": 1e4, "alpha_n": 1e4, "mu_c": 0.3}}
GAP = {"parabola": {"R": 50.0, "center": [0.5, 1.0]}}


def scene(**changes):
    s = small_scene()
    s.update(changes)
    return s


def test_the_parse_makes_the_objects():
    """The model's law, program, gap and regions: those the scene describes."""
    raw = scene(initial_gap=GAP, regions={"rough": COULOMB})
    m = parse_scene(raw).model
    assert m.law == build_law(raw["law"])
    assert isinstance(m.program, LoadingProgram)
    np.testing.assert_array_equal(m.program.times, raw["program"]["times"])
    x = np.array([[0.0, 0.5, 1.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(m.initial_gap(x), gap_function(GAP, 2)(x), rtol=0, atol=0)
    np.testing.assert_allclose(m.initial_gap(x), [0.25 / 100, 0.0, 0.25 / 100])
    assert m.regions == {"rough": build_law(COULOMB)}
    assert m.interfaces == {}
    assert m.variables == tuple(v.name for v in m.law.variables)


def test_one_interface_takes_the_scene_s_gap_and_regions():
    raw = scene(initial_gap=0.01, regions={"rough": COULOMB}, interfaces={"interface": {}})
    m = parse_scene(raw).model
    assert m.initial_gap is None and m.regions == {}
    one = m.interfaces["interface"]
    assert one.law is None and one.initial_gap == 0.01
    assert one.regions == {"rough": build_law(COULOMB)}


def test_the_model_is_no_key_of_a_scene():
    with pytest.raises(SceneError, match=r"scene: unknown key\(s\) \['model'\]"):
        parse_scene(scene(model={}))


def test_a_scene_made_otherwise_gets_its_model_from_the_same_function():
    """``dataclasses.replace`` makes a scene without a model (it would be stale): the problem's
    builder makes it then, with :func:`scene_model`, which the parse uses too."""
    parsed = parse_scene(scene(initial_gap=0.02))
    other = dataclasses.replace(parsed, initial_gap=0.03)
    assert other.model is None
    again = scene_model(parsed)
    assert again.law == parsed.model.law and again.initial_gap == parsed.model.initial_gap == 0.02
    np.testing.assert_array_equal(again.program.times, parsed.model.program.times)
    assert scene_model(other).initial_gap == 0.03
    with pytest.raises(SceneError, match=r"scene\.initial_gap: expected a finite number"):
        scene_model(dataclasses.replace(parsed, initial_gap=float("nan")))


def test_the_problem_is_built_from_the_parsed_objects(monkeypatch):
    """The problem holds the model's law and program themselves; nothing is parsed again."""
    parsed = parse_scene(scene())

    def again(_):
        raise AssertionError("the scene was parsed again")

    monkeypatch.setattr(build_mod, "scene_model", again)
    domain = build_mod.build_mesh(parsed.mesh, MPI.COMM_WORLD, parsed)
    problem = build_mod.build_problem(parsed, domain)
    assert problem.program is parsed.model.program
    assert problem.law is parsed.model.law


def test_a_pointwise_scene_runs_the_cases_it_parsed(monkeypatch):
    """The driver gets the parsed :class:`~subfric_dolfinx.driver.Case` objects themselves."""
    from subfric_dolfinx.driver import Case
    from subfric_dolfinx.scenes import run_scene
    from subfric_dolfinx.scenes import runner as runner_mod

    case = {
        "params": {"preset": "sec7"},
        "control": "disp",
        "path": [[0, 0, 0, 0.5], [1, 0.01, 0, 0.5]],
        "t_samples": [1],
    }
    parsed = parse_scene({"kind": "pointwise", "name": "p", "cases": {"a": case}})
    assert isinstance(parsed.model["a"], Case)
    seen = []
    real = runner_mod.run_case

    def spy(c, **kwargs):
        seen.append(c)
        return real(c, **kwargs)

    monkeypatch.setattr(runner_mod, "run_case", spy)
    res = run_scene(parsed)
    assert seen == [parsed.model["a"]] and seen[0] is parsed.model["a"]
    ref = real(case)  # the dictionary parsed again: the same run
    assert res.cases["a"].n_steps == ref.n_steps > 0
    for k, v in ref.samples.items():
        np.testing.assert_array_equal(res.cases["a"].samples[k], v)
