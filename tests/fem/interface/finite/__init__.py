"""Tests of the finite-sliding interface (:mod:`subfric_dolfinx.fem.interface.finite`): contact
search, projection, segments, the transfer, its tangent and patterns."""
