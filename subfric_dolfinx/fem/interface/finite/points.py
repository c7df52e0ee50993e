"""The law's points of a finite-sliding interface: the secondary facets' quadrature points.

:class:`SlidingPoints` is the :class:`~..protocol.LawPoints` of a
:class:`~.interface.SlidingInterface`: the quadrature points of its secondary facets, in the order
of the cells of its secondary submesh, fixed material points of the secondary body that carry the
law's internal variables. It holds their fixed data (reference positions, weights, initial gaps),
the law's state, the kinematics committed with it (each point's primary facet, total tangential gap
and frame), the last iterate's result, and the state a checkpoint holds and the restart from it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from mpi4py import MPI

from ....constitutive import FrictionLaw, InterfaceState, StatePair
from ....constitutive.state import LOCAL, TANGENTIAL
from ...kinematics import point_weight
from ..base import initial_gaps, restore_law_state, saved_law_state
from ..geometry import frames
from .projection import parametric_normal
from .sides import Sides

__all__ = ["SlidingPoints"]


class SlidingPoints:
    """The law's points of one finite-sliding interface on this rank.

    Args:
        sides: The interface's sides.
        law: The friction law.
        initial_gap: An extra initial normal gap ``g0`` (as for the interface).
        mode: The modelling mode (``"axisymmetric"``: the weights carry ``2 pi r``).
        region: The region of every point (``law`` is then a
            :class:`~subfric_dolfinx.constitutive.RegionalLaw` on them), or ``None``.

    Attributes:
        points: Reference positions of the points, (npts, gdim).
        facet_weights: Their weights on the reference secondary surface, (ns, nq).
        weights: The same times ``2 pi r`` in axisymmetric mode, (npts,).
        state: The law's committed and trial internal variables.
        facet_old: The committed primary facet of each point (global number; -1: none).
        ut_old: The committed total tangential gap (local components), (npts, nt).
        Q_old: The committed frames (the step's start ones once it began), (npts, gdim, gdim).
        last: The return map's result at the last iterate (``None`` before the first).
        last_gap: The law's input gap at the last iterate, (npts, gdim).
        point_data: Fixed data per point, for outputs and checkpoints: ``g0`` and, with regions,
            ``region`` (the region number, as floats; names in :attr:`region_names`).
        region_names: ``("default", <regions>...)``; ``("default",)`` without regions.
    """

    def __init__(
        self,
        sides: Sides,
        law: FrictionLaw,
        initial_gap: float | Callable[[np.ndarray], np.ndarray] | None,
        mode: str | None,
        region: np.ndarray | None = None,
    ) -> None:
        s, gdim = sides.secondary, sides.gdim
        self.comm = sides.comm
        self.gdim, self.nt, self.nq = gdim, sides.nt, sides.nq
        self.n_elements = s.size
        self.submesh = sides.submesh
        self.w_ref = sides.w_ref
        Ys0 = sides.X0[s.nodes]  # (ns, nfd, gdim)
        self.points = np.einsum("qk,fkd->fqd", sides.Ns[0], Ys0).reshape(-1, gdim)
        jac = np.linalg.norm(
            parametric_normal(np.einsum("aqk,fkd->fqda", sides.Ns[1:], Ys0)), axis=-1
        )
        self.facet_weights = jac * sides.w_ref[None, :]  # (ns, nq)
        pw = point_weight(self.points, mode or "3d").reshape(jac.shape)  # 2 pi r, or 1
        self.weights = (self.facet_weights * pw).reshape(-1)
        npts = sides.n_points
        self.point_data = {"g0": initial_gaps(initial_gap, self.points, self.comm)}
        self.region_names: tuple[str, ...] = getattr(law, "names", ("default",))
        if region is not None:
            self.point_data["region"] = np.asarray(region).astype(float)
        fdim = max(gdim - 1, 1)
        sizes = self.facet_weights.sum(axis=1) ** (1.0 / fdim) if s.size else np.zeros(0)
        h_min = self.comm.allreduce(float(sizes.min(initial=np.inf)), op=MPI.MIN)
        self.coordinate_tolerance = 1e-6 * h_min
        init = law.initial_state(npts, self.nt)
        self.state = StatePair(init.copy(), init.copy())
        self._variables = {v.name: v.shape for v in law.variables}
        self.facet_old = np.full(npts, -1, dtype=np.int64)
        self.ut_old = np.zeros((npts, self.nt))
        self.Q_old: np.ndarray = np.zeros((npts, gdim, gdim))
        self.last: Any = None
        self.last_gap = np.zeros((npts, gdim))
        self._Q_last: np.ndarray | None = None

    @property
    def g0(self) -> np.ndarray:
        """The initial gaps of the points, (npts,)."""
        return self.point_data["g0"]

    @property
    def Q(self) -> np.ndarray:
        """The frames of the last iterate (the committed ones after a step), (nf, nq, gdim, gdim).

        Rows ``(e1, [e2,] -n)`` with ``n`` the primary's smooth normal at each point's projection;
        an open point keeps the frame it had.
        """
        Q = self._Q_last if self.last is not None else self.Q_old
        assert Q is not None  # (recorded with the last result)
        return Q.reshape(self.n_elements, self.nq, self.gdim, self.gdim)

    def record(self, result: Any, gap: np.ndarray, Q: np.ndarray) -> None:
        """Keep an iterate's return-map ``result``, the law's input ``gap`` and the frames ``Q``."""
        self.last, self.last_gap, self._Q_last = result, gap, Q

    def commit_kinematics(self, facet: np.ndarray, ut: np.ndarray, Q: np.ndarray) -> None:
        """Accept an iterate's primary facets (global numbers), tangential gaps and frames."""
        self.facet_old, self.ut_old, self.Q_old = facet, ut, Q

    def transported(self, T: np.ndarray) -> InterfaceState:
        """The committed state with its tangential components carried by ``T`` (3-D)."""
        st = self.state.old.copy()
        for name, shape in self._variables.items():
            if shape == TANGENTIAL:
                st[name][...] = np.einsum("mab,mb->ma", T, st[name])
            elif shape == LOCAL:
                st[name][:, : self.nt] = np.einsum("mab,mb->ma", T, st[name][:, : self.nt])
        return st

    def saved_state(self) -> dict[str, np.ndarray]:
        """The committed state a restart needs, name -> (n, ...) array per point.

        The law's variables, and the points' total tangential gap (``sliding_ut``, local
        components) and the normals of their frames (``sliding_normal``; zero where a point never
        faced the primary: its frame is still the identity, which no frame of a normal is).
        """
        out = saved_law_state(self.state)
        out["sliding_ut"] = self.ut_old
        normal = -self.Q_old[:, -1, :]
        normal[np.all(self.Q_old == np.eye(self.gdim), axis=(1, 2))] = 0.0
        out["sliding_normal"] = normal
        return out

    def restore_state(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Put :meth:`saved_state`'s arrays back (then the interface resumes from ``x``)."""
        restore_law_state(self.state, arrays)
        self.ut_old = np.asarray(arrays["sliding_ut"], dtype=float).reshape(self.ut_old.shape)
        normal = np.asarray(arrays["sliding_normal"], dtype=float).reshape(-1, self.gdim)
        faced = np.linalg.norm(normal, axis=1) > 0.5
        self.Q_old = np.broadcast_to(np.eye(self.gdim), self.Q_old.shape).copy()
        self.Q_old[faced] = frames(normal[faced])
