"""Per-point status codes and the result of a batched return map."""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from .state import InterfaceState

__all__ = ["UNSTABLE", "ReturnMapResult", "Status"]


class Status(enum.IntEnum):
    """Outcome of the return map at one point.

    * ``ELASTIC``: in contact, no plastic slip in the step.
    * ``PLASTIC``: in contact, plastic slip on the continuous branch (smallest root).
    * ``SEPARATED``: not in contact (``ubar_n <= 0``): zero traction. At ``ubar_n = 0`` exactly
      the tangent is the one-sided elastic one from the contact side (a touching interface is
      stiff).
    * ``JUMP``: plastic, but the smallest root lies beyond a local minimum of the consistency
      function, i.e. the continuous branch ended in a fold inside the step and the solution
      jumped.
    * ``FAILED``: the point could not be integrated (non-finite input or no converged root):
      zero traction, never NaN (its state: ``docs/model.md`` §7).
    """

    ELASTIC = 0
    PLASTIC = 1
    SEPARATED = 2
    JUMP = 3
    FAILED = 4

    @classmethod
    def legend(cls) -> dict[int, str]:
        """Code -> ``"NAME: meaning"``, as written with the integer ``status`` in output files."""
        return {int(s): f"{s.name}: {STATUS_MEANING[s.name]}" for s in cls}


STATUS_MEANING = {
    "ELASTIC": "in contact, no plastic slip in the step (sticking)",
    "PLASTIC": "in contact, plastic slip in the step (the subloading law's micro-slip below its "
    "strength included)",
    "SEPARATED": "not in contact: zero traction",
    "JUMP": "plastic, the solution jumped past a fold of the law in the step",
    "FAILED": "could not be integrated: zero traction, last converged state kept",
}
"""What each :class:`Status` code means, for the legend written in output files."""

UNSTABLE = "UNSTABLE"
"""Key of the count of unstable points (:attr:`ReturnMapResult.unstable`, a flag beside the
status, not a status) in :meth:`ReturnMapResult.counts` and the counts built on it."""


@dataclasses.dataclass
class ReturnMapResult:
    """Result of a batched return map over N points with m = nt + 1 local components.

    Local components are ordered ``(t1, [t2,] n)``; the normal component of the traction is
    ``f_n`` (> 0 in compression) and that of the gap is ``ubar_n`` (> 0 on approach).

    Attributes:
        traction: ``(f_t1, [f_t2,] f_n)``, shape (N, m).
        tangent: Consistent tangent ``d traction / d gap``, shape (N, m, m); not symmetric in
            plastic points.
        state: Internal variables at the end of the step.
        status: :class:`Status` codes, shape (N,), int8.
        unstable: Plastic points where the rate-form denominator
            ``den = -kappa (mu - mu_k) r + U(r) mu + alpha_t / g`` is not positive (a constitutive
            snap-back: no stable quasi-static solution), shape (N,).
        iterations: Root-finder iterations per point, shape (N,).
    """

    traction: np.ndarray
    tangent: np.ndarray
    state: InterfaceState
    status: np.ndarray
    unstable: np.ndarray
    iterations: np.ndarray

    @property
    def failed_indices(self) -> np.ndarray:
        """Indices of the points that could not be integrated."""
        return np.flatnonzero(self.status == Status.FAILED)

    @property
    def converged(self) -> bool:
        """True when no point failed."""
        return not bool(np.any(self.status == Status.FAILED))

    def counts(self) -> dict[str, int]:
        """Number of points per status, plus ``UNSTABLE``."""
        c = np.bincount(self.status.astype(np.intp), minlength=len(Status))
        out = {s.name: int(c[s]) for s in Status}
        out[UNSTABLE] = int(np.count_nonzero(self.unstable))
        return out
