"""Time and memory of the interface pairing: the exchange of what each rank needs vs the all-gather.

For each size, one mesh is built and partitioned (DOLFINx's partitioner unless ``--partitioner``)
and both pairings are run on it, alternately:

* ``allgather``: the pairing as it was on main before issue 13 (``tests/reference_pairing.py``):
  every rank all-gathers the secondary side, Python loops over the facets;
* ``exchange``: the package's :func:`~subfric_dolfinx.fem.interface.small.pairing.pair_interface`
  (bounding boxes, ``Alltoallv`` of the secondary facets a rank needs, k-d tree).

Printed per implementation (max over ranks): wall time and CPU time per rank (best of
``--repeat``, without tracing; on a loaded machine the CPU time is the steadier one, though a rank
waiting in MPI spins and counts), the peak of Python/numpy allocations during the pairing
(``tracemalloc``, a separate run), the growth of the peak resident set during the pairing
(VmHWM reset through ``/proc/self/clear_refs`` before it; 0 when the pairing stays below the
memory the process had already touched), and the secondary facets each rank received from others.
Timing on a shared machine is noisy: compare the two rows of one size (they ran alternately in
one process), not runs made at different times.

Cases (``--case``):

* ``pad``: the 3-D pad on a plate of issue 13 (plate 2 x 2 x 0.5, pad 1 x 1 x 0.5, hexahedra,
  ``n`` elements along the pad's side; ``n**2`` interface facets);
* ``slab``: two thin slabs of the same footprint (1 x 1 x 2/n each, hexahedra, two layers of
  elements): ``n**2`` interface facets with few dofs, where the interface is a large part of the
  model (as in a lap joint).

Run from the repository root::

    ./run exec python3 benchmarks/pairing_scaling.py --case pad --n 16 28 40
    ./run exec mpirun -n 2 python3 benchmarks/pairing_scaling.py --case pad --n 16 28 40
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
import tracemalloc
from pathlib import Path

import dolfinx
import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests.reference_pairing

from subfric_dolfinx import meshing
from subfric_dolfinx.fem.interface import pair_interface
from tests import reference_pairing


def status_kib(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def reset_hwm() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def build(comm, case: str, n: int, partitioner: str | None):
    if case == "pad":
        opts = {"plate_size": (2.0, 2.0, 0.5), "pad_size": (1.0, 1.0, 0.5)}
    else:
        opts = {"plate_size": (1.0, 1.0, 2.0 / n), "pad_size": (1.0, 1.0, 2.0 / n)}
    dom, _ = meshing.create_interface_mesh(
        meshing.build_pad_on_plate,
        comm,
        partitioner=partitioner,
        n_interface=n,
        cell_type="hexahedron",
        **opts,
    )
    return dom


def run(fn, V, dom):
    t = dom.tags
    return fn(V, dom.cell_tags, dom.facet_tags, t["interface"], t["primary"], t["secondary"])


def measure(comm, impl: str, V, dom, repeat: int) -> dict:
    fn = pair_interface if impl == "exchange" else reference_pairing.pair_interface
    best, best_cpu = np.inf, np.inf
    for _ in range(repeat):
        gc.collect()
        comm.Barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        pairs = run(fn, V, dom)
        cpu = time.process_time() - c0
        dt = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        best = min(best, dt)
        best_cpu = min(best_cpu, cpu)
        del pairs
    gc.collect()
    comm.Barrier()
    rss0 = status_kib("VmRSS")
    hwm_ok = reset_hwm()
    tracemalloc.start()
    pairs = run(fn, V, dom)
    _, traced = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    hwm = status_kib("VmHWM") - rss0 if hwm_ok else -1
    n_secondary_local = dom.interface_facets("secondary", owned_only=True).size
    if impl == "exchange":
        received = pairs.n_received
    else:  # the all-gather brings every other rank's secondary facets
        received = comm.allreduce(n_secondary_local) - n_secondary_local
    return {
        "time": best,
        "cpu": comm.gather(best_cpu),
        "traced": comm.gather(traced / 2**20),
        "hwm": comm.gather(hwm / 1024.0),
        "received": comm.gather(received),
        "primaries": comm.gather(pairs.facets.size),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", choices=["pad", "slab"], default="pad")
    ap.add_argument("--n", type=int, nargs="+", default=[16, 28, 40])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--partitioner", choices=["default", "bodies", "together"], default=None)
    ap.add_argument("--only", choices=["allgather", "exchange"], default=None)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    impls = [args.only] if args.only else ["allgather", "exchange"]
    rows = []
    for n in args.n:
        t0 = time.perf_counter()
        dom = build(comm, args.case, n, args.partitioner)
        V = dolfinx.fem.functionspace(dom.mesh, ("Lagrange", 1, (3,)))
        t_mesh = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        dofs = V.dofmap.index_map.size_global * 3
        for impl in impls:
            m = measure(comm, impl, V, dom, args.repeat)
            rows.append((n, dofs, dom.num_interface_facets, impl, m, t_mesh))
            if comm.rank == 0:
                print(
                    f"[pairing] {args.case} n={n} dofs={dofs} facets={dom.num_interface_facets} "
                    f"{impl}: {m['time']:.3f} s (cpu {max(m['cpu']):.3f} s), "
                    f"traced {max(m['traced']):.1f} MiB, "
                    f"HWM +{max(m['hwm']):.1f} MiB, received {m['received']} "
                    f"(mesh {t_mesh:.1f} s, load {os.getloadavg()[0]:.1f})",
                    flush=True,
                )
        del V, dom
        gc.collect()
    if comm.rank == 0:
        print(f"\n{args.case}, {comm.size} rank(s), partitioner {args.partitioner or 'default'}\n")
        print(
            "| n | dofs | interface facets | pairing | wall s | CPU s/rank (max) | "
            "traced peak MiB/rank (max) | "
            "RSS peak growth MiB/rank (max) | secondary facets received per rank | "
            "primary facets per rank |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|")
        for n, dofs, nf, impl, m, _ in rows:
            print(
                f"| {n} | {dofs:,} | {nf:,} | {impl} | {m['time']:.3f} | "
                f"{max(m['cpu']):.3f} | "
                f"{max(m['traced']):.1f} | {max(m['hwm']):.1f} | "
                f"{', '.join(str(r) for r in m['received'])} | "
                f"{', '.join(str(r) for r in m['primaries'])} |"
            )


if __name__ == "__main__":
    main()
