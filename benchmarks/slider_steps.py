"""The spring-slider's cost per step; one point through the float path and the vectorised map.

Prints (thread CPU time, ``time.thread_time``, best of 3: the machine may be shared):

1. one call for one 1-D point (Sec. 7 preset, f_n = 300 MPa; the cases of
   ``benchmarks/driver_steps.py``): ``SubloadingLaw.point_map`` (floats) beside
   ``return_map`` (the vectorised map on one point);
2. the spring-slider (``driver/slider.py``) per accepted step: stick-slip cycles of the
   subloading law (the law of ``tests/driver/test_slider.py``, k = 50 MPa/mm, m = 1 tonne/mm^2,
   V = 0.1 mm/s, 20 s), and the same steps through the vectorised map (``point_map`` replaced
   by one-point ``return_map`` calls) for comparison; return-map calls per step.

Usage: ``./run exec python3 benchmarks/slider_steps.py``. No timing is asserted anywhere.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.driver_steps import best_call, call_cases
from subfric_dolfinx.constitutive import InterfaceState, SubloadingLaw, preset
from subfric_dolfinx.driver import SliderCase, run_slider
from tests.driver.slider_reference import STICK_SLIP_LAW

P = preset("sec7")
LAW = SubloadingLaw(**STICK_SLIP_LAW)


class VectorisedOnly(SubloadingLaw):
    """The law whose ``point_map`` calls the vectorised map on one point (the previous cost)."""

    def point_map(self, gap, state, dt, **kw):
        """The one-point step through ``return_map``."""
        up, mu, r, f0 = state
        arrays = {"up": np.array([[up]]), "mu": np.array([mu]), "r": np.array([r])}
        if f0 is not None:
            arrays["f"] = np.array([f0])
        v = self.return_map(np.array([gap]), InterfaceState(arrays, 1), dt)
        tr, D, st = v.traction[0], v.tangent[0], v.state
        return (
            float(tr[0]),
            float(tr[1]),
            float(D[0, 0]),
            float(D[0, 1]),
            float(st["up"][0, 0]),
            float(st["mu"][0]),
            float(st["r"][0]),
            int(v.status[0]),
            bool(v.unstable[0]),
            int(v.iterations[0]),
        )


def per_step(law, t_end: float, repeats: int = 3) -> tuple[float, int, float]:
    """(us per accepted step, steps, map calls per step), best of ``repeats``."""
    m, k, V = 1.0, 50.0, 0.1
    case = SliderCase(law, m, k, V, 300.0, t_end, dt_max=2 * math.pi * math.sqrt(m / k) / 100)
    best = math.inf
    for _ in range(repeats):
        t0 = time.thread_time()
        res = run_slider(case)
        best = min(best, (time.thread_time() - t0) / res.n_steps)
    return best * 1e6, res.n_steps, res.map_calls / res.n_steps


def main() -> None:
    print("1. one call, one 1-D point (us): point_map (floats) | return_map (vectorised)")
    for name, gap, _, full, dt in call_cases():
        if gap.shape[1] != 2:
            continue
        g = (gap[0, 0], gap[0, 1])
        st = (full["up"][0, 0], full["mu"][0], full["r"][0], tuple(full["f"][0]))
        fast = best_call(lambda g=g, st=st, dt=dt: P.point_map(g, st, dt))
        vec = best_call(lambda gap=gap, full=full, dt=dt: P.return_map(gap, full, dt))
        path = "floats" if name != "reversal 1-D" else "vectorised (a cusp split)"
        print(f"   {name:14s} {fast * 1e6:8.1f} | {vec * 1e6:8.1f}   point_map through: {path}")
    print("2. spring-slider, stick-slip (k = 50 MPa/mm, m = 1 tonne/mm^2, V = 0.1 mm/s, 20 s)")
    us, n, calls = per_step(LAW, 20.0)
    print(f"   point_map:          {us:8.1f} us per step ({n} steps, {calls:.2f} map calls/step)")
    slow = VectorisedOnly(**{f.name: getattr(LAW, f.name) for f in dataclasses.fields(LAW)})
    us, n, calls = per_step(slow, 2.0, repeats=1)
    print(f"   vectorised map:     {us:8.1f} us per step ({n} steps of the first 2 s)")


if __name__ == "__main__":
    main()
