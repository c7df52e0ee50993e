"""Tests of :mod:`subfric_dolfinx.fem`: problems, solver, load stepping and the bodies' laws."""
