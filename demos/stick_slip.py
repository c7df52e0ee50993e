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
friction's fall in a slip event) of the last full cycle are the slider's within 1.6 % and 3 % at
the default 200 steps a spring period, 0.3 % and 0.5 % at `--steps 400`: the FE step's error (a
transient's cycles are sensitive to the step; the slider, the reference, takes a fine one).

The slider then carries a material-point study far beyond the FE run's reach: the period and
stress drop of the settled cycles against the driving velocity (mean and scatter over many
cycles, and their change with half the time step), the static friction regained after a hold
(slide-hold-slide) against the law's recovery, and the transition from stick-slip to steady
sliding as the spring stiffens past the critical stiffness of the linear stability analysis
(with a dashpot: undamped, steady sliding of this law is unstable at every stiffness).

Printed on rank 0: the FE block's and the slider's last full cycle, then the study; written:
the FE history, a figure of the mean friction traction against time (FE and slider overlaid)
and a figure of the study.

    mpirun -n 2 python3 demos/stick_slip.py [--velocity 0.3] [--slide 2.4] [--no-study]
"""

# %%
import argparse
from pathlib import Path

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import SubloadingLaw
from subfric_dolfinx.driver import SliderCase, run_slider, steady_sliding, stick_slip_cycles
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
# velocity: the block as one material point (its own adaptive steps, the same return map). It is
# the reference, so its step is fine: 2000 steps a spring period at most and a local error of
# 1e-10 mm (the cycles of a transient are sensitive to the step: at the slider's default, 100
# steps a period, the last cycle of the default run comes out 2.5 % short and its stress drop
# 4.4 % low; at 2000, 4000 it moves by less than 0.03 %). A fraction of a second.

# %%
POINT_STEPS = 2000  # the reference slider's steps a spring period (at most)
POINT_ERROR = 1e-10  # mm, its local error per step


def run_point(velocity: float, t_end: float) -> dict:
    """The spring-slider's history (time, velocity, ``f_t``) over ``t_end`` s."""
    law = SubloadingLaw(**STICK_SLIP_LAW)
    case = SliderCase(
        law,
        mass=MASS,
        stiffness=K,
        velocity=velocity,
        f_n=F_N,
        t_end=t_end,
        dt_max=spring_period() / POINT_STEPS,
        err_tol=POINT_ERROR,
    )
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
# ## The material-point study: driving velocity, hold time, stiffness
#
# The FE run shows a few transient cycles; the behaviour over many cycles and parameters is the
# spring-slider's, which costs tens of microseconds a step (the FE block follows it, cycle by
# cycle, as above). Three studies with the same law, each case an independent run (spread over
# the ranks, gathered on rank 0):
#
# * **Driving velocity**: the demo's slider (undamped, 50 MPa/mm, 1 tonne/mm²) driven long
#   enough for some 24 cycles; the period and the stress drop averaged over the cycles that
#   start after the first third of the run (the settled ones), with their scatter. The cycles
#   do not settle to one limit cycle: after each event the slider rings on the interface's
#   elastic layer (the stick mode, `sqrt((alpha_t + k) / m)` = 71 rad/s) and that ringing,
#   hardly damped while it sticks, sets where the next event starts, so the cycles scatter by a few
#   percent; their mean is what a long run measures, to its standard error. The time step's
#   share: the same mean at half the longest step, at the run's driving velocity, against
#   those standard errors.
# * **Hold-time recovery** (slide-hold-slide, through a stiff spring of `HOLD_STIFFNESS`, a
#   test frame): the contact sliding steadily at `V` stopped (the slider at rest, its spring
#   holding the steady friction) for a hold of `t`, then driven at `V` again. In the hold
#   nothing slips and `mu` recovers as the law says, `mu_s - (mu_s - mu_ss) exp(-xi t)`; the
#   static friction regained is the friction's peak on reloading. It is well below the
#   recovered strength `g mu(t)`: the subloading surface reaches the yield surface only after
#   some slip, which weakens `mu` again (at `kappa (mu - mu_k)` per mm). (Through the soft
#   spring the reload lasts about `1 / xi` itself, and `mu` recovers as much while it reloads
#   as in the hold: the peak then hardly depends on the hold.)
# * **Stiffness**: steady sliding of this law with inertia is unstable at every stiffness
#   without damping (`docs/reference/spring_slider.md`); with a dashpot to the base
#   (`DASHPOT` = 5 MPa s/mm, enough to damp the stick mode between events) it has a critical
#   stiffness `k_c` (`driver.steady_sliding`, the linear stability analysis, checked against
#   the eigenvalues in the tests). Driven from rest at `V` = 0.1 mm/s, the friction's range
#   once settled (the last 10 s of 40) against `k / k_c`: stick-slip below `k_c`, steady
#   sliding above; the amplitude does not shrink to zero as `k` nears `k_c` (the oscillation
#   appears at a finite size, as at a subcritical onset).

# %%
VELOCITIES = (0.03, 0.1, 0.3, 1.0)  # mm/s, the sweep's driving velocities
HOLDS = (0.01, 0.1, 0.3, 1.0, 3.0, 10.0)  # s, the holds of slide-hold-slide
HOLD_VELOCITY = 0.1  # mm/s, the slide's velocity around the holds
HOLD_STIFFNESS = 1000.0  # MPa/mm, the slide-hold-slide's spring (a stiff test frame)
DASHPOT = 5.0  # MPa s/mm, the stiffness study's dashpot to the base
STIFFNESS_RATIOS = (0.25, 0.5, 0.75, 0.9, 0.97, 1.03, 1.1, 1.5)  # k / k_c
CYCLES = 24  # cycles a sweep run lasts (about)
SWEEP_STEPS = 200  # the sweep's steps a spring period (at most); the check: twice as many


def law_() -> SubloadingLaw:
    """The stick-slip law."""
    return SubloadingLaw(**STICK_SLIP_LAW)


def sweep_case(velocity: float, refine: int = 1) -> dict:
    """Settled cycles of the demo's slider at ``velocity``: their period and stress drop.

    Mean and scatter over the cycles starting after a third of the run; ``refine`` divides the
    longest step.
    """
    period = max(1.4, 0.4 / velocity)  # about the cycle's period (s)
    t_end = CYCLES * period
    dt_max = spring_period() / (SWEEP_STEPS * refine)
    case = SliderCase(law_(), MASS, K, velocity, F_N, t_end, dt_max=dt_max)
    s = run_slider(case).samples
    w = s["t"] > t_end / 4.0  # (the first event, from a fully rested contact, is the largest)
    start, T, drop = stick_slip_cycles(s["t"][w], s["v"][w], s["f_t"][w], velocity)
    keep = start > t_end / 3.0
    out = {"velocity": velocity, "cycles": int(keep.sum())}
    if keep.sum():
        out.update(
            period=float(T[keep].mean()),
            period_std=float(T[keep].std()),
            drop=float(drop[keep].mean()),
            drop_std=float(drop[keep].std()),
        )
    return out


def hold_case(hold: float) -> dict:
    """Slide-hold-slide through the stiff spring: the friction's peak after a hold.

    The first peak of the friction on reloading after ``hold`` s at rest, and ``g mu`` at the
    hold's end.
    """
    law, V, k = law_(), HOLD_VELOCITY, HOLD_STIFFNESS
    ss = steady_sliding(law, F_N, V, MASS)
    u0 = ss.traction / law.alpha_t
    x0 = u0 + ss.traction / k  # the spring holds the steady friction
    held = run_slider(SliderCase(law, MASS, k, 0.0, F_N, hold, x0=x0), state=ss.state(), u0=u0)
    g = -np.expm1(-law.c_n * F_N)
    lag = 4.0 * np.pi * np.sqrt(MASS / k)  # two of the spring's periods: the inertia's lag
    t_end = 1.5 * (g * law.mu_s - ss.traction) / (k * V) + lag  # past the peak
    reload = SliderCase(law, MASS, k, V, F_N, t_end, x0=x0, dt_max=t_end / 300)
    s = run_slider(reload, state=held.end_state, u0=held.end_motion[0]).samples
    f = np.abs(s["f_t"])
    i = int(np.flatnonzero((f[1:-1] > f[:-2]) & (f[1:-1] >= f[2:]))[0]) + 1
    mu = float(held.samples["mu"][-1])
    return {"hold": hold, "peak": float(f[i]), "steady": ss.traction, "strength": g * mu}


def stiffness_case(ratio: float) -> dict:
    """The friction's range once settled, from rest, with the dashpot at ``ratio`` k_c."""
    ss = steady_sliding(law_(), F_N, HOLD_VELOCITY, MASS, DASHPOT)
    k = ratio * ss.critical_stiffness
    case = SliderCase(law_(), MASS, k, HOLD_VELOCITY, F_N, 40.0, damping=DASHPOT)
    s = run_slider(case).samples
    late = s["t"] >= 30.0
    return {
        "ratio": ratio,
        "stiffness": k,
        "range": float(np.ptp(s["f_t"][late])),
        "v_max": float(s["v"][late].max()),
    }


def study(velocity: float, comm) -> dict | None:
    """The three studies and the time step's share, spread over the ranks; rank 0 gets them."""
    tasks = [("sweep", V, 1) for V in VELOCITIES] + [("sweep", velocity, 2)]
    tasks += [("hold", h, 0) for h in HOLDS] + [("stiffness", r, 0) for r in STIFFNESS_RATIOS]

    def share() -> dict:  # this rank's cases
        done = {}
        for i, (kind, x, refine) in enumerate(tasks):
            if i % comm.size == comm.rank:
                if kind == "sweep":
                    done[i] = sweep_case(x, refine)
                else:
                    done[i] = hold_case(x) if kind == "hold" else stiffness_case(x)
        return done

    # a case failing on one rank raises on every rank (none waits in the gather)
    done = collective(comm, share, "the material-point study", root=None, error=RuntimeError)
    parts = comm.gather(done, root=0)
    if comm.rank != 0:
        return None
    got = {i: r for p in parts for i, r in p.items()}
    res = [got[i] for i in range(len(tasks))]
    n = len(VELOCITIES)
    ss = steady_sliding(law_(), F_N, HOLD_VELOCITY, MASS, DASHPOT)
    fine = res[n]
    coarse = sweep_case(velocity) if velocity not in VELOCITIES else res[VELOCITIES.index(velocity)]
    return {
        "sweep": res[:n],
        "step": {"coarse": coarse, "fine": fine},
        "holds": res[n + 1 : n + 1 + len(HOLDS)],
        "stiffness": res[n + 1 + len(HOLDS) :],
        "critical_stiffness": ss.critical_stiffness,
        "onset_period": ss.onset_period,
    }


def report_study(st: dict) -> None:
    """Print the studies (rank 0)."""
    print(f"spring-slider, {K:g} MPa/mm, settled cycles (mean +- standard deviation):")
    for r in st["sweep"]:
        if "period" not in r:
            print(f"  V = {r['velocity']:g} mm/s: no settled cycles (steady sliding)")
            continue
        print(
            f"  V = {r['velocity']:g} mm/s: period {r['period']:.3f} +- {r['period_std']:.3f} s, "
            f"stress drop {r['drop']:.2f} +- {r['drop_std']:.2f} MPa ({r['cycles']} cycles)"
        )
    c, f = st["step"]["coarse"], st["step"]["fine"]
    if "period" in c and "period" in f:
        dT, dD = (100 * (f[q] / c[q] - 1) for q in ("period", "drop"))
        eT, eD = (100 * c[q + "_std"] / c[q] / np.sqrt(c["cycles"]) for q in ("period", "drop"))
        print(
            f"  half the step at V = {c['velocity']:g}: period {dT:+.2f} %, drop {dD:+.2f} % "
            f"(the means' own spread, sd / sqrt(n): {eT:.2f} %, {eD:.2f} %)"
        )
    h = st["holds"]
    print(
        f"slide-hold-slide, {HOLD_STIFFNESS:g} MPa/mm at {HOLD_VELOCITY:g} mm/s (steady "
        f"{h[0]['steady']:.2f} MPa): hold (s), peak friction on reloading, g mu after the hold:"
    )
    print("  hold" + "".join(f" {r['hold']:7.3g}" for r in h))
    for what, key in (("  peak", "peak"), ("  g mu", "strength")):
        print(what + "".join(f" {r[key]:7.2f}" for r in h))
    print(
        f"with a dashpot of {DASHPOT:g} MPa s/mm at {HOLD_VELOCITY:g} mm/s: k_c = "
        f"{st['critical_stiffness']:.1f} MPa/mm (linear stability); from rest, the friction's "
        "range once settled (MPa):"
    )
    print("  k/k_c" + "".join(f" {r['ratio']:7.3g}" for r in st["stiffness"]))
    print("  range" + "".join(f" {r['range']:7.2g}" for r in st["stiffness"]))


def study_figure(st: dict, outdir: Path) -> Path:
    """Period and stress drop against velocity, the peak after a hold, the range against k."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    sw = [r for r in st["sweep"] if "period" in r]
    V = [r["velocity"] for r in sw]
    ax = axes[0]
    ax.errorbar(V, [r["period"] for r in sw], [r["period_std"] for r in sw], fmt="o-", capsize=3)
    ax.set_xscale("log")
    ax.set_xlabel("driving velocity V (mm/s)")
    ax.set_ylabel("period (s)", color="C0")
    ax2 = ax.twinx()
    drops = [r["drop"] for r in sw]
    ax2.errorbar(V, drops, [r["drop_std"] for r in sw], fmt="s--", color="C1", capsize=3)
    ax2.set_ylabel("stress drop (MPa)", color="C1")
    ax.set_title("settled cycles (mean, scatter)")
    ax.grid(True, alpha=0.3)
    ax = axes[1]
    h = st["holds"]
    t = [r["hold"] for r in h]
    ax.semilogx(t, [r["peak"] for r in h], "o-", label="peak friction on reloading")
    ax.semilogx(t, [r["strength"] for r in h], "^:", label="$g\\,\\mu$ at the hold's end")
    ax.axhline(h[0]["steady"], color="k", lw=0.8, label="steady sliding")
    ax.set_xlabel("hold time (s)")
    ax.set_ylabel("friction traction (MPa)")
    ax.set_title(f"slide-hold-slide, {HOLD_STIFFNESS:g} MPa/mm, {HOLD_VELOCITY:g} mm/s")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax = axes[2]
    s = st["stiffness"]
    ax.plot([r["ratio"] for r in s], [r["range"] for r in s], "o-")
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_xlabel(f"spring stiffness $k / k_c$ ($k_c$ = {st['critical_stiffness']:.1f} MPa/mm)")
    ax.set_ylabel("friction's range once settled (MPa)")
    ax.set_title(f"with a dashpot of {DASHPOT:g} MPa s/mm")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    path = outdir / "stick_slip_study.png"
    fig.savefig(path, dpi=110)
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
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    ap.add_argument(
        "--no-study", action="store_true", help="skip the material-point study (FE run only)"
    )
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    t_end = args.slide / args.velocity
    fe = run_fe(args.velocity, t_end, args.steps, args.n, outdir, comm)
    out: dict = {"fe": fe}
    st = None if args.no_study else study(args.velocity, comm)
    if comm.rank == 0:
        point = run_point(args.velocity, t_end)
        out["point"] = point
        out["report"] = report(fe, point, args.velocity)
        if st is not None:
            report_study(st)
            out["report"]["study"] = st
        if not args.no_figures:
            print(f"wrote {figure(fe, point, args.velocity, outdir)}")
            if st is not None:
                print(f"wrote {study_figure(st, outdir)}")
    return out


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
