"""Finite sliding past the end of the primary surface: no force lost (issue 35, item 3).

A block pressed on a base and slid past the base's end, 2-D and 3-D, meshed apart: the secondary
(block) facets overhang the primary (base) surface. The forces the interface puts on the two
bodies are equal and opposite (to 1e-10 of the load) at every step, before, while and after the
block's facets pass the base's edge; so the supports carry the applied load exactly, and Newton
converges through the moment the edge passes. The interface warns that its contact leaves its
primary surface (:class:`~subfric_dolfinx.logs.OverhangWarning`, naming it).
"""

import numpy as np
import pytest

from subfric_dolfinx.constitutive import CoulombLaw
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    StepControl,
)
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import OverhangWarning
from tests.contact_meshes import tagged_blocks, tagged_boxes
from tests.helpers import everywhere

pytestmark = pytest.mark.three_ranks

STEEL = Material(2.1e5, 0.3)
OVERHANG = "the block is slid past the base's end on purpose"


def side_sums(problem, iface):
    """The interface's forces summed over the primary's and the secondary's owned nodes."""
    comm, gdim = problem.comm, problem.V.mesh.geometry.dim
    n_own = problem.V.dofmap.index_map.size_local
    f = problem.interface_force.reshape(-1, gdim)
    out = []
    for side in (iface.sides.primary, iface.sides.secondary):
        nodes = np.unique(side.nodes)
        out.append(comm.allreduce(f[nodes[nodes < n_own]].sum(axis=0)))
    return out


def run(problem, dt, load):
    """Run the program; per step: iterations, dt, action + reaction, support balance."""
    iface = problem.interfaces["contact"]
    gdim = problem.V.mesh.geometry.dim
    rows = []

    def on_step(rec):
        primary, secondary = side_sums(problem, iface)
        r = problem.reactions
        support = r["bottom"] + r["block"]
        rows.append(
            (
                rec.t,
                rec.dt,
                rec.iterations,
                np.abs(primary + secondary).max() / load,
                abs(abs(r["bottom"][gdim - 1]) - load) / load,
                np.abs(support[: gdim - 1]).max() / load,
                abs(primary[gdim - 1]) / load,
            )
        )

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, dt, control=StepControl(dt_max=dt), on_step=on_step).run()
    return np.array(rows)


def pressed_and_slid(dom, program, dirichlet, p):
    """The block (Coulomb, a stiff penalty) pressed by ``p`` on its top and slid by ``dirichlet``
    on its base, their interface finite sliding."""
    return InterfaceProblem(
        dom,
        CoulombLaw(alpha_t=1e6, alpha_n=1e6, mu_c=0.3),
        {"base": STEEL, "block": STEEL},
        program,
        dirichlet,
        [Pressure("top", p, amplitude="press")],
        interfaces=[
            Interface(
                "contact",
                "base",
                "block",
                kinematics="finite_sliding",
                search_radius=0.05,
                intended_compliance=True,
            )
        ],
    )


def assert_no_force_lost(problem, p, t_end):
    """Steps of 0.1, each: action = reaction, supports = load and the interface carries it (1e-10
    of the load), no cut step, Newton at most 5; the run reaches ``t_end``. On every rank."""
    rows = run(problem, 0.1, p * 1.0)
    pressed = rows[:, 0] > 0.1 - 1e-12
    checks = {
        "action = reaction": rows[:, 3].max() < 1e-10,
        "support = load": rows[pressed, 4].max() < 1e-10,
        "horizontal balance": rows[:, 5].max() < 1e-10,
        "interface carries the load": np.abs(rows[pressed, 6] - 1.0).max() < 1e-10,
        "no cut step": np.allclose(rows[:, 1], 0.1),
        "newton": rows[:, 2].max() <= 5,
        "slid": abs(rows[-1, 0] - t_end) < 1e-12,
    }
    assert everywhere(problem.comm, all(checks.values())), (checks, rows)


@pytest.mark.leaves_validity(OverhangWarning, reason=OVERHANG)
def test_block_slid_past_the_end_of_its_base_loses_no_force(comm):
    """2-D: a block of width 1 (4 facets) on a base of length 2 (12 facets), pressed, then slid
    0.9 in steps of 0.075 (not whole facets of either side): at the end 0.4 of it overhangs."""
    p, slide = 100.0, 0.9
    dom = tagged_blocks(
        comm,
        base=(0.0, 2.0, -1.0, 0.0),
        block=(0.5, 1.5, 0.0, 1.0),
        n_base=(12, 2),
        n_block=(4, 2),
        split_x=1.0,
    )
    program = LoadingProgram([0.0, 0.1, 1.3], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    dirichlet = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("block", slide, 0, amplitude="slide")]
    problem = pressed_and_slid(dom, program, dirichlet, p)
    assert_no_force_lost(problem, p, t_end=1.3)


@pytest.mark.leaves_validity(OverhangWarning, reason=OVERHANG)
def test_3d_block_slid_past_the_edge_of_its_plate_loses_no_force(comm):
    """3-D: a unit block (2 x 2 squares of tetrahedra) on a plate of 1.5 x 1.5 (4 x 4),
    slid 0.6 along x in steps of 0.1: at the end 0.35 of it overhangs the plate's edge."""
    p, slide = 100.0, 0.6
    dom = tagged_boxes(
        comm, n_base=(4, 4, 1), n_block=(2, 2, 1), base_size=1.5, block_at=0.25, split_x=0.75
    )
    program = LoadingProgram([0.0, 0.1, 0.7], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    dirichlet = [
        Dirichlet("bottom", (0.0, 0.0, 0.0)),
        Dirichlet("block", slide, 0, amplitude="slide"),
        Dirichlet("block", 0.0, 1),
    ]
    problem = pressed_and_slid(dom, program, dirichlet, p)
    assert_no_force_lost(problem, p, t_end=0.7)
