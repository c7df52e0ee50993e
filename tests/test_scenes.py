"""Scenes: strict configuration, build only what is needed, outputs only on request."""

import copy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.scenes import SceneError, parse_scene, run_scene

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "demos"))
import block_on_base  # noqa: E402


def small():
    s = block_on_base.scene(n=8, hold=5.0, dt=0.05)
    s["outputs"] = {}
    return s


@pytest.mark.parametrize(
    ("mutate", "pattern"),
    [
        (lambda s: s.update(colour="red"), r"scene: unknown key\(s\) \['colour'\]"),
        (lambda s: s["solver"].update(dt="fast"), r"scene.solver.dt: expected a number"),
        (lambda s: s["solver"].update(dt=-1.0), r"scene.solver.dt: must be > 0"),
        (lambda s: s["solver"].pop("dt"), r"scene.solver: missing key 'dt'"),
        (lambda s: s["mesh"].update(builder="teapot"), r"scene.mesh.builder: must be one of"),
        (
            lambda s: s["mesh"]["options"].update(n_interface=4) or s["mesh"].update(file="x.msh"),
            r"scene.mesh: give exactly one",
        ),
        (lambda s: s["dirichlet"][1].update(componnt=0), r"scene.dirichlet\[1\]: unknown key"),
        (lambda s: s["loads"][0].update(type="suction"), r"scene.loads\[0\].type: must be one of"),
        (lambda s: s["materials"]["slave"].update(G=1.0), r"scene.materials.slave: keys must be"),
        (lambda s: s["law"]["params"].update(kappa=-1.0), r"scene.law: .*kappa"),
        (
            lambda s: s["program"]["times"].__setitem__(2, 0.5),
            r"scene.program: times must increase",
        ),
        (
            lambda s: s["outputs"].update(history="yes"),
            r"scene.outputs.history: expected true or false",
        ),
        (lambda s: s.update(degree=3), r"scene.degree: must be one of \[1, 2\]"),
        (lambda s: s.update(kind="movie"), r"scene.kind: must be one of"),
    ],
)
def test_bad_scene_configs_are_named(mutate, pattern):
    s = copy.deepcopy(small())
    mutate(s)
    with pytest.raises(SceneError, match=pattern):
        parse_scene(s)


def test_files_requested_without_a_directory_are_refused():
    s = small()
    s["outputs"]["history"] = True
    with pytest.raises(SceneError, match="no output directory"):
        run_scene(s)


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
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT)}
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
    alpha = 500.0
    gap_t = np.array([r["up_t1"] for r in h]) + ft / alpha
    from subfric_dolfinx.driver import run_case

    path = [[0.0, 0.0, 0.0, 0.0]] + [
        [ti, g, 0.0, f / alpha] for ti, g, f in zip(t, gap_t, fn, strict=True)
    ]
    ref = run_case(
        {
            "params": {"preset": "sec7"},
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
    assert sorted(p.name for p in shared_tmp.iterdir()) == ["history.csv"]
    assert len(res.snapshots) == 7 and all(len(s["x"]) == 16 for s in res.snapshots.values())


def test_timing_breakdown_is_per_run():
    """Two runs in one process: each run's 'factorisation' (PETSc PCSetUp) and 'linear solve'
    (KSPSolve) are the events' increase during that run, not their process-wide totals."""
    from petsc4py import PETSc

    comm = MPI.COMM_WORLD

    def events():  # this rank's cumulative event times
        return {e: PETSc.Log.Event(e).getPerfInfo()["time"] for e in ("PCSetUp", "KSPSolve")}

    for k in range(2):
        s = small()
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
