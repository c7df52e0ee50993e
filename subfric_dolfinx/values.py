"""Values given by users: the strict number checks and how a bad value is quoted (numpy only).

Every parser of user input uses these: the scene parser (:mod:`subfric_dolfinx.scenes`), driver
cases (:mod:`subfric_dolfinx.driver`), calibration data (:mod:`subfric_dolfinx.calibrate`) and the
checkpoint format (:mod:`subfric_dolfinx.io`). What counts as a number (a boolean does not; an
integer too large for a float is not finite) and how a value is quoted in a message (cut short,
a huge integer by its number of digits) is decided here once; each parser words its message in
its own convention (``scene.solver.dt: expected a finite number, got inf``, ``field
'path[1][1]' must be finite, got nan``), naming the key path and the value::

    try:
        dt = finite_float(value)
    except NotANumber:
        raise SceneError(f"{path}: expected a number, got {short_repr(value)}") from None
    except NotFinite:
        raise SceneError(f"{path}: expected a finite number, got {short_repr(value)}") from None
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

__all__ = [
    "NotANumber",
    "NotAnInteger",
    "NotFinite",
    "NumberError",
    "finite_float",
    "short_repr",
    "strict_int",
    "typed_repr",
]

_BIG = 10**15
"""Integers from this size on are named by their number of digits."""


class NumberError(ValueError):
    """A value refused by :func:`finite_float` or :func:`strict_int` (the caller names it)."""


class NotANumber(NumberError):
    """Not an integer or a float: a boolean, a string, ``None``, a list, ..."""


class NotFinite(NumberError):
    """A number that is NaN, infinite, or an integer beyond the range of a float."""


class NotAnInteger(NumberError):
    """Not an integer: a float (even ``2.0``), a boolean, a string, ..."""


def _real_types(
    numpy: bool,
) -> tuple[type[int] | type[float] | type[np.integer[Any]] | type[np.floating[Any]], ...]:
    return (int, float, np.integer, np.floating) if numpy else (int, float)


def finite_float(value: Any, *, numpy: bool = False) -> float:
    """``value`` as a float, if it is a real number (not a boolean) and finite.

    Args:
        value: Any value (from a JSON file, a dictionary, an HDF5 attribute).
        numpy: Accept numpy's integer and floating scalars too (HDF5 attributes are read as
            them); JSON and dictionaries of Python values need not.

    Raises:
        NotANumber: A boolean or anything but an ``int`` or ``float``.
        NotFinite: NaN, infinite, or an integer beyond the range of a float (``10**400``).
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, _real_types(numpy)):
        raise NotANumber(short_repr(value))
    try:
        x = float(value)
    except OverflowError:
        raise NotFinite(short_repr(value)) from None
    if not math.isfinite(x):
        raise NotFinite(short_repr(value))
    return x


def strict_int(value: Any, *, numpy: bool = False) -> int:
    """``value`` as an int, if it is an integer (not a boolean, not a float such as ``2.0``).

    Args:
        value: Any value.
        numpy: Accept numpy's integer scalars too.

    Raises:
        NotAnInteger: Anything else.
    """
    types = (int, np.integer) if numpy else (int,)
    if isinstance(value, bool | np.bool_) or not isinstance(value, types):
        raise NotAnInteger(short_repr(value))
    return int(value)


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr(value)``, cut to ``limit`` characters.

    A numpy scalar is shown as the Python value (``2.5``, not ``np.float64(2.5)``). An integer of
    16 digits or more is named by its number of digits (``"an integer of 401 digits"``), one
    beyond Python's limit for converting integers to text by that limit.

    Args:
        value: Any value (from a JSON file, a dictionary, a command line, an HDF5 attribute).
        limit: The longest text returned (at least 4).

    Returns:
        The text, ending with ``...`` if it was cut.
    """
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= _BIG:
        try:
            return f"an integer of {len(str(abs(value)))} digits"
        except ValueError:  # beyond sys.get_int_max_str_digits()
            return f"an integer of more than {sys.get_int_max_str_digits()} digits"
    try:
        text = repr(value)
    except ValueError:  # e.g. a container holding an integer beyond the digit limit
        return (
            f"<{type(value).__name__} holding an integer of more than "
            f"{sys.get_int_max_str_digits()} digits>"
        )
    return text if len(text) <= limit else text[: limit - 3] + "..."


def typed_repr(value: Any) -> str:
    """The value's type and :func:`short_repr` (``"list [1, 2]"``): for a value of a wrong type."""
    return f"{type(value).__name__} {short_repr(value)}"
