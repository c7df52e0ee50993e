"""Weak scaling on paper (issue 25 item 4): what 64 and 512 ranks would need for 1e7 and 1e8 dofs.

The 3-D pad on a plate of ``benchmarks/fe_scaling.py`` (its problem, :func:`fe_scaling.build_pad`,
strategy ``"gamg"``, with the penalties and the slide of ``cluster/pad.json``: ``valid=True``, a
model within the package's validity, no warning) at about 25k dofs per rank on 1, 2, 4 and 8 ranks
(4 and 8 oversubscribed on this 2-core machine: the times mean nothing, only what does not depend on
the machine being oversubscribed is recorded), plus 1 rank at about 10k dofs (to separate the fixed
and the per-dof memory) and 2 ranks at 184k (to separate the whole model's size from the rank
count), over a short program (``--steps``, default 6: press, slide, back). Two paths to the
model (``--path``):

* ``gmsh`` (:data:`SERIES`): hexahedra meshed whole by gmsh on rank 0, which hands out the parts;
* ``refined`` (:data:`REFINED_SERIES`): tetrahedra meshed coarse once per size by one process of
  its own and written partitioned (:func:`convert_one`), then read in parts and refined ``k``
  times on the ranks (``meshing.read_partitioned_mesh``, ``meshing.refine_interface_mesh``): no
  rank holds the whole model.

Per run and rank:

* memory: peak RSS after the mesh, after the set-up and at the end; the Jacobian's PETSc storage
  (``Mat.getInfo``); the GAMG hierarchy (every level's operator and interpolation); the
  checkpoint's bytes (one ``write_checkpoint`` at the end);
* communication: PETSc's logged messages, bytes and reductions of ``KSPSolve``, ``PCSetUp``,
  ``PCApply``, ``MatMult`` and ``SNESSolve`` over the steps (a log stage of their own); and every
  MPI collective of the process (``benchmarks/mpi_counts.c``, a PMPI library preloaded into the
  ranks: calls and bytes of ``Allreduce``, ``Allgather(v)``, ``Gather(v)``, ``Bcast``,
  ``Alltoall(v)``, neighbour exchanges; from mpi4py, DOLFINx and PETSc alike) for four phases:
  set-up (mesh, pairing, problem; on the refined path also split into the read, the refinement
  and the problem), the steps, one interface profile
  (``scenes.outputs.interface_profile``, what a scene's ``profile`` output gathers each output step)
  and one checkpoint;
* the pairing's exchange (secondary facets received, extra ghosts), GAMG's levels and coarse grid,
  Newton and Krylov iterations.

Then per-part models are fitted per path (:func:`fit_models`) and extrapolated
(:func:`extrapolate`) to 64 and 512 ranks at 1e7 and 1e8 dofs, and the first part to stop scaling
is named from the numbers (:func:`first_to_break` over those targets, :func:`weak_limit` along the
weak direction at 1e8 dofs on 512 ranks' dofs per rank)::

    B=benchmarks/weak_scaling.py
    ./run exec python3 $B                    # the gmsh path's runs, then report/weak_scaling.md
    ./run exec python3 $B --path refined     # the refined path's runs, then the report
    ./run exec python3 $B --table            # only the report, from every result of both paths

Results: ``benchmarks/output/weak_scaling/<tag>.json``; report: ``report/weak_scaling.md`` and
``report/data/weak_scaling.csv``. No timing is used.
"""

from __future__ import annotations

import argparse
import csv
import ctypes
import dataclasses
import itertools
import json
import math
import os
import subprocess
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

if __package__:  # imported as benchmarks.weak_scaling (the tests)
    from . import fe_scaling
else:  # run as a script: its directory is on the path
    import fe_scaling  # the sibling benchmark: problem, dofs, memory measurement

ROOT = fe_scaling.ROOT
OUT = ROOT / "benchmarks" / "output" / "weak_scaling"
REPORT = ROOT / "report"
SHIM_SOURCE = Path(__file__).resolve().parent / "mpi_counts.c"
SERIES = ((1, 10), (1, 14), (2, 18), (2, 28), (4, 22), (8, 28))
"""(ranks, n): about 25k dofs per rank (n = 14: 25,584; 18: 51,900; 22: 91,944; 28: 184,050);
1 rank at 10,116 dofs and 2 ranks at 184,050 (what depends on the whole model, apart from the
rank count)."""
REFINED_SERIES = ((1, 2, 2), (1, 3, 2), (2, 4, 2), (2, 7, 2), (4, 5, 2), (8, 7, 2))
"""(ranks, coarse n, refinements) of the refined path (``--path refined``): the tetrahedral pad
with ``n`` elements along the pad's side meshed coarse once per ``n`` by one process
(:func:`convert_one`), read in parts and refined ``k`` times on the ranks; sizes as in
:data:`SERIES` (the fine dofs in :func:`refined_counts`)."""
CONVERT_SIZES = (12, 18, 24)
"""Coarse ``n`` converted on the refined path only to measure the conversion's memory (one
process): the series' own coarse models are too small for it to show over the imports."""
PATHS = ("gmsh", "refined")
"""How the model is built: ``gmsh`` (hexahedra meshed whole on rank 0, :data:`SERIES`) or
``refined`` (:data:`REFINED_SERIES`)."""
TARGETS = ((64, 1e7), (512, 1e7), (64, 1e8), (512, 1e8))
EVENTS = ("SNESSolve", "KSPSolve", "PCSetUp", "PCApply", "MatMult")
PHASES = ("read", "refine", "problem", "setup", "steps", "profile", "checkpoint")
"""Phases of the MPI counts: ``setup`` = the mesh and the problem (on the refined path also split
into the coarse model's ``read``, its ``refine``-ment and the ``problem``)."""
NOISE_MIB = 5.0
"""What a process's peak RSS varies by between runs of the same work (MiB): a fitted term that
moves the measured rows by less is not resolved by them (:func:`fit_resolved`)."""
NODE_MEMORY_GIB = 4.0
"""Memory per rank of a typical cluster node (e.g. 128 cores, 512 GiB): a part that needs more on
one rank stops the run."""


# ------------------------------------------------------------------------------------------------
# MPI counters (the preloaded PMPI library)


class MpiCounts:
    """The counters of ``mpi_counts.c`` in this process (:meth:`load`: ``None`` without it)."""

    def __init__(self, lib: ctypes.CDLL) -> None:
        self.lib = lib
        lib.mpi_counts_name.restype = ctypes.c_char_p
        self.n = lib.mpi_counts_n()
        self.names = [lib.mpi_counts_name(i).decode() for i in range(self.n)]

    @classmethod
    def load(cls) -> MpiCounts | None:
        """The counters when the library is preloaded (``LD_PRELOAD``), else ``None``."""
        lib = ctypes.CDLL(None)
        try:
            lib.mpi_counts_n  # noqa: B018
        except AttributeError:
            return None
        return cls(lib)

    def reset(self) -> None:
        """Zero the counters."""
        self.lib.mpi_counts_reset()

    def read(self) -> dict[str, list[float]]:
        """Function -> [calls, bytes] since the last reset (functions never called left out)."""
        c, b = (ctypes.c_double * self.n)(), (ctypes.c_double * self.n)()
        self.lib.mpi_counts_read(c, b)
        return {k: [c[i], b[i]] for i, k in enumerate(self.names) if c[i]}


def build_shim(out: Path) -> Path:
    """Compile ``mpi_counts.c`` with ``mpicc`` into ``out`` (once per source change)."""
    out.mkdir(parents=True, exist_ok=True)
    lib = out / f"libmpicounts_py{sys.version_info.major}{sys.version_info.minor}.so"
    if not lib.exists() or lib.stat().st_mtime < SHIM_SOURCE.stat().st_mtime:
        subprocess.run(
            ["mpicc", "-shared", "-fPIC", "-O2", "-o", str(lib), str(SHIM_SOURCE)], check=True
        )
    return lib


# ------------------------------------------------------------------------------------------------
# The refined path's coarse model


def refined_counts(counts: Sequence[int], times: int) -> tuple[int, int, int, int]:
    """Vertices, edges, faces and tetrahedra of a tetrahedral mesh refined ``times`` times.

    Each edge gets a vertex at its midpoint and is split in two, each face into four (three new
    edges), each tetrahedron into eight (one new edge, the inner octahedron's diagonal, and eight
    new faces).
    """
    v, e, f, t = counts
    for _ in range(times):
        v, e, f, t = v + e, 2 * e + 3 * f + t, 4 * f + 8 * t, 8 * t
    return v, e, f, t


def coarse_file(out: Path, n: int) -> Path:
    """The refined path's coarse model with ``n`` tetrahedra along the pad's side (XDMF)."""
    return out / "coarse" / f"pad_tet_{n}.xdmf"


def convert_one(n: int, out: Path, comm=None) -> dict:
    """Mesh the coarse tetrahedral pad and write it partitioned (collective on ``comm``).

    The benchmark calls it on one process of its own (``comm`` = ``COMM_WORLD`` of a singleton):
    its peak memory is then the conversion's.

    Returns (and writes beside the mesh as ``.json``) its counts (vertices, edges, faces,
    tetrahedra, global), its dofs, the fine dofs after 1-4 refinements (:func:`refined_counts`)
    and rank 0's peak RSS before and after (MiB).
    """
    from mpi4py import MPI

    from subfric_dolfinx import meshing

    comm = MPI.COMM_WORLD if comm is None else comm
    path = coarse_file(out, n)
    if comm.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    start = fe_scaling.peak_rss_mib()
    coarse, _ = meshing.create_interface_mesh(
        meshing.build_pad_on_plate,
        comm,
        n_interface=n,
        cell_type="tetrahedron",
        plate_size=fe_scaling.PLATE_SIZE,
        pad_size=fe_scaling.PAD_SIZE,
    )
    meshing.write_partitioned_mesh(coarse, path)
    topology = coarse.mesh.topology
    for dim in (1, 2):
        topology.create_entities(dim)
    counts = tuple(int(topology.index_map(d).size_global) for d in range(4))
    info = {
        "n": n,
        "counts": counts,
        "coarse_dofs": 3 * counts[0],
        "fine_dofs": {k: 3 * refined_counts(counts, k)[0] for k in range(1, 5)},
        "start_mib": start,
        "peak_mib": fe_scaling.peak_rss_mib(),
    }
    if comm.rank == 0:
        path.with_suffix(".json").write_text(json.dumps(info, indent=1))
    comm.Barrier()
    return info


def launch_convert(n: int, out: Path, force: bool) -> dict:
    """:func:`convert_one` in a process of its own (its peak memory is the conversion's)."""
    info = coarse_file(out, n).with_suffix(".json")
    if not info.exists() or force:
        from subfric_dolfinx.logs import singleton_environment

        cmd = [sys.executable, __file__, "--convert-one", "--n", str(n), "--out", str(out)]
        subprocess.run(cmd, cwd=ROOT, env=singleton_environment(), check=True)
    got = json.loads(info.read_text())
    print(
        f"[coarse n {n}] {got['coarse_dofs']:,} dofs, refined: "
        + ", ".join(f"k {k}: {v:,}" for k, v in got["fine_dofs"].items())
        + f"; conversion's peak {got['peak_mib']:.0f} MiB",
        flush=True,
    )
    return got


# ------------------------------------------------------------------------------------------------
# One run (inside mpirun)


def _mat_info(A) -> dict[str, float]:
    from petsc4py import PETSc

    info = A.getInfo(PETSc.Mat.InfoType.LOCAL)
    rows = A.getLocalSize()[0]
    # PETSc no longer fills MatInfo's "memory": AIJ storage is a value and a column index per
    # allocated nonzero and two row arrays (an estimate; block formats store fewer indices)
    nz = float(info["nz_allocated"])
    return {"memory": nz * (8 + 4) + 8.0 * rows, "nz": float(info["nz_used"])}


def gamg_hierarchy(pc) -> dict:
    """GAMG's levels (finest first): global rows and nonzeros, this rank's rows and bytes.

    The bytes are those of the level operators (the finest one is the Jacobian, not counted here)
    and the interpolations, as PETSc reports them (``Mat.getInfo``).
    """
    from petsc4py import PETSc

    nlev = pc.getMGLevels()
    levels, memory = [], 0.0
    for lev in range(nlev - 1, -1, -1):  # PETSc numbers the coarsest 0
        A = pc.getMGSmoother(lev).getOperators()[0]
        glob = A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)
        loc = _mat_info(A)
        row = {
            "rows": A.getSize()[0],
            "nz": float(glob["nz_used"]),
            "local_rows": A.getLocalSize()[0],
            "memory": loc["memory"],
        }
        if lev > 0:
            P = pc.getMGInterpolation(lev)
            row["interp_memory"] = _mat_info(P)["memory"]
        if lev < nlev - 1:
            memory += loc["memory"] + row.get("interp_memory", 0.0)
        else:
            memory += row.get("interp_memory", 0.0)
        levels.append(row)
    coarse = pc.getMGCoarseSolve()
    return {"levels": levels, "memory": memory, "coarse_pc": coarse.getPC().getType()}


def measure(
    comm, n: int, steps: int, scratch: Path, refined: tuple[Path, int] | None = None
) -> dict:
    """One weak-scaling run on ``comm``: memory, communication and solver counts (collective).

    Args:
        comm: The communicator (its size is the rank count).
        n: Hexahedra along the pad's side (:func:`fe_scaling.dofs_of`); on the refined path the
            coarse tetrahedra's.
        steps: Steps of the program (:func:`fe_scaling.program_points`).
        scratch: Directory for the checkpoint file (removed after).
        refined: The refined path: the coarse model's file (:func:`convert_one`) and how many
            times it is refined on the ranks; ``None``: gmsh's hexahedra on rank 0.

    Returns:
        A JSON-ready record; per-rank values as lists over ranks (every rank gets it).
    """
    from mpi4py import MPI
    from petsc4py import PETSc

    from subfric_dolfinx.fem import LoadStepper, StepControl
    from subfric_dolfinx.io import write_checkpoint
    from subfric_dolfinx.logs import SubfricWarning
    from subfric_dolfinx.scenes.outputs import interface_profile

    counts = MpiCounts.load()
    mpi: dict[str, dict] = {}
    PETSc.Log.begin()
    rss_start = fe_scaling.peak_rss_mib()

    def phase(name: str) -> None:
        if counts is not None:
            mpi[name] = counts.read()
            counts.reset()

    stages = {k: PETSc.Log.Stage(f"weak: {k}") for k in ("setup", "steps")}
    if counts is not None:
        counts.reset()
    stages["setup"].push()
    rss_read = math.nan
    coarse_dofs = None
    if refined is None:
        pad = fe_scaling.build_pad(comm, n, "gamg", steps, valid=True)
    else:
        from subfric_dolfinx import meshing

        coarse = meshing.read_partitioned_mesh(refined[0], comm, 3)
        coarse_dofs = 3 * coarse.mesh.topology.index_map(0).size_global
        phase("read")
        rss_read = fe_scaling.peak_rss_mib()
        dom = meshing.refine_interface_mesh(coarse, refined[1])
        del coarse
        phase("refine")
        pad = fe_scaling.build_pad(comm, n, "gamg", steps, domain=dom, valid=True)
        phase("problem")
    stages["setup"].pop()
    if refined is None:
        phase("setup")
    elif counts is not None:  # the set-up: its three parts together
        mpi["setup"] = {}
        for part in ("read", "refine", "problem"):
            for f, (c, b) in mpi.get(part, {}).items():
                got = mpi["setup"].setdefault(f, [0.0, 0.0])
                got[0] += c
                got[1] += b
    problem, solver = pad.problem, pad.solver
    rss_setup = fe_scaling.peak_rss_mib()
    try:
        stepper = LoadStepper(solver, 10.0, control=StepControl(dt_max=10.0), predictor=True)
        stages["steps"].push()
        with warnings.catch_warnings(record=True) as caught:  # counted, then passed on
            warnings.simplefilter("always", SubfricWarning)
            stepper.run()
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        validity = sum(issubclass(w.category, SubfricWarning) for w in caught)
        stages["steps"].pop()
        phase("steps")
        rss_steps = fe_scaling.peak_rss_mib()
        interface_profile(problem)
        phase("profile")
        path = scratch / f"weak_ckpt_{comm.size}_{n}.h5"
        write_checkpoint(path, problem, stepper, [])
        phase("checkpoint")
        ckpt_bytes = path.stat().st_size if comm.rank == 0 else 0
        comm.Barrier()
        if comm.rank == 0:
            path.unlink()
        comm.Barrier()
        events = {}
        for name in EVENTS:
            info = PETSc.Log.Event(name).getPerfInfo(stages["steps"])
            events[name] = {
                k: float(info[k])
                for k in ("count", "numMessages", "messageLength", "numReductions")
            }
        pc = solver.snes.getKSP().getPC()
        hierarchy = gamg_hierarchy(pc)
        jac = _mat_info(solver.J)
        pairs = problem.interface.pairs
        el = problem.interface
        newton = sum(r.iterations for r in stepper.records)
        local = {
            "rss_start_mib": rss_start,
            "rss_read_mib": rss_read,
            "rss_mesh_mib": pad.rss_mesh_mib,
            "rss_setup_mib": rss_setup,
            "rss_steps_mib": rss_steps,
            "rss_end_mib": fe_scaling.peak_rss_mib(),
            "owned_dofs": problem.V.dofmap.index_map.size_local * problem.V.dofmap.bs,
            "interface_points": el.n_elements * el.nq,
            "pairing_received": pairs.n_received,
            "pairing_extra_ghosts": pairs.n_extra_ghosts,
            "jacobian_memory": jac["memory"],
            "jacobian_nz": jac["nz"],
            "gamg_memory": hierarchy["memory"],
            "coarse_local_rows": hierarchy["levels"][-1]["local_rows"],
            "events": events,
            "mpi": mpi,
        }
        per_rank = comm.allgather(local)
        result = {
            "ranks": comm.size,
            "n": n,
            "path": "gmsh" if refined is None else "refined",
            "refine": 0 if refined is None else refined[1],
            "steps_program": steps,
            "dofs": problem.global_dofs,
            "coarse_dofs": problem.global_dofs if coarse_dofs is None else coarse_dofs,
            "interface_points": comm.allreduce(el.n_elements * el.nq),
            "steps": len(stepper.records),
            "newton": newton,
            "krylov": int(solver.linear.krylov),  # every Krylov solve of the run
            "validity_warnings": comm.allreduce(validity, op=MPI.MAX),
            "gamg_levels": [
                {k: v for k, v in lev.items() if k in ("rows", "nz")} for lev in hierarchy["levels"]
            ],
            "coarse_pc": hierarchy["coarse_pc"],
            "checkpoint_bytes": comm.bcast(ckpt_bytes, root=0),
            "mpi_counted": counts is not None,
            "per_rank": per_rank,
            "load": list(os.getloadavg()),
        }
    finally:
        solver.destroy()
    return result


def run_one(n: int, steps: int, out: Path, path: str = "gmsh", k: int = 0) -> None:
    from mpi4py import MPI

    from subfric_dolfinx import logs

    comm = MPI.COMM_WORLD
    logs.configure(-1, comm)
    scratch = out / "scratch"
    if comm.rank == 0:
        scratch.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    refined = (coarse_file(out, n), k) if path == "refined" else None
    r = measure(comm, n, steps, scratch, refined)
    tag = tag_of(comm.size, n, steps, path, k)
    if comm.rank == 0:
        if refined is not None:  # the conversion's own process (launch_convert)
            r["convert"] = json.loads(refined[0].with_suffix(".json").read_text())
        (out / f"{tag}.json").write_text(json.dumps(r, indent=1))
        row = row_of(r)
        print(
            f"[{tag}] {r['dofs']:,} dofs, {row['dofs_per_rank']:.0f} "
            f"per rank: Newton {r['newton']}, Krylov/Newton {row['krylov_per_newton']:.1f}, "
            f"peak RSS {row['rss_max_mib']:.0f} MiB (rank 0: {row['rss_rank0_mib']:.0f}), "
            f"GAMG levels {len(r['gamg_levels'])} (coarse {row['coarse_rows']} rows)",
            flush=True,
        )


def tag_of(ranks: int, n: int, steps: int, path: str = "gmsh", k: int = 0) -> str:
    if path == "refined":
        return f"weak_refined_r{ranks}_n{n}_k{k}_s{steps}"
    return f"weak_r{ranks}_n{n}_s{steps}"


def launch(
    ranks: int, n: int, steps: int, out: Path, force: bool, route: str = "gmsh", k: int = 0
) -> dict | None:
    path = out / f"{tag_of(ranks, n, steps, route, k)}.json"
    if path.exists() and not force:
        print(f"[{path.stem}] kept (--force to redo)", flush=True)
        return json.loads(path.read_text())
    shim = build_shim(out)
    cmd = [
        "mpirun",
        "-n",
        str(ranks),
        "--map-by",
        ":OVERSUBSCRIBE",
        "-x",
        f"LD_PRELOAD={shim}",
        sys.executable,
        __file__,
        "--one",
        "--n",
        str(n),
        "--steps",
        str(steps),
        "--out",
        str(out),
        "--path",
        route,
        "--k",
        str(k),
    ]
    from subfric_dolfinx.logs import singleton_environment

    env = singleton_environment()
    env.pop("OMPI_MCA_rmaps_base_oversubscribe", None)
    proc = subprocess.run(cmd, cwd=ROOT, env=env)
    if proc.returncode != 0 or not path.exists():
        print(f"[{path.stem}] exit code {proc.returncode}, no result", flush=True)
        return None
    return json.loads(path.read_text())


# ------------------------------------------------------------------------------------------------
# Rows, models, extrapolation


def _median(v) -> float:
    import numpy as np

    return float(np.median(np.asarray(v, float)))


def _mpi_bytes(rank: dict, phase: str, funcs: tuple[str, ...] | None = None) -> float:
    got = rank["mpi"].get(phase, {})
    return float(sum(b for k, (_, b) in got.items() if funcs is None or k in funcs))


def _mpi_calls(rank: dict, phase: str, funcs: tuple[str, ...]) -> float:
    got = rank["mpi"].get(phase, {})
    return float(sum(c for k, (c, _) in got.items() if k in funcs))


GATHERS = ("Allgather", "Allgatherv", "Gather", "Gatherv", "Bcast", "Alltoall", "Alltoallv")
"""Collectives whose volume can grow with the rank count or the model (not the reductions)."""


def row_of(r: dict) -> dict:
    """The measured row of one run (per-rank values: max over ranks unless said)."""
    pr = r["per_rank"]
    newton = max(r["newton"], 1)
    steps = max(r["steps"], 1)
    ev = {k: max(p["events"][k]["messageLength"] for p in pr) for k in EVENTS}
    msgs = max(p["events"]["SNESSolve"]["numMessages"] for p in pr)
    red = max(p["events"]["SNESSolve"]["numReductions"] for p in pr)
    mib = 2.0**20
    others = [p["rss_end_mib"] for p in pr[1:]] or [pr[0]["rss_end_mib"]]
    refined = r.get("path", "gmsh") == "refined"
    return {
        "path": r.get("path", "gmsh"),
        "ranks": r["ranks"],
        "n": r["n"],
        "refine": r.get("refine", 0),
        "coarse_dofs": r.get("coarse_dofs", r["dofs"]),
        "dofs": r["dofs"],
        "dofs_per_rank": r["dofs"] / r["ranks"],
        "interface_points": r["interface_points"],
        "steps": r["steps"],
        "newton": r["newton"],
        "krylov_per_newton": r["krylov"] / newton,
        "rss_max_mib": max(p["rss_end_mib"] for p in pr),
        "rss_rank0_mib": pr[0]["rss_end_mib"],
        "rss_others_mib": _median(others),
        "rss_start_mib": _median([p["rss_start_mib"] for p in pr]),
        "rss_mesh_rank0_mib": pr[0]["rss_mesh_mib"],
        "rss_mesh_others_mib": _median([p["rss_mesh_mib"] for p in pr[1:]] or [math.nan]),
        "jacobian_mib": max(p["jacobian_memory"] for p in pr) / mib,
        "gamg_mib": max(p["gamg_memory"] for p in pr) / mib,
        "gamg_levels": len(r["gamg_levels"]),
        "coarse_rows": r["gamg_levels"][-1]["rows"],
        "coarse_nz": r["gamg_levels"][-1]["nz"],
        "gamg_complexity": sum(lv["nz"] for lv in r["gamg_levels"]) / r["gamg_levels"][0]["nz"],
        "checkpoint_mib": r["checkpoint_bytes"] / mib,
        "pairing_received": max(p["pairing_received"] for p in pr),
        "petsc_bytes_per_newton": ev["SNESSolve"] / newton,
        "petsc_messages_per_newton": msgs / newton,
        "petsc_reductions_per_newton": red / newton,
        "allreduce_calls_per_newton": max(_mpi_calls(p, "steps", ("Allreduce",)) for p in pr)
        / newton,
        "gather_bytes_per_step": max(_mpi_bytes(p, "steps", GATHERS) for p in pr) / steps,
        "gather_calls_per_step": max(_mpi_calls(p, "steps", GATHERS) for p in pr) / steps,
        "setup_gather_bytes": max(_mpi_bytes(p, "setup", GATHERS) for p in pr),
        "read_gather_bytes": max(_mpi_bytes(p, "read", GATHERS) for p in pr)
        if refined
        else math.nan,
        "refine_gather_bytes": max(_mpi_bytes(p, "refine", GATHERS) for p in pr)
        if refined
        else math.nan,
        "profile_bytes": max(_mpi_bytes(p, "profile", GATHERS) for p in pr),
        "checkpoint_rank0_bytes": _mpi_bytes(pr[0], "checkpoint", ("Gather", "Gatherv")),
        "checkpoint_others_bytes": max(
            (_mpi_bytes(p, "checkpoint", ("Allgather", "Allgatherv", "Bcast")) for p in pr[1:]),
            default=0.0,
        ),
        "convert_peak_mib": r["convert"]["peak_mib"] if "convert" in r else math.nan,
        "validity_warnings": r.get("validity_warnings", math.nan),
        "load": r["load"][0],
    }


COLUMNS = [
    "path",
    "ranks",
    "n",
    "refine",
    "coarse_dofs",
    "dofs",
    "dofs_per_rank",
    "interface_points",
    "steps",
    "newton",
    "krylov_per_newton",
    "rss_max_mib",
    "rss_rank0_mib",
    "rss_others_mib",
    "rss_start_mib",
    "rss_mesh_rank0_mib",
    "rss_mesh_others_mib",
    "jacobian_mib",
    "gamg_mib",
    "gamg_levels",
    "coarse_rows",
    "coarse_nz",
    "gamg_complexity",
    "checkpoint_mib",
    "pairing_received",
    "petsc_bytes_per_newton",
    "petsc_messages_per_newton",
    "petsc_reductions_per_newton",
    "allreduce_calls_per_newton",
    "gather_bytes_per_step",
    "gather_calls_per_step",
    "setup_gather_bytes",
    "read_gather_bytes",
    "refine_gather_bytes",
    "profile_bytes",
    "checkpoint_rank0_bytes",
    "checkpoint_others_bytes",
    "convert_peak_mib",
    "validity_warnings",
    "load",
]


def _fmt_count(v: float) -> str:
    """A count, or "an unknown number of" where a run did not record it (NaN)."""
    return "an unknown number of" if math.isnan(v) else str(int(v))


def fit_line(x, y) -> tuple[float, float]:
    """Least-squares ``y = a + b x``; with one distinct ``x``, ``b = 0`` and ``a`` the mean."""
    import numpy as np

    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size == 0:
        raise ValueError("no points to fit")
    if np.ptp(x) == 0:
        return float(y.mean()), 0.0
    b, a = np.polyfit(x, y, 1)
    return float(a), float(b)


def fit_proportional(x, y) -> float:
    """Least-squares ``y = c x`` (through the origin)."""
    import numpy as np

    x, y = np.asarray(x, float), np.asarray(y, float)
    return float((x @ y) / (x @ x)) if x @ x > 0 else 0.0


@dataclasses.dataclass(frozen=True)
class Models:
    """Per-part models fitted to the measured rows (see :func:`fit_models` for each form).

    Attributes:
        memory: (a MiB, b MiB per dof): peak RSS of a rank = a + b dofs_per_rank (ranks other
            than 0; 1-rank runs less ``rank0_excess``).
        rank0_excess: MiB rank 0's peak exceeds the others' by, on several ranks (median).
        start: MiB of a rank before the mesh (Python, DOLFINx, PETSc loaded; median).
        mesh: (e MiB, f MiB per dof, g MiB per dof of the rank): rank 0's peak once the mesh
            is built, over ``start``, = e + f dofs + g dofs_per_rank (gmsh meshes the whole
            model on rank 0, which hands it out: f; a mesh read in parts and refined on the
            ranks: g); a term the rows do not resolve is left out (:func:`fit_resolved`,
            :data:`NOISE_MIB`).
        setup_gather: (k, alpha, beta): bytes a rank receives in gathers during the set-up =
            k coarse_dofs^alpha ranks^beta (least squares in logs, runs on several ranks;
            ``coarse_dofs`` the dofs of the model before the ranks refine it, the model's own
            on the gmsh path).
        refine_factor: Dofs over the coarse model's in the largest run (1 on the gmsh path): the
            extrapolation refines as many times as the measured runs did. The ratio grows with
            the model towards 8 per refinement (a smaller share of vertices on the surface), so
            the extrapolated coarse model is an upper bound.
        checkpoint_others: (a, s): bytes of ``Allgather(v)`` and ``Bcast`` a rank other than
            rank 0 receives when a checkpoint is written = a + s ranks (the interface rows'
            sample sort broadcasts its ``ranks - 1`` splitters; runs on several ranks).
        convert: (a MiB, b MiB per coarse dof): peak RSS of the one process that meshes and
            writes the coarse model (refined path; NaN without such runs).
        checkpoint_rank0: Bytes rank 0 gathers (``Gather(v)``) per sample row when a checkpoint
            is written: the sample sort's samples, at most ``ranks`` of every rank, so rank 0
            receives this times ``min(interface points, ranks^2)`` (runs on several ranks).
        sort_rank0_peak: Bytes rank 0 holds at once per sample while it chooses the splitters
            (:func:`sort_rank0_peak_per_sample`: the gathered samples, their sorted copy and the
            weights' sums); 0 where not measured (then the gathered bytes stand for it).
        jacobian: MiB per dof of the Jacobian's storage on a rank.
        gamg: MiB per dof of the GAMG hierarchy (coarse operators and interpolations).
        checkpoint: Checkpoint bytes per global dof.
        interface_per_dof23: Interface points per dof^(2/3) (the pad's interface is a surface).
        profile: Bytes a rank receives per interface point when a profile is gathered.
        gather_step: (a, b): bytes of gathers and broadcasts per step and rank = a + b ranks.
        petsc_halo: PETSc bytes per Newton iteration and rank per dofs_per_rank^(2/3) (halo), from
            the run on the most ranks.
        krylov: (a, b): Krylov iterations per Newton = a + b log10(dofs).
        reductions: MPI_Allreduce calls per Krylov iteration (a Newton iteration makes
            ``reductions * krylov`` of them, PETSc's and the package's).
        coarsening: Mean ratio of rows between successive GAMG levels.
        coarse_rows: Rows of the coarsest grid (largest measured).
    """

    memory: tuple[float, float]
    rank0_excess: float
    start: float
    mesh: tuple[float, float, float]
    setup_gather: tuple[float, float, float]
    checkpoint_rank0: float
    jacobian: float
    gamg: float
    checkpoint: float
    interface_per_dof23: float
    profile: float
    gather_step: tuple[float, float]
    petsc_halo: float
    krylov: tuple[float, float]
    reductions: float
    coarsening: float
    coarse_rows: int
    refine_factor: float = 1.0
    checkpoint_others: tuple[float, float] = (0.0, 0.0)
    convert: tuple[float, float] = (math.nan, math.nan)
    sort_rank0_peak: float = 0.0


def fit_resolved(columns: list, y, noise: float = 0.0) -> list[float]:
    """Least squares ``y = sum_i c_i columns_i``, keeping only the terms the data resolve.

    A term ``i > 0`` is left out (``c_i = 0``) and the others fitted again while one is negative
    or moves the rows by less than ``noise`` over their range (``c_i ptp(columns_i)``), the
    smallest such term first; the first column's coefficient (the constant) is always fitted.
    """
    import numpy as np

    y = np.asarray(y, float)
    cols = [np.asarray(c, float) for c in columns]
    keep = list(range(len(cols)))
    while True:
        coef, *_ = np.linalg.lstsq(np.column_stack([cols[i] for i in keep]), y, rcond=None)
        moved = {i: c * np.ptp(cols[i]) for i, c in zip(keep, coef, strict=True) if i > 0}
        bad = [i for i, v in moved.items() if v < noise or v < 0]
        if not bad:
            out = [0.0] * len(cols)
            for i, c in zip(keep, coef, strict=True):
                out[i] = float(c)
            return out
        keep.remove(min(bad, key=lambda i: moved[i]))


def fit_power(dofs, ranks, y) -> tuple[float, float, float]:
    """Least squares of ``log y = log k + alpha log dofs + beta log ranks``: (k, alpha, beta).

    With one distinct rank count, ``beta = 0``; with one distinct dofs too, ``alpha = 0``.
    """
    import numpy as np

    n, p, y = (np.log(np.asarray(v, float)) for v in (dofs, ranks, y))
    cols = [np.ones_like(n)] + [c for c in (n, p) if np.ptp(c) > 0]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), y, rcond=None)
    coef = list(coef)
    alpha = coef.pop(1) if np.ptp(n) > 0 else 0.0
    beta = coef.pop(1) if np.ptp(p) > 0 else 0.0
    return float(np.exp(coef[0])), float(alpha), float(beta)


def fit_models(
    rows: list[dict],
    levels: list[list[int]],
    conversions: list[tuple[float, float]] | None = None,
    sort_peak: float = 0.0,
) -> Models:
    """Fit the per-part models to the measured rows.

    Args:
        rows: :func:`row_of` of every run.
        levels: For every run, the global rows of its GAMG levels, finest first.
        conversions: (coarse dofs, peak MiB) of every conversion measured (:func:`convert_one`);
            ``None``: those of the runs' own coarse models (``convert_peak_mib``).
        sort_peak: Rank 0's working memory per sample of the sample sort (bytes,
            :func:`sort_rank0_peak_per_sample`; 0: not measured).
    """
    import numpy as np

    d = [r["dofs_per_rank"] for r in rows]
    many = [r for r in rows if r["ranks"] > 1] or rows
    widest = max(rows, key=lambda r: (r["ranks"], r["dofs"]))
    excess = _median([r["rss_rank0_mib"] - r["rss_others_mib"] for r in many])
    own = [r["rss_others_mib"] if r["ranks"] > 1 else r["rss_rank0_mib"] - excess for r in rows]
    ratios = [a / b for lv in levels for a, b in itertools.pairwise(lv) if b > 0]
    gathered = [r for r in many if r["setup_gather_bytes"] > 0]
    coarse = [r.get("coarse_dofs", r["dofs"]) for r in rows]
    largest = max(range(len(rows)), key=lambda i: rows[i]["dofs"])
    mesh = fit_resolved(
        [[1.0] * len(rows), [r["dofs"] for r in rows], d],
        [r["rss_mesh_rank0_mib"] - r["rss_start_mib"] for r in rows],
        NOISE_MIB,
    )
    several = [r for r in rows if r["ranks"] > 1]
    if conversions is None:
        conversions = [
            (r["coarse_dofs"], r["convert_peak_mib"])
            for r in rows
            if not math.isnan(r.get("convert_peak_mib", math.nan))
        ]
    return Models(
        memory=fit_line(d, own),
        rank0_excess=excess,
        start=_median([r["rss_start_mib"] for r in rows]),
        mesh=(mesh[0], mesh[1], mesh[2]),
        refine_factor=rows[largest]["dofs"] / coarse[largest],
        sort_rank0_peak=sort_peak,
        checkpoint_others=fit_line(
            [r["ranks"] for r in several],
            [r.get("checkpoint_others_bytes", 0.0) for r in several],
        )
        if several
        else (0.0, 0.0),
        convert=fit_line([c for c, _ in conversions], [p for _, p in conversions])
        if conversions
        else (math.nan, math.nan),
        setup_gather=fit_power(
            [r.get("coarse_dofs", r["dofs"]) for r in gathered],
            [r["ranks"] for r in gathered],
            [r["setup_gather_bytes"] for r in gathered],
        )
        if gathered
        else (0.0, 0.0, 0.0),
        checkpoint_rank0=fit_proportional(
            [min(r["interface_points"], r["ranks"] ** 2) for r in several],
            [r["checkpoint_rank0_bytes"] for r in several],
        )
        if several
        else 0.0,
        jacobian=fit_proportional(d, [r["jacobian_mib"] for r in rows]),
        gamg=fit_proportional(d, [r["gamg_mib"] for r in rows]),
        checkpoint=fit_proportional(
            [r["dofs"] for r in rows], [r["checkpoint_mib"] * 2.0**20 for r in rows]
        ),
        interface_per_dof23=fit_proportional(
            [r["dofs"] ** (2 / 3) for r in rows], [r["interface_points"] for r in rows]
        ),
        profile=fit_proportional(
            [r["interface_points"] for r in rows], [r["profile_bytes"] for r in rows]
        ),
        gather_step=fit_line(
            [r["ranks"] for r in rows], [r["gather_bytes_per_step"] for r in rows]
        ),
        petsc_halo=widest["petsc_bytes_per_newton"] / widest["dofs_per_rank"] ** (2 / 3),
        krylov=fit_line(
            [math.log10(r["dofs"]) for r in rows], [r["krylov_per_newton"] for r in rows]
        ),
        reductions=fit_proportional(
            [r["krylov_per_newton"] for r in rows], [r["allreduce_calls_per_newton"] for r in rows]
        ),
        coarsening=float(np.exp(np.mean(np.log(ratios)))) if ratios else math.nan,
        coarse_rows=int(max(r["coarse_rows"] for r in rows)),
    )


def extrapolate(m: Models, ranks: int, dofs: float) -> dict:
    """What ``ranks`` ranks need for ``dofs`` dofs, by the models (per rank unless said)."""
    d = dofs / ranks
    mib = 2.0**20
    rss = m.memory[0] + m.memory[1] * d
    iface = m.interface_per_dof23 * dofs ** (2 / 3)
    krylov = m.krylov[0] + m.krylov[1] * math.log10(dofs)
    levels = (
        1 + math.log(dofs / m.coarse_rows) / math.log(m.coarsening)
        if m.coarsening > 1
        else math.nan
    )
    k, alpha, beta = m.setup_gather
    coarse = dofs / m.refine_factor
    return {
        "ranks": ranks,
        "dofs": dofs,
        "dofs_per_rank": d,
        "coarse_dofs": coarse,
        "rss_mib": rss,
        "rss_rank0_mib": rss + m.rank0_excess,
        "start_mib": m.start,
        "mesh_rank0_mib": m.start + m.mesh[0] + m.mesh[1] * dofs + m.mesh[2] * d,
        "setup_gather_mib": k * coarse**alpha * ranks**beta / mib,
        "checkpoint_others_mib": (m.checkpoint_others[0] + m.checkpoint_others[1] * ranks) / mib,
        "convert_mib": m.convert[0] + m.convert[1] * coarse,
        "jacobian_mib": m.jacobian * d,
        "gamg_mib": m.gamg * d,
        "interface_points": iface,
        "profile_mib": m.profile * iface / mib,
        "gather_step_kib": (m.gather_step[0] + m.gather_step[1] * ranks) / 1024.0,
        "petsc_mib_per_newton": m.petsc_halo * d ** (2 / 3) / mib,
        "krylov_per_newton": krylov,
        "reductions_per_newton": m.reductions * krylov,
        "gamg_levels": levels,
        "coarse_rows": m.coarse_rows,
        "checkpoint_gib": m.checkpoint * dofs / 2.0**30,
        "checkpoint_mib_per_rank": m.checkpoint * d / mib,
        "checkpoint_rank0_mib": m.checkpoint_rank0 * min(iface, ranks**2) / mib,
        "sort_rank0_peak_mib": max(m.checkpoint_rank0, m.sort_rank0_peak)
        * min(iface, ranks**2)
        / mib,
    }


class _SampleRoot:
    """Rank 0 of ``size`` ranks as :func:`io.slabs._splitters` sees it, without MPI.

    Every rank sends ``size`` samples of ``width`` int64 keys and a weight (random keys, equal
    weights); the splitters are broadcast to nobody.
    """

    def __init__(self, size: int, width: int) -> None:
        self.size, self.rank, self.width = size, 0, width

    def gather(self, count: int, root: int = 0) -> list[int]:
        return [count] * self.size

    def Gatherv(self, send, recv, root: int = 0) -> None:
        import numpy as np

        flat = recv[0].reshape(-1, self.width + 1)
        flat[:, :-1] = np.random.default_rng(0).integers(0, 2**40, flat[:, :-1].shape)
        flat[:, -1] = 1

    def bcast(self, value, root: int = 0):
        return value

    def Bcast(self, buf, root: int = 0) -> None:
        pass


def sort_rank0_peak_per_sample(size: int = 512, width: int = 5) -> float:
    """Bytes rank 0 holds at once per sample while it chooses the sample sort's splitters.

    Runs ``io.slabs._splitters`` (what :func:`io.slabs.sorted_rows` calls) as rank 0 of ``size``
    ranks that each hold ``size`` rows of ``width`` int64 keys (the pad's interface points: three
    rounded coordinates, the rank and the local index), so rank 0 receives ``size**2`` samples,
    through a stand-in communicator (:class:`_SampleRoot`); returns the peak of numpy's
    allocations over the call (``tracemalloc``) per sample. The gathered samples alone are
    ``8 (width + 1)`` bytes each.
    """
    import tracemalloc

    import numpy as np

    from subfric_dolfinx.io import slabs

    ordered = np.zeros((size, width), dtype=np.int64)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        splitters = slabs._splitters(_SampleRoot(size, width), ordered, size * size)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    if splitters.shape != (size - 1, width):
        raise RuntimeError(f"the splitters' shape {splitters.shape}, not {(size - 1, width)}")
    return peak / size**2


MESH_PART = {
    "gmsh": "rank 0's mesh (gmsh builds and distributes the whole mesh from rank 0)",
    "refined": "rank 0's mesh (the coarse model read in parts, refined on the ranks)",
}
GATHER_PART = {
    "gmsh": "the partitioner's gathers in the set-up (DOLFINx's PT-Scotch partitioning)",
    "refined": "the partitioner's gathers in the set-up (PT-Scotch, of the coarse model)",
}


SORT_RANK0 = "the checkpoint's sample sort on rank 0 (at most `ranks` samples of every rank)"


def parts_of(row: dict, path: str = "gmsh") -> dict[str, tuple[float, float]]:
    """Part -> (its MiB, the total MiB of the rank it sits on) in an extrapolated row.

    The distributed parts (``rss_mib``, every rank), rank 0's mesh (``mesh_rank0_mib`` over
    ``start_mib``, the memory before it), the partitioner's set-up gathers (``setup_gather_mib``,
    every rank, over ``start_mib``), an interface profile gathered on every rank
    (``profile_mib``), the checkpoint's sample sort on rank 0 (``sort_rank0_peak_mib``: what
    it holds while it chooses the splitters from the gathered samples, ``checkpoint_rank0_mib``
    where that is absent) and what every other rank receives for it (``checkpoint_others_mib``:
    the splitters).
    """
    start = row.get("start_mib", 0.0)
    rss, rank0, mesh = row["rss_mib"], row["rss_rank0_mib"], row["mesh_rank0_mib"]
    sort = row.get("checkpoint_others_mib", 0.0)
    sort0 = row.get("sort_rank0_peak_mib", row["checkpoint_rank0_mib"])
    return {
        "the per-rank memory of the distributed parts": (rss, rss),
        MESH_PART[path]: (mesh - start, mesh),
        GATHER_PART[path]: (row["setup_gather_mib"], start + row["setup_gather_mib"]),
        "an interface profile gathered on every rank": (
            row["profile_mib"],
            rss + row["profile_mib"],
        ),
        SORT_RANK0: (sort0, rank0 + sort0),
        "the checkpoint's sample sort on the other ranks (its ranks - 1 splitters)": (
            sort,
            rss + sort,
        ),
    }


def first_to_break(
    table: list[dict], node_gib: float = NODE_MEMORY_GIB, path: str = "gmsh"
) -> tuple[str, str]:
    """The first part whose need exceeds a node's memory per rank, and why (a number).

    Each part adds to a rank's memory (:func:`parts_of`). In the smallest model (then the
    fewest ranks) where a rank's total exceeds ``node_gib``, the largest part on that rank is
    named. If no rank ever exceeds it, the part that grows most from the smallest model on the
    fewest ranks to the largest on the most (the weak direction of the table) is named, with its
    factor (parts under 1 MiB there are left out: they stop nothing).
    """
    limit = node_gib * 1024.0
    for row in sorted(table, key=lambda r: (r["dofs"], r["ranks"])):
        over = {p: v for p, v in parts_of(row, path).items() if v[1] > limit}
        if over:
            part = max(over, key=lambda p: over[p][0])
            size, total = over[part]
            return part, (
                f"{total / 1024.0:.1f} GiB on one rank at {row['dofs']:.0e} dofs on "
                f"{row['ranks']} ranks, {size / 1024.0:.1f} GiB of it this part "
                f"(a node's share: {node_gib:g} GiB per rank)"
            )
    lo = min(table, key=lambda r: (r["dofs"], r["ranks"]))
    hi = max(table, key=lambda r: (r["dofs"], r["ranks"]))
    a, b = parts_of(lo, path), parts_of(hi, path)
    growth = {p: b[p][0] / a[p][0] for p in a if a[p][0] > 0 and b[p][0] >= 1.0}  # MiB
    part = max(growth, key=growth.get)
    return part, (
        f"grows {growth[part]:.1f}x from {lo['dofs']:.0e} dofs on {lo['ranks']} ranks "
        f"to {hi['dofs']:.0e} on {hi['ranks']} (dofs per rank "
        f"{hi['dofs_per_rank'] / lo['dofs_per_rank']:.2f}x), within {node_gib:g} GiB "
        "per rank"
    )


def weak_limit(
    m: Models,
    dofs_per_rank: float,
    node_gib: float = NODE_MEMORY_GIB,
    path: str = "gmsh",
    max_ranks: int = 2**24,
) -> tuple[str, dict, dict[str, float]] | None:
    """Weak scaling at ``dofs_per_rank`` until a rank's total exceeds ``node_gib``.

    The rank count doubles from 64 (the model growing with it) until a part's rank exceeds a
    node's share (:func:`parts_of`); the largest such part is named.

    Returns:
        The part, the extrapolated row where it stops, and every part's MiB there; ``None`` if
        nothing exceeds ``node_gib`` up to ``max_ranks`` ranks (or the distributed share
        alone exceeds it at 64 ranks: too many dofs per rank, not a limit of scaling).
    """
    limit = node_gib * 1024.0
    ranks = 64
    while ranks <= max_ranks:
        row = extrapolate(m, ranks, dofs_per_rank * ranks)
        parts = parts_of(row, path)
        over = {p: v for p, v in parts.items() if v[1] > limit}
        if over:
            if ranks == 64 and "the per-rank memory of the distributed parts" in over:
                return None
            part = max(over, key=lambda p: over[p][0])
            return part, row, {p: v[0] for p, v in parts.items()}
        ranks *= 2
    return None


# ------------------------------------------------------------------------------------------------
# Report


def _fmt(v) -> str:
    return fe_scaling._fmt(v)


MEASURED_HEAD = [
    "path",
    "ranks",
    "n",
    "refine",
    "dofs",
    "dofs_per_rank",
    "interface_points",
    "newton",
    "krylov_per_newton",
    "rss_others_mib",
    "rss_rank0_mib",
    "rss_mesh_rank0_mib",
    "rss_mesh_others_mib",
    "jacobian_mib",
    "gamg_mib",
    "gamg_levels",
    "coarse_rows",
    "gamg_complexity",
    "checkpoint_mib",
    "pairing_received",
    "petsc_bytes_per_newton",
    "petsc_reductions_per_newton",
    "allreduce_calls_per_newton",
    "gather_bytes_per_step",
    "setup_gather_bytes",
    "read_gather_bytes",
    "refine_gather_bytes",
    "profile_bytes",
    "checkpoint_rank0_bytes",
    "checkpoint_others_bytes",
    "convert_peak_mib",
    "validity_warnings",
    "load",
]
EXTRA_HEAD = [
    "path",
    "ranks",
    "dofs",
    "dofs_per_rank",
    "coarse_dofs",
    "rss_mib",
    "rss_rank0_mib",
    "mesh_rank0_mib",
    "setup_gather_mib",
    "jacobian_mib",
    "gamg_mib",
    "interface_points",
    "profile_mib",
    "checkpoint_rank0_mib",
    "sort_rank0_peak_mib",
    "checkpoint_others_mib",
    "gather_step_kib",
    "petsc_mib_per_newton",
    "krylov_per_newton",
    "reductions_per_newton",
    "gamg_levels",
    "checkpoint_gib",
    "checkpoint_mib_per_rank",
    "convert_mib",
]


def _table(head: list[str], rows: list[dict]) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(_fmt(r[k]) for k in head) + " |" for r in rows]
    return out


def mpi_breakdown(results: list[dict]) -> list[str]:
    """Markdown: every MPI collective of the run on the most ranks, by phase (max over ranks)."""
    r = max(results, key=lambda r: (r["ranks"], r["dofs"]))
    if not r["mpi_counted"]:
        return []
    pr = r["per_rank"]
    phases = [ph for ph in PHASES if any(ph in p["mpi"] for p in pr)]
    funcs = sorted({f for p in pr for ph in phases for f in p["mpi"].get(ph, {})})
    head = ["phase", *funcs]
    out = [
        f"MPI collectives of the {r.get('path', 'gmsh')} path's run on {r['ranks']} ranks "
        f"({r['dofs']:,} dofs), per phase: calls / KiB a rank contributes or receives, max over "
        f"ranks (the steps: all {r['steps']} steps, {r['newton']} Newton iterations"
        + ("; `setup` = `read` + `refine` + `problem`" if "read" in phases else "")
        + "):",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for ph in phases:
        cells = []
        for f in funcs:
            c = max(p["mpi"].get(ph, {}).get(f, [0, 0])[0] for p in pr)
            b = max(p["mpi"].get(ph, {}).get(f, [0, 0])[1] for p in pr)
            cells.append(f"{c:.0f} / {b / 1024:.1f}" if c else "—")
        out.append(f"| {ph} | " + " | ".join(cells) + " |")
    return [*out, ""]


def model_lines(
    m: Models, rows: list[dict], path: str, conversions: list[tuple[float, float]] = ()
) -> list[str]:
    """Markdown: the fitted models of one path."""
    weak = [r for r in rows if r["n"] != min(x["n"] for x in rows) or r["ranks"] > 1]
    kry = [r["krylov_per_newton"] for r in weak]
    if path == "gmsh":
        mesh = (
            f"- rank 0 while the mesh is built (gmsh meshes the whole model there, then DOLFINx "
            f"hands it out): {m.mesh[0]:.0f} MiB + {m.mesh[1] * 1e6:.0f} MiB per million global "
            f"dofs + {m.mesh[2] * 1e3:.3f} MiB per 1000 dofs of the rank over the memory before it;"
        )
        gather = (
            f"- gathers in the set-up (bytes received per rank) = {m.setup_gather[0]:.3g} dofs^"
            f"{m.setup_gather[1]:.2f} ranks^{m.setup_gather[2]:.2f} (runs on ≥ 2 ranks). Nearly "
            f"all of it is one `MPI_Allgatherv` in DOLFINx's cell partitioner: PT-Scotch's "
            f"multilevel bipartition (`SCOTCH_dgraphPart` → `bdgraphBipartSq` → "
            f"`dgraphGatherAll`) gathers its coarsened graph on every rank; it coarsens a larger "
            f"graph further before gathering it, so on models far beyond the measured ones (at "
            f"most {max(r['dofs'] for r in rows):,} dofs) this power law is an upper bound;"
        )
    else:
        k = sorted({r["refine"] for r in rows})
        mesh = (
            f"- rank 0 once its part of the coarse model is read and refined "
            f"{', '.join(str(v) for v in k)} times: {m.mesh[0]:.0f} MiB + "
            f"{m.mesh[1] * 1e6:.1f} MiB per million global dofs + {m.mesh[2] * 1e3:.3f} MiB per "
            f"1000 dofs of the rank over the memory before it (a term that moves the measured "
            f"rows by less than {NOISE_MIB:g} MiB is left out as unresolved: 0 per million "
            f"global dofs means the runs with a larger model at the same dofs per rank found "
            f"rank 0 no larger); the others' median in `rss_mesh_others`;"
        )
        gather = (
            f"- gathers in the set-up (bytes received per rank) = {m.setup_gather[0]:.3g} "
            f"coarse_dofs^{m.setup_gather[1]:.2f} ranks^{m.setup_gather[2]:.2f} (runs on ≥ 2 "
            f"ranks; the coarse model's dofs, {m.refine_factor:.1f} times fewer than the fine "
            f"model's: the partitioner sees only the coarse model; `read_gather_bytes`, "
            f"`refine_gather_bytes`: the read's and the refinement's shares, the rest the "
            f"problem's set-up). As on the gmsh path, PT-Scotch coarsens a larger graph further "
            f"before gathering it on every rank, so far beyond the measured coarse models (at "
            f"most {max(r['coarse_dofs'] for r in rows):,} dofs) this power law is an upper "
            f"bound;"
        )
    lines = [
        f"- peak memory of a rank = {m.memory[0]:.0f} MiB + {m.memory[1] * 1e3:.3f} MiB per 1000 "
        f"dofs of the rank; rank 0's peak is {m.rank0_excess:.0f} MiB more (median on several "
        f"ranks); {m.start:.0f} MiB before the mesh;",
        mesh,
        gather,
        f"- Jacobian {m.jacobian * 1e3:.3f} MiB and GAMG hierarchy {m.gamg * 1e3:.3f} MiB per "
        f"1000 dofs of a rank; checkpoint {m.checkpoint:.1f} bytes per global dof;",
        f"- interface points = {m.interface_per_dof23:.3f} dofs^(2/3) (the pad's interface is a "
        f"surface); an interface profile brings {m.profile:.0f} bytes per interface point to "
        f"every rank;",
        f"- gathers and broadcasts per step and rank = {m.gather_step[0]:.0f} + "
        f"{m.gather_step[1]:.1f} × ranks bytes;",
        f"- PETSc halo bytes per Newton iteration and rank = {m.petsc_halo:.0f} × "
        f"(dofs per rank)^(2/3) (the run on the most ranks);",
        f"- a checkpoint's sample sort of the interface rows gathers {m.checkpoint_rank0:.0f} "
        f"bytes per sample on rank 0 (at most `ranks` samples of every rank: "
        f"min(interface points, ranks²) samples, an upper bound: a rank holding fewer interface "
        f"points sends them all, one holding none nothing) and holds "
        f"{max(m.checkpoint_rank0, m.sort_rank0_peak):.0f} bytes per sample at once while it "
        f"chooses the splitters (the gathered samples, their sorted copy and the weights' sums: "
        f"`io.slabs._splitters` run as rank 0 of 512 ranks, numpy's allocations traced), and "
        f"every other rank receives {m.checkpoint_others[0]:.0f} + "
        f"{m.checkpoint_others[1]:.1f} × ranks bytes of `Bcast` and `Allgather(v)` (the "
        f"`ranks - 1` splitters); the interface history and `snapshot_file` number their rows "
        f"by the same sort;",
        f"- Krylov iterations per Newton = {m.krylov[0]:.1f} + {m.krylov[1]:.2f} log10(dofs) "
        f"(measured {min(kry):.1f}–{max(kry):.1f} over the weak series); "
        f"{m.reductions:.1f} `MPI_Allreduce` calls per Krylov iteration;",
        f"- GAMG coarsens by {m.coarsening:.1f} per level; coarsest grid ≤ {m.coarse_rows} rows "
        f"(largest measured; PETSc's coarse-size limit holds it there as the model grows); "
        f"operator complexity (all levels' nonzeros over the Jacobian's) "
        f"{min(r['gamg_complexity'] for r in rows):.2f}–"
        f"{max(r['gamg_complexity'] for r in rows):.2f}, "
        f"{max(rows, key=lambda r: r['dofs'])['gamg_complexity']:.2f} on the largest model.",
    ]
    if not math.isnan(m.convert[0]):
        lines.append(
            f"- the conversion (one process, once per model: gmsh meshes the coarse model and "
            f"writes it partitioned) peaks at {m.convert[0]:.0f} MiB + "
            f"{m.convert[1] * 1e6:.0f} MiB per million coarse dofs"
            + (
                f" (measured on {len(conversions)} coarse models of "
                f"{min(c for c, _ in conversions):,.0f}–{max(c for c, _ in conversions):,.0f} "
                f"dofs: "
                + ", ".join(f"{c:,.0f}: {p:.0f} MiB" for c, p in sorted(conversions))
                + ")"
                if conversions
                else ""
            )
            + "."
        )
    return lines


def stop_lines(m: Models, table: list[dict], path: str) -> list[str]:
    """Markdown: what stops scaling first on one path (the table's targets, then weak)."""
    part, why = first_to_break(table, path=path)
    row = next(r for r in table if r["ranks"] == 512 and r["dofs"] == 1e8)
    d = row["dofs_per_rank"]
    parts = parts_of(row, path)
    top = max(parts.values(), key=lambda v: v[1])[1]
    out = [
        f"At 512 ranks and 1e8 dofs ({d:,.0f} dofs per rank): {row['rss_mib']:.0f} MiB per "
        f"rank, rank 0 {row['rss_rank0_mib']:.0f} MiB; with the parts that grow with the model "
        f"or the ranks (set-up gathers {row['setup_gather_mib']:.0f} MiB, rank 0's mesh "
        f"{row['mesh_rank0_mib']:.0f} MiB, an interface profile {row['profile_mib']:.1f} MiB, the "
        f"checkpoint's sample sort {row['sort_rank0_peak_mib']:.1f} MiB on rank 0 and "
        f"{row['checkpoint_others_mib']:.2f} MiB on the others) the most any rank needs is "
        f"{top:.0f} MiB.",
        "",
        f"Over the four targets: **{part}**: {why}"
        + (
            " (too few ranks for the model: its own share, not a part that grows with the ranks)."
            if part == "the per-rank memory of the distributed parts"
            else "."
        ),
        "",
    ]
    limit = weak_limit(m, d, path=path)
    if limit is None:
        out.append(
            f"Weak scaling at {d:,.0f} dofs per rank: no part exceeds {NODE_MEMORY_GIB:g} GiB "
            f"per rank up to {2**24:,} ranks."
        )
    else:
        name, where, sizes = limit
        grown = ", ".join(
            f"{p} {v:.0f} MiB" for p, v in sorted(sizes.items(), key=lambda kv: -kv[1])
        )
        out.append(
            f"Weak scaling at {d:,.0f} dofs per rank (the rank count doubled from 64, the model "
            f"with it): the first part to take a rank past {NODE_MEMORY_GIB:g} GiB is **{name}**, "
            f"at {where['ranks']:,} ranks and {where['dofs']:.1e} dofs (there: {grown})."
        )
    return [*out, ""]


def write_report(out: Path, report: Path, command: str) -> list[str]:
    results = [json.loads(p.read_text()) for p in sorted(out.glob("weak_*.json"))]
    if not results:
        print(f"no results in {out}")
        return []
    results.sort(key=lambda r: (PATHS.index(r.get("path", "gmsh")), r["ranks"], r["n"]))
    paths = [p for p in PATHS if any(r.get("path", "gmsh") == p for r in results)]
    by_path: dict[str, dict] = {}
    conversions = [
        (float(c["coarse_dofs"]), float(c["peak_mib"]))
        for c in (
            json.loads(f.read_text()) for f in sorted((out / "coarse").glob("pad_tet_*.json"))
        )
        if "peak_mib" in c
    ]
    sort_peak = sort_rank0_peak_per_sample()
    for path in paths:
        res = [r for r in results if r.get("path", "gmsh") == path]
        rows = [row_of(r) for r in res]
        conv = conversions if path == "refined" and conversions else None
        levels = [[lv["rows"] for lv in r["gamg_levels"]] for r in res]
        m = fit_models(rows, levels, conv, sort_peak)
        table = [{"path": path, **extrapolate(m, p, nd)} for p, nd in TARGETS]
        by_path[path] = {
            "results": res,
            "rows": rows,
            "models": m,
            "table": table,
            "conversions": conv or [],
        }
    (report / "data").mkdir(parents=True, exist_ok=True)
    every_row = [r for v in by_path.values() for r in v["rows"]]
    every_x = [r for v in by_path.values() for r in v["table"]]
    with open(report / "data" / "weak_scaling.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["kind", *dict.fromkeys(COLUMNS + list(every_x[0]))])
        w.writeheader()
        for r in every_row:
            w.writerow({"kind": "measured", **r})
        for r in every_x:
            w.writerow({"kind": "extrapolated", **r})
    counted = all(r["mpi_counted"] for r in results)
    loads = [r["load"] for r in every_row]
    lines = [
        "# Weak scaling on paper: the 3-D pad, GAMG (issues 25 and 39)",
        "",
        f"Generated by `benchmarks/weak_scaling.py` from `benchmarks/output/weak_scaling/`; CSV: "
        f"`report/data/weak_scaling.csv`. Command: `{command}`. Ranks beyond 2 ran "
        f"oversubscribed on a 2-core machine shared with other work: no time is used, only "
        f"memory, message volumes and iteration counts. Load average (1 min) at each run's end "
        f"in the `load` column: {min(loads):.1f}–{max(loads):.1f}. MPI collectives "
        f"{'counted' if counted else 'NOT counted (library not preloaded)'} by "
        f"`benchmarks/mpi_counts.c` (PMPI).",
        "",
        "The model: the pad of `cluster/pad.json` (the Sec. 7 law with the normal and tangential "
        "penalties 1e6 and 1e5 MPa/mm, stiff against the bodies; pressed at 300 MPa and slid "
        "+-0.02 mm), within the package's validity: the runs raised "
        f"{_fmt_count(sum(r.get('validity_warnings', math.nan) for r in results))} validity "
        "warnings (`validity_warnings`).",
        "",
        "Two paths to the same pad (`path`): **gmsh** = hexahedra meshed whole by gmsh on rank 0, "
        "which hands the other ranks their parts (`meshing.create_interface_mesh`); **refined** "
        "= tetrahedra meshed coarse (`n` along the pad's side) once per size by one process and "
        "written partitioned (`meshing.write_partitioned_mesh`), read in parts "
        "(`meshing.read_partitioned_mesh`) and refined `refine` times on the ranks "
        "(`meshing.refine_interface_mesh`): no rank holds the whole model.",
        "",
    ]
    for path in paths:
        v = by_path[path]
        row = next(r for r in v["table"] if r["ranks"] == 512 and r["dofs"] == 1e8)
        limit = weak_limit(v["models"], row["dofs_per_rank"], path=path)
        first = (
            f"nothing past {NODE_MEMORY_GIB:g} GiB per rank up to {2**24:,} ranks"
            if limit is None
            else f"**{limit[0]}**, past {NODE_MEMORY_GIB:g} GiB per rank at "
            f"{limit[1]['ranks']:,} ranks ({limit[1]['dofs']:.1e} dofs)"
        )
        lines.append(
            f"- **{path}**: at 512 ranks and 1e8 dofs a rank needs {row['rss_mib']:.0f} MiB, "
            f"rank 0 {row['rss_rank0_mib']:.0f} MiB; rank 0 while the mesh is built "
            f"{row['mesh_rank0_mib']:.0f} MiB, the set-up's gathers "
            f"{row['setup_gather_mib']:.0f} MiB per rank"
            + (
                f", the conversion of its coarse model ({row['coarse_dofs']:.2g} dofs; one "
                f"process, once) {row['convert_mib']:.0f} MiB"
                if not math.isnan(row["convert_mib"])
                else ""
            )
            + f". First to stop scaling at that many dofs per rank (the ranks doubled, the "
            f"model with them): {first}."
        )
    lines += [
        "",
        "## Measured",
        "",
        "Per rank, max over ranks unless said; `n` = elements along the pad's side (the coarse "
        "model's on the refined path), `refine` = refinements on the ranks; `rss_others` = "
        "median peak RSS of ranks other than 0 (rank 0's own with 1 rank), MiB; "
        "`rss_mesh_rank0` = rank 0's peak once the mesh is built, `rss_mesh_others` the other "
        "ranks' median; `jacobian`, `gamg` = PETSc storage (MiB) of the Jacobian and of GAMG's "
        "coarser operators and interpolations; `gamg_complexity` = the nonzeros of all GAMG's "
        "operators over the Jacobian's (operator complexity); `checkpoint` = file (MiB); "
        "`pairing_received` = secondary facets a rank received to pair; `petsc_bytes_per_newton`, "
        "`petsc_reductions_per_newton` = PETSc's logged message bytes and reductions in "
        "`SNESSolve` per Newton iteration; `allreduce_calls_per_newton` = every `MPI_Allreduce` "
        "(PETSc's and the package's); `gather_bytes_per_step` = bytes of gathers, broadcasts "
        "and all-to-alls per step (none of PETSc's solve); `setup_gather_bytes` the same in the "
        "set-up (`read_gather_bytes`, `refine_gather_bytes`: the refined path's read and "
        "refinement); `profile_bytes` = what a rank receives when one interface profile is "
        "gathered on every rank; `checkpoint_rank0_bytes` = gathered on rank 0 for a "
        "checkpoint, `checkpoint_others_bytes` = allgathered or broadcast to the other ranks "
        "for it; "
        "`convert_peak_mib` = peak of the one process that meshed and wrote the coarse model.",
        "",
        *_table(MEASURED_HEAD, every_row),
        "",
    ]
    for path in paths:
        v = by_path[path]
        lines += [
            f"GAMG levels of the {path} path (global rows, finest first): "
            + "; ".join(
                f"{r['ranks']} rank(s), n {r['n']}: "
                + " → ".join(f"{lv['rows']:,}" for lv in r["gamg_levels"])
                for r in v["results"]
            )
            + f". Coarse solver: `{v['results'][-1]['coarse_pc']}`.",
            "",
            *mpi_breakdown(v["results"]),
        ]
    lines += [
        "## Extrapolated (models, not measurements)",
        "",
        *_table(EXTRA_HEAD, every_x),
        "",
        "`coarse_dofs` = the model before the ranks refine it (the model itself on the gmsh "
        "path); `rss` = a rank's peak in the run, `rss_rank0` = rank 0's, `mesh_rank0` = rank "
        "0's while the mesh is built (MiB); `setup_gather_mib` = what a rank receives in the "
        "set-up's gathers; `checkpoint_rank0_mib` = the sample rows rank 0 gathers for a "
        "checkpoint, `sort_rank0_peak_mib` = what rank 0 holds at once while it sorts them and "
        "chooses the splitters, `checkpoint_others_mib` = what every other rank receives for it; "
        "`profile_mib` = one interface profile gathered on every rank; `gather_step_kib` = the "
        "package's and DOLFINx's gathers per step and rank; `petsc_mib_per_newton` = halo "
        "exchange per Newton iteration and rank; `convert_mib` = the one process that meshes "
        "the coarse model (refined path).",
        "",
    ]
    for path in paths:
        v = by_path[path]
        lines += [
            f"## The {path} path: models (fitted to its measured rows)",
            "",
            *model_lines(v["models"], v["rows"], path, v["conversions"]),
            "",
            f"## The {path} path: first to stop scaling",
            "",
            *stop_lines(v["models"], v["table"], path),
        ]
    (report / "weak_scaling.md").write_text("\n".join(lines))
    print("\n".join(lines[lines.index("## Measured") :]))
    print(f"wrote {report / 'weak_scaling.md'}, {report / 'data' / 'weak_scaling.csv'}")
    return lines


# ------------------------------------------------------------------------------------------------


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=6, help="steps of the program")
    ap.add_argument(
        "--path",
        choices=(*PATHS, "all"),
        default="gmsh",
        help="how the model is built (gmsh: on rank 0; refined: coarse, read in parts, refined "
        "on the ranks; all: both series, one after the other)",
    )
    ap.add_argument(
        "--series",
        nargs="+",
        default=None,
        help="runs as ranks:n (gmsh) or ranks:n:k (refined: coarse n, k refinements)",
    )
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--report", type=Path, default=REPORT)
    ap.add_argument("--force", action="store_true", help="redo runs whose result exists")
    ap.add_argument("--table", action="store_true", help="only the report from the results")
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--convert-one", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--k", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.convert_one:
        convert_one(args.n, args.out)
        return
    if args.one:
        run_one(args.n, args.steps, args.out, args.path, args.k)
        return
    routes = PATHS if args.path == "all" else (args.path,)
    if args.series and len(routes) > 1:
        raise SystemExit("--series goes with one --path (gmsh or refined)")
    for route in () if args.table else routes:
        default = SERIES if route == "gmsh" else REFINED_SERIES
        series = args.series or [":".join(str(v) for v in item) for item in default]
        for item in series:
            ranks, n, *k = (int(v) for v in item.split(":"))
            if route == "refined":
                if len(k) != 1:
                    raise SystemExit(f"--series {item!r}: the refined path takes ranks:n:k")
                launch_convert(n, args.out, args.force)
            elif k:
                raise SystemExit(f"--series {item!r}: the gmsh path takes ranks:n")
            launch(ranks, n, args.steps, args.out, args.force, route, k[0] if k else 0)
        if route == "refined":  # the conversion's memory on larger coarse models
            for n in CONVERT_SIZES:
                launch_convert(n, args.out, args.force)
    command = "./run exec python3 benchmarks/weak_scaling.py --path all" + (
        f" --steps {args.steps}" if args.steps != 6 else ""
    )
    write_report(args.out, args.report, command)


if __name__ == "__main__":
    main()
