"""The gmsh session and queries of the current gmsh model shared by the builders and the reader."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from .groups import INTERFACE, MASTER, SLAVE

__all__ = [
    "body_nodes",
    "gmsh_module",
    "gmsh_session",
    "group_elements",
    "group_nodes",
    "interface_sides",
    "remove_new_models",
    "side_counts",
    "touching_bodies",
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
    n_m, n_s, n_0 = side_counts(tdim, tags[INTERFACE], (tags[MASTER],), (tags[SLAVE],))
    return {MASTER: n_m, SLAVE: n_s, "neither": n_0}


def body_nodes(tdim: int, tags: Sequence[int]) -> np.ndarray:
    """The nodes of the cells of some cell groups (sorted, unique)."""
    parts = [group_nodes(tdim, t) for t in tags]
    return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)


def side_counts(
    tdim: int, interface_tag: int, primary: Sequence[int], secondary: Sequence[int]
) -> tuple[int, int, int]:
    """Interface elements whose nodes all belong to the primary body, the secondary, neither.

    ``primary``, ``secondary``: the cell-group tags of each body.
    """
    p, s = body_nodes(tdim, primary), body_nodes(tdim, secondary)
    counts = [0, 0, 0]
    for conn in group_elements(tdim - 1, interface_tag)[1]:
        in_p = np.isin(conn, p).all(axis=1)
        in_s = np.isin(conn, s).all(axis=1)
        counts[0] += int(np.count_nonzero(in_p & ~in_s))
        counts[1] += int(np.count_nonzero(in_s & ~in_p))
        counts[2] += int(np.count_nonzero(in_p == in_s))
    return counts[0], counts[1], counts[2]


def touching_bodies(tdim: int, interface_tag: int, bodies: dict[str, Sequence[int]]) -> list[str]:
    """The bodies holding every node of some element of an interface group (in body order)."""
    conns = group_elements(tdim - 1, interface_tag)[1]
    out = []
    for name, tags in bodies.items():
        nodes = body_nodes(tdim, tags)
        if any(np.isin(c, nodes).all(axis=1).any() for c in conns):
            out.append(name)
    return out


def remove_new_models(gmsh: Any, before: Sequence[str], current: str) -> None:
    """Remove the gmsh models not in ``before`` and make ``current`` current again."""
    if not gmsh.isInitialized():
        return
    for name in set(gmsh.model.list()) - set(before):
        gmsh.model.setCurrent(name)
        gmsh.model.remove()
    if current in gmsh.model.list():
        gmsh.model.setCurrent(current)
