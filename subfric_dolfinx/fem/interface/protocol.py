"""What both kinds of interface give the outputs of their law's points: :class:`LawPoints`.

Outputs (history, fields, point clouds, interface histories), probes, checkpoints, the validity
watch and the step's diagnostics read an interface's law points through this small protocol,
whatever its kind (the interface itself through its abstract base,
:class:`~.base.BaseInterface`): the points where the law is integrated, with their state, last
result, frames, weights and fixed data, in one order per rank (``n_elements`` facets of ``nq``
points each). A small-sliding :class:`~.small.interface.FrictionInterface` gives its
:class:`~.small.element.InterfaceElements` (the primary facets' points); a finite-sliding
:class:`~.finite.interface.SlidingInterface` its :class:`~.finite.points.SlidingPoints` (the
secondary facets' points, in the order of the cells of its :attr:`~LawPoints.submesh`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["LawPoints"]


@runtime_checkable
class LawPoints(Protocol):
    """The law's points of one interface on this rank.

    Attributes:
        comm: The interface's communicator.
        gdim: Geometric dimension.
        nt: Tangential components (``gdim - 1``).
        nq: Points per facet.
        n_elements: Facets (``n_elements * nq`` points).
        points: Reference coordinates of the points, reshapeable to (n, gdim).
        weights: Integration weights, reshapeable to (n_elements, nq) (times ``2 pi r`` in
            axisymmetric mode).
        facet_weights: The same without the axisymmetric weight: the facets' sizes, (n_elements,
            nq).
        w_ref: The reference rule's weights, (nq,).
        state: Committed (``old``) and trial (``new``) internal variables.
        last: The return map's result at the last iterate (``None`` before the first).
        last_gap: The law's input gap at the last iterate, (n, gdim).
        point_data: Fixed data per point (``g0``; ``region`` with regions).
        region_names: ``("default", <regions>...)``.
        coordinate_tolerance: Points closer than this are the same point (order, matching).
        submesh: A mesh with one cell per facet, in this order (cell averages for fields).
        Q: Local frames at the points, rows ``(e1, [e2,] -n)``, (n_elements, nq, gdim, gdim).
    """

    comm: Any
    gdim: int
    nt: int
    nq: int
    n_elements: int
    points: np.ndarray
    weights: np.ndarray
    facet_weights: np.ndarray
    w_ref: np.ndarray
    state: Any
    last: Any
    last_gap: np.ndarray
    point_data: Mapping[str, np.ndarray]
    region_names: tuple[str, ...]
    coordinate_tolerance: float
    submesh: Any

    @property
    def Q(self) -> np.ndarray: ...  # noqa: D102

    def saved_state(self) -> dict[str, np.ndarray]:
        """The committed state a restart needs, name -> (n, ...) array per point."""
        ...

    def restore_state(self, arrays: Mapping[str, np.ndarray]) -> None:
        """Put :meth:`saved_state`'s arrays back as the committed (and trial) state."""
        ...
