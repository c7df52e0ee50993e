"""Constitutive core: friction laws on interface points, the bulk J2 law (imports numpy only).

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
* :class:`J2Material` (J2 plasticity with linear isotropic and kinematic hardening, its batched
  return map :func:`j2_return_map` and :class:`J2State`) and :class:`LinearElastic`: bulk laws
  of the bodies at their quadrature points (:mod:`.j2`).

May import: numpy and the standard library only.
"""

from .coulomb import CoulombLaw, coulomb_return_map
from .j2 import J2Material, J2Result, J2State, LinearElastic, j2_return_map
from .laws import LAWS, build_law, law_description, register_law
from .presets import PRESETS, Preset, normalised_to_absolute, preset
from .protocol import LOCAL, SCALAR, TANGENTIAL, FrictionLaw, LawBase, LawError, Variable
from .regions import DEFAULT_REGION, RegionalLaw
from .result import UNSTABLE, ReturnMapResult, Status
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
    "UNSTABLE",
    "CoulombLaw",
    "FrictionLaw",
    "InterfaceState",
    "J2Material",
    "J2Result",
    "J2State",
    "LawBase",
    "LawError",
    "LinearElastic",
    "Preset",
    "RegionalLaw",
    "ReturnMapResult",
    "StatePair",
    "Status",
    "SubloadingLaw",
    "Variable",
    "build_law",
    "coulomb_return_map",
    "j2_return_map",
    "law_description",
    "normalised_to_absolute",
    "preset",
    "register_law",
    "subloading_return_map",
]
