"""Tests of :mod:`subfric_dolfinx.constitutive`.

The return maps of the laws, their fuzzing and tangents, laws defined outside the package.
"""
