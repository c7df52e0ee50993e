"""Tests of :mod:`subfric_dolfinx.meshing`: builders, mesh files and their checks, sizes."""
