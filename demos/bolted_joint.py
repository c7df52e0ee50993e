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
"""# Bolted lap joint (3-D): two plates clamped by a bolt, then sheared back and forth.

The subloading-friction law on the plate-plate interface of a single-bolt lap joint; the size of
the model is set by ``--n`` (elements across the plate width). Run as
``mpirun -n 2 python3 demos/bolted_joint.py [--n 8]``; ``--help`` lists the options.
"""

# %% [markdown]
r"""
## A bolted lap joint under cyclic shear: the friction hysteresis of a clamped interface

Two steel plates overlap over a square and are clamped by one bolt through a hole at the
centre of the overlap. The bolt is not meshed: its head and nut press on the annuli they cover
(the `bolt_head` group on top of the upper plate, `bolt_nut` under the lower plate) with a
pressure whose resultant is the bolt's preload. Then the free end of the upper plate is moved
back and forth along the joint while the far end of the lower plate is clamped: the interface
carries the shear by friction, sticks near the bolt where the pressure is highest, slips where
it is lowest, and when the whole overlap slips the joint's shear force saturates. Each reversal
runs through the elastic-plastic transition of the subloading surface again, so force against
slip draws a hysteresis loop whose area is the energy the joint dissipates per cycle (the
damping of bolted structures).

| quantity                 | default                                                        |
|--------------------------|----------------------------------------------------------------|
| plates                   | 60 x 30 x 5 mm, steel (E = 210 GPa, nu = 0.3), overlap 30 mm   |
| bolt                     | hole 9 mm, head and nut annuli 9-16 mm (an M8 bolt), 30 kN     |
| interface law            | the paper's Sec. 7 set (preset `sec7`), alpha = 1e4 MPa/mm      |
| shear                    | +-0.25 mm at the upper plate's end, 1 mm/s, 3 cycles            |

Loading program:

| time          | what happens                                                          |
|---------------|-----------------------------------------------------------------------|
| 0 - 1 s       | the bolt load is applied (pressure on the head and nut annuli)        |
| then          | the upper plate's end moves to +a, -a, +a, ... (`--cycles` cycles), 0 |

The upper plate's end is guided (x prescribed, y held) but free in z, so the bolt load is
carried by the interface alone: the interface's normal resultant equals the bolt load at every
step (a check in `tests/demos/test_bolted_joint.py`). With the Sec. 7 set ($c_n = 2\cdot10^{-4}$
1/MPa, $\mu_s = 500$, $\mu_k = 63$ MPa) the shear strength of a point is $g(f_n)\,\mu$ with
$g = 1 - e^{-c_n f_n}$, concave in $f_n$: whatever the pressure distribution, the joint's
shear force stays below $\mu_s\,A\,g(F_b/A)$ for a bolt load $F_b$ over the interface area
$A$ (Jensen's inequality). Slip softens $\mu$ towards $\mu_k$ (and the recovery term holds it
a little above), so the loops shrink from the static to the kinetic level over the first cycles
and then repeat, symmetric.

One change to the Sec. 7 set: a stiffer interface, $\alpha_t = \alpha_n = 10^4$ MPa/mm instead
of 500 (`--alpha`). The paper's soft layer spreads the bolt load over the whole overlap and lets
the plates interpenetrate by 0.12 mm under the washer, a tenth of an element; with a stiffer
one the pressure concentrates in a cone around the hole and the overlap's corners open (about a
quarter of the interface), as in a real joint. The first peak hardly depends on it (2.39,
2.38 and 2.37 kN with $\alpha$ = 500, $10^4$ and $10^5$ MPa/mm at the default mesh), the
second stroke's a little more (-1.82, -2.04, -2.04 kN); a stiffer interface costs Newton
iterations (3.1, 4.7 and 6.3 per step). This compliance is the model's, chosen on purpose: the
scene declares it (`interfaces.interface.intended_compliance`), so the penetration is judged
against the element size only (the plates overlap by 0.016 mm at most, below a tenth of an
element), not as a compliance (a layer `E*/alpha_n` = 11.5 mm of steel).

The pressure on each annulus is the preload over the exact annulus area; the meshed annuli
(polygons) are 2.5 % smaller at the default mesh, so the applied bolt load is 29.2 kN for the
nominal 30 kN: the demo prints the clamping resultant it actually applied.

Size: `--n` elements across the plate width, tetrahedra (finer around the hole): `--n 8`
(default) has 3.5k dofs, `--n 16` 12k, `--n 24` 33k, `--n 32` 69k, `--n 48` about 200k. The
Jacobian is factorised (MUMPS) at every Newton iteration, which dominates from about 10k dofs
on; the README gives measured times.

Run it on two ranks:

    mpirun -n 2 python3 demos/bolted_joint.py [--n 8] [--cycles 3] [--amplitude 0.25]
        [--preload 30] [--out DIR]

It prints progress on rank 0 (`-v`: a line per step and the timing breakdown), the clamping
resultant against the bolt load and the shear force's extremes per stroke, and writes the CSV
history (`history.csv`) and two figures (`hysteresis.png`, `pressure.png`) into the output
directory. PETSc options apply under the prefix `bolt_`, e.g. `-bolt_snes_monitor`.
"""

# %%
import argparse
import math

# %%
import numpy as np
from mpi4py import MPI

# %%
from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.scenes import cli, run_scene

# %% [markdown]
"""
## Geometry and loading

An M8 bolt in 5 mm plates: hole radius 4.5 mm, washer radius 8 mm. The preload (30 kN by
default) is applied as a uniform pressure on each annulus.
"""

# %%
GEOMETRY = {
    "plate_length": 60.0,
    "width": 30.0,
    "thickness": 5.0,
    "overlap": 30.0,
    "hole_radius": 4.5,
    "washer_radius": 8.0,
}
CLAMP_TIME = 1.0  # s
RATE = 1.0  # mm/s, the paper's sliding velocity
ALPHA = 1e4  # MPa/mm


# %%
def annulus_area() -> float:
    """Exact area of a head/nut annulus, mm^2 (the mesh's polygonal annulus differs a little)."""
    return math.pi * (GEOMETRY["washer_radius"] ** 2 - GEOMETRY["hole_radius"] ** 2)


# %%
def interface_area() -> float:
    """Exact area of the interface (the overlap minus the hole), mm^2."""
    g = GEOMETRY
    return g["overlap"] * g["width"] - math.pi * g["hole_radius"] ** 2


# %%
def program(amplitude: float, cycles: int, steps_per_stroke: int):
    """Times and channels: the clamp ramp, then strokes to +a, -a, ... and back to 0.

    Every stroke (2 a long, a for the first and the last) has ``steps_per_stroke`` breakpoints
    per 2 a, so that the steps end on them.

    Returns:
        ``(times, channels, reversals)``, ``reversals`` the times of the stroke ends.
    """
    times, clamp, shear = [0.0, CLAMP_TIME], [0.0, 1.0], [0.0, 0.0]
    targets = [amplitude * (-1) ** k for k in range(2 * cycles)] + [0.0]
    reversals = []
    for to in targets:
        x0 = shear[-1]
        k = max(1, round(steps_per_stroke * abs(to - x0) / (2.0 * amplitude)))
        for x in np.linspace(x0, to, k + 1)[1:]:
            times.append(times[-1] + abs(to - x0) / k / RATE)
            clamp.append(1.0)
            shear.append(float(x))
        reversals.append(times[-1])
    return times, {"clamp": clamp, "shear": shear}, reversals


# %%
def scene(
    n: int = 8,
    preload: float = 30.0,
    amplitude: float = 0.25,
    cycles: int = 3,
    steps_per_stroke: int = 20,
    alpha: float = ALPHA,
) -> dict:
    """The bolted-joint scene: ``n`` elements across the width, ``preload`` in kN."""
    times, channels, _ = program(amplitude, cycles, steps_per_stroke)
    pressure = 1e3 * preload / annulus_area()  # MPa
    return {
        "kind": "fe",
        "name": "bolted_joint",
        "mesh": {"builder": "bolted_lap_joint", "options": {**GEOMETRY, "n_interface": n}},
        "law": {
            "law": "subloading",
            "params": {"preset": "sec7", "alpha_t": alpha, "alpha_n": alpha},
        },
        "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 2.1e5, "nu": 0.3}},
        # the soft layer is the model's (see above): its penetration is judged as an overlap only
        "interfaces": {"interface": {"intended_compliance": True}},
        "program": {"times": times, "channels": channels},
        "dirichlet": [
            {"group": "primary_xmin", "value": [0.0, 0.0, 0.0]},
            {"group": "secondary_xmax", "component": 0, "value": 1.0, "amplitude": "shear"},
            {"group": "secondary_xmax", "component": 1, "value": 0.0},
        ],
        "loads": [
            {"type": "pressure", "group": "bolt_head", "value": pressure, "amplitude": "clamp"},
            {"type": "pressure", "group": "bolt_nut", "value": pressure, "amplitude": "clamp"},
        ],
        "solver": {"prefix": "bolt_", "dt": CLAMP_TIME / 4, "dt_max": CLAMP_TIME / 4},
        "outputs": {"history": True, "snapshots": [CLAMP_TIME]},
    }


# %% [markdown]
"""
## What the demo measures

The shear force is the reaction on the upper plate's guided end (`R_secondary_xmax_x` of the
history); the slip is the interface's mean plastic slip along the joint (`up_t1`), and the
end displacement the prescribed one. For each stroke: the extreme of the shear force. The
clamping resultant is the interface's normal resultant `F_n`.
"""


# %%
def strokes(history, reversals):
    """Per stroke: (end time, extreme shear force in N: the max on a +stroke, the min on a -)."""
    t = np.array([r["t"] for r in history])
    R = np.array([r["R_secondary_xmax_x"] for r in history])
    out, t0 = [], CLAMP_TIME
    for k, t1 in enumerate(reversals[:-1]):
        seg = (t > t0 + 1e-9) & (t <= t1 + 1e-9)
        out.append((t1, float(R[seg].max() if k % 2 == 0 else R[seg].min())))
        t0 = t1
    return out


# %%
def saturation_bound(preload: float) -> float:
    """mu_s A g(F_b / A), N: no pressure distribution lets the joint carry more shear."""
    p = PRESETS["sec7"].law
    A = interface_area()
    return p.mu_s * A * (1.0 - math.exp(-p.c_n * 1e3 * preload / A))


# %% [markdown]
"""
## Figures
"""


# %%
def figures(result, outdir, amplitude, cycles, steps_per_stroke, preload):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = result.history
    t = np.array([r["t"] for r in h])
    R = 1e-3 * np.array([r["R_secondary_xmax_x"] for r in h])  # kN
    up = np.array([r["up_t1"] for r in h])
    times, channels, reversals = program(amplitude, cycles, steps_per_stroke)
    end = np.interp(t, times, channels["shear"])
    bound = 1e-3 * saturation_bound(preload)
    files = []

    # cycle k: from the end of the previous one (the clamping's for the first) to its second
    # reversal; the last one also takes the return to zero
    starts = [CLAMP_TIME, *reversals[1 : 2 * cycles - 1 : 2]]
    stops = [*reversals[1 : 2 * cycles - 1 : 2], reversals[-1]]
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, max(cycles, 1)))
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for a, x, label in (
        (ax[0], up, "mean plastic slip $u^p_1$ over the interface (mm)"),
        (ax[1], end, "displacement of the upper plate's end (mm)"),
    ):
        for k, (t0, t1) in enumerate(zip(starts, stops, strict=True)):
            inside = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
            a.plot(x[inside], R[inside], lw=1.4, color=colours[k], label=f"cycle {k + 1}")
        first = np.flatnonzero(t >= CLAMP_TIME - 1e-9)[0]
        a.plot(x[first], R[first], "ko", ms=4, label="start of the shear")
        for s in (1, -1):
            a.axhline(s * bound, color="C3", ls="--", lw=0.8)
        a.axhline(0.0, color="k", lw=0.5)
        a.set_xlabel(label)
        a.grid(True, alpha=0.3)
    ax[0].set_ylabel("shear force (kN)")
    ax[0].legend(fontsize=8, loc="lower right")
    ax[1].text(
        0.02,
        0.95,
        r"dashed: $\mu_s A\, g(F_b/A)$",
        transform=ax[1].transAxes,
        fontsize=8,
        color="C3",
        va="top",
    )
    fig.suptitle(
        f"Bolted lap joint, {preload:g} kN preload: shear force against slip, {cycles} cycles"
    )
    fig.tight_layout()
    files.append(outdir / "hysteresis.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    snap = result.snapshots[min(result.snapshots, key=lambda s: abs(s - CLAMP_TIME))]
    fig, ax = plt.subplots(figsize=(6, 5.2))
    sc = ax.scatter(snap["x"][:, 0], snap["x"][:, 1], c=snap["f_n"], s=6, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="contact pressure $f_n$ (MPa)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title("Contact pressure after clamping (interface points)")
    fig.tight_layout()
    files.append(outdir / "pressure.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    return files


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=8, help="elements across the plate width")
    ap.add_argument("--preload", type=float, default=30.0, help="bolt load in kN")
    ap.add_argument(
        "--amplitude", type=float, default=0.25, help="end displacement amplitude in mm"
    )
    ap.add_argument("--cycles", type=int, default=3, help="shear cycles")
    ap.add_argument("--steps", type=int, default=20, help="load steps per stroke of 2 x amplitude")
    ap.add_argument(
        "--alpha", type=float, default=ALPHA, help="interface stiffness alpha_t = alpha_n"
    )
    ap.add_argument("--out", default="demos/output/bolted_joint", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    return ap


# %%
def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    for name in ("n", "cycles", "steps"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name} must be at least 1, got {getattr(args, name)}")
    for name in ("preload", "amplitude", "alpha"):
        if not getattr(args, name) > 0:
            raise ValueError(f"--{name} must be positive, got {getattr(args, name)}")
    outdir = Path(args.out)
    sc = scene(args.n, args.preload, args.amplitude, args.cycles, args.steps, args.alpha)
    _, _, reversals = program(args.amplitude, args.cycles, args.steps)
    result = run_scene(sc, outdir=outdir, comm=comm)
    result.info["strokes"] = strokes(result.history, reversals)
    result.info["bound"] = saturation_bound(args.preload)
    if comm.rank == 0:
        clamp = min(result.history, key=lambda r: abs(r["t"] - CLAMP_TIME))
        print(
            f"[bolted_joint] {result.info['dofs']} dofs: clamping resultant "
            f"{1e-3 * clamp['F_n']:.3f} kN (nominal bolt load {args.preload:g} kN on the exact "
            f"annuli), mean pressure {clamp['f_n']:.1f} MPa, {100 * clamp['separated']:.0f} % "
            "of the interface points open"
        )
        for k, (t1, force) in enumerate(result.info["strokes"]):
            print(
                f"[bolted_joint] stroke {k + 1} (to t = {t1:.3f} s): extreme shear force "
                f"{1e-3 * force:+.3f} kN (bound {1e-3 * result.info['bound']:.3f} kN)"
            )
        if not args.no_figures:
            for f in figures(result, outdir, args.amplitude, args.cycles, args.steps, args.preload):
                print(f"wrote {f}")
    return result


# %%


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
