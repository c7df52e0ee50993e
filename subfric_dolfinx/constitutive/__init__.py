"""Constitutive core: friction laws on interface points (imports numpy only).

* :class:`FrictionLaw` (protocol) and :class:`LawBase`: what a law declares (its internal
  :class:`Variable` s) and provides (``return_map``, ``strength``, ``initial_state``,
  ``parameters``); a new law is one module.
* :class:`SubloadingLaw` (the subloading-friction law with saturation) and :class:`CoulombLaw`
  (the baseline), each with its parameters beside its batched return map.
* :func:`build_law` / :func:`register_law`: the law factory used by scenes and the driver.
* :class:`RegionalLaw`: several laws on one interface, each on its own points (regions).
* :class:`InterfaceState` / :class:`StatePair`: internal-variable arrays with commit and revert.
* :class:`ReturnMapResult` / :class:`Status`: traction, consistent tangent and per-point status.
* :data:`PRESETS` / :func:`preset`: the paper's parameter sets.
* :mod:`.tolerances`: the contact band and the loading margin of the return maps.

May import: numpy and the standard library only.
"""

from .coulomb import CoulombLaw, coulomb_return_map
from .laws import LAWS, build_law, law_description, register_law
from .presets import PRESETS, Preset, normalised_to_absolute, preset
from .protocol import LOCAL, SCALAR, TANGENTIAL, FrictionLaw, LawBase, LawError, Variable
from .regions import DEFAULT_REGION, RegionalLaw
from .result import ReturnMapResult, Status
from .state import InterfaceState, StatePair
from .subloading import SubloadingLaw, subloading_return_map
from .tolerances import CONTACT_TOL, LOAD_TOL

__all__ = [
    "CONTACT_TOL",
    "DEFAULT_REGION",
    "LAWS",
    "LOAD_TOL",
    "LOCAL",
    "PRESETS",
    "SCALAR",
    "TANGENTIAL",
    "CoulombLaw",
    "FrictionLaw",
    "InterfaceState",
    "LawBase",
    "LawError",
    "Preset",
    "RegionalLaw",
    "ReturnMapResult",
    "StatePair",
    "Status",
    "SubloadingLaw",
    "Variable",
    "build_law",
    "coulomb_return_map",
    "law_description",
    "normalised_to_absolute",
    "preset",
    "register_law",
    "subloading_return_map",
]
