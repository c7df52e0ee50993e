"""The contract both kinds of interface keep (:class:`~subfric_dolfinx.fem.interface.BaseInterface`
and what the problem, the outputs and the checkpoints read of it): every test here runs over both
kinds, small sliding (node-to-node pairs fixed at the reference geometry) and finite sliding
(pairing in the current configuration), as dolfinx_mpc runs every test over each of its
assemblers (a parametrised fixture). Each kind's own tests stay beside this file.

The bodies: a block on a base of the same width (2-D, 4 interface facets, ``nu = 0``), the base
held whole (a rigid primary surface: the block's solution is uniform whatever the kind), pressed
by a pressure ``P`` and slid by its top with Coulomb's law.

* **Patch test**: with the block's flanks carrying the exact vertical displacement, every point
  has the closed form's traction and gap at every step: ``f_n = P``; sticking while the top's
  slide ``s`` is below ``mu P (1 / alpha_t + H / G)``, ``f_t = s / (1 / alpha_t + H / G)``, then
  ``f_t = mu P``; the slip ``s - f_t H / G`` (the block's shear in series), its plastic part
  beyond ``f_t / alpha_t``; the same signs for both kinds (the traction on the primary, ``f_t1``,
  and the gap ``u_secondary - u_primary`` along the block's slide; ``gap_n > 0`` closing).
* **Commit and revert**: a step solved and reverted leaves the interface's committed and trial
  state and the solver's iterate bit-identical to before it, and the run continued from there
  gives the straight run's forces and tractions (bit-identical on one rank, to Newton's
  tolerance on two).
* **Checkpoint and restart**: a scene restarted from its checkpoint half way gives the rows of
  the uninterrupted run, bit-identical: the checkpoint holds the stepper's memory (step size,
  growth counter, the predictor's last increment, a hold's cut step, the retry's memory), so
  the restarted steps start from the uninterrupted run's first guesses.
* **Outputs**: the history's interface columns, the interface history's datasets and the
  profiles' fields have the same names for both kinds, and the same meanings: the normal
  resultant is the pressure's, the tangential one Coulomb's and the reaction of the top, the
  interface history's last row is the last profile.
* **1 = 2 ranks**: the displacement and every point's state and traction of a non-uniform run
  (a narrower block pressed and slid to and fro: the kinds differ, each against itself) on 2
  ranks equal those of the serial run gathered, to Newton's tolerance.
* **Dirichlet rows** (as building blocks of the user's own problem, ``demos/user_loop.py``):
  DOLFINx's convention for Newton with lifting: with ``bcs`` the residual holds the interface
  forces on the free rows plus ``K (g - x)`` of the tangent's coupling to the constrained dofs,
  and nothing on the constrained rows; the tangent has no row or column of a constrained dof.
  The reference is the same interface's residual and tangent without ``bcs`` (the whole tangent
  assembled, multiplied by ``g - x`` built from the conditions' values). The block is pushed at
  its left flank, whose condition holds an interface node (the lifting reaches the interface's
  rows). On 2 ranks a rank may hold none of the finite-sliding points. ``destroy`` frees the
  interface's vectors, twice safely.
* **Bad input**: an initial gap that is not finite, an unknown quadrature and a region that is
  no group of the interface are refused with the same message for both kinds, naming the value,
  on every rank.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from demos import user_loop
from subfric_dolfinx import meshing
from subfric_dolfinx.compat import geometry_dofmap, petsc_vector
from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceError,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    StepControl,
    create_matrix,
)
from subfric_dolfinx.fem.interface import FrictionInterface, SlidingInterface, SlidingOptions
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import OverhangWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import (
    PROGRAM,
    everywhere,
    leaves_validity,
    on_root,
    prefix,
    raised_on_every_rank,
)

KINDS = ("small_sliding", "finite_sliding")

E, P, H, W = 2.0e4, 300.0, 0.5, 1.0  # MPa, MPa, mm (each body's height), mm (both widths)
G = E / 2  # nu = 0
MU, ALPHA_T, ALPHA_N = 0.3, 1.0e4, 1.0e6  # Coulomb's friction coefficient, penalties (MPa/mm)
S = 0.04  # mm, the top's slide: gross sliding from 0.0135 mm, within the facets' ends
PATCH_PROGRAM = LoadingProgram([0, 1, 2], {"press": [0, 1, 1], "slide": [0, 0, 1]})
COULOMB = CoulombLaw(alpha_t=ALPHA_T, alpha_n=ALPHA_N, mu_c=MU)


@pytest.fixture(params=KINDS)
def kind(request) -> str:
    """The interface's kind: every test of the contract runs over both."""
    return request.param


def patch_problem(comm: MPI.Comm, kind: str, flanks: bool = True) -> InterfaceProblem:
    """The block on its held base, pressed and slid (the module docstring); ``flanks``: the
    block's flanks carry the exact vertical displacement (the patch test's uniform solution)."""
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base,
        comm,
        base_width=W,
        block_width=W,
        base_height=H,
        block_height=H,
        n_interface=4,
        cell_type="triangle",
    )
    un, ey = P / ALPHA_N, -P / E  # the interface's closure and the block's vertical strain
    bcs = [Dirichlet("primary", (0.0, 0.0)), Dirichlet("top", S, component=0, amplitude="slide")]
    if flanks:
        bcs += [
            Dirichlet(g, lambda x: -un + ey * (x[1] - H), component=1, amplitude="press")
            for g in ("secondary_left", "secondary_right")
        ]
    return InterfaceProblem(
        dom,
        COULOMB,
        {"primary": Material(E, 0.0), "secondary": Material(E, 0.0)},
        PATCH_PROGRAM,
        bcs,
        [Pressure("top", P, amplitude="press")],
        interfaces=[Interface("interface", kinematics=kind)],
    )


def closed_form(t: float) -> tuple[float, float, float]:
    """The patch's tangential traction, tangential gap and plastic slip (magnitudes) at ``t``."""
    s = S * PATCH_PROGRAM.amplitude("slide", t)
    f_t = min(s / (1.0 / ALPHA_T + H / G), MU * P * PATCH_PROGRAM.amplitude("press", t))
    ubar = s - f_t * H / G
    return f_t, ubar, ubar - f_t / ALPHA_T


def test_patch_test_gives_the_closed_form_at_every_point(kind):
    comm = MPI.COMM_WORLD
    prob = patch_problem(comm, kind)
    lp = prob.interfaces["interface"].law_points
    rows = []

    def on_step(rec):
        tr, gap, up = lp.last.traction, lp.last_gap, lp.saved_state()["up"]
        f_t, ubar, slip = closed_form(rec.t)
        p = P * PATCH_PROGRAM.amplitude("press", rec.t)
        n = comm.allreduce(tr.shape[0])
        errors = [  # each against its scale: P (tractions), S (gaps and slips)
            np.abs(tr[:, 1] - p).max(initial=0.0) / P,
            np.abs(tr[:, 0] - f_t).max(initial=0.0) / P,
            np.abs(gap[:, 0] - ubar).max(initial=0.0) / S,
            np.abs(gap[:, 1] - p / ALPHA_N).max(initial=0.0) / S,  # > 0 on approach
            np.abs(up[:, 0] - slip).max(initial=0.0) / S,
        ]
        rows.append((rec.t, n, comm.allreduce(max(errors), op=MPI.MAX)))

    with FrictionSolver(prob, prefix("contract_patch"), {"snes_rtol": 1e-12}) as sv:
        LoadStepper(sv, 0.25, control=StepControl(dt_max=0.25), on_step=on_step).run()
    assert [t for t, _, _ in rows] == [0.25 * k for k in range(1, 9)]
    assert all(n == 8 for _, n, _ in rows)  # every point of the 4 facets, 2 each
    worst = max(e for _, _, e in rows)
    assert worst < 1e-9, rows
    # the program goes through sticking (t = 1.25: s = 0.01 mm) into gross sliding
    assert closed_form(1.25)[0] < MU * P == closed_form(2.0)[0]
    prob.destroy()


def snapshot(prob, solver) -> dict[str, np.ndarray]:
    """Everything a step may change and a revert must put back: each interface's committed and
    trial state, its committed kinematics (finite sliding), the solver's iterate."""
    out = {"x": solver.x.array_r.copy()}
    for name, iface in prob.interfaces.items():
        lp = iface.law_points
        for k, v in lp.saved_state().items():
            out[f"{name}.saved.{k}"] = np.array(v, copy=True)
        for k in lp.state.new.names:
            out[f"{name}.trial.{k}"] = np.array(lp.state.new[k], copy=True)
    return out


def test_a_reverted_step_leaves_the_state_bit_identical(kind):
    comm = MPI.COMM_WORLD
    runs = {}
    for reverted in (False, True):
        prob = patch_problem(comm, kind, flanks=False)
        iface = prob.interfaces["interface"]
        hist = []

        def on_step(rec, iface=iface, hist=hist):
            hist.append((rec.t, iface.force.copy(), iface.law_points.last.traction.copy()))

        with FrictionSolver(prob, prefix("contract_revert"), linear="lu") as solver:
            stepper = LoadStepper(solver, 0.25, control=StepControl(dt_max=0.25), on_step=on_step)
            stepper.run(t_end=1.5)
            if reverted:
                before = snapshot(prob, solver)
                x0 = solver.x.copy()
                result = solver.solve(1.75, 0.25)
                moved = snapshot(prob, solver)
                prob.revert()
                x0.copy(solver.x)
                x0.destroy()
                after = snapshot(prob, solver)
                changed = [k for k in before if not np.array_equal(before[k], moved[k])]
                differ = [k for k in before if not np.array_equal(before[k], after[k])]
                # the solve did change the trial state (else the check below proves nothing)
                assert everywhere(comm, result.converged)
                trial = comm.allreduce(int(any(".trial." in k for k in changed)), op=MPI.MAX)
                assert trial == 1, changed
                assert everywhere(comm, not differ), differ
            stepper.run()
        runs[reverted] = hist
        prob.destroy()
    straight, again = runs[False], runs[True]
    assert [h[0] for h in straight] == [h[0] for h in again] == [0.25 * k for k in range(1, 9)]
    worst = max(
        float(np.abs(a[i] - b[i]).max(initial=0.0))
        for a, b in zip(straight, again, strict=True)
        for i in (1, 2)
    )
    worst = comm.allreduce(worst, op=MPI.MAX)
    # bit-identical on one rank; on more MUMPS's factors may differ in the last bits run to run
    assert worst == 0.0 if comm.size == 1 else worst < 1e-9 * P, worst


def contract_scene(kind: str) -> dict:
    """The patch's bodies as a scene (the block's flanks free): pressed, slid, its outputs."""
    return {
        "kind": "fe",
        "name": f"contract_{kind}",
        "mesh": {
            "builder": "block_on_base",
            "options": {
                "base_width": W,
                "block_width": W,
                "base_height": H,
                "block_height": H,
                "n_interface": 4,
                "cell_type": "triangle",
            },
        },
        "law": {"law": "coulomb", "params": {"alpha_t": ALPHA_T, "alpha_n": ALPHA_N, "mu_c": MU}},
        "materials": {"primary": {"E": E, "nu": 0.0}, "secondary": {"E": E, "nu": 0.0}},
        "interfaces": {"interface": {"kinematics": kind}},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
        "dirichlet": [
            {"group": "primary", "value": [0.0, 0.0]},
            {"group": "top", "component": 0, "value": S, "amplitude": "slide"},
        ],
        "loads": [{"type": "pressure", "group": "top", "value": P, "amplitude": "press"}],
        "solver": {"prefix": prefix("contract_scene"), "dt": 0.25, "dt_max": 0.25},
        "outputs": {
            "history": True,
            "interface_history": True,
            "checkpoint_times": [1.5],
            "snapshots": [2.0],
        },
    }


_RUNS: dict[str, tuple] = {}


def scene_runs(kind: str, tmp_path_factory) -> tuple:
    """The uninterrupted run (checkpoint at t = 1.5) and the run restarted from it (cached)."""
    if kind not in _RUNS:
        comm = MPI.COMM_WORLD
        root = comm.bcast(str(tmp_path_factory.mktemp(kind)) if comm.rank == 0 else None)
        root = Path(root)
        s = contract_scene(kind)
        full = run_scene(s, outdir=root / "full", comm=comm)
        restarted = run_scene(
            s, outdir=root / "restart", comm=comm, restart=root / "full/checkpoint.h5"
        )
        _RUNS[kind] = (full, restarted, root)
    return _RUNS[kind]


def test_a_restarted_run_gives_the_rows_of_the_uninterrupted_one(kind, tmp_path_factory):
    comm = MPI.COMM_WORLD
    full, restarted, _ = scene_runs(kind, tmp_path_factory)
    rows = {r["step"]: r for r in full.history}
    after = [r for r in restarted.history if r["t"] > 1.5 + 1e-9]
    assert [r["step"] for r in restarted.history] == sorted(rows)
    assert len(after) == 2 and set(after[0]) == set(rows[after[0]["step"]])
    # bit-identical on 1 rank, Newton's iterations included; on more, MUMPS's factors vary in
    # their last bits from run to run (docs/reference/solver.md): the same to round-off, each
    # column at the scale of its largest value over the run, Newton's iterations still equal
    tol = 0.0 if comm.size == 1 else 1e-12
    scale = {k: max(abs(float(r[k])) for r in full.history) for k in after[0]}
    differ = [
        (r["step"], k, r[k], rows[r["step"]][k])
        for r in after
        for k in r
        if abs(float(r[k]) - float(rows[r["step"]][k])) > tol * scale[k]
    ]
    assert everywhere(comm, not differ), differ


def interface_outputs(root: Path) -> dict:
    """The interface history's datasets (names, last row of f_n and the time)."""
    import h5py

    with h5py.File(root / "full/interface_history.h5") as f:
        return {
            "names": sorted(f),
            "time": float(f["time"][-1]),
            "f_n": np.array(f["f_n"][-1]),
            "f_t": np.array(f["f_t"][-1]),
        }


def test_outputs_have_the_same_names_and_meanings(kind, tmp_path_factory):
    comm = MPI.COMM_WORLD
    full, _, root = scene_runs(kind, tmp_path_factory)
    small, _, small_root = scene_runs("small_sliding", tmp_path_factory)
    last = full.history[-1]
    snap = full.snapshots[2.0]
    files = on_root(comm, lambda: interface_outputs(root))
    small_files = on_root(comm, lambda: interface_outputs(small_root))
    F_n, F_t = last["F_n"], last["F_t1"]
    checks = {
        "history columns": set(last) == set(small.history[-1]),
        "profile fields": set(snap) == set(small.snapshots[2.0]),
        "interface history datasets": files["names"] == small_files["names"],
        # the meanings: the normal resultant is the pressure's, the friction Coulomb's (gross
        # sliding, the block slid along +x), carried by the held base and the top alike
        "F_n": abs(F_n - P * W) < 1e-9 * P * W,
        "F_t1": abs(F_t - MU * P * W) < 1e-9 * P * W,
        "R_primary_x": abs(last["R_primary_x"] + F_t) < 1e-9 * P * W,
        "R_top_x": abs(last["R_top_x"] - F_t) < 1e-9 * P * W,
        "sliding": last["plastic"] == 1.0 and last["separated"] == 0.0,
        # the interface history's last row is the last profile (each written by its own path)
        "interface history": files["time"] == 2.0
        and np.array_equal(np.sort(files["f_n"].ravel()), np.sort(snap["f_n"].ravel())),
    }
    assert everywhere(comm, all(checks.values())), checks


def gather_state(prob) -> tuple[np.ndarray, ...]:
    """Displacement by original gmsh node; every point's state and traction by its position."""
    comm = prob.comm
    mesh, V = prob.mesh, prob.V
    ncells = mesh.topology.index_map(mesh.topology.dim).size_local
    gnodes = mesh.geometry.input_global_indices[geometry_dofmap(mesh)[:ncells]]
    dofs = V.dofmap.list[:ncells]
    u = prob.u.x.array.reshape(-1, V.dofmap.bs)
    ids = np.concatenate(comm.allgather(gnodes.ravel()))
    vals = np.concatenate(comm.allgather(u[dofs.ravel()]))
    order = np.unique(ids, return_index=True)[1]
    lp = prob.interfaces["interface"].law_points
    n = lp.last.traction.shape[0]  # none on a rank without the interface's points

    def rows(a):
        a = np.asarray(a)
        return a.reshape(n, math.prod(a.shape[1:]))

    state = lp.saved_state()
    iv = np.column_stack([rows(state[k]) for k in sorted(state)] + [lp.last.traction])
    pts = np.concatenate(comm.allgather(np.reshape(lp.points, (n, prob.gdim))))
    iv = np.concatenate(comm.allgather(iv))
    key = np.lexsort(np.round(pts, 9).T[::-1])
    return ids[order], vals[order], pts[key], iv[key]


def block_run(comm, kind, solver_prefix):
    """A narrower block pressed and slid to and fro (tests.helpers.block_problem's, with
    Coulomb's law: the paper's soft normal penalty presses the block deeper than a
    finite-sliding interface's search radius)."""
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base,
        comm,
        partitioner="bodies" if comm.size > 1 else None,
        n_interface=8,
        cell_type="triangle",
    )
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.1, component=0, amplitude="slide")]
    with InterfaceProblem(
        dom,
        COULOMB,
        {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)},
        PROGRAM,
        bcs,
        [Pressure("top", P, amplitude="press")],
        interfaces=[Interface("interface", kinematics=kind)],
    ) as prob:
        with FrictionSolver(prob, solver_prefix, {"snes_rtol": 1e-12}) as solver:
            LoadStepper(solver, 0.25).run(t_end=3.5)
        return gather_state(prob)


@pytest.mark.skipif(MPI.COMM_WORLD.size == 1, reason="1 rank: the serial run is the run")
def test_a_parallel_run_equals_the_gathered_serial_run(kind):
    comm = MPI.COMM_WORLD

    def compare_with_a_serial_run():
        ser = block_run(MPI.COMM_SELF, kind, alone)
        failed = []
        for a, b, name in zip(
            par, ser, ("node ids", "displacement", "points", "state"), strict=True
        ):
            if a.shape != b.shape:
                failed.append(f"{name}: shape {a.shape} vs {b.shape}")
                continue
            scale = max(1.0, float(np.abs(b).max()))
            diff = float(np.abs(a - b).max())
            if diff > 1e-9 * scale:
                failed.append(f"{name}: max diff {diff:.3g}")
            print(f"{kind}, 1 vs {comm.size} ranks, {name}: max |diff| = {diff:.3g}")
        return failed

    # the serial run's warnings (rank 0's) are gathered with the parallel run's: a finite-sliding
    # block slides past the end of its primary surface (the footprint, on this joined mesh)
    overhang = (OverhangWarning,) if kind == "finite_sliding" else ()
    with leaves_validity(*overhang) if overhang else contextlib.nullcontext():
        par = block_run(comm, kind, prefix("contract_par"))
        alone = prefix("contract_par")  # on every rank: the ranks' prefix counts stay equal
        failed = on_root(comm, compare_with_a_serial_run)
    assert not failed, failed


SLIDE = 1e-3  # mm, the user loop's pushed flank's x-displacement


def interface_of(kind, V, domain):
    law = user_loop.law()
    if kind == "small_sliding":
        return FrictionInterface.from_mesh(V, domain, law)
    name = next(iter(domain.interfaces))
    side = domain.interfaces[name]
    return SlidingInterface(
        V,
        domain.cell_tags,
        domain.facet_tags,
        law,
        tag=domain.tags[name],
        primary=domain.body_tags(side.primary),
        secondary=domain.body_tags(side.secondary),
        options=SlidingOptions(name=name),
    )


def pressed_block(V, domain):
    """Owned displacement: the block pressed into the base by 2e-3 mm and moved sideways."""
    X = V.tabulate_dof_coordinates()
    bs = V.dofmap.bs
    tdim = V.mesh.topology.dim
    V.mesh.topology.create_connectivity(tdim, tdim)
    block = np.zeros(X.shape[0], dtype=bool)
    cells = domain.cell_tags.find(domain.tag("secondary"))
    block[dolfinx.fem.locate_dofs_topological(V, tdim, cells)] = True
    u = np.zeros((X.shape[0], bs))
    u[block, 1] = -2e-3 * (1.0 + 0.1 * np.sin(X[block, 0]))
    u[block, 0] = 1e-3 * np.cos(X[block, 0])
    return u.reshape(-1)[: V.dofmap.index_map.size_local * bs].copy()


def test_dirichlet_rows_follow_dolfinx_lifting_convention(kind):
    comm = MPI.COMM_WORLD
    domain, V, _u, _F, _J, bcs, _p, slide = user_loop.model(comm, 4, push="secondary_left")
    slide.x.array[:] = SLIDE
    iface = interface_of(kind, V, domain)
    iface.set_step(0.1)
    imap, bs = V.dofmap.index_map, V.dofmap.bs
    n_owned = imap.size_local * bs
    x = petsc_vector(imap, bs)
    x.array_w[:] = pressed_block(V, domain)

    b_bc, b_free = petsc_vector(imap, bs), petsc_vector(imap, bs)
    iface.assemble_residual(b_bc, x, bcs=bcs)
    iface.assemble_residual(b_free, x)
    A_bc, A = create_matrix(V, [iface]), create_matrix(V, [iface])
    iface.assemble_jacobian(A_bc, x, bcs=bcs)
    iface.assemble_jacobian(A, x)
    A_bc.assemble()
    A.assemble()

    # g - x at the constrained dofs from the conditions' own values: 0 at the bottom (both
    # components), SLIDE for the x-component on the pushed flank
    bottom, flank = (np.asarray(bc.dof_indices()[0][: bc.dof_indices()[1]]) for bc in bcs)
    bottom, flank = bottom[bottom < n_owned], flank[flank < n_owned]
    d = petsc_vector(imap, bs)
    d.array_w[bottom] = -x.array_r[bottom]
    d.array_w[flank] = SLIDE - x.array_r[flank]
    lift = A.createVecLeft()
    A.mult(d, lift)
    constrained = np.union1d(bottom, flank)
    free = np.setdiff1d(np.arange(n_owned), constrained)

    expected = b_free.array_r[free] + lift.array_r[free]
    scale = comm.allreduce(np.abs(b_free.array_r).max(initial=0.0), op=MPI.MAX)
    assert scale > 0.0  # the block is pressed: the interface carries load
    err = np.abs(b_bc.array_r[free] - expected).max(initial=0.0)
    assert everywhere(comm, err <= 1e-12 * scale)
    assert everywhere(comm, not np.any(b_bc.array_r[constrained]))
    # an interface node is constrained: the lifting reaches the interface's rows
    reached = comm.allreduce(np.abs(lift.array_r[free]).max(initial=0.0), op=MPI.MAX)
    assert reached > 1e-6 * scale

    rows = (constrained + imap.local_range[0] * bs).astype(PETSc.IntType)
    A.zeroRowsColumns(rows, diag=0.0)
    A_bc.axpy(-1.0, A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    assert A_bc.norm() == 0.0
    for obj in (x, b_bc, b_free, A_bc, A, d, lift):
        obj.destroy()
    iface.destroy()
    iface.destroy()  # idempotent
    assert iface.x_ext is None and iface.b_ext is None


def bad_problem(kind: str, **interface) -> InterfaceProblem:
    """The patch's problem with the interface's settings ``interface`` (to be refused)."""
    comm = MPI.COMM_WORLD
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base,
        comm,
        base_width=W,
        block_width=W,
        n_interface=4,
        cell_type="triangle",
    )
    return InterfaceProblem(
        dom,
        COULOMB,
        {"primary": Material(E, 0.0), "secondary": Material(E, 0.0)},
        PATCH_PROGRAM,
        [Dirichlet("primary", (0.0, 0.0))],
        interfaces=[Interface("interface", kinematics=kind, **interface)],
    )


@pytest.mark.parametrize(
    ("settings", "error", "message"),
    [
        (
            {"initial_gap": lambda x: np.full(x.shape[1], np.inf)},
            InterfaceError,
            r"the initial gap is not finite at \(-?[0-9.e+-]+, -?[0-9.e+-]+\): inf",
        ),
        (
            {"quadrature": "lobatto"},
            ValueError,
            r"quadrature kind must be 'gauss' or 'nodal', got 'lobatto'",
        ),
        (
            {"regions": {"rough": COULOMB}},
            InterfaceError,
            r"interface 'interface': region\(s\) \['rough'\] are not groups of interface "
            r"facets of the mesh; its interface subgroups are \[\]",
        ),
    ],
    ids=["initial_gap", "quadrature", "region"],
)
def test_bad_settings_are_refused_alike_on_every_rank(kind, settings, error, message):
    """One pattern of the whole message for both kinds: the same error, naming the value."""
    with raised_on_every_rank(error, match=f"^{message}$"):
        bad_problem(kind, **settings)
