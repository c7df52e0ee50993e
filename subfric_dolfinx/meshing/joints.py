"""gmsh builder of a bolted lap joint: two plates overlapping, a bolt hole through both.

:func:`build_bolted_lap_joint` makes the model in the current gmsh session (call it on one rank,
or through :func:`~subfric_dolfinx.meshing.reader.create_interface_mesh`), with the interface
nodes duplicated by gmsh's Crack plugin as in :mod:`.builders`. The bolt itself is not meshed: its
head and nut act through the annuli they cover on the plates' outer faces (``bolt_head`` on top of
the upper plate, ``bolt_nut`` under the lower plate), where a scene applies the clamping pressure.

Layout (x along the joint, z up; the plates are ``width`` wide in y)::

                                  bolt_head
                          +---------==---==----------------------+ <- upper plate (secondary)
                          |          |   |         secondary_xmax|
    +---------------------+==========|   |===========+----------+
    |primary_xmin         |  interface (overlap,     |
    +---------------------+---------==---==----------+ <- lower plate (primary)
                                    bolt_nut
"""

from __future__ import annotations

import numpy as np

from ._size import check_mesh_size, estimate_cells
from .builders import ModelInfo, check_positive, model_info, split_interface_nodes
from .groups import (
    BOLT_HEAD,
    BOLT_NUT,
    INTERFACE,
    PRIMARY,
    PRIMARY_XMIN,
    SECONDARY,
    SECONDARY_XMAX,
    TAGS,
    gmsh_module,
)

__all__ = ["build_bolted_lap_joint"]


def build_bolted_lap_joint(
    *,
    plate_length: float = 60.0,
    width: float = 30.0,
    thickness: float = 5.0,
    overlap: float = 30.0,
    hole_radius: float = 4.5,
    washer_radius: float = 8.0,
    n_interface: int | None = 8,
    mesh_size: float | None = None,
    cell_type: str = "tetrahedron",
    model_name: str = "bolted_lap_joint",
) -> ModelInfo:
    """Build the 3-D bolted lap joint in the current gmsh session (call on one rank).

    The lower plate (``primary``) is ``[0, L] x [0, W] x [0, t]``, the upper plate (``secondary``)
    ``[L - c, 2 L - c] x [0, W] x [t, 2 t]`` with ``L = plate_length``, ``W = width``,
    ``t = thickness`` and ``c = overlap``. A hole of radius ``hole_radius`` goes through both
    plates at the centre of the overlap; the interface is the overlap minus the hole. The annuli
    ``hole_radius < rho < washer_radius`` around the hole on the top of the upper plate and under
    the lower plate are the groups ``bolt_head`` and ``bolt_nut``; the plates' far ends are
    ``primary_xmin`` (x = 0) and ``secondary_xmax`` (x = 2 L - c). The mesh is unstructured
    (tetrahedra) of size ``h = width / n_interface`` (finer around the hole, where the curvature
    asks for it).

    Args:
        plate_length: Length of each plate (x).
        width: Width of the plates (y).
        thickness: Thickness of each plate (z).
        overlap: Length of the overlap, at most ``plate_length``.
        hole_radius: Radius of the bolt hole.
        washer_radius: Outer radius of the head/nut annuli; the annuli must fit in the overlap.
        n_interface: Number of elements across the width.
        mesh_size: Element size; if given it sets ``n_interface = round(width / mesh_size)``.
        cell_type: ``"tetrahedron"`` (the only one).
        model_name: Name of the gmsh model added to the session (it becomes the current model).

    Returns:
        Description of the model.

    Raises:
        ValueError: Invalid sizes or cell type.
        RuntimeError: gmsh did not produce two bodies joined only by a duplicated interface.
    """
    if cell_type != "tetrahedron":
        raise ValueError(
            f"cell_type must be 'tetrahedron' for the bolted lap joint, got {cell_type!r}"
        )
    sizes = {
        "plate_length": plate_length,
        "width": width,
        "thickness": thickness,
        "overlap": overlap,
        "hole_radius": hole_radius,
        "washer_radius": washer_radius,
    }
    check_positive(**sizes)
    L, W, t, c = (float(v) for v in (plate_length, width, thickness, overlap))
    r, R = float(hole_radius), float(washer_radius)
    if c > L:
        raise ValueError(f"overlap ({c}) must not exceed plate_length ({L})")
    if not r < R or 2.0 * R >= min(c, W):
        raise ValueError(
            f"need hole_radius < washer_radius and the washer (diameter {2 * R}) inside the "
            f"overlap ({c} x {W}), got hole_radius {r}, washer_radius {R}"
        )
    if mesh_size is not None:
        check_positive(mesh_size=mesh_size)
        n_interface = max(1, round(W / mesh_size))
    if n_interface is None or int(n_interface) != n_interface or n_interface < 1:
        raise ValueError(f"n_interface must be a positive integer, got {n_interface!r}")
    h = W / int(n_interface)
    boxes = (((0.0, 0.0, 0.0), (L, W, t)), ((L - c, 0.0, t), (2 * L - c, W, 2 * t)))
    option = ("mesh_size", mesh_size) if mesh_size is not None else ("n_interface", n_interface)
    check_mesh_size(estimate_cells(boxes, h, "tetrahedron"), *option)  # before gmsh (._size)

    gmsh = gmsh_module()
    if not gmsh.isInitialized():
        raise RuntimeError("gmsh is not initialised: call gmsh.initialize() before a builder")
    occ = gmsh.model.occ
    gmsh.model.add(model_name)
    cx, cy = L - 0.5 * c, 0.5 * W
    lower = occ.addBox(0.0, 0.0, 0.0, L, W, t)
    upper = occ.addBox(L - c, 0.0, t, L, W, t)
    hole = occ.addCylinder(cx, cy, -t, 0.0, 0.0, 4.0 * t, r)
    plates, _ = occ.cut([(3, lower), (3, upper)], [(3, hole)])
    annuli = []
    for z in (0.0, 2.0 * t):
        outer = occ.addDisk(cx, cy, z, R, R)
        inner = occ.addDisk(cx, cy, z, r, r)
        annuli += occ.cut([(2, outer)], [(2, inner)])[0]
    occ.fragment(plates, annuli)
    occ.synchronize()

    scale = 2.0 * L
    tol = 1e-7 * scale
    groups: dict[str, list[int]] = {PRIMARY: [], SECONDARY: []}
    for _, tag in gmsh.model.getEntities(3):
        z = occ.getCenterOfMass(3, tag)[2]
        groups[SECONDARY if z > t else PRIMARY].append(tag)
    if len(groups[PRIMARY]) != 1 or len(groups[SECONDARY]) != 1:
        raise RuntimeError(f"unexpected geometry after fragment: {groups}")
    for _, tag in gmsh.model.getEntities(2):
        b = np.asarray(gmsh.model.getBoundingBox(2, tag))
        lo, hi = b[:3], b[3:]
        flat_z = hi[2] - lo[2] < tol
        name = None
        if flat_z and abs(lo[2] - t) < tol and lo[0] > L - c - tol and hi[0] < L + tol:
            name = INTERFACE
        elif flat_z and abs(lo[2]) < tol and hi[0] - lo[0] < 2 * R + tol:
            name = BOLT_NUT
        elif flat_z and abs(lo[2] - 2 * t) < tol and hi[0] - lo[0] < 2 * R + tol:
            name = BOLT_HEAD
        elif hi[0] - lo[0] < tol and abs(lo[0]) < tol:
            name = PRIMARY_XMIN
        elif hi[0] - lo[0] < tol and abs(lo[0] - (2 * L - c)) < tol:
            name = SECONDARY_XMAX
        if name is not None:
            groups.setdefault(name, []).append(tag)
    for name in (INTERFACE, BOLT_NUT, BOLT_HEAD, PRIMARY_XMIN, SECONDARY_XMAX):
        if len(groups.get(name, [])) != 1:
            raise RuntimeError(f"expected one {name} surface, found {groups.get(name)}")
    tags: dict[str, int] = {}
    for name, ents in groups.items():
        dim = 3 if name in (PRIMARY, SECONDARY) else 2
        tags[name] = gmsh.model.addPhysicalGroup(dim, ents, TAGS[name], name=name)

    saved = {
        o: gmsh.option.getNumber(o)
        for o in (
            "Mesh.MeshSizeMax",
            "Mesh.ElementOrder",
            "Mesh.MeshSizeFromCurvature",
            "Mesh.Algorithm3D",
        )
    }
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 16)  # the hole in 16 elements at least
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT: faster than Delaunay, deterministic
    try:
        gmsh.model.mesh.generate(3)
    finally:
        for key, value in saved.items():
            gmsh.option.setNumber(key, value)
    split_interface_nodes(3, tags[INTERFACE], groups[INTERFACE])
    return model_info(model_name, 3, cell_type, tags, h)
