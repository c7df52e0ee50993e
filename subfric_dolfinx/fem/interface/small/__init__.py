"""Small sliding: node-to-node interface elements, paired once at the reference geometry.

* :class:`~.interface.FrictionInterface` (:mod:`.interface`): the kind itself: its residual and
  tangent into the user's PETSc vector and matrix, the step, commit and revert.
* :class:`~.element.InterfaceElements` (:mod:`.element`): quadrature, frames, the law's state in
  Quadrature spaces, gap and assembly kernels (the kind's law points).
* :func:`~.pairing.pair_interface` (:mod:`.pairing`): the primary and secondary facets paired across
  ranks, the extended index map.
* :func:`~.regions.element_regions` (:mod:`.regions`): interface regions with their own laws.
"""

from .element import InterfaceElements
from .interface import FrictionInterface
from .pairing import InterfacePairs, pair_interface

__all__ = ["FrictionInterface", "InterfaceElements", "InterfacePairs", "pair_interface"]
