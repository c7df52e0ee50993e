"""The run's history: one row per converged step, kept in memory and written as CSV by rank 0.

A row holds the step (``step``, ``t``, ``dt``, ``newton``, ``cuts``), the interface summary
(:func:`~.summary.interface_summary`: resultant forces, area-weighted means of the traction and of
the law's internal variables, status fractions) and the reaction force of every Dirichlet group
(``R_<group>_x``, ``R_<group>_y`` [, ``R_<group>_z``]), then the columns of ``columns()`` if given
(e.g. probes).

Units: beside the CSV file, ``history.csv-metadata.json`` describes every column (its unit and
what it is, :func:`~.units.column_unit`; the frame and the ``status`` legend) in the W3C
"CSV on the Web" metadata format (``tableSchema.columns``: ``name``, ``dc:description``,
``schema:unitText``), so the CSV stays one header line and numbers for every reader.

Writing is collective: rank 0 writes and flushes each row inside ``try`` and every rank raises the
same :class:`~.collective.OutputError` if that failed (naming the file and the OS error); the file
is then closed, and nothing more is written to it.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .collective import collective
from .links import opener, write_text_nofollow
from .summary import interface_summary
from .units import FRAME, column_unit, status_legend

__all__ = ["HistoryCSV", "history_metadata"]


def history_metadata(path: Path, columns: Sequence[str], law: Any, gdim: int) -> dict[str, Any]:
    """The CSV-on-the-Web metadata of a history file: every column's unit and meaning."""
    cols = []
    for name in columns:
        unit, what = column_unit(name, law, gdim)
        cols.append({"name": name, "titles": name, "datatype": "number",
                     "dc:description": what, "schema:unitText": unit})  # fmt: skip
    return {
        "@context": ["http://www.w3.org/ns/csvw", {"@language": "en"}],
        "url": path.name,
        "dc:description": "subfric-dolfinx run history: one row per converged step; units MPa, "
        "mm, s; forces N (3-D) or N/mm per unit thickness (2-D); " + FRAME,
        "status_legend": status_legend(),
        "tableSchema": {"columns": cols},
    }


class HistoryCSV:
    """One row per converged step, kept in memory and written to a CSV file by rank 0.

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
        self.rows: list[dict[str, float]] = []

    def preload(self, rows: list[dict[str, float]]) -> None:
        """Start from the rows of an earlier run (a restart); they are written first."""
        self.rows = [dict(r) for r in rows]

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
        if self.columns is not None:
            row.update(self.columns())
        self.rows.append(row)
        if self.path is not None:
            collective(
                p.comm, lambda: self._append(row), f"writing {str(self.path)!r}",
                path=self.path, cleanup=self._discard,
            )  # fmt: skip
        return row

    def _append(self, row: dict[str, float]) -> None:
        """Write a row (rank 0), the header and the preloaded rows first."""
        assert self.path is not None
        if self._writer is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            meta = self.path.with_name(self.path.name + "-metadata.json")
            tmp = meta.with_name(meta.name + ".tmp")
            p = self.problem
            text = json.dumps(history_metadata(self.path, list(row), p.law, p.gdim), indent=1)
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
                self.problem.comm, lambda: f.close() if f is not None else None,
                f"closing {str(path)!r}", path=path,
            )  # fmt: skip
