"""From conditions to algebra: the groups they act on, Dirichlet dofs, load vectors, springs.

A condition names a group of the mesh. Dirichlet conditions act on facets (the dofs of the
facets), cells (every dof of the cells: a body held) or nodes (the dofs at the vertices of a node
group); loads and springs need facets. :func:`check_groups` names a condition on the wrong kind
of group before anything is assembled (collective). Loads become one vector per loading channel
(:func:`load_vectors`); a spring adds ``k_i u_i v_i`` to the bulk form and ``k_i u0_i v_i`` to the
loads (:func:`spring_forms`), and its force on the body is read back from a weight vector
(:class:`SpringForces`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, cast

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from ..compat import petsc_vector
from ..meshing import NodeGroup, locate_node_group, nearest_vertex
from .conditions import Dirichlet, DirichletField, PointForce, Pressure, Spring, Traction, channels
from .interface import InterfaceError
from .probes import require_near

__all__ = [
    "LoadPart",
    "SpringForces",
    "check_groups",
    "dirichlet_dofs",
    "group_kind",
    "load_vectors",
    "spring_forms",
]


@dataclasses.dataclass(frozen=True)
class LoadPart:
    """The part of a condition scaled by one loading channel (``amplitude``).

    A load vector of :attr:`InterfaceProblem.loads` is ``(part, vector)``: the vector is scaled by
    ``program.amplitude(part.amplitude, t)``.
    """

    condition: Any
    amplitude: str | None

    @property
    def group(self) -> str:
        """The condition's group."""
        return self.condition.group


def group_kind(domain: Any, name: str, counts: tuple[int, int] | None = None) -> str:
    """``"facets"``, ``"cells"``, ``"nodes"`` or ``"dimension d"`` (another dimension).

    Args:
        domain: The mesh with its tags.
        name: The group.
        counts: Global numbers of facets and cells tagged with the group's tag (used when the
            domain does not record the groups' dimensions).
    """
    if name in getattr(domain, "node_groups", {}):
        return "nodes"
    tdim = domain.mesh.topology.dim
    dim = (getattr(domain, "dims", None) or {}).get(name)
    if dim is None and counts is not None:
        nf, nc = counts
        dim = tdim - 1 if nf > 0 else (tdim if nc > 0 else None)
    return {tdim: "cells", tdim - 1: "facets", None: "empty"}.get(dim, f"dimension {dim}")


def check_groups(domain: Any, conditions: Sequence[Any]) -> dict[str, str]:
    """The kind of every group the conditions name (collective).

    Raises:
        InterfaceError: A missing group (all of them named), a load or spring on a group that is
            not of facets, a Dirichlet condition on a group of curves (3-D) or without entities.
    """
    mesh = domain.mesh
    tdim = mesh.topology.dim
    tags = dict(domain.tags)
    nodes = getattr(domain, "node_groups", {})
    named = [c.group for c in conditions if not isinstance(c, PointForce)]
    missing = [g for g in dict.fromkeys(named) if g not in tags and g not in nodes]
    if missing:
        raise InterfaceError(
            f"the mesh lacks the physical group(s) {missing}; it has "
            f"{sorted(set(tags) | set(nodes))}"
        )
    groups = [g for g in dict.fromkeys(named) if g not in nodes]
    n_owned = mesh.topology.index_map(tdim - 1).size_local
    ncells = mesh.topology.index_map(tdim).size_local
    local = np.zeros((len(groups), 2), dtype=np.int64)
    for i, g in enumerate(groups):
        local[i, 0] = np.count_nonzero(domain.facet_tags.find(tags[g]) < n_owned)
        local[i, 1] = np.count_nonzero(domain.cell_tags.find(tags[g]) < ncells)
    total = mesh.comm.allreduce(local) if groups else local
    kinds = {g: "nodes" for g in dict.fromkeys(named) if g in nodes}
    for g, (nf, nc) in zip(groups, total, strict=True):
        kind = group_kind(domain, g, (int(nf), int(nc)))
        if (kind == "facets" and nf == 0) or (kind == "cells" and nc == 0):
            kind = "empty"
        kinds[g] = kind
    for c in conditions:
        if isinstance(c, PointForce):
            continue
        what, kind = type(c).__name__, kinds[c.group]
        dirichlet = isinstance(c, Dirichlet | DirichletField)
        if kind == "facets" or (dirichlet and kind in ("cells", "nodes")):
            continue
        if kind == "empty":
            raise InterfaceError(f"{what} condition on {c.group!r}: the group has no entities")
        if kind == "cells":
            raise InterfaceError(
                f"{what} condition on {c.group!r}: a group of cells (dimension {tdim}), not of "
                f"facets (dimension {tdim - 1}); loads and springs act on boundary facets"
            )
        if kind == "nodes":
            raise InterfaceError(
                f"{what} condition on {c.group!r}: a group of nodes, not of facets (dimension "
                f"{tdim - 1}); use a point force at a node, or a facet group"
            )
        allowed = "facets" if not dirichlet else "facets, cells or nodes"
        raise InterfaceError(
            f"{what} condition on {c.group!r}: a group of {kind}, not of {allowed}"
        )
    return kinds


def _entities(domain: Any, group: str, kind: str) -> tuple[int, np.ndarray]:
    """(dimension, local entities) of a group: facets, cells, or vertices of a node group."""
    tdim = domain.mesh.topology.dim
    if kind == "nodes":
        domain.mesh.topology.create_connectivity(0, tdim)
        return 0, locate_node_group(domain, group)
    dim = tdim if kind == "cells" else tdim - 1
    domain.mesh.topology.create_connectivity(dim, tdim)
    tags = domain.cell_tags if kind == "cells" else domain.facet_tags
    return dim, tags.find(domain.tags[group])


def dirichlet_dofs(
    V: dolfinx.fem.FunctionSpace, domain: Any, c: Dirichlet | DirichletField, kind: str
) -> tuple[np.ndarray, np.ndarray]:
    """Owned (unrolled, local) dofs of a Dirichlet condition and their reference values.

    Reference values: the value at each dof (to be scaled by the channel), or the dof coordinates
    (3, n) of a :class:`DirichletField` (evaluated at each time).
    """
    gdim = V.mesh.geometry.dim
    bs = V.dofmap.bs
    n_owned = V.dofmap.index_map.size_local * bs
    dim, entities = _entities(domain, c.group, kind)
    xdof = V.tabulate_dof_coordinates()
    vals: np.ndarray
    if c.component is None:
        nodes = dolfinx.fem.locate_dofs_topological(V, dim, entities)
        dofs = (nodes[:, None] * bs + np.arange(bs)).ravel()
        val: np.ndarray
        if callable(c.value):
            val = np.asarray(c.value(xdof[nodes].T), dtype=float).reshape(gdim, -1)
            vals = val.T.ravel()
        else:
            val = np.asarray(c.value, dtype=float)
            if val.shape != (gdim,):
                raise ValueError(f"Dirichlet value on {c.group!r} must have {gdim} components")
            vals = np.tile(val, nodes.size)
    else:
        if not 0 <= c.component < gdim:
            raise ValueError(f"component {c.component!r} out of range on {c.group!r}")
        Vc, _ = V.sub(c.component).collapse()
        dofs = dolfinx.fem.locate_dofs_topological((V.sub(c.component), Vc), dim, entities)[0]
        if isinstance(c, DirichletField):
            vals = xdof[dofs // bs].T  # coordinates, evaluated at each time
        elif callable(c.value):
            vals = np.asarray(c.value(xdof[dofs // bs].T), dtype=float).reshape(-1)
        else:
            vals = np.full(dofs.size, float(cast(float, c.value)))  # (a number with a component)
    keep = dofs < n_owned
    vals = vals[:, keep] if isinstance(c, DirichletField) else vals[keep]
    return dofs[keep].astype(np.int32), vals


def _vector(V: dolfinx.fem.FunctionSpace, L: Any) -> PETSc.Vec:
    f = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(L))
    f.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return f


def _by_channel(value: np.ndarray, chans: list[str | None]) -> dict[str | None, np.ndarray]:
    """Split a vector into one vector per channel (the other components zero)."""
    out: dict[str | None, np.ndarray] = {}
    for i, ch in enumerate(chans):
        if value[i] != 0.0:
            out.setdefault(ch, np.zeros(value.size))[i] = value[i]
    return out


def _point_vector(V: dolfinx.fem.FunctionSpace, domain: Any, c: PointForce) -> tuple:
    """The owned dof blocks at the vertex nearest to a point force's point, and the vertex."""
    mesh = domain.mesh
    require_near(domain, c.x, c.body, f"point force at {c.group[6:]}")
    cells = None if c.body is None else domain.cell_tags.find(domain.tags[c.body])
    xv, _ = nearest_vertex(mesh, c.x, cells)
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    verts = locate_node_group(domain, c.group, NodeGroup(xv.reshape(1, 3), (c.body,)))
    blocks = dolfinx.fem.locate_dofs_topological(V, 0, verts)
    blocks = blocks[blocks < V.dofmap.index_map.size_local]
    if mesh.comm.allreduce(blocks.size) > 1:  # both copies of a duplicated interface node
        where = tuple(float(v) for v in xv[: mesh.geometry.dim])
        raise InterfaceError(
            f"point force at {c.group[6:]}: its nearest vertex {where} is an interface node, "
            "duplicated; give the body it acts on"
        )
    return blocks, xv


def _weighted(expr: Any, w: Any) -> Any:
    """``w * expr``, or ``expr`` itself for the weight 1 (the same form as without a weight)."""
    return expr if isinstance(w, int | float) and w == 1 else w * expr


def load_vectors(
    V: dolfinx.fem.FunctionSpace,
    domain: Any,
    loads: Sequence[Pressure | Traction | PointForce],
    ds: ufl.Measure,
    w: Any = 1,
) -> list[tuple[LoadPart, PETSc.Vec]]:
    """One load vector per condition and channel: ``(LoadPart(condition, channel), vector)``.

    Pressures and tractions are integrated over their facets, with the weight ``w`` (``2 pi r``
    in axisymmetric mode, :func:`~.kinematics.weight`); a point force is put on the owned dofs of
    the vertex nearest to its point (on one rank only; in axisymmetric mode it is a ring load, N
    in total). Collective.
    """
    mesh = domain.mesh
    gdim = mesh.geometry.dim
    v = ufl.TestFunction(V)
    n = ufl.FacetNormal(mesh)
    out: list[tuple[LoadPart, PETSc.Vec]] = []
    for c in loads:
        if isinstance(c, Pressure):
            L = _weighted(-float(c.value) * ufl.dot(n, v), w) * ds(domain.tags[c.group])
            out.append((LoadPart(c, c.amplitude), _vector(V, L)))
            continue
        value = np.asarray(c.value, dtype=float)
        kind = "traction" if isinstance(c, Traction) else "point force"
        if value.shape != (gdim,):
            raise ValueError(f"{kind} on {c.group!r} must have {gdim} components")
        parts = _by_channel(value, channels(c.amplitude, gdim, f"{kind} on {c.group!r}"))
        if isinstance(c, Traction):
            for ch, part in parts.items():
                L = _weighted(ufl.dot(ufl.as_vector(part.tolist()), v), w)
                out.append((LoadPart(c, ch), _vector(V, L * ds(domain.tags[c.group]))))
            continue
        blocks, _ = _point_vector(V, domain, c)
        for ch, part in parts.items():
            f = petsc_vector(V.dofmap.index_map, V.dofmap.bs)
            # Written through one array access on every rank, the ranks without the point too:
            # an access changes the vector's state, which drops PETSc's cached norms. A rank
            # whose vector kept the norm cached by ``set`` would answer ``f.norm()`` alone while
            # the others wait in its reduction (a hang).
            values = f.array_w
            values[:] = 0.0
            for b in blocks:
                values[b * gdim : (b + 1) * gdim] += part
            out.append((LoadPart(c, ch), f))
    return out


def _stiffness(c: Spring, gdim: int) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    k = np.asarray(c.stiffness, dtype=float)
    k = np.full(gdim, float(k)) if k.shape == () else k
    if k.shape != (gdim,) or not np.all(np.isfinite(k)) or np.any(k < 0) or not np.any(k > 0):
        raise ValueError(
            f"spring on {c.group!r}: stiffness must be one number or {gdim}, finite, >= 0 and "
            f"not all zero, got {c.stiffness!r}"
        )
    u0 = np.zeros(gdim) if c.u0 is None else np.asarray(c.u0, dtype=float)
    if u0.shape != (gdim,) or not np.all(np.isfinite(u0)):
        raise ValueError(f"spring on {c.group!r}: u0 must have {gdim} finite components")
    return k, u0, channels(c.amplitude, gdim, f"spring on {c.group!r}")


def spring_forms(
    V: dolfinx.fem.FunctionSpace,
    domain: Any,
    springs: Sequence[Spring],
    ds: ufl.Measure,
    w: Any = 1,
) -> tuple[Any, list[tuple[LoadPart, PETSc.Vec]], SpringForces]:
    """The springs' bulk form ``sum k_i du_i v_i w ds``, load vectors and force read-back.

    ``w``: the weight of the integrals (``2 pi r`` in axisymmetric mode).

    Returns:
        The bilinear form (0 without springs), ``(LoadPart, vector)`` for the moving ends,
        and a :class:`SpringForces`.
    """
    gdim = domain.mesh.geometry.dim
    du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a: Any = 0
    loads: list[tuple[LoadPart, PETSc.Vec]] = []
    weights = []
    for c in springs:
        k, u0, chans = _stiffness(c, gdim)
        dsg = ds(domain.tags[c.group])
        K = ufl.as_matrix(np.diag(k).tolist())
        a = a + _weighted(ufl.inner(ufl.dot(K, du), v), w) * dsg
        for ch, part in _by_channel(k * u0, chans).items():
            L = _weighted(ufl.dot(ufl.as_vector(part.tolist()), v), w) * dsg
            loads.append((LoadPart(c, ch), _vector(V, L)))
        m = _weighted(ufl.dot(ufl.as_vector(k.tolist()), v), w) * dsg
        weights.append((c, u0, chans, _vector(V, m)))
    return a, loads, SpringForces(V, weights)


class SpringForces:
    """The resultant force of each spring group on the body, ``-sum k (u - u0 a(t))`` (collective).

    With the weight vector ``m = int k_i v_i ds`` of a spring, ``int k_i u_i ds = m . u`` exactly,
    so no form is evaluated per step.
    """

    def __init__(self, V: dolfinx.fem.FunctionSpace, weights: list[tuple]) -> None:
        self.V = V
        self.bs = V.dofmap.bs
        self.n_owned = V.dofmap.index_map.size_local * self.bs
        self.weights = [(c, u0, chans, np.asarray(m.array_r).copy()) for c, u0, chans, m in weights]

    def __call__(self, u: np.ndarray, program: Any, t: float) -> dict[str, np.ndarray]:
        """Force of the springs of each group on the body, from the owned dofs ``u``."""
        if not self.weights:
            return {}
        comm = self.V.mesh.comm
        groups = list(dict.fromkeys(c.group for c, *_ in self.weights))
        loc = np.zeros((len(groups), self.bs))
        for c, u0, chans, m in self.weights:
            i = groups.index(c.group)
            mu = (m[: self.n_owned] * u[: self.n_owned]).reshape(-1, self.bs).sum(axis=0)
            msum = m[: self.n_owned].reshape(-1, self.bs).sum(axis=0)
            amp = np.array([program.amplitude(ch, t) for ch in chans])
            loc[i] -= mu - u0 * amp * msum
        tot = comm.allreduce(loc, op=MPI.SUM)
        return {g: tot[i] for i, g in enumerate(groups)}
