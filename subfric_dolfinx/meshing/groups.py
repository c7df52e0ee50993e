"""Physical groups of two-body interface meshes: names, default tags, the mesh error, queries.

Layout of a model (2-D "block on a base", 3-D "pad on a plate")::

            +-----------+            <- "top"          (slave)
            |   slave   |
    +-------+-----------+-------+    <- "interface" (block bottom) and "master_top" (free parts)
    |          master           |
    +---------------------------+    <- "bottom"       (master)

* ``master`` (cells): the base / plate, the body whose outward normal on the interface defines
  the interface frame; ``slave`` (cells): the block / pad.
* ``interface`` (facets): carried by *both* sides, each side being an exterior facet of its own
  body. Tell the sides apart by the body of the adjacent cell, never by assumption.
* ``bottom``: bottom of the master (y = 0 in 2-D, z = 0 in 3-D); ``top``: top of the slave;
  ``master_top``: free part of the master's top face (only when the slave is narrower).
* 2-D sides: ``master_left``/``master_right`` (x = x_min / x_max of the master) and
  ``slave_left``/``slave_right``.
* 3-D sides: ``master_xmin``, ``master_xmax``, ``master_ymin``, ``master_ymax`` and
  ``slave_xmin``, ``slave_xmax``, ``slave_ymin``, ``slave_ymax``.

The bolted lap joint (:mod:`.joints`) has ``master_xmin`` and ``slave_xmax`` (the plates' far
ends) and ``bolt_head``/``bolt_nut``: the annuli under the bolt head (top of the upper plate,
slave) and under the nut (bottom of the lower plate, master).

Files may use other integer tags: look groups up by name.

The gmsh session (:func:`gmsh_session`) and the queries of the current gmsh model's groups
(their nodes, elements, the interface's sides, which bodies touch it) that the builders and the
reader share close the module.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = [
    "BODIES",
    "BOLT_HEAD",
    "BOLT_NUT",
    "BOTTOM",
    "BOUNDARY_GROUPS_2D",
    "BOUNDARY_GROUPS_3D",
    "INTERFACE",
    "MASTER",
    "MASTER_LEFT",
    "MASTER_RIGHT",
    "MASTER_TOP",
    "MASTER_XMAX",
    "MASTER_XMIN",
    "MASTER_YMAX",
    "MASTER_YMIN",
    "REQUIRED_GROUPS",
    "SLAVE",
    "SLAVE_LEFT",
    "SLAVE_RIGHT",
    "SLAVE_XMAX",
    "SLAVE_XMIN",
    "SLAVE_YMAX",
    "SLAVE_YMIN",
    "TAGS",
    "TOP",
    "InterfaceMeshError",
    "gmsh_session",
]

MASTER = "master"
SLAVE = "slave"
INTERFACE = "interface"
BOTTOM = "bottom"
TOP = "top"
MASTER_TOP = "master_top"
MASTER_LEFT = "master_left"
MASTER_RIGHT = "master_right"
SLAVE_LEFT = "slave_left"
SLAVE_RIGHT = "slave_right"
MASTER_XMIN = "master_xmin"
MASTER_XMAX = "master_xmax"
MASTER_YMIN = "master_ymin"
MASTER_YMAX = "master_ymax"
SLAVE_XMIN = "slave_xmin"
SLAVE_XMAX = "slave_xmax"
SLAVE_YMIN = "slave_ymin"
SLAVE_YMAX = "slave_ymax"
BOLT_HEAD = "bolt_head"
BOLT_NUT = "bolt_nut"

#: The two bodies (cell groups), master first.
BODIES: tuple[str, str] = (MASTER, SLAVE)
#: Groups :func:`read_interface_mesh` requires by default.
REQUIRED_GROUPS: tuple[str, ...] = (MASTER, SLAVE, INTERFACE)
#: Boundary facet groups of the 2-D builder (``master_top`` only when the block is narrower).
BOUNDARY_GROUPS_2D: tuple[str, ...] = (
    BOTTOM,
    TOP,
    MASTER_TOP,
    MASTER_LEFT,
    MASTER_RIGHT,
    SLAVE_LEFT,
    SLAVE_RIGHT,
)
#: Boundary facet groups of the 3-D builder (``master_top`` only when the pad is smaller).
BOUNDARY_GROUPS_3D: tuple[str, ...] = (
    BOTTOM,
    TOP,
    MASTER_TOP,
    MASTER_XMIN,
    MASTER_XMAX,
    MASTER_YMIN,
    MASTER_YMAX,
    SLAVE_XMIN,
    SLAVE_XMAX,
    SLAVE_YMIN,
    SLAVE_YMAX,
)
#: Integer tags the builders give the groups (files may use others: look tags up by name).
TAGS: dict[str, int] = {
    MASTER: 1,
    SLAVE: 2,
    INTERFACE: 3,
    BOTTOM: 4,
    TOP: 5,
    MASTER_TOP: 6,
    MASTER_LEFT: 7,
    MASTER_RIGHT: 8,
    SLAVE_LEFT: 9,
    SLAVE_RIGHT: 10,
    MASTER_XMIN: 11,
    MASTER_XMAX: 12,
    MASTER_YMIN: 13,
    MASTER_YMAX: 14,
    SLAVE_XMIN: 15,
    SLAVE_XMAX: 16,
    SLAVE_YMIN: 17,
    SLAVE_YMAX: 18,
    BOLT_HEAD: 19,
    BOLT_NUT: 20,
}


class InterfaceMeshError(ValueError):
    """A mesh does not describe two bodies joined by a duplicated-node interface."""


# -- The gmsh session and the queries of the current gmsh model's groups (builders and reader)


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


def touching_bodies(
    tdim: int, interface_tag: int, bodies: Mapping[str, Sequence[int]]
) -> list[str]:
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
