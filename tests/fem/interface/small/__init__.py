"""Tests of the small-sliding interface (:mod:`subfric_dolfinx.fem.interface.small`): pairing."""
