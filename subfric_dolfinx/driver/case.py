"""Material-point cases: the validated form of CASE.json, from a file or a dictionary.

See :mod:`subfric_dolfinx.driver` for the JSON form.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..constitutive import FrictionLaw, LawError, build_law
from ..values import short_repr
from .checks import CaseError, field_number
from .slider import SliderCase, parse_slider

__all__ = [
    "DEFAULT_STEPS_PER_MM",
    "MAX_STEPS_PER_SEGMENT",
    "MAX_TOTAL_STEPS",
    "Case",
    "load_case",
    "parse_case",
    "read_json",
    "read_table",
    "table_spec",
]

DEFAULT_STEPS_PER_MM = 200.0
MAX_STEPS_PER_SEGMENT = 1e7  # steps between two knots of the path; more is a mistake
MAX_TOTAL_STEPS = 1e8  # steps of a whole case (about an hour at 30 us per step)
MAX_CASE_BYTES = 1 << 30  # a case file larger than this is refused before it is read
MAX_JSON_DEPTH = 64  # arrays and objects nested deeper than this are refused


@dataclasses.dataclass(frozen=True)
class Case:
    """A validated material-point case (see the module docstring for the JSON form)."""

    law: FrictionLaw
    control: str
    path: np.ndarray
    t_samples: np.ndarray
    n_tangential: int = 2
    steps_per_mm: float = DEFAULT_STEPS_PER_MM


def parse_case(obj: Any, base: str | Path | None = None) -> Case | SliderCase:
    """Validate a case given as a JSON-like dictionary.

    Args:
        obj: The case.
        base: Directory that a CSV file named in the case is relative to (default: the current
            one; :func:`load_case` gives the case file's).

    Raises:
        CaseError: The message names the offending field.
    """
    if not isinstance(obj, dict):
        raise CaseError(f"the case must be a JSON object, got {type(obj).__name__}")
    try:
        return _parse(obj, base)
    except RecursionError:  # (a deeply nested value somewhere in a field)
        raise CaseError("the case nests too deeply") from None


PATH_COLUMNS = ("t", "x1", "x2", "ubar_n")
"""The columns of a path: time (s), the two tangential components (``ubar_t`` in mm under
displacement control, ``f_t`` in MPa under stress control) and ``ubar_n`` (mm)."""


def _path_rows(raw: Any, nt: int, base: str | Path | None) -> list[list[float]]:
    """The path's rows from a list of rows or from ``{"csv": FILE, "columns": {...}}``."""
    if isinstance(raw, dict):
        cols = table_spec(raw, "path", PATH_COLUMNS)
        required = {k: k != "x2" or nt == 2 for k in PATH_COLUMNS}
        table = read_table(
            raw["csv"],
            {k: (cols[k], required[k]) for k in PATH_COLUMNS},
            what="field 'path.csv'",
            base=base,
        )
        n = len(table["t"])
        if n < 2:
            raise CaseError(f"field 'path.csv': {raw['csv']!r} holds {n} row(s), need two")
        x2 = table.get("x2", np.zeros(n))
        table_rows = np.column_stack([table["t"], table["x1"], x2, table["ubar_n"]])
        return cast(list[list[float]], table_rows.tolist())
    if not isinstance(raw, list) or len(raw) < 2:
        raise CaseError(
            "field 'path' must be a list of at least two rows [t, x1, x2, ubar_n], or "
            '{"csv": FILE} (columns t, x1, x2, ubar_n)'
        )
    rows = []
    for i, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != 4:
            raise CaseError(
                f"field 'path[{i}]' must be a row [t, x1, x2, ubar_n], got {short_repr(row)}"
            )
        rows.append([field_number(f"path[{i}][{j}]", v) for j, v in enumerate(row)])
    return rows


def table_spec(raw: dict, where: str, names: tuple[str, ...]) -> dict[str, str]:
    """Check a table given as ``{"csv": FILE, "columns": {name: header}}``.

    Args:
        raw: The object (a case's ``path``, a calibration curve's ``csv`` and ``columns``).
        where: Its key path in messages (``"path"``, ``"curves[0]"``).
        names: The names its columns may be given for.

    Returns:
        The header of each name in the file: as ``columns`` maps it, else the name itself.

    Raises:
        CaseError: An unknown key or name, no file name, ``columns`` not names to headers.
    """
    unknown = sorted(set(raw) - {"csv", "columns"})
    if unknown:
        raise CaseError(f"field '{where}': unknown keys {unknown}; allowed: csv, columns")
    if not isinstance(raw.get("csv"), str) or not raw["csv"]:
        got = short_repr(raw.get("csv"))
        raise CaseError(f"field '{where}.csv' must be a file name, got {got}")
    cols = raw.get("columns", {})
    if not isinstance(cols, dict) or not all(isinstance(v, str) for v in cols.values()):
        raise CaseError(
            f"field '{where}.columns' must map names to the file's column headers, got "
            f"{short_repr(cols)}"
        )
    bad = sorted(set(cols) - set(names))
    if bad:
        raise CaseError(f"field '{where}.columns': unknown names {bad}; allowed: {list(names)}")
    return {k: cols.get(k, k) for k in names}


MAX_TABLE_COLUMNS = 1000  # a header with more fields than this is not a table of ours


def read_table(
    path: str | Path,
    columns: Mapping[str, tuple[str, bool]],
    *,
    what: str,
    base: str | Path | None = None,
) -> dict[str, np.ndarray]:
    """Columns of numbers from a CSV file, by header name (the file is data: only read).

    The first line that is not blank and not a comment (``#``) is the header; the delimiter is
    the one of ``,``, ``;`` and tab that splits it into the most fields. Every other line is a
    row of as many fields; the wanted columns must hold finite numbers (a decimal point, not a
    comma). Lines starting with ``#`` (e.g. a units line) and blank lines are skipped.

    Args:
        path: The file; relative to ``base`` if given.
        columns: Name -> (its header in the file, required).
        what: How error messages call it (e.g. ``"field 'path.csv'"``).
        base: Directory of relative paths: the folder of the case (or data) file. The table
            must lie in it or below (resolved: not through ``..``, an absolute path elsewhere
            or a symbolic link leading out): a case file names its own data, never a file
            elsewhere (whose first line an error would show).

    Returns:
        Name -> values, for the required columns and the optional ones present.

    Raises:
        CaseError: Outside ``base``, not a regular file, unreadable, too large, not UTF-8, no
            header, a field beyond the csv module's limit, a required column missing, a short
            row or a value that is not a finite number (file, line and column named).
    """
    p = Path(path)
    if base is not None and not p.is_absolute():
        p = Path(base) / p
    if base is not None:
        top = os.path.realpath(base)
        if os.path.commonpath([top, os.path.realpath(p)]) != top:
            link = f" (a symbolic link to {os.readlink(p)!r})" if p.is_symlink() else ""
            raise CaseError(
                f"{what}: {str(path)!r}{link} lies outside the folder of the file that names "
                f"it ({str(base)!r}): not read; put the table in that folder"
            )
    try:
        if not p.is_file():
            raise CaseError(f"{what}: {str(p)!r} is not a file")
        if p.stat().st_size > MAX_CASE_BYTES:
            raise CaseError(f"{what}: {str(p)!r} is larger than {MAX_CASE_BYTES} bytes")
        data = p.read_bytes()
    except OSError as e:
        raise CaseError(f"{what}: cannot read {str(p)!r}: {e.strerror}") from None
    try:
        text = data.decode("utf-8-sig")  # a spreadsheet's byte-order mark is accepted
    except UnicodeDecodeError as e:
        raise CaseError(f"{what}: {str(p)!r} is not UTF-8 text (byte {e.start})") from None
    lines = [
        (i + 1, ln)
        for i, ln in enumerate(text.splitlines())
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        raise CaseError(f"{what}: {str(p)!r} has no header line (the columns' names)")
    first = lines[0][1]
    delimiter = max((",", ";", "\t"), key=lambda d: len(first.split(d)))
    reader = csv.reader(io.StringIO("\n".join(ln for _, ln in lines)), delimiter=delimiter)
    try:
        rows = list(reader)
    except csv.Error as e:  # e.g. a field beyond csv.field_size_limit()
        line = lines[min(max(reader.line_num, 1), len(lines)) - 1][0]
        raise CaseError(f"{what}: {str(p)!r} line {line}: {e}") from None
    header = [h.strip() for h in rows[0]]
    if len(header) > MAX_TABLE_COLUMNS:
        raise CaseError(f"{what}: {str(p)!r} has {len(header)} columns (limit {MAX_TABLE_COLUMNS})")
    where: dict[str, int] = {}
    for name, (head, required) in columns.items():
        if head in header:
            where[name] = header.index(head)
        elif required:
            raise CaseError(
                f"{what}: {str(p)!r} has no column {head!r}; its columns: {short_repr(header, 200)}"
            )
    out = {name: np.empty(len(rows) - 1) for name in where}
    for k, row in enumerate(rows[1:]):
        line = lines[k + 1][0]
        if len(row) != len(header):
            raise CaseError(
                f"{what}: {str(p)!r} line {line} has {len(row)} fields, the header {len(header)}"
            )
        for name, j in where.items():
            cell = row[j].strip()
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
            if not math.isfinite(x) or not cell:
                raise CaseError(
                    f"{what}: {str(p)!r} line {line}, column {header[j]!r}: "
                    f"{short_repr(cell)} is not a finite number"
                )
            out[name][k] = x
    return out


def _parse(obj: dict, base: str | Path | None = None) -> Case | SliderCase:
    if obj.get("control") == "slider":  # the dynamic control (a SliderCase)
        return parse_slider(obj)
    if "slider" in obj:
        raise CaseError(
            f"field 'control' must be 'slider' in a case with a 'slider' object, got "
            f"{short_repr(obj.get('control'))}"
        )
    allowed = {"law", "params", "control", "path", "t_samples", "n_tangential", "steps_per_mm"}
    unknown = sorted(set(obj) - allowed)
    if unknown:
        raise CaseError(f"unknown field(s) {unknown}; allowed: {sorted(allowed)}")
    try:
        law = build_law(obj)
    except LawError as e:
        raise CaseError(str(e)) from None
    control = obj.get("control")
    if not isinstance(control, str) or control not in ("disp", "stress"):
        raise CaseError(
            f"field 'control' must be 'disp', 'stress' or 'slider', got {short_repr(control)}"
        )
    nt = obj.get("n_tangential", 2)
    if isinstance(nt, bool) or not isinstance(nt, int | float) or nt not in (1, 2):
        raise CaseError(f"field 'n_tangential' must be 1 or 2, got {short_repr(nt)}")
    path = np.array(_path_rows(obj.get("path"), int(nt), base))
    for i in range(1, len(path)):
        if not path[i, 0] > path[i - 1, 0]:
            raise CaseError(
                f"field 'path[{i}][0]': times must increase strictly, got {path[i, 0]!r} "
                f"after {path[i - 1, 0]!r}"
            )
    if nt == 1 and np.any(path[:, 2] != 0.0):
        i = int(np.flatnonzero(path[:, 2] != 0.0)[0])
        raise CaseError(f"field 'path[{i}][2]' must be 0 with n_tangential = 1, got {path[i, 2]!r}")
    ts = obj.get("t_samples")
    if ts == "path":  # every time of the path (e.g. the rows of a measured CSV)
        ts = path[:, 0].tolist()
    if not isinstance(ts, list) or not ts:
        raise CaseError("field 't_samples' must be a non-empty list of times, or \"path\"")
    samples = np.array([field_number(f"t_samples[{i}]", v) for i, v in enumerate(ts)])
    t0, t1 = path[0, 0], path[-1, 0]
    for i, t in enumerate(samples):
        if not t0 <= t <= t1:
            raise CaseError(
                f"field 't_samples[{i}]' = {t!r} lies outside the path [{t0!r}, {t1!r}]"
            )
        if i and t < samples[i - 1]:
            raise CaseError(f"field 't_samples[{i}]': sample times must not decrease")
    spm = obj.get("steps_per_mm", DEFAULT_STEPS_PER_MM)
    spm = field_number("steps_per_mm", spm)
    if spm <= 0:
        raise CaseError(f"field 'steps_per_mm' must be > 0, got {spm!r}")
    return Case(law, control, path, samples, int(nt), spm)


class _Twice(dict):
    """A JSON object with a key given twice: the first value of each key, and which key."""

    key: str
    siblings: list[str]


def _object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object's dict; one with a key given twice is marked.

    ``json.loads`` would keep the last value silently; here the object's place in the file is not
    known yet (:func:`_find_twice` finds it once the file is parsed).
    """
    out = dict(pairs)
    if len(out) == len(pairs):
        return out
    seen: set[str] = set()
    for key, _ in pairs:  # the first key given twice
        if key in seen:
            break
        seen.add(key)
    marked = _Twice()
    for k, v in pairs:
        marked.setdefault(k, v)  # the first value of each key
    marked.key, marked.siblings = key, [k for k in out if k != key]
    return marked


def _find_twice(obj: Any, root: str) -> tuple[str, _Twice] | None:
    """The first object (in the file's order) with a key given twice, and its key path."""
    stack = [(obj, root)]
    while stack:
        o, where = stack.pop()
        if isinstance(o, _Twice):
            return f"{where}.{o.key}" if where else o.key, o
        if isinstance(o, dict):
            stack.extend((v, f"{where}.{k}" if where else k) for k, v in reversed(o.items()))
        elif isinstance(o, list):
            stack.extend((v, f"{where}[{i}]") for i, v in reversed(list(enumerate(o))))
    return None


def read_json(path: str | os.PathLike[str], what: str = "case file", root: str = "") -> Any:
    """Read a JSON file defensively: every malformed file gives one :class:`CaseError`.

    Args:
        path: The file.
        what: How the message calls it (``"case file"``, ``"data file"``).
        root: How a message names the top-level object in a key path (``"scene"`` makes
            ``scene.solver.dt``; by default ``solver.dt``).

    Raises:
        CaseError: Unreadable, a directory, larger than ``MAX_CASE_BYTES``, not UTF-8, invalid
            JSON, a key twice in one object, nested too deeply, or an integer beyond Python's
            digit limit.
    """
    p = Path(path)
    try:
        if p.is_dir():
            raise CaseError(f"{what} {str(p)!r} is a directory")
        if p.stat().st_size > MAX_CASE_BYTES:
            raise CaseError(f"{what} {str(p)!r} is larger than {MAX_CASE_BYTES} bytes")
        data = p.read_bytes()
    except OSError as e:
        raise CaseError(f"cannot read {what} {str(p)!r}: {e.strerror}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        bad = data[e.start : e.start + 1]
        msg = f"{what} {str(p)!r} is not UTF-8 text (byte {e.start}: {bad!r})"
        raise CaseError(msg) from None

    def too_deep(where: str = "") -> CaseError:
        at = f" at {where}" if where else ""
        return CaseError(
            f"{what} {str(p)!r} nests too deeply{at} (more than {MAX_JSON_DEPTH} levels)"
        )

    try:
        obj = json.loads(text, object_pairs_hook=_object)
    except json.JSONDecodeError as e:
        raise CaseError(f"{what} {str(p)!r} is not valid JSON: {e}") from None
    except RecursionError:  # Python <= 3.13's parser recurses; 3.14's does not
        raise too_deep() from None
    except ValueError as e:  # e.g. an integer beyond Python's digit limit
        raise CaseError(f"{what} {str(p)!r} is not valid: {e}") from None
    deep = _too_deep(obj, MAX_JSON_DEPTH)
    if deep is not None:
        raise too_deep(deep)
    twice = _find_twice(obj, root)
    if twice is not None:
        where, o = twice
        raise CaseError(
            f"{what} {str(p)!r} has the key {short_repr(o.key)} twice in one object: {where} "
            f"(beside {short_repr(o.siblings)}): JSON would keep the last one silently"
        )
    return obj


def _too_deep(obj: Any, limit: int) -> str | None:
    """Where a parsed JSON value nests deeper than ``limit``, or None.

    Where: its top-level key or index (e.g. ``'params'``). Iterative: any depth, no recursion.
    """
    stack = [(obj, 1, "")]
    while stack:
        o, d, top = stack.pop()
        if not isinstance(o, dict | list):
            continue
        if d > limit:
            return top
        items = o.items() if isinstance(o, dict) else enumerate(o)
        for k, v in items:
            stack.append((v, d + 1, top or (repr(k) if isinstance(o, dict) else f"[{k}]")))
    return None


def load_case(path: str | Path) -> Case | SliderCase:
    """Read and validate a CASE.json file.

    Raises:
        CaseError: Unreadable file, not UTF-8, invalid JSON (also: nested too deeply, an integer
            beyond Python's digit limit), or a bad field (named in the message).
    """
    return parse_case(read_json(path, "case file"), Path(path).parent)
