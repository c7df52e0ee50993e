"""Finite sliding on non-matching interfaces inside :class:`InterfaceProblem` (issue 22).

* The non-matching contact patch test (MOOSE ``plane_2``/NAFEMS-style): a block on a base of the
  same width, meshed 3 : 2 (and 4 : 6, quadrilaterals, P2) across the interface, pressed by a
  uniform pressure with friction: the exact solution is a uniform stress, the interface pressure
  is uniform and the tangential traction zero; the FE solution is exact when the interface
  transmits a uniform pressure exactly (secondary Gauss points, segment transfer to the primary).
* A block sliding ten times its width along a long base at constant pressure, re-paired as it
  goes (across the partition boundary on 2 ranks): the mean traction against slip equals the
  material-point integration of the law on the same gap path (each point's path), the base
  carries the load where the block is (the centroid of the primary nodal forces is the block's
  centre), and Newton needs at most 5 iterations per step.
* A rigid shaft turned in a shrink-fitted hub, meshed independently with P2 arcs: the pressure
  stays at Lame's at every point within 1 % (measured within 0.7 %), the torque reaches
  Coulomb's ``2 pi R^2 mu p`` (0.995 of it); the straight-sided polygon separates (pressure 0
  to 3.7 times Lame's, torque 0.64 to 0.76 of Coulomb's).
* Axisymmetric: two discs meshed apart, pressed: the pressure uniform to 1e-6 (the transfer
  projects the traction times ``2 pi r``); the shrink fit's shaft pushed two facets out of its
  hub: axial balance, gross sliding, the points beyond the hub open.
* The small-sliding interface is the default kind; a finite-sliding interface on a matching mesh
  at small relative displacement gives the small-sliding forces (the finite-sliding transfer
  follows the relative tangential displacement, here about 1e-5 of a facet: measured 6e-6 of
  the largest nodal force).
"""

import types

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import CoulombLaw, preset
from subfric_dolfinx.fem import (
    Dirichlet,
    DirichletField,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
    StepControl,
)
from subfric_dolfinx.fem.interface import InterfaceError, SlidingInterface
from subfric_dolfinx.fem.validity import ValidityWatch
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from tests.contact_meshes import tagged_annuli, tagged_blocks, tagged_boxes
from tests.helpers import SEC7_PENALTY, everywhere, raised_on_every_rank

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)

STEEL = Material(2.1e5, 0.3)


def gather(comm, a):
    return np.concatenate(comm.allgather(np.asarray(a)))


def pressed_patch(comm, cell, degree, n_base, n_block, p, mode=None):
    """The base and the block meshed apart (``n_base`` : ``n_block``), a finite-sliding interface,
    pressed by ``p`` on top in two steps; the problem, the step records, the gathered tractions."""
    dom = tagged_blocks(comm, n_base=n_base, n_block=n_block, cell=cell, split_x=0.5)
    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.3),
        {"base": STEEL, "block": STEEL},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
        [
            Dirichlet("bottom", 0.0, 1),
            Dirichlet("base_left", 0.0, 0),
            Dirichlet("block_left", 0.0, 0),
        ],
        [Pressure("top", p, amplitude="press")],
        interfaces=[
            Interface(
                "contact", "base", "block", kinematics="finite_sliding", intended_compliance=True
            )
        ],
        settings=ProblemSettings(degree=degree, mode=mode),
    )
    with FrictionSolver(problem, linear="lu") as solver:
        records = LoadStepper(solver, 0.5).run()
    return problem, records, gather(comm, problem.interfaces["contact"].last.traction)


@pytest.mark.parametrize(
    "cell, degree, n_base, n_block",
    [
        ("triangle", 1, (3, 2), (2, 2)),
        ("triangle", 1, (6, 2), (4, 3)),
        ("quadrilateral", 1, (3, 2), (2, 3)),
        ("triangle", 2, (3, 2), (2, 2)),
        ("quadrilateral", 2, (2, 1), (3, 2)),
    ],
)
def test_nonmatching_patch_test_transmits_a_uniform_pressure(comm, cell, degree, n_base, n_block):
    p = 100.0
    problem, records, tr = pressed_patch(comm, cell, degree, n_base, n_block, p)
    iface = problem.interfaces["contact"]
    assert isinstance(iface, SlidingInterface)
    assert (
        tr.shape[0] == n_block[0] * iface.law_points.nq
    )  # every secondary point, once over the ranks
    checks = {
        "f_n": np.abs(tr[:, 1] / p - 1.0).max() < 1e-6,
        "f_t": np.abs(tr[:, 0]).max() < 1e-6 * p,
        "reaction": abs(problem.reactions["bottom"][1] - p) < 1e-6 * p,
        "newton": max(r.iterations for r in records) <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, tr)


def test_the_last_iterate_is_not_evaluated_again(comm, monkeypatch):
    """``update`` at the last evaluation's displacement (on every rank, nothing committed since)
    returns that evaluation; a displacement changed on one rank only is evaluated again on every
    rank (the projections' exchanges are collective), and so is the same one after a commit."""
    import subfric_dolfinx.fem.interface.finite.interface as module

    problem, _, _ = pressed_patch(comm, "triangle", 1, (3, 2), (2, 2), 100.0)
    iface = problem.interfaces["contact"]
    made = []
    real = module.contact_geometry
    monkeypatch.setattr(module, "contact_geometry", lambda *a: made.append(1) or real(*a))
    x = np.zeros(iface.n_owned)
    first = iface.update(x)
    again = iface.update(x.copy())
    y = x.copy()
    if comm.rank == 0 and y.size:
        y[0] = 1e-9
    other = iface.update(y)
    counts = [len(made)]
    iface.update(y)
    iface.commit()
    iface.update(y)
    counts.append(len(made))
    assert everywhere(comm, again is first and other is not first), (counts, comm.rank)
    assert everywhere(comm, counts == [2, 3]), counts


@pytest.mark.parametrize(
    "cell, degree, n_base, n_block",
    [
        ("triangle", 1, (3, 2), (2, 2)),
        ("triangle", 2, (3, 2), (2, 2)),
        ("quadrilateral", 2, (2, 1), (3, 2)),
    ],
)
def test_axisymmetric_nonmatching_patch_test(comm, cell, degree, n_base, n_block):
    """Two discs (x = r) stacked, meshed apart, pressed: the exact solution is a uniform
    ``sigma_zz = -p`` (``u_r = nu p r / E``, in the FE space), the interface transmits it
    exactly where the traction times ``2 pi r`` is projected (the secondary's weights): the pressure
    uniform to 1e-6 although ``r`` varies along the interface, the bottom's reaction
    ``p pi R^2``."""
    p = 100.0
    problem, records, tr = pressed_patch(comm, cell, degree, n_base, n_block, p, "axisymmetric")
    watch = ValidityWatch(problem)  # the element sizes are the facets', not times 2 pi r
    checks = {
        "f_n": np.abs(tr[:, 1] / p - 1.0).max() < 1e-6,
        "f_t": np.abs(tr[:, 0]).max() < 1e-6 * p,
        "reaction": abs(problem.reactions["bottom"][1] - p * np.pi) < 1e-6 * p,
        "sizes": np.isclose(watch.size, 1.0) and np.isclose(watch.h_min, 1.0 / n_block[0]),
        "newton": max(r.iterations for r in records) <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, tr)


def test_axisymmetric_shaft_pushed_out_of_its_shrink_fitted_hub(comm):
    """``demos/shrink_fit.py``'s fit (matched mesh, P2), its shaft pushed 5 mm out, a facet a
    step, with Coulomb: the hub's ends carry the push force (axial balance, to 1e-8), the fit
    slides (``F = mu F_n``), the shaft's points beyond the hub separate, at most 5 Newton a
    step; before the push the fit's pressure is Lame's (0.5 %, as the small-sliding demo).

    A facet a step: no secondary facet in contact straddles the hub's end at a step's end (where one
    does, tests/fem/interface/finite/test_finite_sliding_overhang.py; docs/model.md)."""
    from demos import shrink_fit as sf
    from subfric_dolfinx import meshing

    h, push = 2.5, 5.0
    domain, _ = meshing.create_interface_mesh(sf.build, comm, interfaces=sf.SIDES, h=h)
    problem = InterfaceProblem(
        domain,
        CoulombLaw(alpha_t=sf.ALPHA, alpha_n=sf.ALPHA, mu_c=sf.MU),
        {"shaft": STEEL, "hub": STEEL},
        LoadingProgram([0.0, 1.0, 2.0], {"push": [0.0, 0.0, 1.0]}),
        [
            Dirichlet("axis", 0.0, component=0),
            Dirichlet("hub_ends", 0.0, component=1),
            Dirichlet("shaft", push, component=1, amplitude="push"),
        ],
        interfaces=[
            Interface(
                "fit",
                "hub",
                "shaft",
                kinematics="finite_sliding",
                initial_gap=-sf.DELTA,
                search_radius=0.1,
                reach=2 * h,
            )
        ],
        settings=ProblemSettings(degree=2, mode="axisymmetric"),
    )
    iface, p0, rows = problem.interfaces["fit"], sf.lame_pressure(), []

    def on_step(rec):
        s = interface_summary(problem)
        z = iface.law_points.points[:, 1] + push * max(
            rec.t - 1.0, 0.0
        )  # the shaft moves rigidly in z
        out = z > sf.L + 1e-6
        fn = iface.last.traction[:, 1]
        # the interface's global axial force on the shaft, sum of w (Q^T f)_z
        tg = np.einsum("mji,mj->mi", iface.geometry.Q, iface.last.traction)
        axial = comm.allreduce(float(iface.law_points.weights @ tg[:, 1]))
        rows.append(
            (
                rec.t,
                rec.iterations,
                problem.reactions["shaft"][1],
                problem.reactions["hub_ends"][1],
                s["F_n"],
                comm.allreduce(int(np.count_nonzero(fn[out] != 0.0))),
                comm.allreduce(np.abs(fn / p0 - 1.0).max(initial=0.0), op=MPI.MAX),
                axial,
            )
        )

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.5, control=StepControl(hold_dt=1.0), on_step=on_step).run()
    r = np.array(rows)
    pushed = r[:, 0] > 1.0 + 1e-9
    checks = {
        "Lame before the push": r[0, 6] < 5e-3,
        "balance": np.abs(r[:, 2] + r[:, 3]).max() < 1e-8 * np.abs(r[:, 2]).max(),
        # the push is the interface's force on the shaft (the frames of the current iterate)
        "push = interface force": np.abs(r[:, 2] - r[:, 7]).max() < 1e-6 * np.abs(r[:, 2]).max(),
        # gross sliding: F = mu F_n where every point slips, F_n integrated in the points'
        # frames, which follow the hub's deformed surface (tilted near its held ends): measured
        # 7.2e-4 below it after one facet, 1.1e-3 after two (the step's normals held: 7e-7, 4e-4)
        "Coulomb": np.abs(r[pushed, 2] / (sf.MU * r[pushed, 4]) - 1.0).max() < 2e-3,
        "out of the hub, open": r[:, 5].max() == 0,
        "pushed out": abs(r[-1, 0] - 2.0) < 1e-12,
        "newton": r[:, 1].max() <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, r)


def slide_problem(comm, p, slide, law, n_base=36):
    """A block (width 1, 2 elements) moved ``slide`` along a rigid base of 36 or more
    elements (2 : 3 across the interface): every block dof's x is prescribed, so every point of
    the interface follows the same slip path; the pressure is applied on top."""
    length = 2.0 + slide
    dom = tagged_blocks(
        comm,
        base=(0.0, length, -1.0, 0.0),
        block=(0.5, 1.5, 0.0, 1.0),
        n_base=(max(n_base, int(3 * length)), 1),
        n_block=(2, 2),
        split_x=length / 2,
    )
    program = LoadingProgram(
        [0.0, 0.1, 0.2, 1.0], {"press": [0, 1, 1, 1], "slide": [0, 0, 0.5 / slide, 1.0]}
    )
    return InterfaceProblem(
        dom,
        law,
        {"base": STEEL, "block": STEEL},
        program,
        [Dirichlet("base", (0.0, 0.0)), Dirichlet("block", slide, 0, amplitude="slide")],
        [Pressure("top", p, amplitude="press")],
        interfaces=[
            Interface(
                "contact",
                "base",
                "block",
                kinematics="finite_sliding",
                search_radius=2.5 * p / law.alpha_n,
                intended_compliance=True,
            )
        ],
    )


def run_slide(comm, problem, dt):
    iface = problem.interfaces["contact"]
    X = problem.V.tabulate_dof_coordinates()
    n_own = problem.V.dofmap.index_map.size_local
    base_nodes = np.unique(iface.sides.primary.nodes)
    base_nodes = base_nodes[base_nodes < n_own]
    rows = []

    def on_step(rec):
        tr, w = iface.last.traction, iface.law_points.weights
        f = problem.interface_force.reshape(-1, 2)[base_nodes]
        sums = comm.allreduce(
            np.array(
                [
                    w @ tr[:, 0],
                    w @ tr[:, 1],
                    w @ iface.law_points.last_gap[:, 1],
                    w.sum(),
                    f[:, 1].sum(),
                    f[:, 1] @ X[base_nodes, 0],
                ]
            )
        )
        ft, fn, gn, area, fy, my = sums
        slide = problem.program.amplitude("slide", rec.t)
        rows.append(
            (rec.t, rec.dt, rec.iterations, ft / area, fn / area, gn / area, my / fy, slide)
        )

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, dt, control=StepControl(dt_max=dt), on_step=on_step).run()
    return np.array(rows)


def material_point(law, rows, slide):
    """The law integrated at one point over the same steps and gap path."""
    state, out = law.initial_state(1, 1), []
    for _t, dt, _, _, _, gn, _, s in rows:
        res = law.return_map(np.array([[slide * s, gn]]), state, dt)
        state = res.state
        out.append(res.traction[0])
    return np.array(out)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_block_slides_ten_widths_with_the_load_under_it(comm):
    law, p, slide = preset("sec7"), 300.0, 10.0
    problem = slide_problem(comm, p, slide, law)
    rows = run_slide(comm, problem, 0.01)
    ref = material_point(law, rows, slide)
    peak = np.abs(ref[:, 0]).max()
    centre = 1.0 + slide * rows[:, 7]  # the block's centre
    iface = problem.interfaces["contact"]
    checks = {
        "mean f_t": np.abs(rows[:, 3] - ref[:, 0]).max() < 1e-3 * peak,
        "f_n": np.abs(rows[-1, 4] - p) < 1e-9 * p,
        "peak resolved": np.argmax(np.abs(ref[:, 0])) > np.argmax(rows[:, 7] > 0),
        "load under the block": np.abs(rows[rows[:, 4] > 0, 6] - centre[rows[:, 4] > 0]).max()
        < 1e-9,
        "re-paired": iface.layout_version > 3 and problem.layout_version > 0,
        "newton": rows[:, 2].max() <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, rows[:, 3] - ref[:, 0])


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
@pytest.mark.parametrize("p", [100.0, 600.0])
def test_paper_fig10_as_a_boundary_value_problem(comm, p):
    """Sec. 7 set, 20 mm of sliding: the FE mean traction against the material-point curve."""
    law, slide = preset("sec7"), 20.0
    rows = run_slide(comm, slide_problem(comm, p, slide, law), 0.0125)
    ref = material_point(law, rows, slide)
    err = np.abs(rows[:, 3] - ref[:, 0]).max() / np.abs(ref[:, 0]).max()
    newton = int(rows[:, 2].max())
    assert everywhere(comm, err < 1e-2 and abs(rows[-1, 7] - 1.0) < 1e-12 and newton <= 5), (
        err,
        np.bincount(rows[:, 2].astype(int)),
    )


def test_finite_sliding_on_a_matching_mesh_is_small_sliding_at_small_slip(comm):
    """The same matching mesh, pressed and slid by 1e-6: both kinds give the same forces."""
    law = CoulombLaw(alpha_t=1e6, alpha_n=1e5, mu_c=0.3)
    out = {}
    for kind in ("small_sliding", "finite_sliding"):
        # matching sides: the base as wide as the block and meshed alike; nodes apart
        dom = tagged_blocks(comm, n_base=(4, 2), n_block=(4, 2), split_x=0.5)
        program = LoadingProgram([0.0, 1.0, 2.0], {"press": [0, 1, 1], "slide": [0, 0, 1]})
        problem = InterfaceProblem(
            dom,
            law,
            {"base": STEEL, "block": STEEL},
            program,
            [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 1e-6, 0, amplitude="slide")],
            [Pressure("top", 100.0, amplitude="press")],
            interfaces=[
                Interface("contact", "base", "block", kinematics=kind, intended_compliance=True)
            ],
        )
        with FrictionSolver(problem, linear="lu") as solver:
            LoadStepper(solver, 0.5).run()
        out[kind] = problem.interface_force.copy()
    # over all ranks: a rank may own no dof of this small mesh (one of 3 does)
    scale = comm.allreduce(np.abs(out["small_sliding"]).max(initial=0.0), op=MPI.MAX)
    diff = comm.allreduce(
        np.abs(out["finite_sliding"] - out["small_sliding"]).max(initial=0.0), op=MPI.MAX
    )
    assert diff < 5e-5 * scale, (diff, scale)


def test_unknown_kinematics_are_named(comm):
    dom = tagged_blocks(comm)
    args = (
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.3),
        {"base": STEEL, "block": STEEL},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
    )
    with raised_on_every_rank(InterfaceError, "kinematics 'large' is not one of"):
        InterfaceProblem(
            *args, interfaces=[Interface("contact", "base", "block", kinematics="large")]
        )


def turn_hub(comm, geometry_degree, n_inner=48, n_outer=64, facets=3):
    """A rigid shaft (every dof prescribed: the exact rotation) shrink-fitted in a hub (outer
    circle fixed), meshed independently (48 : 64 around), turned by ``facets`` of its facets.

    Returns the Lame pressure and per step: iterations, the smallest and largest pressure over
    the points (relative to Lame's) and the torque over Coulomb's ``2 pi R^2 mu p``.
    """
    R, r2, delta, mu, E, nu, alpha = 1.0, 1.5, 1e-3, 0.2, 2.1e5, 0.3, 1e6
    dom = tagged_annuli(
        comm, n_inner=n_inner, n_outer=n_outer, geometry_degree=geometry_degree, split_x=0.0
    )
    turn = facets * 2 * np.pi / n_inner

    def rotation(c):
        def f(x, t):
            th = turn * max(t - 0.1, 0.0)
            rx = np.cos(th) * x[0] - np.sin(th) * x[1]
            ry = np.sin(th) * x[0] + np.cos(th) * x[1]
            return rx - x[0] if c == 0 else ry - x[1]

        return f

    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=alpha, alpha_n=alpha, mu_c=mu),
        {"shaft": Material(E, nu), "hub": Material(E, nu)},
        LoadingProgram([0.0, 0.1, 1.1], {"turn": [0, 0, 1]}),
        [
            DirichletField("shaft", rotation(0), 0),
            DirichletField("shaft", rotation(1), 1),
            Dirichlet("outer", (0.0, 0.0)),
        ],
        interfaces=[
            Interface("contact", "shaft", "hub", kinematics="finite_sliding", initial_gap=-delta)
        ],
        settings=ProblemSettings(degree=2),
    )
    # Lame: the hub ring with u(R) = delta - p / alpha (the penalty's share), u(r2) = 0
    lam, G = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    k = -(2 * (lam + G) + 2 * G * r2**2 / R**2) / (R - r2**2 / R)
    p = k * delta / (1 + k / alpha)
    iface = problem.interfaces["contact"]
    rows = []

    def on_step(rec):
        tr = iface.last.traction
        fn = gather(comm, tr[:, 1])
        r = np.linalg.norm(iface.law_points.points, axis=1)
        T = comm.allreduce(float(iface.law_points.weights @ (tr[:, 0] * r)))
        rows.append((rec.iterations, fn.min() / p, fn.max() / p, T / (2 * np.pi * R**2 * mu * p)))

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.1, control=StepControl(dt_max=0.1), on_step=on_step).run()
    return np.array(rows), iface


def test_curved_shrink_fit_turns_without_locking(comm):
    """P2 arcs on both sides (non-matching): every point's pressure stays within 1 % of Lame's
    while the shaft turns by three of its facets, the torque reaches Coulomb's within 1 %, with
    at most 5 Newton iterations a step; the straight-sided polygon separates and locks."""
    rows, iface = turn_hub(comm, 2)
    turning = rows[1:]
    checks = {
        "pressure": np.abs(rows[:, 1:3] - 1.0).max() < 1e-2,
        "torque": np.abs(turning[:, 3] - 1.0).max() < 1e-2,
        "newton": rows[:, 0].max() <= 5,
        "re-searched": iface.layout_version >= 1,
    }
    assert everywhere(comm, all(checks.values())), (checks, rows)
    polygon, _ = turn_hub(comm, 1, facets=1)
    assert everywhere(comm, polygon[:, 1].min() < 0.5 and polygon[:, 2].max() > 1.5), polygon


@pytest.mark.parametrize("degree", [1, 2])
def test_nonmatching_patch_test_in_3d(comm, degree):
    """Tetrahedra meshed 3 x 3 under 2 x 2 across the interface (triangles on triangles cut
    into polygons): the pressure is transmitted uniformly."""
    dom = tagged_boxes(comm, n_base=(3, 3, 1), n_block=(2, 2, 1), split_x=0.5)
    p = 100.0
    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e5, mu_c=0.3),
        {"base": STEEL, "block": STEEL},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
        [Dirichlet("bottom", 0.0, 2), Dirichlet("x0", 0.0, 0), Dirichlet("y0", 0.0, 1)],
        [Pressure("top", p, amplitude="press")],
        interfaces=[
            Interface(
                "contact", "base", "block", kinematics="finite_sliding", intended_compliance=True
            )
        ],
        settings=ProblemSettings(degree=degree),
    )
    iface = problem.interfaces["contact"]
    with FrictionSolver(problem, linear="lu") as solver:
        records = LoadStepper(solver, 1.0).run()
    tr = gather(comm, iface.last.traction)
    checks = {
        "f_n": np.abs(tr[:, 2] / p - 1.0).max() < 1e-6,
        "f_t": np.abs(tr[:, :2]).max() < 1e-6 * p,
        "newton": max(r.iterations for r in records) <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, tr)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_3d_block_slides_diagonally_like_a_material_point(comm):
    """3-D: a block slid along (1, 0.5) over a rigid plate (6 x 6 facets under 2 x 2), across
    the partition boundary: the mean traction is along the slip and equals the material point's
    on the same path (the two tangential components and the frame of the plate)."""
    law, p = preset("sec7"), 300.0
    e = np.array([1.0, 0.5])
    dom = tagged_boxes(
        comm, n_base=(6, 6, 1), n_block=(2, 2, 1), base_size=3.0, block_at=0.5, split_x=1.5
    )
    program = LoadingProgram(
        [0.0, 0.1, 0.2, 1.0], {"press": [0, 1, 1, 1], "slide": [0, 0, 0.1, 1.0]}
    )
    problem = InterfaceProblem(
        dom,
        law,
        {"base": STEEL, "block": STEEL},
        program,
        [
            Dirichlet("base", (0.0, 0.0, 0.0)),
            Dirichlet("block", e[0], 0, amplitude="slide"),
            Dirichlet("block", e[1], 1, amplitude="slide"),
        ],
        [Pressure("top", p, amplitude="press")],
        interfaces=[
            Interface(
                "contact",
                "base",
                "block",
                kinematics="finite_sliding",
                search_radius=1.5,
                intended_compliance=True,
            )
        ],
    )
    iface = problem.interfaces["contact"]
    rows = []

    def on_step(rec):
        w = iface.law_points.weights
        tg = np.einsum("mji,mj->mi", iface.geometry.Q, iface.last.traction)  # on the plate, global
        sums = comm.allreduce(
            np.concatenate([w @ tg, [w @ iface.law_points.last_gap[:, 2], w.sum()]])
        )
        s = program.amplitude("slide", rec.t)
        rows.append((rec.dt, rec.iterations, *(sums[:3] / sums[4]), sums[3] / sums[4], s))

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.02, control=StepControl(dt_max=0.02), on_step=on_step).run()
    rows = np.array(rows)
    state, ref = law.initial_state(1, 2), []
    for dt, _, _, _, _, gn, s in rows:
        res = law.return_map(np.array([[s * np.linalg.norm(e), 0.0, gn]]), state, dt)
        state = res.state
        ref.append(res.traction[0])
    ref = np.array(ref)
    u = e / np.linalg.norm(e)
    along = rows[:, 2:4] @ u
    across = rows[:, 2:4] @ np.array([-u[1], u[0]])
    peak = np.abs(ref[:, 0]).max()
    checks = {
        "along": np.abs(along - ref[:, 0]).max() < 1e-3 * peak,
        "across": np.abs(across).max() < 1e-9 * peak,
        "f_n": abs(rows[-1, 4] + p) < 1e-9 * p,
        "newton": rows[:, 1].max() <= 5,
    }
    assert everywhere(comm, all(checks.values())), (checks, along - ref[:, 0])


def apart_builder(h_base: float = 0.3, h_block: float = 0.2):
    """A block on a wider base, two gmsh surfaces meshed independently (not fragmented): the
    interface group holds the base's top and the block's bottom, with 10 and 5 facets."""
    import gmsh

    gmsh.model.add("apart")
    occ = gmsh.model.occ
    base = occ.addRectangle(0.0, -1.0, 0.0, 3.0, 1.0)
    block = occ.addRectangle(1.0, 0.0, 0.0, 1.0, 1.0)
    occ.synchronize()
    curves: dict[str, list[int]] = {"contact": [], "bottom": [], "top": []}
    for _, t in gmsh.model.getEntities(1):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, t)
        if abs(y1 - y0) > 1e-5:
            continue
        y = 0.5 * (y0 + y1)
        key = "contact" if abs(y) < 1e-5 else "bottom" if y < -0.5 else "top"
        curves[key].append(t)
        wide = x1 - x0 > 2.0  # the base's
        n = round((x1 - x0) / (h_base if wide else h_block))
        gmsh.model.mesh.setTransfiniteCurve(t, n + 1)
    gmsh.model.addPhysicalGroup(2, [base], name="base")
    gmsh.model.addPhysicalGroup(2, [block], name="block")
    for name, ents in curves.items():
        gmsh.model.addPhysicalGroup(1, ents, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h_base)
    gmsh.model.mesh.generate(2)
    return types.SimpleNamespace(gdim=2)


def test_the_reader_takes_sides_meshed_apart_for_finite_sliding(comm):
    from subfric_dolfinx import meshing

    small = {"contact": ("base", "block")}
    with raised_on_every_rank(meshing.InterfaceMeshError, "need the interface's kinematics"):
        meshing.create_interface_mesh(apart_builder, comm, interfaces=small)
    finite = {"contact": {"primary": "base", "secondary": "block", "kinematics": "finite_sliding"}}
    dom, _ = meshing.create_interface_mesh(apart_builder, comm, interfaces=finite)
    assert dom.interfaces["contact"].kinematics == "finite_sliding"
    p = 50.0
    problem = InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e5, alpha_n=1e7, mu_c=0.3),  # as stiff as ten times E*/h
        {"base": STEEL, "block": STEEL},
        LoadingProgram([0.0, 1.0], {"press": [0, 1]}),
        [Dirichlet("bottom", (0.0, 0.0))],
        [Pressure("top", p, amplitude="press")],
    )
    iface = problem.interfaces["contact"]
    assert isinstance(iface, SlidingInterface)  # the mesh's kinematics
    sizes = comm.allreduce(np.array([iface.sides.primary.size, iface.sides.secondary.size]))
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 1.0).run()
    Fn = comm.allreduce(float(iface.law_points.weights @ iface.last.traction[:, 1]))
    # the global force: the points' frames follow the base's deformed surface, whose slope
    # tilts the local components (F_n is then p to 1e-5)
    Fy = comm.allreduce(
        float(
            iface.law_points.weights
            @ np.einsum("mj,mj->m", iface.geometry.Q[:, :, 1], iface.last.traction)
        )
    )
    summary = interface_summary(problem)  # the history's columns
    checks = {
        "summary": abs(summary["F_n"] - Fn) < 1e-12 * p and summary["area"] == pytest.approx(1.0),
        "non-matching": sizes[0] != sizes[1],
        "load carried": abs(abs(Fy) - p) < 1e-9 * p and abs(Fn - p) < 1e-5 * p,
        "reaction": abs(problem.reactions["bottom"][1] - p) < 1e-9 * p,
    }
    assert everywhere(comm, all(checks.values())), (checks, sizes, Fn, Fy)
