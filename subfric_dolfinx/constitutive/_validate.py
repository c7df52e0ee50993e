"""Validation of law parameters: real, finite, in range; errors name the parameter."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from typing import Any

__all__ = ["non_negative", "positive", "real", "validate_fields"]


def real(name: str, value: Any, ok: Callable[[float], bool], allowed: str) -> float:
    """Return ``value`` as a float, or raise an error naming the parameter and its allowed range.

    Raises:
        TypeError: Not a real number (``bool`` is refused too).
        ValueError: Not finite, or ``ok(value)`` is false.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"parameter {name} must be a real number ({allowed}), got {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond the double range
        raise ValueError(
            f"parameter {name} = {value!r} is not finite; allowed: {allowed}"
        ) from None
    if not math.isfinite(v):
        raise ValueError(f"parameter {name} = {v!r} is not finite; allowed: {allowed}")
    if not ok(v):
        raise ValueError(f"parameter {name} = {v!r} is out of range; allowed: {allowed}")
    return v


def validate_fields(obj: Any, rules: dict[str, tuple[Callable[[float], bool], str]]) -> None:
    """Validate and convert fields of a frozen dataclass in place (``__post_init__``)."""
    for name, (ok, allowed) in rules.items():
        object.__setattr__(obj, name, real(name, getattr(obj, name), ok, allowed))


def positive(v: float) -> bool:
    """``v > 0``."""
    return v > 0.0


def non_negative(v: float) -> bool:
    """``v >= 0``."""
    return v >= 0.0
