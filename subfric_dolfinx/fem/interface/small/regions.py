"""Interface regions: the region of every interface element, from subgroups of the interface.

A region is a named group of interface facets (see
:attr:`~subfric_dolfinx.meshing.InterfaceMesh.interface_groups`: the centroids of its facets).
An element belongs to the region whose group holds its primary facet's centroid; elements in no
named region belong to region 0 (the default law).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ....compat import geometry_dofmap
from ..base import InterfaceError
from ..geometry import match_points
from .pairing import InterfacePairs

__all__ = ["element_regions"]


def element_regions(
    pairs: InterfacePairs,
    groups: Mapping[str, np.ndarray],
    names: Sequence[str],
    interface: str = "interface",
) -> np.ndarray:
    """Region number of every element of this rank: 0 (default) or ``1 + names.index(region)``.

    Args:
        pairs: The interface pairs (primary facets) of this rank.
        groups: Subgroup name -> centroids of its facets (n, gdim), the same on every rank.
        names: The regions, in the order of their numbers.
        interface: The interface's name (messages).

    Raises:
        InterfaceError (on every rank): A region that is no subgroup of the interface (the
            subgroups are listed), a facet of a group that is no interface facet, or an element
            in two regions.
    """
    sub = pairs.submesh
    comm = sub.comm
    missing = [n for n in names if n not in groups]
    if missing:
        raise InterfaceError(
            f"interface {interface!r}: region(s) {missing} are not groups of interface facets of "
            f"the mesh; its interface subgroups are {sorted(groups)}"
        )
    gdim = sub.geometry.dim
    nv = {"interval": 2, "triangle": 3, "quadrilateral": 4}[sub.topology.cell_type.name]
    xg = sub.geometry.x[geometry_dofmap(sub)[:, :nv]][..., :gdim]
    centroids = xg.mean(axis=1) if xg.size else np.zeros((0, gdim))
    tol = 1e-6 * pairs.h_min
    region = np.zeros(centroids.shape[0], dtype=np.int64)
    found = np.zeros(len(names), dtype=np.int64)
    clash = None
    for k, name in enumerate(names, start=1):
        keys = np.asarray(groups[name], dtype=float).reshape(-1, gdim)
        idx, _ = match_points(keys, centroids, tol)
        hit = idx >= 0
        twice = hit & (region > 0)
        if np.any(twice) and clash is None:
            clash = (names[region[np.flatnonzero(twice)[0]] - 1], name)
        region[hit] = k
        found[k - 1] = np.count_nonzero(hit)
    found = comm.allreduce(found)
    clashes = [c for c in comm.allgather(clash) if c]
    if clashes:
        a, b = clashes[0]
        raise InterfaceError(f"interface {interface!r}: regions {a!r} and {b!r} share facets")
    for k, name in enumerate(names):
        n = np.asarray(groups[name]).reshape(-1, gdim).shape[0]
        if found[k] != n:
            raise InterfaceError(
                f"interface {interface!r}, region {name!r}: {n - int(found[k])} of its {n} facets "
                "are not primary facets of the interface"
            )
    return region
