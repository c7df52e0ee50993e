"""Meshes of bodies joined by zero-thickness interfaces with duplicated nodes.

* :mod:`.groups`: physical-group names and default tags, :class:`InterfaceMeshError`.
* :mod:`.topology`: bodies and interfaces by the user's own group names (:class:`InterfaceSides`).
* :mod:`.crack`: :func:`duplicate_interface_nodes`, the node duplication of interface groups of
  a gmsh model or ``.msh`` file (readable by DOLFINx's own gmsh reader too).
* :func:`gmsh_session`: a gmsh session and a fresh model for a builder of your own (removed,
  and gmsh finalised if started, on exit).
* :mod:`.builders`: gmsh builders (2-D block on a base, 3-D pad on a plate) with the Crack step.
* :mod:`.joints`: gmsh builder of a 3-D bolted lap joint (two plates, a bolt hole, head and nut
  annuli).
* :mod:`.partitioners`: deterministic partitions for tests (bodies apart, pairs together).
* :mod:`.nodes`: node groups (physical points), vertices by coordinates, nearest vertex.
* :mod:`.reader`: reading a ``.msh`` file or a gmsh model into DOLFINx with named-group checks
  (:class:`InterfaceMesh`, :mod:`.interface_mesh`).

May import: DOLFINx, mpi4py, gmsh, numpy (not the rest of the package).
"""

from .builders import ModelInfo, build_block_on_base, build_pad_on_plate
from .crack import CrackedInterface, duplicate_interface_nodes
from .groups import (
    BODIES,
    BOLT_HEAD,
    BOLT_NUT,
    BOTTOM,
    BOUNDARY_GROUPS_2D,
    BOUNDARY_GROUPS_3D,
    INTERFACE,
    MASTER,
    MASTER_LEFT,
    MASTER_RIGHT,
    MASTER_TOP,
    MASTER_XMAX,
    MASTER_XMIN,
    MASTER_YMAX,
    MASTER_YMIN,
    REQUIRED_GROUPS,
    SLAVE,
    SLAVE_LEFT,
    SLAVE_RIGHT,
    SLAVE_XMAX,
    SLAVE_XMIN,
    SLAVE_YMAX,
    SLAVE_YMIN,
    TAGS,
    TOP,
    InterfaceMeshError,
    gmsh_session,
)
from .joints import build_bolted_lap_joint
from .nodes import NodeGroup, locate_node_group, nearest_vertex
from .partitioners import PARTITIONER_KINDS, body_partitioner
from .reader import InterfaceMesh, create_interface_mesh, read_interface_mesh
from .topology import ROLES, InterfaceSides, mesh_topology

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
    "PARTITIONER_KINDS",
    "REQUIRED_GROUPS",
    "ROLES",
    "SLAVE",
    "SLAVE_LEFT",
    "SLAVE_RIGHT",
    "SLAVE_XMAX",
    "SLAVE_XMIN",
    "SLAVE_YMAX",
    "SLAVE_YMIN",
    "TAGS",
    "TOP",
    "CrackedInterface",
    "InterfaceMesh",
    "InterfaceMeshError",
    "InterfaceSides",
    "ModelInfo",
    "NodeGroup",
    "body_partitioner",
    "build_block_on_base",
    "build_bolted_lap_joint",
    "build_pad_on_plate",
    "create_interface_mesh",
    "duplicate_interface_nodes",
    "gmsh_session",
    "locate_node_group",
    "mesh_topology",
    "nearest_vertex",
    "read_interface_mesh",
]
