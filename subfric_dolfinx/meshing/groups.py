"""Physical-group names of two-body interface meshes, their default tags, and the mesh error.

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
"""

from __future__ import annotations

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
    BOTTOM, TOP, MASTER_TOP, MASTER_LEFT, MASTER_RIGHT, SLAVE_LEFT, SLAVE_RIGHT,
)  # fmt: skip
#: Boundary facet groups of the 3-D builder (``master_top`` only when the pad is smaller).
BOUNDARY_GROUPS_3D: tuple[str, ...] = (
    BOTTOM, TOP, MASTER_TOP, MASTER_XMIN, MASTER_XMAX, MASTER_YMIN, MASTER_YMAX,
    SLAVE_XMIN, SLAVE_XMAX, SLAVE_YMIN, SLAVE_YMAX,
)  # fmt: skip
#: Integer tags the builders give the groups (files may use others: look tags up by name).
TAGS: dict[str, int] = {
    MASTER: 1, SLAVE: 2, INTERFACE: 3, BOTTOM: 4, TOP: 5, MASTER_TOP: 6,
    MASTER_LEFT: 7, MASTER_RIGHT: 8, SLAVE_LEFT: 9, SLAVE_RIGHT: 10,
    MASTER_XMIN: 11, MASTER_XMAX: 12, MASTER_YMIN: 13, MASTER_YMAX: 14,
    SLAVE_XMIN: 15, SLAVE_XMAX: 16, SLAVE_YMIN: 17, SLAVE_YMAX: 18,
    BOLT_HEAD: 19, BOLT_NUT: 20,
}  # fmt: skip


class InterfaceMeshError(ValueError):
    """A mesh does not describe two bodies joined by a duplicated-node interface."""
