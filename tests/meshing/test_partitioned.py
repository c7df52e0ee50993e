"""Partitioned mesh input: a model written in DOLFINx's XDMF/HDF5 with its groups file and read
back, each rank its part (1, 2 and 3 ranks).

* The stored ``.msh`` models (2-D triangles, 3-D tetrahedra and hexahedra) written and read back
  have the ``.msh`` reader's groups, tags, bodies, interfaces, node groups, numbers of entities,
  vertices (by body, gathered) and interface sides.
* A small scene run from the partitioned mesh has the history of the same scene run from the
  ``.msh`` file (to the Newton tolerance: the partitions differ).
* Bad input is refused on every rank with the same message naming the file and what is wrong:
  a missing grid (the facet tags), a missing dataset, a missing or malformed groups file, a name
  that is a path, an HDF5 reference that is a path, counts that do not match, a scene asking for
  another partitioner.
"""

import json
import re

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.meshing import InterfaceMeshError
from subfric_dolfinx.meshing.partitioned import groups_path, main
from subfric_dolfinx.scenes import SceneError, run_scene
from tests.helpers import (
    MESH_DIR,
    interface_vertex_multiplicity,
    on_root,
    raised_on_every_rank,
    small_scene,
)

pytestmark = pytest.mark.three_ranks

STORED = {"block_on_base_tri.msh": 2, "pad_on_plate_tet.msh": 3, "pad_on_plate_hex.msh": 3}


def summary(dom):
    """What a mesh holds, the same on every rank and whatever the partition (collective)."""
    comm, tdim = dom.mesh.comm, dom.tdim
    out = {
        "tags": dict(dom.tags),
        "dims": dict(dom.dims),
        "topology": dom.topology,
        "num_interface_facets": dom.num_interface_facets,
        "cells": dom.mesh.topology.index_map(tdim).size_global,
        "vertices": dom.mesh.topology.index_map(0).size_global,
        "nodes": {k: (g.x.tolist(), g.bodies) for k, g in dom.node_groups.items()},
    }
    for name, tag in sorted(dom.tags.items()):
        dim = dom.dims[name]
        if dim < tdim - 1:
            continue
        mt = dom.cell_tags if dim == tdim else dom.facet_tags
        owned = mt.find(tag) < dom.mesh.topology.index_map(dim).size_local
        out[f"count:{name}"] = comm.allreduce(int(np.count_nonzero(owned)))
    for iface in dom.interfaces:
        for side in ("primary", "secondary"):
            f = dom.interface_facets(side, owned_only=True, interface=iface)
            out[f"side:{iface}:{side}"] = comm.allreduce(int(f.size))
    dom.mesh.topology.create_connectivity(tdim, 0)
    nowned = dom.mesh.topology.index_map(0).size_local
    for body in dom.bodies:
        verts = meshing.nodes.body_vertices(dom.mesh, dom.body_cells(body))
        verts = verts[verts < nowned]
        x = meshing.nodes._vertex_coordinates(dom.mesh, verts)[:, : dom.gdim]
        allx = np.concatenate(comm.allgather(x))
        out[f"x:{body}"] = np.round(allx[np.lexsort(allx.T[::-1])], 12).tolist()
    return out


@pytest.mark.parametrize("name", sorted(STORED))
def test_written_and_read_back_the_msh_model_is_the_same(name, shared_tmp):
    comm = MPI.COMM_WORLD
    gdim = STORED[name]
    dom = meshing.read_interface_mesh(MESH_DIR / name, comm, gdim)
    xdmf, groups = meshing.write_partitioned_mesh(dom, shared_tmp / "model.xdmf")
    assert groups == shared_tmp / "model.groups.json" == groups_path(xdmf)
    back = meshing.read_partitioned_mesh(xdmf, comm, gdim)
    assert back.mesh.topology.cell_type == dom.mesh.topology.cell_type
    a, b = summary(dom), summary(back)
    assert a.keys() == b.keys()
    for k in a:
        assert a[k] == b[k], k
    # each rank holds a part of the mesh, not all of it
    n_local = back.mesh.topology.index_map(back.tdim).size_local
    if comm.size > 1:
        assert 0 < n_local < back.mesh.topology.index_map(back.tdim).size_global
    # the interface's nodes are duplicated: each interface vertex is there twice (gathered)
    counts = interface_vertex_multiplicity(back)
    assert counts.size and np.all(counts == 2)


def test_read_in_parts_then_refined_is_the_msh_model_refined(shared_tmp):
    """The scale path (coarse model read in parts, refined on the ranks) gives the model the
    serial path gives (the .msh read through rank 0, refined): groups, counts, vertices, sides."""
    comm = MPI.COMM_WORLD
    msh = MESH_DIR / "pad_on_plate_tet.msh"
    dom = meshing.read_interface_mesh(msh, comm, 3)
    xdmf, _ = meshing.write_partitioned_mesh(dom, shared_tmp / "pad.xdmf")
    a = summary(meshing.refine_interface_mesh(dom, 1))
    b = summary(meshing.refine_interface_mesh(meshing.read_partitioned_mesh(xdmf, comm, 3), 1))
    assert a.keys() == b.keys()
    for k in a:
        assert a[k] == b[k], k


def history_array(res):
    keys = sorted(res.history[0])
    return keys, np.array([[r[k] for k in keys] for r in res.history])


def test_a_scene_from_the_partitioned_mesh_has_the_msh_scenes_history(shared_tmp):
    comm = MPI.COMM_WORLD
    msh = MESH_DIR / "block_on_base_tri.msh"
    xdmf = shared_tmp / "block.xdmf"
    meshing.write_partitioned_mesh(meshing.read_interface_mesh(msh, comm, 2), xdmf)
    runs = []
    for file in (msh, xdmf):
        s = small_scene(short=True)
        s["mesh"] = {"file": str(file), "gdim": 2}
        runs.append(run_scene(s, comm=comm))
    (ka, a), (kb, b) = (history_array(r) for r in runs)
    assert ka == kb and a.shape == b.shape and a.shape[0] > 10
    scale = np.maximum(np.abs(a).max(axis=0), 1e-12)
    assert np.max(np.abs(a - b) / scale) < 1e-8
    assert abs(runs[0].history[-1]["F_t1"]) > 0  # something happened


def test_the_command_converts_a_msh_file(shared_tmp, capsys):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "cmd.xdmf"
    code = main([str(MESH_DIR / "pad_on_plate_tet.msh"), str(out), "--gdim", "3"])
    assert code == 0
    back = meshing.read_partitioned_mesh(out, comm, 3)
    ref = meshing.read_interface_mesh(MESH_DIR / "pad_on_plate_tet.msh", comm, 3)
    assert summary(back) == summary(ref)
    assert main([str(MESH_DIR / "pad_on_plate_tet.msh"), str(out), "--gdim", "3", "--refine", "-1"])
    if comm.rank == 0:
        assert "--refine" in capsys.readouterr().err


# --- bad input ------------------------------------------------------------------------------------
@pytest.fixture
def written(shared_tmp):
    comm = MPI.COMM_WORLD
    dom = meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", comm, 2)
    xdmf, groups = meshing.write_partitioned_mesh(dom, shared_tmp / "model.xdmf")
    return xdmf, groups


def edit(path, change):
    """Change a file's text on rank 0 (collective)."""
    comm = MPI.COMM_WORLD

    def do():
        path.write_text(change(path.read_text()))

    on_root(comm, do)


def edit_groups(path, change):
    def text(s):
        obj = json.loads(s)
        change(obj)
        return json.dumps(obj)

    edit(path, text)


def read(xdmf):
    return meshing.read_partitioned_mesh(xdmf, MPI.COMM_WORLD, 2)


def test_a_missing_facet_tags_grid_is_named(written):
    xdmf, _ = written
    edit(xdmf, lambda s: s.replace('Name="facet_tags"', 'Name="other"', 1))
    with raised_on_every_rank(InterfaceMeshError, str(xdmf), "['facet_tags'] missing"):
        read(xdmf)


def test_a_missing_dataset_is_named(written):
    xdmf, _ = written
    edit(xdmf, lambda s: s.replace("/MeshTags/facet_tags/Values", "/MeshTags/facet_tags/Gone"))
    with raised_on_every_rank(InterfaceMeshError, "/MeshTags/facet_tags/Gone", "missing"):
        read(xdmf)


def test_an_hdf5_reference_that_is_a_path_is_refused(written):
    xdmf, _ = written
    edit(xdmf, lambda s: re.sub(r">model\.h5:", ">../model.h5:", s, count=1))
    with raised_on_every_rank(InterfaceMeshError, "'../model.h5:", "plain HDF5 file name"):
        read(xdmf)


def test_a_missing_groups_file_is_named(written):
    xdmf, groups = written
    on_root(MPI.COMM_WORLD, groups.unlink)
    with raised_on_every_rank(FileNotFoundError, str(groups), "no such groups file"):
        read(xdmf)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda o: o.update(format="other"), ["not a groups file of format"]),
        (lambda o: o.update(version=2), ["version 2"]),
        (lambda o: o.pop("bodies"), ["missing key(s) ['bodies']"]),
        (lambda o: o.update(extra=1), ["unknown key(s) ['extra']"]),
        (
            lambda o: o["groups"].update({"../etc/passwd": o["groups"].pop("top")}),
            [".groups: expected a plain name", "'../etc/passwd'"],
        ),
        (
            lambda o: o["interfaces"]["interface"].update(primary="a/b"),
            [".interfaces.interface.primary: expected a plain name", "'a/b'"],
        ),
        (
            lambda o: o["interfaces"]["interface"].update(primary="nobody"),
            ["the body 'nobody' is not a body of the mesh"],
        ),
        (lambda o: o["groups"]["top"].update(count=99), ["'top': ", "of 99"]),
        (lambda o: o["groups"]["top"].update(tag=o["groups"]["bottom"]["tag"]), ["also the tag"]),
        (lambda o: o["groups"].pop("top"), ["belong to no group of the groups file"]),
    ],
)
def test_a_bad_groups_file_is_named(written, change, words):
    xdmf, groups = written
    edit_groups(groups, change)
    with raised_on_every_rank(InterfaceMeshError, *words):
        read(xdmf)


def test_a_groups_file_that_is_no_json_or_repeats_a_key_is_refused(written):
    xdmf, groups = written
    edit(groups, lambda s: s.replace('"format"', '"version": 1, "format"', 1))
    with raised_on_every_rank(InterfaceMeshError, str(groups), "'version' is given twice"):
        read(xdmf)
    edit(groups, lambda s: s[: len(s) // 2])
    with raised_on_every_rank(InterfaceMeshError, str(groups), "not a JSON file"):
        read(xdmf)


def test_the_scene_keys(written):
    xdmf, _ = written
    s = small_scene(short=True)
    s["mesh"] = {"file": str(xdmf), "gdim": 2, "partitioner": "bodies"}
    with raised_on_every_rank(SceneError, "scene.mesh.partitioner", "DOLFINx's partitioner"):
        run_scene(s, comm=MPI.COMM_WORLD)
    with raised_on_every_rank(InterfaceMeshError, "expected a 3-D mesh, the groups file says 2-D"):
        meshing.read_partitioned_mesh(xdmf, MPI.COMM_WORLD, 3)
    s["mesh"] = {"file": str(xdmf), "gdim": 2, "refine": -1}
    with raised_on_every_rank(SceneError, "scene.mesh.refine", "-1"):
        run_scene(s, comm=MPI.COMM_WORLD)


def test_writing_needs_an_xdmf_name(shared_tmp):
    dom = meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, 2)
    with raised_on_every_rank(ValueError, "expected an .xdmf file name", "model.h5"):
        meshing.write_partitioned_mesh(dom, shared_tmp / "model.h5")
