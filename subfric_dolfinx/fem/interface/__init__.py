"""Zero-thickness interface elements for DOLFINx.

* :mod:`.geometry`: quadrature on facets, push-forward, local frames, point matching.
* :func:`pair_interface` (:mod:`.pairing`): master/slave facet pairs across ranks, extended
  index map.
* :class:`InterfaceElements` (:mod:`.element`): quadrature, frames, Quadrature-space state of the
  law's declared variables, gap and assembly kernels.
* :class:`ExtendedLayout` (:mod:`.layout`): ghosted vectors and a matrix with cross-interface
  couplings.
* :class:`FrictionInterface` (:mod:`.friction`): one interface as a building block of any DOLFINx
  problem (its residual and tangent into the user's PETSc vector and matrix, commit/revert), and
  :func:`create_matrix` for the matrix with every interface's couplings.
* :class:`SlidingInterface` (:mod:`.finite`): the same with finite sliding on non-matching
  meshes (pairing in the current configuration, :mod:`.search`, :mod:`.projection`,
  :mod:`.segments`, :mod:`.transfer`, :mod:`.sliding`).
"""

from .base import InterfaceError
from .element import InterfaceElements
from .finite import SlidingInterface
from .friction import FrictionInterface
from .geometry import coordinate_basis, frames, match_points, push_forward, quadrature_rule
from .layout import ExtendedLayout, create_matrix
from .pairing import InterfacePairs, pair_interface

__all__ = [
    "ExtendedLayout",
    "FrictionInterface",
    "InterfaceElements",
    "InterfaceError",
    "InterfacePairs",
    "SlidingInterface",
    "coordinate_basis",
    "create_matrix",
    "frames",
    "match_points",
    "pair_interface",
    "push_forward",
    "quadrature_rule",
]
