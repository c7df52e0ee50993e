"""What a scene run returns."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["SceneResult"]


@dataclasses.dataclass
class SceneResult:
    """What a scene produced.

    Attributes:
        name: Scene name.
        kind: ``"fe"`` or ``"pointwise"``.
        cases: Pointwise: case name -> :class:`~subfric_dolfinx.driver.DriverResult`.
        history: FE: one dict per converged step (see :class:`~subfric_dolfinx.io.HistoryCSV`),
            a :class:`~subfric_dolfinx.io.HistoryRows` (stored compactly, read as dicts).
        snapshots: FE: time -> interface profile (arrays over all interface points, in the order
            of :func:`~subfric_dolfinx.io.gather_interface`: ``x``, ``f_t``, ``f_n``, ``status``
            and the law's internal variables by name); with several interfaces, time -> interface
            name -> profile.
        timing: FE: seconds per section (max over ranks) and ``total``.
        iterations: FE: Newton iterations per step.
        files: Paths written.
        info: Sizes (cells, dofs, interface points, ranks) and the final interface summary.
    """

    name: str
    kind: str
    cases: dict[str, Any] = dataclasses.field(default_factory=dict)
    history: Sequence[dict[str, float]] = dataclasses.field(default_factory=list)
    snapshots: dict[float, dict[str, np.ndarray]] = dataclasses.field(default_factory=dict)
    timing: dict[str, float] = dataclasses.field(default_factory=dict)
    iterations: list[int] = dataclasses.field(default_factory=list)
    files: list[str] = dataclasses.field(default_factory=list)
    info: dict[str, Any] = dataclasses.field(default_factory=dict)
