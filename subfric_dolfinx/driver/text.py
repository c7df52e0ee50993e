"""How an input's value is quoted in an error message (numpy only).

One function, :func:`short_repr`, used by every parser of user input (driver cases, calibration
data, scenes): a message names the bad value without echoing a huge one whole.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["short_repr"]

_BIG = 10**15
"""Integers from this size on are named by their number of digits."""


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr(value)``, cut to ``limit`` characters.

    An integer of 16 digits or more is named by its number of digits (``"an integer of 401
    digits"``), one beyond Python's limit for converting integers to text by that limit.

    Args:
        value: Any value (from a JSON file, a dictionary, a command line).
        limit: The longest text returned (at least 4).

    Returns:
        The text, ending with ``...`` if it was cut.
    """
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= _BIG:
        try:
            return f"an integer of {len(str(abs(value)))} digits"
        except ValueError:  # beyond sys.get_int_max_str_digits()
            return f"an integer of more than {sys.get_int_max_str_digits()} digits"
    try:
        text = repr(value)
    except ValueError:  # e.g. a container holding an integer beyond the digit limit
        return f"<{type(value).__name__} holding an integer of more than " \
            f"{sys.get_int_max_str_digits()} digits>"
    return text if len(text) <= limit else text[: limit - 3] + "..."
