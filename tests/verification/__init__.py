"""Verification: the package against independent references.

Rate equations integrated to high accuracy, published benchmarks (SSNV503, the paper's figures),
closed forms, the stability cases and the C reference of the return map.
"""
