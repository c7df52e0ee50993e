"""The benchmark's 3-D pad with a finite-sliding interface (``benchmarks/fe_scaling.py``).

The pad and the plate are meshed apart (``fe_scaling.pad_apart``): the primary surface is the
plate's whole top, so the pad slides onto plate facets it never touched. Reference: the same pad
on the joined mesh with a small-sliding interface and the same (stiff) normal penalty, where
every point keeps the primary point it faced; over a slide of two facets (0.5 mm on 0.25 mm
facets) forth and back the two agree closely (a uniform plate: what the small-sliding pairs miss
is the plate's deformation following the pad). Before the bodies were meshed apart the primary
surface was only the pad's footprint: the leading points slid off it and separated from the
first sliding steps (the tangential force 8 % below the reference by 0.05 mm).

The same pad on a plate 6 mm long slides two of its widths forth and back (+2, -2, 0 mm), its
top free to tilt: within 5 Newton iterations a step, no cut, no point off the plate, no validity
warning; it leans onto its leading edge by a small angle that follows the slide's direction.
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
    # Newton: within 5 at every step, where the program turns too (the slide's first step, 3, and
    # the reversal, 7: nothing to extrapolate; the pad is carried along by its top's displacement)
    newton = finite[:, 4]
    assert newton.max() <= 5, newton


def test_the_pad_slides_two_widths_forth_and_back(comm):
    """The pad meshed apart on a plate 6 mm long (``fe_scaling.pad_apart``'s ``plate_size``),
    pressed at 300 MPa, its top moved in x to +2 mm, back to -2 mm and to 0 (two of its widths
    each way; held in y, free in z: free to tilt), finite sliding, n = 2, 0.4 mm a step. Every
    step converges without a cut within 5 Newton iterations, no point leaves the plate, the normal
    force is the pressure's at every step, the run ends without a validity warning; the pad tilts
    onto its leading edge (the friction's moment about the interface) by a small angle whose sign
    follows the slide's direction."""
    import dataclasses
    import warnings

    from subfric_dolfinx import meshing
    from subfric_dolfinx.constitutive import preset
    from subfric_dolfinx.fem import (
        Dirichlet,
        FrictionSolver,
        Interface,
        InterfaceProblem,
        Material,
        Pressure,
    )
    from subfric_dolfinx.loading import LoadingProgram

    sides = {"primary": "primary", "secondary": "secondary", "kinematics": "finite_sliding"}
    plate = (6.0, 2.0, 0.5)
    dom, _ = meshing.create_interface_mesh(
        fe_scaling.pad_apart, comm, interfaces={"interface": sides}, n=2, plate_size=plate
    )
    program = LoadingProgram(
        [0.0, 1.0, 3.0, 7.0, 9.0], {"press": [0, 1, 1, 1, 1], "slide": [0, 0, 2, -2, 0]}
    )
    problem = InterfaceProblem(
        dom,
        dataclasses.replace(preset("sec7"), alpha_n=fe_scaling.FINITE_ALPHA_N),
        {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)},
        program,
        [
            Dirichlet("bottom", [0.0, 0.0, 0.0]),
            Dirichlet("top", 1.0, component=0, amplitude="slide"),
            Dirichlet("top", 0.0, component=1),
        ],
        [Pressure("top", 300.0, "press")],
        interfaces=[Interface("interface", "primary", "secondary", kinematics="finite_sliding")],
    )
    X = problem.V.tabulate_dof_coordinates()[: problem.V.dofmap.index_map.size_local]
    top = np.flatnonzero(np.abs(X[:, 2] - 1.0) < 1e-9)  # the pad's top nodes (owned)

    def tilt() -> float:
        """The top's rotation about y: the slope of its vertical displacement along x."""
        x, z = X[top, 0], problem.u.x.array.reshape(-1, 3)[top, 2]
        m, sx, sxx, sz, sxz = (
            comm.allreduce(float(v)) for v in (x.size, x.sum(), x @ x, z.sum(), x @ z)
        )
        return (sxz / m - sx * sz / m**2) / (sxx / m - (sx / m) ** 2)

    rows = []

    def on_step(rec):
        s = interface_summary(problem)
        slide = program.amplitude("slide", rec.t)
        rows.append([rec.t, slide, rec.iterations, rec.cuts, s["F_t1"], s["F_n"], s["separated"]])
        rows[-1].append(tilt())

    solver = FrictionSolver(problem, "padfb_", linear="lu")
    try:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            LoadStepper(solver, 0.4, control=StepControl(dt_max=0.4), on_step=on_step).run()
    finally:
        solver.destroy()
    r = np.array(rows)
    sliding = r[:, 0] > 1.0 + 1e-9
    forth = sliding & (r[:, 0] <= 3.0 + 1e-9)
    back = (r[:, 0] > 3.2) & (r[:, 0] <= 7.0 + 1e-9)
    warned = [str(w.message) for w in seen if issubclass(w.category, UserWarning)]
    assert r[-1, 0] == 9.0 and np.abs(r[-1, 1]) < 1e-12, r[-1]
    assert r[:, 2].max() <= 5 and r[:, 3].sum() == 0, r[:, 2:4]
    assert np.all(r[:, 6] == 0.0), r[:, 6]  # no point left the plate
    np.testing.assert_allclose(r[r[:, 0] >= 1.0, 5], 300.0, rtol=1e-6)
    assert not warned, warned
    # the friction opposes the motion; the pad leans onto its leading edge, slightly
    assert np.all(r[forth, 4] > 0.0) and np.all(r[back, 4] < 0.0), r[:, 4]
    assert np.all(r[forth, 7] < 0.0) and np.all(r[back, 7] > 0.0), r[:, 7]
    assert np.abs(r[:, 7]).max() < 1e-2, r[:, 7]
