"""Every mesh file is checked before gmsh parses its body (issue 23, item 2). 1 and 2 ranks.

The damages the issue's probes found, each refused with one clear error on every rank naming
the section and the number at fault (gmsh aborted with "double free or corruption" on the first,
gave an empty reason on the second, accepted the third and fourth), then inverted and
zero-size elements named by tag and physical group (a zero-length interface facet, which the
pairing was blamed for), the same checks in binary and format 2.2 files, and a fuzz of the
reader with 320 mutants of the stored meshes (the full run of ``tests/msh_fuzz.py``, 1,200 and
more, is reported by the script): each one is read or refused, the same on every rank, and
gmsh parses a file only once it passed the checks, in this process, so a crash would end it.
"""

from __future__ import annotations

import re

import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from tests import msh_fuzz
from tests.helpers import MESH_DIR, everywhere, on_root, raised_on_every_rank

TRI = MESH_DIR / "block_on_base_tri.msh"


def damaged(tmp, source, old, new, name="damaged.msh", count=1):
    """A copy of ``source`` with ``old`` replaced by ``new`` (rank 0 writes it)."""
    path = tmp / name

    def write():
        text = source.read_bytes()
        assert text.count(old) >= count, old
        path.write_bytes(text.replace(old, new, count))

    on_root(MPI.COMM_WORLD, write)
    return path


def replaced_line(tmp, source, line, new):
    """A copy of ``source`` with the line ``line`` (trailing blanks aside) replaced by ``new``."""
    path = tmp / "damaged.msh"

    def write():
        pattern = rb"(?m)^" + re.escape(line.encode()) + rb"[ \t]*$"
        text, n = re.subn(pattern, new.encode(), source.read_bytes(), count=1)
        assert n == 1, line
        path.write_bytes(text)

    on_root(MPI.COMM_WORLD, write)
    return path


def refused(path, gdim, *words):
    with raised_on_every_rank(meshing.InterfaceMeshError, "damaged mesh file", *words):
        meshing.read_interface_mesh(path, MPI.COMM_WORLD, gdim)


def element_line(source, tag):
    """The ``$Elements`` line of element ``tag`` in an ASCII 4.1 file."""
    text = source.read_text()
    body = text[text.index("$Elements") : text.index("$EndElements")]
    return re.search(rf"(?m)^{tag} .*$", body).group(0).strip()


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        (b"\n28 163 1 163\n", b"\n28 100 1 163\n", ["$Nodes declares 100 nodes", "hold 163"]),
        (b"\n28 163 1 163\n", b"\n28 160000000000 1 163\n", ["160000000000 nodes", "holds"]),
        (b"\n0 1 0 1\n", b"\n0 1 0 2\n", ["$Nodes"]),
        (b"\n1\n0 0 0\n", b"\n1\nnan 0 0\n", ["node 1 has coordinates [nan", "not finite"]),
        (b"\n1\n0 0 0\n", b"\n1\n1e308 0 0\n", ["node 1", "beyond 1e+100"]),
        (b"\n1\n0 0 0\n", b"\n1\n0 zero 0\n", ["malformed number", "zero"]),
    ],
    ids=["nodes-163-to-100", "1.6e11-nodes", "block-count", "nan", "1e308", "not-a-number"],
)
def test_the_issues_damages_are_refused_naming_them(shared_tmp, old, new, words):
    refused(damaged(shared_tmp, TRI, old, new), 2, *words)


def test_a_truncated_file_is_refused(shared_tmp):
    path = shared_tmp / "cut.msh"
    on_root(MPI.COMM_WORLD, lambda: path.write_bytes(TRI.read_bytes()[:5000]))
    refused(path, 2, "$Nodes", "truncated")


def test_an_inverted_element_is_named(shared_tmp):
    """Two nodes of triangle 300 swapped: its orientation is opposite to its block's."""
    line = element_line(TRI, 300)
    tag, a, b, c = line.split()
    path = replaced_line(shared_tmp, TRI, line, f"{tag} {b} {a} {c}")
    refused(path, 2, "element 300 (triangle)", "physical group", "is inverted")


def test_a_zero_size_element_is_named(shared_tmp):
    """Triangle 300 with a node twice: zero area."""
    line = element_line(TRI, 300)
    tag, a, b, _ = line.split()
    path = replaced_line(shared_tmp, TRI, line, f"{tag} {a} {b} {a}")
    refused(path, 2, "element 300 (triangle)", "has zero area")


def test_a_zero_length_interface_facet_is_named(shared_tmp):
    """An interface line whose two nodes are the same: named, with its group 'interface'."""
    text = TRI.read_text()
    # the interface group's tag, then its entities' element blocks
    tag = re.search(r'(?m)^1 (\d+) "interface"$', text).group(1)
    body = text[text.index("$Entities") : text.index("$EndEntities")].splitlines()[2:]
    curves = [ln.split() for ln in body if len(ln.split()) > 9]
    entity = next(c[0] for c in curves if c[7] == "1" and c[8] == tag)
    els = text[text.index("$Elements") : text.index("$EndElements")].splitlines()
    start = next(i for i, ln in enumerate(els) if ln.split()[:2] == ["1", entity])
    line = els[start + 1].strip()
    etag, a, _ = line.split()
    path = replaced_line(shared_tmp, TRI, line, f"{etag} {a} {a}")
    refused(path, 2, f"element {etag} (line)", "physical group 'interface'", "zero length")


def test_an_inverted_hexahedron_is_named(shared_tmp):
    src = MESH_DIR / "pad_on_plate_hex.msh"
    text = src.read_text()
    els = text[text.index("$Elements") : text.index("$EndElements")].splitlines()
    line = next(ln.strip() for ln in els if len(ln.split()) == 9)
    t, *n = line.split()
    swapped = " ".join([t, n[1], n[0], *n[2:]])
    path = replaced_line(shared_tmp, src, line, swapped)
    refused(path, 3, f"element {t} (hexahedron)", "is inverted")


@pytest.mark.parametrize(("version", "binary"), [(4.1, 1), (2.2, 0), (2.2, 1)])
def test_binary_and_format_2_files_are_checked_too(shared_tmp, version, binary):
    """The block mesh written by gmsh in another format reads; with its node count changed
    (format 2.2 ASCII: the count line; binary: the count of the node block, 8 bytes after
    the section's header), the reader refuses it naming $Nodes."""
    comm = MPI.COMM_WORLD
    src = next(p for p, _ in msh_fuzz.variants(shared_tmp) if f"tri_{version}_{binary}" in p.name)
    meshing.read_interface_mesh(src, comm, 2)

    def damage():
        data = bytearray(src.read_bytes())
        at = data.index(b"$Nodes\n") + len(b"$Nodes\n")
        if version == 2.2:  # the count line, ASCII in both forms
            end = data.index(b"\n", at)
            data[at:end] = b"100"
        else:  # numEntityBlocks, numNodes, ...: numNodes made 100
            data[at + 8 : at + 16] = (100).to_bytes(8, "little")
        (shared_tmp / "bad.msh").write_bytes(bytes(data))

    on_root(comm, damage)
    refused(shared_tmp / "bad.msh", 2, "$Nodes")


def test_fuzzing_the_reader(shared_tmp):
    """320 mutants of the four stored meshes (80 each: truncations, counts, numbers): each is
    read or refused with one clear error, the same on every rank; no crash, no hang, no other
    error. Most are refused; some are read (a changed coordinate can leave a valid mesh)."""
    sources = [(MESH_DIR / n, g) for n, g in msh_fuzz.STORED.items()]
    counts = msh_fuzz.fuzz(sources, 80, seed=23, workdir=shared_tmp)
    outcomes = {o for _, o in counts}
    assert outcomes <= {"accepted", "refused"}, counts
    refused_ = sum(v for (_, o), v in counts.items() if o == "refused")
    assert sum(counts.values()) == 320 and refused_ > 160, counts
    assert everywhere(MPI.COMM_WORLD, True)
