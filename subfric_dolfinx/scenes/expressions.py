"""Arithmetic expressions of the coordinates in scenes, parsed from data (nothing is executed).

A scene is data: an expression such as ``"(x - 1)**2 / (2*R)"`` is parsed with :mod:`ast` and
only a whitelist is accepted: numbers, the coordinates ``x``, ``y``, ``z``, the scene's own
parameters, the constants ``pi`` and ``e``, ``+ - * / **``, unary ``-``/``+``, and the functions
``sqrt``, ``abs``, ``exp``, ``log``, ``sin``, ``cos``, ``tan``, ``min`` and ``max`` (of two
arguments). Anything else (attributes, subscripts, comparisons, other names or calls, keyword
arguments, strings) is refused with a message naming it; the text is never given to ``eval``.
The result is a function of the coordinates evaluated with numpy, element-wise.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..driver.text import short_repr

__all__ = ["COORDINATES", "FUNCTIONS", "ExpressionError", "compile_expression"]

COORDINATES = ("x", "y", "z")
CONSTANTS = {"pi": math.pi, "e": math.e}
FUNCTIONS: dict[str, tuple[int, Callable[..., Any]]] = {
    "sqrt": (1, np.sqrt),
    "abs": (1, np.abs),
    "exp": (1, np.exp),
    "log": (1, np.log),
    "sin": (1, np.sin),
    "cos": (1, np.cos),
    "tan": (1, np.tan),
    "min": (2, np.minimum),
    "max": (2, np.maximum),
}
"""Allowed functions: name -> (number of arguments, numpy function)."""

MAX_LENGTH = 1000
MAX_NODES = 400

_BINARY = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.divide,
    ast.Pow: np.power,
}
_UNARY = {ast.USub: np.negative, ast.UAdd: np.positive}

Node = Callable[[Mapping[str, Any]], Any]


class ExpressionError(ValueError):
    """An expression that is not in the allowed language (the message says what is wrong)."""


def finite_float(v: int | float) -> float | None:
    """``v`` as a finite float, or ``None`` (infinite, NaN, or an integer beyond a float)."""
    try:
        f = float(v)
    except OverflowError:  # e.g. a 401-digit integer
        return None
    return f if math.isfinite(f) else None


def _compile(node: ast.AST, names: frozenset[str]) -> Node:
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ExpressionError(f"only numbers are allowed as constants, got {v!r}")
        f = finite_float(v)
        if f is None:
            raise ExpressionError(f"a number ({short_repr(v)}) is not finite (or beyond a float)")
        return lambda env: f
    if isinstance(node, ast.Name):
        name = node.id
        if name in CONSTANTS:
            c = CONSTANTS[name]
            return lambda env: c
        if name not in names:
            raise ExpressionError(
                f"unknown name {name!r}; allowed: {sorted(names)} and {sorted(CONSTANTS)}"
            )
        return lambda env: env[name]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        op = _BINARY[type(node.op)]
        a, b = _compile(node.left, names), _compile(node.right, names)
        return lambda env: op(a(env), b(env))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        uop = _UNARY[type(node.op)]
        a = _compile(node.operand, names)
        return lambda env: uop(a(env))
    if isinstance(node, ast.Call):
        fname = node.func.id if isinstance(node.func, ast.Name) else None
        if fname not in FUNCTIONS:
            what = fname if fname else ast.dump(node.func)[:40]
            raise ExpressionError(f"unknown function {what!r}; allowed: {sorted(FUNCTIONS)}")
        nargs, fn = FUNCTIONS[fname]
        if node.keywords or len(node.args) != nargs:
            raise ExpressionError(f"{fname}() takes {nargs} positional argument(s)")
        args = [_compile(a, names) for a in node.args]
        return lambda env: fn(*(a(env) for a in args))
    kind = type(node).__name__
    if isinstance(node, ast.BinOp | ast.UnaryOp):
        kind = type(node.op).__name__
    raise ExpressionError(f"{kind} is not allowed (numbers, names, + - * / **, functions only)")


def compile_expression(
    text: str,
    parameters: Mapping[str, float] | None = None,
    coordinates: tuple[str, ...] = COORDINATES,
) -> Callable[[np.ndarray], np.ndarray]:
    """Parse ``text`` into a function of the coordinates ``x`` (gdim, n) returning (n,) values.

    Args:
        text: The expression, e.g. ``"(x - 1)**2 / (2*R)"``.
        parameters: Names usable in it besides the coordinates, with their (finite) values.
        coordinates: The coordinate names (``("x", "y")`` in 2-D: ``z`` is then unknown).

    Raises:
        ExpressionError: Not a string, too long or too large, a syntax error, or anything outside
            the allowed language (named); a parameter that is not a finite number or whose name
            is taken.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"an expression is a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the expression is longer than {MAX_LENGTH} characters")
    params: dict[str, float] = {}
    for k, v in (parameters or {}).items():
        if not isinstance(k, str) or not k.isidentifier():
            raise ExpressionError(f"parameter name {k!r} is not an identifier")
        if k in COORDINATES or k in CONSTANTS or k in FUNCTIONS:
            raise ExpressionError(
                f"parameter name {k!r} is taken (a coordinate, constant or function)"
            )
        f = None if isinstance(v, bool) or not isinstance(v, int | float) else finite_float(v)
        if f is None:
            raise ExpressionError(f"parameter {k!r} must be a finite number, got {short_repr(v)}")
        params[k] = f
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError) as e:
        raise ExpressionError(f"cannot parse {text!r}: {type(e).__name__}: {e}") from None
    if sum(1 for _ in ast.walk(tree)) > MAX_NODES:
        raise ExpressionError(f"the expression has more than {MAX_NODES} parts")
    try:
        body = _compile(tree.body, frozenset(coordinates) | frozenset(params))
    except RecursionError:
        raise ExpressionError("the expression is nested too deeply") from None

    def evaluate(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[0] < len(coordinates):
            raise ValueError(f"coordinates must have shape ({len(coordinates)}, n), got {x.shape}")
        env: dict[str, Any] = dict(params)
        env.update({c: x[i] for i, c in enumerate(coordinates)})
        with np.errstate(all="ignore"):
            out = body(env)
        return np.array(np.broadcast_to(np.asarray(out, dtype=float), (x.shape[1],)))

    return evaluate
