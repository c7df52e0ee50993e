"""Several bodies and interfaces, your own gmsh mesh and group names (issue 21 item 1, issue 24
item 3).

* Three stacked blocks (``base``, ``middle``, ``cap``) with two interfaces of their own (Coulomb,
  ``mu`` 0.2 below the middle block, 0.5 above it), in a gmsh model of the test's own, its nodes
  duplicated with :func:`~subfric_dolfinx.meshing.duplicate_interface_nodes`, read with the
  user's group names: pressed by ``p``, then the cap pushed sideways. Checked against statics:
  each interface carries the whole load ``P = p w`` normally, the same shear as the cap's
  reaction, and the weaker interface slides at ``0.2 P`` while the stronger sticks (its points
  elastic). On 1 and 2 ranks, with DOLFINx's partitioner and with one body per rank.
* ``names=``: the classic block on a base whose groups are renamed (``base``, ``block``,
  ``contact``) reads and runs exactly as with the classic names; the interface checks work with
  the user's names (a missing interface group is named).
* The node duplication on an ``.msh`` file: the output is read by DOLFINx's own gmsh reader (the
  interface tagged on both sides, each an exterior facet of one cell).
"""

import types

import numpy as np
import pytest

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceError,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
)
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from tests.helpers import everywhere, gmsh_open, joined_model, on_root, raised_on_every_rank

P_LID = 100.0  # MPa
W_CAP = 1.0  # mm, the cap's width (the load's width)
SIDES = {"low": ("base", "middle"), "high": ("middle", "cap")}


def stack_builder(h: float = 0.125):
    """Three blocks stacked, meshed together, nodes duplicated on the two interfaces."""
    import gmsh

    gmsh.model.add("stack")
    occ = gmsh.model.occ
    boxes = [(0.0, 0.0, 2.0, 0.5), (0.25, 0.5, 1.5, 0.5), (0.5, 1.0, W_CAP, 0.5)]
    tags = [occ.addRectangle(x, y, 0.0, w, hh) for x, y, w, hh in boxes]
    occ.fragment([(2, tags[0])], [(2, t) for t in tags[1:]])
    occ.synchronize()
    bodies = {"base": [], "middle": [], "cap": []}
    for _, t in gmsh.model.getEntities(2):
        y = occ.getCenterOfMass(2, t)[1]
        bodies["base" if y < 0.5 else "middle" if y < 1.0 else "cap"].append(t)
    curves: dict[str, list[int]] = {"low": [], "high": [], "ground": [], "lid": []}
    tol = 1e-5  # OCC bounding boxes are enlarged by the geometric tolerance
    for _, t in gmsh.model.getEntities(1):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, t)
        if abs(y1 - y0) > tol:
            continue
        y = 0.5 * (y0 + y1)
        if abs(y) < tol:
            curves["ground"].append(t)
        elif abs(y - 0.5) < tol and x0 > 0.25 - tol and x1 < 1.75 + tol:
            curves["low"].append(t)
        elif abs(y - 1.0) < tol and x0 > 0.5 - tol and x1 < 1.5 + tol:
            curves["high"].append(t)
        elif abs(y - 1.5) < tol:
            curves["lid"].append(t)
    for name, ents in bodies.items():
        gmsh.model.addPhysicalGroup(2, ents, name=name)
    for name, ents in curves.items():
        gmsh.model.addPhysicalGroup(1, ents, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.model.mesh.generate(2)
    meshing.duplicate_interface_nodes(None, SIDES)
    return types.SimpleNamespace(gdim=2)


def stack(comm, partitioner=None):
    dom, _ = meshing.create_interface_mesh(
        stack_builder, comm, interfaces=SIDES, partitioner=partitioner
    )
    return dom


def test_the_stack_mesh_knows_its_bodies_and_interfaces(comm):
    dom = stack(comm)
    assert dom.bodies == {"base": ("base",), "middle": ("middle",), "cap": ("cap",)}
    assert dom.interfaces == {
        "low": meshing.InterfaceSides("base", "middle"),
        "high": meshing.InterfaceSides("middle", "cap"),
    }
    counts = [
        comm.allreduce(dom.interface_facets(s, owned_only=True, interface=i).size)
        for i in ("low", "high")
        for s in ("primary", "secondary")
    ]
    assert counts[0] == counts[1] > 0 and counts[2] == counts[3] > 0
    assert counts[0] > counts[2]  # the middle block is wider than the cap


def test_two_bodies_on_a_mesh_of_several_interfaces_names_its_interface(comm):
    """``InterfaceProblem.two_bodies`` is one interface: on the stack's mesh (two) it refuses to
    guess (naming them), and takes the one it is given, with its sides from the mesh's
    topology and the other body's cells outside any interface."""
    dom = stack(comm)
    steel = Material(2.1e5, 0.3)
    args = (
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.5),
        {"base": steel, "middle": steel, "cap": steel},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
        [Dirichlet("ground", [0.0, 0.0])],
    )
    with raised_on_every_rank(InterfaceError, "the mesh has 2 interfaces"):
        InterfaceProblem.two_bodies(*args)
    with InterfaceProblem.two_bodies(*args, interface=Interface("high")) as problem:
        assert list(problem.interfaces) == ["high"]
        assert problem.topology.interfaces == {"high": meshing.InterfaceSides("middle", "cap")}
        assert set(problem.topology.bodies) == {"base", "middle", "cap"}


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on 1 mm bodies"
)
@pytest.mark.parametrize("partitioner", [None, "bodies", "together"])
def test_three_bodies_two_interfaces_against_statics(comm, partitioner):
    dom = stack(comm, partitioner)
    program = LoadingProgram([0.0, 1.0, 2.0], {"press": [0, 1, 1], "push": [0, 0, 1]})
    steel = Material(2.1e5, 0.3)
    law = CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.5)
    problem = InterfaceProblem(
        dom,
        law,
        {"base": steel, "middle": steel, "cap": steel},
        program,
        [Dirichlet("ground", [0.0, 0.0]), Dirichlet("lid", 0.01, 0, amplitude="push")],
        [Pressure("lid", P_LID, amplitude="press")],
        interfaces=[Interface("low", law=law.replace(mu_c=0.2)), Interface("high")],
    )
    assert list(problem.interfaces) == ["low", "high"]
    rows = []

    def on_step(rec):
        row = interface_summary(problem)
        row["R_x"] = problem.reactions["lid"][0]
        rows.append(row)

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.25, on_step=on_step).run()
        mallocs = solver.J.getInfo()["mallocs"]
    load = P_LID * W_CAP
    last = rows[-1]
    checks = {
        "both interfaces in the sparsity": mallocs == 0,
        "F_n low": abs(last["low.F_n"] - load) < 1e-8 * load,
        "F_n high": abs(last["high.F_n"] - load) < 1e-8 * load,
        # the cap's reaction is carried through both interfaces
        "shear low": abs(last["low.F_t1"] - last["R_x"]) < 1e-8 * load,
        "shear high": abs(last["high.F_t1"] - last["R_x"]) < 1e-8 * load,
        # the weaker interface slides at mu P, the stronger one sticks
        "sliding": abs(abs(last["low.F_t1"]) - 0.2 * load) < 1e-6 * load,
        "low slides": last["low.plastic"] == 1.0,
        "high sticks": last["high.plastic"] == 0.0,
    }
    assert everywhere(comm, all(checks.values())), (checks, last)


def renamed_block(**kw):
    """The classic builder's model with the user's own names for its groups."""
    import gmsh

    info = meshing.build_block_on_base(n_interface=8, **kw)
    rename = {"primary": "base", "secondary": "block", "interface": "contact"}
    for d, t in gmsh.model.getPhysicalGroups():
        name = gmsh.model.getPhysicalName(d, t)
        if name in rename:
            gmsh.model.removePhysicalName(name)
            gmsh.model.setPhysicalName(d, t, rename[name])
    return info


def run_block(dom, materials):
    program = LoadingProgram([0, 1, 2], {"press": [0, 1, 1], "slide": [0, 0, 0.5]})
    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.3),
        materials,
        program,
        [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.01, 0, amplitude="slide")],
        [Pressure("top", 100.0, amplitude="press")],
    )
    out = []
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(
            solver, 0.25, on_step=lambda r: out.append(interface_summary(problem)["F_t1"])
        ).run()
    return np.array(out)


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on the 1 mm block"
)
def test_user_group_names_read_and_run_as_the_classic_names(comm):
    names = {"primary": "base", "secondary": "block", "interface": "contact"}
    dom, _ = meshing.create_interface_mesh(renamed_block, comm, names=names)
    assert dom.interfaces == {"contact": meshing.InterfaceSides("base", "block")}
    assert "primary" not in dom.tags and dom.num_interface_facets == 8
    steel, alu = Material(2.1e5, 0.3), Material(7e4, 0.33)
    mine = run_block(dom, {"base": steel, "block": alu})
    classic, _ = meshing.create_interface_mesh(meshing.build_block_on_base, comm, n_interface=8)
    ref = run_block(classic, {"primary": steel, "secondary": alu})
    assert everywhere(comm, np.abs(mine - ref).max() <= 1e-12 * np.abs(ref).max()), (mine, ref)


def test_interface_checks_keep_the_users_names(comm):
    """The roles given other names are required under them; sides name the mesh's bodies."""
    with raised_on_every_rank(
        meshing.InterfaceMeshError, "required physical group 'contact' not found"
    ):
        meshing.create_interface_mesh(
            meshing.build_block_on_base, comm, n_interface=8, names={"interface": "contact"}
        )
    with raised_on_every_rank(meshing.InterfaceMeshError, "'shaft' is not a body of the mesh"):
        meshing.create_interface_mesh(
            renamed_block, comm, interfaces={"contact": ("base", "shaft")}
        )


def test_duplicated_msh_file_is_read_by_dolfinx_gmsh_reader(comm, shared_tmp):
    """A mesh written by gmsh with the two bodies sharing the interface, split by
    ``duplicate_interface_nodes`` into a new file: DOLFINx's own reader reads it, and both sides
    of the interface are exterior facets."""
    import dolfinx

    from subfric_dolfinx.compat import read_from_msh

    joined, apart = shared_tmp / "joined.msh", shared_tmp / "apart.msh"

    def write():
        with gmsh_open() as gmsh:
            tag = joined_model()
            gmsh.write(str(joined))
        return meshing.duplicate_interface_nodes(joined, "seam", output=apart), tag

    info, tag = on_root(comm, write)
    assert info["seam"].primary == ("lower",) and info["seam"].secondary == ("upper",)
    n = info["seam"].facets
    assert info["seam"].new_nodes == n + 1  # every node of the seam, its ends included
    mesh, _, ft = read_from_msh(apart, comm, gdim=2)
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    seam = ft.find(tag)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    n_owned = mesh.topology.index_map(tdim - 1).size_local
    owned = seam[seam < n_owned]
    assert comm.allreduce(owned.size) == 2 * n  # both sides tagged
    assert everywhere(comm, bool(np.all(np.isin(owned, exterior))))


@pytest.mark.parametrize(
    ("bodies", "interfaces", "message"),
    [
        ({"bolt": ["head", "shank"]}, None, r"cell group\(s\) \['plate'\] belong to no body"),
        ({"a": "head", "b": ["head", "shank"]}, None, "'head' is in both 'a' and 'b'"),
        ({"bolt": "seam"}, None, "bodies.bolt: physical group 'seam' must have dimension 2"),
        (None, {"seam": ("head", "head")}, "interfaces.seam: joins the body 'head' to itself"),
        (None, {"plate": ("head", "shank")}, "interfaces.plate: physical group 'plate' must have"),
        (None, {"seam": ("head", "nut")}, "interfaces.seam: the body 'nut' is not a body"),
    ],
)
def test_bodies_and_interfaces_that_do_not_fit_the_groups_are_named(bodies, interfaces, message):
    """Every cell group belongs to exactly one body; every interface joins two bodies."""
    groups = {"head": (2, 1), "shank": (2, 2), "plate": (2, 3), "seam": (1, 4)}
    with pytest.raises(meshing.InterfaceMeshError, match=message):
        meshing.mesh_topology(groups, 2, bodies=bodies, interfaces=interfaces)
    good, _ = meshing.mesh_topology(groups, 2, bodies={"bolt": ["head", "shank"], "plate": "plate"})
    assert good == {"bolt": ("head", "shank"), "plate": ("plate",)}


def layered_builder(h: float = 0.125):
    """A base under a body of two layers (``soft`` below ``hard``), one interface between."""
    import gmsh

    gmsh.model.add("layered")
    occ = gmsh.model.occ
    tags = [occ.addRectangle(0.0, y, 0.0, 1.0, hh) for y, hh in LAYERS.values()]
    occ.fragment([(2, tags[0])], [(2, t) for t in tags[1:]])
    occ.synchronize()
    groups: dict[str, list[int]] = {k: [] for k in LAYERS}
    for _, t in gmsh.model.getEntities(2):
        y = occ.getCenterOfMass(2, t)[1]
        name = next(k for k, (y0, hh) in LAYERS.items() if y0 < y < y0 + hh)
        groups[name].append(t)
    curves: dict[str, list[int]] = {"seam": [], "ground": [], "lid": []}
    for _, t in gmsh.model.getEntities(1):
        y = occ.getCenterOfMass(1, t)[1]
        _, y0, _, _, y1, _ = gmsh.model.getBoundingBox(1, t)
        if abs(y1 - y0) > 1e-5:
            continue
        for name, at in (("ground", 0.0), ("seam", LAYERS["soft"][0]), ("lid", 1.0)):
            if abs(y - at) < 1e-9:
                curves[name].append(t)
    for name, ents in {**groups, **curves}.items():
        gmsh.model.addPhysicalGroup(2 if name in groups else 1, ents, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.model.mesh.generate(2)
    meshing.duplicate_interface_nodes(None, {"seam": (["base"], ["soft", "hard"])})
    return types.SimpleNamespace(gdim=2)


LAYERS = {"base": (0.0, 0.5), "soft": (0.5, 0.25), "hard": (0.75, 0.25)}  # y0, height


def test_a_body_of_two_groups_with_their_own_materials(comm):
    """Plane stress, uniaxial compression ``p`` of a base and a two-layer body (``nu / E`` the
    same in every group, so the lateral strains match and the stress stays uniaxial): every dof
    against the closed form, each layer straining by ``p / E`` of its own material."""
    dom, _ = meshing.create_interface_mesh(
        layered_builder,
        comm,
        bodies={"base": "base", "top": ["soft", "hard"]},
        interfaces={"seam": ("base", "top")},
    )
    assert dom.bodies == {"base": ("base",), "top": ("soft", "hard")}
    dom.add_node_group("pin", [[0.0, 0.0]], "base")
    mats = {"base": Material(2e5, 0.3), "soft": Material(1e5, 0.15), "hard": Material(2e5, 0.3)}
    alpha, p = 1e6, 50.0
    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=alpha, alpha_n=alpha, mu_c=0.5),
        mats,
        LoadingProgram([0.0, 1.0], {"press": [0.0, 1.0]}),
        [Dirichlet("ground", 0.0, component=1), Dirichlet("pin", 0.0, component=0)],
        [Pressure("lid", p, amplitude="press")],
        settings=ProblemSettings(mode="plane_stress"),
    )
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 1.0).run()
    V = problem.V
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n, :2]
    top = np.zeros(n, dtype=bool)
    cells = V.dofmap.list[dom.body_cells("top")].ravel()
    top[cells[cells < n]] = True
    # u_y(y): -p times the compliance integrated from the ground, the interface's jump on top
    (_, hb), (ys, hs), (yh, _) = LAYERS.values()
    E = {k: m.E for k, m in mats.items()}
    y = x[:, 1]
    uy = -p * (
        np.minimum(y, hb) / E["base"]
        + np.clip(y - ys, 0, hs) / E["soft"]
        + np.clip(y - yh, 0, None) / E["hard"]
    ) - np.where(top, p / alpha, 0.0)
    ux = 0.3 / 2e5 * p * x[:, 0]
    u = problem.u.x.array[: 2 * n].reshape(n, 2)
    err = max(np.abs(u[:, 0] - ux).max(initial=0.0), np.abs(u[:, 1] - uy).max(initial=0.0))
    assert everywhere(comm, err < 1e-9 * p / 1e5), err
