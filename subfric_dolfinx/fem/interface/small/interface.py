"""A frictional interface as a building block of any DOLFINx problem.

:class:`FrictionInterface` is one zero-thickness interface between two bodies of a mesh: it pairs
its two sides (:func:`~.pairing.pair_interface`), holds its quadrature, frames and the friction
law's state (:class:`~.element.InterfaceElements`), and adds its residual and consistent tangent
to the user's PETSc vector and matrix. It keeps its own ghost layout (the displacement index map
extended with the other side's nodes), so any number of interfaces work side by side on one
displacement space, each owning its pairs, quadrature, frames, state and kernels.

In one's own Newton loop (e.g. DOLFINx's ``NonlinearProblem``; ``demos/user_loop.py``)::

    iface = FrictionInterface.from_mesh(V, domain, law, "contact")
    A = create_matrix(V, [iface])                 # bulk cells + interface couplings
    # residual callback (x: the Newton iterate, b: the residual being assembled):
    iface.assemble_residual(b, x, bcs=bcs)        # + interface forces, DOLFINx's bc convention
    # Jacobian callback:
    iface.assemble_jacobian(A, x, bcs=bcs); A.assemble()
    # after the step:
    iface.commit()    # converged;   iface.revert()  # failed

The time step of the return map (the recovery of static friction at rest depends on it) is set
with :meth:`FrictionInterface.set_step` before each step.

With ``bcs`` (DOLFINx ``DirichletBC`` objects) the contributions follow DOLFINx's convention for
Newton with lifting (``NonlinearProblem``): the interface forces go to the free rows only, the
tangent's rows and columns of constrained dofs are left out, and the lifting of the tangent's
coupling to constrained dofs, ``K (g - x)``, is added to the free rows. Without ``bcs`` everything
is added (a caller that replaces the constrained rows itself, as
:class:`~subfric_dolfinx.fem.InterfaceProblem` does).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import dolfinx
import numpy as np
from petsc4py import PETSc

from ....compat import petsc_vector
from ....constitutive import FrictionLaw
from ..base import (
    BaseInterface,
    InterfaceError,
    InterfaceOptions,
    NewtonStart,
    stiffen_separated,
)
from .element import InterfaceElements
from .pairing import pair_interface
from .regions import element_regions

__all__ = ["FrictionInterface"]


class FrictionInterface(BaseInterface):
    """One frictional interface between two bodies: pairs, quadrature, frames, state, kernels.

    Args:
        V: The displacement space (vector Lagrange, degree 1 or 2).
        cell_tags: Cell tags of the bodies.
        facet_tags: Facet tags with the interface (both sides tagged ``tag``; nodes duplicated).
        law: The friction law.
        tag: The interface's facet tag.
        primary: Cell tag(s) of the primary body, whose outward normal defines the frame.
        secondary: Cell tag(s) of the secondary body.
        options: Name, quadrature, initial gap, regions, modelling mode
            (:class:`~..base.InterfaceOptions`; ``None``: its defaults).
        timings: A :class:`~subfric_dolfinx.fem.timing.Timings` to time the sections in.

    Attributes:
        elements: The :class:`~.element.InterfaceElements` (quadrature, frames, state).
        pairs: The :class:`~.pairing.InterfacePairs`.
        law: The law (a :class:`~subfric_dolfinx.constitutive.RegionalLaw` with regions).
        force: This rank's owned interface forces at the last residual (displacement layout).
        dt: The step of the return map.
    """

    kinematics = "small_sliding"  # the pairs, ghosts and pattern never change (layout_version)
    fixed_pairs = True
    index_map: dolfinx.common.IndexMap
    x_ext: PETSc.Vec | None  # (None once destroyed)
    b_ext: PETSc.Vec | None

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        cell_tags: dolfinx.mesh.MeshTags,
        facet_tags: dolfinx.mesh.MeshTags,
        law: FrictionLaw,
        *,
        tag: int,
        primary: int | Sequence[int],
        secondary: int | Sequence[int],
        options: InterfaceOptions | None = None,
        timings: Any = None,
    ) -> None:
        o = options or InterfaceOptions()
        super().__init__(V, o.name, timings)
        self.pairs = pair_interface(V, cell_tags, facet_tags, tag, primary, secondary, name=o.name)
        by_region = None
        if o.regions:
            numbers = element_regions(self.pairs, o.groups or {}, list(o.regions), o.name)
            by_region = (numbers, dict(o.regions))
        self.elements = InterfaceElements(
            self.pairs,
            V,
            law,
            o.quadrature,
            initial_gap=o.initial_gap,
            regions=by_region,
            mode=o.mode,
        )
        self.law = self.elements.law
        bs = V.dofmap.bs
        self.index_map = self.pairs.index_map
        self.x_ext = petsc_vector(self.index_map, bs)
        self.b_ext = petsc_vector(self.index_map, bs)
        self._global_nodes = (
            self.index_map.local_to_global(self.elements.nodes.ravel())
            .reshape(self.elements.nodes.shape)
            .astype(PETSc.IntType)
        )

    @classmethod
    def from_mesh(
        cls,
        V: dolfinx.fem.FunctionSpace,
        domain: Any,
        law: FrictionLaw,
        interface: str | None = None,
        *,
        primary: str | None = None,
        secondary: str | None = None,
        options: InterfaceOptions | None = None,
        timings: Any = None,
    ) -> FrictionInterface:
        """The interface ``interface`` of a mesh read by :mod:`subfric_dolfinx.meshing`.

        Args:
            V: The displacement space on ``domain.mesh``.
            domain: An :class:`~subfric_dolfinx.meshing.InterfaceMesh` (its tags, bodies and
                interfaces).
            law: The friction law.
            interface: The interface's facet group (``None``: the mesh's only interface).
            primary: Its primary body (``None``: as the mesh says).
            secondary: Its secondary body (``None``: as the mesh says).
            options: As for the constructor; its ``name`` is ``interface``'s, its ``groups``
                the mesh's subgroups of the interfaces unless given.
            timings: As for the constructor.
        """
        sides = getattr(domain, "interfaces", {})
        if interface is None:
            if len(sides) != 1:
                raise InterfaceError(
                    f"the mesh has {len(sides)} interfaces {sorted(sides)}: name one"
                )
            interface = next(iter(sides))
        if interface not in domain.tags:
            raise InterfaceError(
                f"the mesh has no facet group {interface!r}; its groups: {sorted(domain.tags)}"
            )
        known = sides.get(interface)
        primary = primary or (known.primary if known else None)
        secondary = secondary or (known.secondary if known else None)
        if primary is None or secondary is None:
            raise InterfaceError(f"interface {interface!r}: give its primary and secondary bodies")
        o = options or InterfaceOptions()
        groups = o.groups if o.groups is not None else getattr(domain, "interface_groups", {})
        return cls(
            V,
            domain.cell_tags,
            domain.facet_tags,
            law,
            tag=domain.tags[interface],
            primary=domain.body_tags(primary),
            secondary=domain.body_tags(secondary),
            options=dataclasses.replace(o, name=interface, groups=groups),
            timings=timings,
        )

    # -- the step --------------------------------------------------------------------------------
    def update(self, x: PETSc.Vec | np.ndarray) -> Any:
        """Evaluate the law at the displacement ``x`` (owned values, displacement layout).

        Fills the trial state from the committed one (collective: a ghost update).

        Returns:
            The :class:`~subfric_dolfinx.constitutive.ReturnMapResult` (``converged`` False if
            the return map failed at some point of this rank).
        """
        from ...timing import TIMER_INTERFACE, TIMER_RETURN_MAP

        owned = self._owned(x)
        assert self.x_ext is not None  # (None once destroyed)
        with self._time(TIMER_INTERFACE):
            self.x_ext.array_w[: self.n_owned] = owned
            self.x_ext.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with self._time(TIMER_RETURN_MAP):
            with self.x_ext.localForm() as xl:
                res = self.elements.update(xl.array_r, self.dt)
        self._x_at_update = np.array(owned, copy=True)
        return res

    @property
    def last(self) -> Any:
        """The return map's result at the last iterate (``None`` before the first)."""
        return self.elements.last

    @property
    def law_points(self) -> InterfaceElements:
        """The law's points (:class:`~.protocol.LawPoints`): the interface elements."""
        return self.elements

    def resume(self, x: np.ndarray) -> None:
        """Continue from a restored state: nothing to redo (the pairs are fixed)."""
        self._x_at_update = None

    def forces(self) -> np.ndarray:
        """The owned interface forces of the last iterate (collective: a reverse scatter)."""
        from ...timing import TIMER_INTERFACE

        assert self.elements.last is not None  # (forces of an iterate: after update)
        with self._time(TIMER_INTERFACE):
            traction = self.elements.last.traction
            self.force = self._sum_to_owners(lambda b: self.elements.add_residual(b, traction))
        return self.force

    def element_matrices(self, separated_stiffness: float = 0.0) -> np.ndarray:
        """The element tangents of the last iterate, (nf, n, n), node-blocked, primary first.

        ``separated_stiffness``: points without stiffness get this fraction of the law's contact
        stiffness (:func:`~.base.stiffen_separated`); 0: the exact tangent.
        """
        assert self.elements.last is not None  # (after update)
        tangent = stiffen_separated(self.elements.last.tangent, self.law, separated_stiffness)
        return self.elements.element_matrices(tangent)

    # -- into the user's vector and matrix -------------------------------------------------------
    def _lifting(self, dofs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``K (g - x)`` over the constrained dofs (owned rows; collective)."""
        el = self.elements
        we = self._extended(dofs, values)[el.dofs]  # (nf, n)
        lift = np.einsum("cij,cj->ci", self.element_matrices(), we)
        return self._sum_to_owners(lambda b: np.add.at(b, el.dofs.ravel(), lift.ravel()))

    def _add_tangent(
        self,
        A: PETSc.Mat,
        constrained: np.ndarray | None,
        separated_stiffness: float,
        start: NewtonStart | None,
    ) -> None:
        """Add the consistent tangent of the last iterate to ``A``, the element matrices.

        ``A`` must hold the interface couplings (:func:`~.layout.create_matrix`). ``start`` is
        ignored: a small-sliding interface's tangent is the same at every iteration.
        """
        Ke = self.element_matrices(separated_stiffness)
        if constrained is not None:
            mask = constrained[self.elements.dofs]
            Ke[mask[:, :, None] | mask[:, None, :]] = 0.0
        nodes = self._global_nodes
        if nodes.shape[0]:
            A.setValuesBlockedRCV(nodes, nodes, Ke, addv=PETSc.InsertMode.ADD_VALUES)

    def layout_parts(self) -> tuple[np.ndarray, np.ndarray, dolfinx.common.IndexMap, np.ndarray]:
        """Extra ghosts, their owners, the extended index map and the element nodes in it."""
        p = self.pairs
        return p.extra_ghosts, p.extra_owners, self.index_map, self.elements.nodes
