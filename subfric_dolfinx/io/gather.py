"""Interface values of all ranks in one deterministic, partition-independent order.

The interface's quadrature points are owned by the ranks holding their primary facets, in an order
that depends on the partition. :func:`gather_interface` brings values from all ranks together and
sorts the points lexicographically by their coordinates (first coordinate first), each coordinate
rounded to the element's ``coordinate_tolerance`` (a millionth of the smallest interface facet)
before comparing. Rounding makes the order robust to the last-bit differences that the same point
gets on different partitions (e.g. the Gauss points of a hexahedron face), so a 1-rank and a 2-rank
run give the same order, row by row.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, overload

import numpy as np

__all__ = ["gather_interface", "interface_of", "interface_order"]


def interface_of(problem: Any, interface: str | None = None) -> tuple[Any, Any]:
    """The law's points and law of an interface.

    The points: :class:`~subfric_dolfinx.fem.interface.protocol.LawPoints`.

    Args:
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem`.
        interface: The interface's name (``None``: the first, e.g. the only one).

    Raises:
        KeyError: No interface of that name (the interfaces are listed).
    """
    ifaces = getattr(problem, "interfaces", None)
    if not ifaces:
        return problem.interface, problem.law
    if interface is None:
        iface = next(iter(ifaces.values()))
    elif interface in ifaces:
        iface = ifaces[interface]
    else:
        raise KeyError(f"no interface {interface!r}; interfaces: {sorted(ifaces)}")
    return iface.law_points, iface.law


def interface_order(x: np.ndarray, tol: float) -> np.ndarray:
    """The permutation that sorts points ``x`` (n, gdim) by rounded coordinates (x, then y, ...)."""
    if x.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    keys = np.round(x / tol).astype(np.int64)
    return np.lexsort(keys.T[::-1])


@overload
def gather_interface(
    element: Any, values: Mapping[str, np.ndarray], *, root: None = None
) -> dict[str, np.ndarray]: ...


@overload
def gather_interface(
    element: Any, values: Mapping[str, np.ndarray], *, root: int
) -> dict[str, np.ndarray] | None: ...


def gather_interface(
    element, values: Mapping[str, np.ndarray], *, root: int | None = None
) -> dict[str, np.ndarray] | None:
    """Values at the interface points of all ranks, in the documented order (collective).

    Args:
        element: The interface's law points on this rank
            (:class:`~subfric_dolfinx.fem.interface.protocol.LawPoints`).
        values: Name -> array whose first axis runs over this rank's points (``n_elements * nq``).
        root: Gather on this rank only (the others get ``None``); on every rank when ``None``.

    Returns:
        ``"x"`` (the points' coordinates, (n, gdim)) and every name of ``values``, over all
        points in order.
    """
    comm = element.comm
    gdim = element.gdim
    x = element.points.reshape(-1, gdim)
    n = x.shape[0]
    cols = {"x": x, **values}
    shapes = {k: np.asarray(v).shape[1:] for k, v in cols.items()}
    for k, v in values.items():
        if np.asarray(v).shape[0] != n:
            raise ValueError(f"{k} has {np.asarray(v).shape[0]} rows for {n} interface points")
    widths = [int(np.prod(shape)) for shape in shapes.values()]
    local = np.column_stack(
        [
            np.asarray(v, dtype=float).reshape(n, w)
            for v, w in zip(cols.values(), widths, strict=True)
        ]
    )
    width = local.shape[1]
    if root is None:
        allv = np.concatenate(comm.allgather(local)).reshape(-1, width)
    else:
        parts = comm.gather(local, root=root)
        if comm.rank != root:
            return None
        allv = np.concatenate(parts).reshape(-1, width)
    allv = allv[interface_order(allv[:, :gdim], element.coordinate_tolerance)]
    out: dict[str, np.ndarray] = {}
    c = 0
    for (k, shape), w in zip(shapes.items(), widths, strict=True):
        out[k] = allv[:, c : c + w].reshape(-1, *shape)
        c += w
    return out
