"""Rows of a partition-independent file, distributed in contiguous slabs over the ranks.

A dataset of ``n`` rows (cells by original index, interface points in the order of
:func:`~.gather.interface_order`) is cut into one contiguous slab per rank (:func:`slab`); each
rank reads and writes its own slab only. :func:`push` sends rows from the ranks that hold them
(in partition order) to the slab owners, :func:`pull` fetches rows from the slab owners: both are
one ``Alltoallv`` of the rows a rank holds or needs, so memory stays O(local) per rank.

:func:`interface_rows` gives each local interface point its global row: the rows of
:func:`~.gather.gather_interface` (points sorted by rounded coordinates, ties in the order of the
ranks and of each rank's points), so the file's rows are those of the gathered interface whatever
the partition. It sorts in parallel (:func:`sorted_rows`, a sample sort): no rank receives more
than about twice its share of the points to sort; the splitters are chosen on rank 0 from at most
``size`` samples of each rank (all its points where it holds no more) and broadcast, so a rank
other than rank 0 receives ``size - 1`` rows for them and nothing is all-gathered.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

__all__ = ["interface_rows", "pull", "push", "slab", "sorted_rows"]


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


def _lexsorted(rows: np.ndarray) -> np.ndarray:
    """The permutation sorting the rows of an integer table lexicographically (column 0 first)."""
    if rows.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    return np.lexsort(rows.T[::-1])


def _splitters(comm: Any, ordered: np.ndarray, total: int) -> np.ndarray:
    """``size - 1`` splitters of the rows of every rank, from a weighted regular sample.

    Each rank samples ``min(n_local, size)`` of its sorted rows at regular positions, each
    sample standing for the rows up to the next one; rank 0 gathers them (at most
    ``min(total, size**2)`` rows), sorts them and takes as splitter ``i`` the first sample with
    at least ``i total / size`` rows before it; it broadcasts the splitters (``size - 1`` rows:
    what every other rank receives). Where every row is a sample (``n_local <= size`` everywhere)
    the splitters are the exact quantiles; otherwise no interval holds more than about twice the
    mean (regular sampling).
    """
    size = comm.size
    n_local, width = ordered.shape
    count = min(n_local, size)
    pick = (np.arange(count + 1) * n_local) // max(count, 1)
    sample = np.column_stack([ordered[pick[:-1]], np.diff(pick)]).astype(np.int64)
    counts = comm.gather(sample.size, root=0)
    if comm.rank == 0:
        assert counts is not None  # (rank 0 gathers)
        flat = np.empty(int(sum(counts)), dtype=np.int64)
        displs = np.concatenate([[0], np.cumsum(counts)[:-1]])
        comm.Gatherv(sample.ravel(), [flat, (counts, displs), MPI.INT64_T], root=0)
        got = flat.reshape(-1, width + 1)
        got = got[_lexsorted(got[:, :width])]
        before = np.cumsum(got[:, width]) - got[:, width]  # rows before each sample (estimate)
        at = np.searchsorted(before, (np.arange(1, size) * total) / size, side="left")
        at = np.minimum(at, max(got.shape[0] - 1, 0))
        chosen = got[at, :width] if got.shape[0] else np.zeros((0, width), dtype=np.int64)
        splitters = np.ascontiguousarray(chosen, dtype=np.int64)
    else:
        comm.Gatherv(sample.ravel(), None, root=0)
    n = comm.bcast(splitters.shape[0] if comm.rank == 0 else None, root=0)
    if comm.rank != 0:
        splitters = np.empty((n, width), dtype=np.int64)
    comm.Bcast([splitters, MPI.INT64_T], root=0)
    return splitters


def sorted_rows(comm: Any, keys: np.ndarray) -> tuple[np.ndarray, int]:
    """The global position of each local row of ``keys`` in their lexicographic order (collective).

    A sample sort by regular sampling: each rank sorts its rows, the ranks agree on ``size - 1``
    splitters chosen on rank 0 from a weighted regular sample of every rank's sorted rows
    (:func:`_splitters`: at most ``size`` rows from each rank, gathered on rank 0 alone; every
    rank receives the ``size - 1`` splitters), send each row to the rank of its interval (one
    ``Alltoallv``), sort what they received, number it after the rows of the ranks before them,
    and send the numbers back. Ties are broken by the rank, then by the row's local index: the
    order of a stable sort of all ranks' rows concatenated in rank order
    (:func:`~.gather.gather_interface`'s). The splitters decide only which rank sorts which
    rows, never the positions.

    Args:
        comm: The communicator.
        keys: Integer sort keys, ``(n_local, w)``; ``w`` the same on every rank.

    Returns:
        Each local row's position (int64, ``(n_local,)``) and the global number of rows.
    """
    keys = np.asarray(keys, dtype=np.int64)
    keys = keys if keys.ndim == 2 else keys.reshape(keys.shape[0], -1)
    n_local = keys.shape[0]
    size, rank = comm.size, comm.rank
    full = np.column_stack([keys, np.full(n_local, rank), np.arange(n_local)]).astype(np.int64)
    total = int(comm.allreduce(n_local))
    if size == 1:
        pos = np.empty(n_local, dtype=np.int64)
        pos[_lexsorted(full)] = np.arange(n_local)
        return pos, total
    ordered = full[_lexsorted(full)]
    width = full.shape[1]
    splitters = _splitters(comm, ordered, total)
    # each row's interval: the number of splitters before it (a splitter before an equal row)
    both = np.concatenate([ordered, splitters])
    marker = np.concatenate([np.ones(n_local, np.int64), np.zeros(splitters.shape[0], np.int64)])
    order = np.lexsort((marker, *both.T[::-1]))
    before = np.cumsum(marker[order] == 0)
    dest = np.empty(both.shape[0], dtype=np.int64)
    dest[order] = before
    dest = dest[:n_local]
    got, _, _ = _exchange(comm, dest, ordered)
    mine = _lexsorted(got)
    offset = comm.exscan(got.shape[0])  # (every rank calls it; None on rank 0)
    offset = int(offset) if rank and offset is not None else 0
    position = np.empty(got.shape[0], dtype=np.int64)
    position[mine] = offset + np.arange(got.shape[0])
    # the positions back to the rows' ranks
    back, _, _ = _exchange(
        comm, got[:, width - 2], np.column_stack([got[:, width - 1], position]).astype(np.int64)
    )
    pos = np.empty(n_local, dtype=np.int64)
    pos[back[:, 0]] = back[:, 1]
    return pos, total


def interface_rows(element: Any) -> tuple[np.ndarray, int]:
    """Global row of each local interface point and the number of points (collective).

    The rows are those of :func:`~.gather.gather_interface` (points sorted by rounded coordinates,
    ties in rank order), so a file written in these rows does not depend on the partition. Sorted
    in parallel (:func:`sorted_rows`): no rank receives the whole interface.
    """
    gdim = element.gdim
    x = np.asarray(element.points, dtype=np.float64).reshape(-1, gdim)
    keys = np.round(x / element.coordinate_tolerance).astype(np.int64)
    return sorted_rows(element.comm, keys)
