"""Scenes with several bodies and interfaces, the user's group names and a modelling mode
(issue 21 item 1, issue 24 item 3): the scene keys ``bodies``, ``interfaces``, ``mode`` and
``mesh.names``.

* The three stacked blocks of ``test_multibody.py`` written to an ``.msh`` file: a scene with two
  interfaces (their own laws; ``primary``/``secondary`` and ``master``/``slave`` both accepted)
  gives per-interface history columns against statics, one interface-history file and one
  point-cloud file per interface, a probe on a named interface, and a checkpoint from which a
  restart continues the run to round-off.
* The classic two-body scene on a file whose groups have the user's names (``mesh.names``): the
  same history as on the classic names.
* The built-in meshes' older group names (``master``, ``slave_left``, ...) in a mesh file and
  in a scene: read as ``primary``, ``secondary_left``, ... (the input aliases), the run and its
  columns those of the new names; a checkpoint whose settings say the older names restarts it.
* Bad scenes: every new key checked, the path named.
"""

import copy

import h5py
import numpy as np
import pytest

from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import SceneError, parse_scene, run_scene
from tests.fem.test_multibody import P_LID, W_CAP, renamed_block, stack_builder
from tests.helpers import everywhere, on_root, raised_on_every_rank

COULOMB = {"law": "coulomb", "params": {"alpha_t": 1e5, "alpha_n": 1e5, "mu_c": 0.5}}


def write_model(builder, path):
    """Run a gmsh builder on rank 0 and write its model to ``path``."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Verbosity", 2)
    try:
        builder()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def stack_scene(path, **outputs) -> dict:
    weak = copy.deepcopy(COULOMB)
    weak["params"]["mu_c"] = 0.2
    steel = {"E": 2.1e5, "nu": 0.3}
    return {
        "kind": "fe",
        "name": "stack",
        "mesh": {"file": str(path), "gdim": 2},
        "bodies": {"base": "base", "middle": ["middle"], "cap": "cap"},
        "interfaces": {
            "low": {"primary": "base", "secondary": "middle", "law": weak},
            "high": {"master": "middle", "slave": "cap"},
        },
        "law": COULOMB,
        "mode": "plane_strain",
        "materials": {"base": steel, "middle": steel, "cap": steel},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "push": [0, 0, 1]}},
        "solver": {"dt": 0.25, "linear": "lu"},
        "dirichlet": [
            {"group": "ground", "value": [0.0, 0.0]},
            {"group": "lid", "value": 0.01, "component": 0, "amplitude": "push"},
        ],
        "loads": [{"type": "pressure", "group": "lid", "value": P_LID, "amplitude": "press"}],
        "points": {"A": {"x": [1.0, 1.0], "body": "cap"}},
        "outputs": {
            "probes": [{"point": "A", "fields": ["f_n"], "interface": "high"}],
            **outputs,
        },
    }


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on 1 mm bodies"
)
def test_a_scene_with_three_bodies_and_two_interfaces(comm, shared_tmp):
    path = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(stack_builder, path))
    full = run_scene(
        stack_scene(
            path,
            history=True,
            interface_history=True,
            fields="xdmf",
            checkpoint_times=[1.5],
            snapshots=[2.0],
        ),
        outdir=shared_tmp / "a",
        comm=comm,
    )
    last = full.history[-1]
    load = P_LID * W_CAP
    high = full.snapshots[2.0]["high"]  # the profile of the interface the probe names
    nearest = int(np.argmin(np.linalg.norm(high["x"] - [1.0, 1.0], axis=1)))
    checks = {
        "F_n": max(abs(last[f"{k}.F_n"] - load) for k in ("low", "high")) < 1e-8 * load,
        "sliding": abs(abs(last["low.F_t1"]) - 0.2 * load) < 1e-6 * load,
        "probe": abs(last["A.f_n"] - high["f_n"][nearest]) < 1e-12 * P_LID,
        "snapshots": set(full.snapshots[2.0]) == {"low", "high"},
    }
    assert everywhere(comm, all(checks.values())), (checks, last)

    def files():
        for name in ("low", "high"):
            with h5py.File(shared_tmp / "a" / f"interface_history_{name}.h5") as f:
                assert f["time"].shape == (len(full.history),)
            assert (shared_tmp / "a" / "fields" / f"interface_points_{name}.xdmf").exists()
            assert (shared_tmp / "a" / "fields" / f"interface_{name}.xdmf").exists()

    on_root(comm, files)
    again = run_scene(
        stack_scene(path, history=True),
        outdir=shared_tmp / "a",
        comm=comm,
        restart=shared_tmp / "a" / "checkpoint.h5",
    )
    keys = ["low.F_t1", "high.F_t1", "low.up_norm", "high.F_n"]
    a = np.array([[r[k] for k in keys] for r in full.history])
    b = np.array([[r[k] for k in keys] for r in again.history])
    assert everywhere(comm, a.shape == b.shape and np.abs(a - b).max() <= 1e-10 * np.abs(a).max())


def classic(path=None, names=None):
    s = {
        "kind": "fe",
        "name": "named",
        "mesh": {"builder": "block_on_base", "options": {"n_interface": 8}},
        "law": COULOMB,
        "materials": {"master": {"E": 2.1e5, "nu": 0.3}, "slave": {"E": 7e4, "nu": 0.33}},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
        "solver": {"dt": 0.25, "linear": "lu"},
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0]},
            {"group": "top", "value": 0.01, "component": 0, "amplitude": "slide"},
        ],
        "loads": [{"type": "pressure", "group": "top", "value": 100.0, "amplitude": "press"}],
    }
    if path is not None:
        s["mesh"] = {"file": str(path), "gdim": 2, "names": names}
        s["materials"] = {"base": s["materials"]["master"], "block": s["materials"]["slave"]}
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on the 1 mm block"
)
def test_a_classic_scene_on_a_file_with_the_users_names(comm, shared_tmp):
    path = shared_tmp / "named.msh"
    on_root(comm, lambda: write_model(renamed_block, path))
    names = {"master": "base", "slave": "block", "interface": "contact"}
    mine = run_scene(classic(path, names), comm=comm).history
    ref = run_scene(classic(), comm=comm).history
    a, b = (np.array([r["F_t1"] for r in h]) for h in (mine, ref))
    assert everywhere(comm, np.abs(a - b).max() <= 1e-12 * np.abs(b).max())


def older_names_block():
    """The classic builder's model under its groups' older names (``master``, ``slave_left``)."""
    import gmsh

    from subfric_dolfinx import meshing

    info = meshing.build_block_on_base(n_interface=8)
    older = {new: old for old, new in meshing.CLASSIC_ALIASES.items()}
    for d, t in gmsh.model.getPhysicalGroups():
        name = gmsh.model.getPhysicalName(d, t)
        if name in older:
            gmsh.model.removePhysicalName(name)
            gmsh.model.setPhysicalName(d, t, older[name])
    return info


def worst_of(rows, ref):
    """The largest difference of two histories' values, relative to 1 + the reference's."""
    return max(
        abs(a[k] - b[k]) / (1.0 + abs(b[k])) for a, b in zip(rows, ref, strict=False) for k in b
    )


def named_so(mesh, primary, secondary):
    """The classic scene on ``mesh``, its body held and a flank sprung under the given names."""
    s = classic()
    s["mesh"] = mesh
    s["materials"] = {primary: s["materials"]["master"], secondary: s["materials"]["slave"]}
    s["dirichlet"][0] = {"group": primary, "value": [0.0, 0.0]}
    s["springs"] = [{"group": f"{secondary}_left", "stiffness": [1.0, 0.0]}]
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning, reason="a 1e5 MPa/mm Coulomb penalty on the 1 mm block"
)
def test_older_group_names_are_read_as_their_new_names(comm, shared_tmp):
    """A mesh file whose groups have the built-in meshes' older names (``master``, ``slave``,
    ``slave_left``, ...) and a scene naming them so: the reader reads them as ``primary``,
    ``secondary``, ``secondary_left``, the scene's names are read alike, and the run is the one
    of the builder's mesh under the new names, its columns named so (``R_primary_x``,
    ``S_secondary_left_x``). A checkpoint whose settings say the older names restarts it."""
    from subfric_dolfinx import meshing

    path = shared_tmp / "older.msh"
    on_root(comm, lambda: write_model(older_names_block, path))
    dom = meshing.read_interface_mesh(path, comm, 2)
    older = named_so({"file": str(path), "gdim": 2}, "master", "slave")
    older["outputs"] = {"checkpoint_times": [1.5]}
    ref = run_scene(named_so(classic()["mesh"], "primary", "secondary"), comm=comm).history
    got = run_scene(older, outdir=shared_tmp / "older", comm=comm).history
    columns = set(got[-1])
    checks = {
        "groups": {"primary", "secondary", "secondary_left", "primary_top"} <= set(dom.tags)
        and not any(n.startswith(("master", "slave")) for n in dom.tags),
        "columns": columns == set(ref[-1])
        and {"R_primary_x", "S_secondary_left_x"} <= columns
        and not any("master" in c or "slave" in c for c in columns),
        "run": len(got) == len(ref) and worst_of(got, ref) < 1e-12,
    }
    assert everywhere(comm, all(checks.values())), checks

    def older_settings():  # as a checkpoint of an older run stored them
        with h5py.File(shared_tmp / "older/checkpoint.h5", "r+") as f:
            text = f.attrs["settings"]
            f.attrs["settings"] = text.replace("primary", "master").replace("secondary", "slave")
            return "master" in f.attrs["settings"] and "slave_left" in f.attrs["settings"]

    assert on_root(comm, older_settings)
    again = run_scene(
        older, outdir=shared_tmp / "again", comm=comm, restart=shared_tmp / "older/checkpoint.h5"
    )
    assert len(again.history) == len(got) and worst_of(again.history, got) < 1e-9


BAD = [
    (lambda s: s.update(mode="axisymmetric_3d"), r"scene.mode: must be one of"),
    (lambda s: s.update(mode="3d"), r"scene.mode: '3d' needs a 3-D mesh"),
    (lambda s: s["mesh"].update(names={"base": "x"}), r"scene.mesh.names: unknown role 'base'"),
    (lambda s: s["bodies"].update(cap=["cap", "base"]), r"scene.bodies.cap: the group 'base'"),
    (
        lambda s: s["interfaces"]["low"].update(secondary="shaft"),
        r"scene.interfaces.low: 'shaft' is not a body of scene.bodies",
    ),
    (
        lambda s: s["interfaces"]["high"].update(primary="base"),
        r"scene.interfaces.high: 'primary' and 'master' name the same side differently",
    ),
    (
        lambda s: s["interfaces"]["high"].pop("slave"),
        r"scene.interfaces.high: give both sides",
    ),
    (
        lambda s: s.pop("law"),
        r"scene.interfaces.high.law: missing, and the scene has no 'law'",
    ),
    (
        lambda s: s["interfaces"]["low"]["law"]["params"].update(mu_c=-1),
        r"scene.interfaces.low.law: .*mu_c",
    ),
    (lambda s: s.update(initial_gap=0.01), r"scene.initial_gap/regions: the scene has several"),
    (
        lambda s: s["materials"].update(shaft={"E": 1.0, "nu": 0.3}),
        r"scene.materials: \['shaft'\] are neither bodies",
    ),
    (lambda s: s["points"]["A"].update(body="bolt"), r"scene.points.A.body: 'bolt' is not a body"),
    (
        lambda s: s["interfaces"]["low"].update(quadrature="simpson"),
        r"scene.interfaces.low.quadrature: must be 'gauss' or 'nodal'",
    ),
    # issue 36: the key path and "finite" said; a body without material before the mesh
    (
        lambda s: s["interfaces"]["low"].update(kinematics="finite_sliding", reach=float("nan")),
        r"scene.interfaces.low.reach: expected a finite number, got nan",
    ),
    (
        lambda s: s["solver"].update(dt_max=float("inf")),
        r"scene.solver.dt_max: expected a finite number, got inf",
    ),
    (
        lambda s: s["materials"].pop("cap"),
        r"scene.materials: no material for the body 'cap' \(give one for it, or for each of its",
    ),
    (
        lambda s: (s["materials"].pop("cap"), s["materials"].update(master=s["materials"]["base"])),
        r"no material for the body 'cap'",  # master is the first interface's primary: base
    ),
]


@pytest.mark.parametrize(("mutate", "pattern"), BAD)
def test_bad_bodies_and_interfaces_are_named(mutate, pattern):
    s = stack_scene("x.msh")
    mutate(s)
    with pytest.raises(SceneError, match=pattern):
        parse_scene(s)


def test_a_mesh_without_the_named_interface_is_refused_naming_it(comm, shared_tmp):
    path = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(stack_builder, path))
    s = stack_scene(path)
    s["interfaces"]["middle_cap"] = s["interfaces"].pop("high")
    with raised_on_every_rank(SceneError, "scene.mesh:", "'middle_cap' not found"):
        run_scene(s, comm=comm)


def test_two_interfaces_over_the_same_facets_are_named(comm, shared_tmp):
    """A second physical group on the facets of ``low``, named as an interface too: refused
    naming both (it ended in 'elements of physical groups are not entities of the DOLFINx
    mesh')."""
    import gmsh

    def builder():
        stack_builder()
        for d, t in gmsh.model.getPhysicalGroups():
            if gmsh.model.getPhysicalName(d, t) == "low":
                ents = gmsh.model.getEntitiesForPhysicalGroup(d, t)
                gmsh.model.addPhysicalGroup(d, [int(e) for e in ents], name="low2")

    path = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(builder, path))
    s = stack_scene(path)
    s["interfaces"]["low2"] = copy.deepcopy(s["interfaces"]["low"])
    with raised_on_every_rank(SceneError, "the interfaces 'low' and 'low2' share 24 facets"):
        run_scene(s, comm=comm)
