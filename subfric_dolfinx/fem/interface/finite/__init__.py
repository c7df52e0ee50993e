"""Finite sliding on non-matching meshes: paired in the current configuration (``docs/model.md``).

The geometry of ``docs/model.md`` §11-12.


* :class:`~.interface.SlidingInterface` (:mod:`.interface`; its settings
  :class:`~.interface.SlidingOptions`): the kind itself, holding its parts:
  its two sides, fixed (:mod:`.sides`), the law's points with their state and checkpoint data
  (:mod:`.points`), the per-step search of every secondary facet's reach and the layout
  (:mod:`.reach`), the transfer of the tractions to the primary (:mod:`.transfer`) and the forces
  and tangent (:mod:`.assembly`). Each Newton iterate's contact geometry (projections, frames,
  gaps, slip, the tangent's pieces, segments) is one immutable value (:mod:`.contact`).
* The search's tools: :mod:`.surface` (contact surfaces, nodal normals), :mod:`.search` (the
  parallel exchange of candidate facets), :mod:`.projection` and :mod:`.closest` (points on
  facets).
* The kinematics of a secondary point on the primary (gap, convected slip, transport of the state,
  their derivatives): :mod:`.sliding`.
* The overlap of secondary and primary facets the transfer integrates on: :mod:`.segments`.
* Interface regions, the region of every secondary facet:
  :mod:`~subfric_dolfinx.fem.interface.finite.regions`.
"""

from .interface import SlidingInterface, SlidingOptions

__all__ = ["SlidingInterface", "SlidingOptions"]
