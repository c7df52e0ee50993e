"""Zero-thickness interface elements for DOLFINx.

* :mod:`.geometry`: quadrature on facets, push-forward, local frames, point matching.
* :func:`pair_interface` (:mod:`.pairing`): master/slave facet pairs across ranks, extended
  index map.
* :class:`InterfaceElements` (:mod:`.element`): quadrature, frames, Quadrature-space state of the
  law's declared variables, gap and assembly kernels.
* :class:`ExtendedLayout` (:mod:`.layout`): ghosted vectors and a matrix with cross-interface
  couplings.
"""

from .element import InterfaceElements
from .geometry import coordinate_basis, frames, match_points, push_forward, quadrature_rule
from .layout import ExtendedLayout
from .pairing import InterfaceError, InterfacePairs, pair_interface

__all__ = [
    "ExtendedLayout",
    "InterfaceElements",
    "InterfaceError",
    "InterfacePairs",
    "coordinate_basis",
    "frames",
    "match_points",
    "pair_interface",
    "push_forward",
    "quadrature_rule",
]
