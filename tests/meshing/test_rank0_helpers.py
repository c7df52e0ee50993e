"""The gmsh helpers of :mod:`subfric_dolfinx.meshing` run on rank 0 alone, as documented.

A 2-rank job (``mpirun -n 2``, a fresh one: in the suite DOLFINx is imported on every rank
already) where rank 0 alone imports the helpers, meshes two bodies with gmsh and duplicates the
interface's nodes into a file, while rank 1 waits at a barrier; then both ranks read the file
into DOLFINx. Importing the helpers must not initialise PETSc (collective: on one rank of two it
hangs, or aborts the job), so rank 0 reports which of DOLFINx and petsc4py it had imported before
the barrier: none. The read mesh has the interface's facets on both sides.
"""

import subprocess
import sys

import pytest

from tests.helpers import ROOT, singleton_env

pytestmark = pytest.mark.serial  # starts its own 2-rank job

SCRIPT = r"""
import sys
from mpi4py import MPI

comm = MPI.COMM_WORLD
out = sys.argv[1]
if comm.rank == 0:
    from subfric_dolfinx.meshing import duplicate_interface_nodes, gmsh_session

    with gmsh_session("two-blocks") as gmsh:
        occ = gmsh.model.occ
        low, high = occ.addRectangle(0, 0, 0, 2, 1), occ.addRectangle(0.5, 1, 0, 1, 1)
        occ.fragment([(2, low)], [(2, high)])
        occ.synchronize()
        for name, y in (("base", 0.5), ("block", 1.5)):
            tags = [t for _, t in gmsh.model.getEntities(2)
                    if abs(occ.getCenterOfMass(2, t)[1] - y) < 1e-6]
            gmsh.model.addPhysicalGroup(2, tags, name=name)
        contact = [t for _, t in gmsh.model.getEntities(1)
                   if abs(occ.getCenterOfMass(1, t)[1] - 1) < 1e-6
                   and 0.5 < occ.getCenterOfMass(1, t)[0] < 1.5]
        gmsh.model.addPhysicalGroup(1, contact, name="contact")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        gmsh.model.mesh.generate(2)
        done = duplicate_interface_nodes(None, {"contact": ("base", "block")}, output=out)
    loaded = sorted({m.split(".")[0] for m in sys.modules} & {"dolfinx", "petsc4py"})
    print(f"rank 0 imported {loaded or 'neither'}; facets {done['contact'].facets}", flush=True)
comm.barrier()
from subfric_dolfinx.meshing import read_interface_mesh

domain = read_interface_mesh(out, comm, 2, interfaces={"contact": ("base", "block")})
n = domain.num_interface_facets
if comm.rank == 0:
    print(f"read on {comm.size} ranks: {n} interface facets", flush=True)
"""


def test_rank_0_alone_meshes_and_duplicates_then_every_rank_reads(tmp_path):
    out = tmp_path / "apart.msh"
    p = subprocess.run(
        ["mpirun", "-n", "2", sys.executable, "-c", SCRIPT, str(out)],
        cwd=ROOT,
        env=singleton_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    text = p.stdout + p.stderr
    assert p.returncode == 0, text
    assert "rank 0 imported neither; facets 4" in text, text
    assert "read on 2 ranks: 4 interface facets" in text, text
