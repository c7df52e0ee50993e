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
r"""# A bolted joint with the bolt as a body: pretension, then cyclic shear

Four bodies and three frictional interfaces in one 3-D model. A bolt (head, shank and the part
of the shank in the nut, three cell groups of one body) and its nut (a body of its own, tied to
the shank: the thread is bonded) clamp two steel plates that overlap; the shank passes through
the plates' holes with a clearance. The interfaces, each with the subloading-friction law:

| interface   | primary | secondary | where                                        |
|-------------|---------|-----------|----------------------------------------------|
| `head_face` | upper   | bolt      | under the head, around the hole              |
| `joint`     | lower   | upper     | the plates' overlap, minus the hole          |
| `nut_face`  | lower   | nut       | under the lower plate, around the hole       |

**Pretension** is an interference on the nut face: its initial gap $g_0 = -\delta$ (the nut
turned by $\delta$ beyond snug). The first step stretches the bolt and compresses the plates until
the bolt force and the clamping force balance. **Then cyclic shear**: the upper plate's far end
is moved back and forth along the joint (y held, z free), the lower plate's far end clamped. The
joint sticks, slips around the hole's low-pressure rim, then slides; the head and nut are dragged
with the plates and the bolt bends in its clearance.

**Force balance, at every step** (the demo checks it; `tests/demos/test_model_demos.py` too):
the bolt's axial force, measured in the shank as
$N = \frac{1}{\ell}\int_{\text{shank}} \sigma_{zz}\,dV$ (exact for a free-sided segment of length
$\ell$ in equilibrium), equals the normal resultant of the head face, of the nut face and of the
joint (the clamping force): the upper plate is free in $z$, so nothing else carries the clamping.
The pretension changes under the shear (the bolt tilts; printed as the pretension loss), and
the shear force against the imposed displacement draws the joint's hysteresis loops.

The bolt and the nut are held only through their interfaces: weak springs (x and y only, so the
axial balance is untouched) on the head's top face remove their rigid rotation about the bolt
axis when every point of an interface slides.

    mpirun -n 2 python3 demos/bolt_clamped_joint.py [--h 2.0] [--cycles 2] [--out DIR]
"""

# %%
import argparse
import math
import types
from pathlib import Path

import dolfinx
import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    Spring,
    StepControl,
)
from subfric_dolfinx.io import interface_summary, write_history_file
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import cli

# geometry (mm)
LP, W, T, C = 40.0, 20.0, 4.0, 20.0  # plate length, width, thickness, overlap
XC, YC = LP - C / 2, W / 2  # the hole's axis
R_HOLE, R_SHANK, R_WASHER = 4.5, 4.0, 8.0  # hole, shank, head and nut
T_HEAD, T_NUT = 4.0, 5.0
DELTA = 0.01  # mm, the nut's interference (pretension)
SHEAR = 0.05  # mm, amplitude of the upper plate's end
ALPHA = 1e5  # MPa/mm, the interfaces' penalties
STEEL = Material(2.1e5, 0.3)
BODIES = {"bolt": ["head", "shank", "tail"], "nut": ["nut"], "lower": ["lower"], "upper": ["upper"]}
SIDES = {"head_face": ("upper", "bolt"), "joint": ("lower", "upper"), "nut_face": ("lower", "nut")}


# %% [markdown]
# ## The mesh: gmsh, the user's names, the interfaces' nodes split


# %%
def build(h: float):
    """Plates, bolt and nut meshed together (rank 0); the three interfaces' nodes duplicated."""
    import gmsh

    gmsh.model.add("bolt_clamped_joint")
    occ = gmsh.model.occ
    lower = occ.addBox(0, 0, 0, LP, W, T)
    upper = occ.addBox(LP - C, 0, T, LP, W, T)
    for plate, z in ((lower, 0.0), (upper, T)):
        hole = occ.addCylinder(XC, YC, z, 0, 0, T, R_HOLE)
        occ.cut([(3, plate)], [(3, hole)])
    head = occ.addCylinder(XC, YC, 2 * T, 0, 0, T_HEAD, R_WASHER)
    shank = occ.addCylinder(XC, YC, 0, 0, 0, 2 * T, R_SHANK)
    tail = occ.addCylinder(XC, YC, -T_NUT, 0, 0, T_NUT, R_SHANK)
    nut = occ.addCylinder(XC, YC, -T_NUT, 0, 0, T_NUT, R_WASHER)
    occ.cut([(3, nut)], [(3, occ.addCylinder(XC, YC, -T_NUT, 0, 0, T_NUT, R_SHANK))])
    occ.fragment(occ.getEntities(3), [])
    occ.synchronize()
    groups: dict[str, list[int]] = {
        k: [] for k in ("lower", "upper", "head", "shank", "tail", "nut")
    }
    del lower, upper, head, shank, tail, nut
    for _, t in gmsh.model.getEntities(3):
        x0, _, z0, x1, _, z1 = gmsh.model.getBoundingBox(3, t)
        zc, wide = 0.5 * (z0 + z1), x1 - x0
        if zc > 2 * T:
            groups["head"].append(t)
        elif wide > 3 * R_WASHER:
            groups["lower" if zc < T else "upper"].append(t)
        elif zc > 0:
            groups["shank"].append(t)
        else:
            groups["tail" if wide < 2 * R_SHANK + 1e-3 else "nut"].append(t)
    tag_of = {t: name for name, ts in groups.items() for t in ts}
    faces: dict[str, list[int]] = {
        "head_face": [],
        "joint": [],
        "nut_face": [],
        "lower_end": [],
        "upper_end": [],
        "head_top": [],
    }
    pairs = {
        frozenset(("upper", "head")): "head_face",
        frozenset(("lower", "upper")): "joint",
        frozenset(("lower", "nut")): "nut_face",
    }
    for _, s in gmsh.model.getEntities(2):
        up, _ = gmsh.model.getAdjacencies(2, s)
        owners = frozenset(tag_of[v] for v in up)
        x0, _, z0, x1, _, z1 = gmsh.model.getBoundingBox(2, s)
        if owners in pairs:
            faces[pairs[owners]].append(s)
        elif owners == {"lower"} and abs(x1) < 1e-6:
            faces["lower_end"].append(s)
        elif owners == {"upper"} and abs(x0 - (2 * LP - C)) < 1e-6:
            faces["upper_end"].append(s)
        elif owners == {"head"} and abs(z0 - (2 * T + T_HEAD)) < 1e-6:
            faces["head_top"].append(s)
    for name, ts in groups.items():
        gmsh.model.addPhysicalGroup(3, ts, name=name)
    for name, ts in faces.items():
        gmsh.model.addPhysicalGroup(2, ts, name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.25 * h)
    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    field.setNumbers(dist, "SurfacesList", faces["head_face"] + faces["nut_face"])
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    field.setNumber(thr, "SizeMin", 0.5 * h)
    field.setNumber(thr, "SizeMax", h)
    field.setNumber(thr, "DistMin", 1.0)
    field.setNumber(thr, "DistMax", 6.0)
    field.setAsBackgroundMesh(thr)
    gmsh.model.mesh.generate(3)
    meshing.duplicate_interface_nodes(
        None, {k: (BODIES[a], BODIES[b]) for k, (a, b) in SIDES.items()}
    )
    return types.SimpleNamespace(gdim=3)


# %% [markdown]
# ## The problem


# %%
def program(cycles: int) -> LoadingProgram:
    """Pretension, then ``cycles`` cycles of shear.

    The first second: nothing moves (the interference acts at once); then the upper plate's end
    to +a, -a, ... and back to 0, 1 s per quarter cycle.
    """
    t, shear = [0.0, 1.0], [0.0, 0.0]
    for _ in range(cycles):
        t += [t[-1] + 1, t[-1] + 3, t[-1] + 4]
        shear += [1.0, -1.0, 0.0]
    return LoadingProgram(t, {"shear": shear})


def problem(domain, cycles: int) -> InterfaceProblem:
    law = preset("sec7").replace(alpha_t=ALPHA, alpha_n=ALPHA)
    return InterfaceProblem(
        domain,
        law,
        {b: STEEL for b in BODIES},
        program(cycles),
        [
            Dirichlet("lower_end", [0.0, 0.0, 0.0]),
            Dirichlet("upper_end", SHEAR, component=0, amplitude="shear"),
            Dirichlet("upper_end", 0.0, component=1),
        ],
        [Spring("head_top", [1e-2, 1e-2, 0.0])],
        interfaces=[
            Interface("head_face"),
            Interface("joint"),
            Interface("nut_face", initial_gap=-DELTA),
        ],
    )


def bolt_force(problem: InterfaceProblem):
    """``N = (1/l) int_shank sigma_zz dV``: a compiled form, evaluated on every rank."""
    ctx = problem.bulk_context
    sig = problem.bulk.stress(problem.u, ctx)
    form = dolfinx.fem.form(sig[2, 2] / (2 * T) * ctx.measure("shank"))

    def evaluate() -> float:
        return problem.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)

    return evaluate


def run(domain, cycles: int, dt: float) -> tuple[list[dict[str, float]], InterfaceProblem]:
    """Pretension and cyclic shear: one row per step (the forces of the balance), the problem."""
    p = problem(domain, cycles)
    N = bolt_force(p)
    rows = []
    dofs = p.global_dofs

    def on_step(rec):
        s = interface_summary(p)
        rows.append(
            {
                "t": rec.t,
                "shear": SHEAR * p.program.amplitude("shear", rec.t),
                "force": p.reactions["upper_end"][0],
                "bolt": N(),
                "head": s["head_face.F_n"],
                "joint": s["joint.F_n"],
                "nut": s["nut_face.F_n"],
                "joint_slip": s["joint.up_norm"],
                "joint_plastic": s["joint.plastic"],
                "residual_bound": math.sqrt(dofs) * rec.residuals[-1],
            }
        )

    with FrictionSolver(p, "bolt_", linear="lu") as solver:
        LoadStepper(solver, dt, control=StepControl(hold_dt=1.0), on_step=on_step).run()
    return rows, p


COLUMNS = {
    "shear": ("mm", "displacement imposed at the upper plate's end, x"),
    "force": ("N", "shear force: the reaction at the upper plate's end, x"),
    "bolt": ("N", "bolt force: the shank's axial stress integrated over its section"),
    "head": ("N", "normal resultant of the head's face (head_face.F_n)"),
    "joint": ("N", "normal resultant of the joint between the plates (joint.F_n)"),
    "nut": ("N", "normal resultant of the nut's face (nut_face.F_n)"),
    "joint_slip": ("mm", "mean plastic slip of the joint (joint.up_norm)"),
    "joint_plastic": ("1", "fraction of the joint's points sliding (joint.plastic)"),
    "residual_bound": ("N", "sqrt(dofs) times Newton's last residual norm"),
}
"""Units and meanings of the history's columns (``history.csv-metadata.json``)."""


def balance(rows: list[dict[str, float]]) -> float:
    """The largest difference between the bolt force and the three normal resultants.

    Relative to the pretension, over all steps.
    """
    pre = abs(rows[0]["bolt"])
    return max(
        abs(abs(r["bolt"]) - abs(r[k])) / pre for r in rows for k in ("head", "joint", "nut")
    )


def balance_newton(rows: list[dict[str, float]]) -> float:
    """What Newton's stop allows of :func:`balance`: ``sqrt(dofs) |F|`` relative to the pretension.

    Each difference is the residual's action on a field of nodal values at most 1 (the shank's
    ``z / l``, a face's indicator), so at most ``sqrt(dofs)`` times the residual norm ``|F|`` a
    step ended with (Cauchy-Schwarz; each row's ``residual_bound``); at the floor this is
    ~1e-12, far below the demo's 1e-8.
    """
    pre = abs(rows[0]["bolt"])
    return max(r["residual_bound"] for r in rows) / pre


# %% [markdown]
# ## What it shows


# %%
def report(rows: list[dict[str, float]], comm: MPI.Comm) -> dict:
    pre = abs(rows[0]["bolt"])
    force = np.array([r["force"] for r in rows])
    out = {
        "pretension": pre,
        "balance": balance(rows),
        "balance_newton": balance_newton(rows),
        "pretension_change": abs(rows[-1]["bolt"]) / pre - 1.0,
        "min_pretension": min(abs(r["bolt"]) for r in rows) / pre - 1.0,
        "shear_max": float(force.max()),
        "shear_min": float(force.min()),
        "steps": len(rows),
    }
    if comm.rank == 0:
        print(
            f"pretension {pre:.1f} N (interference {DELTA} mm on the nut face); at every one "
            f"of {len(rows)} steps the bolt's axial force equals the head's, the joint's and "
            f"the nut's normal resultants within {out['balance']:.1e} of it"
        )
        print(
            f"under the shear: the bolt force varies down to {100 * out['min_pretension']:+.2f} "
            f"% and ends {100 * out['pretension_change']:+.2f} % off the pretension; shear "
            f"force {out['shear_min']:.1f} to {out['shear_max']:.1f} N"
        )
    return out


def figure(rows: list[dict[str, float]], outdir: Path) -> None:
    """Hysteresis, one colour per cycle; the bolt's force and the three normal resultants."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10.5, 4))
    t = np.array([r["t"] for r in rows])
    shear = np.array([1e3 * r["shear"] for r in rows])
    force = np.array([r["force"] for r in rows])
    cycles = max(round((t[-1] - 1.0) / 4.0), 1)  # 4 s a cycle after the 1 s pretension
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, cycles))
    for k in range(cycles):
        inside = (t >= 1.0 + 4 * k - 1e-9) & (t <= 5.0 + 4 * k + 1e-9)
        ax[0].plot(
            shear[inside], force[inside], ".-", ms=3, color=colours[k], label=f"cycle {k + 1}"
        )
    ax[0].plot(shear[0], force[0], "ko", ms=4, label="after the pretension")
    ax[0].axhline(0.0, color="k", lw=0.5)
    ax[0].set_xlabel("displacement of the upper plate's end (µm)")
    ax[0].set_ylabel("shear force (N)")
    ax[0].set_title("hysteresis", fontsize=10)
    ax[0].legend(fontsize=8)
    ax[0].grid(True, alpha=0.3)
    styles = {  # the four agree to round-off: drawn so that each stays visible
        "bolt": {"lw": 4.0, "alpha": 0.35, "color": "C0"},
        "head": {"lw": 1.2, "ls": "--", "color": "C1"},
        "joint": {"lw": 1.2, "ls": ":", "color": "k"},
        "nut": {"lw": 0.0, "marker": "x", "ms": 3, "color": "C3"},
    }
    labels = {
        "bolt": "bolt (the shank's axial stress)",
        "head": "head's face, F_n",
        "joint": "joint, F_n",
        "nut": "nut's face, F_n",
    }
    for k, style in styles.items():
        ax[1].plot(t, [abs(r[k]) for r in rows], label=labels[k], **style)
    ax[1].set_xlabel("t (s)")
    ax[1].set_ylabel("force (N)")
    ax[1].set_title("bolt force and the normal resultants (equal at every step)", fontsize=10)
    ax[1].legend(fontsize=8)
    ax[1].grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(outdir / "bolt_clamped_joint.png", dpi=120)
    plt.close(fig)


# %% [markdown]
# ## The command line


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--h", type=float, default=2.0, help="element size (mm)")
    ap.add_argument("--cycles", type=int, default=2, help="shear cycles")
    ap.add_argument("--dt", type=float, default=0.1, help="time step in s")
    ap.add_argument("--out", default="demos/output/bolt_clamped_joint", help="output directory")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)
    domain, _ = meshing.create_interface_mesh(
        build, comm, bodies=BODIES, interfaces=SIDES, h=args.h
    )
    rows, problem_ = run(domain, args.cycles, args.dt)
    out = report(rows, comm)
    if comm.rank == 0:
        outdir = Path(args.out)
        outdir.mkdir(parents=True, exist_ok=True)
        write_history_file(outdir / "history.csv", rows, problem_, COLUMNS)  # and its units
        figure(rows, outdir)
    return {"history": rows, "report": out}


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
