"""The mesh of bodies joined by duplicated-node interfaces, as read into DOLFINx.

:class:`InterfaceMesh` (made by :func:`~.reader.read_interface_mesh`) knows its groups by name,
its bodies, its interfaces and the two sides of each.
"""

from __future__ import annotations

import dataclasses

import dolfinx
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from .groups import BODIES, CLASSIC_ALIASES, INTERFACE
from .nodes import NodeGroup
from .topology import InterfaceSides, Topology

__all__ = ["InterfaceMesh"]


@dataclasses.dataclass
class InterfaceMesh:
    """A DOLFINx mesh of bodies joined by duplicated-node interfaces.

    Attributes:
        mesh: The mesh.
        cell_tags: Cell tags (physical-group tags of the bodies' cell groups).
        facet_tags: Facet tags (physical-group tags of the facet groups).
        tags: Physical-group name -> integer tag (the names of the file or model).
        num_interface_facets: Global number of facets on each side of the first interface.
        dims: Physical-group name -> its dimension (cells: ``tdim``, facets: ``tdim - 1``).
        interface_groups: Subgroups of the interfaces (named facet groups of interface facets,
            e.g. regions with their own friction law) -> the centroids of their facets (n, gdim),
            on every rank. A facet carries one tag in DOLFINx, so these groups are not among the
            facet tags (nor in ``tags``): find their facets by centroid.
        node_groups: Node groups by name: the named physical groups of points of the file or
            model, and those added with :meth:`add_node_group`.
        topology: Its bodies and interfaces (:class:`~.topology.Topology`, resolved by the
            reader): read by the problem, the scenes and the outputs.
    """

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    tags: dict[str, int]
    num_interface_facets: int = 0
    dims: dict[str, int] = dataclasses.field(default_factory=dict)
    interface_groups: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    node_groups: dict[str, NodeGroup] = dataclasses.field(default_factory=dict)
    topology: Topology = dataclasses.field(default_factory=Topology)
    _sides: dict[str, dict[str, npt.NDArray[np.int32]]] = dataclasses.field(
        default_factory=dict, repr=False
    )
    _counts: dict[str, int] = dataclasses.field(default_factory=dict, repr=False)

    @property
    def bodies(self) -> dict[str, tuple[str, ...]]:
        """Body name -> its cell groups (:attr:`topology`)."""
        return self.topology.bodies

    @property
    def interfaces(self) -> dict[str, InterfaceSides]:
        """Interface group -> its :class:`~.topology.InterfaceSides` (:attr:`topology`)."""
        return self.topology.interfaces

    @property
    def gdim(self) -> int:
        """Geometric dimension."""
        return self.mesh.geometry.dim

    @property
    def tdim(self) -> int:
        """Topological dimension."""
        return self.mesh.topology.dim

    def tag(self, name: str) -> int:
        """Integer tag of the physical group ``name``.

        Raises:
            KeyError: No group of that name (the message lists the groups present).
        """
        try:
            return self.tags[name]
        except KeyError:
            renamed = CLASSIC_ALIASES.get(name)
            hint = f" ({name!r} is now {renamed!r})" if renamed in self.tags else ""
            raise KeyError(
                f"no physical group {name!r}{hint}; groups: {sorted(self.tags)}"
            ) from None

    def body_tags(self, name: str) -> tuple[int, ...]:
        """The cell tags of a body (its cell groups) or of one cell group.

        Raises:
            KeyError: Neither a body nor a group of that name (the bodies are listed).
        """
        if name in self.bodies:
            return tuple(self.tag(g) for g in self.bodies[name])
        if name in self.tags:
            return (self.tags[name],)
        raise KeyError(f"no body or group {name!r}; bodies: {sorted(self.bodies)}")

    def add_node_group(self, name: str, x: npt.ArrayLike, body: str | None = None) -> NodeGroup:
        """Name the nodes at the points ``x`` (n, gdim) of ``body`` (any body if ``None``).

        Conditions may then refer to ``name`` (a Dirichlet condition on its nodes). A point must
        be a vertex of the mesh (within a millionth of the mesh's extent); the nodes are located
        when a condition uses the group. ``body`` is a body or a cell group.

        Raises:
            ValueError: ``name`` is already a physical group or node group, or ``body`` unknown.
        """
        if name in self.tags or name in self.node_groups:
            raise ValueError(f"a group named {name!r} exists already")
        known = sorted(set(self.bodies) | {n for n, d in self.dims.items() if d == self.tdim})
        if body is not None and body not in known:
            raise ValueError(f"body must be one of {known or list(BODIES)} or None, got {body!r}")
        xa = np.atleast_2d(np.asarray(x, dtype=float))
        x3 = np.zeros((xa.shape[0], 3))
        x3[:, : xa.shape[1]] = xa
        group = NodeGroup(x3, (body,) * xa.shape[0])
        self.node_groups[name] = group
        return group

    def body_cells(self, body: str) -> npt.NDArray[np.int32]:
        """Local indices (owned and ghost) of the cells of ``body`` (a body or a cell group)."""
        parts = [self.cell_tags.find(t) for t in self.body_tags(body)]
        return np.unique(np.concatenate(parts)).astype(np.int32)

    def facets(self, name: str) -> npt.NDArray[np.int32]:
        """Local indices (owned and ghost) of the facets of the facet group ``name``."""
        return self.facet_tags.find(self.tag(name))

    def _interface(self, interface: str | None) -> str:
        if interface is None:
            if not self._sides:
                return INTERFACE
            return next(iter(self._sides))
        if interface not in self._sides:
            raise ValueError(f"no interface {interface!r}; interfaces: {sorted(self._sides)}")
        return interface

    def interface_facets(
        self, side: str, *, owned_only: bool = False, interface: str | None = None
    ) -> npt.NDArray[np.int32]:
        """Local indices of the facets of an interface on one side.

        The side of a facet is the body of its (unique) adjacent cell.

        Args:
            side: ``"primary"`` or ``"secondary"`` (``"master"``/``"slave"``), or the body's
                name.
            owned_only: Only facets owned by this rank.
            interface: The interface group (``None``: the first, e.g. the only one).
        """
        name = self._interface(interface)
        sides = self._sides.get(name, {})
        known = self.interfaces.get(name)
        alias = {"master": "primary", "slave": "secondary"}
        key = alias.get(side, side)
        if known is not None and side not in alias and side not in ("primary", "secondary"):
            key = {known.primary: "primary", known.secondary: "secondary"}.get(side, side)
        if key not in ("primary", "secondary"):
            allowed = [*BODIES, "primary", "secondary"]
            if known is not None:
                allowed += [known.primary, known.secondary]
            raise ValueError(f"side must be one of {list(dict.fromkeys(allowed))}, got {side!r}")
        f = sides.get(key, np.zeros(0, dtype=np.int32))
        if owned_only:
            f = f[f < self.mesh.topology.index_map(self.tdim - 1).size_local]
        return f

    def interface_side_tags(self, interface: str | None = None) -> dolfinx.mesh.MeshTags:
        """Facet tags marking each local facet of an interface with its adjacent cell's tag.

        Use as ``ufl.Measure("ds", domain=mesh, subdomain_data=...)`` and integrate over one side
        with ``ds(tag)`` of that side's body (its cell group), e.g. ``ds(tags["primary"])``.
        """
        name = self._interface(interface)
        sides = self._sides.get(name, {})
        f = np.concatenate([sides.get("primary", []), sides.get("secondary", [])]).astype(np.int32)
        tdim = self.tdim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)
        f2c = self.mesh.topology.connectivity(tdim - 1, tdim)
        imap = self.mesh.topology.index_map(tdim)
        value = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int32)
        value[self.cell_tags.indices] = self.cell_tags.values
        v = np.array([value[f2c.links(k)[0]] for k in f], dtype=np.int32)
        order = np.argsort(f)
        return dolfinx.mesh.meshtags(self.mesh, tdim - 1, f[order], v[order])
