"""Building an FE scene: the mesh, the law, the loading program and the problem, nothing more."""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from .. import meshing
from ..fem import (
    Dirichlet,
    Interface,
    InterfaceError,
    InterfaceProblem,
    Material,
    PointForce,
    Pressure,
    ProblemSettings,
    Spring,
    Traction,
)
from ..fem.dynamics import Dynamics
from ..fem.kinematics import ModeError
from ..fem.plasticity import PlasticityError
from ..fem.probes import require_near
from .materials import scene_dynamics, scene_materials
from .parser import scene_model
from .schema import DirichletSpec, FEScene, MeshSpec, SceneError

__all__ = ["BUILDERS", "build_mesh", "build_problem"]

BUILDERS = {
    "block_on_base": meshing.build_block_on_base,
    "pad_on_plate": meshing.build_pad_on_plate,
    "bolted_lap_joint": meshing.build_bolted_lap_joint,
}
"""Mesh builders a scene may name."""


def build_mesh(spec: MeshSpec, comm: Any, scene: FEScene | None = None) -> meshing.InterfaceMesh:
    """The mesh of a scene, built or read, then refined ``spec.refine`` times (collective).

    Built with gmsh, read from a ``.msh`` file, or read from a partitioned ``.xdmf`` mesh (each
    rank its part).

    With the scene, its ``bodies`` and ``interfaces`` (and ``mesh.names``) say which groups the
    reader checks as bodies and interfaces.
    """
    topo: dict[str, Any] = {"names": dict(spec.names) or None}
    if scene is not None:
        if scene.bodies:
            topo["bodies"] = {
                b: ([g] if isinstance(g, str) else list(g)) for b, g in scene.bodies.items()
            }
        if scene.interfaces:  # sides given, or None: found from the mesh
            topo["interfaces"] = {n: _mesh_sides(spec) for n, spec in scene.interfaces.items()}
    try:
        if spec.builder is not None:
            dom, _ = meshing.create_interface_mesh(
                BUILDERS[spec.builder], comm, partitioner=spec.partitioner, **topo, **spec.options
            )
        elif spec.file is not None and spec.file.endswith(".xdmf"):
            dom = meshing.read_partitioned_mesh(spec.file, comm, spec.gdim, **topo)
        else:
            dom = meshing.read_interface_mesh(
                spec.file, comm, spec.gdim, partitioner=spec.partitioner, **topo
            )
        return meshing.refine_interface_mesh(dom, spec.refine)
    except meshing.InterfaceMeshError as e:
        if spec.names or (scene is not None and (scene.bodies or scene.interfaces)):
            raise SceneError(f"scene.mesh: {e}") from None
        raise


def _mesh_sides(spec: Any) -> Any:
    """What the reader is told of an interface: its sides (``None``: the mesh's) and kind.

    A finite-sliding interface's sides may be meshed independently: the reader is told so.
    """
    if spec.sides[0] is None:
        return None
    if spec.kinematics is None:
        return spec.sides
    return {"primary": spec.sides[0], "secondary": spec.sides[1], "kinematics": spec.kinematics}


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
        # (parser.py: a pressure's value is a number and its amplitude one channel, a
        # traction's a vector)
        Pressure(ld.group, float(cast(float, ld.value)), cast(str | None, ld.amplitude))
        if ld.type == "pressure"
        else Traction(ld.group, cast(list[float], ld.value), ld.amplitude)
        for ld in scene.loads
    ] + point_forces
    materials = {k: Material(v["E"], v["nu"]) for k, v in scene.materials.items()}
    model = scene.model if scene.model is not None else scene_model(scene)
    interfaces = None
    if scene.interfaces:
        interfaces = [
            Interface(
                name,
                *spec.sides,
                law=model.interfaces[name].law,
                initial_gap=model.interfaces[name].initial_gap,
                regions=model.interfaces[name].regions or None,
                quadrature=spec.quadrature,
                kinematics=spec.kinematics,
                search_radius=spec.search_radius,
                reach=spec.reach,
                intended_compliance=bool(spec.intended_compliance),
            )
            for name, spec in scene.interfaces.items()
        ]
    elif model.initial_gap is not None or model.regions:  # the scene's one interface's
        interfaces = [
            Interface(group, initial_gap=model.initial_gap, regions=model.regions or None)
            for group in _only_interface(domain)
        ]
    _check_material_names(scene, domain)
    try:
        return InterfaceProblem(
            domain,
            model.law,
            scene_materials(scene) or materials,
            model.program,
            bcs,
            [*loads, *springs],
            interfaces=interfaces,
            settings=ProblemSettings(scene.degree, scene.quadrature, scene.mode, _dynamics(scene)),
        )
    except PlasticityError as e:
        raise SceneError(f"scene.materials: {e}") from None
    except ModeError as e:
        raise SceneError(f"scene.mode: {e}") from None


def _dynamics(scene: FEScene) -> Dynamics | None:
    """The scene's inertia (:func:`~.materials.scene_dynamics`), ``None``: quasi-static."""
    kwargs = scene_dynamics(scene)
    return None if kwargs is None else Dynamics(**kwargs)


def _only_interface(domain: meshing.InterfaceMesh) -> list[str]:
    """The group of the mesh's only interface (the classic layout's when it knows none).

    Raises:
        InterfaceError: The mesh has several interfaces.
    """
    known = list(domain.interfaces) or [meshing.INTERFACE]
    if len(known) > 1:
        raise InterfaceError(
            f"the mesh has {len(known)} interfaces {known}: give the initial gap and the regions "
            "per interface (scene.interfaces.<name>.initial_gap, .regions)"
        )
    return known


def _check_material_names(scene: FEScene, domain: meshing.InterfaceMesh) -> None:
    """Every material names a body or a cell group of the mesh (or primary/secondary).

    Raises:
        SceneError: Naming the unknown keys and the bodies there are.
    """
    cells = {n for n, d in domain.dims.items() if d == domain.tdim}
    known = set(domain.bodies) | cells | {"primary", "secondary"}
    extra = sorted(set(scene.materials) - known)
    if extra:
        raise SceneError(
            f"scene.materials: {extra} are neither bodies nor cell groups of the mesh; bodies: "
            f"{sorted(domain.bodies)}"
        )
