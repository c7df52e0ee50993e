"""What both kinds of interface give the rest of the package: the law's points and the state.

Outputs (history, fields, point clouds, interface histories), probes, checkpoints, the validity
watch and the step's diagnostics read an interface through two small protocols, whatever its
kind:

* :class:`LawPoints`: the points where the law is integrated, with their state, last result,
  frames, weights and fixed data, in one order per rank (``n_elements`` facets of ``nq`` points
  each). A small-sliding :class:`~.small.interface.FrictionInterface` gives its
  :class:`~.small.element.InterfaceElements` (the master facets' points); a finite-sliding
  :class:`~.finite.interface.SlidingInterface` gives itself (the slave facets' points, its facets
  in the order of the cells of its :attr:`~LawPoints.submesh`).
* :class:`InterfaceKind`: the interface itself, with :attr:`~InterfaceKind.law_points`,
  :meth:`~InterfaceKind.resume` (after a restart put back the displacement and the state) and
  :meth:`~InterfaceKind.assemble_jacobian`, which
  :meth:`~subfric_dolfinx.fem.InterfaceProblem.jacobian` calls the same way for every kind.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
from petsc4py import PETSc

__all__ = ["InterfaceKind", "LawPoints"]


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


@runtime_checkable
class InterfaceKind(Protocol):
    """One interface of a problem, of either kind.

    Attributes:
        name: Its facet group.
        kinematics: ``"small_sliding"`` or ``"finite_sliding"``.
        law: Its friction law.
        layout_version: Grows when its ghosts and matrix pattern change.
    """

    name: str
    kinematics: str
    law: Any
    layout_version: int

    @property
    def law_points(self) -> LawPoints: ...  # noqa: D102

    @property
    def last(self) -> Any: ...  # noqa: D102

    def resume(self, x: np.ndarray) -> None:
        """Continue from the owned displacement ``x`` with the committed state in place."""
        ...

    def assemble_jacobian(
        self,
        A: PETSc.Mat,
        x: PETSc.Vec | None = None,
        *,
        bcs: Sequence[Any] | None = None,
        separated_stiffness: float = 0.0,
        frictionless: bool = False,
        keep_contact: bool = False,
    ) -> None:
        """Add the interface's tangent at ``x`` to ``A`` (``ADD_VALUES``; call ``A.assemble()``).

        Every kind takes every keyword; a kind that has no use for one ignores it.

        Args:
            A: A matrix with the interface's couplings in its pattern.
            x: The displacement (owned values); ``None``: the last iterate's.
            bcs: DOLFINx Dirichlet conditions: the rows and columns of their dofs are left out.
            separated_stiffness: In this Jacobian only, points without stiffness (separated,
                failed) get this fraction of the law's contact stiffness; 0: the exact tangent.
            frictionless: In this Jacobian only, the law's tangent keeps its normal stiffness
                alone (finite sliding, the first iteration where the loading program turns);
                small sliding ignores it.
            keep_contact: In this Jacobian only, points open here that were in contact at the
                step's start keep their normal stiffness there (finite sliding, the first
                iteration of a step); small sliding ignores it.
        """
        ...
