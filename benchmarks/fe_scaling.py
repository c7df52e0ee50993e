"""Scaling of the FE solver with the size, per linear strategy, on 1 and 2 ranks (issue 13).

The 3-D pad on a plate (hexahedra, ``meshing.build_pad_on_plate``: plate 2 x 2 x 0.5 mm of steel,
pad 1 x 1 x 0.5 mm of aluminium, ``n`` elements along the pad's side; the Sec. 7 law), bottom
clamped, the pad's top pressed at 300 MPa and moved in x (y held). Programs (steps end on the
breakpoints, ``dt = dt_max`` = the program's spacing): **24 steps** = press in 4, slide to
+0.5 mm past the static peak in 8, back to -0.5 mm in 12; **100 steps** = 10 + 30 + 60; other
counts split 1/6, 1/3, 1/2. dofs = 3 [(2n+1)^2 (n/2+1) + (n+1)^2 (n/2+1)]: n = 8: 5,550;
12: 16,674; 16: 37,206; 20: 70,026; 24: 118,014; 28: 184,050; 30: 224,736; 50: 998,556.

Each run is its own process (``mpirun -n R``), recorded in ``--out``/``<tag>.json``: dofs,
interface points, steps, Newton and Krylov iterations, preconditioner refreshes, cuts, wall time
by section (mesh, problem set-up, bulk and interface assembly, return map, preconditioner
set-up = PETSc's ``PCSetUp``, Krylov = ``KSPSolve``; max over ranks), peak RSS per rank, the load
average before and after, and the history of the interface's tangential force (to compare the
strategies: difference to LU's relative to its peak). A run that exceeds ``--time-limit`` stops
after the step in progress and says how far it got. Existing results are kept (``--force``
redoes them), so a campaign can be resumed. Then ``--table`` writes a Markdown and a CSV table
and a log-log plot of the time against the dofs with fitted exponents::

    ./run exec python3 benchmarks/fe_scaling.py --sizes 8 12 16 20 24 28 30 --ranks 1 2
    ./run exec python3 benchmarks/fe_scaling.py --table      # report/fe_scaling.md, .png, data/

``--kinematics finite_sliding`` runs the same pad with a finite-sliding interface (pairing in
the current configuration, ``docs/model.md`` §12; tag suffix ``_fs``, a separate ``--out`` is
advised; the Sec. 7 set with ``alpha_n = 1e6`` MPa/mm) on the same two boxes meshed apart
(:func:`pad_apart`: the same nodes and dofs, but the primary surface is the plate's whole top,
so the pad slides onto plate facets it did not touch at the start) and adds the contact search
(per step) and projection (points and segments, per Newton iteration) as seconds and as a
share of the stepping's wall time (issue 22 item 7). Its ``reach`` (how far a point may slide
in one step) is ``--reach``, by default 1.5 times the program's largest slide per step (or the
facet size if larger), so that no step is cut for it::

    ./run exec python3 benchmarks/fe_scaling.py --sizes 8 14 20 28 --ranks 2 --strategies gamg \
        --kinematics finite_sliding --out benchmarks/output/fe_scaling_fs

The machine is shared: run the largest sizes last and read the load column. No timing is
asserted anywhere.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import itertools
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "output" / "fe_scaling"
REPORT = ROOT / "report"
STRATEGIES = ("reuse", "lu", "gamg")


def dofs_of(n: int) -> int:
    """Dofs of the pad on a plate with ``n`` hexahedra along the pad's side."""
    nz = layers(n)
    return 3 * ((2 * n + 1) ** 2 * (nz + 1) + (n + 1) ** 2 * (nz + 1))


def layers(n: int) -> int:
    """Hexahedra across the plate's and the pad's thickness (0.5 mm) for ``n`` along the pad."""
    return max(1, round(0.5 * n))


def program_points(steps: int) -> tuple[list[float], list[float], list[float]]:
    """Times and channels (press, slide) of the program with ``steps`` steps."""
    import numpy as np

    if steps == 24:
        npress, nf, nb = 4, 8, 12
    elif steps == 100:
        npress, nf, nb = 10, 30, 60
    else:
        npress = max(1, steps // 6)
        nf = max(1, steps // 3)
        nb = max(1, steps - npress - nf)
    t = list(np.linspace(0.0, 1.0, npress + 1))
    press = list(np.linspace(0.0, 1.0, npress + 1))
    slide = [0.0] * (npress + 1)
    t += list(np.linspace(1.0, 1.5, nf + 1)[1:])
    slide += list(np.linspace(0.0, 0.5, nf + 1)[1:])
    t += list(np.linspace(1.5, 2.5, nb + 1)[1:])
    slide += list(np.linspace(0.5, -0.5, nb + 1)[1:])
    press += [1.0] * (nf + nb)
    return t, press, slide


PLATE_SIZE = (2.0, 2.0, 0.5)
"""The plate's extents (mm), ``meshing.build_pad_on_plate``'s and :func:`pad_apart`'s."""
PAD_SIZE = (1.0, 1.0, 0.5)
"""The pad's extents (mm), centred on the plate."""
KINEMATICS = ("small_sliding", "finite_sliding")
FINITE_ALPHA_N = 1e6
"""The normal penalty (MPa/mm) of the finite-sliding runs (as in ``demos/block_sliding_far``)."""


def tag_of(n: int, strategy: str, ranks: int, steps: int, kinematics: str = "small_sliding") -> str:
    suffix = "_fs" if kinematics == "finite_sliding" else ""
    return f"pad_n{n}_{strategy}_r{ranks}_s{steps}{suffix}"


def default_reach(n: int, steps: int) -> float:
    """The finite-sliding reach of the benchmark: 1.5 times the largest slide per step.

    The pad's top moves by the program's slide (mm) and its facets are ``1 / n`` wide; the reach
    is at least a facet.
    """
    slide = program_points(steps)[2]
    largest = max(abs(b - a) for a, b in itertools.pairwise(slide))
    return max(1.5 * largest, 1.0 / n)


# ------------------------------------------------------------------------------------------------
# One run (inside mpirun)


ELASTIC_RTOL = 1e-11
"""Relative tolerance of the reference linear solve: the Krylov tolerance a strategy uses at a
step's first Newton iteration (1 % of Newton's target ``snes_rtol`` = 1e-9; ``fem/linear.py``),
with which a linear step converges in one Newton iteration."""


def elastic_solve(problem, solver, strategy: str) -> dict:
    """One linear solve of the same mesh with the strategy's preconditioner, built from scratch.

    The limit a Newton iteration is measured against (issue 25): the bulk is linear and the
    interface adds a local change, so a Newton iteration cannot cost much less than solving the
    linear system once. The matrix is the run's last Jacobian (the same size and pattern; the
    bulk's stiffness and the interface's last tangent), the right-hand side ``J x`` for the
    run's last displacement ``x``, the tolerance :data:`ELASTIC_RTOL`; options: the strategy's
    defaults under the run's prefix, so that options given to the run (``PETSC_OPTIONS``,
    e.g. MUMPS's) apply to both. Times: the preconditioner's set-up (a MUMPS factorisation, an
    AMG hierarchy) and the solve, max over ranks (collective).
    """
    from mpi4py import MPI
    from petsc4py import PETSc

    from subfric_dolfinx.compat import pushed_options
    from subfric_dolfinx.fem.linear import rigid_modes, strategy_options

    comm = problem.comm
    A = solver.J.copy()
    nullspace = rigid_modes(problem) if strategy == "gamg" else None
    if nullspace is not None:
        A.setNearNullSpace(nullspace)
    b = A.createVecLeft()
    A.mult(solver.x, b)
    x = b.duplicate()
    x.set(0.0)
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(solver.prefix)
    defaults = {"?" + k: v for k, v in strategy_options(strategy, problem).items()}
    try:
        with pushed_options(solver.prefix, defaults, {"ksp_rtol": ELASTIC_RTOL, "ksp_atol": 0.0}):
            ksp.setOperators(A)
            ksp.setFromOptions()
            comm.Barrier()
            t0 = time.perf_counter()
            ksp.setUp()
            t1 = time.perf_counter()
            ksp.solve(b, x)
            t2 = time.perf_counter()
        its, reason = ksp.getIterationNumber(), int(ksp.getConvergedReason())
        x.axpy(-1.0, solver.x)
        error = x.norm() / max(solver.x.norm(), 1e-300)
    finally:
        for obj in (ksp, A, b, x, nullspace):
            if obj is not None:
                obj.destroy()
    setup = comm.allreduce(t1 - t0, op=MPI.MAX)
    solve = comm.allreduce(t2 - t1, op=MPI.MAX)
    return {
        "setup_s": setup,
        "solve_s": solve,
        "total_s": setup + solve,
        "krylov": its,
        "reason": reason,
        "error": error,
    }


@dataclasses.dataclass
class PadRun:
    """The benchmark's problem, built by :func:`build_pad` (shared with ``weak_scaling.py``).

    Attributes:
        problem: The pad on a plate (:class:`~subfric_dolfinx.fem.InterfaceProblem`).
        solver: Its :class:`~subfric_dolfinx.fem.FrictionSolver` (prefix ``fs_``).
        t_mesh: Wall time of the mesh (s, max over ranks).
        t_problem: Wall time of the problem and solver set-up, pairing included (s, max).
        rss_mesh_mib: This rank's peak RSS once the mesh is built (MiB).
    """

    problem: Any
    solver: Any
    t_mesh: float
    t_problem: float
    rss_mesh_mib: float


def build_pad(
    comm,
    n: int,
    strategy: str,
    steps: int,
    kinematics: str = "small_sliding",
    reach: float | None = None,
    alpha_n: float | None = None,
    domain: Any = None,
    partitioner: Any = None,
) -> PadRun:
    """The pad on a plate with ``n`` hexahedra along the pad's side and its ``steps`` program.

    ``kinematics`` of the interface (``"finite_sliding"``: the bodies meshed apart,
    :func:`pad_apart`, a stiff normal penalty and the search ``reach``, default
    :func:`default_reach`); ``alpha_n`` the normal penalty (default: :data:`FINITE_ALPHA_N` for
    finite sliding, the Sec. 7 set's otherwise); ``domain`` the pad's mesh built already (e.g.
    read in parts and refined on the ranks: the same groups; ``t_mesh`` is then 0 and
    ``rss_mesh_mib`` the peak so far), else gmsh's hexahedra on rank 0, distributed by
    ``partitioner`` (a kind of ``meshing.body_partitioner``; default DOLFINx's). Collective.
    The caller owns ``solver`` (``solver.destroy()`` when done).
    """
    from mpi4py import MPI

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

    finite = kinematics == "finite_sliding"
    t0 = time.perf_counter()
    if domain is not None:
        dom = domain
    elif finite:
        sides = {"primary": "primary", "secondary": "secondary", "kinematics": kinematics}
        dom, _ = meshing.create_interface_mesh(
            pad_apart, comm, interfaces={"interface": sides}, n=n, partitioner=partitioner
        )
    else:
        dom, _ = meshing.create_interface_mesh(
            meshing.build_pad_on_plate,
            comm,
            n_interface=n,
            cell_type="hexahedron",
            plate_size=PLATE_SIZE,
            pad_size=PAD_SIZE,
            partitioner=partitioner,
        )
    t_mesh = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    rss_mesh = peak_rss_mib()
    t, press, slide = program_points(steps)
    prog = LoadingProgram(t, {"press": press, "slide": slide})
    bcs = [
        Dirichlet("bottom", [0.0, 0.0, 0.0]),
        Dirichlet("top", 1.0, component=0, amplitude="slide"),
        Dirichlet("top", 0.0, component=1),
    ]
    mats = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
    if finite and reach is None:
        reach = default_reach(n, steps)
    interfaces = (
        [Interface("interface", "primary", "secondary", kinematics=kinematics, reach=reach)]
        if finite
        else None
    )
    # the Sec. 7 set's normal penalty lets the pad sink 0.6 mm at 300 MPa (more than its
    # facets): finite sliding pairs in the current configuration, so it gets a stiff one
    if alpha_n is None and finite:
        alpha_n = FINITE_ALPHA_N
    law = preset("sec7")
    if alpha_n is not None:
        law = dataclasses.replace(law, alpha_n=alpha_n)
    t1 = time.perf_counter()
    problem = InterfaceProblem(
        dom,
        law,
        mats,
        prog,
        bcs,
        [Pressure("top", 300.0, "press")],
        interfaces=interfaces,
    )
    solver = FrictionSolver(problem, "fs_", linear=strategy)
    t_problem = comm.allreduce(time.perf_counter() - t1, op=MPI.MAX)
    return PadRun(problem, solver, t_mesh, t_problem, rss_mesh)


def pad_apart(n: int, plate_size: tuple[float, float, float] = PLATE_SIZE) -> Any:
    """The gmsh builder (rank 0) of the pad and the plate meshed apart, for finite sliding.

    The boxes of ``meshing.build_pad_on_plate`` (plate 2 x 2 x 0.5 mm, the pad 1 x 1 x 0.5 mm
    centred on it), each meshed on its own (structured hexahedra, ``n`` along the pad's side,
    the element size of the plate the same): groups ``primary`` and ``secondary`` (cells),
    ``interface`` (the plate's whole top and the pad's bottom), ``bottom``, ``top``. Its nodes
    and dofs are those of the joined mesh (:func:`dofs_of`); what differs is the primary
    surface, which reaches past the pad's footprint. ``plate_size``: another plate (a longer one
    for a longer slide; the pad centred on it, its thickness ``plate_size[2]``).
    """
    import types

    import gmsh

    gmsh.model.add("pad_apart")
    occ = gmsh.model.occ
    plate = occ.addBox(0.0, 0.0, 0.0, *plate_size)
    corner = [0.5 * (p - q) for p, q in zip(plate_size[:2], PAD_SIZE[:2], strict=True)]
    pad = occ.addBox(*corner, plate_size[2], *PAD_SIZE)
    occ.synchronize()
    h = PAD_SIZE[0] / n
    nz = layers(n)
    for _, t in gmsh.model.getEntities(1):
        x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(1, t)
        along_z = z1 - z0 > 1e-6
        cells = nz if along_z else max(1, round(max(x1 - x0, y1 - y0) / h))
        gmsh.model.mesh.setTransfiniteCurve(t, cells + 1)
    for _, t in gmsh.model.getEntities(2):
        gmsh.model.mesh.setTransfiniteSurface(t)
        gmsh.model.mesh.setRecombine(2, t)
    for _, t in gmsh.model.getEntities(3):
        gmsh.model.mesh.setTransfiniteVolume(t)
    faces: dict[str, list[int]] = {"interface": [], "bottom": [], "top": []}
    for _, t in gmsh.model.getEntities(2):
        _, _, z0, _, _, z1 = gmsh.model.getBoundingBox(2, t)
        if z1 - z0 > 1e-6:  # (gmsh's boxes are padded by ~1e-7)
            continue
        z = 0.5 * (z0 + z1)
        top = plate_size[2] + PAD_SIZE[2]
        key = "bottom" if z < 1e-6 else "top" if z > top - 1e-6 else "interface"
        faces[key].append(t)
    gmsh.model.addPhysicalGroup(3, [plate], name="primary")
    gmsh.model.addPhysicalGroup(3, [pad], name="secondary")
    for name, ents in faces.items():
        gmsh.model.addPhysicalGroup(2, ents, name=name)
    gmsh.model.mesh.generate(3)
    return types.SimpleNamespace(gdim=3)


def peak_rss_mib() -> float:
    """This process's peak resident memory so far (MiB; Linux's ``ru_maxrss`` is in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_one(
    n: int,
    strategy: str,
    steps: int,
    time_limit: float,
    out: Path,
    predictor: bool = True,
    kinematics: str = "small_sliding",
    reach: float | None = None,
) -> None:
    from mpi4py import MPI
    from petsc4py import PETSc

    from subfric_dolfinx import logs
    from subfric_dolfinx.fem import LoadStepper, StepControl, timing_breakdown
    from subfric_dolfinx.fem.timing import TIMER_PROJECTION, TIMER_SEARCH
    from subfric_dolfinx.io import interface_summary

    comm = MPI.COMM_WORLD
    logs.configure(-1, comm)
    PETSc.Log.begin()
    load0 = os.getloadavg()
    finite = kinematics == "finite_sliding"
    if finite and reach is None:
        reach = default_reach(n, steps)
    pad = build_pad(comm, n, strategy, steps, kinematics, reach)
    problem, solver, t_mesh, t_problem = pad.problem, pad.solver, pad.t_mesh, pad.t_problem
    rss_setup = peak_rss_mib()
    history, stopped = [], [None]
    contact0 = {k: problem.timings.seconds.get(k, 0.0) for k in (TIMER_SEARCH, TIMER_PROJECTION)}
    start = time.perf_counter()

    class TimeLimit(Exception):
        pass

    def on_step(rec):
        s = interface_summary(problem)
        history.append({"t": rec.t, "F_t1": s["F_t1"], "F_n": s["F_n"], "newton": rec.iterations})
        late = time.perf_counter() - start > time_limit
        if comm.allreduce(late, op=MPI.LOR):
            stopped[0] = f"time limit {time_limit:g} s: stopped after step {rec.step} (t {rec.t:g})"
            raise TimeLimit

    stepper = LoadStepper(
        solver, 10.0, control=StepControl(dt_max=10.0), on_step=on_step, predictor=predictor
    )
    failure = None
    try:
        stepper.run()
    except TimeLimit:
        pass
    except Exception as e:  # StepFailure: recorded, not raised
        failure = f"{type(e).__name__}: {e}"
    wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    sections = timing_breakdown(problem, solver.event_start)
    contact = {  # nested in the interface's sections: not in the sum of "other"
        k: comm.allreduce(problem.timings.seconds.get(k, 0.0) - v, op=MPI.MAX)
        for k, v in contact0.items()
    }
    sections = {"mesh": t_mesh, "problem + solver set-up": t_problem, **sections}
    sections.pop("setup", None)  # the pairing, inside "problem + solver set-up"
    sections["other"] = wall - sum(
        v for k, v in sections.items() if k not in ("mesh", "problem + solver set-up")
    )
    events = {}
    for name in ("PCSetUp", "PCApply", "KSPSolve", "MatLUFactorNum", "MatMult"):
        info = PETSc.Log.Event(name).getPerfInfo()
        seconds = comm.allreduce(info["time"], op=MPI.MAX)
        events[name] = {"count": int(info["count"]), "time": seconds}
    rss = comm.gather(peak_rss_mib(), root=0)
    newton = sum(r.iterations for r in stepper.records)
    nnz = int(solver.J.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"])  # the Jacobian's
    elastic = elastic_solve(problem, solver, strategy)  # after the peak RSS of the run
    result = {
        "tag": tag_of(n, strategy, comm.size, steps, kinematics),
        "kinematics": kinematics,
        "reach": reach,
        "search_s": contact[TIMER_SEARCH],
        "projection_s": contact[TIMER_PROJECTION],
        "search_share": (contact[TIMER_SEARCH] + contact[TIMER_PROJECTION]) / wall,
        "n": n,
        "strategy": strategy,
        "ranks": comm.size,
        "steps_program": steps,
        "dofs": problem.global_dofs,
        "interface_points": comm.allreduce(problem.interface.n_elements * problem.interface.nq),
        "steps": len(stepper.records),
        "newton": newton,
        "krylov": int(solver.linear.krylov),  # every Krylov solve of the run
        "cuts": int(sum(r.cuts for r in stepper.records)),
        "line_search_steps": stepper.line_search_steps,
        "linear": solver.linear.stats,
        "wall": wall,
        "wall_per_newton": wall / newton if newton else math.nan,
        "predictor": predictor,
        "newton_per_step": newton / len(stepper.records) if stepper.records else math.nan,
        "elastic": elastic,
        "per_newton_vs_elastic": (wall / newton) / elastic["total_s"] if newton else math.nan,
        "sections": sections,
        "events": events,
        "rss_mib": rss,
        "nnz": nnz,
        "pattern_misses": (
            comm.allreduce(next(iter(problem.interfaces.values())).search.pattern_misses)
            if finite
            else 0
        ),  # tangent entries beyond the finite-sliding pattern (left out, then rebuilt)
        "rss_setup_mib": comm.allreduce(rss_setup, op=MPI.MAX),
        "load": [load0[0], os.getloadavg()[0]],
        "failure": failure,
        "stopped": stopped[0],
        "history": history,
    }
    solver.destroy()
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / f"{result['tag']}.json").write_text(json.dumps(result, indent=1))
        print(
            f"[{result['tag']}] dofs {result['dofs']}: {result['steps']} steps, Newton {newton}, "
            f"Krylov {result['krylov']}, refreshes {result['linear']['refreshes']}, wall "
            f"{wall:.1f} s, RSS {max(rss):.0f} MiB/rank (rank 0 {rss[0]:.0f}), "
            f"nnz {nnz}, pattern misses {result['pattern_misses']}, load {result['load'][0]:.1f}; "
            f"Newton/step {result['newton_per_step']:.2f}; one linear solve "
            f"{elastic['total_s']:.2f} s (set-up {elastic['setup_s']:.2f} s, "
            f"{elastic['krylov']} Krylov), a Newton iteration costs "
            f"{result['per_newton_vs_elastic']:.2f} of it"
            + (
                f"; contact search {contact[TIMER_SEARCH]:.2f} s + projection "
                f"{contact[TIMER_PROJECTION]:.2f} s = {100 * result['search_share']:.1f} % of "
                f"the wall time (reach {reach:.3g} mm)"
                if finite
                else ""
            )
            + (f", FAILED: {failure}" if failure else "")
            + (f", {stopped[0]}" if stopped[0] else ""),
            flush=True,
        )


# ------------------------------------------------------------------------------------------------
# Campaign


def launch(
    n,
    strategy,
    ranks,
    steps,
    time_limit,
    out,
    force=False,
    predictor=True,
    kinematics="small_sliding",
    reach=None,
) -> dict | None:
    path = out / f"{tag_of(n, strategy, ranks, steps, kinematics)}.json"
    if path.exists() and not force:
        print(f"[{path.stem}] kept (--force to redo)", flush=True)
        return json.loads(path.read_text())
    cmd = [
        "mpirun",
        "-n",
        str(ranks),
        sys.executable,
        __file__,
        "--one",
        "--n",
        str(n),
        "--strategy",
        strategy,
        "--steps",
        str(steps),
        "--time-limit",
        str(time_limit),
        "--out",
        str(out),
        "--kinematics",
        kinematics,
    ]
    cmd += [] if predictor else ["--no-predictor"]
    cmd += [] if reach is None else ["--reach", str(reach)]
    from subfric_dolfinx.logs import singleton_environment

    proc = subprocess.run(cmd, cwd=ROOT, env=singleton_environment())
    if proc.returncode != 0 or not path.exists():
        print(f"[{path.stem}] exit code {proc.returncode}, no result", flush=True)
        return None
    return json.loads(path.read_text())


# ------------------------------------------------------------------------------------------------
# Tables and plot


def history_difference(a: dict, b: dict) -> float:
    """Max |F_t1(a) - F_t1(b)| / max |F_t1(b)| over the steps both have at the same times."""
    hb = {round(h["t"], 9): h["F_t1"] for h in b["history"]}
    diffs = [abs(h["F_t1"] - hb[round(h["t"], 9)]) for h in a["history"] if round(h["t"], 9) in hb]
    peak = max((abs(v) for v in hb.values()), default=0.0)
    return max(diffs) / peak if diffs and peak > 0 else math.nan


def fit_exponent(x, y) -> float:
    """Slope of log y against log x (least squares), nan with fewer than 2 points."""
    import numpy as np

    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        return math.nan
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


COLUMNS = [
    "strategy",
    "ranks",
    "steps_program",
    "n",
    "dofs",
    "interface_points",
    "steps",
    "newton",
    "newton_per_step",
    "krylov",
    "krylov_per_newton",
    "refreshes",
    "cuts",
    "wall_s",
    "s_per_newton",
    "elastic_s",
    "elastic_setup_s",
    "per_newton_vs_elastic",
    "mesh_s",
    "setup_s",
    "bulk_s",
    "return_map_s",
    "interface_s",
    "pc_setup_s",
    "krylov_s",
    "other_s",
    "rss_max_mib",
    "diff_vs_lu",
    "speedup_vs_lu",
    "per_newton_vs_lu",
    "load",
    "status",
    "kinematics",
    "search_s",
    "projection_s",
    "search_share",
]


def rows_of(results: list[dict]) -> list[dict]:
    def key(r):
        return r["n"], r["ranks"], r["steps_program"], r.get("kinematics", "small_sliding")

    lu = {key(r): r for r in results if r["strategy"] == "lu"}
    rows = []
    for r in sorted(
        results,
        key=lambda r: (
            r["steps_program"],
            r["strategy"],
            r["ranks"],
            r["n"],
            r.get("kinematics", "small_sliding"),
        ),
    ):
        s = r["sections"]
        ref = lu.get(key(r))
        complete = r["failure"] is None and r["stopped"] is None
        ref_ok = ref is not None and ref["failure"] is None and ref["stopped"] is None
        status = "ok" if complete else (r["stopped"] or r["failure"])[:90]
        rows.append(
            {
                "strategy": r["strategy"],
                "ranks": r["ranks"],
                "steps_program": r["steps_program"],
                "n": r["n"],
                "dofs": r["dofs"],
                "interface_points": r["interface_points"],
                "steps": r["steps"],
                "newton": r["newton"],
                "krylov": r["krylov"],
                "newton_per_step": r["newton"] / r["steps"] if r["steps"] else math.nan,
                "elastic_s": r.get("elastic", {}).get("total_s", math.nan),
                "elastic_setup_s": r.get("elastic", {}).get("setup_s", math.nan),
                "per_newton_vs_elastic": r.get("per_newton_vs_elastic", math.nan),
                "krylov_per_newton": r["krylov"] / r["newton"] if r["newton"] else math.nan,
                "refreshes": r["linear"]["refreshes"],
                "cuts": r["cuts"],
                "wall_s": r["wall"],
                "s_per_newton": r["wall_per_newton"],
                "mesh_s": s["mesh"],
                "setup_s": s["problem + solver set-up"],
                "bulk_s": s["bulk assembly"],
                "return_map_s": s["return map"],
                "interface_s": s["interface assembly"],
                "pc_setup_s": s["factorisation"],
                "krylov_s": s["linear solve"],
                "other_s": s["other"],
                "rss_max_mib": max(r["rss_mib"]),
                "diff_vs_lu": history_difference(r, ref) if ref is not None else math.nan,
                "speedup_vs_lu": ref["wall"] / r["wall"] if (ref_ok and complete) else math.nan,
                "per_newton_vs_lu": (
                    ref["wall_per_newton"] / r["wall_per_newton"] if ref is not None else math.nan
                ),
                "load": r["load"][0],
                "status": status,
                "kinematics": r.get("kinematics", "small_sliding"),
                "search_s": r.get("search_s", math.nan),
                "projection_s": r.get("projection_s", math.nan),
                "search_share": r.get("search_share", math.nan),
            }
        )
    return rows


def _fmt(v) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "—"
        if v != 0 and (abs(v) < 1e-3 or abs(v) >= 1e5):
            return f"{v:.1e}"
        return f"{v:.3g}" if abs(v) < 100 else f"{v:.0f}"
    if isinstance(v, int) and v >= 10000:
        return f"{v:,}"
    return str(v)


def default_against_fastest(sub: list[dict]) -> list[str]:
    """Markdown lines: the default's wall time against the fastest, per rank count and size.

    Complete runs of one program; ``"auto"`` is one of the measured strategies.
    """
    from subfric_dolfinx.fem.linear import auto_choice

    out = []
    for ranks in sorted({r["ranks"] for r in sub}):
        for dofs in sorted({r["dofs"] for r in sub if r["ranks"] == ranks}):
            done = {
                r["strategy"]: r["wall_s"]
                for r in sub
                if r["ranks"] == ranks and r["dofs"] == dofs and r["status"] == "ok"
            }
            pick = auto_choice(3, dofs, ranks)
            if len(done) < 2 or pick not in done:
                continue
            best = min(done, key=done.get)
            ratio = done[pick] / done[best]
            out.append(
                f"| {ranks} | {dofs:,} | {pick} | {_fmt(done[pick])} | {best} | "
                f"{_fmt(done[best])} | {ratio:.2f} | "
                f"{'yes' if ratio <= 1.1 else '**no**'} |"
            )
    if not out:
        return []
    return [
        'The default (`"auto"`, `fem.linear.auto_choice`: in 3-D `"reuse"` from '
        "`AUTO_REUSE_DOFS_PER_RANK` dofs per rank below `AUTO_GAMG_DOFS` dofs in all, else "
        '`"gamg"`) against the fastest complete run of the same size (wall, s):',
        "",
        "| ranks | dofs | default | wall | fastest | wall | default / fastest | within 10 % |",
        "|---|---|---|---|---|---|---|---|",
        *out,
        "",
    ]


def write_tables(out: Path, report: Path) -> None:
    import numpy as np

    results = [json.loads(p.read_text()) for p in sorted(out.glob("pad_*.json"))]
    if not results:
        print(f"no results in {out}")
        return
    rows = rows_of(results)
    (report / "data").mkdir(parents=True, exist_ok=True)
    with open(report / "data" / "fe_scaling.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    head = [
        "strategy",
        "ranks",
        "dofs",
        "interface_points",
        "steps",
        "newton",
        "newton_per_step",
        "krylov_per_newton",
        "refreshes",
        "wall_s",
        "s_per_newton",
        "elastic_s",
        "per_newton_vs_elastic",
        "pc_setup_s",
        "krylov_s",
        "bulk_s",
        "return_map_s",
        "interface_s",
        "search_s",
        "projection_s",
        "search_share",
        "mesh_s",
        "rss_max_mib",
        "diff_vs_lu",
        "speedup_vs_lu",
        "per_newton_vs_lu",
        "load",
        "status",
    ]
    lines = [
        "# FE scaling: the pad on a plate, per linear strategy (issue 13)",
        "",
        "Generated by `benchmarks/fe_scaling.py --table` from `benchmarks/output/fe_scaling/`; "
        "CSV: `report/data/fe_scaling.csv`, figure: `report/fe_scaling.png`. 2-core shared "
        "machine: `load` is the 1-minute load average when the run started (2 = both cores "
        "busy with other work); compare counts first, times within a load window. Times in s "
        "(wall, max over ranks); `pc_setup` = PETSc's PCSetUp (factorisations or AMG set-ups), "
        "`krylov` = KSPSolve; `diff_vs_lu` = max |F_t - F_t(LU)| / peak |F_t(LU)|; "
        "`speedup_vs_lu` = LU's wall time over this one's (complete runs), `per_newton_vs_lu` "
        "the same per Newton iteration (LU runs stopped by the time limit count too); "
        "`elastic_s` = one linear solve of the same mesh with the strategy's preconditioner "
        "built from scratch (set-up + Krylov to rtol 1e-11, the run's last Jacobian; the limit "
        "a Newton iteration is measured against), `per_newton_vs_elastic` = `s_per_newton` / "
        "`elastic_s`; RSS = "
        "peak resident memory of the largest rank (MiB).",
        "",
        "![Wall time and time per Newton iteration against dofs](fe_scaling.png)",
        "",
    ]
    exps = []
    for steps in sorted({r["steps_program"] for r in rows}):
        sub = [r for r in rows if r["steps_program"] == steps]
        lines += [f"## {steps}-step program", ""]
        lines.append("| " + " | ".join(head) + " |")
        lines.append("|" + "---|" * len(head))
        for r in sub:
            lines.append("| " + " | ".join(_fmt(r[k]) for k in head) + " |")
        lines.append("")
        pairs = []
        for strategy in STRATEGIES:
            one = {r["dofs"]: r for r in sub if r["strategy"] == strategy and r["ranks"] == 1}
            for r in sub:
                if r["strategy"] == strategy and r["ranks"] == 2 and r["dofs"] in one:
                    o = one[r["dofs"]]
                    pairs.append(
                        f"| {strategy} | {r['dofs']:,} | {_fmt(o['s_per_newton'])} | "
                        f"{_fmt(r['s_per_newton'])} | "
                        f"{_fmt(o['s_per_newton'] / r['s_per_newton'])} |"
                    )
        if pairs:
            lines += [
                "2 ranks against 1 (time per Newton iteration, s):",
                "",
                "| strategy | dofs | 1 rank | 2 ranks | speed-up |",
                "|---|---|---|---|---|",
                *pairs,
                "",
            ]
        lines += default_against_fastest(sub)
        for strategy in STRATEGIES:
            for ranks in (1, 2):
                pts = [
                    r
                    for r in sub
                    if r["strategy"] == strategy and r["ranks"] == ranks and r["status"] == "ok"
                ]
                if len(pts) < 2:
                    continue
                d = [p["dofs"] for p in pts]
                big = [p for p in pts if 20000 <= p["dofs"] <= 250000]
                exps.append(
                    {
                        "steps": steps,
                        "strategy": strategy,
                        "ranks": ranks,
                        "time": fit_exponent(d, [p["wall_s"] for p in pts]),
                        "per_newton_20k_200k": fit_exponent(
                            [p["dofs"] for p in big], [p["s_per_newton"] for p in big]
                        ),
                        "rss": fit_exponent(d, [p["rss_max_mib"] for p in pts]),
                        "range": f"{min(d):,}–{max(d):,}",
                    }
                )
    if exps:
        lines += [
            "## Fitted exponents (time ∝ dofs^p, least squares in log-log, completed runs)",
            "",
            "| program | strategy | ranks | dofs | p (wall) | p (s per Newton, 20k–250k) | "
            "p (peak RSS) |",
            "|---|---|---|---|---|---|---|",
        ]
        for e in exps:
            lines.append(
                f"| {e['steps']} steps | {e['strategy']} | {e['ranks']} | {e['range']} | "
                f"{_fmt(e['time'])} | {_fmt(e['per_newton_20k_200k'])} | {_fmt(e['rss'])} |"
            )
        lines.append("")
    (report / "fe_scaling.md").write_text("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    markers = {"reuse": "o", "lu": "s", "gamg": "^"}
    for steps in sorted({r["steps_program"] for r in rows}):
        if steps != 24 and len({r["steps_program"] for r in rows}) > 1:
            continue
        for strategy in STRATEGIES:
            for ranks, style in ((1, "-"), (2, "--")):
                pts = [
                    r
                    for r in rows
                    if r["strategy"] == strategy
                    and r["ranks"] == ranks
                    and r["steps_program"] == steps
                    and r["status"] == "ok"
                ]
                if not pts:
                    continue
                d = np.array([p["dofs"] for p in pts])
                p_exp = fit_exponent(d, [p["wall_s"] for p in pts])
                label = f"{strategy}, {ranks} rank{'s' if ranks > 1 else ''} (p = {p_exp:.2f})"
                axes[0].loglog(
                    d, [p["wall_s"] for p in pts], style, marker=markers[strategy], label=label
                )
                axes[1].loglog(
                    d,
                    [p["s_per_newton"] for p in pts],
                    style,
                    marker=markers[strategy],
                    label=f"{strategy}, {ranks}",
                )
    axes[0].set_xlabel("dofs")
    axes[0].set_ylabel("wall time of the program (s)")
    axes[0].set_title("Pad on a plate, 24-step program")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("dofs")
    axes[1].set_ylabel("wall time per Newton iteration (s)")
    axes[1].set_title("Cost per Newton iteration")
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(report / "fe_scaling.png", dpi=120)
    print(
        f"wrote {report / 'fe_scaling.md'}, {report / 'fe_scaling.png'}, "
        f"{report / 'data' / 'fe_scaling.csv'}"
    )


# ------------------------------------------------------------------------------------------------


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 12, 16, 20, 24, 28, 30])
    ap.add_argument("--strategies", nargs="+", choices=STRATEGIES, default=list(STRATEGIES))
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--steps", type=int, default=24, help="program: 24 or 100 steps (or any)")
    ap.add_argument("--time-limit", type=float, default=1800.0, help="seconds per run")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--force", action="store_true", help="redo runs whose result exists")
    ap.add_argument("--table", action="store_true", help="only write the tables and the plot")
    ap.add_argument("--report", type=Path, default=REPORT)
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--strategy", help=argparse.SUPPRESS)
    ap.add_argument(
        "--kinematics",
        choices=KINEMATICS,
        default="small_sliding",
        help="the interface's kinematics (finite_sliding: tag suffix _fs)",
    )
    ap.add_argument(
        "--reach",
        type=float,
        default=None,
        help="finite sliding: the reach (mm); default 1.5 x the largest slide a step",
    )
    ap.add_argument(
        "--no-predictor",
        dest="predictor",
        action="store_false",
        help="LoadStepper(predictor=False): every step's Newton starts from the converged "
        "state, as before the predictor (a separate --out is advised)",
    )
    args = ap.parse_args(argv)
    if args.one:
        run_one(
            args.n,
            args.strategy,
            args.steps,
            args.time_limit,
            args.out,
            args.predictor,
            args.kinematics,
            args.reach,
        )
        return
    if not args.table:
        for n in sorted(args.sizes):  # the largest last
            for ranks in args.ranks:
                for strategy in args.strategies:
                    launch(
                        n,
                        strategy,
                        ranks,
                        args.steps,
                        args.time_limit,
                        args.out,
                        args.force,
                        args.predictor,
                        args.kinematics,
                        args.reach,
                    )
    write_tables(args.out, args.report)


if __name__ == "__main__":
    main()
