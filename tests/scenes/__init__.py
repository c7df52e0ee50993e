"""Tests of :mod:`subfric_dolfinx.scenes`: scene files, their parsing, runs and command line."""
