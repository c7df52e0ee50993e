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
"""# Stick-slip: a block pulled through a soft spring, with inertia, against the spring-slider

The law's softening from static to kinetic friction and its recovery at rest make steady
sliding unstable under a soft drive: the block sticks while the spring loads it, slips in a
fast event when the static friction is reached, and sticks again. This demo computes that with
the bodies' inertia (`ProblemSettings(dynamics=Dynamics(...))`, see
[dynamics](../reference/dynamics.md)): a stiff block, 10 mm long and 0.1 mm high, of mass
1 tonne per mm² of interface, pressed at 300 MPa on a fixed base and pulled at its left end
through a spring of 50 MPa/mm per unit interface area whose far end moves at a constant
velocity `V` (0.3 mm/s by default). The interface follows the stick-slip law of the
material-point checks (`alpha_t = alpha_n = 5000` MPa/mm, `mu_s = 500`, `mu_k = 300` MPa,
`kappa = 20` /mm, `xi = 2` /s, `u_tilde = 50` /mm).

The same block as one material point is the driver's spring-slider (`driver.run_slider`: the
mass, the spring, the driving velocity, the same law). The FE block slips in the slider's
cycles, event by event, from the same rested start: the period and the stress drop (the
friction's fall in a slip event) of the last full cycle are the slider's within a percent or
two (the first cycles are transient; tens of mm of pull are needed for the limit cycle). Printed on
rank 0: both, the last full cycle of each; written: the FE history and a figure of the mean
friction traction against time, FE and slider overlaid.

    mpirun -n 2 python3 demos/stick_slip.py [--velocity 0.3] [--slide 2.4] [--out DIR]
"""

# %%
import argparse
from pathlib import Path

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import SubloadingLaw
from subfric_dolfinx.driver import SliderCase, run_slider
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
    Spring,
    StepControl,
)
from subfric_dolfinx.fem.dynamics import Dynamics
from subfric_dolfinx.io import HistoryCSV, collective
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import cli

# %% [markdown]
# ## The block, the spring and the law
#
# The block is stiff (E = 1e8 MPa) and flat, so that it moves nearly as one mass: its tilting
# under the spring's pull changes the contact pressure by a fraction of a percent. Its density
# gives the mass per unit interface area, `MASS / HEIGHT`. The spring acts on the block's left
# end (a `Spring` load: stiffness per unit area of that end, its far end moved by the program's
# channel `drive`), so its stiffness there is `K WIDTH / HEIGHT`. The base is held.

# %%
WIDTH, HEIGHT = 10.0, 0.1  # mm, the block's (and the base's) length and height
K = 50.0  # MPa/mm, the spring's stiffness per unit interface area
MASS = 1.0  # tonne/mm^2, the block's mass per unit interface area
F_N = 300.0  # MPa, the pressure on the block's top
STICK_SLIP_LAW = {
    "alpha_t": 5000.0,  # MPa/mm
    "alpha_n": 5000.0,  # MPa/mm
    "mu_s": 500.0,  # MPa
    "mu_k": 300.0,  # MPa
    "kappa": 20.0,  # 1/mm
    "xi": 2.0,  # 1/s
    "u_tilde": 50.0,  # 1/mm
    "c_n": 2e-4,  # 1/MPa
}
CONTACT = {"contact": {"primary": "base", "secondary": "block"}}


def spring_period() -> float:
    """``2 pi sqrt(MASS / K)``: the block's period on the spring alone (s)."""
    return float(2.0 * np.pi * np.sqrt(MASS / K))


def write_mesh(path: Path, n: int, comm: MPI.Comm) -> None:
    """The base and the block as two ``n`` x 1 quadrilateral grids, meshed apart, by rank 0.

    Their interface nodes face each other (small sliding); collective.
    """

    def build() -> None:  # rank 0
        with meshing.gmsh_session("stick_slip") as gmsh:
            occ = gmsh.model.occ
            base = occ.addRectangle(0.0, -HEIGHT, 0.0, WIDTH, HEIGHT)
            block = occ.addRectangle(0.0, 0.0, 0.0, WIDTH, HEIGHT)
            occ.synchronize()
            groups: dict[str, list[int]] = {"contact": [], "bottom": [], "top": []}
            groups["block_left"] = []
            for _, c in gmsh.model.getEntities(1):
                x0, y0, _, _, y1, _ = gmsh.model.getBoundingBox(1, c)
                horizontal = abs(y1 - y0) < 1e-6
                gmsh.model.mesh.setTransfiniteCurve(c, n + 1 if horizontal else 2)
                if horizontal:
                    y = 0.5 * (y0 + y1)
                    key = "contact" if abs(y) < 1e-6 else "bottom" if y < 0 else "top"
                    groups[key].append(c)
                elif abs(x0) < 1e-6 and y0 > -1e-6:
                    groups["block_left"].append(c)
            for s in (base, block):
                gmsh.model.mesh.setTransfiniteSurface(s)
                gmsh.model.mesh.setRecombine(2, s)
            gmsh.model.addPhysicalGroup(2, [base], name="base")
            gmsh.model.addPhysicalGroup(2, [block], name="block")
            for name, curves in groups.items():
                gmsh.model.addPhysicalGroup(1, curves, name=name)
            gmsh.model.mesh.generate(2)
            path.parent.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(path))

    collective(comm, build, f"building the mesh {str(path)!r}", error=RuntimeError)


# %% [markdown]
# ## The FE run
#
# The pressure is there from the start: the interface starts with the overlap `F_N / alpha_n`
# (`initial_gap`), so the normal direction starts in equilibrium and only the spring sets the
# block moving. The time integrator is Newmark's average acceleration (`rho_inf = 1`, no
# numerical damping, which would shift where steady sliding turns unstable) with the
# interfaces' forces at the step's middle (`interface_forces="mixed"`, the default); the step is
# a fixed fraction of the spring's period (`--steps` steps a period), small enough for the slip
# events. After each step the block's mean velocity (its top's nodes) and the interface's mean
# friction traction `F_t1 / area` are kept.


# %%
def owned_coordinates(problem: InterfaceProblem) -> np.ndarray:
    """Coordinates of the owned dofs, ``(n_owned, 3)``, unrolled as the owned values."""
    bs = problem.V.dofmap.bs
    x = problem.V.tabulate_dof_coordinates()[: problem.layout.n_owned // bs]
    return np.repeat(x, bs, axis=0)


def run_fe(velocity: float, t_end: float, steps: int, n: int, outdir: Path, comm) -> dict:
    """The block pulled for ``t_end`` s; its history (time, block velocity, mean ``f_t``)."""
    mesh = outdir / "stick_slip.msh"
    write_mesh(mesh, n, comm)
    domain = meshing.read_interface_mesh(mesh, comm, 2, interfaces=CONTACT)
    law = SubloadingLaw(**STICK_SLIP_LAW)
    spring = Spring(
        "block_left", stiffness=(K * WIDTH / HEIGHT, 0.0), u0=(1.0, 0.0), amplitude="drive"
    )
    contact = Interface(
        "contact",
        "base",
        "block",
        initial_gap=-F_N / law.alpha_n,
        intended_compliance=True,  # the slider's alpha_n: the normal compliance is the model's
    )
    problem = InterfaceProblem(
        domain,
        law,
        {"base": Material(1e8, 0.0), "block": Material(1e8, 0.0)},
        LoadingProgram([0.0, t_end], {"drive": [0.0, velocity * t_end]}),
        [Dirichlet("base", (0.0, 0.0))],
        [Pressure("top", F_N), spring],
        interfaces=[contact],
        settings=ProblemSettings(dynamics=Dynamics({"base": 1.0, "block": MASS / HEIGHT})),
    )
    history = HistoryCSV(outdir / "history.csv", problem)
    rows: list[tuple[float, float, float]] = []
    with problem:
        x = owned_coordinates(problem)
        top = (np.arange(x.shape[0]) % 2 == 0) & np.isclose(x[:, 1], HEIGHT)
        count = comm.allreduce(int(top.sum()))

        def on_step(rec) -> None:
            history.write(rec)
            v = comm.allreduce(float(problem.dynamics.velocity[top].sum())) / count
            row = history.rows[-1]
            rows.append((rec.t, v, abs(row["F_t1"]) / row["area"]))

        dt = spring_period() / steps
        try:
            with FrictionSolver(problem, "stick_", linear="lu") as solver:
                LoadStepper(solver, dt, control=StepControl(dt_max=dt), on_step=on_step).run()
        finally:
            history.close()
    t, v, f = (np.array(c) for c in zip(*rows, strict=True))
    return {"t": t, "v": v, "f_t": f}


# %% [markdown]
# ## The spring-slider
#
# The driver's 1-DOF dynamic control with the same law, mass, spring, pressure and driving
# velocity: the block as one material point (its own adaptive steps, the same return map).


# %%
def run_point(velocity: float, t_end: float) -> dict:
    """The spring-slider's history (time, velocity, ``f_t``) over ``t_end`` s."""
    law = SubloadingLaw(**STICK_SLIP_LAW)
    case = SliderCase(law, mass=MASS, stiffness=K, velocity=velocity, f_n=F_N, t_end=t_end)
    s = run_slider(case).samples
    return {"t": s["t"], "v": s["v"], "f_t": np.abs(s["f_t"])}


# %% [markdown]
# ## The cycles
#
# A cycle runs from one slip event's velocity peak to the next (peaks above twice the driving
# velocity and above half the run's highest: at a slow drive the block rings after an event, its
# smaller velocity peaks are not events); its period is their distance in time, its stress drop the
# range of the friction traction over it. The last full cycle of each run is compared: the first
# ones, from a rested contact whose static friction is fully recovered, are longer.


# %%
def last_cycle(run: dict, velocity: float) -> tuple[float, float] | None:
    """Period (s) and stress drop (MPa) of the last full cycle; None without two slip events."""
    t, v, f = run["t"], run["v"], run["f_t"]
    i = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] > 2 * velocity)) + 1
    if i.size:  # the slip events' peaks, not the ringing after an event (its smaller peaks)
        i = i[v[i] >= 0.5 * v[i].max()]
    if i.size < 2:
        return None
    a, b = i[-2], i[-1]
    return float(t[b] - t[a]), float(f[a : b + 1].max() - f[a : b + 1].min())


def report(fe: dict, point: dict, velocity: float) -> dict:
    """Print the FE block's last cycle against the slider's (rank 0)."""
    out: dict = {"velocity": velocity, "steps": int(fe["t"].size)}
    got, ref = last_cycle(fe, velocity), last_cycle(point, velocity)
    print(
        f"V = {velocity:g} mm/s, {fe['t'][-1]:g} s: FE {out['steps']} steps, "
        f"friction f_t from {fe['f_t'].min():.2f} to {fe['f_t'].max():.2f} MPa"
    )
    if got is None or ref is None:
        print("no two slip events in the FE run or the slider's: steady sliding at this drive")
        return out
    out.update(period=got[0], drop=got[1], period_slider=ref[0], drop_slider=ref[1])
    for what, unit, a, b in (
        ("period", "s", got[0], ref[0]),
        ("stress drop", "MPa", got[1], ref[1]),
    ):
        print(
            f"{what}: FE {a:.4f} {unit}, spring-slider {b:.4f} {unit} ({100 * (a / b - 1):+.2f} %)"
        )
    return out


def figure(fe: dict, point: dict, velocity: float, outdir: Path) -> Path:
    """Mean friction traction against time, FE and slider overlaid."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(point["t"], point["f_t"], "-", lw=2.5, alpha=0.5, label="spring-slider")
    ax.plot(fe["t"], fe["f_t"], "-", lw=1, label="FE block (mean over the interface)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("friction traction $|f_t|$ (MPa)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Stick-slip at V = {velocity:g} mm/s, spring {K:g} MPa/mm, {F_N:g} MPa")
    fig.tight_layout()
    path = outdir / "stick_slip.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# %% [markdown]
# ## The command line


# %%
def positive(text: str) -> float:
    """A number > 0 from the command line."""
    x = float(text)
    if not x > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return x


def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--velocity", type=positive, default=0.3, help="driving velocity V (mm/s)")
    ap.add_argument(
        "--slide", type=positive, default=2.4, help="the spring's far end's travel (mm)"
    )
    ap.add_argument("--steps", type=int, default=200, help="FE steps per spring period")
    ap.add_argument("--n", type=int, default=4, help="elements along the interface")
    ap.add_argument("--out", default="demos/output/stick_slip", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    t_end = args.slide / args.velocity
    fe = run_fe(args.velocity, t_end, args.steps, args.n, outdir, comm)
    out: dict = {"fe": fe}
    if comm.rank == 0:
        point = run_point(args.velocity, t_end)
        out["point"] = point
        out["report"] = report(fe, point, args.velocity)
        if not args.no_figures:
            print(f"wrote {figure(fe, point, args.velocity, outdir)}")
    return out


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
