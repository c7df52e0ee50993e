"""How an input's value is quoted in an error message: one function for every parser
(:func:`subfric_dolfinx.values.short_repr`), numpy only."""

import ast
import sys

import numpy as np
import pytest

from subfric_dolfinx.values import (
    NotAnInteger,
    NotANumber,
    NotFinite,
    finite_float,
    short_repr,
    strict_int,
    typed_repr,
)
from tests.helpers import ROOT

pytestmark = pytest.mark.numpy_only

PKG = ROOT / "subfric_dolfinx"


@pytest.mark.parametrize(
    ("value", "limit", "text"),
    [
        (1.5, 80, "1.5"),
        ("abc", 80, "'abc'"),
        (10**14, 80, "100000000000000"),
        (10**15, 80, "an integer of 16 digits"),
        (-(10**400), 80, "an integer of 401 digits"),
        (True, 80, "True"),
        ("x" * 100, 10, "'xxxxxx..."),
        (list(range(100)), 20, "[0, 1, 2, 3, 4, 5..."),
    ],
)
def test_short_repr(value, limit, text):
    assert short_repr(value, limit) == text
    assert len(short_repr(value, limit)) <= max(limit, len(text))


def test_integers_beyond_the_digit_limit_are_named_without_converting_them():
    limit = sys.get_int_max_str_digits()
    if limit == 0:
        pytest.skip("this Python converts integers of any size")
    big = 10 ** (limit + 10)
    assert short_repr(big) == f"an integer of more than {limit} digits"
    assert short_repr([big]) == f"<list holding an integer of more than {limit} digits>"


def test_no_other_module_defines_its_own():
    """The scene parser, its materials and bodies, the driver and the calibration once each had a
    private copy; they import this one now."""
    copies = [
        f"{p.relative_to(PKG)}:{node.lineno}"
        for p in sorted(PKG.rglob("*.py"))
        for node in ast.walk(ast.parse(p.read_text()))
        if isinstance(node, ast.FunctionDef)
        and node.name in ("_short", "short_repr")
        and p.name != "values.py"
    ]
    assert not copies, copies


@pytest.mark.parametrize(
    ("value", "numpy", "out"),
    [
        (1, False, 1.0),
        (-2.5, False, -2.5),
        (10**300, False, 1e300),
        (np.float64(2.5), False, 2.5),  # a float subclass
        (np.int64(3), True, 3.0),
        (np.float32(0.5), True, 0.5),
        (True, False, NotANumber),
        (np.bool_(True), True, NotANumber),
        ("1.5", False, NotANumber),
        (None, False, NotANumber),
        ([1.0], False, NotANumber),
        (np.int64(3), False, NotANumber),
        (float("nan"), False, NotFinite),
        (-float("inf"), False, NotFinite),
        (10**400, False, NotFinite),
        (np.float64("inf"), True, NotFinite),
    ],
)
def test_finite_float(value, numpy, out):
    """The one check of a number given by a user: not a boolean, finite, in a float's range."""
    if isinstance(out, type):
        with pytest.raises(out):
            finite_float(value, numpy=numpy)
    else:
        got = finite_float(value, numpy=numpy)
        assert got == out and type(got) is float


@pytest.mark.parametrize(
    ("value", "numpy", "ok"),
    [
        (3, False, True),
        (np.int32(3), True, True),
        (np.int32(3), False, False),
        (True, False, False),
        (2.0, False, False),
        ("2", False, False),
    ],
)
def test_strict_int(value, numpy, ok):
    if ok:
        assert strict_int(value, numpy=numpy) == int(value)
    else:
        with pytest.raises(NotAnInteger):
            strict_int(value, numpy=numpy)


def test_numpy_scalars_are_quoted_as_python_values():
    assert short_repr(np.float64(2.5)) == "2.5"
    assert short_repr(np.int64(10**15)) == "an integer of 16 digits"
    assert typed_repr([1, 2]) == "list [1, 2]"
