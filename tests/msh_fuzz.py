"""Mutants of the stored meshes for fuzzing the mesh reader (issue 23, item 2).

:func:`mutants` yields damaged copies of an MSH file: truncations at random bytes, counts of the
section and block headers changed (0, one less or more, half, double, huge, negative, NaN, not a
number), numbers anywhere changed the same way, deleted or doubled, and for binary files bytes
overwritten. :func:`fuzz` feeds each one to :func:`~subfric_dolfinx.meshing.read_interface_mesh`
in this process (gmsh parses a file only after the reader's checks: a crash would end the
process) and counts the outcomes. Every rank makes the same mutants (a seeded generator).

As a script, the full run (the in-suite test runs a few hundred): ``./run exec python3 -m
tests.msh_fuzz [--mutants 1200] [--seed 0]`` on 1 rank, or under ``mpirun -n 2``; it also
fuzzes binary and format 2.2 copies of the stored meshes (written by gmsh), and prints the
counts per kind of mutation and outcome.
"""

from __future__ import annotations

import argparse
import collections
import re
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from tests.helpers import MESH_DIR

STORED = {
    "block_on_base_tri.msh": 2,
    "block_on_base_quad.msh": 2,
    "pad_on_plate_tet.msh": 3,
    "pad_on_plate_hex.msh": 3,
}
_NUMBER = re.compile(rb"-?[0-9][0-9.eE+-]*")
_REPLACEMENTS = [
    b"0",
    b"-1",
    b"1e20",
    b"160000000000",
    b"18446744073709551615",
    b"nan",
    b"inf",
    b"1e308",
    b"-7",
    b"x",
    b"2147483648",
    b"4.5",
]


def _count_lines(text: bytes) -> list[tuple[int, int]]:
    """(start, end) of the lines holding counts: the first line of each section, and the block
    headers of $Nodes and $Elements (4 integers)."""
    spans = []
    pos = 0
    after_section = False
    for line in text.split(b"\n"):
        end = pos + len(line)
        stripped = line.strip()
        if after_section or (len(stripped.split()) == 4 and b"." not in stripped):
            spans.append((pos, end))
        after_section = stripped.startswith(b"$") and not stripped.startswith(b"$End")
        pos = end + 1
    return spans


def _change(token: bytes, rng: np.random.Generator) -> bytes:
    kind = rng.integers(6)
    try:
        v = int(token)
    except ValueError:
        v = None
    if kind == 0 and v is not None:
        return str(v + int(rng.choice([-1, 1]))).encode()
    if kind == 1 and v is not None:
        return str(int(v * rng.choice([0.5, 2.0, 10.0]))).encode()
    return _REPLACEMENTS[rng.integers(len(_REPLACEMENTS))]


def mutants(data: bytes, n: int, rng: np.random.Generator) -> Iterator[tuple[str, bytes]]:
    """``n`` damaged copies of ``data`` with the kind of damage: ``truncate``, ``count``,
    ``number``, ``delete``, ``double`` (ASCII), ``bytes`` (binary files)."""
    binary = b"\n" in data[:40] and data.split(b"\n")[1].split()[1:2] == [b"1"]
    ascii_counts = _count_lines(data) if not binary else []
    numbers = [m.span() for m in _NUMBER.finditer(data)] if not binary else []
    for _ in range(n):
        kind = rng.choice(
            ["truncate", "bytes"]
            if binary
            else ["truncate", "count", "count", "number", "delete", "double"]
        )
        if kind == "truncate":
            yield kind, data[: int(rng.integers(1, len(data)))]
        elif kind == "bytes":
            b = bytearray(data)
            for _ in range(int(rng.integers(1, 4))):
                at = int(rng.integers(40, len(b) - 8))
                b[at : at + 8] = rng.integers(0, 256, 8, dtype=np.uint8).tobytes()
            yield kind, bytes(b)
        else:
            if kind == "count":
                lo, hi = ascii_counts[rng.integers(len(ascii_counts))]
                tokens = [m.span() for m in _NUMBER.finditer(data, lo, hi)]
                if not tokens:
                    continue
                s, e = tokens[rng.integers(len(tokens))]
            else:
                s, e = numbers[rng.integers(len(numbers))]
            token = data[s:e]
            new = {"delete": b"", "double": token + b" " + token}.get(kind, None)
            if new is None:
                new = _change(token, rng)
            yield kind, data[:s] + new + data[e:]


def fuzz(
    sources: list[tuple[Path, int]], per_file: int, seed: int, workdir: Path
) -> collections.Counter:
    """Read ``per_file`` mutants of each (file, gdim) (collective); the outcome counts.

    Outcomes: ``accepted`` (read, a valid mesh), ``refused`` (``InterfaceMeshError``, the same
    message on every rank), anything else ``<Type>: <message>`` (a failure of the test). The
    mutant files are written by rank 0 into ``workdir``.
    """
    comm = MPI.COMM_WORLD
    rng = np.random.default_rng(seed)
    out: collections.Counter = collections.Counter()
    for k, (src, gdim) in enumerate(sources):
        data = src.read_bytes()
        for i, (kind, mutant) in enumerate(mutants(data, per_file, rng)):
            path = workdir / f"m{k}_{i}.msh"
            if comm.rank == 0:
                path.write_bytes(mutant)
            comm.Barrier()
            try:
                meshing.read_interface_mesh(path, comm, gdim)
                outcome = "accepted"
            except meshing.InterfaceMeshError as e:
                outcome = "refused"
                messages = comm.allgather(str(e))
                if len(set(messages)) != 1 or not str(e).strip():
                    outcome = f"unclear: {messages}"
            except Exception as e:  # a failure of the reader
                outcome = f"{type(e).__name__}: {e}"[:300]
            out[(kind, outcome)] += 1
            comm.Barrier()
            if comm.rank == 0:
                if outcome in ("accepted", "refused"):
                    path.unlink()
                else:  # kept for a look
                    path.rename(workdir / f"failed_{kind}_{k}_{i}.msh")
    return out


def variants(workdir: Path) -> list[tuple[Path, int]]:
    """Binary and format 2.2 copies of the stored meshes, written by gmsh (rank 0)."""
    comm = MPI.COMM_WORLD
    out = []
    if comm.rank == 0:
        import gmsh

        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Verbosity", 1)
    for name, gdim in STORED.items():
        for version, binary in ((4.1, 1), (2.2, 0), (2.2, 1)):
            path = workdir / f"{Path(name).stem}_{version}_{binary}.msh"
            if comm.rank == 0:
                gmsh.clear()
                gmsh.open(str(MESH_DIR / name))
                gmsh.option.setNumber("Mesh.MshFileVersion", version)
                gmsh.option.setNumber("Mesh.Binary", binary)
                gmsh.write(str(path))
            out.append((path, gdim))
    if comm.rank == 0:
        gmsh.finalize()
    comm.Barrier()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mutants", type=int, default=1200, help="mutants in all")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    work = Path(comm.bcast(tempfile.mkdtemp(prefix="msh-fuzz-") if comm.rank == 0 else None))
    sources = [(MESH_DIR / n, g) for n, g in STORED.items()] + variants(work)
    per_file = -(-args.mutants // len(sources))
    t0 = time.perf_counter()
    counts = fuzz(sources, per_file, args.seed, work)
    wall = time.perf_counter() - t0
    total = sum(counts.values())
    bad = {k: v for k, v in counts.items() if k[1] not in ("accepted", "refused")}
    if comm.rank == 0:
        print(f"{total} mutants of {len(sources)} files on {comm.size} rank(s) in {wall:.1f} s")
        for (kind, outcome), v in sorted(counts.items()):
            print(f"  {kind:9s} {outcome[:100]:100s} {v}")
        print(
            f"FAILED (the mutants are kept in {work})"
            if bad
            else "no crash, no hang, every damaged file refused or read"
        )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
