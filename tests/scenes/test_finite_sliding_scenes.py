"""Finite sliding in scenes and their outputs (issue 22: the scene key, outputs, restart).

* ``interfaces.<name>.kinematics: "small_sliding"`` is today's interface: the same history as a
  scene without the key (identical on 1 rank; within MUMPS's round-off on 2).
* A finite-sliding scene (``demos/block_sliding_far.py``'s block, meshed apart from its base,
  slid one width at 300 MPa) writes every output of a small-sliding one: the history's interface
  columns (forces, means of the law's variables, status fractions), the probes at an interface
  point, the interface profiles (snapshots), the interface history (HDF5), the interface points
  (XDMF) and the fields (VTX). The probes, the HDF5 history and the point cloud hold the values of
  the snapshot at the same time (each written by its own path); the normal resultant is the
  pressure's (3000 N/mm on 10 mm); no slide warning (the pairs follow the slide).
* Checkpoint and restart: in the contract both kinds keep (tests/fem/interface/test_contract.py).
* Newton: at most 5 iterations per sliding step of the demo's scene, the slide's first included;
  at its ``--n 4`` (2 mm steps) too, where the extrapolated start keeps the pressed points closed.
"""

import copy
import warnings

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from demos import block_sliding_far as far
from subfric_dolfinx import logs
from subfric_dolfinx.fem import FrictionSolver
from subfric_dolfinx.fem.interface.finite.interface import SlidingInterface
from subfric_dolfinx.logs import SlideWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import DEMO_SLIDES, everywhere, on_root, small_scene


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
def test_the_small_sliding_key_is_todays_interface(comm):
    plain = small_scene()
    keyed = copy.deepcopy(plain)
    keyed["interfaces"] = {"interface": {"kinematics": "small_sliding"}}
    a = run_scene(plain, comm=comm).history
    b = run_scene(keyed, comm=comm).history
    diff = max(
        abs(ra[k] - rb[k]) / (1.0 + abs(ra[k])) for ra, rb in zip(a, b, strict=True) for k in ra
    )
    assert len(a) == len(b) > 10 and list(a[0]) == list(b[0])
    assert diff < 1e-8, diff  # 0 on 1 rank; 3e-11 on 2 (MUMPS's factors vary in the last bits)


@pytest.fixture(scope="module")
def sliding_runs(tmp_path_factory):
    """The run of every output."""
    comm = MPI.COMM_WORLD
    root = comm.bcast(str(tmp_path_factory.mktemp("fslide")) if comm.rank == 0 else None)
    from pathlib import Path

    root = Path(root)
    mesh = root / "block.msh"
    far.write_mesh(mesh, 4, 10.0, comm)
    s = far.scene(mesh, 4, 10.0)
    s["points"] = {"P": {"x": [10.0, 0.0], "body": "block"}}
    s["outputs"] = {
        "history": True,
        "fields": "vtx",
        "interface_history": True,
        "snapshots": [11.0],
        "probes": [{"point": "P", "fields": ["f_n", "f_t", "mu", "status", "gap"]}],
    }
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        full = run_scene(s, outdir=root / "full", comm=comm)
    slide_warned = any(issubclass(w.category, logs.SlideWarning) for w in seen)
    return full, root, slide_warned


def test_a_finite_sliding_scene_writes_every_output(comm, sliding_runs):
    full, root, slide_warned = sliding_runs
    last = full.history[-1]
    snap = full.snapshots[11.0]
    # the probe's point: the nearest, a tie (P is midway between two points) broken by the
    # coordinates, whatever order the ranks gathered the snapshot in
    d = np.round(np.linalg.norm(snap["x"] - [10.0, 0.0], axis=1) / 1e-9)
    i = int(np.lexsort((np.round(snap["x"][:, 1] / 1e-9), np.round(snap["x"][:, 0] / 1e-9), d))[0])

    def files() -> dict:
        with h5py.File(root / "full/interface_history.h5") as f:
            ih = {"f_n": f["f_n"][-1], "mu": f["mu"][-1], "time": f["time"][-1]}
        with h5py.File(root / "full/fields/interface_points.h5") as f:
            steps = sorted((k for k in f if k.startswith("step_")), key=lambda k: int(k[5:]))
            cloud = np.sort(f[steps[-1]]["f_n"][()])
        return {"ih": ih, "cloud": cloud, "bp": (root / "full/fields/interface.bp").is_dir()}

    got = on_root(comm, files)
    checks = {
        "columns": {"F_t1", "F_n", "mu", "plastic", "separated", "P.f_n", "P.mu"} <= set(last),
        "F_n": abs(last["F_n"] - 3000.0) < 1e-5 * 3000.0,
        "sliding": last["plastic"] == 1.0 and last["separated"] == 0.0,
        "probe": last["P.f_n"] == snap["f_n"][i] and last["P.mu"] == snap["mu"][i],
        "history file": got["ih"]["time"] == 11.0
        and np.array_equal(got["ih"]["f_n"], snap["f_n"])
        and np.array_equal(got["ih"]["mu"], snap["mu"]),
        "point cloud": np.array_equal(got["cloud"], np.sort(snap["f_n"])),
        "fields": got["bp"],
        "points": snap["x"].shape == (8, 2),
        "no slide warning": not slide_warned,
    }
    assert everywhere(comm, all(checks.values())), [k for k, v in checks.items() if not v]


def test_newton_takes_at_most_5_iterations_per_sliding_step(comm, tmp_path_factory, monkeypatch):
    """The demo's scene (``--n 8``: 1 mm steps, 0.8 of the block's facet) slid 6 mm: every step of
    the slide converges in at most 5 Newton iterations, without a failed attempt (the exact 2-D
    tangent, the steps started from the extrapolated increment, the first iteration's Jacobian
    keeping the points in contact at the step's start). The first step of the slide has no
    increment to extrapolate across the breakpoint: it starts from the block carried along by its
    top's displacement (``LoadStepper``'s ``predictor`` where the program turns), nowhere from a
    frictionless first iteration (the start where no body is moved by the program alone).
    Without the predictor 7 to 10 per step (``benchmarks/finite_sliding_newton.py``)."""
    from pathlib import Path

    root = Path(comm.bcast(str(tmp_path_factory.mktemp("fnewton")) if comm.rank == 0 else None))
    mesh = root / "block.msh"
    far.write_mesh(mesh, 8, 6.0, comm)
    s = far.scene(mesh, 8, 6.0)
    s.pop("points")
    s["outputs"] = {"history": True}
    # (t, converged, frictionless start, predictor) of every solve (a failed attempt too)
    attempts = []
    solve = FrictionSolver.solve

    def counted(self, t, dt, **kwargs):
        r = solve(self, t, dt, **kwargs)
        start = kwargs.get("start")
        turns = start is not None and start.turns
        attempts.append((t, r.converged, turns, kwargs.get("predictor") is not None))
        return r

    monkeypatch.setattr(FrictionSolver, "solve", counted)
    history = run_scene(s, outdir=root / "out", comm=comm).history
    sliding = [(r["t"], int(r["newton"]), int(r["cuts"])) for r in history if r["t"] > 1.0 + 1e-9]
    failed = [t for t, converged, _, _ in attempts if t > 1.0 + 1e-9 and not converged]
    frictionless = [t for t, _, turns, _ in attempts if turns]
    predicted = [t for t, _, _, given in attempts if given]
    assert len(sliding) >= 6 and sliding[-1][0] == 7.0, sliding
    assert max(n for _, n, _ in sliding) <= 5, sliding
    assert sum(c for _, _, c in sliding) == 0 and not failed, (sliding, failed)
    # the slide's first step starts from the carried block, no step frictionless
    assert not frictionless and sliding[0][0] in predicted, (frictionless, predicted)


START_CORRECTION, SOLVE = SlidingInterface.start_correction, FrictionSolver.solve


def far_slide(comm, root, monkeypatch, closes: bool) -> tuple[list, list, list]:
    """The demo's ``--n 4`` scene slid 20 mm at 2 mm a step, the extrapolated starts closed or not.

    Returns:
        Per step (t, Newton, cuts, push, F_t1); the times of failed attempts; per corrected start,
        the points pressed at the step's start that face the base open after the correction
        (over every rank).
    """
    monkeypatch.setattr(SlidingInterface, "closes_extrapolated_start", closes)
    correct = START_CORRECTION
    still_open = []

    def checked(self, x):
        change = correct(self, x)
        if change is not None:
            self.update(np.asarray(self._owned(x)) + change)
            nt, st = self.sides.nt, self.start
            gap = self.law_points.last_gap[:, nt]
            stuck = (st.normal_stiffness > 0) & self.geometry.found & (gap <= 0.0)
            still_open.append(comm.allreduce(int(stuck.sum())))
        return change

    monkeypatch.setattr(SlidingInterface, "start_correction", checked)
    mesh = root / "block.msh"
    # decided on rank 0: another rank may find the file rank 0 is writing (and skip the collective)
    if not comm.bcast(mesh.exists() if comm.rank == 0 else None):
        far.write_mesh(mesh, 4, 20.0, comm)
    comm.barrier()
    s = far.scene(mesh, 4, 20.0)
    s.pop("points")
    s["outputs"] = {"history": True}
    # the slide's first step 1 mm (its end a knot of the straight slide), then 2 mm steps
    s["program"] = {
        "times": [0, 1, 2, 21],
        "channels": {"press": [0, 1, 1, 1], "slide": [0, 0, 0.05, 1]},
    }
    s["solver"]["dt"] = s["solver"]["dt_max"]
    failed = []

    def counted(self, t, dt, **kwargs):
        r = SOLVE(self, t, dt, **kwargs)
        if not r.converged:
            failed.append(t)
        return r

    monkeypatch.setattr(FrictionSolver, "solve", counted)
    out = root / ("closed" if closes else "open")
    history = run_scene(s, outdir=out, comm=comm).history
    rows = [(r["t"], int(r["newton"]), int(r["cuts"]), r["R_top_x"], r["F_t1"]) for r in history]
    return rows, failed, still_open


def test_an_extrapolated_start_keeps_the_pressed_points_closed(comm, tmp_path_factory, monkeypatch):
    """The demo's ``--n 4`` scene at 2 mm steps (the slide's first 1 mm), 0.8 of the block's
    facets, on base facets 1.3 times larger. The last step's increment, extrapolated, carries the
    base's indentation that travels with the block to the base's nodes inexactly by a fraction of
    a micrometre, against the
    points' penetration of 0.3 um (300 MPa on 1e6 MPa/mm): from that start the first Jacobian
    holds the block on the few points still closed, and it tilts. The interface keeps the
    points pressed at the step's start closed at the extrapolated start
    (``SlidingInterface.start_correction``): after it no such point is open, every step converges
    within 5 Newton iterations without a failed attempt, and the converged states are those of
    the uncorrected start to Newton's tolerance (push and friction force per step to 1e-6 of the
    peak: measured 4e-7). The reference: without the correction a step takes more than 5."""
    from pathlib import Path

    root = Path(comm.bcast(str(tmp_path_factory.mktemp("fstart")) if comm.rank == 0 else None))
    closed, failed, still_open = far_slide(comm, root, monkeypatch, True)
    plain, _, _ = far_slide(comm, root, monkeypatch, False)
    assert [r[0] for r in closed] == [r[0] for r in plain] and len(closed) >= 12, (closed, plain)
    a, b = np.array(closed)[:, 3:], np.array(plain)[:, 3:]
    peak = np.abs(b[:, 1]).max()
    assert np.abs(a - b).max() < 1e-6 * peak, np.abs(a - b).max() / peak  # Newton's tolerance
    assert still_open and max(still_open) == 0, still_open  # corrected starts, all closed
    assert max(r[1] for r in closed) <= 5 and not failed, (closed, failed)
    assert max(r[1] for r in plain) > 5, plain  # the reference: what the correction removes
