"""Running the report's studies; every raw result goes to ``report/data/*.json``.

Nothing here makes a figure, a table or a sentence (:mod:`analysis`, :mod:`figures` and the
template do): the report can always be rebuilt from ``report/data/`` alone
(``./run report --reuse``). Runs, one at a time (their timings are measured):

1. the material-point convergence study (``report/mp_study.py``, in this process);
2. the material-point stability cases (``tests/stability``, in this process);
3. the FE stability cases under ``mpirun -n 1`` and ``mpirun -n 2`` (``report/fe_stability.py``);
4. the FE convergence and timing study under ``mpirun -n 1`` and ``mpirun -n 2``
   (``report/fe_study.py``: 2-D and 3-D, this law and Coulomb), the OMPI/PETSc environment
   passed through.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
T_START = time.perf_counter()


def say(msg: str) -> None:
    """A progress line with the time since the start."""
    print(f"[report {time.perf_counter() - T_START:6.1f} s] {msg}", flush=True)


# --------------------------------------------------------------------------------------------
# Configuration of the FE study


def fe_config(quick: bool) -> dict[str, Any]:
    """Runs of the FE study (the README's section 2 gives the reasoning).

    Per case (``block`` 2-D, ``pad`` 3-D) and law (this one and Coulomb): a study in time (``n``
    fixed), one in space (``dt`` fixed), both against fine references, and a **joint** sequence
    refining time and space together (the trade-off a user makes), run on 1 and 2 ranks; and a
    probe of the coarsest step that converges without a cut (``max_cuts = 0``).
    """
    if quick:
        return {
            "hold": 2.0,
            "laws": ["subloading", "coulomb"],
            "cases": {
                "block": {
                    "time_n": 8,
                    "time_dts": [0.04, 0.02],
                    "dt_ref": 0.01,
                    "space_dt": 0.04,
                    "ns": [8, 16],
                    "n_ref": 32,
                    "joint": [[8, 0.04], [16, 0.02]],
                    "probe_dts": [0.16, 0.08],
                },
                "pad": {
                    "time_n": 2,
                    "time_dts": [0.1, 0.05],
                    "dt_ref": 0.025,
                    "space_dt": 0.05,
                    "ns": [2],
                    "n_ref": 3,
                    "joint": [[2, 0.1], [2, 0.05]],
                    "probe_dts": [],
                },
            },
        }
    return {
        "hold": 2.0,
        "laws": ["subloading", "coulomb"],
        "cases": {
            "block": {
                "time_n": 8,
                "time_dts": [0.04, 0.02, 0.01, 0.005],
                "dt_ref": 0.00125,
                "space_dt": 0.04,
                "ns": [8, 16, 32, 64, 128],
                "n_ref": 256,
                "joint": [[8, 0.04], [16, 0.02], [32, 0.01], [64, 0.005], [128, 0.0025]],
                "probe_dts": [0.32, 0.16, 0.08],
            },
            "pad": {
                "time_n": 2,
                "time_dts": [0.1, 0.05, 0.025],
                "dt_ref": 0.00625,
                "space_dt": 0.05,
                "ns": [2, 3, 4, 8],
                "n_ref": 16,
                "joint": [[2, 0.1], [3, 0.05], [4, 0.025], [8, 0.0125]],
                "probe_dts": [],
            },
        },
    }


def fe_runs(cfg: dict[str, Any], ranks: int) -> list[dict[str, Any]]:
    """The run list of one rank count (repeats: best-of for timings)."""
    runs: list[dict[str, Any]] = []

    def add(case: str, law: str, n: int, dt: float, **extra: Any) -> None:
        if not any(
            r["case"] == case
            and r["law"] == law
            and r["n"] == n
            and r["dt"] == dt
            and r.get("max_cuts") == extra.get("max_cuts")
            for r in runs
        ):
            runs.append({"case": case, "law": law, "n": n, "dt": dt, **extra})

    for case, c in cfg["cases"].items():
        for law in cfg["laws"]:
            for n, dt in c["joint"]:
                add(case, law, n, dt, repeats=2 if n * (3 if case == "pad" else 1) <= 16 else 1)
            if ranks > 1:
                continue
            for dt in c["time_dts"]:
                add(case, law, c["time_n"], dt)
            add(case, law, c["time_n"], c["dt_ref"])
            for n in c["ns"]:
                add(case, law, n, c["space_dt"])
            add(case, law, c["n_ref"], c["space_dt"])
            for dt in c["probe_dts"]:
                add(case, law, c["time_n"], dt, max_cuts=0)
    return runs


# --------------------------------------------------------------------------------------------
# Subprocesses


def mpirun(n: int, script: str, *args: str) -> None:
    """Run ``mpirun -n n python3 report/<script> args``; stdout streamed; raise on failure."""
    cmd = ["mpirun", "-n", str(n), sys.executable, str(HERE / script), *args]
    env = dict(os.environ)  # OMPI_*, PETSc and PYTHONPATH settings pass through
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if "PYTHONPATH" in env else "")
    say("$ " + " ".join(cmd[:4]) + " report/" + script + " " + " ".join(args))
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    for line in proc.stdout.splitlines():
        if line.startswith("[fe_"):
            print("   " + line, flush=True)
    if proc.returncode != 0:
        raise RuntimeError(
            f"{' '.join(cmd)} failed with exit code {proc.returncode}:\n"
            + "\n".join(proc.stderr.splitlines()[-30:])
        )


# --------------------------------------------------------------------------------------------
# The studies: run (writing report/data) or load (--reuse)


def material_point(data: Path, quick: bool, reuse: bool = False) -> dict[str, Any]:
    """The material-point convergence study (``mp_study.run``), ``mp_study.json``."""
    from report import mp_study

    if quick:
        mp_study.PATHS["reversal"] = (*mp_study.PATHS["reversal"][:2], [25.0, 50.0, 100.0])
        mp_study.PATHS["turn"] = (*mp_study.PATHS["turn"][:2], [100.0, 200.0, 400.0])
    if reuse:
        return json.loads((data / "mp_study.json").read_text())
    res = mp_study.run(repeats=2 if quick else 3, log=say)
    (data / "mp_study.json").write_text(json.dumps(res, indent=1))
    return res


def stability(data: Path, reuse: bool = False) -> tuple[list[dict], dict[int, dict]]:
    """The stability catalogue: material-point cases here, FE cases on 1 and 2 ranks."""
    from tests import stability as stability_cases

    if reuse:
        point = json.loads((data / "stability_point.json").read_text())
        fe = {n: json.loads((data / f"stability_fe_{n}.json").read_text()) for n in (1, 2)}
        return point, fe
    point = []
    for case in stability_cases.POINT_CASES:
        t0 = time.perf_counter()
        o = case.run(None)
        wall = time.perf_counter() - t0
        try:
            case.check(o)
            chk = "ok"
        except AssertionError as e:
            chk = f"FAILED: {e}"
        d = o.to_dict()
        d.update(
            name=case.name,
            what=case.what,
            expect=case.expect,
            must=case.must,
            check=chk,
            wall=wall,
            passed=bool(o.outcome == case.expect and o.nan_free and chk == "ok"),
        )
        point.append(d)
        say(f"point case {case.name}: {o.outcome} ({'ok' if d['passed'] else 'NOT ok'})")
    (data / "stability_point.json").write_text(json.dumps(point, indent=1))
    fe = {}
    for n in (1, 2):
        out = data / f"stability_fe_{n}.json"
        mpirun(n, "fe_stability.py", str(out))
        fe[n] = json.loads(out.read_text())
    return point, fe


def fe_study(data: Path, cfg: dict[str, Any], reuse: bool = False) -> dict[int, list[dict]]:
    """The FE convergence and timing runs on 1 and 2 ranks (``fe_study_<n>.json``)."""
    if reuse:
        return {n: json.loads((data / f"fe_study_{n}.json").read_text())["runs"] for n in (1, 2)}
    out = {}
    for n in (1, 2):
        conf = data / f"fe_config_{n}.json"
        conf.write_text(json.dumps({"hold": cfg["hold"], "runs": fe_runs(cfg, n)}))
        res = data / f"fe_study_{n}.json"
        mpirun(n, "fe_study.py", str(conf), str(res))
        out[n] = json.loads(res.read_text())["runs"]
    return out
