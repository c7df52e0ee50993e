"""The host runner ./run: settings checked before anything runs, chroot builds that take turns.

A real first build (debootstrap and 2.5 GB of packages, minutes) cannot run in the suite, so the
build lock is tested on the runner's own ``ensure_rootfs`` with the expensive step stubbed: the
runner is sourced (it then defines its functions only) and ``build_tree`` (debootstrap + apt) is
replaced by a function that takes a second and writes a marked tree. Everything else — the
lock, the private build directory, its atomic rename, the cleanup after a killed build — is the
runner's code. Runs on one rank (no MPI).
"""

import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.numpy_only

RUN = ROOT / "run"

STUB = r"""
source "$RUNNER"
build_tree() {  # the stub: a second's work, then a complete (marked) tree
    echo "start $$" >>"$LOG"
    [ ! -e "$1" ] || echo "CLOBBERED $1" >>"$LOG"
    mkdir -p "$1"
    sleep "${STUB_SECONDS:-1}"
    echo "built by $$" >"$1/owner"
    packages_hash >"$1/.subfric-packages"
    echo "end $$" >>"$LOG"
}
apt_install() { echo "update $$" >>"$LOG"; packages_hash >"$1/.subfric-packages"; }
ensure_rootfs
[ -f "$SUBFRIC_ROOTFS/owner" ] && [ -f "$SUBFRIC_ROOTFS/.subfric-packages" ]
echo "ready $$" >>"$LOG"
"""


def env(tmp_path, **extra):
    # guard: should the stub ever not replace the real build, debootstrap and apt-get fail here
    fake = tmp_path / "bin"
    if not fake.is_dir():
        fake.mkdir()
        for tool in ("debootstrap", "apt-get", "unshare", "chroot"):
            (fake / tool).write_text(f"#!/bin/sh\necho 'test: {tool} must not run' >&2\nexit 99\n")
            (fake / tool).chmod(0o755)
    e = {
        "PATH": f"{fake}:" + os.environ.get("PATH", "/usr/bin:/bin"),
        "HOME": str(tmp_path),
        "SUBFRIC_ROOTFS": str(tmp_path / "cache" / "rootfs"),
        "LOG": str(tmp_path / "log"),
        "RUNNER": str(RUN),
    }
    e.update({k: str(v) for k, v in extra.items()})
    return e


def builder(tmp_path, **extra):
    return subprocess.Popen(
        ["bash", "-c", STUB],
        env=env(tmp_path, **extra),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )


def log_lines(tmp_path):
    path = tmp_path / "log"
    return path.read_text().split("\n")[:-1] if path.exists() else []


def wait_for(tmp_path, word, timeout=30):
    t0 = time.monotonic()
    while not any(line.startswith(word) for line in log_lines(tmp_path)):
        assert time.monotonic() - t0 < timeout, f"no {word!r} in {log_lines(tmp_path)}"
        time.sleep(0.05)


@pytest.fixture
def check_tools():
    for tool in ("bash", "flock", "sha256sum"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} is not installed")


def test_concurrent_first_builds_take_turns(tmp_path, check_tools):
    """Three ./run calls on a machine without the chroot: one builds, the two others wait for
    it and use its tree; nobody deletes a tree another is building; nothing is left over."""
    first = builder(tmp_path)
    wait_for(tmp_path, "start")  # the first one holds the lock and is building
    others = [builder(tmp_path) for _ in range(2)]
    outputs = [p.communicate(timeout=60)[0] for p in (first, *others)]
    assert [p.returncode for p in (first, *others)] == [0, 0, 0], outputs
    lines = log_lines(tmp_path)
    assert sum(line.startswith("start") for line in lines) == 1, lines
    assert not any("CLOBBERED" in line for line in lines), lines
    assert sum(line.startswith("ready") for line in lines) == 3, lines
    assert all("waiting for it" in out for out in outputs[1:]), outputs
    rootfs = tmp_path / "cache" / "rootfs"
    assert (rootfs / "owner").read_text().strip() == f"built by {first.pid}"
    left = sorted(p.name for p in rootfs.parent.iterdir())
    assert left == ["rootfs", "rootfs.lock"], left


def test_a_killed_build_leaves_nothing_usable_and_the_next_one_builds(tmp_path, check_tools):
    """A build killed half-way (its whole process group, as Ctrl-C does) leaves its private
    directory, never a tree at the chroot's path; the next ./run removes it and builds."""
    first = builder(tmp_path, STUB_SECONDS=60)
    wait_for(tmp_path, "start")
    os.killpg(first.pid, signal.SIGKILL)
    first.communicate(timeout=30)
    cache = tmp_path / "cache"
    assert not (cache / "rootfs").exists()
    assert [p.name for p in cache.iterdir() if p.name.startswith("rootfs.build.")]
    second = builder(tmp_path)
    out = second.communicate(timeout=60)[0]
    assert second.returncode == 0, out
    assert "left by an interrupted build" in out, out
    assert sorted(p.name for p in cache.iterdir()) == ["rootfs", "rootfs.lock"]


def test_an_unmarked_tree_at_the_chroot_path_is_moved_aside(tmp_path, check_tools):
    rootfs = tmp_path / "cache" / "rootfs"
    (rootfs / "etc").mkdir(parents=True)  # e.g. a half-built tree of an earlier version
    p = builder(tmp_path)
    out = p.communicate(timeout=60)[0]
    assert p.returncode == 0, out
    assert "is not a complete chroot: moved aside" in out, out
    aside = [q for q in rootfs.parent.iterdir() if q.name.startswith("rootfs.unmarked.")]
    assert len(aside) == 1 and (aside[0] / "etc").is_dir()
    assert (rootfs / "owner").is_file()


def run_runner(runner, tmp_path, *args, cwd=None, **extra):
    return subprocess.run(
        [str(runner), *args],
        env=env(tmp_path, **extra),
        capture_output=True,
        text=True,
        timeout=60,
        cwd=cwd,
    )


@pytest.mark.parametrize("mode", ["bogus", "Native", " chroot"])
def test_an_invalid_mode_stops_before_anything_runs(tmp_path, mode):
    marker = tmp_path / "marker"
    for args in (["exec", "touch", str(marker)], ["lint"], ["help"]):
        r = run_runner(RUN, tmp_path, *args, SUBFRIC_MODE=mode)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert f"SUBFRIC_MODE must be 'native' or 'chroot', got '{mode}'" in r.stderr
        assert not marker.exists()


@pytest.mark.parametrize("content", [None, "# only a comment\n\n"], ids=["missing", "empty"])
def test_a_missing_or_empty_package_list_stops_the_chroot_before_anything(tmp_path, content):
    """A copy of the runner without its package list, forced into chroot mode: it stops with a
    clear error, builds nothing and runs nothing."""
    repo = tmp_path / "repo"
    repo.mkdir()
    shutil.copy2(RUN, repo / "run")
    if content is not None:
        (repo / "debian-packages.txt").write_text(content)
    marker = tmp_path / "marker"
    r = run_runner(
        repo / "run", tmp_path, "exec", "touch", str(marker), cwd=repo, SUBFRIC_MODE="chroot"
    )
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "debian-packages.txt" in r.stderr
    assert ("is missing" if content is None else "names no package") in r.stderr
    assert not marker.exists() and not (tmp_path / "cache").exists()


@pytest.mark.parametrize("stack", ["bogus", "Sid", "bookworm"])
def test_an_invalid_stack_stops_before_anything_runs(tmp_path, stack):
    marker = tmp_path / "marker"
    r = run_runner(RUN, tmp_path, "exec", "touch", str(marker), SUBFRIC_STACK=stack)
    assert r.returncode == 2, (r.stdout, r.stderr)
    want = f"SUBFRIC_STACK must be 'trixie' (DOLFINx 0.9) or 'sid' (DOLFINx 0.11), got '{stack}'"
    assert want in r.stderr, r.stderr
    assert not marker.exists()


def packages_of(stack, text, tmp_path):
    lst = tmp_path / "list.txt"
    lst.write_text(text)
    r = subprocess.run(
        [str(ROOT / ".ci" / "packages"), stack, str(lst)], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    return r.stdout.split()


def test_one_package_list_for_both_stacks(tmp_path):
    """Plain lines are for both stacks, 'STACK: name' lines for one; comments and blank lines
    are ignored; the real list gives each stack DOLFINx and the same names otherwise."""
    text = "# a comment\nboth-a\n\n  both-b   # trailing\nsid: only-sid\ntrixie: only-trixie x\n"
    assert packages_of("trixie", text, tmp_path) == ["both-a", "both-b", "only-trixie", "x"]
    assert packages_of("sid", text, tmp_path) == ["both-a", "both-b", "only-sid"]
    bad = subprocess.run([str(ROOT / ".ci" / "packages"), "bookworm"], capture_output=True)
    assert bad.returncode == 2
    real = (ROOT / "debian-packages.txt").read_text()
    for stack in ("trixie", "sid"):
        names = packages_of(stack, real, tmp_path)
        assert "python3-dolfinx" in names and "python3-pip" in names, names
        assert "mypy" in names, names  # ./run lint's type checker, on each stack
        assert len(names) == len(set(names)), names


FAILING_APT = r"""
source "$RUNNER"
select_stack sid
in_root() {  # apt-get in the tree, as sid on a bad day answers it
    echo "Reading package lists..."
    echo "E: Unable to locate package python3-dolfinx-real"
    echo "The following packages have unmet dependencies:"
    echo " python3-dolfinx : Depends: python3-petsc4py-real3.25 but it is not going to be installed"
    return 100
}
mkdir -p "$TREE"
apt_install "$TREE"
"""


def test_a_stack_that_cannot_be_installed_says_which_and_why(tmp_path):
    """sid's archive on a bad day: the error names the stack, apt's reasons (which package),
    and how to run the other stack alone; the tree is not marked as built."""
    tree = tmp_path / "tree"
    r = subprocess.run(
        ["bash", "-c", FAILING_APT],
        env=env(tmp_path, TREE=tree),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "the sid (Debian unstable, DOLFINx 0.11) stack cannot be installed" in r.stderr
    assert "Unable to locate package python3-dolfinx-real" in r.stderr
    assert "python3-petsc4py-real3.25 but it is not going to be installed" in r.stderr
    assert "SUBFRIC_STACK=trixie ./run test" in r.stderr
    assert not (tree / ".subfric-packages").exists()


SUMMARY = r"""
unset SUBFRIC_ROOTFS
source "$RUNNER"
lint_ruff() { :; }
mypy_stack() { echo "mypy $STACK" >>"$LOG"; }
ensure_rootfs_if_chroot() { [ "$STACK" != sid ] || [ -z "${SID_BROKEN:-}" ] || return 2; }
pytest_ranks() { echo "pytest $STACK $1" >>"$LOG"; [ "$STACK:$1" != "trixie:2" ]; }
test_all
"""


@pytest.mark.parametrize("broken", [False, True], ids=["sid-ok", "sid-broken"])
def test_the_summary_names_the_stack_of_each_line(tmp_path, broken):
    extra = {"SID_BROKEN": "1"} if broken else {}
    r = subprocess.run(
        ["bash", "-c", SUMMARY],
        env=env(tmp_path, **extra),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 1, (r.stdout, r.stderr)  # trixie's 2-rank leg "failed"
    lines = [ln for ln in r.stderr.splitlines() if "DOLFINx" in ln and ": " in ln]
    assert (
        "[run] trixie (Debian 13, DOLFINx 0.9): 1 rank passed, 2 ranks FAILED, 3 ranks passed"
        in "\n".join(lines)
    ), r.stderr
    if broken:
        assert any("sid (Debian unstable, DOLFINx 0.11): NOT RUN" in ln for ln in lines)
        assert log_lines(tmp_path) == [
            "mypy trixie",  # the type check of the stack that runs, first
            "pytest trixie 1",
            "pytest trixie 2",
            "pytest trixie 3",
        ]
    else:
        assert any(
            "sid (Debian unstable, DOLFINx 0.11): 1 rank passed, 2 ranks passed, 3 ranks passed"
            in ln
            for ln in lines
        ), r.stderr
        legs = log_lines(tmp_path)  # the 1-rank legs side by side, then 2 and 3 ranks in turn
        # each stack's type check first, side by side (either may end first)
        assert sorted(legs[:2]) == ["mypy sid", "mypy trixie"], legs
        legs = legs[2:]
        assert sorted(legs[:2]) == ["pytest sid 1", "pytest trixie 1"], legs
        assert legs[2:] == [f"pytest {s} {n}" for s in ("trixie", "sid") for n in (2, 3)], legs


LINT = r"""
unset SUBFRIC_ROOTFS
source "$RUNNER"
lint_ruff() { echo "ruff" >>"$LOG"; }
mypy_stack() { echo "mypy $STACK" >>"$LOG"; [ "$STACK" != "${MYPY_FAILS:-}" ]; }
lint
"""


@pytest.mark.parametrize("fails", ["", "trixie", "sid"], ids=["clean", "trixie-fails", "sid-fails"])
def test_lint_is_ruff_then_mypy_on_each_stack(tmp_path, fails):
    r = subprocess.run(
        ["bash", "-c", LINT],
        env=env(tmp_path, MYPY_FAILS=fails),
        capture_output=True,
        text=True,
        timeout=60,
    )
    ran = log_lines(tmp_path)
    # ruff first; then both stacks' mypy side by side, each to its end whatever the other gives
    assert ran[0] == "ruff" and sorted(ran[1:]) == ["mypy sid", "mypy trixie"], ran
    if not fails:
        assert r.returncode == 0, (r.stdout, r.stderr)
        assert "FAILED" not in r.stderr
    else:
        assert r.returncode != 0, (r.stdout, r.stderr)
        other = "sid" if fails == "trixie" else "trixie"
        assert f"FAILED: mypy on {fails}" in r.stderr, r.stderr
        assert f"FAILED: mypy on {other}" not in r.stderr, r.stderr


def test_rootfs_without_a_stack_is_refused_for_both_stacks(tmp_path):
    r = run_runner(RUN, tmp_path, "test")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "SUBFRIC_ROOTFS names the chroot of one stack: set SUBFRIC_STACK too" in r.stderr


def test_exec_runs_in_the_callers_folder(tmp_path):
    """``./run exec`` runs in the folder it is called from: a script named relative to it is
    found (natively: any folder; the repository's subfolders in the chroot, where the repository
    is mounted at the same path). Called from outside the repository in chroot mode it stops
    with exit code 2, naming the folder, before anything runs (the chroot does not see it)."""
    import sys

    sub = tmp_path / "work"
    sub.mkdir()
    (sub / "where.py").write_text("import os\nprint('ran in', os.getcwd())\n")
    r = run_runner(
        RUN, tmp_path, "exec", sys.executable, "where.py", cwd=sub, SUBFRIC_MODE="native"
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"ran in {sub.resolve()}"
    r = run_runner(RUN, tmp_path, "exec", "pwd", cwd=ROOT / "demos", SUBFRIC_MODE="native")
    assert r.returncode == 0 and r.stdout.strip() == str((ROOT / "demos").resolve()), r
    marker = tmp_path / "marker"
    r = run_runner(RUN, tmp_path, "exec", "touch", str(marker), cwd=sub, SUBFRIC_MODE="chroot")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert f"{sub.resolve()} is outside the repository" in r.stderr, r.stderr
    assert not marker.exists() and not (tmp_path / "cache").exists()


def test_the_environment_imports_the_mpi_builds_of_adios2_and_h5py(tmp_path):
    """``./run exec python3 -c 'import adios2'`` works in a plain process: the runner's variables
    (``env_vars``) select the MPI builds of ADIOS2 and h5py, the libraries DOLFINx uses (Debian's
    wrappers load their serial builds otherwise, and the serial ADIOS2 is not installed)."""
    script = (
        f'source "{RUN}"; mapfile -t v < <(env_vars); exec env -i "${{v[@]}}" python3 -c '
        '"import adios2, h5py; print(adios2.is_built_with_mpi, h5py.get_config().mpi)"'
    )
    p = subprocess.run(["bash", "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.split() == ["True", "True"], p.stdout


def test_the_docs_command_fails_on_any_sphinx_warning(tmp_path):
    """``./run docs`` is Sphinx with warnings as errors, going on to list them all (the same build
    as ``tests/demos/test_docs.py``'s, which asserts it succeeds)."""
    script = f'source "{RUN}"; in_env() {{ printf "%s\\n" "$@"; }}; main docs -q'
    p = subprocess.run(["bash", "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    args = p.stdout.split()
    assert args[0] == "sphinx-build" and {"-W", "--keep-going", "-q"} <= set(args), args


# The suite's own guard against a hang pytest-timeout cannot end (tests/conftest.py): its
# thread needs the GIL, which a rank waiting inside PETSc's reductions holds; faulthandler's
# watchdog, a C thread, ends the test's process past its timeout and a margin.
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
