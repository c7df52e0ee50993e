"""Meshes of bodies joined by zero-thickness interfaces with duplicated nodes.

* :mod:`.groups`: physical-group names and default tags, :class:`InterfaceMeshError`; the
  built-in meshes' older group names (``master``, ``slave_left``, ...) as input aliases
  (:data:`CLASSIC_ALIASES`, :func:`canonical_group`).
* :mod:`.topology`: the topology, bodies and interfaces by the user's own group names, resolved
  once by the reader (:class:`Topology`, :class:`InterfaceSides`).
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
* :mod:`.partitioned`: a mesh written in DOLFINx's partitioned XDMF/HDF5 format with its groups
  file (:func:`write_partitioned_mesh`) and read back, each rank its part
  (:func:`read_partitioned_mesh`).
* :mod:`.refine`: :func:`refine_interface_mesh`, uniform refinement on the ranks, the groups and
  the duplicated interface nodes kept.

**On one rank.** The gmsh helpers (the builders, :func:`duplicate_interface_nodes`,
:func:`gmsh_session`) run on one process, rank 0 of an MPI job, whose other ranks wait to read
the result: importing them (``from subfric_dolfinx.meshing import duplicate_interface_nodes``)
imports neither DOLFINx nor PETSc, whose initialisation is collective (on one rank of several it
hangs or aborts the job). The DOLFINx parts (:mod:`.reader`, :mod:`.interface_mesh`,
:mod:`.nodes`, :mod:`.partitioners`, :mod:`.partitioned`, :mod:`.refine`) are imported when one
of their names is first used.

May import: DOLFINx, mpi4py, gmsh, numpy, scipy, h5py (of the package: the layer-0 modules).
"""

import importlib
from typing import Any

from .builders import ModelInfo, build_block_on_base, build_pad_on_plate
from .crack import CrackedInterface, duplicate_interface_nodes
from .groups import (
    BODIES,
    BOLT_HEAD,
    BOLT_NUT,
    BOTTOM,
    BOUNDARY_GROUPS_2D,
    BOUNDARY_GROUPS_3D,
    CLASSIC_ALIASES,
    INTERFACE,
    PRIMARY,
    PRIMARY_LEFT,
    PRIMARY_RIGHT,
    PRIMARY_TOP,
    PRIMARY_XMAX,
    PRIMARY_XMIN,
    PRIMARY_YMAX,
    PRIMARY_YMIN,
    REQUIRED_GROUPS,
    SECONDARY,
    SECONDARY_LEFT,
    SECONDARY_RIGHT,
    SECONDARY_XMAX,
    SECONDARY_XMIN,
    SECONDARY_YMAX,
    SECONDARY_YMIN,
    TAGS,
    TOP,
    InterfaceMeshError,
    canonical_group,
    gmsh_session,
)
from .joints import build_bolted_lap_joint
from .topology import KINEMATICS, ROLES, InterfaceSides, Topology, mesh_topology

_WITH_DOLFINX = {
    "NodeGroup": "nodes",
    "locate_node_group": "nodes",
    "nearest_vertex": "nodes",
    "PARTITIONER_KINDS": "partitioners",
    "body_partitioner": "partitioners",
    "InterfaceMesh": "reader",
    "create_interface_mesh": "reader",
    "read_interface_mesh": "reader",
    "read_partitioned_mesh": "partitioned",
    "write_partitioned_mesh": "partitioned",
    "refine_interface_mesh": "refine",
}
"""The names whose modules import DOLFINx: imported on first use (:func:`__getattr__`)."""


def __getattr__(name: str) -> Any:
    """A name of the DOLFINx parts, imported when first used (PEP 562)."""
    if name in _WITH_DOLFINX:
        value = getattr(importlib.import_module(f".{_WITH_DOLFINX[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "BODIES",
    "BOLT_HEAD",
    "BOLT_NUT",
    "BOTTOM",
    "BOUNDARY_GROUPS_2D",
    "BOUNDARY_GROUPS_3D",
    "CLASSIC_ALIASES",
    "INTERFACE",
    "KINEMATICS",
    "PARTITIONER_KINDS",
    "PRIMARY",
    "PRIMARY_LEFT",
    "PRIMARY_RIGHT",
    "PRIMARY_TOP",
    "PRIMARY_XMAX",
    "PRIMARY_XMIN",
    "PRIMARY_YMAX",
    "PRIMARY_YMIN",
    "REQUIRED_GROUPS",
    "ROLES",
    "SECONDARY",
    "SECONDARY_LEFT",
    "SECONDARY_RIGHT",
    "SECONDARY_XMAX",
    "SECONDARY_XMIN",
    "SECONDARY_YMAX",
    "SECONDARY_YMIN",
    "TAGS",
    "TOP",
    "CrackedInterface",
    "InterfaceMesh",
    "InterfaceMeshError",
    "InterfaceSides",
    "ModelInfo",
    "NodeGroup",
    "Topology",
    "body_partitioner",
    "build_block_on_base",
    "build_bolted_lap_joint",
    "build_pad_on_plate",
    "canonical_group",
    "create_interface_mesh",
    "duplicate_interface_nodes",
    "gmsh_session",
    "locate_node_group",
    "mesh_topology",
    "nearest_vertex",
    "read_interface_mesh",
    "read_partitioned_mesh",
    "refine_interface_mesh",
    "write_partitioned_mesh",
]
