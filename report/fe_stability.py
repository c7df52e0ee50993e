"""Run the FE stability cases of ``tests/stability`` (under mpirun) into a JSON file.

    mpirun -n R python3 report/fe_stability.py OUT.json    (the repository root on PYTHONPATH)

The same cases are asserted by ``tests/verification/test_stability.py``; here their outcomes are
recorded (rank 0 writes), with the wall time of each case (max over ranks).
"""

import json
import sys
import time
from pathlib import Path

from mpi4py import MPI

from tests.stability import FE_CASES


def main():
    """Run every FE stability case on this communicator; write the outcomes (rank 0)."""
    comm = MPI.COMM_WORLD
    out = {}
    for case in FE_CASES:
        comm.Barrier()
        t0 = time.perf_counter()
        o = case.run(comm)
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        d = o.to_dict()
        # per-step series are not needed in the report
        d["data"] = {k: v for k, v in d["data"].items() if k not in ("sep", "t", "ft_mean")}
        try:
            case.check(o)
            d["check"] = "ok"
        except AssertionError as e:
            d["check"] = f"FAILED: {e}"
        d["passed"] = bool(o.outcome == case.expect and o.nan_free and d["check"] == "ok")
        d["wall"] = wall
        d["ranks"] = comm.size
        out[case.name] = d
        if comm.rank == 0:
            print(
                f"[fe_stability] {comm.size} rank(s) {case.name}: {o.outcome} "
                f"({'as expected' if d['passed'] else 'NOT as expected'}), {wall:.2f} s",
                flush=True,
            )
    if comm.rank == 0:
        Path(sys.argv[1]).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
