"""General loads and constraints (issue 16, item 3): traction vectors with a channel per
component, point forces at the nearest vertex (applied once, also at a vertex shared by two
ranks), Dirichlet conditions on whole bodies (cell groups) and on node groups (gmsh physical
points, scene points). Each checked against the reactions (equilibrium) or the prescribed
values. 1 and 2 ranks."""

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    Material,
    PointForce,
    Pressure,
    Traction,
)
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import LAW, SEC7_PENALTY, everywhere, prefix, small_scene

MATERIALS = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
PROGRAM = LoadingProgram([0, 1, 2, 3], {"press": [0, 1, 1, 1], "shear": [0, 0, 1, -1]})


def with_points(**kw):
    """The block on a base with physical points: ``pin`` at the block's top-left corner,
    ``ipin`` at the left end of the interface (a duplicated node: gmsh keeps it in one body)."""
    import gmsh

    info = meshing.build_block_on_base(**kw)
    box = gmsh.model.getEntitiesInBoundingBox
    pin = box(0.49, 0.99, -1, 0.51, 1.01, 1, dim=0)
    ipin = box(0.49, 0.49, -1, 0.51, 0.51, 1, dim=0)
    gmsh.model.addPhysicalGroup(0, [pin[0][1]], name="pin")
    gmsh.model.addPhysicalGroup(0, [ipin[0][1]], name="ipin")
    return info


def block(comm, builder=meshing.build_block_on_base, n=8):
    dom, _ = meshing.create_interface_mesh(builder, comm, n_interface=n, cell_type="triangle")
    return dom


def run(prob, name, on_step=None, dt=0.5):
    with FrictionSolver(prob, prefix(name)) as solver:
        LoadStepper(solver, dt, on_step=on_step).run()


def body_dofs(prob, body):
    V = prob.V
    cells = prob.domain.cell_tags.find(prob.tags[body])
    blocks = V.dofmap.list[cells].ravel()
    return np.unique(blocks[blocks < V.dofmap.index_map.size_local])


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_shear_traction_with_a_channel_per_component_equals_the_reaction():
    """A traction (q shear(t), -p press(t)) on the block's top, each component on its own
    channel: the base's reaction is minus its resultant at every step (the top is 1 mm wide)."""
    comm = MPI.COMM_WORLD
    q, p = 10.0, 300.0
    prob = InterfaceProblem(
        block(comm),
        LAW,
        MATERIALS,
        PROGRAM,
        [Dirichlet("bottom", (0.0, 0.0))],
        [Traction("top", (q, -p), amplitude=["shear", "press"])],
    )
    rows = []
    run(prob, "shear", lambda rec: rows.append((rec.t, prob.reactions["bottom"].copy())))
    assert len(rows) == 6
    for t, r in rows:
        applied = np.array([q * PROGRAM.amplitude("shear", t), -p * PROGRAM.amplitude("press", t)])
        assert r == pytest.approx(-applied, rel=1e-9, abs=1e-9 * p), (t, r, applied)
    assert rows[3][1][0] < -0.9 * q and rows[-1][1][0] > 0.9 * q  # both signs of the shear


def shared_vertex(dom):
    """Coordinates of a vertex that is a ghost on some rank (a vertex shared by two ranks) off
    the interface, the same on every rank; None on one rank."""
    mesh = dom.mesh
    mesh.topology.create_connectivity(0, 2)
    vmap = mesh.topology.index_map(0)
    ghosts = np.arange(vmap.size_local, vmap.size_local + vmap.num_ghosts, dtype=np.int32)
    x = meshing.nodes._vertex_coordinates(mesh, ghosts)
    x = x[np.abs(x[:, 1] - 0.5) > 1e-9]
    found = [tuple(v) for v in x]
    allx = sorted({v for part in mesh.comm.allgather(found) for v in part})
    return np.asarray(allx[0]) if allx else None


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_point_force_is_applied_once_and_equals_the_reaction():
    """Point forces: one at a vertex shared by two ranks (on 2 ranks), one off any vertex of the
    block (it goes to the nearest): the base's reaction is minus their sum, each counted once."""
    comm = MPI.COMM_WORLD
    dom = block(comm)
    shared = shared_vertex(dom)
    if comm.size > 1:
        assert shared is not None  # the test does test a shared vertex
    x1 = shared if shared is not None else np.array([1.0, 0.75, 0.0])
    F1, F2 = np.array([3.0, -50.0]), np.array([-1.0, -20.0])
    program = LoadingProgram([0, 1], {"f": [0, 1]})
    prob = InterfaceProblem(
        dom,
        LAW,
        MATERIALS,
        program,
        [Dirichlet("bottom", (0.0, 0.0))],
        [
            PointForce(x1[:2], F1, amplitude="f"),
            PointForce((0.93, 0.871), F2, amplitude="f", body="secondary"),
        ],
    )
    # each load vector's norm, a reduction, is the force's on every rank: the ranks without the
    # point take part (a norm cached on them while the others reduced hung a 2-rank run)
    norms = [f.norm() for _, f in prob.loads]
    assert norms == pytest.approx([np.linalg.norm(F1), np.linalg.norm(F2)], rel=1e-12)
    run(prob, "point", dt=1.0)
    assert prob.reactions["bottom"] == pytest.approx(-(F1 + F2), rel=1e-9)
    if x1[1] > 0.5:  # both on the block: the interface carries them
        s = interface_summary(prob)
        assert s["F_n"] == pytest.approx(-(F1 + F2)[1], rel=1e-9)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_dirichlet_condition_on_a_cell_group_holds_every_dof_of_the_body():
    """The base held as a whole (its cell group) against the base held at its bottom: with the
    cell group every dof of the base is zero, its interface side included; its reaction is the
    interface's resultant."""
    comm = MPI.COMM_WORLD
    results = {}
    for group in ("primary", "bottom"):
        prob = InterfaceProblem(
            block(comm),
            LAW,
            MATERIALS,
            PROGRAM,
            [Dirichlet(group, (0.0, 0.0))],
            [
                Pressure("top", 300.0, amplitude="press"),
                Traction("secondary_left", (40.0, 0.0), "shear"),
            ],
        )
        run(prob, f"cells_{group}")
        u = prob.u.x.array.reshape(-1, 2)[body_dofs(prob, "primary")]
        results[group] = (
            np.abs(u).max(initial=0.0),
            prob.reactions[group],
            interface_summary(prob),
        )
    umax, r, s = results["primary"]
    assert everywhere(comm, umax == 0.0)
    assert comm.allreduce(results["bottom"][0], op=MPI.MAX) > 1e-4  # held at the bottom, it moves
    assert r[1] == pytest.approx(s["F_n"], rel=1e-9)
    assert r[0] == pytest.approx(-s["F_t1"], rel=1e-9, abs=1e-9 * s["F_n"])
    assert abs(s["F_t1"]) > 5.0


def vertex_value(prob, x, body):
    """Displacement at the vertex of ``body`` at ``x`` (on every rank)."""
    verts = meshing.locate_node_group(
        prob.domain, "v", meshing.NodeGroup(np.array([[x[0], x[1], 0.0]]), (body,))
    )
    prob.mesh.topology.create_connectivity(0, 2)
    import dolfinx.fem

    blocks = dolfinx.fem.locate_dofs_topological(prob.V, 0, verts)
    blocks = blocks[blocks < prob.V.dofmap.index_map.size_local]
    mine = prob.u.x.array.reshape(-1, 2)[blocks]
    values = [v for part in prob.comm.allgather(mine.tolist()) for v in part]
    assert len(values) == 1
    return np.asarray(values[0])


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_dirichlet_conditions_on_gmsh_physical_points():
    """Physical points of the gmsh model are node groups: ``pin`` (the block's top-left corner)
    is moved by 0.01 mm sideways while the block is pressed; ``ipin`` (the left end of the
    interface, a duplicated node kept by gmsh in the base) is held. Each prescribed value is
    found at its vertex, in its body only (the other copy of ``ipin`` moves)."""
    comm = MPI.COMM_WORLD
    dom = block(comm, with_points)
    assert dom.node_groups["pin"].bodies == ("secondary",)
    assert dom.node_groups["ipin"].bodies == ("primary",)
    program = LoadingProgram([0, 1], {"p": [0, 1]})
    prob = InterfaceProblem(
        dom,
        LAW,
        MATERIALS,
        program,
        [
            Dirichlet("bottom", (0.0, 0.0)),
            Dirichlet("pin", 0.01, component=0, amplitude="p"),
            Dirichlet("ipin", (0.0, 0.0)),
        ],
        [Pressure("top", 200.0, amplitude="p")],
    )
    run(prob, "pins", dt=0.5)
    assert vertex_value(prob, (0.5, 1.0), "secondary")[0] == 0.01
    assert np.all(vertex_value(prob, (0.5, 0.5), "primary") == 0.0)
    assert np.abs(vertex_value(prob, (0.5, 0.5), "secondary")).max() > 1e-5
    assert prob.reactions["pin"][1] == 0.0 and abs(prob.reactions["pin"][0]) > 0.1


def test_a_scene_with_general_loads_and_constraints():
    """The same features through a scene: a point of ``points`` used as a node group by a
    Dirichlet condition (its nearest vertex), a point force at a named point, a traction with a
    channel per component and the base held as a body. The reactions balance the loads."""
    s = small_scene()
    s["solver"]["prefix"] = prefix("scene_loads")
    s["program"] = {"times": [0, 1], "channels": {"press": [0, 1], "slide": [0, 1]}}
    s["dirichlet"] = [
        {"group": "primary", "value": [0.0, 0.0]},
        {"group": "corner", "component": 0, "value": 0.0},
    ]
    s["points"] = {"corner": {"x": [1.02, 1.01], "body": "secondary"}, "A": {"x": [1.3, 0.8]}}
    s["loads"] = [
        {"type": "traction", "group": "top", "value": [0.0, -100.0], "amplitude": [None, "press"]}
    ]
    s["point_forces"] = [{"point": "A", "value": [2.0, -10.0], "amplitude": "slide"}]
    res = run_scene(s, comm=MPI.COMM_WORLD)
    row = res.history[-1]
    width = 1.0
    assert row["R_primary_y"] + row["R_corner_y"] == pytest.approx(100.0 * width + 10.0, rel=1e-9)
    assert row["R_primary_x"] + row["R_corner_x"] == pytest.approx(-2.0, rel=1e-9, abs=1e-9)
    assert row["R_corner_y"] == 0.0  # only component 0 is held there
