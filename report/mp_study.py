"""Material-point convergence study for the report: error against wall time, both laws.

Two displacement-controlled paths at f_n = 300 MPa (``u_n = 0.6`` mm, Sec. 7 preset):

* ``reversal`` (1-D): forward to +1 mm in 1 s, back to -1 mm in 2 s, hold 20 s, reload to +1 mm
  in 2 s (the loading of the FE demo, at one point);
* ``turn`` (3-D contact, two tangential components): 0.3 mm along e1, then 0.15 mm along e2.

References: the subloading law against ``tests/reference_ode.py`` (LSODA at rtol 1e-12; its own
error is estimated by the difference to Radau at the same tolerance); Coulomb against its exact
solution (1-D: the play operator, exact on every straight leg; the turn: on the circle
``|f_t| = R`` the angle obeys ``d theta / ds = (alpha_t / R) cos theta``, so ``sin theta =
tanh(alpha_t s / R)``). Errors are ``max |f_t - f_t,ref|`` over the samples divided by the peak of
``|f_t,ref|`` along the path;
wall times are the driver's own, best of ``repeats`` runs.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from subfric_dolfinx.constitutive import CoulombLaw, preset  # noqa: E402
from subfric_dolfinx.driver import run_case  # noqa: E402
from tests.reference_ode import solve_reference  # noqa: E402

P = preset("sec7")
F_N = 300.0
UN = F_N / P.alpha_n
G = -math.expm1(-P.c_n * F_N)
# Coulomb with the same penalty stiffness, its strength equal to the subloading kinetic strength
MU_C = G * P.mu_k / F_N
COULOMB = CoulombLaw(alpha_t=P.alpha_t, alpha_n=P.alpha_n, mu_c=MU_C)

PATHS = {
    "reversal": (
        np.array(
            [[0, 0, 0, UN], [1, 1, 0, UN], [3, -1, 0, UN], [23, -1, 0, UN], [25, 1, 0, UN]],
            dtype=float,
        ),
        1,
        [25.0 * 2**k for k in range(7)],
    ),
    "turn": (
        np.array([[0, 0, 0, UN], [0.3, 0.3, 0, UN], [0.45, 0.3, 0.15, UN]], dtype=float),
        2,
        [100.0 * 2**k for k in range(7)],
    ),
}


def samples_of(path: np.ndarray) -> np.ndarray:
    """40 equal intervals plus the breakpoints."""
    return np.union1d(np.linspace(path[0, 0], path[-1, 0], 41), path[:, 0])


def coulomb_exact(path: np.ndarray, ts: np.ndarray, nt: int) -> np.ndarray:
    """Exact Coulomb tractions at ``ts`` (constant ``u_n``; straight legs)."""
    R = MU_C * COULOMB.alpha_n * path[0, 3]
    a = COULOMB.alpha_t
    out = np.zeros((ts.size, nt))
    if nt == 1:
        # the play operator: exact leg by leg
        knots = np.union1d(path[:, 0], ts)
        u = np.interp(knots, path[:, 0], path[:, 1])
        f = np.zeros(knots.size)
        for i in range(1, knots.size):
            f[i] = np.clip(f[i - 1] + a * (u[i] - u[i - 1]), -R, R)
        out[:, 0] = f[np.searchsorted(knots, ts)]
        return out
    # turn: leg 1 along e1 (elastic, then on the circle), leg 2 along e2 from (R, 0)
    t1 = path[1, 0]
    v1 = path[1, 1] / t1
    v2 = (path[2, 2] - path[1, 2]) / (path[2, 0] - t1)
    assert a * path[1, 1] > R, "leg 1 must reach the circle"
    for i, t in enumerate(ts):
        if t <= t1:
            out[i, 0] = min(a * v1 * t, R)
        else:
            s = v2 * (t - t1)
            x = a * s / R
            out[i] = R / math.cosh(x), R * math.tanh(x)
    return out


def _case(law: str, path: np.ndarray, ts: np.ndarray, nt: int) -> dict:
    params = {"preset": "sec7"} if law == "subloading" else COULOMB.parameters()
    return {
        "law": law,
        "params": params,
        "control": "disp",
        "path": path.tolist(),
        "t_samples": ts.tolist(),
        "n_tangential": nt,
    }


def lsq_order(steps: list[int], errs: list[float]) -> float:
    """Observed order: minus the least-squares slope of log(error) against log(steps)."""
    x, y = np.log(np.asarray(steps, float)), np.log(np.asarray(errs, float))
    return float(-np.polyfit(x, y, 1)[0])


def run(repeats: int = 3, log=print) -> dict:
    """Run the study; return a JSON-ready dictionary."""
    out: dict = {
        "f_n": F_N,
        "mu_c": MU_C,
        "g": G,
        "repeats": repeats,
        "paths": {},
    }
    for key, (path, nt, spms) in PATHS.items():
        ts = samples_of(path)
        t0 = time.perf_counter()
        ref = solve_reference(P, path, ts, n_tangential=nt, rtol=1e-12)
        t_ref = time.perf_counter() - t0
        ref_b = solve_reference(P, path, ts, n_tangential=nt, rtol=1e-12, method="Radau")
        # the peak of |f_t| along the whole path (not only at the samples), for the scale
        dense_ts = np.union1d(np.linspace(path[0, 0], path[-1, 0], 4001), path[:, 0])
        dense = solve_reference(P, path, dense_ts, n_tangential=nt, rtol=1e-10)
        peak = float(np.linalg.norm(dense.f_t, axis=1).max())
        ref_err = float(np.linalg.norm(ref.f_t - ref_b.f_t, axis=1).max() / peak)
        exact_c = coulomb_exact(path, ts, nt)
        peak_c = float(np.linalg.norm(coulomb_exact(path, dense_ts, nt), axis=1).max())
        entry: dict = {
            "path": path.tolist(),
            "n_tangential": nt,
            "reference": {
                "seconds": t_ref,
                "lsoda_vs_radau": ref_err,
                "drift": ref.drift,
                "switches": [[t, k] for t, k in ref.switches],
                "peak": peak,
            },
            "coulomb_peak": peak_c,
            "runs": [],
        }
        for law, refv, pk in (("subloading", ref.f_t, peak), ("coulomb", exact_c, peak_c)):
            for spm in spms:
                case = _case(law, path, ts, nt)
                walls = []
                res = None
                n_rep = repeats if spm * (path.shape[0]) < 4000 else max(2, repeats - 1)
                for _ in range(n_rep):
                    res = run_case(case, steps_per_mm=spm)
                    walls.append(res.wall_time)
                assert res is not None and res.complete
                ft = np.column_stack([res.samples["f_t1"], res.samples["f_t2"]])[:, :nt]
                err = float(np.linalg.norm(ft - refv, axis=1).max() / pk)
                i = int(np.linalg.norm(ft - refv, axis=1).argmax())
                entry["runs"].append(
                    {
                        "law": law,
                        "spm": spm,
                        "steps": res.n_steps,
                        "error": err,
                        "t_worst": float(ts[i]),
                        "wall": min(walls),
                        "walls": walls,
                        "counts": res.status_counts,
                    }
                )
                log(
                    f"[mp] {key:8s} {law:10s} spm {spm:7.0f}: {res.n_steps:5d} steps, "
                    f"error {err:.3e}, best wall {min(walls) * 1e3:.1f} ms of {n_rep}"
                )
        for law in ("subloading", "coulomb"):
            rs = [r for r in entry["runs"] if r["law"] == law]
            errs = [r["error"] for r in rs]
            if min(errs) > 1e-13:
                entry[f"order_{law}"] = lsq_order([r["steps"] for r in rs], errs)
            else:
                entry[f"order_{law}"] = None  # exact to round-off at every step
        out["paths"][key] = entry
    return out


if __name__ == "__main__":
    import json

    print(json.dumps(run(repeats=1), indent=1)[:2000])
