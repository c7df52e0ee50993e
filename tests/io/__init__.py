"""Tests of :mod:`subfric_dolfinx.io`: output files, histories, checkpoints, gathering."""
