# ---
# jupyter:
#   jupytext:
#     cell_markers: '"""'
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.16.4
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
r"""# Smoke test: a linear-elastic bar meshed with gmsh

This demo is the first end-to-end check of the toolchain the project builds on: gmsh builds a
mesh on one rank, DOLFINx distributes it, a small-strain linear-elastic problem is assembled and
solved with a direct (LU) solver through petsc4py, and two scalar quantities of interest are
reduced over all ranks. It runs unchanged on one or more MPI ranks:

```bash
python3 demos/elastic_smoke.py --n 8
mpirun -n 2 python3 demos/elastic_smoke.py --n 8 --out demos/output/elastic_smoke
```

and prints, on rank 0 only, the mean displacement of the loaded (right) edge ("tip
displacement") and the total strain energy. Both are independent of the number of ranks up to
round-off, which is what `tests/fem/test_elastic_smoke.py` checks, together with a closed-form
solution.

The problem: a plane-stress rectangle $\Omega = (0, L) \times (0, H)$, clamped on its left edge
$\Gamma_D = \{x = 0\}$ and loaded by a uniform traction $\bar{t}$ on its right edge
$\Gamma_N = \{x = L\}$; the top and bottom edges are traction free. Find
$u \in V = \{v \in [H^1(\Omega)]^2 : v = 0 \text{ on } \Gamma_D\}$ such that

$$
\int_\Omega \sigma(u) : \varepsilon(v) \, \mathrm{d}x
  = \int_{\Gamma_N} \bar{t} \cdot v \, \mathrm{d}s \quad \forall v \in V,
\qquad
\sigma(u) = 2 \mu \varepsilon(u) + \lambda^* \operatorname{tr} \varepsilon(u) I,
$$

with $\varepsilon(u) = \operatorname{sym} \nabla u$, $\mu = E / (2 (1 + \nu))$ and the
plane-stress $\lambda^* = E \nu / (1 - \nu^2)$.

Two load cases are useful:

* the default, a downward shear traction $\bar{t} = (0, -q)$: a cantilever, compared below
  with Timoshenko beam theory only as a plausibility check (P1 triangles are too stiff in
  bending on coarse meshes);
* an axial traction $\bar{t} = (\sigma_0, 0)$ with $\nu = 0$: the exact solution
  $u = (\sigma_0 x / E, 0)$ is linear, so P1 elements reproduce it to round-off, and the tip
  displacement is $\sigma_0 L / E$ and the strain energy $\sigma_0^2 L H / (2 E)$.

## Implementation

The modules used: gmsh for the geometry and mesh, DOLFINx/UFL for the discretisation,
petsc4py for the linear solve.
"""

# %%
"""Linear-elastic smoke demo: a gmsh rectangle, clamped on the left, traction on the right."""

import argparse
import pathlib

import dolfinx
import dolfinx.fem.petsc
import gmsh
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx.commandline import main_block, program_args, summary
from subfric_dolfinx.compat import model_to_mesh
from subfric_dolfinx.io.fields import annotate_xdmf
from subfric_dolfinx.scenes.cli import HelpFormatter

# Physical-group tags of the gmsh model: one for the surface, one for each loaded/clamped edge.
DOMAIN, CLAMPED, LOADED = 1, 1, 2


# %% [markdown]
# ### The mesh
#
# The gmsh model is built on rank 0 only. An exception raised there while the other ranks wait
# inside `model_to_mesh` (which starts with a broadcast from rank 0) would hang the whole job, so
# the gmsh work is wrapped: rank 0 catches any error, broadcasts it, and every rank raises it. gmsh
# is initialised here only if nobody else has done so, and the model is removed afterwards in any
# case, so the function can be called repeatedly in one process (as the tests do).


# %%
def _build_gmsh_model(length: float, height: float, n: int) -> None:
    """Create the meshed rectangle as the current gmsh model (rank 0 only)."""
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("elastic_smoke")
    surface = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, length, height)
    gmsh.model.occ.synchronize()
    left, right = [], []
    for _, curve in gmsh.model.getBoundary([(2, surface)], oriented=False):
        x_mid = gmsh.model.occ.getCenterOfMass(1, curve)[0]
        if np.isclose(x_mid, 0.0):
            left.append(curve)
        elif np.isclose(x_mid, length):
            right.append(curve)
    if len(left) != 1 or len(right) != 1:
        raise RuntimeError(f"expected one left and one right edge, found {left} and {right}")
    gmsh.model.addPhysicalGroup(2, [surface], DOMAIN, name="domain")
    gmsh.model.addPhysicalGroup(1, left, CLAMPED, name="clamped")
    gmsh.model.addPhysicalGroup(1, right, LOADED, name="loaded")
    h = height / n
    gmsh.option.setNumber("Mesh.CharacteristicLengthMin", h)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", h)
    gmsh.model.mesh.generate(2)
    _, triangles, _ = gmsh.model.mesh.getElements(2)
    if len(triangles) == 0 or len(triangles[0]) == 0:
        raise RuntimeError("gmsh generated no triangles")


def build_mesh(comm: MPI.Comm, n: int, length: float = 4.0, height: float = 1.0, rank: int = 0):
    """Mesh the rectangle (0, length) x (0, height) with gmsh on `rank` and distribute it.

    Args:
        comm: Communicator the mesh lives on.
        n: Resolution: the mesh size is `height / n`.
        length: Length of the rectangle (x direction).
        height: Height of the rectangle (y direction).
        rank: Rank of `comm` that runs gmsh.

    Returns:
        `(mesh, cell_tags, facet_tags)` as returned by `subfric_dolfinx.compat.model_to_mesh`
        (DOLFINx's `gmshio.model_to_mesh` in 0.9, `io.gmsh.model_to_mesh` in 0.11); the
        facet tags mark the left edge with `CLAMPED` and the right edge with `LOADED`.

    Raises:
        RuntimeError: on every rank, if building the gmsh model failed on `rank`.
    """
    error, owns_gmsh = None, False
    if comm.rank == rank:
        try:
            owns_gmsh = not gmsh.isInitialized()
            if owns_gmsh:
                gmsh.initialize(interruptible=False)
            _build_gmsh_model(length, height, n)
        except Exception as exc:  # any error must reach the other ranks, or they would hang
            error = f"{type(exc).__name__}: {exc}"
    error = comm.bcast(error, root=rank)
    try:
        if error is not None:
            raise RuntimeError(f"building the gmsh model failed on rank {rank}: {error}")
        model = gmsh.model if comm.rank == rank else None
        return model_to_mesh(model, comm, rank, gdim=2)
    finally:
        if comm.rank == rank and gmsh.isInitialized():
            if "elastic_smoke" in gmsh.model.list():
                gmsh.model.setCurrent("elastic_smoke")
                gmsh.model.remove()
            if owns_gmsh:
                gmsh.finalize()


# %% [markdown]
# ### The variational problem and its solution
#
# P1 vector elements; the clamp is a homogeneous Dirichlet condition on the dofs of the facets
# tagged `CLAMPED`; the traction enters through the exterior-facet measure restricted to the
# tag `LOADED`. The system is assembled with the Dirichlet rows and columns eliminated
# (lifting) and solved with a PETSc KSP of type `preonly` with an LU factorisation by MUMPS,
# which works on any number of ranks. The solver's convergence reason is checked: a failed
# factorisation raises instead of returning garbage.


# %%
def solve(
    comm: MPI.Comm,
    n: int = 8,
    *,
    length: float = 4.0,
    height: float = 1.0,
    young: float = 1000.0,
    poisson: float = 0.3,
    traction: tuple[float, float] = (0.0, -1.0),
) -> dict:
    """Solve the clamped plane-stress rectangle under an end traction.

    Args:
        comm: Communicator to solve on (e.g. `MPI.COMM_WORLD`, or `MPI.COMM_SELF` for a serial
            reference solve on one rank).
        n: Mesh resolution: the mesh size is `height / n`.
        length: Length of the rectangle.
        height: Height of the rectangle.
        young: Young's modulus E.
        poisson: Poisson's ratio ν (plane stress).
        traction: Uniform traction vector on the right edge.

    Returns:
        A dict with the solution `u` (a `dolfinx.fem.Function`), `mesh`, `facet_tags`, the mean
        displacement of the right edge `tip_displacement` (numpy array of 2), the total strain
        energy `strain_energy`, the external work `external_work` (∫ t·u ds) and the global
        number of cells `num_cells`. The scalars are the same on every rank.
    """
    mesh, _, facet_tags = build_mesh(comm, n, length, height)
    tdim = mesh.topology.dim

    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (mesh.geometry.dim,)))
    mu = young / (2.0 * (1.0 + poisson))
    lmbda = young * poisson / (1.0 - poisson**2)

    def epsilon(w):
        return ufl.sym(ufl.grad(w))

    def sigma(w):
        return 2.0 * mu * epsilon(w) + lmbda * ufl.tr(epsilon(w)) * ufl.Identity(len(w))

    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    t_bar = dolfinx.fem.Constant(mesh, np.asarray(traction, dtype=PETSc.ScalarType))
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    a = dolfinx.fem.form(ufl.inner(sigma(u), epsilon(v)) * ufl.dx)
    L = dolfinx.fem.form(ufl.dot(t_bar, v) * ds(LOADED))

    clamped_facets = facet_tags.find(CLAMPED)
    clamped_dofs = dolfinx.fem.locate_dofs_topological(V, tdim - 1, clamped_facets)
    zero = np.zeros(mesh.geometry.dim, dtype=PETSc.ScalarType)
    bc = dolfinx.fem.dirichletbc(zero, clamped_dofs, V)

    A = dolfinx.fem.petsc.assemble_matrix(a, bcs=[bc])
    A.assemble()
    b = dolfinx.fem.petsc.assemble_vector(L)
    dolfinx.fem.petsc.apply_lifting(b, [a], bcs=[[bc]])
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    dolfinx.fem.petsc.set_bc(b, [bc])

    ksp = PETSc.KSP().create(comm)
    ksp.setOperators(A)
    ksp.setType(PETSc.KSP.Type.PREONLY)
    ksp.getPC().setType(PETSc.PC.Type.LU)
    ksp.getPC().setFactorSolverType("mumps")
    uh = dolfinx.fem.Function(V, name="displacement")
    try:
        ksp.solve(b, uh.x.petsc_vec)
        reason = ksp.getConvergedReason()
        if reason <= 0:
            raise RuntimeError(f"the LU solve failed (KSP converged reason {reason})")
    finally:
        ksp.destroy()
        A.destroy()
        b.destroy()
    uh.x.scatter_forward()

    # ### Quantities of interest
    #
    # Each is an integral assembled locally and summed over the ranks, so it does not depend on
    # the partition: the tip displacement is the mean of u over the loaded edge, the strain
    # energy is ½ ∫ σ(u) : ε(u) dx, and the external work ∫ t̄ · u ds equals twice the strain
    # energy for the discrete solution too (Clapeyron), a cheap consistency check.
    def integrate(expr) -> float:
        local = dolfinx.fem.assemble_scalar(dolfinx.fem.form(expr))
        return comm.allreduce(local, op=MPI.SUM)

    edge_length = integrate(1.0 * ds(LOADED))
    tip = np.array([integrate(uh[i] * ds(LOADED)) for i in range(2)]) / edge_length
    energy = 0.5 * integrate(ufl.inner(sigma(uh), epsilon(uh)) * ufl.dx)
    work = integrate(ufl.dot(t_bar, uh) * ds(LOADED))
    cell_map = mesh.topology.index_map(tdim)
    return {
        "u": uh,
        "mesh": mesh,
        "facet_tags": facet_tags,
        "tip_displacement": tip,
        "strain_energy": energy,
        "external_work": work,
        "num_cells": cell_map.size_global,
    }


# %% [markdown]
# ### Beam-theory reference for the default load case
#
# For a shear load $q$ per unit length of the end edge (total $P = q H$ per unit thickness), the
# Timoshenko tip deflection of a cantilever is
# $P L^3 / (3 E I) + P L / (k G A)$ with $I = H^3 / 12$, $A = H$, $k = 5/6$ and $G = \mu$.


# %%
def timoshenko_tip_deflection(length, height, young, poisson, shear_load):
    """Timoshenko-beam tip deflection of the cantilever under a uniform end shear traction."""
    force = shear_load * height
    inertia = height**3 / 12.0
    shear_modulus = young / (2.0 * (1.0 + poisson))
    bending = force * length**3 / (3.0 * young * inertia)
    shear = force * length / (5.0 / 6.0 * shear_modulus * height)
    return bending + shear


# %% [markdown]
# ### Driver
#
# Command-line options choose the resolution and, optionally, an output directory for an XDMF file
# of the displacement (viewable in ParaView). Nothing is written without `--out`.


# %%
def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=summary(__doc__), formatter_class=HelpFormatter)
    parser.add_argument("--n", type=int, default=8, help="mesh resolution: h = H / n")
    parser.add_argument("--out", type=pathlib.Path, default=None, help="write u.xdmf into OUT")
    args = parser.parse_args(program_args(argv))  # in a notebook: the defaults
    if args.n < 1:
        parser.error("--n must be a positive integer")

    comm = MPI.COMM_WORLD
    length, height, young, poisson, q = 4.0, 1.0, 1000.0, 0.3, 1.0
    result = solve(
        comm, args.n, length=length, height=height, young=young, poisson=poisson, traction=(0, -q)
    )
    reference = timoshenko_tip_deflection(length, height, young, poisson, q)

    if args.out is not None:
        if comm.rank == 0:
            args.out.mkdir(parents=True, exist_ok=True)
        comm.Barrier()
        with dolfinx.io.XDMFFile(comm, args.out / "u.xdmf", "w") as xdmf:
            xdmf.write_mesh(result["mesh"])
            xdmf.write_function(result["u"])
        if comm.rank == 0:  # the unit into the closed files, as the package's field files have
            annotate_xdmf(args.out / "u.xdmf", {"displacement": "mm"}, {"units": "MPa, mm, s"})
        comm.Barrier()

    if comm.rank == 0:
        ux, uy = result["tip_displacement"]
        print(f"ranks: {comm.size}, cells: {result['num_cells']}, n: {args.n}")
        print(f"tip displacement: ux = {ux:.12e}, uy = {uy:.12e}")
        print(f"strain energy: {result['strain_energy']:.12e}")
        print(f"external work / 2: {result['external_work'] / 2:.12e}")
        print(f"Timoshenko tip deflection: {-reference:.6e} (FE / beam = {uy / -reference:.4f})")
        if args.out is not None:
            print(f"wrote {args.out / 'u.xdmf'}")
    return result


# %%
if __name__ == "__main__":  # in a notebook: main() with the defaults
    main_block(main)
