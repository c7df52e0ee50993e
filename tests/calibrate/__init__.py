"""Tests of :mod:`subfric_dolfinx.calibrate`: calibration from measured curves."""
