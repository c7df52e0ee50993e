"""The driver's case errors and the check of a case's numbers (shared by every kind of case)."""

from __future__ import annotations

from typing import Any

from ..values import NotANumber, NotFinite, finite_float, short_repr

__all__ = ["CaseError", "field_number"]


class CaseError(ValueError):
    """A malformed case; the message names the offending field."""


def field_number(where: str, v: Any) -> float:
    """The value of the field ``where`` as a float: a real number (not a boolean), finite.

    The check of every number of a case and of calibration data (:mod:`subfric_dolfinx.values`).

    Raises:
        CaseError: Naming the field and the value (``field 'path[1][1]' must be finite, got nan``).
    """
    try:
        return finite_float(v)
    except NotANumber:
        raise CaseError(f"field '{where}' must be a number, got {short_repr(v)}") from None
    except NotFinite:
        raise CaseError(f"field '{where}' must be finite, got {short_repr(v)}") from None
