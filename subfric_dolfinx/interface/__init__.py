"""Zero-thickness interface elements for DOLFINx (the only package that knows DOLFINx here).

* :func:`pair_interface`: master/slave facet pairs across ranks, extended index map.
* :class:`InterfaceElements`: quadrature, local frames, Quadrature-space state, kernels.
* :class:`ExtendedLayout`: ghosted vectors and a matrix with cross-interface couplings.
"""

from .element import InterfaceElements, quadrature_rule
from .layout import ExtendedLayout
from .pairing import InterfaceError, InterfacePairs, pair_interface

__all__ = [
    "ExtendedLayout",
    "InterfaceElements",
    "InterfaceError",
    "InterfacePairs",
    "pair_interface",
    "quadrature_rule",
]
