"""The suite's own guard against a hang that pytest-timeout cannot end (tests/conftest.py).

pytest-timeout's thread needs the GIL; a rank waiting inside a C library that holds it (PETSc's
reductions do) is never interrupted. The suite's conftest arms faulthandler's watchdog, a C
thread, for every test: past the test's timeout and a margin it dumps every thread's stack and
ends the process.
"""

import os
import subprocess
import sys
import textwrap

import pytest

HANGS = textwrap.dedent(
    """
    import re

    import pytest


    @pytest.mark.timeout(1)
    def test_hangs_holding_the_gil():
        re.match(r"(a+)+$", "a" * 60 + "b")  # C regex backtracking: years, the GIL held
    """
)


@pytest.mark.serial
def test_a_test_that_hangs_holding_the_gil_ends_its_process(tmp_path):
    (tmp_path / "test_hangs.py").write_text(HANGS)
    env = dict(os.environ, SUBFRIC_TEST_HANG_MARGIN="2")
    cmd = [sys.executable, "-m", "pytest", "-p", "tests.conftest", "-p", "no:cacheprovider"]
    cmd += ["--rootdir", str(tmp_path), "-c", os.devnull, "-o", "timeout_method=thread"]
    cmd += ["-q", "test_hangs.py"]
    run = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode != 0, run.stdout + run.stderr
    assert "Timeout (0:00:03)!" in run.stderr, run.stdout + run.stderr
    assert "test_hangs.py" in run.stderr and "in test_hangs_holding_the_gil" in run.stderr
