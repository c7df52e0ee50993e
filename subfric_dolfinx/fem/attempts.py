"""What a load step's attempt saw at the interface: the return map's statuses and activity.

:func:`describe_attempt` (the worst point of the last evaluation, for a failed step's message)
and :func:`interface_activity` (the fractions of points that slide and that are open, for the
progress lines) of :class:`~.stepping.LoadStepper`, over every interface of the problem.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from mpi4py import MPI

from ..constitutive import UNSTABLE, Status

__all__ = [
    "SLIDING_FRACTION",
    "AttemptReport",
    "WorstPoint",
    "describe_attempt",
    "interface_activity",
]

SLIDING_FRACTION = 0.95
"""A point slides when it slips plastically with a traction at this fraction of the law's strength
or more (below it, a closed point sticks: the subloading law's micro-slip included)."""

_SEVERITY = (
    Status.SEPARATED.name,
    Status.ELASTIC.name,
    Status.PLASTIC.name,
    Status.JUMP.name,
    UNSTABLE,
    Status.FAILED.name,
)


@dataclasses.dataclass(frozen=True)
class WorstPoint:
    """The point of the most severe status at an attempt (:func:`describe_attempt`).

    Attributes:
        status: Its status name (a :class:`~subfric_dolfinx.constitutive.Status` name or
            :data:`~subfric_dolfinx.constitutive.UNSTABLE`).
        x: Its coordinates.
        traction: Its local traction ``(f_t, [f_t2,] f_n)`` (MPa).
        gap: Its local gap ``(ubar_t, [ubar_t2,] ubar_n)`` (mm).
    """

    status: str
    x: tuple[float, ...]
    traction: tuple[float, ...]
    gap: tuple[float, ...]


@dataclasses.dataclass(frozen=True)
class AttemptReport:
    """What the return map saw at the last evaluation of an attempt (:func:`describe_attempt`).

    Attributes:
        counts: Points per status name, and :data:`~subfric_dolfinx.constitutive.UNSTABLE`,
            over all ranks.
        worst: The point of the most severe status (FAILED, UNSTABLE, JUMP, PLASTIC, ELASTIC,
            SEPARATED) and, among those, of the largest traction; ``None`` without points.
        text: A one-line summary of both.
    """

    counts: Mapping[str, int]
    worst: WorstPoint | None
    text: str


def describe_attempt(problem: Any) -> AttemptReport:
    """What the return map saw at its last evaluation (collective; the same on every rank).

    Returns:
        The counts per status, the worst point and their summary.
    """
    names = [s.name for s in Status] + [UNSTABLE]
    local = np.zeros(len(names), dtype=np.int64)
    candidate = None
    ifaces = problem.interfaces
    for iname, iface in ifaces.items():
        el = iface.law_points
        res = el.last
        if res is None or not res.status.size:
            continue
        c = res.counts()
        local += [c.get(n, 0) for n in names]
        st = res.status
        sev = np.select(
            [
                st == Status.FAILED,
                res.unstable,
                st == Status.JUMP,
                st == Status.PLASTIC,
                st == Status.ELASTIC,
            ],
            [5, 4, 3, 2, 1],
            0,
        )
        size = np.linalg.norm(res.traction, axis=1)
        i = int(np.lexsort((size, sev))[-1])
        x = el.points.reshape(-1, problem.gdim)[i]
        mine = (
            int(sev[i]),
            float(size[i]),
            tuple(float(v) for v in x),
            tuple(float(v) for v in res.traction[i]),
            tuple(float(v) for v in el.last_gap[i]),
            iname if len(ifaces) > 1 else "",
        )
        candidate = mine if candidate is None else max(candidate, mine)
    counts_arr = np.zeros_like(local)
    problem.comm.Allreduce(local, counts_arr)
    counts = {n: int(v) for n, v in zip(names, counts_arr, strict=True)}
    found = [cand for cand in problem.comm.allgather(candidate) if cand is not None]
    worst = None
    total = sum(counts[s.name] for s in Status)
    shown = ", ".join(f"{n} {counts[n]}" for n in reversed(_SEVERITY) if counts[n])
    text = f"return map at the last iterate: {shown or 'no point'} (of {total} points)"
    if found:
        sev, _, x, tr, gap, iname = max(found)
        worst = WorstPoint(_SEVERITY[sev], x, tr, gap)

        def fmt(v: tuple[float, ...]) -> str:
            return "(" + ", ".join(f"{a:.4g}" for a in v) + ")"

        on = f" on the interface {iname!r}" if iname else ""
        text += (
            f"; worst point {_SEVERITY[sev]}{on} at x = {fmt(x)}: traction (f_t, f_n) = {fmt(tr)} "
            f"MPa, gap (ubar_t, ubar_n) = {fmt(gap)} mm"
        )
    return AttemptReport(counts, worst, text)


def interface_activity(problem: Any) -> tuple[float, float]:
    """Fractions of the interface points that slide and that are open (collective).

    Over every interface of the problem (their points together).

    After a converged step (committed state): a point slides when its status is PLASTIC or JUMP
    and its tangential traction is at least :data:`SLIDING_FRACTION` of the law's strength at its
    normal traction; it is open when SEPARATED; the others stick.

    Returns:
        ``(sliding, open)``, the same on every rank.
    """
    local = np.zeros(3)
    for iface in problem.interfaces.values():  # every interface's points together
        el = iface.law_points
        res = el.last
        if res is None or not res.status.size:
            continue
        nt = el.nt
        st = res.status
        f_t = np.linalg.norm(res.traction[:, :nt], axis=1)
        strength = iface.law.strength(el.state.old, res.traction[:, nt], 0.0)
        plastic = (st == Status.PLASTIC) | (st == Status.JUMP)
        sliding = plastic & (f_t >= SLIDING_FRACTION * strength) & (strength > 0.0)
        local += np.count_nonzero(sliding), np.count_nonzero(st == Status.SEPARATED), st.size
    total = np.zeros(3)
    problem.comm.Allreduce(local, total, op=MPI.SUM)
    n = max(total[2], 1.0)
    return float(total[0] / n), float(total[1] / n)
