"""The run's history: one row per converged step, kept in memory and written as CSV by rank 0.

A row holds the step (``step``, ``t``, ``dt``, ``newton``, ``cuts``), the interface summary
(:func:`~.summary.interface_summary`: resultant forces, area-weighted means of the traction and of
the law's internal variables, status fractions) and the reaction force of every Dirichlet group
(``R_<group>_x``, ``R_<group>_y`` [, ``R_<group>_z``]), a dynamic problem's energy accounts
(:data:`~subfric_dolfinx.fem.dynamics.ENERGY_COLUMNS`), then the columns of ``columns()`` if given
(e.g. probes).

Units: beside the CSV file, ``history.csv-metadata.json`` describes every column (its unit and
what it is, :func:`~.units.column_unit`; the frame and the ``status`` legend) in the W3C
"CSV on the Web" metadata format (``tableSchema.columns``: ``name``, ``dc:description``,
``schema:unitText``), so the CSV stays one header line and numbers for every reader.

In memory the rows are a :class:`HistoryRows`: a sequence of dicts to its reader, stored as one
float64 array (8 bytes a column: about 170 bytes a step for a 21-column row, several times less
than a list of dicts), so a run of :data:`~subfric_dolfinx.fem.stepping.MAX_STEPS` (a million)
steps keeps about 170 MB of history (plus half that at most while the array grows).

Writing is collective: rank 0 writes and flushes each row inside ``try`` and every rank raises the
same :class:`~.collective.OutputError` if that failed (naming the file and the OS error); the file
is then closed, and nothing more is written to it.
"""

from __future__ import annotations

import csv
import json
import operator
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, overload

import numpy as np

from .collective import collective
from .links import opener, write_text_nofollow
from .summary import interface_summary
from .units import FRAME, column_unit, status_legend

__all__ = ["HistoryCSV", "HistoryRows", "history_metadata", "write_history_file"]


class HistoryRows(Sequence[dict[str, float]]):
    """The history's rows, stored compactly; read as a sequence of dicts (one per step).

    Every row is a row of one float64 array; reading a row makes its dict (a fresh one each
    time: changing it does not change the history). Columns whose first value was an integer
    (``step``, ``newton``, ``cuts``) are read as integers. A row with other columns than the
    earlier ones (a restart with other probes) adds them; each row reads back with its own keys.

    Args:
        rows: Rows to start from.
    """

    def __init__(self, rows: Iterable[Mapping[str, float]] = ()) -> None:
        self.columns: list[str] = []
        self._index: dict[str, int] = {}
        self._ints: list[bool] = []
        self._data = np.empty((0, 0))
        self._has: np.ndarray | None = None  # which row has which column, once they differ
        self._n = 0
        for r in rows:
            self.append(r)

    def append(self, row: Mapping[str, float]) -> None:
        """Add a row (its values as floats)."""
        new = [k for k in row if k not in self._index]
        if new and self._n and self._has is None:
            self._has = np.ones((len(self._data), len(self.columns)), dtype=bool)
        for k in new:
            self._index[k] = len(self.columns)
            self.columns.append(k)
            self._ints.append(isinstance(row[k], int) and not isinstance(row[k], bool))
        width = len(self.columns)
        if self._n == len(self._data) or width > self._data.shape[1]:
            grown = np.zeros(
                (
                    max(16, 2 * len(self._data)) if self._n == len(self._data) else len(self._data),
                    width,
                )
            )
            grown[: self._n, : self._data.shape[1]] = self._data[: self._n]
            self._data = grown
            if self._has is not None:
                has = np.zeros(grown.shape, dtype=bool)
                has[: self._n, : self._has.shape[1]] = self._has[: self._n]
                self._has = has
        if len(row) < width and self._has is None:
            self._has = np.ones(self._data.shape, dtype=bool)
        for k, v in row.items():
            self._data[self._n, self._index[k]] = v
        if self._has is not None:
            self._has[self._n] = False
            self._has[self._n, [self._index[k] for k in row]] = True
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def _row(self, i: int) -> dict[str, float]:
        values = self._data[i].tolist()
        has = self._has[i] if self._has is not None else None
        return {
            c: int(v) if is_int else v
            for j, (c, v, is_int) in enumerate(zip(self.columns, values, self._ints, strict=True))
            if has is None or has[j]
        }

    @overload
    def __getitem__(self, i: int) -> dict[str, float]: ...
    @overload
    def __getitem__(self, i: slice) -> list[dict[str, float]]: ...
    def __getitem__(self, i: int | slice) -> dict[str, float] | list[dict[str, float]]:
        if isinstance(i, slice):
            return [self._row(k) for k in range(*i.indices(self._n))]
        k = operator.index(i)
        if not -self._n <= k < self._n:
            raise IndexError(f"history row {i} of {self._n}")
        return self._row(k % self._n)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Sequence) and not isinstance(other, str | bytes):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"HistoryRows({self._n} rows, columns {self.columns})"

    def nbytes(self) -> int:
        """Bytes of the stored values (the array, with its room to grow)."""
        return self._data.nbytes + (self._has.nbytes if self._has is not None else 0)


def history_metadata(
    path: Path,
    columns: Sequence[str],
    law: Any,
    gdim: int,
    mode: str | None = None,
    extra: Mapping[str, tuple[str, str]] | None = None,
) -> dict[str, Any]:
    """The CSV-on-the-Web metadata of a history file: every column's unit and meaning.

    Args:
        path: The CSV file.
        columns: Its columns.
        law: The friction law (its variables' units); ``None``: only ``extra`` names units.
        gdim: The geometric dimension.
        mode: The problem's mode (``"axisymmetric"``: forces are totals, in N).
        extra: Column -> (unit, description) of columns of the caller's own (these first).
    """
    cols = []
    for name in columns:
        known = (extra or {}).get(name)
        if known is None:
            known = column_unit(name, law, gdim, mode) if law is not None else ("?", "")
        unit, what = known
        cols.append(
            {
                "name": name,
                "titles": name,
                "datatype": "number",
                "dc:description": what,
                "schema:unitText": unit,
            }
        )
    if mode == "axisymmetric":
        forces = "N (totals over the circumference), areas mm2"
    else:
        forces = "N, areas mm2" if gdim == 3 else "N/mm and areas mm per unit thickness"
    return {
        "@context": ["http://www.w3.org/ns/csvw", {"@language": "en"}],
        "url": path.name,
        "dc:description": "subfric-dolfinx run history: one row per converged step; units MPa, "
        f"mm, s; forces {forces}; " + FRAME,
        "status_legend": status_legend(),
        "tableSchema": {"columns": cols},
    }


def write_history_file(
    path: str | Path,
    rows: Sequence[Mapping[str, float]],
    problem: Any = None,
    extra: Mapping[str, tuple[str, str]] | None = None,
    gdim: int | None = None,
) -> None:
    """Write rows of one's own as a history CSV file with its metadata (one process).

    For a history kept by one's own step callback (columns of its own beside those of
    :class:`HistoryCSV`): ``path`` and ``<path>-metadata.json`` (:func:`history_metadata`), each
    written to a temporary file and renamed; a link at either name is refused.

    Args:
        path: The CSV file.
        rows: One mapping per row, every row with the first row's columns.
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem` (law, dimension, mode), or
            ``None`` (a loop of one's own: ``extra`` names every column's unit).
        extra: Column -> (unit, description) of the columns :func:`.column_unit` does not know.
        gdim: The dimension without a problem (the forces' unit in the description).
    """
    path = Path(path)
    columns = list(rows[0]) if rows else []
    law = getattr(problem, "law", None)
    dim = getattr(problem, "gdim", gdim or 3)
    meta = history_metadata(path, columns, law, dim, getattr(problem, "mode", None), extra)
    lines = [",".join(columns)]
    lines += [",".join(f"{float(r[k]):.17g}" for k in columns) for r in rows]
    files = {
        path: "\n".join(lines) + "\n",
        path.with_name(path.name + "-metadata.json"): json.dumps(meta, indent=1) + "\n",
    }
    for target, text in files.items():
        tmp = target.with_name(target.name + ".tmp")
        if tmp.is_symlink():
            tmp.unlink()
        write_text_nofollow(tmp, text)
        os.replace(tmp, target)


class HistoryCSV:
    """One row per converged step, kept in memory (``rows``) and written to a CSV file by rank 0.

    Args:
        path: File to write (parent directories are created); ``None``: memory only.
        problem: The problem (for the averages and the reaction forces).
        columns: More columns of each row (collective), e.g. probes.
    """

    def __init__(
        self,
        path: str | Path | None,
        problem: Any,
        columns: Callable[[], dict[str, float]] | None = None,
    ) -> None:
        self.path = Path(path) if path is not None else None
        self.problem = problem
        self.columns = columns
        self._writer: Any = None
        self._file: Any = None
        self.rows = HistoryRows()

    def preload(self, rows: Iterable[Mapping[str, float]]) -> None:
        """Start from the rows of an earlier run (a restart); they are written first."""
        self.rows = HistoryRows(rows)

    def write(self, record: Any) -> dict[str, float]:
        """Append the row of a converged step (a :class:`~subfric_dolfinx.fem.StepRecord`)."""
        p = self.problem
        row: dict[str, float] = {
            "step": record.step,
            "t": record.t,
            "dt": record.dt,
            "newton": record.iterations,
            "cuts": record.cuts,
        }
        row.update(interface_summary(p))
        for group, force in p.reactions.items():
            for i, f in enumerate(force):
                row[f"R_{group}_{'xyz'[i]}"] = float(f)
        row.update(getattr(record, "energy", None) or {})  # a dynamic problem's accounts
        if self.columns is not None:
            row.update(self.columns())
        self.rows.append(row)
        if self.path is not None:
            collective(
                p.comm,
                lambda: self._append(row),
                f"writing {str(self.path)!r}",
                path=self.path,
                cleanup=self._discard,
            )
        return row

    def _append(self, row: dict[str, float]) -> None:
        """Write a row (rank 0), the header and the preloaded rows first."""
        assert self.path is not None
        if self._writer is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            meta = self.path.with_name(self.path.name + "-metadata.json")
            tmp = meta.with_name(meta.name + ".tmp")
            p = self.problem
            text = json.dumps(
                history_metadata(self.path, list(row), p.law, p.gdim, getattr(p, "mode", None)),
                indent=1,
            )
            write_text_nofollow(tmp, text + "\n")
            os.replace(tmp, meta)
            self._file = open(self.path, "w", newline="", opener=opener)
            self._writer = csv.DictWriter(self._file, fieldnames=list(row))
            self._writer.writeheader()
            for old in self.rows[:-1]:  # preloaded rows of a restart
                self._writer.writerow({k: f"{v:.17g}" for k, v in old.items()})
        self._writer.writerow({k: f"{v:.17g}" for k, v in row.items()})
        self._file.flush()

    def _discard(self) -> None:
        """After a failed write: close the file, dropping what could not be written."""
        self.path = None
        f, self._file = self._file, None
        if f is not None:
            try:
                f.close()
            except OSError:
                pass

    def close(self) -> None:
        """Close the file (collective: a failure is raised on every rank)."""
        if self.path is not None:
            f, path = self._file, self.path
            self._file = self._writer = self.path = None
            collective(
                self.problem.comm,
                lambda: f.close() if f is not None else None,
                f"closing {str(path)!r}",
                path=path,
            )
