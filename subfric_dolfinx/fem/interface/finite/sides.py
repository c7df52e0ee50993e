"""The two sides of a finite-sliding interface, fixed at its construction: what every part reads.

:class:`Sides` holds the primary and secondary contact surfaces
(:mod:`.surface`), the secondary facets' points' reference rule, the displacement space's nodes, the
largest facet size and the two distances of the search (``radius``, ``reach``). The parts of a
:class:`~.interface.SlidingInterface` (its search, its law's points, its transfer, its assembly)
each read it; none changes it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import dolfinx
import numpy as np
from mpi4py import MPI

from ....compat import create_submesh
from ..base import InterfaceError
from ..geometry import quadrature_rule
from .projection import facet_basis
from .surface import ContactSurface, contact_surface, facet_measures

__all__ = ["Sides", "make_sides", "surface_size"]


@dataclasses.dataclass(frozen=True)
class Sides:
    """The fixed description of a finite-sliding interface on this rank.

    Attributes:
        comm: The interface's communicator.
        primary: The primary body's facets (its smooth normal defines the frame).
        secondary: The secondary body's facets, in the order of the cells of :attr:`submesh`.
        submesh: A mesh with one cell per secondary facet (cell averages in field outputs).
        imap0: The displacement space's index map (without the interface's extra ghosts).
        bs: The displacement's block size.
        X0: Reference positions of the displacement space's local nodes, (n_local0, gdim).
        Ns: The secondary facets' basis and its derivatives at the law's points,
            (1 + fdim, nq, nfd).
        w_ref: The reference rule's weights, (nq,).
        h: The largest facet size of either side, over every rank.
        radius: The largest normal distance at which a point faces the primary.
        reach: How far a point may slide in one step (and the pattern's hysteresis).
    """

    comm: MPI.Comm
    primary: ContactSurface
    secondary: ContactSurface
    submesh: Any
    imap0: dolfinx.common.IndexMap
    bs: int
    X0: np.ndarray
    Ns: np.ndarray
    w_ref: np.ndarray
    h: float
    radius: float
    reach: float

    @property
    def gdim(self) -> int:
        """The geometric dimension."""
        return int(self.X0.shape[1])

    @property
    def nt(self) -> int:
        """Tangential components (``gdim - 1``)."""
        return self.gdim - 1

    @property
    def nq(self) -> int:
        """Points per secondary facet."""
        return int(self.Ns.shape[1])

    @property
    def n_points(self) -> int:
        """The law's points on this rank."""
        return self.secondary.size * self.nq

    @property
    def n_owned(self) -> int:
        """Owned displacement dofs."""
        return self.imap0.size_local * self.bs

    @property
    def n_local0(self) -> int:
        """Local nodes (owned and ghosts) of the displacement space."""
        return self.imap0.size_local + self.imap0.num_ghosts


def surface_size(surface: ContactSurface, x_nodes: np.ndarray, comm: MPI.Comm) -> float:
    """The largest facet size (length, or the square root of the area) over every rank."""
    fdim = x_nodes.shape[1] - 1
    local = float(facet_measures(surface, x_nodes).max(initial=0.0)) ** (1.0 / fdim)
    return comm.allreduce(local, op=MPI.MAX)


def make_sides(
    V: dolfinx.fem.FunctionSpace,
    cell_tags: dolfinx.mesh.MeshTags,
    facet_tags: dolfinx.mesh.MeshTags,
    tag: int,
    primary: int | Sequence[int],
    secondary: int | Sequence[int],
    name: str,
    quadrature: str,
    search_radius: float | None,
    reach: float | None,
) -> Sides:
    """The sides of the interface ``tag`` between the cells ``primary`` and ``secondary``.

    Collective. Arguments as for :class:`~.interface.SlidingInterface`.

    Raises:
        InterfaceError: A side without a facet with the tag (on every rank), or a search radius
            or reach that is not positive.
    """
    mesh = V.mesh
    comm = mesh.comm
    gdim = mesh.geometry.dim
    X0 = V.tabulate_dof_coordinates()[:, :gdim].copy()
    prim = contact_surface(V, cell_tags, facet_tags, tag, list(np.atleast_1d(primary)))
    sec = contact_surface(V, cell_tags, facet_tags, tag, list(np.atleast_1d(secondary)))
    # the secondary facets' own mesh (cell averages in field output): the facets in its order
    submesh, parents = create_submesh(mesh, mesh.topology.dim - 1, sec.facets)
    sorter = np.argsort(sec.facets)
    perm = sorter[np.searchsorted(sec.facets, parents, sorter=sorter)]
    sec = dataclasses.replace(
        sec,
        facets=sec.facets[perm],
        cells=sec.cells[perm],
        nodes=sec.nodes[perm],
        orientation=sec.orientation[perm],
        global_facets=sec.global_facets[perm],
    )
    counts = comm.allreduce(np.array([prim.size, sec.size]))
    if counts.min() == 0:
        side = "primary" if counts[0] == 0 else "secondary"
        raise InterfaceError(
            f"interface {name!r} (tag {tag}): its {side} body has no facet with the tag"
        )
    h = max(surface_size(prim, X0, comm), surface_size(sec, X0, comm))
    radius = float(search_radius) if search_radius is not None else 2.0 * h
    reach = float(reach) if reach is not None else h
    if not (radius > 0 and reach > 0):
        raise InterfaceError(f"interface {name!r}: search_radius and reach must be > 0")
    X, w = quadrature_rule(sec.cell, sec.degree, quadrature)
    return Sides(
        comm=comm,
        primary=prim,
        secondary=sec,
        submesh=submesh,
        imap0=V.dofmap.index_map,
        bs=V.dofmap.bs,
        X0=X0,
        Ns=facet_basis(sec.cell, sec.degree, X, 1),
        w_ref=w,
        h=h,
        radius=radius,
        reach=reach,
    )
