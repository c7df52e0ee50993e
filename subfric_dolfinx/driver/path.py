"""A case's path as a plan of steps: knots, the gap at the knots, steps per knot interval.

The knots are the path's rows and the sample times. Between two knots the prescribed gap (or
stress) is linear, so a step's value is interpolated within its knot interval from the two
knot values: the cost of a step does not depend on the number of path rows (the values at all
knots come from one vectorised interpolation up front). Every step count is computed, and the
limits checked, before the first step: a case that would take too long is refused at once.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .case import MAX_STEPS_PER_SEGMENT, MAX_TOTAL_STEPS, Case, CaseError

__all__ = ["StepPlan", "end_steps", "plan_steps", "step_arrays"]


@dataclasses.dataclass(frozen=True)
class StepPlan:
    """The steps of a case at a step density.

    Attributes:
        knots: Knot times (path rows and sample times), (K,).
        values: ``(x1, x2, ubar_n)`` at the knots, (K, 3).
        counts: Steps in each knot interval, (K - 1,), each >= 1.
        total: Steps after the initial one (``counts.sum()``).
    """

    knots: np.ndarray
    values: np.ndarray
    counts: np.ndarray
    total: int


def plan_steps(case: Case, steps_per_mm: float, max_total: float = MAX_TOTAL_STEPS) -> StepPlan:
    """Knots, knot values and step counts of ``case``, with the limits checked.

    A knot interval gets ``ceil(steps_per_mm * L)`` equal steps (at least one), ``L`` being the
    largest change of ``|ubar_t|`` or ``ubar_n`` in it, in mm (under stress control the
    tangential change counts as ``|f_t| / alpha_t`` mm).

    Raises:
        CaseError: A knot interval needs more than ``MAX_STEPS_PER_SEGMENT`` steps, or the case
            more than ``max_total`` in all (the message names the interval, or the total).
    """
    path = case.path
    knots = np.union1d(path[:, 0], case.t_samples)
    values = np.column_stack([np.interp(knots, path[:, 0], path[:, j]) for j in (1, 2, 3)])
    d = np.diff(values, axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        dx = np.hypot(d[:, 0], d[:, 1]) if case.n_tangential == 2 else np.abs(d[:, 0])
        if case.control == "stress":
            dx = dx / case.law.alpha_t
        length = np.maximum(dx, np.abs(d[:, 2]))
        n = steps_per_mm * length - 1e-9
    bad = ~(n <= MAX_STEPS_PER_SEGMENT)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        stress = case.control == "stress"
        what = "tangential stress change / alpha_t" if stress else "change"
        raise CaseError(
            f"field 'path': the {what} between t = {knots[i]:g} and t = {knots[i + 1]:g} is "
            f"{length[i]:g} mm, which needs {n[i]:.3g} steps at steps_per_mm = {steps_per_mm:g} "
            f"(limit {MAX_STEPS_PER_SEGMENT:g}); scale the path or lower steps_per_mm"
        )
    counts = np.maximum(1, np.ceil(n)).astype(np.int64)
    total = int(counts.sum())
    if total > max_total:
        raise CaseError(
            f"field 'path': the case needs {total:.3g} steps in all at steps_per_mm = "
            f"{steps_per_mm:g} (limit {max_total:g}); shorten the path or lower steps_per_mm"
        )
    return StepPlan(knots, values, counts, total)


def step_arrays(plan: StepPlan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every step of a plan: times (S,), time increments (S,), values (S, 3); ``S = total + 1``.

    Step 0 is the initial one (at the first knot, ``dt = 0``); a knot interval's last step ends
    exactly on its end knot (time and value), as in the step loop of :mod:`.run`.
    """
    K = plan.knots.size
    counts = plan.counts
    seg = np.repeat(np.arange(K - 1), counts)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    k = np.arange(plan.total) - start[seg] + 1
    a = k / counts[seg]
    last = k == counts[seg]
    ta, tb = plan.knots[:-1][seg], plan.knots[1:][seg]
    t = np.where(last, tb, ta + (tb - ta) * a)
    va, vb = plan.values[:-1][seg], plan.values[1:][seg]
    v = np.where(last[:, None], vb, va + (vb - va) * a[:, None])
    times = np.concatenate([plan.knots[:1], t])
    values = np.concatenate([plan.values[:1], v])
    dts = np.diff(times, prepend=times[0])
    return times, dts, values


def end_steps(plan: StepPlan) -> np.ndarray:
    """Index of the step ending at each knot (0 for the first knot), (K,)."""
    return np.concatenate([[0], np.cumsum(plan.counts)])
