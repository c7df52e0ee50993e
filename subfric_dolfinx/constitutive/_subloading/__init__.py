"""The subloading return map's implementation (private; the entry point is :mod:`..subloading`).

One module per step of the algorithm (numbered as in :mod:`..subloading`): :mod:`.trial` (1),
:mod:`.switch` (2), :mod:`.branch` (3), :mod:`.root` and :mod:`.scan` (4), :mod:`.rotation`
(5), :mod:`.tangent` (6); :mod:`.integrate` runs them over chunks of points; :mod:`.common`
holds the constants and the data objects (law, settings, inputs, outputs).
"""
