# ---
# jupyter:
#   jupytext:
#     cell_markers: '"""'
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.16.4
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
"""# Two bodies from the library's pieces: a block pushed sideways by its flank

The other FE demos describe their run as a *scene* (a JSON-like dictionary) and hand it to
`run_scene`. This one builds the same kind of run from the library's own pieces, one at a time,
as a DOLFINx demo does: the mesh, the friction law, the loading program, the problem, the
nonlinear solver, the load stepping and the output writers. Each piece is a public class or
function of `subfric_dolfinx`; the scene runner (`subfric_dolfinx.scenes`) does nothing else.

The run: an aluminium block on a steel base is pressed with 200 MPa on its top, then pushed
sideways by a prescribed displacement of its **left flank** (not of its top, as in the main
demo), held for 20 s, and pushed further: 1 mm in all, the block's width. So the interface is
**finite-sliding** (its points are paired with the base again as the block moves) and the base
is long enough for the block to stay on it. Pushed at the flank, the block tilts a little: the
contact pressure grows at the leading edge and drops at the trailing one, so the interface
slides first where the pressure is low (the saturation `|f_t| <= g(f_n) mu` is reached there
first).

| time (s) | what happens                                         |
|----------|------------------------------------------------------|
| 0 - 1    | the pressure on the top rises to 200 MPa             |
| 1 - 2    | the left flank is pushed 0.5 mm to the right         |
| 2 - 22   | held: the static friction recovers                   |
| 22 - 23  | pushed to 1 mm: a new peak                           |

Run it on one or two ranks:

    mpirun -n 2 python3 demos/two_bodies_api.py [--n 16] [--fields xdmf|vtx|none] [--out DIR]

It writes the mesh (`two_bodies_api.msh`), `history.csv`, the displacement and the per-facet
interface fields for ParaView (`fields/`), and the interface state at every quadrature point as
a point cloud (`fields/interface_points.xdmf`). PETSc options apply under the prefix `api_`.
"""

# %%
import argparse
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import SubloadingLaw
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    StepControl,
    format_breakdown,
    timing_breakdown,
)
from subfric_dolfinx.io import (
    FieldWriter,
    HistoryCSV,
    InterfacePointsXDMF,
    collective,
    gather_interface,
)
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import cli

PRESSURE = 200.0  # MPa
PUSH = 1.0  # mm, the flank's final displacement
HOLD = 20.0  # s
TIMES = [0.0, 1.0, 2.0, 2.0 + HOLD, 3.0 + HOLD]  # s
FIELD_TIMES = TIMES[1:]  # s
ALPHA = 1e5  # MPa/mm, a stiff interface (the paper's 500 MPa/mm is a soft layer)

# %% [markdown]
# ## 1. The mesh
#
# Two rectangles meshed by gmsh on rank 0, each with its own nodes (not fragmented: the bodies
# may slide along each other), written to a `.msh` file with its physical groups: the bodies
# `primary` (the base) and `secondary` (the block), the `interface` (the base's whole top and the
# block's bottom: the block finds the base wherever it slides), and the boundary groups `bottom`,
# `top` and `secondary_left`. `meshing.read_interface_mesh` reads it into DOLFINx and distributes
# it; `interfaces=` names the interface's two bodies and its kind (finite sliding, whose sides
# need not match). The result, a `meshing.InterfaceMesh`, carries the DOLFINx mesh, its cell
# and facet tags and the names of the groups. (For an interface that slides a few of its
# elements at most, `meshing.create_interface_mesh(meshing.build_block_on_base, comm, ...)`
# builds and reads a mesh whose interface nodes are duplicated, in one call.)


# %%
BASE = 3.0  # mm, the base's length: the block (from x = 0.5 mm) stays on it when pushed 1 mm
CONTACT = {
    "interface": {"primary": "primary", "secondary": "secondary", "kinematics": "finite_sliding"}
}


def write_mesh(path: Path, n: int, comm: MPI.Comm) -> None:
    """The block on the base, meshed apart (triangles of ``1/n`` mm), written by rank 0.

    The block is 1 x 0.5 mm from x = 0.5 mm, the base 3 x 0.5 mm; collective.
    """

    def build() -> None:  # rank 0
        with meshing.gmsh_session("two_bodies_api") as gmsh:
            occ = gmsh.model.occ
            base = occ.addRectangle(0.0, 0.0, 0.0, BASE, 0.5)
            block = occ.addRectangle(0.5, 0.5, 0.0, 1.0, 0.5)
            occ.synchronize()
            groups: dict[str, list[int]] = {g: [] for g in ("interface", "bottom", "top")}
            groups["secondary_left"] = []
            for _, c in gmsh.model.getEntities(1):
                x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, c)
                if abs(y1 - y0) < 1e-6:  # horizontal: the base's bottom, the contact, the top
                    key = {0: "bottom", 1: "interface", 2: "top"}[round(2 * y0)]
                    groups[key].append(c)
                elif abs(x1 - x0) < 1e-6 and abs(x0 - 0.5) < 1e-6 and y0 > 0.5 - 1e-6:
                    groups["secondary_left"].append(c)
            gmsh.model.addPhysicalGroup(2, [base], name="primary")
            gmsh.model.addPhysicalGroup(2, [block], name="secondary")
            for name, curves in groups.items():
                gmsh.model.addPhysicalGroup(1, curves, name=name)
            gmsh.option.setNumber("Mesh.MeshSizeMax", 1.0 / n)
            gmsh.model.mesh.generate(2)
            path.parent.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(path))

    collective(comm, build, f"building the mesh {str(path)!r}", error=RuntimeError)


def build_mesh(comm: MPI.Comm, n: int, outdir: Path) -> meshing.InterfaceMesh:
    """The two bodies, ``n`` elements along the block's bottom, read into DOLFINx."""
    path = outdir / "two_bodies_api.msh"
    write_mesh(path, n, comm)
    return meshing.read_interface_mesh(path, comm, 2, interfaces=CONTACT)


# %% [markdown]
# ## 2. The friction law and the loading program
#
# A friction law is a frozen dataclass of its parameters: here the subloading-friction law with
# the paper's Sec. 7 values in the normalised reading (the numbers of
# `constitutive.preset("sec7")`, written out) but a stiff interface: with the paper's penalty
# of 500 MPa/mm the interface is a soft layer under which the pressure is uniform, and the block
# would sink 0.4 mm into it. The law validates its parameters when it is built (a wrong value
# is an error naming it) and declares the internal variables it needs (`up`, `mu`, `r`, ...):
# the interface stores them in DOLFINx Quadrature spaces.
#
# The loading program gives named amplitude channels, linear between breakpoints. Load steps
# end on every breakpoint, so the start of the hold and the reversal of a load are never
# stepped over.


# %%
def friction_law() -> SubloadingLaw:
    """The paper's Sec. 7 set (A6111-T4 on tool steel), normalised reading, stiff penalties."""
    return SubloadingLaw(
        alpha_t=ALPHA,  # tangential penalty, MPa/mm
        alpha_n=ALPHA,  # normal penalty, MPa/mm
        mu_s=500.0,  # static value of the hardening function mu, MPa
        mu_k=63.0,  # kinetic value, MPa
        kappa=98.0 / 63.0,  # softening per unit slip, 1/mm
        xi=11.0 / 500.0,  # recovery rate at rest, 1/s
        u_tilde=15.0,  # approach of the subloading surface to the yield surface, 1/mm
        c_n=2e-4,  # saturation: g(f_n) = 1 - exp(-c_n f_n), 1/MPa
    )


def loading_program() -> LoadingProgram:
    """Press, push, hold, push again (channels ``press`` and ``push``, amplitudes 0 .. 1)."""
    return LoadingProgram(TIMES, {"press": [0, 1, 1, 1, 1], "push": [0, 0, 0.5, 0.5, 1.0]})


# %% [markdown]
# ## 3. The problem
#
# `InterfaceProblem` puts it together: two linear-elastic bodies (`Material(E, nu)` per body),
# the interface elements between them (paired across ranks by coordinates), the prescribed
# displacements (`Dirichlet(group, value, component, amplitude)`) and loads
# (`Pressure(group, value, amplitude)`, `Traction`), each scaled by a channel of the program.
# It assembles the residual and the consistent Jacobian (the law's tangent at every interface
# point) into PETSc objects whose sparsity includes every cross-interface coupling.
#
# `Interface(group, ...)` gives an interface its own settings: here `kinematics=
# "finite_sliding"` (the block's points are paired with the base in the current configuration
# at every Newton iteration; the default, `"small_sliding"`, keeps the node pairs of the
# reference geometry, valid while the block slides a few interface elements) and
# `intended_compliance=True`: the normal penalty of 1e5 MPa/mm is as compliant as 0.6 mm of the
# bodies, a choice of the model (see the law above), so the run's validity check judges how far
# the bodies overlap (a `PenetrationWarning` beyond a tenth of an element), not that compliance.


# %%
def build_problem(domain: meshing.InterfaceMesh) -> InterfaceProblem:
    """The base held at its bottom, the block pressed on its top and pushed at its flank."""
    materials = {
        "primary": Material(E=2.1e5, nu=0.3),  # tool steel (the base)
        "secondary": Material(E=7.0e4, nu=0.33),  # aluminium (the block)
    }
    dirichlet = [
        Dirichlet("bottom", (0.0, 0.0)),
        Dirichlet("secondary_left", PUSH, component=0, amplitude="push"),
    ]
    loads = [Pressure("top", PRESSURE, amplitude="press")]
    contact = Interface("interface", kinematics="finite_sliding", intended_compliance=True)
    return InterfaceProblem(
        domain,
        friction_law(),
        materials,
        loading_program(),
        dirichlet,
        loads,
        interfaces=[contact],
    )


# %% [markdown]
# ## 4. Solver, load stepping and output
#
# `FrictionSolver` is a PETSc SNES (Newton with a direct solver by default) under an options
# prefix: `-api_snes_monitor` on the command line applies to it, and the options it sets itself
# are removed from PETSc's database when it is destroyed (use it as a context manager).
#
# `LoadStepper` advances the solver through the program: steps end on breakpoints and on the
# `stops` asked for, a step that fails is retried with a line search and then cut, easy steps
# let the step grow up to `dt_max`, and the holds of the program are crossed in steps of
# `hold_dt` (nothing moves; the return map integrates the recovery exactly). After every
# converged step it calls `on_step` with a `StepRecord` (time, Newton iterations, status
# counts): that is where the outputs are written.
#
# * `HistoryCSV`: one row per step: the interface resultants and area-weighted means, the status
#   fractions, the reaction of every Dirichlet group;
# * `FieldWriter`: the displacement and the interface fields averaged per facet (VTX or XDMF);
# * `InterfacePointsXDMF`: the interface state at every quadrature point (point cloud);
# * `gather_interface`: the interface values of all ranks in one partition-independent order.
#
# Every call is collective: each rank runs the same lines.


# %%
def run(problem: InterfaceProblem, outdir: Path, dt: float, fields: str) -> dict:
    """Step through the program, writing the outputs; return the history and two profiles."""
    comm = problem.comm
    PETSc.Log.begin()  # PETSc's events: the factorisation and solve times of the breakdown
    history = HistoryCSV(outdir / "history.csv", problem)
    profiles = {}
    writers = []
    if fields != "none":
        writers = [
            FieldWriter(outdir / "fields", problem, fields),
            InterfacePointsXDMF(outdir / "fields" / "interface_points.xdmf", problem),
        ]

    def on_step(rec) -> None:
        history.write(rec)
        if np.any(np.isclose(rec.t, FIELD_TIMES)):
            for w in writers:
                w.write(rec.t)
        if np.any(np.isclose(rec.t, [2.0, TIMES[-1]])):
            el = problem.interface
            nt = el.nt
            tr = el.last.traction
            profiles[round(rec.t, 9)] = gather_interface(
                el, {"f_t": tr[:, :nt], "f_n": tr[:, nt], "mu": el.state.old["mu"]}
            )

    try:
        with FrictionSolver(problem, "api_") as solver:
            stepper = LoadStepper(
                solver, dt, control=StepControl(dt_max=2.5 * dt, hold_dt=5.0), on_step=on_step
            )
            stepper.run(stops=FIELD_TIMES)
            timing = timing_breakdown(problem, solver.event_start)
    finally:
        history.close()
        for w in writers:
            w.close()
    if comm.rank == 0:
        print(format_breakdown(timing, sum(timing.values())))
    return {"history": history.rows, "profiles": profiles, "steps": len(stepper.records)}


# %% [markdown]
# ## 5. What it shows
#
# The mean tangential traction on the interface peaks during the first push and softens, the
# hold recovers part of the static friction (a second peak), and at the end of each push the
# pressure under the leading (right) edge of the block is higher than under the trailing one.
# The default run (66 steps, the hold in 4): the mean tangential traction peaks at 16.1 MPa,
# has softened to 10.4 MPa when the hold starts and peaks again at 12.0 MPa after it; at the end
# of the first push the pressure is 204 MPa under the trailing edge and 223 MPa under the
# leading one.


# %%
def report(result: dict) -> None:
    """Print the peaks and the pressure under the block's edges (rank 0)."""
    h = result["history"]
    t = np.array([r["t"] for r in h])
    ft = np.array([r["F_t1"] / r["area"] for r in h])
    first, second = ft[(t > 1) & (t <= 2)].max(), ft[t > TIMES[3]].max()
    held = ft[np.isclose(t, TIMES[3])][0]
    print(
        f"{result['steps']} steps; mean f_t: first peak {first:.3f} MPa, after the hold "
        f"{held:.3f} MPa, second peak {second:.3f} MPa"
    )
    for time_, p in sorted(result["profiles"].items()):
        fn, mu = p["f_n"], p["mu"]
        print(
            f"t = {time_:g} s: f_n at the trailing edge {fn[0]:.1f} MPa, at the leading edge "
            f"{fn[-1]:.1f} MPa; mu from {mu.min():.1f} to {mu.max():.1f} MPa"
        )


# %% [markdown]
# ## The command line


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements along the interface")
    ap.add_argument("--dt", type=float, default=0.02, help="initial time step in s")
    ap.add_argument(
        "--fields", choices=["xdmf", "vtx", "none"], default="xdmf", help="field output"
    )
    ap.add_argument("--out", default="demos/output/two_bodies_api", help="output directory")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    problem = build_problem(build_mesh(comm, args.n, Path(args.out)))
    result = run(problem, Path(args.out), args.dt, args.fields)
    if comm.rank == 0:
        report(result)
    return result


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
