"""Physical groups of two-body interface meshes: names, default tags, the mesh error, queries.

Layout of a model (2-D "block on a base", 3-D "pad on a plate")::

            +-----------+            <- "top"          (secondary)
            | secondary |
    +-------+-----------+-------+    <- "interface" (block bottom) and "primary_top" (free parts)
    |          primary          |
    +---------------------------+    <- "bottom"       (primary)

* ``primary`` (cells): the base / plate, the body whose outward normal on the interface defines
  the interface frame; ``secondary`` (cells): the block / pad.
* ``interface`` (facets): carried by *both* sides, each side being an exterior facet of its own
  body. Tell the sides apart by the body of the adjacent cell, never by assumption.
* ``bottom``: bottom of the primary (y = 0 in 2-D, z = 0 in 3-D); ``top``: top of the secondary;
  ``primary_top``: free part of the primary's top face (only when the secondary is narrower).
* 2-D sides: ``primary_left``/``primary_right`` (x = x_min / x_max of the primary) and
  ``secondary_left``/``secondary_right``.
* 3-D sides: ``primary_xmin``, ``primary_xmax``, ``primary_ymin``, ``primary_ymax`` and
  ``secondary_xmin``, ``secondary_xmax``, ``secondary_ymin``, ``secondary_ymax``.

The bolted lap joint (:mod:`.joints`) has ``primary_xmin`` and ``secondary_xmax`` (the plates' far
ends) and ``bolt_head``/``bolt_nut``: the annuli under the bolt head (top of the upper plate,
secondary) and under the nut (bottom of the lower plate, primary).

Files may use other integer tags: look groups up by name.

**Input aliases.** Files written before these names (and other codes') call the groups
``master``, ``slave``, ``master_top``, ``master_left``, ... ``slave_ymax``: the reader
(:func:`~.reader.read_interface_mesh`) reads each of them as its ``primary``/``secondary`` name
(:data:`CLASSIC_ALIASES`), and a scene may name them so (:mod:`subfric_dolfinx.scenes`). Nothing
else accepts them; everything the package writes says ``primary``/``secondary``.

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
    "CLASSIC_ALIASES",
    "INTERFACE",
    "PRIMARY",
    "PRIMARY_LEFT",
    "PRIMARY_RIGHT",
    "PRIMARY_TOP",
    "PRIMARY_XMAX",
    "PRIMARY_XMIN",
    "PRIMARY_YMAX",
    "PRIMARY_YMIN",
    "REQUIRED_GROUPS",
    "SECONDARY",
    "SECONDARY_LEFT",
    "SECONDARY_RIGHT",
    "SECONDARY_XMAX",
    "SECONDARY_XMIN",
    "SECONDARY_YMAX",
    "SECONDARY_YMIN",
    "TAGS",
    "TOP",
    "InterfaceMeshError",
    "canonical_group",
    "canonical_names",
    "gmsh_session",
]

PRIMARY = "primary"
SECONDARY = "secondary"
INTERFACE = "interface"
BOTTOM = "bottom"
TOP = "top"
PRIMARY_TOP = "primary_top"
PRIMARY_LEFT = "primary_left"
PRIMARY_RIGHT = "primary_right"
SECONDARY_LEFT = "secondary_left"
SECONDARY_RIGHT = "secondary_right"
PRIMARY_XMIN = "primary_xmin"
PRIMARY_XMAX = "primary_xmax"
PRIMARY_YMIN = "primary_ymin"
PRIMARY_YMAX = "primary_ymax"
SECONDARY_XMIN = "secondary_xmin"
SECONDARY_XMAX = "secondary_xmax"
SECONDARY_YMIN = "secondary_ymin"
SECONDARY_YMAX = "secondary_ymax"
BOLT_HEAD = "bolt_head"
BOLT_NUT = "bolt_nut"

#: The two bodies (cell groups), primary first.
BODIES: tuple[str, str] = (PRIMARY, SECONDARY)
#: Groups :func:`read_interface_mesh` requires by default.
REQUIRED_GROUPS: tuple[str, ...] = (PRIMARY, SECONDARY, INTERFACE)
#: Boundary facet groups of the 2-D builder (``primary_top`` only when the block is narrower).
BOUNDARY_GROUPS_2D: tuple[str, ...] = (
    BOTTOM,
    TOP,
    PRIMARY_TOP,
    PRIMARY_LEFT,
    PRIMARY_RIGHT,
    SECONDARY_LEFT,
    SECONDARY_RIGHT,
)
#: Boundary facet groups of the 3-D builder (``primary_top`` only when the pad is smaller).
BOUNDARY_GROUPS_3D: tuple[str, ...] = (
    BOTTOM,
    TOP,
    PRIMARY_TOP,
    PRIMARY_XMIN,
    PRIMARY_XMAX,
    PRIMARY_YMIN,
    PRIMARY_YMAX,
    SECONDARY_XMIN,
    SECONDARY_XMAX,
    SECONDARY_YMIN,
    SECONDARY_YMAX,
)
#: Integer tags the builders give the groups (files may use others: look tags up by name).
TAGS: dict[str, int] = {
    PRIMARY: 1,
    SECONDARY: 2,
    INTERFACE: 3,
    BOTTOM: 4,
    TOP: 5,
    PRIMARY_TOP: 6,
    PRIMARY_LEFT: 7,
    PRIMARY_RIGHT: 8,
    SECONDARY_LEFT: 9,
    SECONDARY_RIGHT: 10,
    PRIMARY_XMIN: 11,
    PRIMARY_XMAX: 12,
    PRIMARY_YMIN: 13,
    PRIMARY_YMAX: 14,
    SECONDARY_XMIN: 15,
    SECONDARY_XMAX: 16,
    SECONDARY_YMIN: 17,
    SECONDARY_YMAX: 18,
    BOLT_HEAD: 19,
    BOLT_NUT: 20,
}


CLASSIC_ALIASES: dict[str, str] = {
    name.replace("primary", "master").replace("secondary", "slave"): name
    for name in TAGS
    if name.startswith(("primary", "secondary"))
}
"""The classic layout's older group names (``master``, ``slave_left``, ...) -> their names
(``primary``, ``secondary_left``, ...): input aliases, read by the reader and the scenes."""


def canonical_group(name: str) -> str:
    """The group's name: an input alias of :data:`CLASSIC_ALIASES` resolved, any other as is."""
    return CLASSIC_ALIASES.get(name, name)


def canonical_names(value: Any) -> Any:
    """JSON-like data (a run's settings, as an older checkpoint stored them), aliases resolved.

    String values and mapping keys of :data:`CLASSIC_ALIASES` (``master``, ``slave_left``, ...)
    are read as their ``primary``/``secondary`` names. A key whose name is also present (an
    interface's ``master`` beside its ``primary``) is merged into it where one of the two is
    ``None``, and dropped.
    """
    if isinstance(value, str):
        return canonical_group(value)
    if isinstance(value, list | tuple):
        return [canonical_names(v) for v in value]
    if not isinstance(value, dict):
        return value
    out = {k: canonical_names(v) for k, v in value.items() if canonical_group(k) == k}
    for k, v in value.items():
        name = canonical_group(k)
        if name == k:
            continue
        v = canonical_names(v)
        if name not in out:
            out[name] = v
        elif out[name] is None or v is None:
            out[name] = v if out[name] is None else out[name]
        else:
            out[k] = v
    return out


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
    """Count interface elements whose nodes all belong to the primary, the secondary, or neither."""
    n_m, n_s, n_0 = side_counts(tdim, tags[INTERFACE], (tags[PRIMARY],), (tags[SECONDARY],))
    return {PRIMARY: n_m, SECONDARY: n_s, "neither": n_0}


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


def rename_aliased_groups(what: str) -> list[tuple[int, int, str]]:
    """Give the current gmsh model's groups named by an input alias their own names (rank 0).

    Returns:
        (dimension, tag, alias) of every group renamed (:func:`restore_group_names` puts the
        aliases back).

    Raises:
        InterfaceMeshError: A group under both names (``master`` and ``primary``).
    """
    gmsh = gmsh_module()
    named = {gmsh.model.getPhysicalName(d, t): (d, t) for d, t in gmsh.model.getPhysicalGroups()}
    both = sorted(a for a, n in CLASSIC_ALIASES.items() if a in named and n in named)
    if both:
        a = both[0]
        raise InterfaceMeshError(
            f"{what}: the physical groups {a!r} and {CLASSIC_ALIASES[a]!r} are both present; "
            f"{a!r} is read as {CLASSIC_ALIASES[a]!r} (an older name): rename one of them"
        )
    renamed = []
    for alias, name in CLASSIC_ALIASES.items():
        if alias in named:
            d, t = named[alias]
            gmsh.model.removePhysicalName(alias)
            gmsh.model.setPhysicalName(d, t, name)
            renamed.append((d, t, alias))
    return renamed


def restore_group_names(renamed: list[tuple[int, int, str]]) -> None:
    """Put back the names :func:`rename_aliased_groups` replaced (rank 0)."""
    gmsh = gmsh_module()
    if not gmsh.isInitialized():
        return
    for d, t, alias in renamed:
        with contextlib.suppress(Exception):  # the model may be gone (a file's session)
            gmsh.model.removePhysicalName(CLASSIC_ALIASES[alias])
            gmsh.model.setPhysicalName(d, t, alias)
