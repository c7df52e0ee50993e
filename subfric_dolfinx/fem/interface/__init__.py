"""Zero-thickness interface elements for DOLFINx: one contract, two kinds.

* :class:`BaseInterface` (:mod:`.base`): the abstract base of both kinds, what they do alike
  (the Dirichlet rows and columns of the residual and the tangent, the step, commit and revert,
  ``destroy``) and what the rest of the package reads of an interface, and the helpers both use
  (:class:`InterfaceError`, :class:`InterfaceOptions`: the settings both kinds take,
  :class:`NewtonStart`, the tangent's stiffening, the initial gap, the
  exchange of rows between ranks); :mod:`.protocol`: what the outputs read of an interface's
  law points (:class:`~.protocol.LawPoints`); :mod:`.kinds`: the kind of each interface from
  its ``kinematics``.
* :mod:`.small`: node-to-node small sliding, :class:`FrictionInterface` (pairs fixed at the
  reference geometry, :func:`pair_interface`, :class:`InterfaceElements`).
* :mod:`.finite`: finite sliding on non-matching meshes, :class:`SlidingInterface` (pairing in
  the current configuration), made of parts: its sides, search, law's points, transfer and
  assembly, and each iterate's contact geometry as one value.
* Shared by both: :mod:`.geometry` (quadrature on facets, push-forward, local frames, point
  matching) and :mod:`.layout` (:class:`ExtendedLayout`: ghosted vectors and a matrix with the
  cross-interface couplings; :func:`create_matrix` for the matrix with every interface's
  couplings).
"""

from .base import BaseInterface, InterfaceError, InterfaceOptions, NewtonStart
from .finite import SlidingInterface, SlidingOptions
from .geometry import coordinate_basis, frames, match_points, push_forward, quadrature_rule
from .layout import ExtendedLayout, create_matrix
from .small import FrictionInterface, InterfaceElements, InterfacePairs, pair_interface

__all__ = [
    "BaseInterface",
    "ExtendedLayout",
    "FrictionInterface",
    "InterfaceElements",
    "InterfaceError",
    "InterfaceOptions",
    "InterfacePairs",
    "NewtonStart",
    "SlidingInterface",
    "SlidingOptions",
    "coordinate_basis",
    "create_matrix",
    "frames",
    "match_points",
    "pair_interface",
    "push_forward",
    "quadrature_rule",
]
