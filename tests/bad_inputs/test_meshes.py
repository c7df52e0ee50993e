"""Bad meshes: files that are missing, not meshes, lack a group, have sides that do not pair or
the wrong dimension; gmsh models with shared or lost nodes; bad meshing arguments."""

import os

import gmsh
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import InterfaceError, InterfaceProblem, Material
from tests.helpers import (
    MESH_DIR,
    PROGRAM,
    everywhere,
    gmsh_open,
    joined_model,
    on_root,
    raised_on_every_rank,
)

MESH_CASES = {
    # name: (file, gdim, exception, words, regular expression or None)
    "missing-file": ("no_such_mesh.msh", 2, FileNotFoundError, ["mesh file not found"], None),
    "no-interface-group": (
        "broken_no_interface.msh",
        2,
        meshing.InterfaceMeshError,
        # the groups found are listed
        ["required physical group 'interface' not found", "'primary'", "'secondary'", "'bottom'"],
        None,
    ),
    "sides-count-differ": (
        "broken_mismatch_count.msh",
        2,
        meshing.InterfaceMeshError,
        ["8 on the 'primary' side, 9 on the 'secondary' side"],
        None,
    ),
    "3d-mesh-read-as-2d-tet": (
        "pad_on_plate_tet.msh",
        2,
        meshing.InterfaceMeshError,
        ["expected a 2-D mesh", "found cells of topological dimension 3"],
        "expected a 2-D mesh .* found cells of topological dimension 3",
    ),
    "3d-mesh-read-as-2d-hex": (
        "pad_on_plate_hex.msh",
        2,
        meshing.InterfaceMeshError,
        ["expected a 2-D mesh", "found cells of topological dimension 3"],
        None,
    ),
    "2d-mesh-read-as-3d": (
        "block_on_base_quad.msh",
        3,
        meshing.InterfaceMeshError,
        ["expected a 3-D mesh", "found cells of topological dimension 2"],
        "expected a 3-D mesh .* found cells of topological dimension 2",
    ),
}


@pytest.mark.parametrize("name", list(MESH_CASES))
def test_bad_mesh_file(name):
    file, gdim, exc, words, match = MESH_CASES[name]
    path = MESH_DIR / file
    with raised_on_every_rank(exc, str(path), *words, match=match):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, gdim)


def test_mesh_without_a_required_boundary_group():
    path = MESH_DIR / "block_on_base_tri.msh"
    required = (*meshing.REQUIRED_GROUPS, "clamp")
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path), "'clamp' not found"):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2, required=required)


def test_mesh_without_two_required_boundary_groups():
    """Both missing groups are named, the first (in the order required) first."""
    required = (*meshing.REQUIRED_GROUPS, meshing.PRIMARY_TOP, meshing.SECONDARY_XMIN)
    with raised_on_every_rank(
        meshing.InterfaceMeshError, match=r"'secondary_xmin' not found.*'primary_top'"
    ):
        meshing.read_interface_mesh(
            MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, 2, required=required
        )


def test_mesh_path_is_a_directory():
    with raised_on_every_rank(meshing.InterfaceMeshError, str(MESH_DIR), "a directory"):
        meshing.read_interface_mesh(MESH_DIR, MPI.COMM_WORLD, 2)


@pytest.mark.parametrize("content", ["this is not a mesh\n", ""], ids=["garbage", "empty"])
def test_file_that_is_not_a_mesh(shared_tmp, content):
    path = shared_tmp / "not_a_mesh.msh"
    on_root(MPI.COMM_WORLD, lambda: path.write_text(content))
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path)):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)


# --------------------------------------------------------------------------------------------
# Mesh files are data: only MSH files reach gmsh (a script's SystemCall never runs)

SCRIPT = 'SystemCall "touch {marker}";\n'
HEADER_ASCII = b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
NOT_MSH = {
    # name: (file name, content, words of the message)
    "geo-script": ("script.geo", None, ["does not start with '$MeshFormat'"]),
    "script-named-msh": ("script.msh", None, ["does not start with '$MeshFormat'"]),
    "script-after-a-blank-line": ("blank.msh", "\n$MeshFormat\n", ["does not start"]),
    "binary-blob": ("blob.msh", bytes(range(256)) * 4, ["does not start"]),
    "msh-version-1": ("v1.msh", b"$NOD\n3\n", ["does not start"]),
    "msh-version-3": ("v3.msh", b"$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", ["not 2.x or 4.x"]),
    "file-type-2": ("t2.msh", b"$MeshFormat\n4.1 2 8\n$EndMeshFormat\n", ["file type"]),
    "data-size-4": ("d4.msh", b"$MeshFormat\n4.1 0 4\n$EndMeshFormat\n", ["data size"]),
    "binary-bad-endianness": (
        "endian.msh",
        b"$MeshFormat\n4.1 1 8\n\x02\x00\x00\x00\n$EndMeshFormat\n",
        ["endianness"],
    ),
    "no-end-of-format": ("noend.msh", b"$MeshFormat\n4.1 0 8\n" + SCRIPT.encode(), ["$End"]),
}


@pytest.mark.parametrize("case", list(NOT_MSH))
def test_only_msh_files_reach_gmsh(shared_tmp, case):
    """A gmsh script (as .geo or named .msh) is refused before gmsh opens it: its SystemCall,
    which would create the marker file, never runs; other non-MSH content is refused too."""
    comm = MPI.COMM_WORLD
    name, content, words = NOT_MSH[case]
    path, marker = shared_tmp / name, shared_tmp / "MARKER"
    script = SCRIPT.format(marker=marker)
    data = script if content is None else content
    data = data + script if isinstance(data, str) else data

    def write():
        if isinstance(data, str):
            path.write_text(data)
        else:
            path.write_bytes(data)

    on_root(comm, write)
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path), "not an MSH mesh", *words):
        meshing.read_interface_mesh(path, comm, 2)
    assert on_root(comm, lambda: not marker.exists()), "the script ran"


def test_a_script_after_a_valid_header_is_read_as_msh_not_run(shared_tmp):
    """gmsh's MSH reader is chosen by the header: what follows it is never run as a script."""
    comm = MPI.COMM_WORLD
    path, marker = shared_tmp / "header_then_script.geo", shared_tmp / "MARKER"
    on_root(comm, lambda: path.write_bytes(HEADER_ASCII + SCRIPT.format(marker=marker).encode()))
    with raised_on_every_rank(meshing.InterfaceMeshError, str(path)):
        meshing.read_interface_mesh(path, comm, 2)
    assert on_root(comm, lambda: not marker.exists()), "the script ran"


@pytest.mark.parametrize(("version", "binary"), [(2.2, 0), (2.2, 1), (4.1, 1)])
def test_msh_formats_2_and_4_ascii_and_binary_are_read(shared_tmp, version, binary):
    """The stored ASCII 4.1 mesh written again as MSH 2.2/4.1, ASCII/binary, reads the same."""
    comm = MPI.COMM_WORLD
    src, path = MESH_DIR / "block_on_base_tri.msh", shared_tmp / "again.msh"

    def convert():
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        try:
            gmsh.option.setNumber("General.Verbosity", 2)
            gmsh.merge(str(src))
            gmsh.option.setNumber("Mesh.MshFileVersion", version)
            gmsh.option.setNumber("Mesh.Binary", binary)
            gmsh.write(str(path))
        finally:
            gmsh.finalize()

    on_root(comm, convert)
    a = meshing.read_interface_mesh(src, comm, 2)
    b = meshing.read_interface_mesh(path, comm, 2)
    cells = [m.mesh.topology.index_map(m.tdim).size_global for m in (a, b)]
    assert cells[0] == cells[1] > 0
    assert b.num_interface_facets == a.num_interface_facets > 0
    assert b.tags == a.tags


@pytest.mark.parametrize("gdim", [1, 4, 2.5, "2"])
def test_bad_gdim(gdim):
    with raised_on_every_rank(ValueError, f"gdim must be 2 or 3, got {gdim!r}"):
        meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, gdim)


def test_interface_sides_that_do_not_pair_node_to_node():
    """Equal facet counts (the reader accepts it) but nodes at different places."""
    path = MESH_DIR / "broken_mismatch_coords.msh"
    dom = meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)
    mats = {"primary": Material(2.0e4, 0.3), "secondary": Material(2.0e4, 0.3)}
    with raised_on_every_rank(
        InterfaceError, "do not pair node to node", "at [", match=r"do not pair node to node.*at \["
    ):
        InterfaceProblem(dom, preset("sec7"), mats, PROGRAM)


# --------------------------------------------------------------------------------------------
# gmsh models (the current model on rank 0)


def on_root_with_a_gmsh_model(build, read):
    """``build()`` a gmsh model on rank 0 (its failure fails every rank, no rank is left
    waiting), then ``read()`` on every rank; gmsh is finalised again whatever happens."""
    comm = MPI.COMM_WORLD

    def start():
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Verbosity", 2)
        build()

    try:
        on_root(comm, start)
        read()
    finally:
        if comm.rank == 0 and gmsh.isInitialized():
            gmsh.finalize()


def test_bodies_that_share_nodes():
    """Two rectangles meshed conformally without duplicating the interface nodes."""

    def glued():
        gmsh.model.add("glued")
        a = gmsh.model.occ.addRectangle(0, 0, 0, 1, 0.5)
        b = gmsh.model.occ.addRectangle(0, 0.5, 0, 1, 0.5)
        gmsh.model.occ.fragment([(2, a)], [(2, b)])
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [a], name=meshing.PRIMARY)
        gmsh.model.addPhysicalGroup(2, [b], name=meshing.SECONDARY)
        line = [t for _, t in gmsh.model.getEntitiesInBoundingBox(-1, 0.49, -1, 2, 0.51, 1, 1)]
        gmsh.model.addPhysicalGroup(1, line, name=meshing.INTERFACE)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        gmsh.model.mesh.generate(2)

    def read():
        with raised_on_every_rank(
            meshing.InterfaceMeshError, match=r"share \d+ nodes .* must be duplicated"
        ):
            meshing.read_interface_mesh(None, MPI.COMM_WORLD, 2)

    on_root_with_a_gmsh_model(glued, read)


def test_group_elements_that_are_no_facets():
    """A facet-group element that is no facet of the cells (gmshio would drop it silently)."""

    def with_a_bogus_group():
        meshing.build_block_on_base(cell_type="quadrilateral", n_interface=4)
        nodes, x, _ = gmsh.model.mesh.getNodes()
        x = x.reshape(-1, 3)
        # a "facet" joining the two bottom corners of the base: not an edge of any cell
        ends = [
            int(nodes[np.argmin(np.linalg.norm(x - p, axis=1))]) for p in ([0, 0, 0], [2, 0, 0])
        ]
        line = gmsh.model.addDiscreteEntity(1)
        gmsh.model.mesh.addElementsByType(line, 1, [], ends)
        gmsh.model.addPhysicalGroup(1, [line], name="bogus")

    def read():
        with raised_on_every_rank(meshing.InterfaceMeshError, "'bogus': 1 of 1"):
            meshing.read_interface_mesh(None, MPI.COMM_WORLD, 2)

    on_root_with_a_gmsh_model(with_a_bogus_group, read)


def test_no_current_gmsh_model():
    comm = MPI.COMM_WORLD
    assert everywhere(comm, comm.rank != 0 or not gmsh.isInitialized())
    with raised_on_every_rank(meshing.InterfaceMeshError, "no current gmsh model"):
        meshing.read_interface_mesh(None, comm, 2)


# --------------------------------------------------------------------------------------------
# Arguments of the builders, partitioners and the mesh object


def test_bad_builder_options():
    comm = MPI.COMM_WORLD
    with raised_on_every_rank(ValueError, "cell_type must be one of"):
        meshing.create_interface_mesh(meshing.build_block_on_base, comm, cell_type="hexahedron")
    with raised_on_every_rank(ValueError, "must lie on the base"):
        meshing.create_interface_mesh(meshing.build_block_on_base, comm, block_x=1.5)
    joint = meshing.build_bolted_lap_joint
    with raised_on_every_rank(ValueError, "overlap (70.0) must not exceed plate_length (60.0)"):
        meshing.create_interface_mesh(joint, comm, overlap=70.0)
    with raised_on_every_rank(ValueError, "the washer (diameter 32.0) inside the overlap"):
        meshing.create_interface_mesh(joint, comm, washer_radius=16.0)
    with raised_on_every_rank(ValueError, "hole_radius must be a positive finite number"):
        meshing.create_interface_mesh(joint, comm, hole_radius=float("nan"))
    with raised_on_every_rank(ValueError, "cell_type must be 'tetrahedron'"):
        meshing.create_interface_mesh(joint, comm, cell_type="hexahedron")


def test_bad_partitioner_kind_group_and_side():
    with raised_on_every_rank(ValueError, "partitioner kind"):
        meshing.body_partitioner("random")
    im = meshing.read_interface_mesh(MESH_DIR / "block_on_base_tri.msh", MPI.COMM_WORLD, 2)
    with raised_on_every_rank(KeyError, "no physical group 'nope'"):
        im.tag("nope")
    with raised_on_every_rank(ValueError, "side must be one of"):
        im.interface_facets("interface")


# --------------------------------------------------------------------------------------------
# Interface regions and graded meshes (builder options), a group partly on the interface


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"interface_regions": {"a": [0.2, 0.8]}}, "inside the interface [0.5, 1.5]"),
        ({"interface_regions": {"a": [0.9, 0.7]}}, "must be an increasing interval"),
        ({"interface_regions": {"a": [0.6, 1.0], "b": [0.9, 1.2]}}, "'a' and 'b' overlap"),
        ({"interface_regions": {"top": [0.6, 1.0]}}, "must be an identifier other than"),
        ({"interface_regions": {"a b": [0.6, 1.0]}}, "must be an identifier other than"),
        ({"interface_regions": {"a": "left"}}, "expected [x0, x1]"),
        ({"interface_regions": {"a": [0.6, float("nan")]}}, "must be an increasing interval"),
        ({"far_size": 1.0, "cell_type": "quadrilateral"}, "needs triangles or tetrahedra"),
        ({"far_size": 0.01}, "must be at least the interface size"),
        ({"far_size": 1.0, "growth": -1}, "growth must be a positive finite number"),
        ({"far_size": 1.0, "refine_radius": -1}, "refine_radius must be a finite number >= 0"),
    ],
)
def test_bad_region_and_grading_options(options, words):
    with raised_on_every_rank(ValueError, words):
        meshing.create_interface_mesh(meshing.build_block_on_base, MPI.COMM_WORLD, **options)


def test_a_facet_group_partly_on_the_interface():
    """A named facet group holding an interface curve and another curve: a region must lie on
    the interface only (DOLFINx keeps one tag per facet, so subgroups are read apart)."""

    def with_a_straddling_group():
        meshing.build_block_on_base(n_interface=4)
        iface = gmsh.model.getEntitiesForPhysicalGroup(1, meshing.TAGS[meshing.INTERFACE])
        bottom = gmsh.model.getEntitiesForPhysicalGroup(1, meshing.TAGS[meshing.BOTTOM])
        gmsh.model.addPhysicalGroup(1, [int(iface[0]), int(bottom[0])], name="straddle")

    def read():
        with raised_on_every_rank(
            meshing.InterfaceMeshError, "'straddle' lies partly on the 'interface' group"
        ):
            meshing.read_interface_mesh(None, MPI.COMM_WORLD, 2)

    on_root_with_a_gmsh_model(with_a_straddling_group, read)


# --------------------------------------------------------------------------------------------
# duplicate_interface_nodes: bad sides, sources and outputs; a full disk (issue 36)


@pytest.mark.serial
def test_duplicate_refuses_equal_sides_and_sources_that_are_not_files(tmp_path):
    with gmsh_open():
        joined_model()
        with pytest.raises(
            meshing.InterfaceMeshError, match=r"share the cell group\(s\) \['upper'"
        ):
            meshing.duplicate_interface_nodes(None, {"seam": ("upper", "upper")})
        with pytest.raises(
            meshing.InterfaceMeshError, match=r"share the cell group\(s\) \['lower'"
        ):
            meshing.duplicate_interface_nodes(None, {"seam": (["lower"], ["upper", "lower"])})
    os.mkfifo(tmp_path / "fifo.msh")
    (tmp_path / "dir.msh").mkdir()
    for name, words in (("fifo.msh", "not a regular file"), ("dir.msh", "a directory")):
        with pytest.raises(meshing.InterfaceMeshError, match=words):  # no hang on the FIFO
            meshing.duplicate_interface_nodes(tmp_path / name, "seam", output=tmp_path / "o.msh")
    assert not (tmp_path / "o.msh").exists()


@pytest.mark.serial
def test_duplicate_never_writes_through_a_link_or_into_a_directory(tmp_path):
    (tmp_path / "victim").write_text("precious\n")
    (tmp_path / "link.msh").symlink_to(tmp_path / "victim")
    (tmp_path / "dir.msh").mkdir()
    with gmsh_open():
        joined_model()
        for name, words in (("link.msh", "is a symbolic link"), ("dir.msh", "is a directory")):
            with pytest.raises(meshing.InterfaceMeshError, match=words):
                meshing.duplicate_interface_nodes(None, "seam", output=tmp_path / name)
    assert (tmp_path / "victim").read_text() == "precious\n"
    assert sorted(os.listdir(tmp_path)) == ["dir.msh", "link.msh", "victim"]  # nothing left


@pytest.mark.serial
def test_duplicate_on_a_full_disk_fails_and_leaves_the_old_output(tmp_path, monkeypatch):
    """gmsh returns normally from a write the disk cut short: the file is checked whole before
    it replaces the output. A real small tmpfs where it can be mounted, and always a write cut
    short by hand (gmsh's file truncated after it wrote it)."""
    from tests.helpers import tmpfs

    old = "an earlier output\n"
    with tmpfs(tmp_path / "small", "64k") as mounted:
        places = [tmp_path / "small"] if mounted else []
        for d in places:
            (d / "apart.msh").write_text(old)
            (d / "filler").write_bytes(b"\0" * (60 << 10))  # the rest: less than the mesh
            with gmsh_open():
                joined_model(h=0.02)
                with pytest.raises(OSError, match=r"apart\.msh"):
                    meshing.duplicate_interface_nodes(None, "seam", output=d / "apart.msh")
            assert (d / "apart.msh").read_text() == old
            assert sorted(os.listdir(d)) == ["apart.msh", "filler"]
    import gmsh

    real = gmsh.write

    def cut_short(name):
        real(name)
        with open(name, "r+b") as f:
            f.truncate(os.path.getsize(name) // 2)

    out = tmp_path / "apart.msh"
    out.write_text(old)
    with gmsh_open():
        joined_model()
        monkeypatch.setattr(gmsh, "write", cut_short)
        with pytest.raises(OSError, match=r"apart\.msh' failed: gmsh's file is not whole"):
            meshing.duplicate_interface_nodes(None, "seam", output=out)
    assert out.read_text() == old and sorted(os.listdir(tmp_path)) == ["apart.msh", "small"]
    monkeypatch.setattr(gmsh, "write", real)
    with gmsh_open():
        joined_model()
        meshing.duplicate_interface_nodes(None, "seam", output=out)  # a whole write replaces it
    assert out.read_text() != old and sorted(os.listdir(tmp_path)) == ["apart.msh", "small"]


def test_a_mesh_file_too_large_for_the_memory_is_refused_before_it_is_read(shared_tmp, monkeypatch):
    """A 2 GB file was read whole (4.2 GB resident) before being refused. Its size is now
    compared with the machine's memory first (here the memory said to be 64 MiB, the file a
    sparse 16 MiB with a valid header: checking it takes about 5 times its size): nothing of it
    is mapped or read. A line too long to be one is refused before it is copied."""
    from subfric_dolfinx.meshing import _msh

    path = shared_tmp / "huge.msh"

    def make():
        with open(path, "wb") as f:
            f.write(HEADER_ASCII)
            f.truncate(16 << 20)

    on_root(MPI.COMM_WORLD, make)
    monkeypatch.setattr(_msh, "machine_memory", lambda: 64 << 20)
    mapped = []
    real = _msh._mapped
    monkeypatch.setattr(_msh, "_mapped", lambda *a: mapped.append(1) or real(*a))
    with raised_on_every_rank(
        meshing.InterfaceMeshError, str(path), "a mesh file of 0.0156 GiB", "not read"
    ):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)
    assert everywhere(MPI.COMM_WORLD, not mapped)
    monkeypatch.undo()

    def long_line():
        with open(path, "wb") as f:
            f.write(HEADER_ASCII + b"x" * (2 << 20))

    on_root(MPI.COMM_WORLD, long_line)
    with raised_on_every_rank(meshing.InterfaceMeshError, "a line of more than 1048576 bytes"):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, 2)
