"""Tests of :mod:`subfric_dolfinx.driver`: the material-point driver and its inputs."""
