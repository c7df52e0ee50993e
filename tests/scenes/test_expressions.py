"""Expressions of the coordinates in scenes and the initial-gap specs (numpy only).

A scene is data: expressions are parsed with a whitelist and evaluated with numpy, nothing is
executed. Accepted expressions evaluate to the value numpy gives; everything outside the language
(attribute access, subscripts, calls of other functions, imports, lambdas, comparisons, strings,
keyword arguments, unknown names) is refused with a message naming it, before anything runs.
"""

import math

import numpy as np
import pytest

from subfric_dolfinx.scenes import SceneError
from subfric_dolfinx.scenes.expressions import ExpressionError, compile_expression
from subfric_dolfinx.scenes.interface_spec import gap_function, parse_initial_gap

pytestmark = pytest.mark.numpy_only

X = np.array([[0.0, 0.5, 1.0, 2.0], [1.0, 1.0, -1.0, 0.25], [0.0, 0.0, 3.0, 1.0]])


@pytest.mark.parametrize(
    ("text", "params", "expected"),
    [
        ("1.5", {}, lambda x, y, z: np.full(4, 1.5)),
        ("(x - 1)**2 / (2*R)", {"R": 50}, lambda x, y, z: (x - 1) ** 2 / 100),
        ("-x + +y*2 - 3e-2", {}, lambda x, y, z: -x + 2 * y - 0.03),
        ("sqrt(x**2 + y**2 + z**2)", {}, lambda x, y, z: np.sqrt(x**2 + y**2 + z**2)),
        (
            "max(0, x - a) + min(y, 0)",
            {"a": 0.7},
            lambda x, y, z: np.maximum(0, x - 0.7) + y.clip(max=0),
        ),
        (
            "abs(y) * exp(-x) + log(2) + sin(pi*x) + cos(z) + tan(e)",
            {},
            lambda x, y, z: abs(y) * np.exp(-x)
            + math.log(2)
            + np.sin(np.pi * x)
            + np.cos(z)
            + math.tan(math.e),
        ),
    ],
)
def test_accepted_expressions_evaluate_like_numpy(text, params, expected):
    f = compile_expression(text, params)
    np.testing.assert_allclose(f(X), expected(*X), rtol=1e-15)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("__import__('os').system('touch /tmp/owned')", "unknown function"),
        ("x.real", "Attribute is not allowed"),
        ("x[0]", "Subscript is not allowed"),
        ("(lambda: 1)()", "unknown function"),
        ("lambda: 1", "Lambda is not allowed"),
        ("x if y else z", "IfExp is not allowed"),
        ("x < 1", "Compare is not allowed"),
        ("'a' * 3", "only numbers are allowed"),
        ("True + x", "only numbers are allowed"),
        ("x // 2", "FloorDiv is not allowed"),
        ("x % 2", "Mod is not allowed"),
        ("not x", "Not is not allowed"),
        ("open('f')", "unknown function 'open'"),
        ("sqrt(x, y)", "sqrt() takes 1 positional"),
        ("max(x, y=1)", "max() takes 2 positional"),
        ("w + 1", "unknown name 'w'"),
        ("z", "unknown name 'z'"),  # in 2-D (coordinates x, y only)
        ("[x, y]", "List is not allowed"),
        ("x +", "cannot parse"),
        ("1" * 1001, "longer than 1000"),
        ("+".join(["x"] * 300), "more than 400 parts"),
        ("(" * 300 + "x" + ")" * 300, "cannot parse"),
        ("1e400", "not finite"),
    ],
)
def test_everything_else_is_refused(text, words):
    with pytest.raises(ExpressionError) as e:
        compile_expression(text, coordinates=("x", "y"))
    assert words in str(e.value), str(e.value)


def test_parameters_are_checked():
    with pytest.raises(ExpressionError, match="parameter name 'x' is taken"):
        compile_expression("x", {"x": 1.0})
    with pytest.raises(ExpressionError, match="parameter 'R' must be a finite number"):
        compile_expression("R", {"R": float("nan")})
    with pytest.raises(ExpressionError, match="parameter 'R' must be a finite number"):
        compile_expression("R", {"R": "50"})


def test_overflow_gives_non_finite_values_not_an_error_or_a_hang():
    """Huge powers are floats (no big-integer arithmetic): inf, which the interface refuses."""
    f = compile_expression("10**10**10 * x")
    assert np.all(~np.isfinite(f(X)[1:]))


def test_gap_specs():
    two = X[:2]
    assert gap_function(0.01, 2) == 0.01 and gap_function(None, 2) is None

    def python(x):  # a scene given from Python may hold a function (code, trusted)
        return x[0]

    parse_initial_gap(python)
    assert gap_function(python, 2) is python
    par = gap_function({"parabola": {"R": 50, "center": [1.0, 1.0]}}, 2)
    np.testing.assert_allclose(par(two), ((two[0] - 1) ** 2 + (two[1] - 1) ** 2) / 100)
    circ = gap_function({"circle": {"R": 5, "center": [1.0, 1.0]}}, 2)
    d2 = (two[0] - 1) ** 2 + (two[1] - 1) ** 2
    np.testing.assert_allclose(circ(two), 5 - np.sqrt(25 - d2))
    with pytest.raises(ValueError, match="farther than R = 1"):
        gap_function({"circle": {"R": 1, "center": [1.0, 1.0]}}, 2)(two)
    expr = gap_function({"expression": "g + s*x", "parameters": {"g": 0.1, "s": 2}}, 2)
    np.testing.assert_allclose(expr(two), 0.1 + 2 * two[0])
    with pytest.raises(SceneError, match=r"scene.initial_gap.expression: unknown name 'z'"):
        gap_function({"expression": "z"}, 2)
    with pytest.raises(SceneError, match="3 coordinates for a 2-D mesh"):
        gap_function({"parabola": {"R": 1, "center": [0, 0, 0]}}, 2)


@pytest.mark.parametrize(
    ("spec", "pattern"),
    [
        (float("inf"), "expected a finite number"),
        ("0.1", "expected a number or an object"),
        ({}, "expected a number or an object"),
        ({"sphere": {"R": 1}}, r"expected one of 'expression', 'parabola', 'circle'"),
        ({"parabola": {"R": 1}}, r"parabola: expected the keys \['R', 'center'\]"),
        ({"parabola": {"R": -1, "center": [0, 0]}}, r"parabola.R: must be a positive"),
        ({"circle": {"R": 1, "center": [0]}}, r"circle.center: must be 2 or 3 finite"),
        ({"expression": "x", "scale": 2}, r"unknown key\(s\) \['scale'\]"),
        ({"expression": "x", "parameters": [1]}, r"parameters: expected an object"),
        ({"expression": "eval('1')"}, r"expression: unknown function 'eval'"),
    ],
)
def test_bad_gap_specs_are_named(spec, pattern):
    with pytest.raises(SceneError, match=r"scene.initial_gap.*" + pattern):
        parse_initial_gap(spec)
