"""What both kinds of interface share: the error, the Dirichlet dofs, the tangent's stiffening.

* :class:`InterfaceError`: an unusable interface (mesh, tags, settings), from either kind.
* :func:`_bc_values`: the owned dofs of DOLFINx Dirichlet conditions and ``g - x`` there, for
  the Dirichlet rows and columns of an interface's residual and tangent.
* :func:`stiffen_separated`: the tangent with a fraction of the contact stiffness at points
  that have none (the retry of a failed step).
* :func:`initial_gaps`: the initial normal gap at the law's points.
* :func:`exchange_rows`: rows of arrays sent to the ranks that need them (``MPI_Alltoallv``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import dolfinx
import numpy as np
from mpi4py import MPI

from ...constitutive import FrictionLaw

__all__ = ["InterfaceError", "Received", "exchange_rows", "initial_gaps", "stiffen_separated"]


class InterfaceError(ValueError):
    """A mesh whose interface is unusable (missing tags, unpaired facets, undivided nodes)."""


def _bc_values(
    V: dolfinx.fem.FunctionSpace, bcs: Sequence[Any], x: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """Owned constrained dofs of DOLFINx ``bcs`` (unrolled, sorted) and ``g - x`` there."""
    bs = V.dofmap.bs
    imap = V.dofmap.index_map
    n_owned, n_all = imap.size_local * bs, (imap.size_local + imap.num_ghosts) * bs
    dofs = [bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in bcs]
    dofs = np.unique(np.concatenate(dofs)) if dofs else np.zeros(0, np.int32)
    dofs = dofs[dofs < n_owned].astype(np.int32)
    values = np.zeros(n_all)
    x0 = np.zeros(n_all)
    if x is not None:
        x0[:n_owned] = x[:n_owned]
    for bc in bcs:
        bc.set(values, x0, 1.0)
    return dofs, values[dofs]


def stiffen_separated(tangent: np.ndarray, law: FrictionLaw, fraction: float) -> np.ndarray:
    """The tangent with ``fraction`` of the contact stiffness at points that have none.

    A point separated beyond the contact band (or failed) has a zero tangent: where every point
    of a body's interface is so, and no support holds the body in some direction, the Jacobian
    is singular (a block pulled sideways without load may tip about its one touching point, then
    a pressure finds it floating: a failed linear solve). A Newton step on a Jacobian where such
    points keep ``fraction * diag(alpha_t, ..., alpha_n)`` exists, and leaves the undetermined
    motions alone where nothing pushes them; the residual, hence the converged solution, is
    unchanged. Used by :class:`~.stepping.LoadStepper` in the retry of a failed step
    (:data:`~.stepping.RETRY_SEPARATED_STIFFNESS`).

    Args:
        tangent: Consistent tangents (N, m, m).
        law: The law (its ``alpha_t``, ``alpha_n``; the largest over regions).
        fraction: Fraction of the contact stiffness; 0 returns ``tangent`` itself.
    """
    if not fraction or tangent.shape[0] == 0:
        return tangent
    free = ~tangent.reshape(tangent.shape[0], -1).any(axis=1)
    if not free.any():
        return tangent
    m = tangent.shape[-1]
    diag = np.full(m, float(law.alpha_t))
    diag[-1] = float(law.alpha_n)
    out = tangent.copy()
    out[free] = fraction * np.diag(diag)
    return out


def initial_gaps(
    spec: float | Callable[[np.ndarray], np.ndarray] | None, x: np.ndarray, comm
) -> np.ndarray:
    """The initial gap at points ``x`` (n, gdim) (collective: a failure is raised on every rank).

    Raises:
        InterfaceError: The function failed, gave the wrong number of values or a value that is
            not finite (the first such point is named).
    """
    n = x.shape[0]
    error = None
    g = np.zeros(n)
    try:
        if spec is not None:
            vals = spec(x.T.copy()) if callable(spec) else spec
            g = np.array(np.broadcast_to(np.asarray(vals, dtype=float), (n,)))
            bad = np.flatnonzero(~np.isfinite(g))
            if bad.size:
                where = ", ".join(f"{v:.6g}" for v in x[bad[0]])
                error = f"the initial gap is not finite at ({where}): {g[bad[0]]:g}"
    except Exception as e:  # a function of the user's, or values of the wrong shape
        error = f"the initial gap could not be evaluated: {type(e).__name__}: {e}"
    errors = [m for m in comm.allgather(error) if m]
    if errors:
        raise InterfaceError(errors[0])
    return g


@dataclasses.dataclass
class Received:
    """Rows received in an exchange, grouped by source rank (ascending)."""

    source: np.ndarray
    rows: list[np.ndarray]


def exchange_rows(comm: MPI.Comm, dest: np.ndarray, arrays: list[np.ndarray]) -> Received:
    """Send row ``i`` of each array to rank ``dest[i]`` (``MPI_Alltoallv``; collective).

    Only the counts go to every rank; the rows go where they are needed.
    """
    order = np.argsort(dest, kind="stable")
    counts = np.bincount(dest, minlength=comm.size).astype(np.int64)
    recv_counts = np.empty_like(counts)
    comm.Alltoall(counts, recv_counts)
    n_recv = int(recv_counts.sum())
    out = []
    for a in arrays:
        a = np.ascontiguousarray(a[order])
        width = math.prod(a.shape[1:])
        recv = np.empty((n_recv, *a.shape[1:]), dtype=a.dtype)
        sc, rc = counts * width, recv_counts * width
        sd = np.concatenate([[0], np.cumsum(sc)[:-1]])
        rd = np.concatenate([[0], np.cumsum(rc)[:-1]])
        comm.Alltoallv([a, (sc, sd)], [recv, (rc, rd)])
        out.append(recv)
    return Received(np.repeat(np.arange(comm.size, dtype=np.int32), recv_counts), out)
