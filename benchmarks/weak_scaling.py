"""Weak scaling on paper (issue 25 item 4): what 64 and 512 ranks would need for 1e7 and 1e8 dofs.

The 3-D pad on a plate of ``benchmarks/fe_scaling.py`` (its problem, :func:`fe_scaling.build_pad`,
strategy ``"gamg"``) at about 25k dofs per rank on 1, 2, 4 and 8 ranks (4 and 8 oversubscribed on
this 2-core machine: the times mean nothing, only what does not depend on the machine being
oversubscribed is recorded), plus 1 rank at about 10k dofs (to separate the fixed and the per-dof
memory) and 2 ranks at 184k (to separate the whole model's size from the rank count), over a
short program (``--steps``, default 6: press, slide, back). Per run and rank:

* memory: peak RSS after the mesh, after the set-up and at the end; the Jacobian's PETSc storage
  (``Mat.getInfo``); the GAMG hierarchy (every level's operator and interpolation); the
  checkpoint's bytes (one ``write_checkpoint`` at the end);
* communication: PETSc's logged messages, bytes and reductions of ``KSPSolve``, ``PCSetUp``,
  ``PCApply``, ``MatMult`` and ``SNESSolve`` over the steps (a log stage of their own); and every
  MPI collective of the process (``benchmarks/mpi_counts.c``, a PMPI library preloaded into the
  ranks: calls and bytes of ``Allreduce``, ``Allgather(v)``, ``Gather(v)``, ``Bcast``,
  ``Alltoall(v)``, neighbour exchanges; from mpi4py, DOLFINx and PETSc alike) for four phases:
  set-up (mesh, pairing, problem), the steps, one interface profile
  (``scenes.outputs.interface_profile``, what a scene's ``profile`` output gathers each output step)
  and one checkpoint;
* the pairing's exchange (secondary facets received, extra ghosts), GAMG's levels and coarse grid,
  Newton and Krylov iterations.

Then per-part models are fitted (:func:`fit_models`) and extrapolated (:func:`extrapolate`) to 64
and 512 ranks at 1e7 and 1e8 dofs, and the first part to stop scaling is named from the numbers
(:func:`first_to_break`)::

    ./run exec python3 benchmarks/weak_scaling.py            # runs, then report/weak_scaling.md
    ./run exec python3 benchmarks/weak_scaling.py --table    # only the table from the results

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
TARGETS = ((64, 1e7), (512, 1e7), (64, 1e8), (512, 1e8))
EVENTS = ("SNESSolve", "KSPSolve", "PCSetUp", "PCApply", "MatMult")
PHASES = ("setup", "steps", "profile", "checkpoint")
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


def measure(comm, n: int, steps: int, scratch: Path) -> dict:
    """One weak-scaling run on ``comm``: memory, communication and solver counts (collective).

    Args:
        comm: The communicator (its size is the rank count).
        n: Hexahedra along the pad's side (:func:`fe_scaling.dofs_of`).
        steps: Steps of the program (:func:`fe_scaling.program_points`).
        scratch: Directory for the checkpoint file (removed after).

    Returns:
        A JSON-ready record; per-rank values as lists over ranks (every rank gets it).
    """
    from petsc4py import PETSc

    from subfric_dolfinx.fem import LoadStepper, StepControl
    from subfric_dolfinx.io import write_checkpoint
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
    pad = fe_scaling.build_pad(comm, n, "gamg", steps)
    stages["setup"].pop()
    phase("setup")
    problem, solver = pad.problem, pad.solver
    rss_setup = fe_scaling.peak_rss_mib()
    try:
        stepper = LoadStepper(solver, 10.0, control=StepControl(dt_max=10.0), predictor=True)
        stages["steps"].push()
        stepper.run()
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
            "steps_program": steps,
            "dofs": problem.global_dofs,
            "interface_points": comm.allreduce(el.n_elements * el.nq),
            "steps": len(stepper.records),
            "newton": newton,
            "krylov": int(solver.linear.krylov),  # every Krylov solve of the run
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


def run_one(n: int, steps: int, out: Path) -> None:
    from mpi4py import MPI

    from subfric_dolfinx import logs

    comm = MPI.COMM_WORLD
    logs.configure(-1, comm)
    scratch = out / "scratch"
    if comm.rank == 0:
        scratch.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    r = measure(comm, n, steps, scratch)
    if comm.rank == 0:
        (out / f"{tag_of(comm.size, n, steps)}.json").write_text(json.dumps(r, indent=1))
        row = row_of(r)
        print(
            f"[{tag_of(comm.size, n, steps)}] {r['dofs']:,} dofs, {row['dofs_per_rank']:.0f} "
            f"per rank: Newton {r['newton']}, Krylov/Newton {row['krylov_per_newton']:.1f}, "
            f"peak RSS {row['rss_max_mib']:.0f} MiB (rank 0: {row['rss_rank0_mib']:.0f}), "
            f"GAMG levels {len(r['gamg_levels'])} (coarse {row['coarse_rows']} rows)",
            flush=True,
        )


def tag_of(ranks: int, n: int, steps: int) -> str:
    return f"weak_r{ranks}_n{n}_s{steps}"


def launch(ranks: int, n: int, steps: int, out: Path, force: bool) -> dict | None:
    path = out / f"{tag_of(ranks, n, steps)}.json"
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
    return {
        "ranks": r["ranks"],
        "n": r["n"],
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
        "jacobian_mib": max(p["jacobian_memory"] for p in pr) / mib,
        "gamg_mib": max(p["gamg_memory"] for p in pr) / mib,
        "gamg_levels": len(r["gamg_levels"]),
        "coarse_rows": r["gamg_levels"][-1]["rows"],
        "coarse_nz": r["gamg_levels"][-1]["nz"],
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
        "profile_bytes": max(_mpi_bytes(p, "profile", GATHERS) for p in pr),
        "checkpoint_rank0_bytes": _mpi_bytes(pr[0], "checkpoint", ("Gather", "Gatherv")),
        "load": r["load"][0],
    }


COLUMNS = [
    "ranks",
    "n",
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
    "jacobian_mib",
    "gamg_mib",
    "gamg_levels",
    "coarse_rows",
    "coarse_nz",
    "checkpoint_mib",
    "pairing_received",
    "petsc_bytes_per_newton",
    "petsc_messages_per_newton",
    "petsc_reductions_per_newton",
    "allreduce_calls_per_newton",
    "gather_bytes_per_step",
    "gather_calls_per_step",
    "setup_gather_bytes",
    "profile_bytes",
    "checkpoint_rank0_bytes",
    "load",
]


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
        mesh: (e MiB, f MiB per dof): rank 0's peak once the mesh is built, over ``start``,
            = e + f dofs (gmsh meshes the whole model on rank 0, which hands it out).
        setup_gather: (k, alpha, beta): bytes a rank receives in gathers during the set-up =
            k dofs^alpha ranks^beta (least squares in logs, runs on several ranks).
        checkpoint_rank0: Bytes rank 0 gathers (``Gather(v)``) per interface point when a
            checkpoint is written (the interface's coordinates, sorted there into the file's rows).
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
    mesh: tuple[float, float]
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


def fit_models(rows: list[dict], levels: list[list[int]]) -> Models:
    """Fit the per-part models to the measured rows.

    Args:
        rows: :func:`row_of` of every run.
        levels: For every run, the global rows of its GAMG levels, finest first.
    """
    import numpy as np

    d = [r["dofs_per_rank"] for r in rows]
    many = [r for r in rows if r["ranks"] > 1] or rows
    widest = max(rows, key=lambda r: (r["ranks"], r["dofs"]))
    excess = _median([r["rss_rank0_mib"] - r["rss_others_mib"] for r in many])
    own = [r["rss_others_mib"] if r["ranks"] > 1 else r["rss_rank0_mib"] - excess for r in rows]
    ratios = [a / b for lv in levels for a, b in itertools.pairwise(lv) if b > 0]
    gathered = [r for r in many if r["setup_gather_bytes"] > 0]
    return Models(
        memory=fit_line(d, own),
        rank0_excess=excess,
        start=_median([r["rss_start_mib"] for r in rows]),
        mesh=fit_line(
            [r["dofs"] for r in rows], [r["rss_mesh_rank0_mib"] - r["rss_start_mib"] for r in rows]
        ),
        setup_gather=fit_power(
            [r["dofs"] for r in gathered],
            [r["ranks"] for r in gathered],
            [r["setup_gather_bytes"] for r in gathered],
        )
        if gathered
        else (0.0, 0.0, 0.0),
        checkpoint_rank0=fit_proportional(
            [r["interface_points"] for r in rows], [r["checkpoint_rank0_bytes"] for r in rows]
        ),
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
    return {
        "ranks": ranks,
        "dofs": dofs,
        "dofs_per_rank": d,
        "rss_mib": rss,
        "rss_rank0_mib": rss + m.rank0_excess,
        "start_mib": m.start,
        "mesh_rank0_mib": m.start + m.mesh[0] + m.mesh[1] * dofs,
        "setup_gather_mib": k * dofs**alpha * ranks**beta / mib,
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
        "checkpoint_rank0_mib": m.checkpoint_rank0 * iface / mib,
    }


def first_to_break(table: list[dict], node_gib: float = NODE_MEMORY_GIB) -> tuple[str, str]:
    """The first part whose need exceeds a node's memory per rank, and why (a number).

    Each part adds to a rank's memory: the distributed parts (``rss_mib``, every rank), rank 0's
    mesh (``mesh_rank0_mib`` over ``start_mib``, the memory before it: gmsh builds and hands out
    the whole mesh from rank 0), the partitioner's set-up gathers (``setup_gather_mib``, every
    rank, over ``start_mib``), an interface profile gathered on every rank (``profile_mib``), the
    checkpoint's interface rows on rank 0 (``checkpoint_rank0_mib``). In the smallest model
    (then the fewest ranks) where a rank's total exceeds ``node_gib``, the largest part on that
    rank is named. If no rank ever exceeds it, the part that grows most from the smallest model
    on the fewest ranks to the largest on the most (the weak direction of the table) is named,
    with its factor (parts under 1 MiB there are left out: they stop nothing).
    """
    limit = node_gib * 1024.0

    def m_start(row: dict) -> float:
        return row.get("start_mib", 0.0)

    def parts(row: dict) -> dict[str, tuple[float, float]]:
        """Part -> (its MiB, the total of the rank it sits on)."""
        rss, rank0, mesh = row["rss_mib"], row["rss_rank0_mib"], row["mesh_rank0_mib"]
        return {
            "the per-rank memory of the distributed parts": (rss, rss),
            "rank 0's mesh (gmsh builds and distributes the whole mesh from rank 0)": (
                mesh - m_start(row),
                mesh,
            ),
            "the partitioner's gathers in the set-up (DOLFINx's PT-Scotch partitioning)": (
                row["setup_gather_mib"],
                m_start(row) + row["setup_gather_mib"],
            ),
            "an interface profile gathered on every rank": (
                row["profile_mib"],
                rss + row["profile_mib"],
            ),
            "the checkpoint's interface rows (coordinates gathered and sorted on rank 0)": (
                row["checkpoint_rank0_mib"],
                rank0 + row["checkpoint_rank0_mib"],
            ),
        }

    for row in sorted(table, key=lambda r: (r["dofs"], r["ranks"])):
        over = {p: v for p, v in parts(row).items() if v[1] > limit}
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
    a, b = parts(lo), parts(hi)
    growth = {p: b[p][0] / a[p][0] for p in a if a[p][0] > 0 and b[p][0] >= 1.0}  # MiB
    part = max(growth, key=growth.get)
    return part, (
        f"grows {growth[part]:.1f}x from {lo['dofs']:.0e} dofs on {lo['ranks']} ranks "
        f"to {hi['dofs']:.0e} on {hi['ranks']} (dofs per rank "
        f"{hi['dofs_per_rank'] / lo['dofs_per_rank']:.2f}x), within {node_gib:g} GiB "
        "per rank"
    )


# ------------------------------------------------------------------------------------------------
# Report


def _fmt(v) -> str:
    return fe_scaling._fmt(v)


MEASURED_HEAD = [
    "ranks",
    "dofs",
    "dofs_per_rank",
    "interface_points",
    "newton",
    "krylov_per_newton",
    "rss_others_mib",
    "rss_rank0_mib",
    "rss_mesh_rank0_mib",
    "jacobian_mib",
    "gamg_mib",
    "gamg_levels",
    "coarse_rows",
    "checkpoint_mib",
    "pairing_received",
    "petsc_bytes_per_newton",
    "petsc_reductions_per_newton",
    "allreduce_calls_per_newton",
    "gather_bytes_per_step",
    "setup_gather_bytes",
    "profile_bytes",
    "checkpoint_rank0_bytes",
    "load",
]
EXTRA_HEAD = [
    "ranks",
    "dofs",
    "dofs_per_rank",
    "rss_mib",
    "rss_rank0_mib",
    "mesh_rank0_mib",
    "setup_gather_mib",
    "jacobian_mib",
    "gamg_mib",
    "interface_points",
    "profile_mib",
    "checkpoint_rank0_mib",
    "gather_step_kib",
    "petsc_mib_per_newton",
    "krylov_per_newton",
    "reductions_per_newton",
    "gamg_levels",
    "coarse_rows",
    "checkpoint_gib",
    "checkpoint_mib_per_rank",
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
    funcs = sorted({f for p in pr for ph in PHASES for f in p["mpi"].get(ph, {})})
    head = ["phase", *funcs]
    out = [
        f"MPI collectives of the run on {r['ranks']} ranks ({r['dofs']:,} dofs), per phase: "
        f"calls / KiB a rank contributes or receives, max over ranks (the steps: all "
        f"{r['steps']} steps, {r['newton']} Newton iterations):",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for ph in PHASES:
        cells = []
        for f in funcs:
            c = max(p["mpi"].get(ph, {}).get(f, [0, 0])[0] for p in pr)
            b = max(p["mpi"].get(ph, {}).get(f, [0, 0])[1] for p in pr)
            cells.append(f"{c:.0f} / {b / 1024:.1f}" if c else "—")
        out.append(f"| {ph} | " + " | ".join(cells) + " |")
    return [*out, ""]


def write_report(out: Path, report: Path, command: str) -> list[str]:
    results = [json.loads(p.read_text()) for p in sorted(out.glob("weak_r*.json"))]
    if not results:
        print(f"no results in {out}")
        return []
    results.sort(key=lambda r: (r["ranks"], r["n"]))
    rows = [row_of(r) for r in results]
    models = fit_models(rows, [[lv["rows"] for lv in r["gamg_levels"]] for r in results])
    table = [extrapolate(models, p, nd) for p, nd in TARGETS]
    part, why = first_to_break(table)
    (report / "data").mkdir(parents=True, exist_ok=True)
    with open(report / "data" / "weak_scaling.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["kind", *dict.fromkeys(COLUMNS + list(table[0]))])
        w.writeheader()
        for r in rows:
            w.writerow({"kind": "measured", **r})
        for r in table:
            w.writerow({"kind": "extrapolated", **r})
    weak = [r for r in rows if r["n"] != min(x["n"] for x in rows) or r["ranks"] > 1]
    kry = [r["krylov_per_newton"] for r in weak]
    counted = all(r["mpi_counted"] for r in results)
    m = models
    lines = [
        "# Weak scaling on paper: the 3-D pad, GAMG (issue 25 item 4)",
        "",
        f"Generated by `benchmarks/weak_scaling.py` from `benchmarks/output/weak_scaling/`; CSV: "
        f"`report/data/weak_scaling.csv`. Command: `{command}`. Load average (1 min) at each "
        f"run's end in the `load` column. Ranks beyond 2 ran oversubscribed on a 2-core machine: "
        f"no time is used, only memory, message volumes and iteration counts. MPI collectives "
        f"{'counted' if counted else 'NOT counted (library not preloaded)'} by "
        f"`benchmarks/mpi_counts.c` (PMPI).",
        "",
        "## Measured",
        "",
        "Per rank, max over ranks unless said; `rss_others` = median peak RSS of ranks other than "
        "0 (rank 0's own with 1 rank), MiB; `rss_mesh_rank0` = rank 0's peak once the mesh is "
        "built; `jacobian`, `gamg` = PETSc storage (MiB) of the Jacobian and of GAMG's coarser "
        "operators and interpolations; `checkpoint` = file (MiB); `pairing_received` = "
        "secondary facets a rank received to pair; `petsc_bytes_per_newton`, "
        "`petsc_reductions_per_newton` = PETSc's logged message bytes and reductions in "
        "`SNESSolve` per Newton iteration; "
        "`allreduce_calls_per_newton` = every `MPI_Allreduce` (PETSc's and the package's); "
        "`gather_bytes_per_step` = bytes of gathers, broadcasts and all-to-alls per step (none of "
        "PETSc's solve); `setup_gather_bytes` the same in the set-up; `profile_bytes` = what a "
        "rank receives when one interface profile is gathered on every rank.",
        "",
        *_table(MEASURED_HEAD, rows),
        "",
        "GAMG levels (global rows, finest first): "
        + "; ".join(
            f"{r['ranks']} rank(s), n {r['n']}: "
            + " → ".join(f"{lv['rows']:,}" for lv in r["gamg_levels"])
            for r in results
        )
        + f". Coarse solver: `{results[-1]['coarse_pc']}`.",
        "",
        *mpi_breakdown(results),
        "## Models (fitted to the measured rows)",
        "",
        f"- peak memory of a rank = {m.memory[0]:.0f} MiB + {m.memory[1] * 1e3:.3f} MiB per 1000 "
        f"dofs of the rank; rank 0's peak is {m.rank0_excess:.0f} MiB more (median on several "
        f"ranks); {m.start:.0f} MiB before the mesh;",
        f"- rank 0 while the mesh is built (gmsh meshes the whole model there, then DOLFINx hands "
        f"it out): {m.mesh[0]:.0f} MiB + {m.mesh[1] * 1e6:.0f} MiB per million global dofs over "
        f"the memory before it;",
        f"- gathers in the set-up (bytes received per rank) = {m.setup_gather[0]:.3g} dofs^"
        f"{m.setup_gather[1]:.2f} ranks^{m.setup_gather[2]:.2f} (runs on ≥ 2 ranks). Nearly "
        f"all of it is one `MPI_Allgatherv` in DOLFINx's cell partitioner: PT-Scotch's "
        f"multilevel bipartition (`SCOTCH_dgraphPart` → `bdgraphBipartSq` → `dgraphGatherAll`) "
        f"gathers its coarsened graph on every rank; it coarsens a larger graph further before "
        f"gathering it, so on models far beyond the measured ones (at most "
        f"{max(r['dofs'] for r in results):,} dofs) this power law is an upper bound;",
        f"- Jacobian {m.jacobian * 1e3:.3f} MiB and GAMG hierarchy {m.gamg * 1e3:.3f} MiB per 1000 "
        f"dofs of a rank; checkpoint {m.checkpoint:.1f} bytes per global dof;",
        f"- interface points = {m.interface_per_dof23:.3f} dofs^(2/3) (the pad's interface is a "
        f"surface); an interface profile brings {m.profile:.0f} bytes per interface point to "
        f"every rank;",
        f"- gathers and broadcasts per step and rank = {m.gather_step[0]:.0f} + "
        f"{m.gather_step[1]:.1f} × ranks bytes;",
        f"- PETSc halo bytes per Newton iteration and rank = {m.petsc_halo:.0f} × "
        f"(dofs per rank)^(2/3) (the run on the most ranks);",
        f"- a checkpoint gathers {m.checkpoint_rank0:.0f} bytes per interface point on rank 0;",
        f"- Krylov iterations per Newton = {m.krylov[0]:.1f} + {m.krylov[1]:.2f} log10(dofs) "
        f"(measured {min(kry):.1f}–{max(kry):.1f} over the weak series); "
        f"{m.reductions:.1f} `MPI_Allreduce` calls per Krylov iteration;",
        f"- GAMG coarsens by {m.coarsening:.1f} per level; coarsest grid ≤ {m.coarse_rows} rows "
        f"(largest measured; PETSc's coarse-size limit holds it there as the model grows).",
        "",
        "## Extrapolated (models, not measurements)",
        "",
        *_table(EXTRA_HEAD, table),
        "",
        "`rss` = a rank's peak in the run, `rss_rank0` = rank 0's, `mesh_rank0` = rank 0's "
        "while the mesh is built (MiB); `setup_gather_mib` = what a rank receives in the set-up's "
        "gathers; `checkpoint_rank0_mib` = the interface coordinates rank 0 gathers and sorts "
        "for a checkpoint; "
        "`profile_mib` = one interface profile gathered on every rank; `gather_step_kib` = the "
        "package's and DOLFINx's gathers per step and rank; `petsc_mib_per_newton` = halo "
        "exchange per Newton iteration and rank.",
        "",
        "## First to stop scaling",
        "",
        f"**{part}**: {why}.",
        "",
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
        "--series",
        nargs="+",
        default=[f"{r}:{n}" for r, n in SERIES],
        help="runs as ranks:n (n hexahedra along the pad's side)",
    )
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--report", type=Path, default=REPORT)
    ap.add_argument("--force", action="store_true", help="redo runs whose result exists")
    ap.add_argument("--table", action="store_true", help="only the report from the results")
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        run_one(args.n, args.steps, args.out)
        return
    if not args.table:
        for item in args.series:
            ranks, n = (int(v) for v in item.split(":"))
            launch(ranks, n, args.steps, args.out, args.force)
    command = "./run exec python3 benchmarks/weak_scaling.py" + (
        f" --steps {args.steps}" if args.steps != 6 else ""
    )
    write_report(args.out, args.report, command)


if __name__ == "__main__":
    main()
