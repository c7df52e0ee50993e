"""The subloading return map's implementation (private; the entry point is :mod:`..subloading`).

Scalar path (plain floats, at most ``SMALL_N`` points): :mod:`.point` (the specification),
:mod:`.root` (branch and certified smallest root), :mod:`.rotation` (rotation of the flow
direction), :mod:`.general` (split and rotation with the exact tangent), :mod:`.fast` (unrolled
special cases). Batched path (numpy, chunks of ``CHUNK`` points): :mod:`.batch`, :mod:`.vroot`,
:mod:`.vrotation`, :mod:`.vgeneral`. Shared: :mod:`.common` (constants), :mod:`.scan` (the
branch-and-bound scan certifying the smallest root under strong softening, folds -> JUMP).
"""
