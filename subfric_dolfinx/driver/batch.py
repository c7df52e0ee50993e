"""Many material-point cases advanced together through one vectorised step loop.

:func:`run_cases` runs displacement-controlled cases (several normal stresses, several parameter
sets, several paths) side by side: at every iteration each unfinished case takes its next step,
and the cases sharing a law go through ONE call of the batched return map (each case one point,
with its own time increment). The steps of a case are exactly those :func:`~.run.run_case` takes
(same plan, same arithmetic), so each result equals the one-by-one run (the one numpy map gives
the same numbers for a point whatever the batch size).

Cost: one step of N cases costs one map call on N points plus a fixed loop overhead, instead of
N calls and N loop overheads. With few cases the map's fixed cost per call dominates (some
hundred us); from some hundreds of cases on its cost per point does (1-5 us per point).
``benchmarks/driver_steps.py`` measures it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..constitutive import UNSTABLE, InterfaceState, Status
from .case import MAX_TOTAL_STEPS, Case, CaseError, parse_case
from .path import end_steps, plan_steps, step_arrays
from .run import DriverResult, fields, own_columns

__all__ = ["run_cases"]

_JUMP, _FAILED = int(Status.JUMP), int(Status.FAILED)
_NAMES = [s.name for s in Status]


class _Group:
    """Cases sharing one law (and n_tangential): their step arrays and their joint state."""

    def __init__(self, law: Any, nt: int, members: list[int], steps: list[tuple]) -> None:
        self.law = law
        self.nt = nt
        self.members = np.array(members)
        self.n_steps = np.array([steps[c][0].size for c in members])
        S = int(self.n_steps.max())
        k = len(members)
        m = nt + 1
        # padded per-step arrays (step, case): finished cases are dropped from the calls
        self.gap = np.zeros((S, k, m))
        self.dt = np.zeros((S, k))
        for j, c in enumerate(members):
            _, dts, vals = steps[c]
            s = dts.size
            self.gap[:s, j, :nt] = vals[:, :nt]
            self.gap[:s, j, nt] = vals[:, 2]
            self.dt[:s, j] = dts
        self.active = np.arange(k)  # positions (in members) still stepping
        self.state: InterfaceState = law.initial_state(k, nt)


def run_cases(
    cases: Sequence[Case | dict[str, Any]],
    *,
    steps_per_mm: float | None = None,
    on_instability: str = "stop",
    max_steps: float = MAX_TOTAL_STEPS,
    progress: Callable[[int, int, float], None] | None = None,
) -> list[DriverResult]:
    """Run displacement-controlled cases together; return one result per case, in order.

    Args:
        cases: :class:`Case` objects or their JSON-like dictionaries (any laws, paths, sample
            times; ``control`` must be ``"disp"``).
        steps_per_mm: Overrides every case's step density.
        on_instability: ``"stop"``: a case stops at its first loss of stability (the others go
            on); ``"continue"``: go on, flagged.
        max_steps: Limit of the total number of steps of each case.
        progress: Called every 2000 iterations as ``progress(iteration, iterations, 0.0)``.

    Returns:
        The results, as :func:`~.run.run_case` would give them (``wall_time`` is the whole
        batch's).

    Raises:
        CaseError: An invalid case (named by its index), a stress-controlled one, or more steps
            than the limits.
        RuntimeError: The return map failed at a point of a case.
    """
    if on_instability not in ("stop", "continue"):
        raise ValueError(f"on_instability must be 'stop' or 'continue', got {on_instability!r}")
    parsed: list[Case] = []
    for i, c in enumerate(cases):
        try:
            case = c if isinstance(c, Case) else parse_case(c)
        except CaseError as e:
            raise CaseError(f"case {i}: {e}") from None
        if not isinstance(case, Case) or case.control != "disp":  # (a SliderCase has none)
            raise CaseError(
                f"case {i}: the batch driver runs displacement control only; run "
                "stress-controlled and slider cases with run_case"
            )
        parsed.append(case)
    spms = []
    for case in parsed:
        spm = case.steps_per_mm if steps_per_mm is None else float(steps_per_mm)
        if not (np.isfinite(spm) and spm > 0):
            raise CaseError(f"steps_per_mm must be finite and > 0, got {steps_per_mm!r}")
        spms.append(spm)
    t_start = time.perf_counter()
    plans = []
    for i, (case, spm) in enumerate(zip(parsed, spms, strict=True)):
        try:
            plans.append(plan_steps(case, spm, max_steps))
        except CaseError as e:
            raise CaseError(f"case {i}: {e}") from None
    steps = [step_arrays(p) for p in plans]
    groups: dict[tuple, list[int]] = {}
    for i, case in enumerate(parsed):
        groups.setdefault((case.law, case.n_tangential), []).append(i)
    runs = [_CaseLog(parsed[i], plans[i], steps[i]) for i in range(len(parsed))]
    gs = [_Group(law, nt, members, steps) for (law, nt), members in groups.items()]
    stop = on_instability == "stop"
    S = max(int(g.n_steps.max()) for g in gs) if gs else 0
    for it in range(S):
        for g in gs:
            if g.active.size:
                _step(g, it, runs, stop)
        if progress is not None and it and it % 2000 == 0:
            progress(it, S, 0.0)
    wall = time.perf_counter() - t_start
    return [r.result(wall) for r in runs]


class _CaseLog:
    """Samples, counts and the stability record of one case of a batch."""

    def __init__(self, case: Case, plan: Any, steps: tuple) -> None:
        self.case = case
        self.times = steps[0]
        self.fields = fields(case.law)
        self.own = own_columns(case.law, case.n_tangential)
        knot_step = end_steps(plan)
        # the step after which each sample is taken (samples are knots)
        self.sample_steps = knot_step[np.searchsorted(plan.knots, case.t_samples)]
        self.next_sample = 0
        self.rows: list[list[float]] = []
        self.row_status: list[str] = []
        self.counts = np.zeros(len(Status) + 1, dtype=np.int64)
        self.lost: dict[str, Any] | None = None
        self.n_steps = 0
        self.complete = False

    def row(self, t: float, tr: np.ndarray, st: InterfaceState, j: int, gap: np.ndarray) -> list:
        nt = self.case.n_tangential
        f2 = [float(tr[0]), float(tr[1]) if nt == 2 else 0.0]
        u2 = [float(gap[0]), float(gap[1]) if nt == 2 else 0.0]
        own = [
            0.0 if k == -1 else float(st[name][j] if k is None else st[name][j, k])
            for name, k in self.own
        ]
        return [t, *f2, float(tr[nt]), *own, *u2, float(gap[nt])]

    def result(self, wall: float) -> DriverResult:
        arr = np.array(self.rows).reshape(-1, len(self.fields))
        counts = {name: int(self.counts[i]) for i, name in enumerate(_NAMES)}
        counts[UNSTABLE] = int(self.counts[-1])
        return DriverResult(
            {k: arr[:, i] for i, k in enumerate(self.fields)},
            self.row_status,
            counts,
            self.lost,
            self.n_steps,
            wall,
            self.complete,
        )


def _step(g: _Group, it: int, runs: list[_CaseLog], stop: bool) -> None:
    """Iteration ``it`` of the group's active cases: one map call, then the bookkeeping."""
    act = g.active
    gap = g.gap[it, act]
    dts = g.dt[it, act]
    dt = float(dts[0]) if np.all(dts == dts[0]) else dts
    res = g.law.return_map(gap, g.state, dt)
    status = res.status
    if np.any(status == _FAILED):
        j = int(np.flatnonzero(status == _FAILED)[0])
        c = int(g.members[act[j]])
        t = float(runs[c].times[it])
        raise RuntimeError(f"case {c}: return map failed at t = {t!r} (gap {gap[j].tolist()})")
    g.state = res.state
    tr = res.traction
    unstable = res.unstable
    flagged = unstable | (status == _JUMP)
    done = []
    for j, pos in enumerate(act.tolist()):
        log = runs[int(g.members[pos])]
        log.counts[status[j]] += 1
        log.n_steps += 1
        t = float(log.times[it])
        if unstable[j]:
            log.counts[-1] += 1
        if flagged[j] and log.lost is None:
            row = log.row(t, tr[j], g.state, j, gap[j])
            reason = "den <= 0" if unstable[j] else "jump at a fold"
            log.lost = {"t": t, "reason": reason, **dict(zip(log.fields[1:], row[1:], strict=True))}
        if stop and log.lost is not None:  # (as run_case: no sample of this step, incomplete)
            done.append(j)
            continue
        ss = log.sample_steps
        while log.next_sample < ss.size and ss[log.next_sample] == it:
            log.rows.append(
                log.row(float(log.case.t_samples[log.next_sample]), tr[j], g.state, j, gap[j])
            )
            log.row_status.append(_NAMES[status[j]])
            log.next_sample += 1
        if it == log.times.size - 1:
            log.complete = True
            done.append(j)
    if done:
        keep = np.setdiff1d(np.arange(act.size), done)
        g.active = act[keep]
        g.state = g.state.take(keep)
