"""The report's scripts (``./run report`` runs ``report/generate.py``), a package.

Its modules import each other as ``report.<module>``, and the tests import them the same way
(``tests/demos/test_report.py``); a script run by path (``python3 report/generate.py``) puts the
repository on ``sys.path`` first.
"""
