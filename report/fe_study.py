"""FE runs for the report (run under mpirun by report/generate.py).

    mpirun -n R python3 report/fe_study.py CONFIG.json OUT.json

CONFIG.json: ``{"hold": 2.0, "runs": [{"case": "block", "law": "subloading", "n": 16, "dt": 0.02,
"repeats": 2}, ...]}``. A case is a scene of a demo with FIXED steps (``dt_max = dt``, so ``dt``
is what varies) and no output files:

* ``block`` (2-D): ``demos/block_on_base.scene(n, hold, dt)``, the main demo with its hold
  shortened to ``hold``;
* ``pad`` (3-D): ``demos/pad_on_plate.scene(n, holds=(hold,), amplitude=1, alpha_n=500)``
  (1 mm strokes and the Sec. 7 set's normal penalty), its program sampled as at ``dt = 0.1`` for
  every run (the same knots: the runs share their breakpoints);

and a law, ``subloading`` (the demo's) or ``coulomb`` with the same penalties and the kinetic
strength of the subloading law at the nominal pressure (``mu_c f_n = g(f_n) mu_k``). A run with
``"max_cuts": 0`` fails rather than cut a step (the coarsest-step probe). A run is repeated
``repeats`` times in this process and its wall time is the best of them. Rank 0 writes OUT.json:
per run the history (``t``, mean tangential traction ``F_t1 / area``, Newton iterations), whether
it converged, the timing breakdown (``run_scene(...).timing``; the mesh generation timed around
``meshing.create_interface_mesh``) and the sizes.
"""

import json
import math
import sys
import time
from pathlib import Path

import petsc4py

petsc4py.init([sys.argv[0]])

from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if not __package__:  # run as a script, not imported as report.fe_study: the repository's packages
    sys.path.insert(0, str(ROOT))
from demos import block_on_base, pad_on_plate  # noqa: E402
from subfric_dolfinx import meshing  # noqa: E402
from subfric_dolfinx.constitutive import build_law  # noqa: E402
from subfric_dolfinx.fem import StepFailure  # noqa: E402
from subfric_dolfinx.scenes import run_scene  # noqa: E402

MESH_SECONDS = [0.0]
PRESSURE = 300.0  # MPa, both cases


def time_meshing() -> None:
    """Time every ``meshing.create_interface_mesh`` call into ``MESH_SECONDS`` (from now on)."""
    create = meshing.create_interface_mesh

    def timed_create(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return create(*args, **kwargs)
        finally:
            MESH_SECONDS[0] += time.perf_counter() - t0

    meshing.create_interface_mesh = timed_create


def coulomb_of(law_spec: dict) -> dict:
    """Coulomb with the law's penalties and its kinetic strength at the nominal pressure."""
    law = build_law(law_spec)
    mu_c = -math.expm1(-law.c_n * PRESSURE) * law.mu_k / PRESSURE
    return {
        "law": "coulomb",
        "params": {"alpha_t": law.alpha_t, "alpha_n": law.alpha_n, "mu_c": mu_c},
    }


def make_scene(case: str, law: str, n: int, dt: float, hold: float) -> dict:
    """The case's scene with fixed steps ``dt`` and no outputs."""
    if case == "block":
        scene = block_on_base.scene(n=n, hold=hold, dt=dt)
    elif case == "pad":
        # the report's records: 1 mm strokes and the Sec. 7 set's normal penalty
        scene = pad_on_plate.scene(
            n=n, holds=(hold,), amplitude=1.0, dt=0.1, fields=None, alpha_n=500.0
        )
    else:
        raise ValueError(f"unknown case {case!r}")
    if law == "coulomb":
        scene["law"] = coulomb_of(scene["law"])
    scene["solver"].update(dt=dt, dt_max=dt, hold_dt=None)
    scene["outputs"] = {}
    return scene


def one_run(run: dict, hold: float, prefix: str) -> dict:
    """Run one configuration; the history, timing and sizes (every rank)."""
    scene = make_scene(run["case"], run["law"], int(run["n"]), float(run["dt"]), hold)
    scene["solver"]["prefix"] = prefix
    if "max_cuts" in run:
        scene["solver"]["max_cuts"] = int(run["max_cuts"])
    comm = MPI.COMM_WORLD
    PETSc.Log.begin()
    m0 = MESH_SECONDS[0]
    comm.Barrier()
    t0 = time.perf_counter()
    try:
        res = run_scene(scene)
    except StepFailure as e:
        return {"converged": False, "failure": str(e)[:300], "wall": math.inf}
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    timing = dict(res.timing)
    timing["mesh generation"] = comm.allreduce(MESH_SECONDS[0] - m0, op=MPI.MAX)
    area = res.history[-1]["area"]
    return {
        "converged": True,
        "t": [r["t"] for r in res.history],
        "ft": [r["F_t1"] / area for r in res.history],
        "newton": list(res.iterations),
        "cuts": int(sum(r["cuts"] for r in res.history)),
        "unstable": max(r["unstable"] for r in res.history),
        "timing": timing,
        "wall": wall,
        "info": {k: v for k, v in res.info.items() if k != "summary"},
    }


def main():
    """Run the configured list (argv[1]); write histories and timings to argv[2] (rank 0)."""
    time_meshing()
    cfg = json.loads(Path(sys.argv[1]).read_text())
    out_path = Path(sys.argv[2])
    comm = MPI.COMM_WORLD
    hold = float(cfg["hold"])
    out = []
    for i, run in enumerate(cfg["runs"]):
        best, walls = None, []
        for k in range(int(run.get("repeats", 1))):
            r = one_run(run, hold, f"rep{i}_{k}_")
            walls.append(r["wall"])
            if best is None:
                best = r
            elif r["converged"] and r["timing"]["total"] < best["timing"]["total"]:
                best["timing"] = r["timing"]
            if not r["converged"]:
                break
        keys = [k for k in ("case", "law", "n", "dt", "max_cuts") if k in run]
        best.update(wall=min(walls), walls=walls, ranks=comm.size, **{k: run[k] for k in keys})
        out.append(best)
        if comm.rank == 0:
            what = f"{len(best['t'])} steps" if best["converged"] else "FAILED"
            print(
                f"[fe_study] {comm.size} rank(s) {run['case']} {run['law']} n={run['n']} "
                f"dt={run['dt']}: {what}, best wall {best['wall']:.2f} s of {len(walls)}",
                flush=True,
            )
    if comm.rank == 0:
        out_path.write_text(json.dumps({"hold": hold, "runs": out}))


if __name__ == "__main__":
    main()
