"""Peak memory of rank 0 against the other ranks: the whole model on rank 0 vs a partitioned read.

Two ways to the same fine 3-D pad on a plate (tetrahedra, plate 2 x 2 x 0.5 mm, pad 1 x 1 x
0.5 mm, ``n * 2**k`` elements along the pad's side), each in its own processes (peak resident
memory is per process)::

    B=benchmarks/partitioned_read.py
    ./run exec mpirun -n 2 python3 $B --n 6 -k 2 --mode direct
    ./run exec python3 $B --n 6 --mode convert --out scratch/pad     # once, on one process
    ./run exec mpirun -n 2 python3 $B --n 6 -k 2 --mode partitioned --out scratch/pad

* ``direct``: gmsh meshes the fine model on rank 0, which reads it and hands the other ranks
  their parts (:func:`~subfric_dolfinx.meshing.create_interface_mesh`): rank 0 holds the whole
  fine model for a while;
* ``convert``: gmsh meshes the coarse model (``n``), written as a partitioned XDMF/HDF5 mesh
  with its groups file (:func:`~subfric_dolfinx.meshing.write_partitioned_mesh`) into ``--out``;
* ``partitioned``: that mesh read back, each rank its part
  (:func:`~subfric_dolfinx.meshing.read_partitioned_mesh`), and refined ``k`` times on the
  ranks (:func:`~subfric_dolfinx.meshing.refine_interface_mesh`): no rank holds more than its
  share of the fine model, and no rank loads gmsh (without ``--out``: converted first in the same
  processes, rank 0 then also holding gmsh and the coarse model).

Printed per rank: the peak resident memory (Linux's ``ru_maxrss``) after the imports, after the
mesh, and after the problem's set-up (``--problem``: the function space, the interface pairing
and the matrix), and the ratio of rank 0's peak to the largest other rank's. No timing is
asserted; the fine mesh's sizes (cells, vertices, dofs = 3 x vertices) are printed with them.
``--out DIR`` keeps the partitioned files there (default: a temporary directory).
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path


def peak_mib() -> float:
    """This process's peak resident memory so far (MiB; ``ru_maxrss`` is in KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Rank 0's peak memory: direct vs partitioned read.")
    ap.add_argument("--n", type=int, default=6, help="elements along the pad's side (coarse)")
    ap.add_argument("-k", "--refine", type=int, default=2, help="uniform refinements")
    ap.add_argument("--mode", choices=("direct", "convert", "partitioned"), required=True)
    ap.add_argument("--problem", action="store_true", help="also set the problem up")
    ap.add_argument("--out", type=Path, default=None, help="directory of the partitioned files")
    args = ap.parse_args(argv)

    from mpi4py import MPI

    from subfric_dolfinx import meshing

    comm = MPI.COMM_WORLD
    marks = {"imports": peak_mib()}
    t0 = time.perf_counter()
    geometry = {"plate_size": (2.0, 2.0, 0.5), "pad_size": (1.0, 1.0, 0.5)}
    fine_n = args.n * 2**args.refine
    tmp = None
    if args.mode == "direct":
        dom, _ = meshing.create_interface_mesh(
            meshing.build_pad_on_plate,
            comm,
            n_interface=fine_n,
            cell_type="tetrahedron",
            **geometry,
        )
    else:
        out = args.out
        if out is None:
            tmp = comm.bcast(tempfile.mkdtemp(prefix="subfric-part-") if comm.rank == 0 else None)
            out = Path(tmp)
        xdmf = out / f"pad_{args.n}.xdmf"
        if args.mode == "convert" or args.out is None:
            out.mkdir(parents=True, exist_ok=True)
            coarse, _ = meshing.create_interface_mesh(
                meshing.build_pad_on_plate,
                comm,
                n_interface=args.n,
                cell_type="tetrahedron",
                **geometry,
            )
            meshing.write_partitioned_mesh(coarse, xdmf)
            del coarse
        if args.mode == "convert":
            if comm.rank == 0:
                print(f"wrote {xdmf}")
            return 0
        dom = meshing.read_partitioned_mesh(xdmf, comm, 3)
        dom = meshing.refine_interface_mesh(dom, args.refine)
    comm.Barrier()
    marks["mesh"] = peak_mib()
    t_mesh = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    tdim = dom.tdim
    cells = dom.mesh.topology.index_map(tdim).size_global
    vertices = dom.mesh.topology.index_map(0).size_global
    if args.problem:
        from subfric_dolfinx.constitutive import preset
        from subfric_dolfinx.fem import Dirichlet, InterfaceProblem, Material, Pressure
        from subfric_dolfinx.loading import LoadingProgram

        program = LoadingProgram([0.0, 1.0], {"press": [0.0, 1.0], "slide": [0.0, 0.0]})
        prob = InterfaceProblem(
            dom,
            preset("sec7"),
            {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)},
            program,
            [Dirichlet("bottom", (0.0, 0.0, 0.0))],
            [Pressure("top", 300.0, amplitude="press")],
        )
        comm.Barrier()
        marks["problem"] = peak_mib()
        del prob
    peaks = comm.gather(marks, root=0)
    if tmp is not None and comm.rank == 0:
        shutil.rmtree(tmp, ignore_errors=True)
    if comm.rank == 0:
        assert peaks is not None
        last = list(marks)[-1]
        others = [p[last] for p in peaks[1:]]
        ratio = peaks[0][last] / max(others) if others else 1.0
        row = {
            "mode": args.mode,
            "ranks": comm.size,
            "n": args.n,
            "refine": args.refine,
            "fine_n": fine_n,
            "cells": cells,
            "vertices": vertices,
            "dofs": 3 * vertices,
            "mesh_seconds": round(t_mesh, 2),
            "peak_mib": [{k: round(v, 1) for k, v in p.items()} for p in peaks],
            "rank0_over_others": round(ratio, 3),
        }
        print(json.dumps(row))
        for r, p in enumerate(peaks):
            print(f"rank {r}: " + ", ".join(f"{k} {v:.0f} MiB" for k, v in p.items()))
        print(
            f"{args.mode}: {cells} cells, {3 * vertices} dofs on {comm.size} rank(s); rank 0's "
            f"peak / the largest other rank's: {ratio:.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
