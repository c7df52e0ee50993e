"""A model no rank holds whole: the cluster scene's 3-D pad built by refinement on the ranks.

The scene of ``cluster/pad.json`` (the pad on a plate, the Sec. 7 law with a normal penalty
stiff against the bodies, pressed at 300 MPa and slid +-0.02 mm over 100 steps: about 1.3
interface elements, within small sliding's validity; GAMG) on tetrahedra: meshed coarse once
(``n`` elements along the pad's side, gmsh, one process), written in DOLFINx's partitioned
format, then read in parts and refined ``k`` times on the ranks (``mesh.refine``), so that the
fine model never exists on one rank::

    B=benchmarks/large_model.py
    ./run exec python3 $B --convert --n 8 --out scratch/large          # once, one process
    ./run exec mpirun -n 2 python3 $B --n 8 -k 3 --out scratch/large   # ~2.5M dofs

Printed (rank 0, and as one JSON line): the fine model's sizes, the wall time of the mesh
(read + refinement), the set-up and the steps, Newton's iterations, the validity warnings the
run raised (none expected), and the peak resident memory of every rank (Linux's
``ru_maxrss``) with rank 0's over the largest other rank's. ``--end T`` ends the program at
time ``T`` (the same steps up to it) for a quick look; ``--direct N`` runs the scene as written
instead (hexahedra meshed by gmsh on rank 0, ``N`` along the pad: 28 gives 184,050 dofs), the
baseline of the same program. Nothing is asserted; the load average before and after is printed.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import resource
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "cluster" / "pad.json"
GEOMETRY = {"plate_size": (2.0, 2.0, 0.5), "pad_size": (1.0, 1.0, 0.5)}


def peak_mib() -> float:
    """This process's peak resident memory so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def convert(n: int, out: Path) -> Path:
    """Mesh the coarse pad (tetrahedra, ``n`` along the pad) and write it partitioned."""
    from mpi4py import MPI

    from subfric_dolfinx import meshing

    out.mkdir(parents=True, exist_ok=True)
    xdmf = out / f"pad_tet_{n}.xdmf"
    coarse, _ = meshing.create_interface_mesh(
        meshing.build_pad_on_plate,
        MPI.COMM_WORLD,
        n_interface=n,
        cell_type="tetrahedron",
        **GEOMETRY,
    )
    meshing.write_partitioned_mesh(coarse, xdmf)
    return xdmf


def scene_for(xdmf: Path, refine: int, end: float | None, direct: int | None = None) -> dict:
    """``cluster/pad.json`` on the partitioned coarse mesh refined ``refine`` times.

    ``direct``: on the scene's own mesh instead (gmsh, ``direct`` elements along the pad).
    """
    scene = copy.deepcopy(json.loads(SCENE.read_text()))
    if direct is None:
        scene["name"] = f"{scene['name']}_refined"
        scene["mesh"] = {"file": str(xdmf), "gdim": 3, "refine": refine}
    else:
        scene["mesh"]["options"]["n_interface"] = direct
    if end is not None:
        import numpy as np

        times = scene["program"]["times"]
        channels = scene["program"]["channels"]
        kept = [t for t in times if t < end] + [end]
        scene["program"]["channels"] = {
            key: [float(v) for v in np.interp(kept, times, values)]
            for key, values in channels.items()
        }
        scene["program"]["times"] = kept
    return scene


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=8, help="coarse elements along the pad's side")
    ap.add_argument("-k", "--refine", type=int, default=3, help="refinements on the ranks")
    ap.add_argument("--out", type=Path, required=True, help="directory of the mesh and the run")
    ap.add_argument("--convert", action="store_true", help="only write the coarse mesh")
    ap.add_argument(
        "--direct",
        type=int,
        default=None,
        metavar="N",
        help="instead: the scene as written (hexahedra meshed by gmsh on rank 0), N along the pad",
    )
    ap.add_argument("--end", type=float, default=None, help="end the program here (a look)")
    ap.add_argument(
        "--option",
        nargs=2,
        action="append",
        default=[],
        metavar=("KEY", "VALUE"),
        help="a PETSc option under the scene's prefix (the scene's solver.options)",
    )
    args = ap.parse_args(argv)

    if args.convert:
        print(f"wrote {convert(args.n, args.out)}")
        return 0

    from mpi4py import MPI

    from subfric_dolfinx.scenes import run_scene

    comm = MPI.COMM_WORLD
    xdmf = args.out / f"pad_tet_{args.n}.xdmf"
    if args.direct is None and not xdmf.exists():
        raise SystemExit(f"{xdmf} does not exist: run with --convert first")
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = scene_for(xdmf, args.refine, args.end, args.direct)
        scene["solver"].setdefault("options", {}).update(dict(args.option))
        result = run_scene(
            scene,
            outdir=args.out
            / (f"run_{args.n}_{args.refine}" if args.direct is None else f"run_hex_{args.direct}"),
            comm=comm,
        )
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    names = sorted({f"{w.category.__name__}: {w.message}"[:160] for w in caught})
    peaks = comm.gather(peak_mib(), root=0)
    if comm.rank == 0:
        assert peaks is not None
        ratio = peaks[0] / max(peaks[1:]) if len(peaks) > 1 else 1.0
        row = {
            "ranks": comm.size,
            "n": args.n,
            "refine": args.refine,
            "info": {k: v for k, v in result.info.items() if not isinstance(v, dict)},
            "steps": len(result.iterations),
            "newton_total": int(sum(result.iterations)),
            "newton_max": int(max(result.iterations, default=0)),
            "timing": {k: round(v, 1) for k, v in result.timing.items()},
            "wall_seconds": round(wall, 1),
            "peak_mib": [round(p, 1) for p in peaks],
            "rank0_over_others": round(ratio, 3),
            "warnings": names,
            "load_before_after": [round(load_before, 2), round(os.getloadavg()[0], 2)],
        }
        print(json.dumps(row))
        print(
            f"{row['info'].get('dofs')} dofs on {comm.size} ranks: {row['steps']} steps, "
            f"Newton {row['newton_total']} (max {row['newton_max']}) in {wall:.0f} s; peak "
            + " / ".join(f"{p:.0f}" for p in peaks)
            + f" MiB (rank 0 / largest other {ratio:.2f}); warnings: {len(names)}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
