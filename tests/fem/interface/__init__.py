"""Tests of :mod:`subfric_dolfinx.fem.interface`: the contract both kinds keep (``test_contract``);
each kind's own tests in ``finite/`` and ``small/``.
"""
