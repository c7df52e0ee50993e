"""subfric-dolfinx: the subloading-friction model with saturation on DOLFINx interface elements.

Importing this package is cheap and pulls in neither DOLFINx, PETSc, MPI nor gmsh: the
constitutive core (:mod:`subfric_dolfinx.constitutive`) and the material-point driver
(:mod:`subfric_dolfinx.driver`) need numpy only. The finite-element layers import DOLFINx when
they are imported themselves.
"""

__version__ = "0.1.0"
