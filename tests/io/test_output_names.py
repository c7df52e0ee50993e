"""Names from a mesh never become paths: every output file lies inside the output directory.

An interface is named by a physical group of the mesh, free text, and with several interfaces
its name is part of file names (``interface_history_<name>.h5``, ``fields/interface_<name>.bp``,
``fields/interface_points_<name>.xdmf``). A group named ``a/../../../victim/esc`` wrote
``victim/esc.h5`` and ``esc.bp/`` outside the output directory, creating the missing folders.

* :func:`~subfric_dolfinx.io.paths.file_part` maps any name to a safe part of a file name
  (letters, digits, ``_-+.``; no leading dot; bounded); safe names are kept as they are;
* :func:`~subfric_dolfinx.io.paths.inside` refuses a name that leads outside its directory;
* a two-interface scene with that group name and every output writes its files, under the
  mapped name, inside the output directory, and nothing elsewhere; two names that map to the
  same file are refused on every rank before anything is written. 1 and 2 ranks.
"""

from __future__ import annotations

import copy
import os

import gmsh
import pytest
from mpi4py import MPI

from subfric_dolfinx.io import OutputError
from subfric_dolfinx.io.paths import MAX_PART, file_part, inside, interface_stems
from subfric_dolfinx.scenes import run_scene
from tests.fem.test_multibody import stack_builder
from tests.helpers import on_root, raised_on_every_rank
from tests.scenes.test_scene_bodies import stack_scene, write_model

HOSTILE = "a/../../../victim/esc"


@pytest.mark.parametrize(
    ("name", "part"),
    [
        ("low", "low"),
        ("contact_1.b-2+", "contact_1.b-2+"),
        (HOSTILE, "a_.._.._.._victim_esc"),
        ("..", "_."),
        (".hidden", "_hidden"),
        ("-rf", "_rf"),
        ("", "_"),
        ("/etc/passwd", "_etc_passwd"),
        ("contact 1\n<x>", "contact_1_x_"),
        ("été", "_t_"),
        ("a\0b", "a_b"),
    ],
)
def test_a_name_becomes_a_safe_part_of_a_file_name(name, part):
    assert file_part(name) == part
    assert file_part(part) == part  # a safe name is kept


def test_a_long_name_is_cut_with_a_digest_of_the_whole():
    a, b = "x" * 300 + "a", "x" * 300 + "b"
    assert len(file_part(a)) == MAX_PART and file_part(a) != file_part(b)
    assert file_part(a).startswith("x" * (MAX_PART - 9) + "-")


def test_two_names_of_the_same_file_are_refused():
    assert interface_stems("interface", ["a b"]) == {"a b": "interface"}
    assert interface_stems("h", ["low", HOSTILE]) == {
        "low": "h_low",
        HOSTILE: "h_a_.._.._.._victim_esc",
    }
    with pytest.raises(OutputError, match="'a b' and 'a_b' would write the same file"):
        interface_stems("h", ["a b", "a_b"])


def test_a_path_outside_the_directory_is_refused(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "fields").symlink_to(tmp_path)
    assert inside(tmp_path / "out", "fields") == tmp_path / "out" / "fields"
    assert inside(tmp_path / "out", "a/b.h5") == tmp_path / "out" / "a" / "b.h5"
    for bad in ("../x.h5", "a/../../x.h5", "/etc/x", "", ".", "a//b", "x\0y", "fields/x.bp"):
        with pytest.raises(OutputError, match="not a file inside the output directory"):
            inside(tmp_path / "out", bad)


def renamed_stack(names):
    """The three stacked blocks, their interfaces' groups renamed (``low``, ``high`` -> names)."""

    def builder():
        stack_builder()
        for d, t in gmsh.model.getPhysicalGroups():
            old = gmsh.model.getPhysicalName(d, t)
            if old in names:
                gmsh.model.removePhysicalName(old)
                gmsh.model.setPhysicalName(d, t, names[old])

    return builder


def one_step_scene(path, names, **outputs):
    s = copy.deepcopy(stack_scene(path, **outputs))
    s["interfaces"] = {names[k]: s["interfaces"][k] for k in ("low", "high")}
    s["outputs"]["probes"][0]["interface"] = names["high"]
    s["program"] = {"times": [0, 1], "channels": {"press": [0, 1], "push": [0, 0]}}
    s["solver"]["dt"] = 1.0
    # Within the model's validity: an interface as stiff as ten times E*/h (h = 0.125 mm).
    for spec in (s["interfaces"][names["low"]]["law"], s["law"]):
        spec["params"]["alpha_n"] = 1e7
    return s


def tree(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_an_interface_named_with_dots_and_slashes_writes_inside_the_output_directory(shared_tmp):
    comm = MPI.COMM_WORLD
    names = {"low": HOSTILE, "high": "high"}
    mesh = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(renamed_stack(names), mesh))
    out = shared_tmp / "run" / "out"
    s = one_step_scene(mesh, names, interface_history=True, fields="vtx", history=True)
    res = run_scene(s, outdir=out, comm=comm)
    part = "a_.._.._.._victim_esc"

    def check():
        outside = [p for p in tree(shared_tmp) if not p.startswith("run/out") and p != "stack.msh"]
        assert outside == ["run"], outside
        inner = tree(out)
        for f in (
            f"interface_history_{part}.h5",
            "interface_history_high.h5",
            f"fields/interface_{part}.bp",
            f"fields/interface_points_{part}.xdmf",
            f"fields/interface_points_{part}.h5",
        ):
            assert f in inner, (f, inner)
        assert not any("victim/" in p for p in inner), inner

    on_root(comm, check)
    assert f"{HOSTILE}.F_n" in res.history[-1]  # the name itself kept where it is data


def test_two_interface_names_of_the_same_file_are_refused_before_writing(shared_tmp):
    comm = MPI.COMM_WORLD
    names = {"low": "a b", "high": "a_b"}
    mesh = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(renamed_stack(names), mesh))
    out = shared_tmp / "out"
    with raised_on_every_rank(OutputError, "'a b' and 'a_b' would write the same file"):
        run_scene(one_step_scene(mesh, names, interface_history=True), outdir=out, comm=comm)
    assert on_root(comm, lambda: not os.path.lexists(out))
