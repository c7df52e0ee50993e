"""Checkpoint write and restore: wall time and memory per rank, at the size of the 3-D pad.

    ./run exec mpirun -n 2 python3 benchmarks/checkpoint_io.py --n 28 [--dir DIR] [--repeat 3]

Builds the pad-on-plate problem (hexahedra, ``--n`` elements along the pad's side; no solve),
fills the displacement and the interface state with deterministic values, then writes a
checkpoint and restores it ``--repeat`` times. Prints one line per rank count: dofs, interface
points, file size, the best write and restore times (the slowest rank's), and per rank the peak
of Python/numpy allocations during a write and during a restore (``tracemalloc``, a separate
pass: HDF5's own C allocations are not seen) and the growth of the process's peak RSS over the
whole I/O phase. The machine is shared: times are noisy, compare within one run.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
import tracemalloc
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from mpi4py import MPI

from demos import pad_on_plate
from subfric_dolfinx.fem import StepperMemory
from subfric_dolfinx.io import restore_checkpoint, write_checkpoint
from subfric_dolfinx.scenes import parse_scene
from subfric_dolfinx.scenes.build import build_mesh, build_problem


def rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", default=None)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    scene = parse_scene(pad_on_plate.scene(n=args.n, fields=None))
    problem = build_problem(scene, build_mesh(scene.mesh, comm))
    x = problem.V.tabulate_dof_coordinates()
    u = problem.u.x.array.reshape(-1, problem.gdim)
    u[:] = 1e-3 * np.sin(x[:, : problem.gdim] * 3.0)
    el = problem.interface
    st = el.state.old
    p = el.points.reshape(-1, el.gdim)
    for name in st.names:
        a = st[name]
        a[...] = (np.cos(p[:, :1] * 5.0) if a.ndim == 2 else np.cos(p[:, 0] * 5.0)) + 1.0
    memory = StepperMemory(t=1.0, step=10, dt=0.05)
    stepper = SimpleNamespace(memory=lambda: memory, restore=lambda m: None, dt_max=0.1)
    history = [{"t": 0.1 * i, "F_n": 300.0, "F_t1": 1.0 * i} for i in range(10)]
    d = Path(comm.bcast(args.dir or tempfile.mkdtemp(prefix="ckbench-"), root=0))
    path = d / "checkpoint.h5"
    rss0 = rss_mib()

    def timed(fn) -> float:
        comm.Barrier()
        t0 = time.perf_counter()
        fn()
        return comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)

    def write() -> None:
        write_checkpoint(path, problem, stepper, history)

    def restore() -> None:
        restore_checkpoint(path, problem, stepper)

    tw = min(timed(write) for _ in range(args.repeat))
    tr = min(timed(restore) for _ in range(args.repeat))

    def peak(fn) -> float:
        tracemalloc.start()
        fn()
        _, top = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return top / 2**20

    mw, mr = peak(write), peak(restore)
    grow = rss_mib() - rss0
    dofs = problem.global_dofs
    npts = comm.allreduce(p.shape[0])
    size = path.stat().st_size / 2**20 if comm.rank == 0 else 0.0
    rows = comm.gather((mw, mr, grow, rss_mib()), root=0)
    if comm.rank == 0:
        per = "; ".join(
            f"rank {r}: write {a:.1f} MiB, restore {b:.1f} MiB, RSS +{c:.0f} MiB (peak {e:.0f})"
            for r, (a, b, c, e) in enumerate(rows)
        )
        print(
            f"{comm.size} rank(s), n = {args.n}: {dofs} dofs, {npts} interface points, "
            f"file {size:.1f} MiB; write {tw:.3f} s, restore {tr:.3f} s; {per}",
            flush=True,
        )
        if args.dir is None:
            import shutil

            shutil.rmtree(d, ignore_errors=True)


if __name__ == "__main__":
    main()
