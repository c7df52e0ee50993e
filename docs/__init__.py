"""The documentation's scripts (``conf.py`` for Sphinx, ``demo_results.py``, ``readme_numbers.py``).

A package so that the tests import them as ``docs.<module>`` (``tests/demos/test_docs.py``,
``tests/demos/test_readme.py``); Sphinx skips this file (``exclude_patterns`` in ``conf.py``).
"""
