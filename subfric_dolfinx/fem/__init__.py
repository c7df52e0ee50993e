"""The finite-element layer: bodies joined by frictional interface elements (DOLFINx).

* :mod:`.interface`: pairing of the interface sides across ranks, interface elements (quadrature,
  frames, Quadrature-space state, kernels), the parallel layout with cross-interface couplings,
  and :class:`FrictionInterface`, one interface as a building block of any DOLFINx problem.
* :mod:`.conditions`: materials, prescribed displacements, loads, springs and interfaces (plain
  data); :mod:`.boundary`: the groups they act on, Dirichlet dofs, load vectors, spring forms;
  :mod:`.bodies`: the interfaces of a problem on the mesh's topology.
* :mod:`.bulk`: the bodies' law: the :class:`~.bulk.BulkModel` protocol (any UFL residual, with
  quadrature-point state committed and reverted with the step), :class:`UFLBulk`, and the
  built-in :class:`LinearElasticity` (the fast path); :mod:`.plasticity`: :class:`J2Bulk`, J2
  plasticity with its state at the quadrature points (a bulk model).
* :mod:`.problem`: :class:`InterfaceProblem`, the residual and consistent Jacobian (its settings:
  :class:`ProblemSettings`; two bodies and one interface: :meth:`InterfaceProblem.two_bodies`).
* :mod:`.solver`: :class:`FrictionSolver`, PETSc SNES with a clean options lifecycle, and
  :class:`SolveResult`, what one solve did;
  :mod:`.convergence`: Newton's stopping test, scaled to the round-off floor of the residual.
* :mod:`.stepping`: :class:`LoadStepper`, adaptive load stepping through a loading program
  (:class:`StepControl`: how its step adapts; :class:`StepperMemory`: what decides its next
  steps, which a checkpoint stores); :mod:`.steplog`: its log lines (segments, progress, steps);
  :mod:`.validity`: the warnings when a run's penetration or slide goes beyond what the
  small-sliding penalty interface describes.
* :mod:`.kinematics`: the small strain, elastic stress and weight of each modelling mode (3-D,
  plane strain, plane stress, axisymmetric).
* :mod:`.timing`: wall time per section; :mod:`._petsc`: PETSc calls petsc4py 3.22 lacks.

May import: DOLFINx, PETSc, MPI, numpy, and :mod:`subfric_dolfinx.constitutive`,
:mod:`subfric_dolfinx.loading`, :mod:`subfric_dolfinx.logs` (not io or scenes).
"""

from .attempts import AttemptReport
from .bulk import BulkContext, BulkModel, LinearElasticity, UFLBulk
from .conditions import (
    Dirichlet,
    DirichletField,
    Interface,
    Material,
    PointForce,
    Pressure,
    ProblemSettings,
    Spring,
    Traction,
)
from .interface import FrictionInterface, InterfaceError, NewtonStart, create_matrix
from .plasticity import J2Bulk, PlasticityError
from .problem import InterfaceProblem
from .solver import (
    DEFAULT_OPTIONS,
    PETSC_ERROR_REASON,
    FrictionSolver,
    SolveResult,
    SolverOptionError,
)
from .stepping import (
    LoadStepper,
    StepControl,
    StepFailure,
    StepInterrupted,
    StepperMemory,
    StepRecord,
)
from .timing import format_breakdown, timing_breakdown

__all__ = [
    "DEFAULT_OPTIONS",
    "PETSC_ERROR_REASON",
    "AttemptReport",
    "BulkContext",
    "BulkModel",
    "Dirichlet",
    "DirichletField",
    "FrictionInterface",
    "FrictionSolver",
    "Interface",
    "InterfaceError",
    "InterfaceProblem",
    "J2Bulk",
    "LinearElasticity",
    "LoadStepper",
    "Material",
    "NewtonStart",
    "PlasticityError",
    "PointForce",
    "Pressure",
    "ProblemSettings",
    "SolveResult",
    "SolverOptionError",
    "Spring",
    "StepControl",
    "StepFailure",
    "StepInterrupted",
    "StepRecord",
    "StepperMemory",
    "Traction",
    "UFLBulk",
    "create_matrix",
    "format_breakdown",
    "timing_breakdown",
]
