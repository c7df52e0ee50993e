"""Constitutive core: friction laws on interface points (imports numpy only).

* :class:`SubloadingParameters` / :class:`CoulombParameters`: validated, immutable parameters with a
  batched ``return_map(gap, state, dt)`` and ``initial_state(n, nt)``.
* :class:`InterfaceState` / :class:`StatePair`: internal-variable arrays with commit and revert.
* :class:`ReturnMapResult` / :class:`Status`: traction, consistent tangent and per-point status.
* :data:`PRESETS` / :func:`preset`: the paper's parameter sets.
"""

from .coulomb import coulomb_return_map
from .parameters import (
    PRESETS,
    CoulombParameters,
    Preset,
    SubloadingParameters,
    normalised_to_absolute,
    preset,
)
from .result import ReturnMapResult, Status
from .state import InterfaceState, StatePair
from .subloading import subloading_return_map

__all__ = [
    "PRESETS",
    "CoulombParameters",
    "InterfaceState",
    "Preset",
    "ReturnMapResult",
    "StatePair",
    "Status",
    "SubloadingParameters",
    "coulomb_return_map",
    "normalised_to_absolute",
    "preset",
    "subloading_return_map",
]
