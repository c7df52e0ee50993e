"""The repository's programs, run.

The demos, the documentation site, the README's numbers, the report and the benchmarks' scripts.
"""
