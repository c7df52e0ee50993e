"""A model meshed once, written in DOLFINx's partitioned XDMF/HDF5 format and read back in parts.

:func:`write_partitioned_mesh` writes an :class:`~.interface_mesh.InterfaceMesh` (read from a
``.msh`` file or built with gmsh, its interface nodes duplicated) as three files:

* ``MODEL.xdmf`` and ``MODEL.h5``: DOLFINx's XDMF/HDF5 of the mesh (grid ``mesh``), its cell tags
  (grid ``cell_tags``) and its facet tags (grid ``facet_tags``), written collectively, each rank
  its part;
* ``MODEL.groups.json``: what the tags mean: the group names and their tags, dimensions and
  numbers of entities, the bodies, the interfaces and their sides, the interface subgroups (the
  centroids of their facets) and the node groups. It is data, read with :mod:`json` and checked
  (:func:`parse_groups`), never executed.

:func:`read_partitioned_mesh` reads them back collectively: each rank reads its part of the mesh
and of the tags (``dolfinx.io.XDMFFile.read_mesh``/``read_meshtags``, DOLFINx's partitioner),
rank 0 reads and checks the JSON and the XDMF's references, and every failure is raised on every
rank. The mesh's duplicated interface nodes stay duplicated (the XDMF stores nodes, not
coordinates to merge), and the reader checks again what :func:`~.reader.read_interface_mesh`
checks: every group's number of entities, the two sides of every interface.

To convert a ``.msh`` file::

    python3 -m subfric_dolfinx.meshing.partitioned MODEL.msh MODEL.xdmf --gdim 3

(on one or several ranks: ``mpirun -n 4 python3 -m ...``; the ``.msh`` is read on rank 0, as
:func:`~.reader.read_interface_mesh` does, the files are written by every rank). A scene reads the
result with ``"mesh": {"file": "MODEL.xdmf", "gdim": 3}``.
"""

from __future__ import annotations

import json
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import dolfinx
import dolfinx.io
import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from .groups import InterfaceMeshError
from .interface_mesh import InterfaceMesh
from .nodes import NodeGroup
from .reader import check_group_counts, find_sides, raise_collectively
from .topology import KINEMATICS, InterfaceSides, Topology, mesh_topology

__all__ = [
    "FORMAT",
    "groups_path",
    "parse_groups",
    "read_partitioned_mesh",
    "write_partitioned_mesh",
]

FORMAT = "subfric-dolfinx mesh groups"
"""The ``format`` of a groups file (``MODEL.groups.json``); its ``version`` is 1."""

GRIDS = ("mesh", "cell_tags", "facet_tags")
"""The XDMF grids of a partitioned mesh: the mesh, its cell tags, its facet tags."""

CELL_TYPES = ("triangle", "quadrilateral", "tetrahedron", "hexahedron", "prism", "pyramid")
"""The cell types a groups file may name (DOLFINx's names)."""

MAX_JSON_BYTES = 256 * 2**20
"""The largest groups file read (its interface subgroups' centroids may be long)."""

_MAX_NAME = 100


def groups_path(path: str | os.PathLike) -> Path:
    """The groups file beside an XDMF file: ``MODEL.xdmf`` -> ``MODEL.groups.json``."""
    p = Path(path)
    return p.with_name(p.stem + ".groups.json")


def _plain_name(value: Any, where: str) -> str:
    """A group, body or interface name: a plain name, not a path.

    Raises:
        InterfaceMeshError: Not a string, empty, longer than 100 characters, ``.`` or ``..``,
            with a slash, a backslash or a control character.
    """
    bad = (
        not isinstance(value, str)
        or not value
        or value in (".", "..")
        or len(value) > _MAX_NAME
        or any(c in "/\\" or ord(c) < 32 or ord(c) == 127 for c in value)
    )
    if bad:
        shown = repr(value) if len(repr(value)) <= 80 else repr(value)[:77] + "..."
        raise InterfaceMeshError(
            f"{where}: expected a plain name (1 to {_MAX_NAME} characters, no '/', '\\', control "
            f"characters, not '.' or '..'), got {shown}"
        )
    return value


def _points(value: Any, gdim: int, where: str) -> np.ndarray:
    """An (n, gdim) array of finite coordinates from a JSON list of lists.

    Raises:
        InterfaceMeshError: Another shape, or a value that is no finite number.
    """
    if not isinstance(value, list) or not all(
        isinstance(r, list)
        and len(r) == gdim
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in r)
        for r in value
    ):
        raise InterfaceMeshError(f"{where}: expected a list of points of {gdim} numbers each")
    a = np.asarray(value, dtype=float).reshape(-1, gdim)
    if not np.all(np.isfinite(a)):
        raise InterfaceMeshError(f"{where}: a coordinate is not a finite number")
    return a


def _keys(obj: Any, where: str, required: Sequence[str], optional: Sequence[str] = ()) -> dict:
    if not isinstance(obj, dict):
        raise InterfaceMeshError(f"{where}: expected an object, got {type(obj).__name__}")
    missing = [k for k in required if k not in obj]
    extra = sorted(set(obj) - set(required) - set(optional))
    if missing or extra:
        raise InterfaceMeshError(
            f"{where}: "
            + (f"missing key(s) {missing}" if missing else "")
            + ("; " if missing and extra else "")
            + (f"unknown key(s) {extra}" if extra else "")
        )
    return obj


def _mapping(obj: Any, where: str) -> dict:
    """A JSON object whose keys are names (checked by the caller)."""
    if not isinstance(obj, dict):
        raise InterfaceMeshError(f"{where}: expected an object, got {type(obj).__name__}")
    return obj


def _int(value: Any, where: str, lo: int = 0) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < lo:
        raise InterfaceMeshError(f"{where}: expected an integer >= {lo}, got {value!r}")
    return value


def _describe(domain: InterfaceMesh) -> dict[str, Any]:
    """The groups file's content for ``domain`` (collective: the groups' entity counts)."""
    mesh, tdim = domain.mesh, domain.tdim
    items = sorted(domain.tags.items())
    local = np.zeros(len(items), dtype=np.int64)
    for i, (name, tag) in enumerate(items):
        dim = domain.dims.get(name, tdim)
        if dim not in (tdim - 1, tdim):  # (points, curves in 3-D: in no tags of the mesh)
            continue
        tags = domain.cell_tags if dim == tdim else domain.facet_tags
        found = tags.find(tag)
        local[i] = np.count_nonzero(found < mesh.topology.index_map(dim).size_local)
    total = np.zeros_like(local)
    mesh.comm.Allreduce(local, total, op=MPI.SUM)
    gdim = domain.gdim
    return {
        "format": FORMAT,
        "version": 1,
        "gdim": gdim,
        "cell_type": mesh.topology.cell_type.name,
        "groups": {
            name: {"tag": int(tag), "dim": int(domain.dims.get(name, tdim)), "count": int(n)}
            for (name, tag), n in zip(items, total, strict=True)
        },
        "bodies": {b: list(gs) for b, gs in domain.bodies.items()},
        "interfaces": {
            name: {"primary": s.primary, "secondary": s.secondary, "kinematics": s.kinematics}
            for name, s in domain.interfaces.items()
        },
        "interface_groups": {
            name: np.asarray(c, dtype=float).reshape(-1, gdim).tolist()
            for name, c in domain.interface_groups.items()
        },
        "node_groups": {
            name: {"x": g.x[:, :gdim].tolist(), "bodies": list(g.bodies)}
            for name, g in domain.node_groups.items()
        },
    }


def parse_groups(obj: Any, what: str = "groups file") -> dict[str, Any]:
    """Check the content of a groups file (:func:`write_partitioned_mesh` writes it).

    Returns:
        ``gdim``, ``cell_type``, ``tags`` (name -> tag), ``dims`` (name -> dimension),
        ``counts`` (name -> (dimension, number of entities), the groups of cells and facets),
        ``topology``
        (:class:`~.topology.Topology`), ``interface_groups`` (name -> (n, gdim) centroids) and
        ``node_groups`` (name -> :class:`~.nodes.NodeGroup`).

    Raises:
        InterfaceMeshError: Naming the key path of what is wrong: another format or version,
            a missing or unknown key, a name that is not a plain name (e.g. a path), a tag given
            to two groups of one dimension, a body or an interface naming an unknown group.
    """
    keys = ("format", "version", "gdim", "cell_type", "groups", "bodies", "interfaces")
    _keys(obj, what, keys, ("interface_groups", "node_groups"))
    if obj["format"] != FORMAT or obj["version"] != 1:
        raise InterfaceMeshError(
            f"{what}: not a groups file of format {FORMAT!r} version 1 (format "
            f"{obj['format']!r}, version {obj['version']!r})"
        )
    gdim = obj["gdim"]
    if gdim not in (2, 3) or isinstance(gdim, bool):
        raise InterfaceMeshError(f"{what}.gdim: expected 2 or 3, got {gdim!r}")
    cell_type = obj["cell_type"]
    if not isinstance(cell_type, str) or cell_type not in CELL_TYPES:
        raise InterfaceMeshError(f"{what}.cell_type: not a cell type: {cell_type!r}")
    groups = _mapping(obj["groups"], f"{what}.groups")
    tags: dict[str, int] = {}
    dims: dict[str, int] = {}
    counts: dict[str, tuple[int, int]] = {}
    seen: dict[tuple[int, int], str] = {}
    for name, g in groups.items():
        where = f"{what}.groups.{_plain_name(name, f'{what}.groups')}"
        _keys(g, where, ("tag", "dim", "count"))
        tag, dim, n = _int(g["tag"], f"{where}.tag"), g["dim"], _int(g["count"], f"{where}.count")
        if dim not in range(gdim + 1) or isinstance(dim, bool):
            raise InterfaceMeshError(f"{where}.dim: expected 0 to {gdim}, got {dim!r}")
        if (dim, tag) in seen:
            raise InterfaceMeshError(
                f"{where}.tag: {tag} is also the tag of {seen[dim, tag]!r} (dimension {dim})"
            )
        seen[dim, tag] = name
        tags[name], dims[name] = tag, dim
        if dim >= gdim - 1:  # (the mesh's tags hold cells and facets)
            counts[name] = (dim, n)
    by_name = {n: (dims[n], tags[n]) for n in tags}
    bodies: dict[str, list[str]] = {}
    for body, gs in _mapping(obj["bodies"], f"{what}.bodies").items():
        where = f"{what}.bodies.{_plain_name(body, f'{what}.bodies')}"
        if not isinstance(gs, list) or not gs:
            raise InterfaceMeshError(f"{where}: expected a list of cell groups, got {gs!r}")
        bodies[body] = [_plain_name(g, where) for g in gs]
    interfaces: dict[str, dict[str, str]] = {}
    for iface, s in _mapping(obj["interfaces"], f"{what}.interfaces").items():
        where = f"{what}.interfaces.{_plain_name(iface, f'{what}.interfaces')}"
        _keys(s, where, ("primary", "secondary", "kinematics"))
        if s["kinematics"] not in KINEMATICS:
            raise InterfaceMeshError(
                f"{where}.kinematics: expected one of {list(KINEMATICS)}, got {s['kinematics']!r}"
            )
        interfaces[iface] = {
            "primary": _plain_name(s["primary"], f"{where}.primary"),
            "secondary": _plain_name(s["secondary"], f"{where}.secondary"),
            "kinematics": s["kinematics"],
        }
    try:
        found_bodies, sides = mesh_topology(by_name, gdim, bodies=bodies, interfaces=interfaces)
    except InterfaceMeshError as e:
        raise InterfaceMeshError(f"{what}: {e}") from None
    topology = Topology(
        dict(found_bodies), {k: v for k, v in sides.items() if isinstance(v, InterfaceSides)}
    )
    igroups: dict[str, np.ndarray] = {}
    for name, c in _mapping(obj.get("interface_groups", {}), f"{what}.interface_groups").items():
        where = f"{what}.interface_groups.{_plain_name(name, f'{what}.interface_groups')}"
        igroups[name] = _points(c, gdim, where)
    nodes: dict[str, NodeGroup] = {}
    for name, g in _mapping(obj.get("node_groups", {}), f"{what}.node_groups").items():
        where = f"{what}.node_groups.{_plain_name(name, f'{what}.node_groups')}"
        _keys(g, where, ("x", "bodies"))
        x = _points(g["x"], gdim, f"{where}.x")
        owners = g["bodies"]
        if not isinstance(owners, list) or len(owners) != x.shape[0]:
            raise InterfaceMeshError(f"{where}.bodies: expected one body (or null) per node")
        for b in owners:
            if b is not None and b not in found_bodies and b not in tags:
                raise InterfaceMeshError(f"{where}.bodies: {b!r} is no body of the mesh")
        x3 = np.zeros((x.shape[0], 3))
        x3[:, :gdim] = x
        nodes[name] = NodeGroup(x3, tuple(owners))
        dims[name] = 0
    for name in igroups:
        dims[name] = gdim - 1
    return {
        "gdim": gdim,
        "cell_type": cell_type,
        "tags": tags,
        "dims": dims,
        "counts": counts,
        "topology": topology,
        "interface_groups": igroups,
        "node_groups": nodes,
    }


def _strict_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise InterfaceMeshError(f"the key {k!r} is given twice in one object")
        out[k] = v
    return out


def _no_constant(name: str) -> Any:
    raise InterfaceMeshError(f"{name} is not a JSON number")


def read_groups_file(path: Path) -> dict[str, Any]:
    """Read and check a groups file (one process).

    Raises:
        FileNotFoundError: No such file.
        InterfaceMeshError: Too large, not UTF-8 JSON, a key given twice, or bad content
            (:func:`parse_groups`); the message names the file.
    """
    what = str(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such groups file (written beside the XDMF file)")
    if path.stat().st_size > MAX_JSON_BYTES:
        raise InterfaceMeshError(f"{what}: larger than {MAX_JSON_BYTES} bytes")
    try:
        obj = json.loads(
            path.read_bytes().decode("utf-8"),
            object_pairs_hook=_strict_pairs,
            parse_constant=_no_constant,
        )
    except InterfaceMeshError as e:
        raise InterfaceMeshError(f"{what}: {e}") from None
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise InterfaceMeshError(f"{what}: not a JSON file: {e}") from None
    return parse_groups(obj, what)


def _check_xdmf(path: Path) -> None:
    """Check an XDMF file's grids and the HDF5 datasets they name (one process).

    Every ``HDF`` data item must name a plain file beside the XDMF file (no directory) and a
    dataset of the declared dimensions in it.

    Raises:
        FileNotFoundError: The XDMF file or its HDF5 file does not exist.
        InterfaceMeshError: Not XML, a grid of :data:`GRIDS` missing, a data item naming a path or
            a missing dataset.
    """
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such XDMF file")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError, ValueError) as e:
        raise InterfaceMeshError(f"{path}: not an XDMF (XML) file: {e}") from None
    grids = {g.get("Name"): g for g in root.iter("Grid")}
    missing = [g for g in GRIDS if g not in grids]
    if missing:
        raise InterfaceMeshError(
            f"{path}: grid(s) {missing} missing (found {sorted(n for n in grids if n)}); a "
            "partitioned mesh has its mesh, cell tags and facet tags (write_partitioned_mesh)"
        )
    items: list[tuple[str, str, tuple[int, ...]]] = []
    for name in GRIDS:
        for item in grids[name].iter("DataItem"):
            if item.get("Format") != "HDF":
                continue
            text = (item.text or "").strip()
            file, _, dataset = text.partition(":")
            if not file or not dataset or Path(file).name != file or file in (".", ".."):
                raise InterfaceMeshError(
                    f"{path}: grid {name!r} refers to {text[:80]!r}: expected a plain HDF5 file "
                    "name beside the XDMF file and a dataset ('MODEL.h5:/path')"
                )
            try:
                dims = tuple(int(v) for v in (item.get("Dimensions") or "").split())
            except ValueError:
                raise InterfaceMeshError(
                    f"{path}: grid {name!r}: bad Dimensions {item.get('Dimensions')!r}"
                ) from None
            items.append((file, dataset, dims))
    import h5py  # (rank 0 only, serially: any h5py build)

    for file in sorted({f for f, _, _ in items}):
        h5 = path.with_name(file)
        if not h5.is_file():
            raise FileNotFoundError(f"{path}: its HDF5 file {h5} does not exist")
        try:
            with h5py.File(h5, "r") as f:
                for ff, dataset, dims in items:
                    if ff != file:
                        continue
                    d = f.get(dataset)
                    if not isinstance(d, h5py.Dataset) or (dims and tuple(d.shape) != dims):
                        got = "missing" if d is None else f"of shape {getattr(d, 'shape', '?')}"
                        raise InterfaceMeshError(
                            f"{path}: the dataset {dataset!r} of {h5.name} is {got}, the XDMF "
                            f"file declares {dims}"
                        )
        except OSError as e:
            raise InterfaceMeshError(f"{h5}: not a readable HDF5 file: {e}") from None


def write_partitioned_mesh(domain: InterfaceMesh, path: str | os.PathLike) -> tuple[Path, Path]:
    """Write ``domain`` as ``MODEL.xdmf``/``MODEL.h5`` and ``MODEL.groups.json`` (collective).

    Args:
        domain: The mesh, e.g. from :func:`~.reader.read_interface_mesh`.
        path: The XDMF file (``.xdmf``); the HDF5 and groups files are written beside it.

    Returns:
        The XDMF file and the groups file.

    Raises:
        ValueError: ``path`` does not end with ``.xdmf`` (on every rank).
        InterfaceMeshError: The groups file cannot be written (on every rank).
    """
    path = Path(path)
    if path.suffix != ".xdmf":
        raise ValueError(f"expected an .xdmf file name, got {str(path)!r}")
    mesh, comm, tdim = domain.mesh, domain.mesh.comm, domain.tdim
    desc = _describe(domain)
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim - 1, 0)
    names = (mesh.name, domain.cell_tags.name, domain.facet_tags.name)
    mesh.name, domain.cell_tags.name, domain.facet_tags.name = GRIDS
    geometry = f"/Xdmf/Domain/Grid[@Name='{GRIDS[0]}']/Geometry"
    try:
        with dolfinx.io.XDMFFile(comm, str(path), "w") as f:
            f.write_mesh(mesh)
            f.write_meshtags(domain.cell_tags, mesh.geometry, geometry_xpath=geometry)
            f.write_meshtags(domain.facet_tags, mesh.geometry, geometry_xpath=geometry)
    finally:
        mesh.name, domain.cell_tags.name, domain.facet_tags.name = names
    out = groups_path(path)
    error: tuple[str, str] | None = None
    if comm.rank == 0:
        try:
            tmp = out.with_name(out.name + ".tmp")
            tmp.write_text(json.dumps(desc, indent=1) + "\n", encoding="utf-8")
            tmp.replace(out)
        except OSError as e:
            error = ("InterfaceMeshError", f"{out}: cannot write the groups file: {e}")
    raise_collectively(comm, error)
    return path, out


def read_partitioned_mesh(
    path: str | os.PathLike,
    comm: MPI.Comm,
    gdim: int | None = None,
    *,
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none,
    names: Mapping[str, str] | None = None,
    bodies: Mapping[str, str | Sequence[str]] | None = None,
    interfaces: Mapping[str, Any] | Sequence[str] | None = None,
) -> InterfaceMesh:
    """Read a mesh written by :func:`write_partitioned_mesh`, each rank its part (collective).

    Args:
        path: The XDMF file (its ``.h5`` and ``.groups.json`` beside it).
        comm: Communicator of the mesh.
        gdim: The expected dimension (``None``: the file's).
        ghost_mode: Ghost mode of DOLFINx's partitioner.
        names: As in :func:`~.reader.read_interface_mesh` (with ``bodies`` or ``interfaces``).
        bodies: Bodies instead of the file's (each a cell group or a list of them).
        interfaces: Interfaces instead of the file's; sides given as ``None`` (or a list of
            interface groups) are those the file gives.

    Returns:
        The mesh with its groups, bodies, interfaces and sides.

    Raises:
        FileNotFoundError: A file is missing (on every rank).
        InterfaceMeshError: Bad groups file, an XDMF file without its grids or datasets, another
            dimension than ``gdim``, a group whose number of entities differs from the groups
            file's, interface sides that do not match (on every rank).
    """
    path = Path(path)
    what = str(path)
    error: tuple[str, str] | None = None
    desc: dict[str, Any] | None = None
    if comm.rank == 0:
        try:
            if path.suffix != ".xdmf":
                raise InterfaceMeshError(f"{what}: expected an .xdmf file")
            _check_xdmf(path)
            desc = read_groups_file(groups_path(path))
            if gdim is not None and desc["gdim"] != gdim:
                raise InterfaceMeshError(
                    f"{what}: expected a {gdim}-D mesh, the groups file says {desc['gdim']}-D"
                )
            if names is not None or bodies is not None or interfaces is not None:
                desc["topology"] = _own_topology(desc, names, bodies, interfaces, what)
        except (FileNotFoundError, InterfaceMeshError) as e:
            error = (type(e).__name__, str(e))
        except Exception as e:  # anything else: on every rank
            error = ("InterfaceMeshError", f"{what}: {type(e).__name__}: {e}")
    raise_collectively(comm, error)
    desc = comm.bcast(desc, root=0)
    assert desc is not None  # (rank 0's, checked)
    with dolfinx.io.XDMFFile(comm, str(path), "r") as f:
        mesh = f.read_mesh(ghost_mode=ghost_mode, name=GRIDS[0])
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        ct = f.read_meshtags(mesh, name=GRIDS[1])
        ft = f.read_meshtags(mesh, name=GRIDS[2])
    if mesh.topology.cell_type.name != desc["cell_type"] or mesh.geometry.dim != desc["gdim"]:
        raise InterfaceMeshError(
            f"{what}: a {mesh.geometry.dim}-D mesh of {mesh.topology.cell_type.name} cells, the "
            f"groups file says {desc['gdim']}-D {desc['cell_type']}"
        )
    imesh = InterfaceMesh(
        mesh=mesh,
        cell_tags=ct,
        facet_tags=ft,
        tags=desc["tags"],
        dims=desc["dims"],
        interface_groups=desc["interface_groups"],
        node_groups=desc["node_groups"],
        topology=desc["topology"],
    )
    _check_tag_values(imesh, desc["tags"], what)
    check_group_counts(imesh, desc["counts"], what)
    for iface in imesh.interfaces:
        find_sides(imesh, iface, what)
    if imesh.interfaces:
        imesh.num_interface_facets = imesh._counts[next(iter(imesh.interfaces))]
    return imesh


def _own_topology(
    desc: dict[str, Any],
    names: Mapping[str, str] | None,
    bodies: Mapping[str, str | Sequence[str]] | None,
    interfaces: Mapping[str, Any] | Sequence[str] | None,
    what: str,
) -> Topology:
    """The topology the caller gives, resolved against the file's groups (rank 0).

    Interfaces whose sides are not given take the file's.

    Raises:
        InterfaceMeshError: An unknown group or body, or an interface without sides that the file
            does not know.
    """
    by_name = {n: (desc["dims"][n], t) for n, t in desc["tags"].items()}
    try:
        found_bodies, sides = mesh_topology(
            by_name, desc["gdim"], names=names, bodies=bodies, interfaces=interfaces
        )
    except InterfaceMeshError as e:
        raise InterfaceMeshError(f"{what}: {e}") from None
    known = desc["topology"].interfaces
    out: dict[str, InterfaceSides] = {}
    for name, s in sides.items():
        if s is None:
            if name not in known:
                raise InterfaceMeshError(
                    f"{what}: the interface {name!r} has no sides in the groups file (its "
                    f"interfaces: {sorted(known)}); give its primary and secondary bodies"
                )
            s = known[name]
        out[name] = s
    return Topology(dict(found_bodies), out)


def _check_tag_values(imesh: InterfaceMesh, tags: dict[str, int], what: str) -> None:
    """Every tag value read belongs to a group of the groups file (collective).

    Raises:
        InterfaceMeshError: On every rank, naming the unknown values.
    """
    unknown: set[int] = set()
    for mt, dim in ((imesh.cell_tags, imesh.tdim), (imesh.facet_tags, imesh.tdim - 1)):
        known = {t for n, t in tags.items() if imesh.dims.get(n) == dim}
        unknown |= {int(v) for v in np.unique(mt.values)} - known
    found = sorted(set().union(*imesh.mesh.comm.allgather(unknown)))
    if found:
        raise InterfaceMeshError(
            f"{what}: tag value(s) {found[:10]} of the XDMF file belong to no group of the "
            "groups file"
        )


def parser() -> Any:
    """The command line of :func:`main`."""
    from ..commandline import ArgumentParser

    ap = ArgumentParser(
        prog="python3 -m subfric_dolfinx.meshing.partitioned",
        description="Write a .msh model as a partitioned XDMF/HDF5 mesh with its groups file.",
    )
    ap.add_argument("msh", help="the .msh file (its interface nodes duplicated)")
    ap.add_argument("xdmf", help="the XDMF file to write (MODEL.xdmf)")
    ap.add_argument("--gdim", type=int, required=True, choices=(2, 3))
    ap.add_argument("--refine", type=int, default=0, help="refine uniformly this many times")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """Convert a ``.msh`` file to a partitioned mesh (``python3 -m`` this module; collective).

    Returns:
        0, or 2 on bad arguments or input (one line on standard error, from rank 0).
    """
    from ..commandline import ArgumentError, error_line
    from .reader import read_interface_mesh
    from .refine import refine_interface_mesh

    comm = MPI.COMM_WORLD
    try:
        args = parser().parse_args(argv)
        if args.refine < 0:
            raise ArgumentError(f"argument --refine: expected >= 0, got {args.refine}")
        dom = read_interface_mesh(args.msh, comm, args.gdim)
        dom = refine_interface_mesh(dom, args.refine)
        xdmf, groups = write_partitioned_mesh(dom, args.xdmf)
    except (ArgumentError, FileNotFoundError, InterfaceMeshError, ValueError) as e:
        if comm.rank == 0:
            error_line(str(e))
        return 2
    if comm.rank == 0:
        n = dom.mesh.topology.index_map(dom.tdim).size_global
        print(f"wrote {xdmf} ({n} cells) and {groups}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
