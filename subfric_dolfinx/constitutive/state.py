"""Internal-variable arrays of interface points, with commit and revert.

An :class:`InterfaceState` holds, for ``N`` points with ``nt`` tangential components (1 in 2-D,
2 in 3-D), the plastic slip ``up`` (N, nt), the hardening function ``mu`` (N,) and the normal-yield
ratio ``r`` (N,). It can wrap existing arrays without copying (e.g. the arrays of DOLFINx
Quadrature functions), so that in-place updates are seen by their owner.

A :class:`StatePair` keeps the last converged state (``old``) and the trial state of the current
step (``new``): ``commit()`` copies new into old after a converged step, ``revert()`` copies old
into new after a failed one (the pattern of MGIS's material data manager).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["InterfaceState", "StatePair"]


class InterfaceState:
    """Internal variables ``up``, ``mu``, ``r`` of ``N`` interface points.

    Args:
        up: Plastic slip, shape (N, nt), nt in {1, 2}.
        mu: Hardening function, shape (N,).
        r: Normal-yield ratio, shape (N,).
        copy: Copy the arrays (default) or wrap them (they must then be float64 and writable).

    Raises:
        ValueError: Shapes do not match or nt is not 1 or 2.
    """

    __slots__ = ("mu", "r", "up")

    def __init__(
        self,
        up: npt.ArrayLike,
        mu: npt.ArrayLike,
        r: npt.ArrayLike,
        *,
        copy: bool = True,
    ) -> None:
        conv = (lambda a: np.array(a, dtype=np.float64)) if copy else (lambda a: np.asarray(a))
        up_a, mu_a, r_a = conv(up), conv(mu), conv(r)
        if up_a.ndim != 2 or up_a.shape[1] not in (1, 2):
            raise ValueError(f"up must have shape (N, 1) or (N, 2), got {up_a.shape}")
        n = up_a.shape[0]
        if mu_a.shape != (n,) or r_a.shape != (n,):
            raise ValueError(
                f"mu and r must have shape ({n},) to match up {up_a.shape}, "
                f"got {mu_a.shape} and {r_a.shape}"
            )
        if not copy:
            for name, a in (("up", up_a), ("mu", mu_a), ("r", r_a)):
                if a.dtype != np.float64 or not a.flags.writeable:
                    raise ValueError(f"{name} must be a writable float64 array to be wrapped")
        self.up, self.mu, self.r = up_a, mu_a, r_a

    @classmethod
    def initial(cls, n_points: int, n_tangential: int, mu0: float) -> InterfaceState:
        """A virgin state: no plastic slip, ``mu = mu0``, ``r = 0``.

        Args:
            n_points: Number of points N >= 0.
            n_tangential: 1 (2-D) or 2 (3-D).
            mu0: Initial hardening function (e.g. ``params.mu_initial``).
        """
        if n_tangential not in (1, 2):
            raise ValueError(f"n_tangential must be 1 or 2, got {n_tangential!r}")
        if n_points < 0:
            raise ValueError(f"n_points must be >= 0, got {n_points!r}")
        return cls(
            np.zeros((n_points, n_tangential)),
            np.full(n_points, float(mu0)),
            np.zeros(n_points),
            copy=False,
        )

    @property
    def n_points(self) -> int:
        """Number of points N."""
        return self.up.shape[0]

    @property
    def n_tangential(self) -> int:
        """Number of tangential components (1 in 2-D, 2 in 3-D)."""
        return self.up.shape[1]

    def copy(self) -> InterfaceState:
        """Return a deep copy."""
        return InterfaceState(self.up, self.mu, self.r, copy=True)

    def assign(self, other: InterfaceState) -> None:
        """Copy the values of ``other`` into this state's arrays, in place."""
        if other.up.shape != self.up.shape:
            raise ValueError(
                f"cannot assign a state of shape {other.up.shape} to one of shape {self.up.shape}"
            )
        np.copyto(self.up, other.up)
        np.copyto(self.mu, other.mu)
        np.copyto(self.r, other.r)

    def take(self, index: npt.ArrayLike) -> InterfaceState:
        """Return a copy of the state at some points."""
        return InterfaceState(self.up[index], self.mu[index], self.r[index], copy=True)

    def __repr__(self) -> str:
        return f"InterfaceState(n_points={self.n_points}, n_tangential={self.n_tangential})"


class StatePair:
    """The last converged state and the trial state of the current step.

    Args:
        old: Last converged (committed) state; the pair owns it from now on.
        new: Trial state; a copy of ``old`` when omitted.
    """

    __slots__ = ("new", "old")

    def __init__(self, old: InterfaceState, new: InterfaceState | None = None) -> None:
        self.old = old
        self.new = old.copy() if new is None else new
        if self.new.up.shape != self.old.up.shape:
            raise ValueError("old and new states must have the same shape")

    def commit(self) -> None:
        """Accept the trial state: copy ``new`` into ``old``."""
        self.old.assign(self.new)

    def revert(self) -> None:
        """Reject the trial state: copy ``old`` into ``new``."""
        self.new.assign(self.old)
