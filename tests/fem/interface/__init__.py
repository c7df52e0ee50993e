"""Tests of :mod:`subfric_dolfinx.fem.interface`.

Contact search, projection, segments, pairing and finite sliding.
"""
