"""How an input's value is quoted in an error message: one function for every parser
(:func:`subfric_dolfinx.driver.text.short_repr`), numpy only."""

import ast
import sys
from pathlib import Path

import pytest

from subfric_dolfinx.driver.text import short_repr

pytestmark = pytest.mark.numpy_only

PKG = Path(__file__).resolve().parents[1] / "subfric_dolfinx"


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
        if isinstance(node, ast.FunctionDef) and node.name in ("_short", "short_repr")
        and p.name != "text.py"
    ]  # fmt: skip
    assert not copies, copies
