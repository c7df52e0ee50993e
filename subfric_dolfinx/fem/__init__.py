"""The finite-element layer: two elastic bodies joined by frictional interface elements (DOLFINx).

* :mod:`.interface`: pairing of the interface sides across ranks, interface elements (quadrature,
  frames, Quadrature-space state, kernels), the parallel layout with cross-interface couplings.
* :mod:`.conditions`: materials, prescribed displacements, loads and springs (plain data);
  :mod:`.boundary`: the groups they act on, Dirichlet dofs, load vectors, spring forms.
* :mod:`.problem`: :class:`InterfaceProblem`, the residual and consistent Jacobian.
* :mod:`.solver`: :class:`FrictionSolver`, PETSc SNES with a clean options lifecycle;
  :mod:`.convergence`: Newton's stopping test, scaled to the round-off floor of the residual.
* :mod:`.stepping`: :class:`LoadStepper`, adaptive load stepping through a loading program.
* :mod:`.kinematics`: the small strain, elastic stress and weight of each modelling mode (3-D,
  plane strain, plane stress, axisymmetric).
* :mod:`.timing`: wall time per section; :mod:`._petsc`: PETSc calls petsc4py 3.22 lacks.

May import: DOLFINx, PETSc, MPI, numpy, and :mod:`subfric_dolfinx.constitutive`,
:mod:`subfric_dolfinx.loading`, :mod:`subfric_dolfinx.logs` (not io or scenes).
"""

from .conditions import (
    Dirichlet,
    DirichletField,
    Material,
    PointForce,
    Pressure,
    Spring,
    Traction,
)
from .interface import InterfaceError
from .problem import InterfaceProblem
from .solver import DEFAULT_OPTIONS, FrictionSolver, SolverOptionError
from .stepping import LoadStepper, StepFailure, StepInterrupted, StepRecord
from .timing import format_breakdown, timing_breakdown

__all__ = [
    "DEFAULT_OPTIONS",
    "Dirichlet",
    "DirichletField",
    "FrictionSolver",
    "InterfaceError",
    "InterfaceProblem",
    "LoadStepper",
    "Material",
    "PointForce",
    "Pressure",
    "SolverOptionError",
    "Spring",
    "StepFailure",
    "StepInterrupted",
    "StepRecord",
    "Traction",
    "format_breakdown",
    "timing_breakdown",
]
