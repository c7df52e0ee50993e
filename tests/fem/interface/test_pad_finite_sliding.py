"""The benchmark's 3-D pad with a finite-sliding interface (``benchmarks/fe_scaling.py``).

The pad and the plate are meshed apart (``fe_scaling.pad_apart``): the primary surface is the
plate's whole top, so the pad slides onto plate facets it never touched. Reference: the same pad
on the joined mesh with a small-sliding interface and the same (stiff) normal penalty, where
every point keeps the primary point it faced; over a slide of two facets (0.5 mm on 0.25 mm
facets) forth and back the two agree closely (a uniform plate: what the small-sliding pairs miss
is the plate's deformation following the pad). Before the bodies were meshed apart the primary
surface was only the pad's footprint: the leading points slid off it and separated from the
first sliding steps (the tangential force 8 % below the reference by 0.05 mm).
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from benchmarks import fe_scaling
from subfric_dolfinx.fem import LoadStepper, StepControl
from subfric_dolfinx.io import interface_summary

pytestmark = pytest.mark.three_ranks

STEPS = 12  # press in 2, to +0.5 mm in 4, back to -0.5 mm in 6


def history(comm: MPI.Comm, kinematics: str) -> np.ndarray:
    """(step, [t, F_t1, F_n, separated fraction, Newton]) of the 12-step program, n = 4."""
    pad = fe_scaling.build_pad(comm, 4, "lu", STEPS, kinematics, alpha_n=fe_scaling.FINITE_ALPHA_N)
    rows = []

    def on_step(rec):
        s = interface_summary(pad.problem)
        rows.append([rec.t, s["F_t1"], s["F_n"], s["separated"], rec.iterations])

    try:
        LoadStepper(pad.solver, 10.0, control=StepControl(dt_max=10.0), on_step=on_step).run()
    finally:
        pad.solver.destroy()
    return np.array(rows)


def test_the_pad_slides_onto_the_plate_beyond_its_footprint(comm):
    finite = history(comm, "finite_sliding")
    small = history(comm, "small_sliding")
    assert finite.shape == small.shape == (STEPS, 5)
    np.testing.assert_allclose(finite[:, 0], small[:, 0])
    peak = np.abs(small[:, 1]).max()
    assert peak > 10.0  # the pad slid (the static peak at 300 MPa is ~24 N on 1 mm^2)
    assert np.all(finite[:, 3] == 0.0), finite[:, 3]  # no point left the primary surface
    # the pressure's force, in the finite frames that follow the plate's deformed surface
    np.testing.assert_allclose(finite[:, 2], small[:, 2], rtol=1e-4)
    assert np.abs(finite[:, 1] - small[:, 1]).max() < 0.01 * peak, (finite[:, 1], small[:, 1])
    # Newton: where the program turns (the slide's first step, 3, and the reversal, 7: nothing to
    # extrapolate) at most 8 (measured 6 and 5 on 1 and 2 ranks, 7 and 5 on 3 ranks of sid: the
    # count depends on the partition; over issue 22 item 3's 5 at the slide's first step on this
    # pad); elsewhere the extrapolated start and the full 3-D tangent (dB t) converge in 2-3
    newton = finite[:, 4]
    turns = [2, 6]
    assert newton[turns].max() <= 8 and np.delete(newton, turns).max() <= 4, newton
