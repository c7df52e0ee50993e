"""An independent reference of the subloading return map: the same algorithm in plain Python
floats, one point at a time (the package's scalar path before issue 26, where it ran batches of
at most 32 points; kept here only to test the package's one numpy map against a second
implementation: ``tests/constitutive/test_return_map_paths.py``).

:func:`return_map` takes the arguments of ``SubloadingLaw.return_map`` and returns the arrays
of its result. :mod:`.point` is the readable specification of one step; :mod:`.root` (branch and
certified smallest root, with the branch-and-bound :mod:`.scan`), :mod:`.switch` (the split of
the elastic trial segment), :mod:`.rotation` and :mod:`.general` (rotation of the flow direction
and the forward derivatives of the tangent).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from subfric_dolfinx.constitutive import CONTACT_TOL, LOAD_TOL

from .common import Law
from .point import point

__all__ = ["Result", "return_map"]


@dataclasses.dataclass
class Result:
    traction: np.ndarray
    tangent: np.ndarray
    up: np.ndarray
    mu: np.ndarray
    r: np.ndarray
    status: np.ndarray
    unstable: np.ndarray
    iterations: np.ndarray


def return_map(law, gap, state, dt, *, tol=LOAD_TOL, max_iter=100, contact_tol=CONTACT_TOL):
    """The step of every point of ``state`` (an ``InterfaceState``, with or without ``f``) to
    ``gap``; ``dt`` a float or one per point."""
    L = Law(law)
    gap = np.asarray(gap, dtype=float)
    n = gap.shape[0]
    f = state["f"].tolist() if "f" in state else [None] * n
    dts = np.broadcast_to(np.asarray(dt, dtype=float), (n,)).tolist()
    rows = zip(
        gap.tolist(),
        state["up"].tolist(),
        state["mu"].tolist(),
        state["r"].tolist(),
        f,
        dts,
        strict=True,
    )
    res = [point(L, g, u, mu, r, f0, d, tol, max_iter, contact_tol) for g, u, mu, r, f0, d in rows]
    return Result(
        np.array([q[0] for q in res]).reshape(n, -1),
        np.array([q[1] for q in res]).reshape(n, gap.shape[1], gap.shape[1]),
        np.array([q[2] for q in res]).reshape(n, -1),
        np.array([q[3] for q in res]),
        np.array([q[4] for q in res]),
        np.array([q[5] for q in res], dtype=np.int8),
        np.array([q[6] for q in res], dtype=bool),
        np.array([q[7] for q in res], dtype=np.int64),
    )
