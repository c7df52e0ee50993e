"""Scenes: build only what is needed, outputs only on request (bad configurations are in the
catalogue of bad inputs, tests/bad_inputs/test_scenes.py)."""

import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI

from demos import block_on_base
from subfric_dolfinx.logs import SlideWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import DEMO_SLIDES, python_env, small_scene


def test_pointwise_scene_needs_no_mesh_no_mpi_no_dolfinx(tmp_path):
    code = (
        "import sys\n"
        "from subfric_dolfinx.scenes import run_scene\n"
        "case = {'params': {'preset': 'sec7'}, 'control': 'disp', 'n_tangential': 1,\n"
        "        'path': [[0, 0, 0, 1.2], [1, 1, 0, 1.2]], 't_samples': [1]}\n"
        "r = run_scene({'kind': 'pointwise', 'name': 'p', 'cases': {'a': case}})\n"
        "assert r.cases['a'].complete and r.cases['a'].samples['f_t1'][0] > 0\n"
        "bad = [m for m in ('dolfinx', 'petsc4py', 'mpi4py', 'gmsh', 'ufl') if m in sys.modules]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    env = python_env({"PATH": "/usr/bin:/bin"})
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_demo_block_on_base_against_the_material_point_driver(shared_tmp):
    """Demo 1 at a small size: its mean friction follows the material-point driver driven by the
    interface's mean gap (peak and end of the forward stroke within 2 %), the hold recovers the
    static friction, and it writes exactly the files it was asked for."""
    comm = MPI.COMM_WORLD
    res = block_on_base.main(
        ["--n", "8", "--hold", "5", "--dt", "0.05", "--out", str(shared_tmp), "--no-figures"], comm
    )
    h = res.history
    t = np.array([r["t"] for r in h])
    area = h[-1]["area"]
    ft = np.array([r["F_t1"] for r in h]) / area
    fn = np.array([r["f_n"] for r in h])
    alpha_t, alpha_n = 500.0, block_on_base.ALPHA_N  # the Sec. 7 set, a stiff normal penalty
    gap_t = np.array([r["up_t1"] for r in h]) + ft / alpha_t
    from subfric_dolfinx.driver import run_case

    path = [[0.0, 0.0, 0.0, 0.0]] + [
        [ti, g, 0.0, f / alpha_n] for ti, g, f in zip(t, gap_t, fn, strict=True)
    ]
    ref = run_case(
        {
            "params": {"preset": "sec7", "alpha_n": alpha_n},
            "control": "disp",
            "n_tangential": 1,
            "path": path,
            "t_samples": t.tolist(),
            "steps_per_mm": 1e-9,
        }
    )
    fwd = (t > 1.0) & (t <= 2.0)
    peak_fe, peak_mp = ft[fwd].max(), ref.samples["f_t1"][fwd].max()
    assert peak_fe == pytest.approx(peak_mp, rel=0.02)
    end = np.flatnonzero(np.isclose(t, 2.0))[0]
    assert ft[end] == pytest.approx(ref.samples["f_t1"][end], rel=0.02)
    assert peak_fe > 1.5 * ft[end]  # static peak, then softening
    # the 5 s hold recovers friction: the reload peak beats the level before the hold
    before = abs(ft[np.flatnonzero(np.isclose(t, 4.0))[0]])
    assert ft[t > 9.0].max() > 1.2 * before
    assert sorted(p.name for p in shared_tmp.iterdir()) == [
        ".subfric-files.json",  # the run's files (io.outdir)
        "history.csv",
        "history.csv-metadata.json",
    ]
    assert len(res.snapshots) == 7 and all(len(s["x"]) == 16 for s in res.snapshots.values())


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
def test_timing_breakdown_is_per_run():
    """Two runs in one process: each run's 'factorisation' (PETSc PCSetUp) and 'linear solve'
    (KSPSolve) are the events' increase during that run, not their process-wide totals."""
    from petsc4py import PETSc

    comm = MPI.COMM_WORLD

    def events():  # this rank's cumulative event times
        return {e: PETSc.Log.Event(e).getPerfInfo()["time"] for e in ("PCSetUp", "KSPSolve")}

    for k in range(2):
        s = small_scene()
        s["solver"]["prefix"] = f"timing{k}_"
        PETSc.Log.begin()
        before = events()
        res = run_scene(s, comm=comm)
        after = events()
        tim = res.timing
        for section, event in (("factorisation", "PCSetUp"), ("linear solve", "KSPSolve")):
            grown = comm.allreduce(after[event] - before[event], op=MPI.MAX)  # as the breakdown
            assert 0.0 < tim[section] <= grown * (1 + 1e-9) + 1e-12, (k, section, tim, grown)
            assert tim[section] >= 0.5 * grown, (k, section, tim, grown)
        assert tim["factorisation"] + tim["linear solve"] < tim["total"]


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
def test_a_hold_in_one_step_recovers_as_in_forty():
    """The main demo crosses its hold in steps of ``hold_dt`` (nothing moves; the return map
    integrates the recovery of mu exactly, whatever the step): the state at the end of the hold
    and the reload peak after it are those of a run stepping the hold at dt_max, to round-off."""
    comm = MPI.COMM_WORLD
    runs = {}
    for hold_dt in (5.0, None):
        s = small_scene()
        s["solver"]["hold_dt"] = hold_dt
        s["solver"]["prefix"] = None
        s["solver"]["linear"] = "lu"  # compared to round-off (README, "Which linear strategy")
        s["outputs"] = {"snapshots": [9.0]}
        runs[hold_dt] = run_scene(s, comm=comm)
    one, many = runs[5.0], runs[None]

    def hold_steps(res):
        return sum(1 for r in res.history if 4.0 < r["t"] <= 9.0 + 1e-9)

    assert hold_steps(one) == 1 and hold_steps(many) == 40  # dt_max 0.125 s
    a, b = one.snapshots[9.0], many.snapshots[9.0]
    mu4 = next(r["mu"] for r in many.history if abs(r["t"] - 4.0) < 1e-9)
    assert b["mu"].mean() > 1.5 * mu4  # the hold did recover mu
    np.testing.assert_allclose(a["mu"], b["mu"], rtol=1e-9)
    np.testing.assert_allclose(a["r"], b["r"], rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(a["f_t"], b["f_t"], rtol=1e-7, atol=1e-9)

    def peak(res):
        return max(r["F_t1"] for r in res.history if r["t"] > 9.0)

    assert peak(one) == pytest.approx(peak(many), rel=1e-9)
