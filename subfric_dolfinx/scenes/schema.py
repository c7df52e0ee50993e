"""The scene schema: the dataclasses of scenes, the scene error and the scene's number check.

A scene is a small JSON-like configuration; :func:`~.parser.parse_scene` turns it into these
dataclasses, strictly (an unknown key or a wrong type is an error naming its path).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from ..constitutive import FrictionLaw
from ..driver import Case
from ..loading import LoadingProgram
from ..values import NotANumber, NotFinite, finite_float, short_repr

__all__ = [
    "LINEAR_STRATEGIES",
    "DirichletSpec",
    "DynamicsSpec",
    "FEScene",
    "FrameSpec",
    "InterfaceModel",
    "InterfaceSpec",
    "LoadSpec",
    "MeshSpec",
    "OutputSpec",
    "PointForceSpec",
    "PointScene",
    "PointSpec",
    "ProbeSpec",
    "SceneError",
    "SceneModel",
    "SolverSpec",
    "SpringSpec",
    "scene_number",
]


LINEAR_STRATEGIES = ("auto", "reuse", "lu", "gamg")
"""The linear strategies of :mod:`subfric_dolfinx.fem.linear` (named here without importing it)."""


class SceneError(ValueError):
    """An invalid scene; the message names the offending key by its path."""


def scene_number(value: Any, path: str) -> float:
    """A number of a scene as a float: a real number (not a boolean), finite.

    The scene's wording of :func:`subfric_dolfinx.values.finite_float`.

    Raises:
        SceneError: ``{path}: expected a number, got ...`` or ``expected a finite number``.
    """
    try:
        return finite_float(value)
    except NotANumber:
        raise SceneError(f"{path}: expected a number, got {short_repr(value)}") from None
    except NotFinite:
        raise SceneError(f"{path}: expected a finite number, got {short_repr(value)}") from None


BUILDER_GDIM = {"block_on_base": 2, "pad_on_plate": 3, "bolted_lap_joint": 3}
"""The mesh builders a scene may name, with the dimension of their meshes."""


@dataclasses.dataclass(frozen=True)
class MeshSpec:
    """Where the mesh comes from.

    Attributes:
        builder: ``"block_on_base"`` (2-D), ``"pad_on_plate"`` or ``"bolted_lap_joint"`` (3-D),
            built with gmsh.
        file: Or a ``.msh`` file, or a partitioned mesh ``MODEL.xdmf`` (with ``MODEL.h5`` and
            ``MODEL.groups.json`` beside it, written by
            :func:`~subfric_dolfinx.meshing.write_partitioned_mesh`), each rank reading its part
            (relative to the working directory).
        gdim: Geometric dimension of ``file``.
        options: Keyword arguments of the builder.
        partitioner: ``None``, ``"default"``, ``"bodies"``, ``"together"`` or ``"balanced"``
            (:func:`~subfric_dolfinx.meshing.body_partitioner`; a partitioned mesh: ``None`` or
            ``"default"``, DOLFINx's partitioner).
        names: The classic layout's roles (``primary``, ``secondary``, ``interface``; or the
            input aliases ``master``, ``slave``) -> the file's own group names, e.g.
            ``{"primary": "base", "secondary": "block", "interface": "contact"}``.
        refine: Refine the mesh uniformly this many times on the ranks (0 to 8; triangles and
            tetrahedra: :func:`~subfric_dolfinx.meshing.refine_interface_mesh`).
    """

    builder: str | None = None
    file: str | None = None
    gdim: int | None = None
    options: dict[str, Any] = dataclasses.field(default_factory=dict)
    partitioner: str | None = None
    names: dict[str, str] = dataclasses.field(default_factory=dict)
    refine: int = 0

    @property
    def geometric_dim(self) -> int:
        """The mesh's dimension: the builder's, or ``gdim`` of a file (0: not given)."""
        if self.builder is not None and self.builder in BUILDER_GDIM:
            return BUILDER_GDIM[self.builder]
        return int(self.gdim or 0)


@dataclasses.dataclass(frozen=True)
class DirichletSpec:
    """Prescribed displacement ``(value + gradient . x) * amplitude(t)`` on a group.

    ``value`` is a list (all components) or a number with ``component``. The group is a facet
    group (its facets' dofs), a cell group (every dof of the body), a node group of the mesh
    (gmsh physical points) or a point of the scene's ``points`` (its nearest vertex).
    """

    group: str
    value: float | list[float]
    component: int | None = None
    amplitude: str | None = None
    gradient: list[float] | None = None


@dataclasses.dataclass(frozen=True)
class LoadSpec:
    """A pressure (``value`` a number, positive inwards) or traction (``value`` a vector).

    A traction's ``amplitude`` may be a list, one channel (or null) per component.
    """

    type: str
    group: str
    value: float | list[float]
    amplitude: str | None | list[str | None] = None


# --- supports, points, probes and frames -----------------------------------------------------
@dataclasses.dataclass(frozen=True)
class SpringSpec:
    """Elastic support ``t = -k (u - u0 amplitude(t))`` per component on a facet group.

    ``stiffness`` (MPa/mm: N/mm per mm² of the face) is one number or one per component (0: that
    component free); ``u0`` the springs' end, ``amplitude`` one channel or one per component.
    """

    group: str
    stiffness: float | list[float]
    u0: list[float] | None = None
    amplitude: str | None | list[str | None] = None


@dataclasses.dataclass(frozen=True)
class PointSpec:
    """A named point: coordinates ``x`` and, on the interface, the ``body`` it belongs to."""

    x: list[float]
    body: str | None = None


@dataclasses.dataclass(frozen=True)
class PointForceSpec:
    """A force vector (N) at the mesh vertex nearest to the named point ``point``."""

    point: str
    value: list[float]
    amplitude: str | None | list[str | None] = None


@dataclasses.dataclass(frozen=True)
class ProbeSpec:
    """Values at a named point in the history.

    ``fields`` among ``u`` (displacement), ``sigma`` (stress components), ``von_mises``, and the
    interface's ``f_t``, ``f_n``, ``gap``, ``status`` and the law's variables (at the nearest
    quadrature point of ``interface``: needed when the scene has several interfaces).
    """

    point: str
    fields: list[str] = dataclasses.field(default_factory=lambda: ["u"])
    interface: str | None = None


@dataclasses.dataclass(frozen=True)
class FrameSpec:
    """Reaction of ``group`` resolved in the local frame (tangent [, n x tangent], normal).

    Columns ``R_<name>_t``, ``R_<name>_n`` (2-D) or ``R_<name>_t1``, ``_t2``, ``_n`` (3-D);
    ``name`` defaults to the group.
    """

    group: str
    normal: list[float]
    tangent: list[float]
    name: str | None = None


@dataclasses.dataclass(frozen=True)
class SolverSpec:
    """SNES prefix and load-stepping controls.

    Attributes:
        dt: Initial load step (s).
        prefix: PETSc options prefix of the solver (command-line options apply under it); a
            unique ``subfric_<n>_`` when omitted.
        dt_max: Largest step (default ``dt``).
        dt_min: Smallest step before the run gives up.
        max_cuts: Consecutive step cuts allowed.
        hold_dt: Step in the program's holds (segments where no channel changes), e.g. the
            hold's length: one step (``None``: holds are stepped like the rest).
        options: PETSc options under the prefix, for this scene's solver only.
        linear: Linear strategy, ``"auto"`` (``"gamg"`` in 3-D from 100k dofs, else
            ``"reuse"``), ``"reuse"``, ``"lu"`` or ``"gamg"``
            (:mod:`subfric_dolfinx.fem.linear`).
        max_steps: Most load steps of the run (default
            :data:`~subfric_dolfinx.fem.stepping.MAX_STEPS`, 1e6): a program that needs more
            even at ``dt_max`` (and ``hold_dt`` in holds) is refused before anything is built;
            a run that reaches it (cuts) stops with a ``StepFailure``, its checkpoint written.
    """

    dt: float
    prefix: str | None = None
    dt_max: float | None = None
    dt_min: float | None = None
    max_cuts: int = 10
    hold_dt: float | None = None
    options: dict[str, Any] = dataclasses.field(default_factory=dict)
    linear: str = "auto"
    max_steps: int = 1_000_000


@dataclasses.dataclass(frozen=True)
class DynamicsSpec:
    """The time integrator of a dynamic scene (one whose materials give a ``density``).

    See :class:`~subfric_dolfinx.fem.dynamics.Dynamics` (units: MPa, mm, s; density in
    tonne/mm^3, in ``scene.materials.<body>.density``).

    Attributes:
        rho_inf: Generalised-alpha's spectral radius at infinite frequency, in [0, 1] (1:
            Newmark's average acceleration).
        alpha_m: Rayleigh damping's mass coefficient (1/s).
        alpha_k: Rayleigh damping's stiffness coefficient (s).
        initial_velocity: Body (or cell group) -> its initial velocity (mm/s, one value per
            coordinate); the others start at rest.
        gravity: A constant body force ``rho g``: ``g`` (mm/s^2, one value per coordinate).
        interface_forces: ``"mixed"`` or ``"end"`` (the interfaces' forces at the step's end
            alone: no energy gained where contacts close or open within a step).
    """

    rho_inf: float = 1.0
    alpha_m: float = 0.0
    alpha_k: float = 0.0
    initial_velocity: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    gravity: list[float] | None = None
    interface_forces: str = "mixed"


@dataclasses.dataclass(frozen=True)
class OutputSpec:
    """What to produce; nothing by default.

    Attributes:
        history: Write ``history.csv`` (one row per converged step).
        fields: ``"vtx"`` or ``"xdmf"`` field output (per-facet averages, and the interface
            state at the quadrature points in ``fields/interface_points.xdmf``), or ``None``.
        field_times: Times at which fields are written (all steps if empty).
        snapshots: Times at which interface profiles are gathered and returned (steps end there).
        snapshot_file: Write the snapshots to ``interface_profiles.h5`` instead (the layout of
            the interface history at the snapshot times, every variable of the law), each rank
            its own points: no rank gathers the interface.
        interface_history: Write ``interface_history.h5`` (every field at every step, see
            :class:`~subfric_dolfinx.io.InterfaceHistoryH5`).
        checkpoint_every: Write ``checkpoint.h5`` every so many converged steps (0: never).
        checkpoint_times: And at these times (steps end there).
        probes: Values at named points in the history (:class:`ProbeSpec`).
        reaction_frames: Reactions (and spring forces) of groups resolved in local frames
            (:class:`FrameSpec`).
        stress: Also write the Cauchy stress and von Mises stress of the bodies with the fields
            (``stress.bp``, or ``stress.xdmf`` for degree 1 only).

    With checkpoints enabled, SIGTERM makes the run write a checkpoint after the current step and
    stop (:class:`SceneInterrupted`), and a step that cannot be solved leaves the last converged
    state in the checkpoint.
    """

    history: bool = False
    fields: str | None = None
    field_times: list[float] = dataclasses.field(default_factory=list)
    snapshots: list[float] = dataclasses.field(default_factory=list)
    snapshot_file: bool = False
    interface_history: bool = False
    checkpoint_every: int = 0
    checkpoint_times: list[float] = dataclasses.field(default_factory=list)
    probes: list[ProbeSpec] = dataclasses.field(default_factory=list)
    reaction_frames: list[FrameSpec] = dataclasses.field(default_factory=list)
    stress: bool = False

    @property
    def checkpoints(self) -> bool:
        """Whether checkpoints are written."""
        return self.checkpoint_every > 0 or bool(self.checkpoint_times)


@dataclasses.dataclass(frozen=True)
class InterfaceSpec:
    """One interface of a scene (a facet group of the mesh with duplicated nodes).

    Attributes:
        primary: The body whose outward normal defines the interface frame; ``None``: the body
            the mesh gives.
        secondary: The other body.
        master: Same as ``primary`` (an input alias, read as ``primary``).
        slave: Same as ``secondary`` (an input alias, read as ``secondary``).
        law: Its friction law (``{"law": ..., "params": ...}``); ``None``: the scene's ``law``.
        initial_gap: Its initial gap (as the scene's ``initial_gap``).
        regions: Its regions (as the scene's ``regions``).
        quadrature: ``"gauss"`` or ``"nodal"``; ``None``: the scene's.
        kinematics: ``"small_sliding"`` (node-to-node pairs fixed at the reference geometry, the
            sides' nodes matching) or ``"finite_sliding"`` (pairing in the current configuration:
            the bodies slide any distance, the sides may be meshed independently); ``None``:
            small sliding.
        search_radius: Finite sliding only: the largest normal distance at which a point of the
            secondary side faces the primary (mm, > 0); ``None``: twice the largest facet size.
        reach: Finite sliding only: how far a point may slide in one step (mm, > 0); ``None``:
            the largest facet size.
        intended_compliance: ``true``: its normal penalty's compliance is the model's, chosen on
            purpose (a soft layer, rough surfaces): its penetration is judged against the
            interface element size only, not as a compliance (``PenetrationWarning``);
            ``None``: judged on both.
    """

    primary: str | None = None
    secondary: str | None = None
    # input aliases, resolved into primary/secondary when the scene is read: left out of a
    # restart's settings (an older checkpoint's are read through the aliases)
    master: str | None = dataclasses.field(default=None, metadata={"omit_if_none": True})
    slave: str | None = dataclasses.field(default=None, metadata={"omit_if_none": True})
    law: Any = None
    initial_gap: Any = None
    regions: dict[str, Any] = dataclasses.field(default_factory=dict)
    quadrature: str | None = None
    # left out of a restart's settings while unset (checkpoints written before they existed)
    kinematics: str | None = dataclasses.field(default=None, metadata={"omit_if_none": True})
    search_radius: float | None = dataclasses.field(default=None, metadata={"omit_if_none": True})
    reach: float | None = dataclasses.field(default=None, metadata={"omit_if_none": True})
    intended_compliance: bool | None = dataclasses.field(
        default=None, metadata={"omit_if_none": True}
    )

    @property
    def sides(self) -> tuple[str | None, str | None]:
        """(primary, secondary), from either name."""
        return self.primary or self.master, self.secondary or self.slave


Gap = float | Callable[[np.ndarray], np.ndarray] | None
"""An initial gap as built: none, a number (mm), or a function of the coordinates (gdim, n)."""


@dataclasses.dataclass(frozen=True)
class InterfaceModel:
    """One interface's law, initial gap and regions as objects (see :class:`SceneModel`).

    Attributes:
        law: Its own law; ``None``: the scene's.
        initial_gap: Its initial gap (the scene's, when the scene has this one interface).
        regions: Region (a group of its facets) -> that region's law; empty: none.
    """

    law: FrictionLaw | None
    initial_gap: Gap
    regions: dict[str, FrictionLaw]


@dataclasses.dataclass(frozen=True)
class SceneModel:
    """An FE scene's law, loading program, initial gaps and regions, parsed once into objects.

    :func:`~.parser.parse_scene` makes it while validating the scene (:attr:`FEScene.model`);
    the problem is built from it (:func:`~.build.build_problem`), nothing is parsed again.

    Attributes:
        law: The scene's law; ``None``: every interface has its own.
        program: The loading program.
        initial_gap: The classic scene's initial gap (no ``interfaces``).
        regions: The classic scene's regions (no ``interfaces``).
        interfaces: Name -> :class:`InterfaceModel`, as ``FEScene.interfaces`` orders them.
        variables: The internal variables of every law of the scene (probe fields), by name.
    """

    law: FrictionLaw | None
    program: LoadingProgram
    initial_gap: Gap
    regions: dict[str, FrictionLaw]
    interfaces: dict[str, InterfaceModel]
    variables: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class FEScene:
    """A finite-element scene: bodies and frictional interfaces.

    The classic scene has two bodies, ``primary`` and ``secondary``, and one ``interface`` with the
    scene's ``law``, ``initial_gap`` and ``regions``. ``bodies`` names bodies made of cell groups
    (e.g. ``{"bolt": ["head", "shank"]}``), ``interfaces`` the interfaces one by one, each with
    its own sides and law (:class:`InterfaceSpec`); ``materials`` are keyed by body or cell group.
    ``mode`` is ``"3d"``, ``"plane_strain"`` (the 2-D default), ``"plane_stress"`` or
    ``"axisymmetric"`` (coordinates ``(r, z)``, every integral with ``2 pi r``).

    A scene's bodies are linear elastic (the built-in fast path). A bulk law of the user's (a UFL
    residual, ``bulk=`` of :class:`~subfric_dolfinx.fem.InterfaceProblem`) and a solver loop of
    the user's (:class:`~subfric_dolfinx.fem.FrictionInterface`) are Python API only: a scene is
    data, and nothing in it is executed.
    """

    name: str
    mesh: MeshSpec
    materials: dict[str, dict[str, Any]]  # checked by scenes/materials.py ("model": "j2")
    program: dict[str, Any]
    solver: SolverSpec
    law: Any = None  # {"law": name, "params": {...}}, or a FrictionLaw object
    dirichlet: list[DirichletSpec] = dataclasses.field(default_factory=list)
    loads: list[LoadSpec] = dataclasses.field(default_factory=list)
    springs: list[SpringSpec] = dataclasses.field(default_factory=list)
    points: dict[str, PointSpec] = dataclasses.field(default_factory=dict)
    point_forces: list[PointForceSpec] = dataclasses.field(default_factory=list)
    degree: int = 1
    quadrature: str = "gauss"
    outputs: OutputSpec = dataclasses.field(default_factory=OutputSpec)
    kind: str = "fe"
    # the interface beyond its law (see scenes/interface_spec.py): the initial gap g0 (a number,
    # {"expression": ..., "parameters": ...}, {"parabola": ...} or {"circle": ...}) and regions
    # (a group of interface facets -> its law)
    initial_gap: Any = None
    regions: dict[str, Any] = dataclasses.field(default_factory=dict)
    bodies: dict[str, Any] = dataclasses.field(default_factory=dict)
    interfaces: dict[str, InterfaceSpec] = dataclasses.field(default_factory=dict)
    mode: str | None = None  # "3d", "plane_strain" (2-D default), "plane_stress", "axisymmetric"
    # the bodies' inertia: with a "density" in every material (tonne/mm^3), the integrator's
    # settings (None: its defaults, or quasi-static without densities)
    dynamics: DynamicsSpec | None = None
    # what parse_scene made of law, program, initial_gap and regions (not a key of the scene;
    # None in a scene made otherwise, e.g. by dataclasses.replace: the problem's builder makes it)
    model: SceneModel | None = dataclasses.field(
        default=None, init=False, repr=False, compare=False
    )


@dataclasses.dataclass(frozen=True)
class PointScene:
    """A pointwise scene: named material-point cases (see :mod:`subfric_dolfinx.driver`)."""

    name: str
    cases: dict[str, dict[str, Any]]
    steps_per_mm: float | None = None
    on_instability: str = "stop"
    save: bool = False
    kind: str = "pointwise"
    # the cases as parse_scene made them (not a key of the scene; None in a scene made otherwise)
    model: dict[str, Case] | None = dataclasses.field(
        default=None, init=False, repr=False, compare=False
    )
