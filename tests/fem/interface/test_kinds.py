"""What every kind of interface does alike (:class:`~subfric_dolfinx.fem.interface.BaseInterface`),
over both kinds, as building blocks of the user's own problem (``demos/user_loop.py``).

* DOLFINx's Dirichlet convention for Newton with lifting: with ``bcs`` the residual holds the
  interface forces on the free rows plus ``K (g - x)`` of the tangent's coupling to the
  constrained dofs, and nothing on the constrained rows; the tangent has no row or column of a
  constrained dof. The reference is the same interface's residual and tangent without ``bcs``
  (the whole tangent assembled, multiplied by ``g - x`` built from the conditions' values). The
  block is pushed at its left flank, whose condition holds an interface node (the lifting
  reaches the interface's rows). On 2 ranks a rank may hold none of the finite-sliding points.
"""

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from demos import user_loop
from subfric_dolfinx.compat import petsc_vector
from subfric_dolfinx.fem import create_matrix
from subfric_dolfinx.fem.interface import FrictionInterface, SlidingInterface
from tests.helpers import everywhere

SLIDE = 1e-3  # mm, the pushed flank's x-displacement


def interface_of(kind, V, domain):
    law = user_loop.law()
    if kind == "small_sliding":
        return FrictionInterface.from_mesh(V, domain, law)
    name = next(iter(domain.interfaces))
    side = domain.interfaces[name]
    return SlidingInterface(
        V,
        domain.cell_tags,
        domain.facet_tags,
        law,
        tag=domain.tags[name],
        primary=domain.body_tags(side.primary),
        secondary=domain.body_tags(side.secondary),
        name=name,
    )


def pressed_block(V, domain):
    """Owned displacement: the block pressed into the base by 2e-3 mm and moved sideways."""
    X = V.tabulate_dof_coordinates()
    bs = V.dofmap.bs
    tdim = V.mesh.topology.dim
    V.mesh.topology.create_connectivity(tdim, tdim)
    block = np.zeros(X.shape[0], dtype=bool)
    cells = domain.cell_tags.find(domain.tag("secondary"))
    block[dolfinx.fem.locate_dofs_topological(V, tdim, cells)] = True
    u = np.zeros((X.shape[0], bs))
    u[block, 1] = -2e-3 * (1.0 + 0.1 * np.sin(X[block, 0]))
    u[block, 0] = 1e-3 * np.cos(X[block, 0])
    return u.reshape(-1)[: V.dofmap.index_map.size_local * bs].copy()


@pytest.mark.parametrize("kind", ["small_sliding", "finite_sliding"])
def test_dirichlet_rows_follow_dolfinx_lifting_convention(kind):
    comm = MPI.COMM_WORLD
    domain, V, _u, _F, _J, bcs, _p, slide = user_loop.model(comm, 4, push="secondary_left")
    slide.x.array[:] = SLIDE
    iface = interface_of(kind, V, domain)
    iface.set_step(0.1)
    imap, bs = V.dofmap.index_map, V.dofmap.bs
    n_owned = imap.size_local * bs
    x = petsc_vector(imap, bs)
    x.array_w[:] = pressed_block(V, domain)

    b_bc, b_free = petsc_vector(imap, bs), petsc_vector(imap, bs)
    iface.assemble_residual(b_bc, x, bcs=bcs)
    iface.assemble_residual(b_free, x)
    A_bc, A = create_matrix(V, [iface]), create_matrix(V, [iface])
    iface.assemble_jacobian(A_bc, x, bcs=bcs)
    iface.assemble_jacobian(A, x)
    A_bc.assemble()
    A.assemble()

    # g - x at the constrained dofs from the conditions' own values: 0 at the bottom (both
    # components), SLIDE for the x-component on the pushed flank
    bottom, flank = (np.asarray(bc.dof_indices()[0][: bc.dof_indices()[1]]) for bc in bcs)
    bottom, flank = bottom[bottom < n_owned], flank[flank < n_owned]
    d = petsc_vector(imap, bs)
    d.array_w[bottom] = -x.array_r[bottom]
    d.array_w[flank] = SLIDE - x.array_r[flank]
    lift = A.createVecLeft()
    A.mult(d, lift)
    constrained = np.union1d(bottom, flank)
    free = np.setdiff1d(np.arange(n_owned), constrained)

    expected = b_free.array_r[free] + lift.array_r[free]
    scale = comm.allreduce(np.abs(b_free.array_r).max(initial=0.0), op=MPI.MAX)
    assert scale > 0.0  # the block is pressed: the interface carries load
    err = np.abs(b_bc.array_r[free] - expected).max(initial=0.0)
    assert everywhere(comm, err <= 1e-12 * scale)
    assert everywhere(comm, not np.any(b_bc.array_r[constrained]))
    # an interface node is constrained: the lifting reaches the interface's rows
    reached = comm.allreduce(np.abs(lift.array_r[free]).max(initial=0.0), op=MPI.MAX)
    assert reached > 1e-6 * scale

    rows = (constrained + imap.local_range[0] * bs).astype(PETSc.IntType)
    A.zeroRowsColumns(rows, diag=0.0)
    A_bc.axpy(-1.0, A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    assert A_bc.norm() == 0.0
    for obj in (x, b_bc, b_free, A_bc, A, d, lift):
        obj.destroy()
    iface.destroy()
    iface.destroy()  # idempotent
    assert iface.x_ext is None and iface.b_ext is None
