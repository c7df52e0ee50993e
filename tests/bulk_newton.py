"""A small Newton loop for a bulk model alone (no interface): a test harness for
:class:`~subfric_dolfinx.fem.plasticity.J2Bulk` and its protocol, with component-wise Dirichlet
conditions whose values change from step to step, and an optional load form."""

from __future__ import annotations

import types

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx.compat import petsc_vector


def context(mesh, V, mode, cell_tags, tags):
    """A duck-typed bulk context (the problem's ``BulkContext``)."""
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    return types.SimpleNamespace(mesh=mesh, V=V, mode=mode, dx=dx, tags=tags)


def tag_all_cells(mesh, value=1):
    tdim = mesh.topology.dim
    n = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = np.arange(n, dtype=np.int32)
    return dolfinx.mesh.meshtags(mesh, tdim, cells, np.full(n, value, dtype=np.int32))


class Newton:
    """Newton's method on ``F(u; v) - external(v) = 0`` with the bulk model's forms.

    Args:
        bulk: The bulk model (forms, update, commit, revert).
        ctx: Its context.
        u: The displacement.
        constraints: name -> (component, dofs) of the Dirichlet conditions (dofs: indices of
            ``u.x.array``, local).
        external: The external load's form (linear in the test function ``v``) or ``None``;
            it receives ``v`` and returns a form.
    """

    def __init__(self, bulk, ctx, u, constraints, external=None):
        V = ctx.V
        self.bulk, self.u = bulk, u
        v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
        F, J = bulk.forms(u, v, du, ctx)
        self.load = dolfinx.fem.Constant(ctx.mesh, PETSc.ScalarType(0.0))
        if external is not None:
            F = F - self.load * external(v)
        self.F = dolfinx.fem.form(F)
        self.J = dolfinx.fem.form(J if J is not None else ufl.derivative(F, u, du))
        self.constraints = constraints
        zero = PETSc.ScalarType(0.0)
        self.bcs = [
            dolfinx.fem.dirichletbc(zero, dofs, V.sub(c)) for c, dofs in constraints.values()
        ]
        self.A = dolfinx.fem.petsc.create_matrix(self.J)
        self.b = petsc_vector(V.dofmap.index_map, V.dofmap.index_map_bs)
        self.ksp = PETSc.KSP().create(ctx.mesh.comm)
        self.ksp.setOperators(self.A)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.du = dolfinx.fem.Function(V)
        self.history: list[list[float]] = []

    def residual(self):
        """Assemble the residual (no boundary conditions) into ``self.b``; returns it."""
        with self.b.localForm() as loc:
            loc.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self.b, self.F)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return self.b

    def solve(self, values, load=0.0, rtol=1e-11, atol=1e-9, max_it=25):
        """One step: Dirichlet values (name -> value), the load factor; returns the residual
        norms (the last below the tolerance) or raises RuntimeError."""
        u = self.u
        for name, val in values.items():
            u.x.array[self.constraints[name][1]] = val
        u.x.scatter_forward()
        self.load.value = load
        norms = []
        for _ in range(max_it):
            self.bulk.update(u)
            b = self.residual()
            dolfinx.fem.petsc.set_bc(b, self.bcs)
            norms.append(b.norm())
            if norms[-1] <= max(rtol * norms[0], atol):
                self.history.append(norms)
                return norms
            self.A.zeroEntries()
            dolfinx.fem.petsc.assemble_matrix(self.A, self.J, bcs=self.bcs)
            self.A.assemble()
            self.ksp.solve(b, self.du.x.petsc_vec)
            self.du.x.scatter_forward()
            u.x.array[:] -= self.du.x.array
        raise RuntimeError(f"Newton did not converge: {norms}")

    def reaction(self, name):
        """The sum of the internal forces at a constraint's dofs (all ranks), at the last
        update: the reaction force (times 2 pi r in axisymmetric mode)."""
        b = self.residual()
        _, dofs = self.constraints[name]
        V = self.u.function_space
        n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        local = b.array_r[dofs[dofs < n_owned]].sum()
        return V.mesh.comm.allreduce(local, op=MPI.SUM)


def component_dofs(V, comp, marker):
    """Unrolled local dofs of component ``comp`` on the boundary facets where ``marker(x)``."""
    mesh = V.mesh
    fdim = mesh.topology.dim - 1
    facets = dolfinx.mesh.locate_entities_boundary(mesh, fdim, marker)
    return dolfinx.fem.locate_dofs_topological(V.sub(comp), fdim, facets)
