"""Finite sliding on non-matching meshes: paired in the current configuration (``docs/model.md``).

The geometry of ``docs/model.md`` §11-12.


* :class:`~.interface.SlidingInterface` (:mod:`.interface`): the kind itself, made of three
  parts: the per-step search of every slave facet's reach (:mod:`.reach`), the forces and
  tangent (:mod:`.assembly`) and the law's points with their checkpoint data (:mod:`.points`).
* The search: :mod:`.surface` (contact surfaces, nodal normals), :mod:`.search` (the parallel
  exchange of candidate facets), :mod:`.projection` and :mod:`.closest` (points on facets).
* The kinematics of a slave point on the master (gap, convected slip, transport of the state,
  their derivatives): :mod:`.sliding`.
* The transfer of the tractions to the master: :mod:`.segments` (the overlap of slave and master
  facets) and :mod:`.transfer` (the segment transfer and its tangent).
"""

from .interface import SlidingInterface

__all__ = ["SlidingInterface"]
