"""Reading bodies joined by duplicated-node interfaces into DOLFINx, with checks.

:func:`read_interface_mesh` reads a ``.msh`` file or the current gmsh model into DOLFINx,
collectively, with checks whose failures are raised on all ranks; :func:`create_interface_mesh`
builds with a builder of :mod:`.builders` and reads in one call. The result, an
:class:`InterfaceMesh`, knows its groups by name, its bodies, its interfaces and the two sides of
each (:mod:`.topology`: the user's own group names, ``names=``, ``bodies=``, ``interfaces=``).

Subgroups of the interface (named facet groups lying on it, e.g. a rough patch) are read by
centroid: a DOLFINx facet carries one tag: a facet in both ``interface`` and ``rough`` would keep
only one of them (gmshio drops the other). So the reader takes groups whose entities are interface
entities out of the gmsh model before DOLFINx reads it, keeps the centroids of their facets, and
puts the groups back afterwards. Such a group must lie on the interface entirely.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import dolfinx
import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from ..compat import model_to_mesh
from ._msh import open_msh
from .builders import ModelInfo
from .groups import (
    INTERFACE,
    PRIMARY,
    SECONDARY,
    InterfaceMeshError,
    body_nodes,
    gmsh_module,
    gmsh_session,
    group_elements,
    remove_new_models,
    rename_aliased_groups,
    restore_group_names,
    side_counts,
    touching_bodies,
)
from .interface_mesh import InterfaceMesh
from .nodes import NodeGroup, node_groups
from .partitioners import Partitioner, body_partitioner
from .topology import InterfaceSides, Topology, default_names, mesh_topology

__all__ = ["InterfaceMesh", "create_interface_mesh", "read_interface_mesh"]


_ERRORS: dict[str, type[Exception]] = {
    "FileNotFoundError": FileNotFoundError,
    "InterfaceMeshError": InterfaceMeshError,
    "RuntimeError": RuntimeError,
    "ValueError": ValueError,
}


def raise_collectively(comm: MPI.Comm, error: tuple[str, str] | None, root: int = 0) -> None:
    """Broadcast ``error`` (class name, message) from ``root`` and raise it on every rank."""
    error = comm.bcast(error, root=root)
    if error is not None:
        raise _ERRORS.get(error[0], InterfaceMeshError)(error[1])


def _describe_groups(groups: dict[tuple[int, int], str]) -> str:
    if not groups:
        return "none"
    return ", ".join(f"{n or '(unnamed)'!r} (dim {d}, tag {t})" for (d, t), n in groups.items())


def _inspect_current_model(
    gdim: int,
    required: Sequence[str] | None,
    what: str,
    topology: dict[str, Any],
) -> tuple[dict[str, int], Topology]:
    """Check the current gmsh model (rank 0).

    Returns:
        Name -> tag, and the topology (every interface's sides resolved: the one place they are).

    Raises:
        InterfaceMeshError: Naming what is wrong.
    """
    gmsh = gmsh_module()
    groups = {(d, t): gmsh.model.getPhysicalName(d, t) for d, t in gmsh.model.getPhysicalGroups()}
    dims = {d for d, t in groups if any(c.size for c in group_elements(d, t)[1])}
    tdim = max(dims, default=-1)
    if tdim != gdim:
        raise InterfaceMeshError(
            f"{what}: expected a {gdim}-D mesh (cells of topological dimension {gdim} for "
            f"gdim={gdim}), found cells of topological dimension {tdim} "
            f"(physical groups: {_describe_groups(groups)})"
        )
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.asarray(coords).reshape(-1, 3)
    if gdim == 2 and x.size and np.abs(x[:, 2]).max() > 1e-12 * max(1.0, np.abs(x).max()):
        raise InterfaceMeshError(
            f"{what}: expected a planar mesh (z = 0) for gdim=2, found z in "
            f"[{x[:, 2].min():g}, {x[:, 2].max():g}]"
        )
    names: dict[str, int] = {}
    by_name: dict[str, tuple[int, int]] = {}
    for (d, t), n in groups.items():
        if not n:
            continue  # unnamed groups are read by gmshio but not addressable by name
        if n in names:
            raise InterfaceMeshError(f"{what}: physical name {n!r} is used by several groups")
        names[n] = t
        by_name[n] = (d, t)
    nm = default_names(topology.get("names"))
    if required is None:  # the classic layout's groups, unless the bodies/interfaces are given
        given = topology.get("interfaces") is not None or topology.get("bodies") is not None
        required = () if given else (PRIMARY, SECONDARY, INTERFACE)
    for n in required:
        n = nm.get(n, n)
        if n not in names:
            raise InterfaceMeshError(
                f"{what}: required physical group {n!r} not found; physical groups found: "
                f"{_describe_groups(groups)}"
            )
    for role in (PRIMARY, SECONDARY, INTERFACE):
        n = nm[role]
        want = gdim - 1 if role == INTERFACE else gdim
        if n in by_name and by_name[n][0] != want:
            raise InterfaceMeshError(
                f"{what}: physical group {n!r} must have dimension {want}, found dimension "
                f"{by_name[n][0]}"
            )
    types = {t for d, tg in groups if d == gdim for t in group_elements(d, tg)[0]}
    if len(types) != 1:
        tnames = sorted(gmsh.model.mesh.getElementProperties(t)[0] for t in types)
        raise InterfaceMeshError(f"{what}: expected one cell type, found {tnames}")
    try:
        bodies, sides = mesh_topology(
            by_name,
            gdim,
            names=topology.get("names"),
            bodies=topology.get("bodies"),
            interfaces=topology.get("interfaces"),
        )
    except InterfaceMeshError as e:
        raise InterfaceMeshError(f"{what}: {e}") from None
    body_tags = {b: [names[g] for g in gs] for b, gs in bodies.items()}
    interfaces: dict[str, InterfaceSides] = {}
    for iface, side in sides.items():
        if side is None:
            touching = touching_bodies(gdim, names[iface], body_tags)
            if len(touching) != 2:
                raise InterfaceMeshError(
                    f"{what}: the interface {iface!r} touches the bodies {touching}, not two: "
                    "give its primary and secondary bodies"
                )
            side = InterfaceSides(*sorted(touching, key=lambda b: min(body_tags[b])))
        interfaces[iface] = side
        p, q = side.primary, side.secondary
        shared = np.intersect1d(body_nodes(gdim, body_tags[p]), body_nodes(gdim, body_tags[q]))
        if shared.size:
            pt = gmsh.model.mesh.getNode(int(shared[0]))[0][:gdim]
            raise InterfaceMeshError(
                f"{what}: the bodies {p!r} and {q!r} share {shared.size} nodes (e.g. at "
                f"{tuple(float(v) for v in pt)}); the interface nodes must be duplicated, e.g. "
                "with meshing.duplicate_interface_nodes (gmsh's Crack plugin with "
                "OpenBoundaryPhysicalGroup)"
            )
        n_p, n_s, n_0 = side_counts(gdim, names[iface], body_tags[p], body_tags[q])
        if n_0:
            raise InterfaceMeshError(
                f"{what}: {n_0} {iface!r} facets do not belong to the boundary of exactly one "
                f"of the bodies {p!r} and {q!r}"
            )
        if n_p != n_s and side.kinematics == "small_sliding":
            raise InterfaceMeshError(
                f"{what}: the two sides of the {iface!r} group have different numbers "
                f"of facets: {n_p} on the {p!r} side, {n_s} on the {q!r} side (sides meshed "
                "independently need the interface's kinematics 'finite_sliding')"
            )
    _no_shared_facets(gdim, names, list(interfaces), what)
    if ntags.size and not np.array_equal(np.sort(ntags), np.arange(1, ntags.size + 1)):
        # e.g. right after the Crack plugin: gmshio needs contiguous node tags
        gmsh.model.mesh.renumberNodes()
        gmsh.model.mesh.renumberElements()
    return names, Topology(dict(bodies), interfaces)


def _no_shared_facets(gdim: int, names: dict[str, int], ifaces: list[str], what: str) -> None:
    """Refuse two interfaces over the same facets (rank 0, the current gmsh model).

    Raises:
        InterfaceMeshError: Naming both groups and the number of facets they share.
    """
    if len(ifaces) < 2:
        return
    sets = {}
    for iface in ifaces:
        conns = [np.sort(c, axis=1) for c in group_elements(gdim - 1, names[iface])[1]]
        rows = {tuple(r) for c in conns for r in c.tolist()}
        sets[iface] = rows
    for i, a in enumerate(ifaces):
        for b in ifaces[i + 1 :]:
            both = sets[a] & sets[b]
            if both:
                raise InterfaceMeshError(
                    f"{what}: the interfaces {a!r} and {b!r} share {len(both)} facets (of "
                    f"{len(sets[a])} and {len(sets[b])}): two interfaces over the same facets; "
                    "give each interface facets of its own (one physical group per interface)"
                )


def read_interface_mesh(
    source: str | os.PathLike | None,
    comm: MPI.Comm,
    gdim: int,
    *,
    partitioner: str | Partitioner | None = None,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    required: Sequence[str] | None = None,
    names: dict[str, str] | None = None,
    bodies: dict[str, str | Sequence[str]] | None = None,
    interfaces: dict[str, Any] | Sequence[str] | None = None,
) -> InterfaceMesh:
    """Read bodies joined by duplicated-node interfaces into DOLFINx (collective).

    Rank 0 reads and checks the gmsh data; every failure is raised on all ranks. Groups named by
    the built-in meshes' older names (``master``, ``slave``, ``slave_left``, ...: input aliases,
    :data:`~.groups.CLASSIC_ALIASES`) are read under their names (``primary``, ``secondary``,
    ``secondary_left``); a current gmsh model keeps its own names.

    Args:
        source: Path of an MSH file (format 2 or 4, ASCII or binary), or ``None`` for the
            current gmsh model of rank 0 (its node tags are renumbered if they have gaps, as
            after the Crack plugin).
        comm: Communicator of the mesh.
        gdim: Expected geometric (= topological) dimension, 2 or 3.
        partitioner: A partitioner callable, a kind of :func:`body_partitioner`, or ``None``:
            with a finite-sliding interface its ``"balanced"`` kind (every body, and its cells on
            an interface, shared evenly by the ranks: so is the search and projection), else
            DOLFINx's default partitioner.
        ghost_mode: Ghost mode for the default partitioner or a :func:`body_partitioner` kind.
        required: Physical groups that must be present (the roles ``primary``, ``secondary``,
            ``interface`` stand for the groups ``names`` gives them); ``None``: the classic
            layout's three groups, unless ``bodies`` or ``interfaces`` are given.
        names: The classic layout's roles -> the user's group names, e.g. ``{"primary": "base",
            "secondary": "block", "interface": "contact"}`` (:mod:`.topology`).
        bodies: Body -> its cell group(s); default: every named cell group is a body.
        interfaces: Interface group -> (primary, secondary) bodies (or a dict with these keys),
            or a list of interface groups (the two bodies each touches; the primary is the one
            whose first cell group has the smaller tag); default: the classic ``interface``.

    Returns:
        The mesh, its tags, the name -> tag dictionary, the bodies, interfaces and their sides.

    Raises:
        FileNotFoundError: ``source`` does not exist.
        InterfaceMeshError: Not an MSH file (format 2 or 4, ASCII or binary: anything else, e.g.
            a ``.geo`` script, is refused before gmsh opens it), wrong dimension, a required
            group missing, several cell types, bodies sharing nodes, interface sides with
            different numbers of facets, interface facets that are not exterior facets of
            exactly one body, group elements that are not entities of the mesh (which gmshio
            would drop silently), an unknown body or group in ``names``/``bodies``/
            ``interfaces``.
    """
    if gdim not in (2, 3):
        raise ValueError(f"gdim must be 2 or 3, got {gdim!r}")
    what = "current gmsh model" if source is None else str(source)
    error: tuple[str, str] | None = None
    tags: dict[str, int] = {}
    counts: dict[str, tuple[int, int]] = {}  # name -> (dimension, number of elements)
    dims: dict[str, int] = {}  # name -> dimension, every named group
    nodes: dict[str, NodeGroup] = {}  # physical groups of points
    found = Topology()
    subgroups: dict[str, np.ndarray] = {}
    model = None
    topology = {"names": names, "bodies": bodies, "interfaces": interfaces}
    with contextlib.ExitStack() as stack:
        if comm.rank == 0:
            try:
                gmsh = gmsh_module()
                if source is None:
                    if not gmsh.isInitialized() or not gmsh.model.list():
                        raise InterfaceMeshError(
                            "read_interface_mesh(None): no current gmsh model on rank 0"
                        )
                else:
                    path = Path(source)
                    name = stack.enter_context(open_msh(path))  # MSH only: nothing runs
                    stack.enter_context(gmsh_session(f"subfric-read-{os.getpid()}"))
                    try:
                        gmsh.merge(name)
                    except Exception as e:
                        raise InterfaceMeshError(f"gmsh could not read {path}: {e}") from e
                stack.callback(restore_group_names, rename_aliased_groups(what))
                tags, found = _inspect_current_model(gdim, required, what, topology)
                b = found.bodies
                subgroups, withheld = withhold_interface_subgroups(
                    gdim, tags, what, list(found.interfaces)
                )
                stack.callback(restore_groups, withheld)
                for name in subgroups:
                    tags.pop(name)
                for d, t in gmsh.model.getPhysicalGroups():
                    name = gmsh.model.getPhysicalName(d, t)
                    if name:
                        dims[name] = d
                    if d >= gdim - 1 and name:
                        counts[name] = (d, sum(c.shape[0] for c in group_elements(d, t)[1]))
                nodes = node_groups(
                    gdim, tags, {bd: tuple(tags[g] for g in gs) for bd, gs in b.items()}
                )
                model = gmsh.model
            except (FileNotFoundError, InterfaceMeshError) as e:
                error = (type(e).__name__, str(e))
            except Exception as e:  # anything else, e.g. from gmsh: report on all ranks
                error = ("InterfaceMeshError", f"{what}: {type(e).__name__}: {e}")
        raise_collectively(comm, error)
        tags = comm.bcast(tags, root=0)
        subgroups = comm.bcast(subgroups, root=0)
        counts = comm.bcast(counts, root=0)
        dims = comm.bcast(dims, root=0)
        nodes = comm.bcast(nodes, root=0)
        found = comm.bcast(found, root=0)
        if partitioner is None and comm.size > 1:
            finite = ghost_mode in (
                dolfinx.mesh.GhostMode.none,
                dolfinx.mesh.GhostMode.shared_facet,
            ) and any(v.kinematics == "finite_sliding" for v in found.interfaces.values())
            partitioner = "balanced" if finite else "default"
        if isinstance(partitioner, str):
            partitioner = body_partitioner(
                partitioner, ghost_mode, bodies=found.bodies, interfaces=list(found.interfaces)
            )
        mesh, ct, ft = model_to_mesh(model, comm, 0, gdim=gdim, partitioner=partitioner)
    imesh = InterfaceMesh(
        mesh=mesh,
        cell_tags=ct,
        facet_tags=ft,
        tags=tags,
        dims=dims,
        interface_groups=subgroups,
        node_groups=nodes,
        topology=found,
    )
    check_group_counts(imesh, counts, what)
    for iface in found.interfaces:
        find_sides(imesh, iface, what)
    if found.interfaces:
        first = next(iter(found.interfaces))
        imesh.num_interface_facets = imesh._counts[first]
    return imesh


def check_group_counts(imesh: InterfaceMesh, counts: dict[str, tuple[int, int]], what: str) -> None:
    """Check that every cell and facet of the gmsh groups made it into the DOLFINx tags.

    gmshio silently drops tagged facets that are not facets of the mesh cells, e.g. boundary
    elements that use the other body's copy of a duplicated node.
    """
    mesh, tdim = imesh.mesh, imesh.tdim
    items = sorted(counts.items())
    local = np.zeros(len(items), dtype=np.int64)
    for i, (name, (dim, _)) in enumerate(items):
        tags = imesh.cell_tags if dim == tdim else imesh.facet_tags
        found = tags.find(imesh.tags[name])
        local[i] = np.count_nonzero(found < mesh.topology.index_map(dim).size_local)
    total = np.zeros_like(local)
    mesh.comm.Allreduce(local, total, op=MPI.SUM)
    lost = [
        f"{name!r}: {n - int(k)} of {n}"
        for (name, (_, n)), k in zip(items, total, strict=True)
        if int(k) != n
    ]
    if lost:
        raise InterfaceMeshError(
            f"{what}: elements of physical groups are not entities of the DOLFINx mesh "
            f"({', '.join(lost)}); boundary elements must use the nodes of their own body"
        )


def find_sides(imesh: InterfaceMesh, iface: str, what: str) -> None:
    """Split an interface's facets by the body of the adjacent cell, with collective checks."""
    mesh, comm, tdim = imesh.mesh, imesh.mesh.comm, imesh.tdim
    sides_of = imesh.interfaces[iface]
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    imap = mesh.topology.index_map(tdim)
    cell_value = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int32)
    cell_value[imesh.cell_tags.indices] = imesh.cell_tags.values
    facets = imesh.facet_tags.find(imesh.tag(iface))
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
    body = cell_value[cells] if facets.size else np.empty(0, dtype=np.int32)
    nf_owned = mesh.topology.index_map(tdim - 1).size_local
    owned = facets < nf_owned
    in_p = np.isin(body, imesh.body_tags(sides_of.primary))
    in_s = np.isin(body, imesh.body_tags(sides_of.secondary))
    sides = {"primary": facets[in_p], "secondary": facets[in_s]}
    local = np.array(
        [
            np.count_nonzero(owned),
            np.count_nonzero(owned & ~np.isin(facets, exterior)),  # exterior: owned only
            np.count_nonzero(owned & in_p),
            np.count_nonzero(owned & in_s),
        ],
        dtype=np.int64,
    )
    total = np.zeros_like(local)
    comm.Allreduce(local, total, op=MPI.SUM)
    n_owned, n_interior, n_p, n_s = (int(v) for v in total)
    if n_interior:
        raise InterfaceMeshError(
            f"{what}: {n_interior} {iface!r} facets are interior facets (shared by two "
            "cells); the interface nodes must be duplicated"
        )
    matching = sides_of.kinematics == "small_sliding"
    if (matching and n_p != n_s) or n_p + n_s != n_owned:
        p, q = sides_of.primary, sides_of.secondary
        raise InterfaceMeshError(
            f"{what}: the two sides of the {iface!r} group have different numbers of facets: "
            f"{n_p} on the {p!r} side, {n_s} on the {q!r} side"
            + (f", {n_owned - n_p - n_s} next to neither body" if n_p + n_s != n_owned else "")
        )
    imesh._sides[iface] = sides
    imesh._counts[iface] = n_p


def create_interface_mesh(
    builder: Callable[..., ModelInfo],
    comm: MPI.Comm,
    *,
    partitioner: str | Partitioner | None = None,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    names: dict[str, str] | None = None,
    bodies: dict[str, str | Sequence[str]] | None = None,
    interfaces: dict[str, Any] | Sequence[str] | None = None,
    **kwargs: Any,
) -> tuple[InterfaceMesh, ModelInfo]:
    """Build a model with ``builder(**kwargs)`` on rank 0 and read it into DOLFINx (collective).

    gmsh is initialised on rank 0 if needed (and finalised afterwards); the model is removed from
    the session once read. A builder failure is raised on all ranks.

    Args:
        builder: :func:`build_block_on_base`, :func:`build_pad_on_plate`, or alike.
        comm: Communicator of the mesh.
        partitioner: As in :func:`read_interface_mesh`.
        ghost_mode: As in :func:`read_interface_mesh`.
        names: As in :func:`read_interface_mesh`.
        bodies: As in :func:`read_interface_mesh`.
        interfaces: As in :func:`read_interface_mesh`.
        **kwargs: Passed to ``builder`` (whose result has the model's ``gdim``).

    Returns:
        The mesh and the builder's model description (the same on all ranks).
    """
    error: tuple[str, str] | None = None
    info: ModelInfo | None = None
    with contextlib.ExitStack() as stack:
        if comm.rank == 0:
            try:
                gmsh = stack.enter_context(gmsh_session(None))
                stack.callback(remove_new_models, gmsh, gmsh.model.list(), gmsh.model.getCurrent())
                info = builder(**kwargs)
            except Exception as e:
                error = (type(e).__name__, f"{getattr(builder, '__name__', builder)}: {e}")
        raise_collectively(comm, error)
        info = comm.bcast(info, root=0)
        assert info is not None  # (the builder's, from the root)
        imesh = read_interface_mesh(
            None,
            comm,
            info.gdim,
            partitioner=partitioner,
            ghost_mode=ghost_mode,
            names=names,
            bodies=bodies,
            interfaces=interfaces,
        )
    return imesh, info


# -- Subgroups of the interface, withheld from DOLFINx and restored


def _centroids(gdim: int, entities: list[int]) -> np.ndarray:
    """Centroids (mean of the corner nodes) of the elements of facet ``entities``, deduplicated."""
    gmsh = gmsh_module()
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(ntags.max()) + 1 if ntags.size else 0, 3))
    x[ntags] = np.asarray(coords).reshape(-1, 3)
    out = []
    for e in entities:
        for etype, _, enodes in zip(*gmsh.model.mesh.getElements(gdim - 1, e), strict=True):
            props = gmsh.model.mesh.getElementProperties(int(etype))
            conn = np.asarray(enodes, dtype=np.int64).reshape(-1, props[3])[:, : props[5]]
            out.append(x[conn].mean(axis=1)[:, :gdim])
    c = np.concatenate(out) if out else np.zeros((0, gdim))
    if not c.size:
        return c
    scale = max(1.0, float(np.abs(x).max()))
    _, first = np.unique(np.round(c / (1e-9 * scale)).astype(np.int64), axis=0, return_index=True)
    return c[np.sort(first)]


def withhold_interface_subgroups(
    gdim: int, names: dict[str, int], what: str, interfaces: Sequence[str] = (INTERFACE,)
) -> tuple[dict[str, np.ndarray], list[tuple[int, int, str, list[int]]]]:
    """Take the interfaces' subgroups out of the current gmsh model (rank 0).

    Returns:
        Name -> facet centroids (n, gdim), and what to give :func:`restore_groups`.

    Raises:
        InterfaceMeshError: A named facet group lies partly on an interface.
    """
    gmsh = gmsh_module()
    interfaces = [i for i in interfaces if i in names]
    if not interfaces:
        return {}, []
    fdim = gdim - 1
    owner = {
        int(e): i
        for i in interfaces
        for e in gmsh.model.getEntitiesForPhysicalGroup(fdim, names[i])
    }
    groups: dict[str, np.ndarray] = {}
    withheld: list[tuple[int, int, str, list[int]]] = []
    for d, t in gmsh.model.getPhysicalGroups(fdim):
        name = gmsh.model.getPhysicalName(d, t)
        if not name or name in interfaces:
            continue
        ents = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(d, t)]
        on = [e for e in ents if e in owner]
        if not on:
            continue
        host = owner[on[0]]
        if len(on) != len(ents) or any(owner[e] != host for e in on):
            raise InterfaceMeshError(
                f"{what}: the facet group {name!r} lies partly on the {host!r} group "
                f"({len(ents) - len(on)} of its {len(ents)} entities are not interface entities); "
                "a group of interface facets (an interface region) must lie on one interface only"
            )
        groups[name] = _centroids(gdim, ents)
        withheld.append((d, t, name, ents))
    for d, t, _, _ in withheld:
        gmsh.model.removePhysicalGroups([(d, t)])
    return groups, withheld


def restore_groups(withheld: list[tuple[int, int, str, list[int]]]) -> Any:
    """Put withheld groups back into the current gmsh model (if it still exists)."""
    gmsh = gmsh_module()
    if not withheld or not gmsh.isInitialized():
        return
    for d, t, name, ents in withheld:
        gmsh.model.addPhysicalGroup(d, ents, t, name=name)
