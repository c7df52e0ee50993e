"""The topology value (issue 34 item 3): ``primary``/``secondary`` everywhere, ``master``/``slave``
read as input aliases where the user names a side (the reader's ``names=`` and ``interfaces=``,
the materials' keys), and the problem's interfaces over the mesh's bodies."""

import pytest

from subfric_dolfinx.meshing import InterfaceSides, Topology, mesh_topology

pytestmark = pytest.mark.numpy_only

GROUPS = {"base": (2, 1), "block": (2, 2), "contact": (1, 3)}


def test_the_old_side_names_are_read_as_aliases():
    new = mesh_topology(
        GROUPS, 2, interfaces={"contact": {"primary": "base", "secondary": "block"}}
    )
    old = mesh_topology(GROUPS, 2, interfaces={"contact": {"master": "base", "slave": "block"}})
    assert old == new and new[1]["contact"] == InterfaceSides("base", "block")
    names = mesh_topology(
        GROUPS, 2, names={"master": "base", "slave": "block", "interface": "contact"}
    )
    assert names[1] == {"contact": InterfaceSides("base", "block")}
    again = mesh_topology(
        GROUPS, 2, names={"primary": "base", "secondary": "block", "interface": "contact"}
    )
    assert again == names


def test_materials_by_side_name_go_to_the_first_interfaces_bodies():
    topo = Topology(
        {"base": ("base",), "block": ("block",)}, {"contact": InterfaceSides("base", "block")}
    )
    for keys in (("primary", "secondary"), ("master", "slave")):
        got = topo.materials(dict(zip(keys, ("steel", "alu"), strict=True)))
        assert got["base"] == "steel" and got["block"] == "alu"
    own = topo.materials({"master": "steel", "base": "copper"})  # a body's own wins
    assert own["base"] == "copper"


def test_a_problem_interface_between_new_bodies_adds_them():
    mesh = Topology({"base": ("base",)}, {})
    topo = mesh.with_interfaces({"seam": InterfaceSides("base", "lid", "finite_sliding")})
    assert topo.bodies == {"base": ("base",), "lid": ("lid",)}
    assert topo.first == InterfaceSides("base", "lid", "finite_sliding")
    assert topo.body_tags({"base": 1, "lid": 4}) == {"base": (1,), "lid": (4,)}
    assert mesh.interfaces == {}  # a value: the mesh's own is unchanged
