"""Subgroups of the interface: named facet groups lying on the interface, read by centroid.

A DOLFINx facet carries one tag: a facet in both ``interface`` and ``rough`` would keep only one
of them (gmshio drops the other). So the reader takes groups whose entities are interface entities
out of the gmsh model before DOLFINx reads it, keeps the centroids of their facets, and puts the
groups back afterwards. Such a group must lie on the interface entirely.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ._gmsh import gmsh_module
from .groups import INTERFACE, InterfaceMeshError

__all__ = ["restore_groups", "withhold_interface_subgroups"]


def _centroids(gdim: int, entities: list[int]) -> np.ndarray:
    """Centroids (mean of the corner nodes) of the elements of facet ``entities``, deduplicated."""
    gmsh = gmsh_module()
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(ntags.max()) + 1 if ntags.size else 0, 3))
    x[ntags] = np.asarray(coords).reshape(-1, 3)
    out = []
    for e in entities:
        for etype, _, enodes in zip(*gmsh.model.mesh.getElements(gdim - 1, e), strict=True):
            props = gmsh.model.mesh.getElementProperties(int(etype))
            conn = np.asarray(enodes, dtype=np.int64).reshape(-1, props[3])[:, : props[5]]
            out.append(x[conn].mean(axis=1)[:, :gdim])
    c = np.concatenate(out) if out else np.zeros((0, gdim))
    if not c.size:
        return c
    scale = max(1.0, float(np.abs(x).max()))
    _, first = np.unique(np.round(c / (1e-9 * scale)).astype(np.int64), axis=0, return_index=True)
    return c[np.sort(first)]


def withhold_interface_subgroups(
    gdim: int, names: dict[str, int], what: str, interfaces: Sequence[str] = (INTERFACE,)
) -> tuple[dict[str, np.ndarray], list[tuple[int, int, str, list[int]]]]:
    """Take the interfaces' subgroups out of the current gmsh model (rank 0).

    Returns:
        Name -> facet centroids (n, gdim), and what to give :func:`restore_groups`.

    Raises:
        InterfaceMeshError: A named facet group lies partly on an interface.
    """
    gmsh = gmsh_module()
    interfaces = [i for i in interfaces if i in names]
    if not interfaces:
        return {}, []
    fdim = gdim - 1
    owner = {
        int(e): i
        for i in interfaces
        for e in gmsh.model.getEntitiesForPhysicalGroup(fdim, names[i])
    }
    groups: dict[str, np.ndarray] = {}
    withheld: list[tuple[int, int, str, list[int]]] = []
    for d, t in gmsh.model.getPhysicalGroups(fdim):
        name = gmsh.model.getPhysicalName(d, t)
        if not name or name in interfaces:
            continue
        ents = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(d, t)]
        on = [e for e in ents if e in owner]
        if not on:
            continue
        host = owner[on[0]]
        if len(on) != len(ents) or any(owner[e] != host for e in on):
            raise InterfaceMeshError(
                f"{what}: the facet group {name!r} lies partly on the {host!r} group "
                f"({len(ents) - len(on)} of its {len(ents)} entities are not interface entities); "
                "a group of interface facets (an interface region) must lie on one interface only"
            )
        groups[name] = _centroids(gdim, ents)
        withheld.append((d, t, name, ents))
    for d, t, _, _ in withheld:
        gmsh.model.removePhysicalGroups([(d, t)])
    return groups, withheld


def restore_groups(withheld: list[tuple[int, int, str, list[int]]]) -> Any:
    """Put withheld groups back into the current gmsh model (if it still exists)."""
    gmsh = gmsh_module()
    if not withheld or not gmsh.isInitialized():
        return
    for d, t, name, ents in withheld:
        gmsh.model.addPhysicalGroup(d, ents, t, name=name)
