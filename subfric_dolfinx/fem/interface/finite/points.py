"""The law's points of a finite-sliding interface (a part of :class:`~.interface.SlidingInterface`).

A :class:`~.interface.SlidingInterface` is its own :class:`~.protocol.LawPoints`: the quadrature
points of its slave facets, in the order of the cells of its slave submesh. This part gives the
frames of the last iterate per facet, the state a checkpoint holds (the law's variables, the
points' total tangential gap and their frames' normals) and the restart from it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..base import restore_law_state, saved_law_state
from ..geometry import frames

__all__ = ["SlidingPoints"]


class SlidingPoints:
    """The law's-points part of :class:`~.interface.SlidingInterface` (its attributes)."""

    @property
    def law_points(self) -> SlidingPoints:
        """The law's points (:class:`~.protocol.LawPoints`): the slave facets' points, here."""
        return self

    @property
    def Q(self) -> np.ndarray:
        """The frames of the last iterate (the committed ones after a step), (nf, nq, gdim, gdim).

        Rows ``(e1, [e2,] -n)`` with ``n`` the master's smooth normal at each point's projection;
        an open point keeps the frame it had.
        """
        Q = self._Q if self.last is not None else self.Q_old
        return Q.reshape(self.n_elements, self.nq, self.gdim, self.gdim)

    def saved_state(self) -> dict[str, np.ndarray]:
        """The committed state a restart needs, name -> (n, ...) array per point.

        The law's variables, and the points' total tangential gap (``sliding_ut``, local
        components) and the normals of their frames (``sliding_normal``; zero where a point never
        faced the master: its frame is still the identity, which no frame of a normal is).
        """
        out = saved_law_state(self.state)
        out["sliding_ut"] = self.ut_old
        normal = -self.Q_old[:, -1, :]
        normal[np.all(self.Q_old == np.eye(self.gdim), axis=(1, 2))] = 0.0
        out["sliding_normal"] = normal
        return out

    def restore_state(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Put :meth:`saved_state`'s arrays back (then :meth:`resume` from the displacement)."""
        restore_law_state(self.state, arrays)
        self.ut_old = np.asarray(arrays["sliding_ut"], dtype=float).reshape(self.ut_old.shape)
        normal = np.asarray(arrays["sliding_normal"], dtype=float).reshape(-1, self.gdim)
        faced = np.linalg.norm(normal, axis=1) > 0.5
        self.Q_old = np.broadcast_to(np.eye(self.gdim), self.Q_old.shape).copy()
        self.Q_old[faced] = frames(normal[faced])

    def resume(self, x: np.ndarray) -> None:
        """Continue from the owned displacement ``x`` (a restart).

        The next step searches from it: the points' master facets and reference coordinates
        there are found again (the facets are not in the checkpoint: their numbers depend on the
        partition).
        """
        self._x_committed = np.array(np.asarray(x)[: self.n_owned], dtype=float)
        self._x_at_update = None
        self.last = None
