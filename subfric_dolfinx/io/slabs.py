"""Rows of a partition-independent file, distributed in contiguous slabs over the ranks.

A dataset of ``n`` rows (cells by original index, interface points in the order of
:func:`~.gather.interface_order`) is cut into one contiguous slab per rank (:func:`slab`); each
rank reads and writes its own slab only. :func:`push` sends rows from the ranks that hold them
(in partition order) to the slab owners, :func:`pull` fetches rows from the slab owners: both are
one ``Alltoallv`` of the rows a rank holds or needs, so memory stays O(local) per rank.

:func:`interface_rows` gives each local interface point its global row. It gathers the points'
coordinates (``gdim`` numbers per point, the only O(interface) data) to rank 0 once, sorts them
as :func:`~.gather.gather_interface` does and scatters the rows back: the file's rows are those of
the gathered interface, whatever the partition. The interface is a surface: in 3-D it holds
O(n^(2/3)) of the n cells: a small fraction of the mesh.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

from .gather import interface_order

__all__ = ["interface_rows", "pull", "push", "slab"]


def slab(n: int, size: int, rank: int) -> tuple[int, int]:
    """Rows ``[lo, hi)`` of ``rank``'s slab of ``n`` rows cut into ``size`` slabs."""
    b = -(-n // size) if n else 0
    lo = min(rank * b, n)
    return lo, min(lo + b, n)


def _owner(rows: np.ndarray, n: int, size: int) -> np.ndarray:
    b = max(-(-n // size), 1)
    return rows // b


def _exchange(
    comm: Any, dest: np.ndarray, payload: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Send row ``i`` of ``payload`` (2-D, float64 or int64) to rank ``dest[i]``.

    Returns:
        The received rows (grouped by source rank, each group in the sender's order), the send
        order (a permutation of the rows) and the number of rows received from each rank.
    """
    size = comm.size
    order = np.argsort(dest, kind="stable")
    send = np.ascontiguousarray(payload[order])
    w = payload.shape[1]
    scount = np.bincount(dest, minlength=size).astype(np.int64)
    rcount = np.array(comm.alltoall(scount.tolist()), dtype=np.int64)
    recv = np.empty((int(rcount.sum()), w), dtype=payload.dtype)
    mpitype = MPI.DOUBLE if payload.dtype == np.float64 else MPI.INT64_T
    sdispl = np.concatenate([[0], np.cumsum(scount)[:-1]]) * w
    rdispl = np.concatenate([[0], np.cumsum(rcount)[:-1]]) * w
    comm.Alltoallv([send, (scount * w, sdispl), mpitype], [recv, (rcount * w, rdispl), mpitype])
    return recv, order, rcount


def push(comm: Any, rows: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """This rank's slab of ``n`` rows, assembled from the rows every rank holds (collective).

    Args:
        comm: The communicator.
        rows: Global row of each local row (each global row held by exactly one rank).
        values: The local rows, ``(len(rows), ...)``; sent as float64.
        n: Number of global rows.

    Returns:
        ``(hi - lo, ...)`` float64, the rows of :func:`slab`.

    Raises:
        RuntimeError: A row of the slab was held by no rank (on the slab's owner only: callers
            agree on it).
    """
    rows = np.asarray(rows, dtype=np.int64)
    shape = values.shape[1:]
    flat = np.asarray(values, dtype=np.float64).reshape(rows.size, int(np.prod(shape)))
    payload = np.column_stack([rows.astype(np.float64), flat])
    recv, _, _ = _exchange(comm, _owner(rows, n, comm.size), payload)
    lo, hi = slab(n, comm.size, comm.rank)
    got = recv[:, 0].astype(np.int64) - lo
    if got.size != hi - lo or np.unique(got).size != got.size:
        raise RuntimeError(f"rows {lo}..{hi} of the slab were not all provided exactly once")
    out = np.empty((hi - lo, flat.shape[1]))
    out[got] = recv[:, 1:]
    return out.reshape(hi - lo, *shape)


def pull(comm: Any, rows: np.ndarray, block: np.ndarray, n: int) -> np.ndarray:
    """The given global rows, fetched from the slabs ``block`` of their owners (collective).

    Args:
        comm: The communicator.
        rows: Global rows this rank needs (each in ``[0, n)``).
        block: This rank's slab (:func:`slab` rows of the dataset), ``(hi - lo, ...)``.
        n: Number of global rows.

    Returns:
        ``(len(rows), ...)`` float64.
    """
    rows = np.asarray(rows, dtype=np.int64)
    shape = block.shape[1:]
    flat = np.asarray(block, dtype=np.float64).reshape(block.shape[0], int(np.prod(shape)))
    lo, _ = slab(n, comm.size, comm.rank)
    asked, order, counts = _exchange(comm, _owner(rows, n, comm.size), rows.reshape(-1, 1))
    answer = flat[asked[:, 0] - lo]
    # the answers go back to the askers, each in the order it asked
    back, _, _ = _exchange(comm, np.repeat(np.arange(comm.size), counts), answer)
    out = np.empty((rows.size, flat.shape[1]))
    out[order] = back
    return out.reshape(rows.size, *shape)


def interface_rows(element: Any) -> tuple[np.ndarray, int]:
    """Global row of each local interface point and the number of points (collective).

    The rows are those of :func:`~.gather.gather_interface` (points sorted by rounded coordinates),
    so a file written in these rows does not depend on the partition.
    """
    comm = element.comm
    gdim = element.gdim
    x = np.ascontiguousarray(element.points.reshape(-1, gdim), dtype=np.float64)
    counts = np.array(comm.allgather(x.shape[0]), dtype=np.int64)
    displ = np.concatenate([[0], np.cumsum(counts)[:-1]])
    root = comm.rank == 0
    allx = np.empty((int(counts.sum()), gdim)) if root else None
    comm.Gatherv(x, [allx, (counts * gdim, displ * gdim), MPI.DOUBLE] if root else None, root=0)
    rows_all = None
    if root:
        assert allx is not None  # (allocated on the root)
        order = interface_order(allx, element.coordinate_tolerance)
        rows_all = np.empty(order.size, dtype=np.int64)
        rows_all[order] = np.arange(order.size)
        del allx, order
    rows = np.empty(x.shape[0], dtype=np.int64)
    comm.Scatterv([rows_all, (counts, displ), MPI.INT64_T] if root else None, rows, root=0)
    return rows, int(counts.sum())
