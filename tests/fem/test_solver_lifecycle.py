"""The solver cleans up after itself: options never outlive a solver, prefixes are released.

As DOLFINx's own SNES ``NonlinearProblem`` does: options pushed under the prefix, applied, then
deleted (or the database's earlier values restored); the scene runner guards everything from the
solver's creation on. Reproduces the leaks of the first version and shows them fixed.
"""

import dataclasses
import gc

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from demos import block_on_base
from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    DEFAULT_OPTIONS,
    PETSC_ERROR_REASON,
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    SolveResult,
)
from subfric_dolfinx.fem.linear import STRATEGY_OPTIONS
from subfric_dolfinx.fem.solver import _LIVE_PREFIXES
from subfric_dolfinx.io import CheckpointError
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import parse_scene, run_scene
from subfric_dolfinx.scenes.build import build_mesh, build_problem
from tests.contact_meshes import tagged_blocks
from tests.helpers import block_problem, everywhere, raised_on_every_rank

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)


def small_scene(prefix):
    s = block_on_base.scene(n=4, hold=1.0, dt=0.1)
    s["solver"]["prefix"] = prefix
    s["outputs"] = {}
    return s


@pytest.fixture(scope="module")
def problem():
    scene = parse_scene(small_scene("lc_"))
    return build_problem(scene, build_mesh(scene.mesh, MPI.COMM_WORLD))


def under(prefix):
    return {k: v for k, v in PETSc.Options().getAll().items() if k.startswith(prefix)}


def test_options_do_not_outlive_the_solver(problem):
    before = PETSc.Options().getAll()
    with FrictionSolver(problem, "lc1_", {"snes_max_it": 3, "ksp_type": "gmres"}) as s:
        assert s.snes.getTolerances()[3] == 3
        assert s.snes.getKSP().getType() == "gmres"
        assert PETSc.Options().getAll() == before  # applied, then deleted
    # the first version left them behind: the next solver of that prefix inherited them
    with FrictionSolver(problem, "lc1_") as s:
        assert s.snes.getTolerances()[3] == DEFAULT_OPTIONS["snes_max_it"]
        assert s.snes.getKSP().getType() == STRATEGY_OPTIONS["reuse"]["ksp_type"]
    assert PETSc.Options().getAll() == before


def test_command_line_options_apply_and_stay(problem):
    """Options in the database (the command line) apply under the prefix and are kept; the
    solver's own options win for that solver only."""
    opts = PETSc.Options()
    opts["lc2_snes_max_it"] = 7
    try:
        with FrictionSolver(problem, "lc2_") as s:
            assert s.snes.getTolerances()[3] == 7
        with FrictionSolver(problem, "lc2_", {"snes_max_it": 5}) as s:
            assert s.snes.getTolerances()[3] == 5
        assert under("lc2_") == {"lc2_snes_max_it": "7"}
    finally:
        opts.delValue("lc2_snes_max_it")


def test_late_read_options_reach_the_factorisation(problem):
    """MUMPS reads its options when it factorises, long after setFromOptions: the solver pushes
    its options again around each solve (and removes them afterwards)."""
    before = PETSc.Options().getAll()
    with FrictionSolver(problem, "lc3_", {"mat_mumps_icntl_14": 57}) as s:
        r = s.solve(0.1, 0.1)
        assert r.converged
        F = s.snes.getKSP().getPC().getFactorMatrix()
        assert F.getMumpsIcntl(14) == 57
        assert PETSc.Options().getAll() == before
        r = s.solve(0.2, 0.1, options={"snes_max_it": 1, "snes_atol": 1e-300, "snes_rtol": 1e-300})
        assert not r.converged and r.iterations == 1  # options for this solve only ...
        assert s.snes.getTolerances()[3] == DEFAULT_OPTIONS["snes_max_it"]  # ... then restored
        assert PETSc.Options().getAll() == before


def test_a_petsc_error_gives_a_result_of_the_same_fields(monkeypatch):
    """An error raised inside a callback (here the Jacobian's, on every rank) ends the solve with
    a SolveResult like a converged one: not converged, reason PETSC_ERROR_REASON, PETSc's message
    in ``error`` (``None`` after a converged solve); the result is frozen."""
    scene = parse_scene(small_scene("lc6_"))
    prob = build_problem(scene, build_mesh(scene.mesh, MPI.COMM_WORLD))
    with FrictionSolver(prob, "lc6_") as s:
        ok = s.solve(0.1, 0.1)

        def broken(*args, **kwargs):
            raise RuntimeError("the Jacobian fails on purpose")

        monkeypatch.setattr(prob, "jacobian", broken)
        bad = s.solve(0.2, 0.1)
    assert type(ok) is SolveResult and type(bad) is SolveResult
    assert ok.converged and ok.reason > 0 and ok.error is None and not ok.interrupted
    assert ok.iterations >= 1 and len(ok.residuals) == ok.iterations + 1
    assert not bad.converged and bad.reason == PETSC_ERROR_REASON and bad.error
    assert bad.converged_by is None and bad.residuals == () and not bad.interrupted
    with pytest.raises(dataclasses.FrozenInstanceError):
        ok.converged = False  # type: ignore[misc]


def test_destroy_is_safe_and_releases_the_prefix(problem):
    s = FrictionSolver(problem, "lc4_")
    assert "lc4_" in _LIVE_PREFIXES
    with pytest.raises(ValueError, match="already used"):
        FrictionSolver(problem, "lc4_")
    s.destroy()
    s.destroy()  # idempotent
    assert not s.alive and "lc4_" not in _LIVE_PREFIXES
    with pytest.raises(RuntimeError, match="destroyed"):
        s.solve(0.1, 0.1)
    t = FrictionSolver(problem, "lc4_")  # usable again
    del t
    gc.collect()
    assert "lc4_" not in _LIVE_PREFIXES  # a collected solver releases its prefix too


@pytest.mark.parametrize("kind", ["small_sliding", "finite_sliding"])
def test_the_problem_releases_its_petsc_objects(kind):
    """Leaving an InterfaceProblem's ``with`` block frees its PETSc objects as FrictionSolver's
    does: the bulk matrix, the load vectors and its interfaces' vectors (of either kind), after a
    solved step; a second ``destroy`` is safe."""
    comm = MPI.COMM_WORLD
    dom = tagged_blocks(comm, n_base=(4, 2), n_block=(4, 2), split_x=0.5)
    with InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e7, alpha_n=1e7, mu_c=0.3),
        {"base": Material(2.1e5, 0.3), "block": Material(2.1e5, 0.3)},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
        [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.0, 0)],
        [Pressure("top", 100.0, amplitude="press")],
        interfaces=[Interface("contact", "base", "block", kinematics=kind)],
    ) as problem:
        with FrictionSolver(problem, linear="lu") as solver:
            records = LoadStepper(solver, 0.5).run()
        assert records[-1].t == pytest.approx(1.0)
        iface = problem.interfaces["contact"]
        held = [problem.K, *(f for _, f in problem.loads), iface.x_ext, iface.b_ext]
        assert all(obj.handle for obj in held)
    assert not any(obj.handle for obj in held)
    assert problem.K is None and problem.K_scale is None and problem.loads == []
    assert iface.x_ext is None and iface.b_ext is None
    problem.destroy()  # idempotent


def test_automatic_prefixes_are_unique(problem):
    with FrictionSolver(problem) as a, FrictionSolver(problem) as b:
        assert a.prefix != b.prefix and a.prefix.startswith("subfric_")


def test_automatic_prefixes_agree_after_a_solver_on_one_rank(problem):
    """A solver made on rank 0 alone (``COMM_SELF``) moves only that rank's automatic count on;
    the next solver of every rank still has one prefix (the first version gave the ranks
    different prefixes: each read its options under its own)."""
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        with FrictionSolver(block_problem(MPI.COMM_SELF)) as alone:
            assert alone.alive
    with FrictionSolver(problem) as solver:
        assert len(set(comm.allgather(solver.prefix))) == 1, comm.allgather(solver.prefix)


def test_prefixes_that_differ_between_ranks_are_refused_on_every_rank(problem):
    """A given prefix that is not the same on every rank, or one that a live solver of some
    rank holds, is one ValueError on every rank, before any option is read (the first version
    raised on the rank that held it while the others went on into the collective SNES); then
    the prefix is free again."""
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        names = str([f"lc7r{r}_" for r in range(comm.size)])
        with raised_on_every_rank(ValueError, "differs between the ranks", names):
            FrictionSolver(problem, f"lc7r{comm.rank}_")
    held = FrictionSolver(block_problem(MPI.COMM_SELF), "lc7_") if comm.rank == 0 else None
    with raised_on_every_rank(ValueError, "'lc7_' is already used by another live solver"):
        FrictionSolver(problem, "lc7_")
    if held is not None:
        held.destroy()
    assert not any(p.startswith("lc7") for p in _LIVE_PREFIXES)
    with FrictionSolver(problem, "lc7_") as solver:
        assert solver.alive


def test_a_failed_restart_releases_the_prefix(shared_tmp):
    """The first version created the solver before the runner's ``try``: a restart from a missing
    checkpoint left the prefix taken forever."""
    comm = MPI.COMM_WORLD
    with pytest.raises(CheckpointError, match="does not exist"):
        run_scene(small_scene("lc5_"), comm=comm, restart=shared_tmp / "missing.h5")
    assert "lc5_" not in _LIVE_PREFIXES
    res = run_scene(small_scene("lc5_"), comm=comm)  # the same prefix works
    assert everywhere(comm, len(res.history) > 0)


def test_a_restart_at_the_end_of_the_program_takes_no_step(shared_tmp):
    """The first version crashed in its summary (``max()`` of an empty list)."""
    comm = MPI.COMM_WORLD
    s = small_scene("lc6_")
    t_end = s["program"]["times"][-1]
    s["outputs"] = {"checkpoint_times": [t_end], "history": True}
    full = run_scene(s, outdir=shared_tmp, comm=comm)
    again = run_scene(s, outdir=shared_tmp, comm=comm, restart=shared_tmp / "checkpoint.h5")
    assert again.iterations == [] and len(again.history) == len(full.history)
    a = np.array([[r["t"], r["F_t1"]] for r in again.history])
    b = np.array([[r["t"], r["F_t1"]] for r in full.history])
    np.testing.assert_array_equal(a, b)
    assert "lc6_" not in _LIVE_PREFIXES
