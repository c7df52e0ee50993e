"""A dynamic run's vectors in a checkpoint: velocity, acceleration, the step's start forces.

A problem with inertia (:class:`~subfric_dolfinx.fem.dynamics.Inertia`) keeps owned vectors in
the displacement's layout; a checkpoint stores each under ``/dynamics/<name>`` laid out as
``/displacement`` (original cell index, cell-local dof, component: the same on any partition),
and the energy accounts in the group's attribute ``accounts`` (JSON).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from .slabs import pull, push

__all__ = ["DYNAMICS", "by_cell", "from_cells", "read_dynamics"]

DYNAMICS = ("velocity", "acceleration", "force", "interface_force")
"""The vectors of a dynamic run's checkpoint (``/dynamics``)."""


def _cell_dofs(problem: Any) -> np.ndarray:
    mesh = problem.mesh
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    return np.asarray(problem.V.dofmap.list[:n])


def by_cell(problem: Any, values: np.ndarray, cells: np.ndarray, n_cells: int) -> np.ndarray:
    """This rank's slab of owned dof values laid out as ``/displacement`` (collective)."""
    dofs = _cell_dofs(problem)
    v = problem.u.copy()
    v.x.array[:] = 0.0
    v.x.array[: values.size] = values
    v.x.scatter_forward()
    return push(problem.comm, cells, v.x.array.reshape(-1, problem.gdim)[dofs], n_cells)


def from_cells(problem: Any, block: np.ndarray, cells: np.ndarray, n_cells: int) -> np.ndarray:
    """Dof values (owned, then ghosts) from this rank's slab laid out as ``/displacement``."""
    dofs = _cell_dofs(problem)
    v = problem.u.copy()
    v.x.array.reshape(-1, problem.gdim)[dofs] = pull(problem.comm, cells, block, n_cells)
    v.x.scatter_forward()
    return np.array(v.x.array, dtype=float)


def read_dynamics(
    f: Any, name: str, c0: int, c1: int, error: type[Exception]
) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """This rank's rows ``[c0, c1)`` of ``/dynamics`` and its accounts, validated.

    Returns:
        ``None`` where the file has no ``/dynamics`` (a quasi-static run's).

    Raises:
        error: A vector missing, of another shape than the displacement's, or not finite;
            accounts that are not a JSON object (the file ``name`` and the item named).
    """
    if "dynamics" not in f:
        return None
    g = f["dynamics"]
    shape = f["displacement"].shape
    out = {}
    for k in DYNAMICS:
        if k not in g or g[k].shape != shape or g[k].dtype.kind != "f":
            found = g[k].shape if k in g else "missing"
            raise error(
                f"checkpoint {name}: 'dynamics/{k}' is {found} (the displacement's shape "
                f"{shape} wanted)"
            )
        a = np.asarray(g[k][c0:c1], dtype=float)
        if not np.all(np.isfinite(a)):
            raise error(f"checkpoint {name}: 'dynamics/{k}' holds NaN/inf")
        out[k] = a
    try:
        text = g.attrs["accounts"]
        accounts = json.loads(text.decode() if isinstance(text, bytes) else str(text))
    except (KeyError, ValueError, TypeError, UnicodeDecodeError) as e:
        raise error(f"checkpoint {name}: 'dynamics' accounts unreadable ({e})") from None
    if not isinstance(accounts, dict):
        raise error(f"checkpoint {name}: 'dynamics' accounts are not an object")
    return out, accounts
