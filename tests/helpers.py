"""Helpers shared by the tests: MPI-safe assertions, unique names, small problems and scenes.

Multi-rank rule: a test never asserts on one rank alone before a collective (a failure there
would leave the other ranks waiting until the timeout). Either every rank checks the same
gathered data (:func:`everywhere`, :func:`global_spread`), or the root computes, the verdict is
broadcast and every rank asserts (:func:`on_root`, :func:`raised_on_every_rank`).

The DOLFINx stack is imported inside the functions that build problems, so that a numpy-only
test module can use the MPI helpers without loading it.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import sys
import traceback
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import logs
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.loading import LoadingProgram

ROOT = Path(__file__).resolve().parents[1]
MESH_DIR = ROOT / "meshes"

# --------------------------------------------------------------------------------------------
# Collective assertions


def everywhere(comm: MPI.Comm, ok: bool) -> bool:
    """True on every rank iff ``ok`` holds on every rank (collective)."""
    return comm.allreduce(bool(ok), op=MPI.LAND)


def global_spread(comm: MPI.Comm, a: np.ndarray) -> tuple[float, float]:
    """(max - min, min) of an array over all ranks (``(0, 0)`` if empty everywhere)."""
    lo = comm.allreduce(a.min() if a.size else np.inf, op=MPI.MIN)
    hi = comm.allreduce(a.max() if a.size else -np.inf, op=MPI.MAX)
    return hi - lo, (lo if np.isfinite(lo) else 0.0)


def on_root(comm: MPI.Comm, fn: Callable[[], Any], root: int = 0) -> Any:
    """Call ``fn()`` on ``root`` only and return its result on every rank (collective).

    If ``fn`` raised there (a failed ``assert`` included), every rank raises ``AssertionError``
    with the root's error and traceback: a check made on the root fails on every rank and never
    leaves the other ranks waiting in the broadcast.
    """
    result = error = None
    if comm.rank == root:
        try:
            result = fn()
        except Exception as e:
            error = f"on rank {root}: {type(e).__name__}: {e}\n{traceback.format_exc()}"
    result, error = comm.bcast((result, error), root=root)
    if error is not None:
        raise AssertionError(error)
    return result


@contextlib.contextmanager
def raised_on_every_rank(
    exc_type: type[BaseException], *words: str, match: str | None = None
) -> Iterator[None]:
    """Expect ``exc_type`` from the block on every rank of ``MPI.COMM_WORLD``, with the same
    message, containing each of ``words`` (and matching the regular expression ``match``).

    The outcome of every rank is gathered, so a rank that did not raise makes every rank fail
    (instead of hanging in the next collective).
    """
    comm = MPI.COMM_WORLD
    outcome = None
    try:
        yield
    except Exception as e:
        outcome = (type(e).__name__, isinstance(e, exc_type), str(e))
    everyone = comm.allgather(outcome)
    missing = [rank for rank, o in enumerate(everyone) if o is None]
    assert not missing, f"{exc_type.__name__} not raised on rank(s) {missing}: {everyone}"
    for rank, (name, ok, msg) in enumerate(everyone):
        assert ok, f"rank {rank} raised {name} ({msg}), expected {exc_type.__name__}"
    messages = {msg for _, _, msg in everyone}
    assert len(messages) == 1, f"the ranks raised different messages: {messages}"
    (msg,) = messages
    for w in words:
        assert w in msg, f"{w!r} not in the message {msg!r}"
    if match is not None:
        assert re.search(match, msg), f"{match!r} does not match the message {msg!r}"


@contextlib.contextmanager
def leaves_validity(*categories: type[Warning]) -> Iterator[None]:
    """The block leaves the model's validity on purpose: it must issue each of ``categories``
    (:class:`~subfric_dolfinx.logs.SubfricWarning` subclasses), checked on every rank.

    The suite makes the package's warnings errors (``filterwarnings`` in ``pyproject.toml``):
    a scene that leaves the model's validity says so with this (or the ``leaves_validity`` mark,
    tests/conftest.py), and the warning it expects must come. Inside the block these categories
    are collected instead of raised; a run's rank 0 alone shows a package warning
    (:func:`subfric_dolfinx.logs.warn`), so what each rank saw is gathered over
    ``MPI.COMM_WORLD`` and every rank asserts the same. Any other warning goes on as usual (an
    unexpected package warning still fails the test where it is issued).
    """
    import ffcx  # noqa: F401  (its import replaces showwarning: logging.captureWarnings(True))

    comm = MPI.COMM_WORLD
    seen: set[type[Warning]] = set()
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def collect(message, category, filename, lineno, file=None, line=None):
            expected = [c for c in categories if issubclass(category, c)]
            if not expected:
                shown(message, category, filename, lineno, file, line)
            seen.update(expected)

        warnings.showwarning = collect
        for category in categories:
            warnings.filterwarnings("always", category=category)
        yield
    everyone = comm.allgather(sorted(c.__name__ for c in seen))
    missing = [c.__name__ for c in categories if not any(c.__name__ in s for s in everyone)]
    assert not missing, (
        f"expected {missing} (the test declares that its scene leaves the model's validity): "
        "the scene stays valid now; drop the declaration or make the scene leave it again"
    )


warns_on_every_rank = leaves_validity
"""The block must issue each of the categories, checked on every rank: :func:`leaves_validity`
for a warning that is not the model's (an :class:`~subfric_dolfinx.logs.OutputWarning`)."""


# Why a test's scene leaves the model's validity (the reasons of ``leaves_validity`` marks)

SEC7_PENALTY = (
    "LAW, the paper's Sec. 7 set: its 500 MPa/mm normal penalty is far softer than the 1 mm "
    "block's interface elements can tolerate (as published)"
)
DEMO_SLIDES = "small_scene runs the main demo's program: 1 mm slides over 0.125 mm elements"
SOFT_GAP = (
    "nearly rigid bodies (E = 1e8 MPa) on a 1e4 MPa/mm penalty, on purpose: the closed forms "
    "take the bodies rigid"
)
SHORT_SLIDE = 0.35
"""mm: a slide that softens small_scene's interface and stays within 3 of its 0.125 mm interface
elements (the small-sliding interface's validity, fem/validity.py)."""


# --------------------------------------------------------------------------------------------
# Names and processes


class _PrefixCounter:
    """How many prefixes :func:`prefix` has given in this process.

    A solver's prefix must be the same on every rank of its communicator (each rank reads its
    options under its own prefix), so every rank must call :func:`prefix` as often as the others:
    the suite's teardown (``tests/conftest.py``) checks that after every test, fails the test that
    called it on some ranks only, and puts every rank on the same count again.
    """

    given = 0


def prefix(name: str) -> str:
    """A PETSc options prefix used by no other solver of this process (the same on every rank
    as long as every rank calls this as often: :class:`_PrefixCounter`)."""
    n = _PrefixCounter.given
    _PrefixCounter.given += 1
    return f"t{n}_{name}_"


def driver_cli(*args: Any, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``python3 -m subfric_dolfinx.driver ARGS`` from the repository root (one process)."""
    return module_cli("driver", *args, timeout=timeout)


def python_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """``env`` (default: this process's environment) for a child ``python3`` that must import
    ``subfric_dolfinx`` as this process does, and the ``tests``/``demos`` packages.

    From the source tree (``./run exec``, a developer's ``python3 -m pytest``): the repository
    root is put first on ``PYTHONPATH``. Against the installed package (``./run test``, see
    ``.ci/pytest-installed``, which sets ``SUBFRIC_TEST_INSTALLED``): nothing is added, so that the
    child imports the installed package too (its environment appends the root for ``tests`` and
    ``demos``).
    """
    env = dict(os.environ if env is None else env)
    if os.environ.get("SUBFRIC_TEST_INSTALLED"):
        for k in ("PATH", "PYTHONSAFEPATH", "SUBFRIC_TEST_INSTALLED"):
            if k in os.environ:
                env.setdefault(k, os.environ[k])
        return env
    extra = env.get("PYTHONPATH")
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + extra if extra else "")
    return env


def module_cli(module: str, *args: Any, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``python3 -m subfric_dolfinx.<module> ARGS`` from the repository root (one process)."""
    env = python_env()
    return subprocess.run(
        [sys.executable, "-m", f"subfric_dolfinx.{module}", *map(str, args)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def singleton_env() -> dict[str, str]:
    """The environment without the variables of the enclosing mpirun job.

    A child started from an MPI rank would otherwise try to join the parent's job; without them
    it starts as an MPI singleton.
    """
    return logs.singleton_environment()


# --------------------------------------------------------------------------------------------
# Fault injection (output tests)


def hang_fails(seconds: float = 600) -> Any:
    """A pytest mark: after ``seconds`` the test fails and the job ends, even in a hang.

    pytest-timeout's default (signal) method never fires while a rank waits inside an MPI call;
    the thread method dumps every thread's stack and exits the process, and ``mpirun`` then
    ends the other ranks: a fault test that hangs fails instead of blocking the suite.
    """
    import pytest

    return pytest.mark.timeout(seconds, method="thread")


@contextlib.contextmanager
def tmpfs(path: Path, size: str = "1m", readonly: bool = False) -> Iterator[bool]:
    """Mount a small tmpfs at ``path`` (rank 0, collective), unmounted on exit.

    Yields whether the mount was made: mounting needs root in a private mount namespace (as
    inside ``./run``); where it is not allowed (a container), the test of a real fault skips,
    saying so, and its injected twin, which runs everywhere, still checks the error.
    """
    comm = MPI.COMM_WORLD

    def mount() -> bool:
        path.mkdir(parents=True, exist_ok=True)
        opts = f"size={size}" + (",ro" if readonly else "")
        cmd = ["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(path)]
        try:
            return subprocess.run(cmd, capture_output=True, timeout=30).returncode == 0
        except OSError:
            return False

    mounted = on_root(comm, mount)
    try:
        yield mounted
    finally:
        comm.Barrier()
        if mounted:
            on_root(comm, lambda: subprocess.run(["umount", "-l", str(path)], timeout=30))


def fill(directory: Path, leave: int) -> None:
    """Fill the file system of ``directory`` but ``leave`` bytes (one filler file; rank 0)."""
    import shutil

    free = shutil.disk_usage(directory).free
    with open(directory / "filler", "wb") as f:
        f.write(b"\0" * max(free - leave, 0))


def mpirun(code: str, n: int, timeout: float = 150) -> subprocess.CompletedProcess:
    """Run Python ``code`` on ``n`` ranks (``mpirun``) from the repository root, in a process
    group killed after ``timeout`` s (a hang fails the test instead of blocking the suite).

    Returns:
        The completed process (``returncode`` -9 after a timeout, with what it printed).
    """
    env = python_env(singleton_env())
    cmd = ["mpirun", "-n", str(n), sys.executable, "-c", code]
    p = subprocess.Popen(
        cmd,
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, 9)
        out, err = p.communicate()
        err += f"\n[test] killed after {timeout} s: a hang"
        p.returncode = -9
    return subprocess.CompletedProcess(cmd, p.returncode, out, err)


# --------------------------------------------------------------------------------------------
# Small problems and scenes

LAW = preset("sec7")
P = 300.0  # MPa, the pressure on the block
PROGRAM = LoadingProgram(
    [0, 1, 2, 3, 4, 5], {"press": [0, 1, 1, 1, 1, 1], "slide": [0, 0, 1.0, -0.5, -0.5, 1.0]}
)


def column(mode: str, comm):
    """Two bodies of one size on top of each other, the interface across the whole width, held
    against rigid motions only (``bottom`` fixed normally, a pinned and a rolling node): the
    uniaxial column of tests/fem/test_bulk.py and tests/fem/test_j2_problem.py. Returns (domain,
    bcs)."""
    from subfric_dolfinx import meshing
    from subfric_dolfinx.fem import Dirichlet

    if mode == "3d":
        dom, _ = meshing.create_interface_mesh(
            meshing.build_pad_on_plate,
            comm,
            plate_size=(1.0, 1.0, 0.5),
            pad_size=(1.0, 1.0, 0.5),
            n_interface=2,
            cell_type="tetrahedron",
        )
        dom.add_node_group("pin", [[0.0, 0.0, 0.0]], "primary")
        dom.add_node_group("roll", [[1.0, 0.0, 0.0]], "primary")
        bcs = [
            Dirichlet("bottom", 0.0, component=2),
            Dirichlet("pin", [0.0, 0.0, 0.0]),
            Dirichlet("roll", 0.0, component=1),
        ]
        return dom, bcs
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, base_width=1.0, block_width=1.0, n_interface=4
    )
    dom.add_node_group("pin", [[0.0, 0.0]], "primary")
    return dom, [Dirichlet("bottom", 0.0, component=1), Dirichlet("pin", 0.0, component=0)]


def block_problem(comm, law=LAW, cell_type="triangle", partitioner=None, program=None, lift=None):
    """A narrower block on a base (8 interface elements), pressed then slid: a non-uniform
    interface state.

    With ``lift`` the block is pressed by a prescribed vertical displacement of its top (channel
    ``press``) plus ``lift(x)`` times channel ``lift``; otherwise by a pressure ``P``.
    """
    from subfric_dolfinx import meshing
    from subfric_dolfinx.fem import Dirichlet, DirichletField, InterfaceProblem, Material, Pressure

    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base,
        comm,
        partitioner=partitioner,
        n_interface=8,
        cell_type=cell_type,
    )
    program = program or PROGRAM
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.3, component=0, amplitude="slide")]
    loads = []
    if lift is None:
        loads.append(Pressure("top", P, amplitude="press"))
    else:

        def vertical(x, t):
            return -0.25 * program.amplitude("press", t) + program.amplitude("lift", t) * lift(x)

        bcs.append(DirichletField("top", vertical, component=1))
    mats = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
    return InterfaceProblem(dom, law, mats, program, bcs, loads)


def jacobian_against_differences(prob: Any, x: Any, J: Any, rng: Any, h: float) -> tuple:
    """The problem's Jacobian ``J`` at ``x`` against central differences of its residual.

    In one random direction ``d`` (``rng``'s standard normals, zero on the Dirichlet dofs):
    ``(|J d - fd|, |fd|)`` over every rank, ``fd = (F(x + h d) - F(x - h d)) / 2 h``
    (collective).
    """
    comm = prob.comm
    d = x.duplicate()
    d.array_w[:] = rng.standard_normal(d.array_r.size)
    d.array_w[np.isin(np.arange(d.array_r.size), prob.bc_dofs)] = 0.0
    Fp, Fm = prob.create_vector(), prob.create_vector()
    xp, xm = x.copy(), x.copy()
    xp.axpy(h, d)
    xm.axpy(-h, d)
    prob.residual(xp, Fp)
    prob.residual(xm, Fm)
    fd = (Fp.array_r - Fm.array_r) / (2 * h)
    Jd = J.createVecLeft()
    J.mult(d, Jd)
    err = comm.allreduce(float(np.sum((Jd.array_r - fd) ** 2))) ** 0.5
    nrm = comm.allreduce(float(np.sum(fd**2))) ** 0.5
    for v in (d, Fp, Fm, xp, xm, Jd):
        v.destroy()
    return err, nrm


def joined_model(h: float = 0.25) -> int:
    """Two rectangles meshed together in the current gmsh model (:func:`gmsh_open`): the cell
    groups ``lower`` and ``upper``, their shared edge the group ``seam``; returns its tag."""
    import gmsh

    gmsh.model.add("joined")
    occ = gmsh.model.occ
    a, b = occ.addRectangle(0, 0, 0, 1, 0.5), occ.addRectangle(0, 0.5, 0, 1, 0.5)
    occ.fragment([(2, a)], [(2, b)])
    occ.synchronize()
    low = [t for _, t in gmsh.model.getEntities(2) if occ.getCenterOfMass(2, t)[1] < 0.5]
    high = [t for _, t in gmsh.model.getEntities(2) if t not in low]
    mid = [
        t for _, t in gmsh.model.getEntities(1) if abs(occ.getCenterOfMass(1, t)[1] - 0.5) < 1e-9
    ]
    gmsh.model.addPhysicalGroup(2, low, name="lower")
    gmsh.model.addPhysicalGroup(2, high, name="upper")
    tag = gmsh.model.addPhysicalGroup(1, mid, name="seam")
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.model.mesh.generate(2)
    return tag


@contextlib.contextmanager
def gmsh_open() -> Iterator[Any]:
    """gmsh initialised quietly (no configuration files, no signal handler), finalised after."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Verbosity", 2)
    try:
        yield gmsh
    finally:
        gmsh.finalize()


def small_scene(short: bool = False) -> dict:
    """The main demo's scene at a small size (8 interface elements, a 5 s hold), no outputs, on
    the builder's 1 mm block (the geometry the tests' points, probes and groups are placed in;
    the demo's own block is 10 mm long). Its normal stiffness is the demo's.

    The demo's program slides 1 mm, beyond the small-sliding interface's validity on these
    elements (:data:`DEMO_SLIDES`); ``short``: pressed (1 s), then slid :data:`SHORT_SLIDE`
    (1 s), within it.
    """
    from demos import block_on_base

    s = block_on_base.scene(n=8, hold=5.0, dt=0.05)
    s["mesh"]["options"] = {"n_interface": 8, "cell_type": "triangle"}
    s["outputs"] = {}
    if short:
        s["program"] = {
            "times": [0, 1, 2],
            "channels": {"press": [0, 1, 1], "slide": [0, 0, SHORT_SLIDE]},
        }
    return s


def interface_vertex_multiplicity(dom: Any) -> np.ndarray:
    """How many times each interface vertex of an ``InterfaceMesh`` is there, over all ranks
    (by coordinates, rounded; 2 everywhere where the interface's nodes are duplicated)."""
    import dolfinx

    from subfric_dolfinx import meshing

    tdim, comm = dom.tdim, dom.mesh.comm
    dom.mesh.topology.create_connectivity(tdim - 1, 0)
    f = dom.facets(next(iter(dom.interfaces)))
    v = dolfinx.mesh.compute_incident_entities(dom.mesh.topology, f, tdim - 1, 0)
    # (every rank's vertices of its interface facets, owned or not, once each by global index)
    gi = dom.mesh.topology.index_map(0).local_to_global(v)
    x = meshing.nodes._vertex_coordinates(dom.mesh, v)
    allg = np.concatenate(comm.allgather(gi))
    allx = np.concatenate(comm.allgather(x))
    _, first = np.unique(allg, return_index=True)
    _, mult = np.unique(np.round(allx[first], 10), axis=0, return_counts=True)
    return mult


def run_finite_pad(
    comm: MPI.Comm, n: int, steps: int, reach: float, after: Callable[[Any], Any]
) -> tuple[np.ndarray, Any]:
    """Run ``benchmarks.fe_scaling``'s pad meshed apart (finite sliding, LU) through its program.

    Returns:
        The rows ``(t, F_t1, F_n, Newton)`` of its steps, and ``after(pad)`` taken once it ran,
        before its solver is destroyed (collective).
    """
    from benchmarks import fe_scaling
    from subfric_dolfinx.fem import LoadStepper, StepControl
    from subfric_dolfinx.io import interface_summary

    pad = fe_scaling.build_pad(
        comm, n, "lu", steps, "finite_sliding", reach=reach, alpha_n=fe_scaling.FINITE_ALPHA_N
    )
    rows = []

    def on_step(rec):
        s = interface_summary(pad.problem)
        rows.append([rec.t, s["F_t1"], s["F_n"], rec.iterations])

    try:
        LoadStepper(pad.solver, 10.0, control=StepControl(dt_max=10.0), on_step=on_step).run()
        return np.array(rows), after(pad)
    finally:
        pad.solver.destroy()
