"""The gmsh session and queries of the current gmsh model shared by the builders and the reader."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from .groups import INTERFACE, MASTER, SLAVE

__all__ = [
    "gmsh_module",
    "gmsh_session",
    "group_elements",
    "group_nodes",
    "interface_sides",
    "remove_new_models",
]


# --- gmsh session helpers ------------------------------------------------------------------------
def gmsh_module():
    try:
        import gmsh
    except ModuleNotFoundError as e:  # pragma: no cover - gmsh is installed where tests run
        raise ModuleNotFoundError(
            "subfric_dolfinx.meshing needs the gmsh Python module (pip extra 'mesh')", name="gmsh"
        ) from e
    return gmsh


@contextlib.contextmanager
def gmsh_session(model_name: str | None) -> Iterator[Any]:
    """Initialise gmsh if needed and, if ``model_name`` is given, work in a fresh model.

    On exit the fresh model is removed, the previously current model restored, and gmsh finalised
    if it was initialised here.
    """
    gmsh = gmsh_module()
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Verbosity", 2)
    previous = gmsh.model.getCurrent() if not own else None
    try:
        if model_name is not None:
            gmsh.model.add(model_name)
        yield gmsh
    finally:
        if model_name is not None and gmsh.isInitialized():
            gmsh.model.setCurrent(model_name)
            gmsh.model.remove()
            if previous:
                gmsh.model.setCurrent(previous)
        if own and gmsh.isInitialized():
            gmsh.finalize()


def group_nodes(dim: int, tag: int) -> np.ndarray:
    gmsh = gmsh_module()
    nodes, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
    return np.unique(np.asarray(nodes, dtype=np.int64))


def group_elements(dim: int, tag: int) -> tuple[list[int], list[np.ndarray]]:
    """Element types and (num_elements, num_nodes) node arrays of a physical group."""
    gmsh = gmsh_module()
    types: list[int] = []
    conns: list[np.ndarray] = []
    for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        etypes, _, enodes = gmsh.model.mesh.getElements(dim, int(entity))
        for t, n in zip(etypes, enodes, strict=True):
            nn = gmsh.model.mesh.getElementProperties(int(t))[3]
            types.append(int(t))
            conns.append(np.asarray(n, dtype=np.int64).reshape(-1, nn))
    return types, conns


def interface_sides(tdim: int, tags: dict[str, int]) -> dict[str, int]:
    """Count interface elements whose nodes all belong to the master, to the slave, or neither."""
    master, slave = group_nodes(tdim, tags[MASTER]), group_nodes(tdim, tags[SLAVE])
    counts = {MASTER: 0, SLAVE: 0, "neither": 0}
    for conn in group_elements(tdim - 1, tags[INTERFACE])[1]:
        in_m = np.isin(conn, master).all(axis=1)
        in_s = np.isin(conn, slave).all(axis=1)
        counts[MASTER] += int(np.count_nonzero(in_m & ~in_s))
        counts[SLAVE] += int(np.count_nonzero(in_s & ~in_m))
        counts["neither"] += int(np.count_nonzero(in_m == in_s))
    return counts


def remove_new_models(gmsh: Any, before: Sequence[str], current: str) -> None:
    """Remove the gmsh models not in ``before`` and make ``current`` current again."""
    if not gmsh.isInitialized():
        return
    for name in set(gmsh.model.list()) - set(before):
        gmsh.model.setCurrent(name)
        gmsh.model.remove()
    if current in gmsh.model.list():
        gmsh.model.setCurrent(current)
