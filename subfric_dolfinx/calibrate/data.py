"""DATA.json of the calibration: parsing and validation (every error names the field)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np

from ..constitutive import SubloadingLaw
from ..driver.case import CaseError, field_number, read_json, read_table, table_spec
from ..values import short_repr

__all__ = [
    "NAMES",
    "UNITS",
    "CalibrationData",
    "CalibrationError",
    "Curve",
    "load_data",
    "parse_data",
]

NAMES = ("alpha_t", "alpha_n", "mu_s", "mu_k", "kappa", "xi", "u_tilde", "c_n")
"""The eight parameters of the subloading law, in the order of FIT.json's ``params``."""
UNITS = {
    "alpha_t": "MPa/mm",
    "alpha_n": "MPa/mm",
    "mu_s": "MPa",
    "mu_k": "MPa",
    "kappa": "1/mm",
    "xi": "1/s",
    "u_tilde": "1/mm",
    "c_n": "1/MPa",
}
"""The unit of each parameter (as the law's parameters are documented)."""

MAX_POINTS = 1_000_000  # data points in all; more is a mistake (or another tool's job)


class CalibrationError(ValueError):
    """Bad calibration data, or parameters the data cannot identify; the message says which."""


@dataclasses.dataclass(frozen=True)
class Curve:
    """One measured curve: a monotonic slide at constant normal stress from the virgin state.

    Attributes:
        f_n: Normal stress, MPa (> 0).
        velocity: Sliding velocity, mm/s (> 0).
        slip: Tangential displacement ``ubar_t``, mm, strictly increasing, from >= 0, (k,).
        f_t: Measured tangential stress at ``slip``, MPa, (k,).
    """

    f_n: float
    velocity: float
    slip: np.ndarray
    f_t: np.ndarray


@dataclasses.dataclass(frozen=True)
class CalibrationData:
    """A validated DATA.json.

    Attributes:
        params: All eight parameters: start values of the fitted ones, values of the fixed ones.
        fit: Names of the fitted parameters (in the order of the correlation matrix).
        bounds: ``name -> (lo, hi)`` for every fitted name (``(0, inf)`` unless given).
        curves: The measured curves.
    """

    params: dict[str, float]
    fit: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    curves: tuple[Curve, ...]

    @property
    def n_points(self) -> int:
        """Number of measured points in all."""
        return sum(c.slip.size for c in self.curves)


@overload
def _num(where: str, v: Any, *, allow_none: Literal[False] = False) -> float: ...


@overload
def _num(where: str, v: Any, *, allow_none: bool) -> float | None: ...


def _num(where: str, v: Any, *, allow_none: bool = False) -> float | None:
    """The driver's number check (finite, not a bool), raising :class:`CalibrationError`."""
    if v is None and allow_none:
        return None
    try:
        return field_number(where, v)
    except CaseError as e:
        raise CalibrationError(str(e)) from None


def _numbers(where: str, v: Any) -> np.ndarray:
    if not isinstance(v, list):
        raise CalibrationError(f"field '{where}' must be a list of numbers, got {short_repr(v)}")
    return np.array([_num(f"{where}[{i}]", x) for i, x in enumerate(v)], dtype=float)


def _curve(i: int, c: Any, base: str | Path | None) -> Curve:
    w = f"curves[{i}]"
    if not isinstance(c, dict):
        raise CalibrationError(f"field '{w}' must be an object, got {short_repr(c)}")
    unknown = sorted(set(c) - {"f_n", "velocity", "slip", "f_t", "csv", "columns"})
    if unknown:
        raise CalibrationError(
            f"field '{w}': unknown keys {unknown}; allowed: f_n, velocity, "
            "slip, f_t (or csv, columns)"
        )
    if "csv" in c:  # the measured curve from a CSV file (e.g. a tribometer's export)
        both = sorted({"slip", "f_t"} & set(c))
        if both:
            raise CalibrationError(
                f"field '{w}': give the curve as csv or as slip and f_t, not both (also {both})"
            )
        try:
            spec = {"csv": c["csv"], **({"columns": c["columns"]} if "columns" in c else {})}
            cols = table_spec(spec, w, ("slip", "f_t"))
            table = read_table(
                c["csv"],
                {k: (cols[k], True) for k in ("slip", "f_t")},
                what=f"field '{w}.csv'",
                base=base,
            )
        except CaseError as e:
            raise CalibrationError(str(e)) from None
        c = {**c, "slip": table["slip"].tolist(), "f_t": table["f_t"].tolist()}
    elif "columns" in c:
        raise CalibrationError(f"field '{w}.columns' names the columns of a csv file; give csv")
    for k in ("f_n", "velocity", "slip", "f_t"):
        if k not in c:
            raise CalibrationError(f"field '{w}.{k}' is missing")
    f_n = _num(f"{w}.f_n", c["f_n"])
    v = _num(f"{w}.velocity", c["velocity"])
    if not f_n > 0.0:
        raise CalibrationError(f"field '{w}.f_n' must be > 0 (MPa, in contact), got {f_n!r}")
    if not v > 0.0:
        raise CalibrationError(f"field '{w}.velocity' must be > 0 (mm/s), got {v!r}")
    slip = _numbers(f"{w}.slip", c["slip"])
    f_t = _numbers(f"{w}.f_t", c["f_t"])
    if slip.size < 2:
        raise CalibrationError(f"field '{w}.slip' must hold at least two points, got {slip.size}")
    if f_t.size != slip.size:
        raise CalibrationError(f"field '{w}.f_t' has {f_t.size} values for {slip.size} slip values")
    if slip[0] < 0.0:
        raise CalibrationError(
            f"field '{w}.slip[0]' must be >= 0 (the slide starts at 0 from "
            f"the virgin state), got {slip[0]!r}"
        )
    bad = np.flatnonzero(~(np.diff(slip) > 0.0))
    if bad.size:
        j = int(bad[0]) + 1
        raise CalibrationError(
            f"field '{w}.slip[{j}]' = {slip[j]!r}: slip must increase "
            f"strictly (a monotonic slide), after {slip[j - 1]!r}"
        )
    return Curve(f_n, v, slip, f_t)


def parse_data(obj: Any, base: str | Path | None = None) -> CalibrationData:
    """Validate a DATA.json object.

    Args:
        obj: The data.
        base: Directory that CSV files named in it are relative to (default: the current one;
            :func:`load_data` gives the data file's).

    Raises:
        CalibrationError: A missing, unknown or bad field (named), or an unknown parameter name.
    """
    if not isinstance(obj, dict):
        raise CalibrationError(f"the data must be a JSON object, got {type(obj).__name__}")
    try:
        return _parse(obj, base)
    except RecursionError:
        raise CalibrationError("the data nests too deeply") from None


def _parse(obj: dict, base: str | Path | None) -> CalibrationData:
    unknown = sorted(set(obj) - {"params", "fit", "bounds", "curves"})
    if unknown:
        raise CalibrationError(f"unknown fields {unknown}; allowed: params, fit, bounds, curves")
    raw = obj.get("params")
    if not isinstance(raw, dict):
        raise CalibrationError(
            f"field 'params' must be an object with all eight parameters "
            f"{', '.join(NAMES)}; got {short_repr(raw)}"
        )
    unknown = sorted(set(raw) - set(NAMES))
    if unknown:
        raise CalibrationError(
            f"field 'params': unknown parameter names {unknown}; the eight are {', '.join(NAMES)}"
        )
    missing = [k for k in NAMES if k not in raw]
    if missing:
        raise CalibrationError(
            f"field 'params': missing {missing} (give all eight: start "
            "values of the fitted ones, values of the fixed ones)"
        )
    params = {k: _num(f"params.{k}", raw[k]) for k in NAMES}
    try:
        SubloadingLaw(**params)
    except (TypeError, ValueError) as e:
        raise CalibrationError(f"field 'params': {e}") from None
    fit = obj.get("fit")
    if not isinstance(fit, list) or not fit or not all(isinstance(k, str) for k in fit):
        raise CalibrationError(
            f"field 'fit' must be a non-empty list of parameter names, got {short_repr(fit)}"
        )
    bad = [k for k in fit if k not in NAMES]
    if bad:
        raise CalibrationError(
            f"field 'fit': unknown parameter names {bad}; the eight are {', '.join(NAMES)}"
        )
    dup = sorted({k for k in fit if fit.count(k) > 1})
    if dup:
        raise CalibrationError(f"field 'fit' names {dup} more than once")
    rb = obj.get("bounds", {})
    if not isinstance(rb, dict):
        raise CalibrationError(
            f"field 'bounds' must be an object {{name: [lo, hi]}}, got {short_repr(rb)}"
        )
    bad = sorted(set(rb) - set(fit))
    if bad:
        raise CalibrationError(f"field 'bounds': {bad} not fitted (bounds only for names in 'fit')")
    bounds: dict[str, tuple[float, float]] = {}
    for k in fit:
        lo, hi = 0.0, math.inf
        if k in rb:
            b = rb[k]
            if not isinstance(b, list) or len(b) != 2:
                raise CalibrationError(
                    f"field 'bounds.{k}' must be [lo, hi] (null: no bound), got {short_repr(b)}"
                )
            lo_, hi_ = (_num(f"bounds.{k}[{j}]", b[j], allow_none=True) for j in (0, 1))
            lo = 0.0 if lo_ is None else lo_
            hi = math.inf if hi_ is None else hi_
            if not 0.0 <= lo < hi:
                raise CalibrationError(
                    f"field 'bounds.{k}' = [{lo!r}, {hi!r}]: need "
                    "0 <= lo < hi (every parameter is >= 0)"
                )
        x0 = params[k]
        if not x0 > 0.0:
            raise CalibrationError(
                f"field 'params.{k}': the start value of a fitted "
                f"parameter must be > 0 (the fit works on log {k}), "
                f"got {x0!r}"
            )
        if not lo <= x0 <= hi:
            raise CalibrationError(
                f"field 'params.{k}': the start value {x0!r} lies outside "
                f"its bounds [{lo!r}, {hi!r}]"
            )
        bounds[k] = (lo, hi)
    curves = obj.get("curves")
    if not isinstance(curves, list) or not curves:
        raise CalibrationError(
            "field 'curves' must be a non-empty list of curves {f_n, velocity, slip, f_t}"
        )
    cs = tuple(_curve(i, c, base) for i, c in enumerate(curves))
    n = sum(c.slip.size for c in cs)
    if n > MAX_POINTS:
        raise CalibrationError(f"field 'curves': {n} points in all (limit {MAX_POINTS})")
    if n <= len(fit):
        raise CalibrationError(
            f"field 'curves': {n} points for {len(fit)} fitted parameters; "
            "need more points than parameters"
        )
    return CalibrationData(params, tuple(fit), bounds, cs)


def load_data(path: str | Path) -> CalibrationData:
    """Read and validate a DATA.json file.

    Raises:
        CalibrationError: Unreadable or malformed file, or a bad field (named).
    """
    try:
        obj = read_json(path, "data file")
    except CaseError as e:
        raise CalibrationError(str(e)) from None
    return parse_data(obj, Path(path).parent)
