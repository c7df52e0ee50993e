"""Interface regions of a finite-sliding interface: the region of every secondary facet.

A region is a named group of interface facets (see
:attr:`~subfric_dolfinx.meshing.InterfaceMesh.interface_groups`: the centroids of its facets).
With finite sliding the law's points are the secondary facets' points, material points of
the secondary body that keep their internal variables as they slide: a point takes the law of the
region whose group holds its *secondary* facet's centroid, and keeps it wherever it slides (the
small-sliding interface reads its primary facets instead:
:mod:`~subfric_dolfinx.fem.interface.small.regions`). Secondary facets in no named region belong
to region 0 (the default law). A group may hold primary facets too (a group of both sides, as a
mesh made apart gives it): those are left aside.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from mpi4py import MPI

from ..base import InterfaceError
from ..geometry import match_points
from .sides import Sides

__all__ = ["secondary_regions"]


def _centroids(sd: Sides, side: str) -> np.ndarray:
    """The centroids of one side's facets on this rank (their vertex nodes), (nf, gdim)."""
    surface = sd.primary if side == "primary" else sd.secondary
    nv = {"interval": 2, "triangle": 3, "quadrilateral": 4}[surface.cell.name]
    if surface.size == 0:
        return np.zeros((0, sd.gdim))
    return sd.X0[surface.nodes[:, :nv]].mean(axis=1)


def secondary_regions(
    sd: Sides, groups: Mapping[str, np.ndarray], names: Sequence[str], interface: str
) -> np.ndarray:
    """Region number of every secondary facet of this rank: 0 or ``1 + names.index(region)``.

    Collective.

    Args:
        sd: The interface's sides.
        groups: Subgroup name -> centroids of its facets (n, gdim), the same on every rank.
        names: The regions, in the order of their numbers.
        interface: The interface's name (messages).

    Raises:
        InterfaceError (on every rank): A region that is no subgroup of the interface (the
            subgroups are listed), a facet of a group that is no facet of the interface, a region
            without a secondary facet, or a secondary facet in two regions.
    """
    comm = sd.comm
    missing = [n for n in names if n not in groups]
    if missing:
        raise InterfaceError(
            f"interface {interface!r}: region(s) {missing} are not groups of interface facets of "
            f"the mesh; its interface subgroups are {sorted(groups)}"
        )
    tol = 1e-6 * sd.h
    secondary, primary = _centroids(sd, "secondary"), _centroids(sd, "primary")
    region = np.zeros(sd.secondary.size, dtype=np.int64)
    clash = None
    counts = []
    for k, name in enumerate(names, start=1):
        keys = np.asarray(groups[name], dtype=float).reshape(-1, sd.gdim)
        idx, _ = match_points(keys, secondary, tol)
        hit = idx >= 0
        twice = hit & (region > 0)
        if np.any(twice) and clash is None:
            clash = (names[region[np.flatnonzero(twice)[0]] - 1], name)
        region[hit] = k
        # which of the group's facets are facets of the interface (either side) on this rank
        seen = np.zeros(keys.shape[0], dtype=np.int64)
        for side in (secondary, primary):
            j, _ = match_points(side, keys, tol)
            seen[j >= 0] = 1
        counts.append((int(np.count_nonzero(hit)), seen))
    clashes = [c for c in comm.allgather(clash) if c]
    if clashes:
        a, b = clashes[0]
        raise InterfaceError(
            f"interface {interface!r}: regions {a!r} and {b!r} share secondary facets"
        )
    for name, (n_secondary, seen) in zip(names, counts, strict=True):
        n_secondary = comm.allreduce(n_secondary)
        seen_all = np.zeros_like(seen)
        comm.Allreduce(seen, seen_all, op=MPI.MAX)
        if not seen_all.all():
            raise InterfaceError(
                f"interface {interface!r}, region {name!r}: {int(np.count_nonzero(seen_all == 0))} "
                f"of its {seen_all.size} facets are not facets of the interface"
            )
        if n_secondary == 0:
            raise InterfaceError(
                f"interface {interface!r}, region {name!r}: none of its facets is a secondary "
                "facet; with finite sliding a region is a group of the secondary's facets (its "
                "points carry the law as they slide)"
            )
    return region
