"""Values at named points, in parallel, the same on every partition.

:class:`PointEvaluator` evaluates functions of the bodies at fixed points with DOLFINx's point
evaluation (a bounding-box tree of the body's owned cells, ``compute_collisions_points``,
``compute_colliding_cells``, ``Function.eval``). A point on a cell boundary touches several
cells, possibly on several ranks, and for a discontinuous field (the stress) the value depends on
the cell; DOLFINx's ``determine_point_ownership`` gives such a point to the lowest rank holding
it, which depends on the partition, and searches all cells, whereas the interface's nodes are
duplicated and a point there must name its body. So each rank finds the colliding owned cells of
the point's body, the cell with the lexicographically smallest midpoint is chosen among all ranks,
and its rank evaluates: one cell, whatever the partition. :class:`InterfacePointProbe` finds the
interface quadrature point nearest to each point (ties broken by the coordinates), the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import dolfinx
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from .interface import InterfaceError

__all__ = ["InterfacePointProbe", "PointEvaluator", "require_near"]


def _winner(comm: MPI.Comm, keys: list[tuple | None]) -> list[int]:
    """For each point, the rank whose key is smallest (-1 where no rank has one)."""
    everyone = comm.allgather(keys)
    out = []
    for i in range(len(keys)):
        cands = [(k[i], r) for r, k in enumerate(everyone) if k[i] is not None]
        out.append(min(cands)[1] if cands else -1)
    return out


class PointEvaluator:
    """Evaluate body functions at fixed points (collective).

    Args:
        domain: The mesh with its tags.
        points: Coordinates (n, gdim or 3).
        bodies: For each point, the body whose cells are searched (``None``: every cell).
        names: Point names (for messages).

    Raises:
        InterfaceError: A point lies in no cell of its body (named, with its coordinates).
    """

    def __init__(
        self,
        domain: Any,
        points: np.ndarray,
        bodies: Sequence[str | None],
        names: Sequence[str],
    ) -> None:
        mesh = domain.mesh
        self.comm = mesh.comm
        tdim = mesh.topology.dim
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        x = np.zeros((pts.shape[0], 3))
        x[:, : pts.shape[1]] = pts
        self.x = x
        n_cells = mesh.topology.index_map(tdim).size_local
        cells = np.full(x.shape[0], -1, dtype=np.int32)
        keys: list[tuple | None] = [None] * x.shape[0]
        for body in dict.fromkeys(bodies):
            idx = [i for i, b in enumerate(bodies) if b == body]
            if body is None:
                own = np.arange(n_cells, dtype=np.int32)
            else:
                own = domain.cell_tags.find(domain.tags[body])
                own = own[own < n_cells]
            tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=own)
            cand = dolfinx.geometry.compute_collisions_points(tree, x[idx])
            hits = dolfinx.geometry.compute_colliding_cells(mesh, cand, x[idx])
            for j, i in enumerate(idx):
                c = np.asarray(hits.links(j), dtype=np.int32)
                if c.size == 0:
                    continue
                mid = dolfinx.mesh.compute_midpoints(mesh, tdim, c)
                best = np.lexsort(mid.T[::-1])[0]
                cells[i] = c[best]
                keys[i] = tuple(float(v) for v in mid[best])
        self.owner = _winner(self.comm, keys)
        missing = [i for i, r in enumerate(self.owner) if r < 0]
        if missing:
            i = missing[0]
            where = f" of the body {bodies[i]!r}" if bodies[i] else ""
            gdim = mesh.geometry.dim
            raise InterfaceError(
                f"point {names[i]!r} at {tuple(float(v) for v in x[i, :gdim])} is in no cell{where}"
            )
        self.mine = np.array([r == self.comm.rank for r in self.owner], dtype=bool)
        self.cells = cells[self.mine]

    def eval(self, f: dolfinx.fem.Function) -> np.ndarray:
        """Values of ``f`` at the points, (n, value size), on every rank (collective)."""
        size = int(np.prod(f.ufl_shape)) if f.ufl_shape else 1
        out = np.zeros((self.x.shape[0], size))
        if self.cells.size:
            out[self.mine] = np.asarray(f.eval(self.x[self.mine], self.cells)).reshape(-1, size)
        return self.comm.allreduce(out, op=MPI.SUM)


def require_near(domain: Any, x: Sequence[float], body: str | None, what: str) -> None:
    """Refuse a point farther from ``body`` (the mesh if ``None``) than its nearest cell's size.

    Collective.

    A point force or a held point acts at the vertex nearest to its point: a point in the body
    or next to it (a corner given roughly) is meant; one farther away than a cell is not.

    Raises:
        InterfaceError: On every rank, naming ``what``, the point, its distance and the body.
    """
    mesh = domain.mesh
    tdim = mesh.topology.dim
    x3 = np.zeros((1, 3))
    xa = np.asarray(x, dtype=float).ravel()
    x3[0, : xa.size] = xa
    n_cells = mesh.topology.index_map(tdim).size_local
    if body is None:
        own = np.arange(n_cells, dtype=np.int32)
    else:
        own = domain.cell_tags.find(domain.tags[body])
        own = own[own < n_cells].astype(np.int32)
    mine = None
    if own.size:
        tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=own)
        mid = dolfinx.geometry.create_midpoint_tree(mesh, tdim, own)
        c = np.asarray(dolfinx.geometry.compute_closest_entity(tree, mid, mesh, x3), np.int32)
        # (DOLFINx 0.9 annotates the entities as a list, 0.11 as the int32 array the binding
        # takes: the ignore is unused there)
        d2 = dolfinx.geometry.squared_distance(mesh, tdim, c, x3)  # type: ignore[arg-type, unused-ignore]
        mine = (float(np.sqrt(max(float(d2[0]), 0.0))), float(mesh.h(tdim, c)[0]))
    found = [m for m in mesh.comm.allgather(mine) if m is not None]
    if not found:
        raise InterfaceError(f"{what}: the body {body!r} has no cells")
    d, h = min(found)
    if d > h:
        where = tuple(float(v) for v in xa)
        of = f"the body {body!r}" if body else "the mesh"
        raise InterfaceError(
            f"{what}: {where} is {d:.4g} away from {of}, more than its nearest cell's size "
            f"({h:.4g}): outside it (such a point acts at its nearest vertex, meant for a "
            "point in the body or next to it)"
        )


class InterfacePointProbe:
    """The interface quadrature point nearest to each of some points (collective).

    Args:
        element: The interface's law points (:class:`~.interface.protocol.LawPoints`).
        points: Coordinates (n, gdim or more).

    Attributes:
        where: Coordinates of the chosen quadrature points, (n, gdim), on every rank.
    """

    def __init__(self, element: Any, points: np.ndarray) -> None:
        self.el = element
        gdim = element.gdim
        self.comm = element.comm
        x = np.atleast_2d(np.asarray(points, dtype=float))[:, :gdim]
        qp = element.points.reshape(-1, gdim)
        tol = element.coordinate_tolerance
        index = np.full(x.shape[0], -1, dtype=np.int64)
        keys: list[tuple | None] = [None] * x.shape[0]
        for i, p in enumerate(x):
            if qp.shape[0] == 0:
                continue
            dist = np.round(np.sqrt(np.sum((qp - p) ** 2, axis=1)) / tol)
            key = np.column_stack([dist, np.round(qp / tol)])
            j = int(np.lexsort(key.T[::-1])[0])
            index[i] = j
            keys[i] = tuple(float(v) for v in key[j])
        self.owner = _winner(self.comm, keys)
        self.mine = np.array([r == self.comm.rank for r in self.owner], dtype=bool)
        self.index = index[self.mine]
        where = np.zeros((x.shape[0], gdim))
        where[self.mine] = qp[self.index] if self.index.size else where[self.mine]
        self.where = self.comm.allreduce(where, op=MPI.SUM)

    def values(self, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Rows of per-point arrays (first axis over this rank's points) at the chosen points.

        Returns:
            Name -> (n, width) array, on every rank (collective).
        """
        out = {}
        n = self.mine.size
        for name, a in arrays.items():
            a = np.asarray(a, dtype=float)
            a = a.reshape(a.shape[0], int(np.prod(a.shape[1:])))
            v = np.zeros((n, a.shape[1]))
            if self.index.size:
                v[self.mine] = a[self.index]
            out[name] = self.comm.allreduce(v, op=MPI.SUM)
        return out
