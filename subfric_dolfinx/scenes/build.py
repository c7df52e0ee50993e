"""Building an FE scene: the mesh, the law, the loading program and the problem, nothing more."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import meshing
from ..fem import Dirichlet, InterfaceProblem, Material, PointForce, Pressure, Spring, Traction
from ..fem.probes import require_near
from .interface_spec import gap_function, parse_regions
from .parser import build_program, parse_law
from .schema import DirichletSpec, FEScene, MeshSpec, SceneError

__all__ = ["BUILDERS", "build_mesh", "build_problem"]

BUILDERS = {
    "block_on_base": meshing.build_block_on_base,
    "pad_on_plate": meshing.build_pad_on_plate,
    "bolted_lap_joint": meshing.build_bolted_lap_joint,
}
"""Mesh builders a scene may name."""


def build_mesh(spec: MeshSpec, comm: Any) -> meshing.InterfaceMesh:
    """The mesh of a scene: built with a gmsh builder or read from a ``.msh`` file (collective)."""
    if spec.builder is not None:
        dom, _ = meshing.create_interface_mesh(
            BUILDERS[spec.builder], comm, partitioner=spec.partitioner, **spec.options
        )
        return dom
    return meshing.read_interface_mesh(spec.file, comm, spec.gdim, partitioner=spec.partitioner)


def _dirichlet(spec: DirichletSpec, gdim: int, path: str) -> Dirichlet:
    if spec.gradient is None:
        return Dirichlet(spec.group, spec.value, spec.component, spec.amplitude)
    grad = np.asarray(spec.gradient, dtype=float)
    base = np.asarray(spec.value, dtype=float)
    if spec.component is not None:
        if grad.shape != (gdim,) or base.shape != ():
            raise SceneError(f"{path}: with a component, value is a number and gradient has {gdim}")

        def scalar(x: np.ndarray) -> np.ndarray:
            return base + grad @ x[:gdim]

        return Dirichlet(spec.group, scalar, spec.component, spec.amplitude)
    if grad.shape != (gdim, gdim) and grad.shape != (gdim * gdim,):
        raise SceneError(f"{path}.gradient: expected {gdim}x{gdim} values for a vector value")
    G = grad.reshape(gdim, gdim)

    def vector(x: np.ndarray) -> np.ndarray:
        return base[:, None] + G @ x[:gdim]

    return Dirichlet(spec.group, vector, None, spec.amplitude)


def _supports(scene: FEScene, domain: meshing.InterfaceMesh) -> tuple[list, list]:
    """The scene's springs and point forces (collective).

    The scene's points named by Dirichlet conditions become node groups of ``domain`` (the vertex
    nearest to each, in its body); such a point, like a point force's, must lie within a cell's
    size of its body (:class:`~subfric_dolfinx.fem.InterfaceError` naming it otherwise).
    """
    for name in dict.fromkeys(d.group for d in scene.dirichlet):
        pt = scene.points.get(name)
        if pt is None or name in domain.tags or name in domain.node_groups:
            continue
        require_near(domain, pt.x, pt.body, f"scene.points.{name} (held by scene.dirichlet)")
        cells = None if pt.body is None else domain.body_cells(pt.body)
        x, _ = meshing.nearest_vertex(domain.mesh, pt.x, cells)
        domain.add_node_group(name, x[None, : domain.gdim], pt.body)
    springs = [Spring(s.group, s.stiffness, s.u0, s.amplitude) for s in scene.springs]
    forces = [
        PointForce(
            scene.points[f.point].x, f.value, f.amplitude, scene.points[f.point].body, f.point
        )
        for f in scene.point_forces
    ]
    return springs, forces


def build_problem(scene: FEScene, domain: meshing.InterfaceMesh) -> InterfaceProblem:
    """The interface problem of a scene on ``domain`` (collective)."""
    gdim = domain.mesh.geometry.dim
    springs, point_forces = _supports(scene, domain)
    bcs = [_dirichlet(d, gdim, f"scene.dirichlet[{i}]") for i, d in enumerate(scene.dirichlet)]
    loads = [
        Pressure(ld.group, float(ld.value), ld.amplitude)  # type: ignore[arg-type]
        if ld.type == "pressure"
        else Traction(ld.group, ld.value, ld.amplitude)  # type: ignore[arg-type]
        for ld in scene.loads
    ] + point_forces
    materials = {k: Material(v["E"], v["nu"]) for k, v in scene.materials.items()}
    return InterfaceProblem(
        domain,
        parse_law(scene.law),
        materials,
        build_program(scene.program),
        bcs,
        loads,
        springs=springs,
        degree=scene.degree,
        quadrature=scene.quadrature,
        initial_gap=gap_function(scene.initial_gap, gdim),
        regions=parse_regions(scene.regions) or None,
    )
