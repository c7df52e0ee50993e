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
r"""# Pad on a plate (3-D): reciprocal sliding with holds, and the recovery of static friction

An aluminium pad (A6111-T4) is pressed on a steel plate (tool steel) and slid back and forth.
Between some strokes it is held still for a while. While the contact rests, the hardening
function of the subloading-friction law recovers towards its static value,

$$\dot\mu = -\kappa(\mu - \mu_k)|\dot u^p| + \xi(\mu_s - \mu),$$

so the next stroke starts with a peak of tangential force that is higher the longer the hold was,
then softens back to the kinetic level as the pad slides. This is the static friction's growth
with the time of stationary contact, measured in friction tests since Rabinowicz, and the reason
a machine slide "sticks" after standing overnight.

The interface follows the paper's Sec. 7 parameter set (preset `sec7`, normalised reading; a
stiffer normal penalty, see below):
$\mu_s = 500$, $\mu_k = 63$ MPa, $\xi = 11/500 = 0.022$ 1/s, i.e. a recovery time
$1/\xi \approx 45$ s, so holds of 0, 5, 20 and 60 s recover 0, 10, 36 and 73 % of the gap
between the kinetic and the static strength.

Loading program (1 mm/s sliding as in the paper's experiments; $a$ = stroke amplitude, 0.4 mm):

| phase          | what happens                                                          |
|----------------|-----------------------------------------------------------------------|
| 0 - 1 s        | a pressure of 300 MPa is applied on the top of the pad                |
| run-in         | the top is moved to $+a$, then to $-a$: static peak, then softening   |
| hold $h_1$     | the top is held still for $h_1$ s                                     |
| stroke         | moved to the other end ($\pm a$): a peak, then kinetic sliding; and   |
|                | back and forth until it has slid 2 mm (three passes)                  |
| hold $h_2$ ... | and so on, one hold before each stroke                                |

The holds come in a shuffled order (5, 60, 0, 20 s by default): the peak then follows the
hold length and not the number of strokes done, which is the point of the demo. A pass is
0.8 mm long: the pad stays within 0.4 mm of where it started, 2.4 of its interface elements,
where the small-sliding interface (pairs fixed at the reference geometry) is valid. After the
run-in and after each hold the pad makes three passes, 2.4 mm of slip, enough for the hardening
function to return close to its kinetic steady state ($\kappa = 98/63$ 1/mm: 2.4 mm of slip
removes 98 % of the excess over it), so each hold starts from about the same state.

What the default run shows: the mean tangential traction peaks at 4.4, 6.2, 11.0 and 18.6 MPa
after holds of 0, 5, 20 and 60 s, from a kinetic level of about 4.0-4.5 MPa; the strengths the
holds restored ($g(f_n)\,\mu$ with the mean $\mu$ at the end of the hold) are 4.5, 7.0, 13.0
and 22.4 MPa, and the virgin peak of the run-in is 23.9 MPa (the static strength
$g(f_n)\,\mu_s$ is 29.1 MPa).

Run it on two ranks:

    mpirun -n 2 python3 demos/pad_on_plate.py [--n 6] [--cell hexahedron|tetrahedron]
        [--holds 5 60 0 20] [--fields vtx|xdmf|none] [--out DIR]

The default mesh is coarse (6 hexahedra along the pad's side), so that the default runs in
seconds; `--n` refines it, and the solver's linear strategy follows the size (`"auto"`: GAMG or
a reused MUMPS factorisation in 3-D, see the documentation's page on the solver). The normal
penalty is $\alpha_n = 10^5$ MPa/mm instead of the Sec. 7 set's 500, with which the pad would
sink 0.7 mm into the plate, more than an element. It is still as compliant as 0.6 mm of the
bodies, a compliance chosen on purpose, which the scene declares
(`interfaces.interface.intended_compliance`: the validity check then judges only how far the
bodies overlap, 4 µm, a fortieth of an element): under it the pressure under the pad is nearly
uniform, so the mean traction hardly depends on the mesh.

It prints progress on rank 0 (`-v`: a line per step and the timing breakdown), and writes the CSV
history, three figures and (by default) VTX fields for ParaView (`fields/displacement.bp`,
`fields/interface.bp`, at the end of the pressing, of every stroke and of every hold) into the
output directory. PETSc options apply under the prefix `pad_`, e.g. `-pad_snes_monitor`.
"""

# %%
import argparse
import math

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.scenes import cli, run_scene

# %% [markdown]
# ## The loading program
#
# The runner's load steps end on every breakpoint of the program and grow during easy stretches
# (up to `dt_max`). A hold of 60 s needs only a few steps (the recovery of $\mu$ integrates
# exactly over a step), a stroke needs many (the peak and the softening must be resolved). So the
# strokes are written with extra breakpoints (the amplitude is linear between breakpoints, so
# they change nothing but where the steps end): every `dt` seconds over the first 0.5 mm of a
# stroke, where the peak and the start of the softening are, and every `4 dt` over the rest,
# where the pad slides at a slowly varying kinetic level. `dt_max` is large: the steps lengthen
# during holds and follow the breakpoints during strokes.

# %%
RATE = 1.0  # sliding velocity, mm/s (the paper's Sec. 7 tests)
ALPHA_N = 1e5  # MPa/mm, the normal penalty (the Sec. 7 set's 500 would sink the pad 0.7 mm)
PRESS_TIME = 1.0  # s
FINE = 0.5  # mm at the start of each stroke with the fine step
RESET = 2.0  # mm: the slip after each hold (mu returns close to its kinetic value)
COARSE = 4  # the step over the rest of a stroke, in fine steps


def program(amplitude: float, holds, dt: float):
    """Breakpoints and channels of the program, and the strokes that follow each hold.

    After the run-in and after each hold the pad slides at least :data:`RESET` mm, in passes of
    ``2 amplitude`` from one end to the other (the peak is that of the first pass). A pass has a
    breakpoint every ``dt`` s over its first ``FINE`` mm (the peak and the start of the
    softening), then every ``COARSE * dt`` s (kinetic sliding, smooth).

    Returns:
        ``(times, channels, strokes)`` with ``strokes`` a list of ``(hold, t_start, t_end)``.
    """
    times, press, slide = [0.0, PRESS_TIME], [0.0, 1.0], [0.0, 0.0]

    def stroke(to: float) -> tuple[float, float]:
        t0, x0 = times[-1], slide[-1]
        length = abs(to - x0)
        fine = min(FINE, length)
        xs = list(np.linspace(0.0, fine, max(1, math.ceil(fine / (RATE * dt) - 1e-9)) + 1)[1:])
        rest = length - fine
        if rest > 0:
            k = max(1, math.ceil(rest / (RATE * COARSE * dt) - 1e-9))
            xs += list(fine + np.linspace(0.0, rest, k + 1)[1:])
        sign = 1.0 if to > x0 else -1.0
        for x in xs:
            times.append(t0 + x / RATE)
            press.append(1.0)
            slide.append(x0 + sign * x)
        slide[-1] = to
        return t0, times[-1]

    passes = max(1, math.ceil(RESET / (2.0 * amplitude) - 1e-9))  # strokes of RESET mm or more
    stroke(amplitude)  # run-in: virgin static peak
    for _ in range(passes):
        stroke(-slide[-1])  # and back (and forth): the kinetic state everywhere
    strokes = []
    for h in holds:
        if h > 0:
            times.append(times[-1] + h)
            press.append(1.0)
            slide.append(slide[-1])
        strokes.append((float(h), *stroke(-slide[-1])))
        for _ in range(passes - 1):
            stroke(-slide[-1])
    return times, {"press": press, "slide": slide}, strokes


# %% [markdown]
# ## The scene
#
# The plate (primary) is clamped at its bottom. The pad's top carries the pressure and is moved in
# x by the `slide` channel; its y displacement is held at zero (a guided loading head), so that
# the pad's sideways position is not left to the interface's tangential stiffness alone.


# %%
def scene(
    n: int = 6,
    cell: str = "hexahedron",
    holds=(5.0, 60.0, 0.0, 20.0),
    amplitude: float = 0.4,
    pressure: float = 300.0,
    dt: float = 0.025,
    fields: str | None = "vtx",
    alpha_n: float = ALPHA_N,
) -> dict:
    """The pad-on-plate scene: ``n`` elements along the pad's side, normal penalty ``alpha_n``."""
    times, channels, strokes = program(amplitude, holds, dt)
    ends = [PRESS_TIME] + [t1 for _, _, t1 in strokes] + [t0 for _, t0, _ in strokes]
    return {
        "kind": "fe",
        "name": "pad_on_plate",
        "mesh": {
            "builder": "pad_on_plate",
            "options": {
                "n_interface": n,
                "cell_type": cell,
                "plate_size": [2.0, 2.0, 0.5],
                "pad_size": [1.0, 1.0, 0.5],
            },
        },
        "law": {"law": "subloading", "params": {"preset": "sec7", "alpha_n": alpha_n}},
        # the normal penalty's compliance is the model's (see above): its penetration is judged
        # against the interface element size only
        "interfaces": {"interface": {"intended_compliance": True}},
        "materials": {
            "primary": {"E": 2.1e5, "nu": 0.3},  # tool steel
            "secondary": {"E": 7.0e4, "nu": 0.33},  # aluminium
        },
        "program": {"times": times, "channels": channels},
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0, 0.0]},
            {"group": "top", "component": 0, "value": 1.0, "amplitude": "slide"},
            {"group": "top", "component": 1, "value": 0.0},
        ],
        "loads": [{"type": "pressure", "group": "top", "value": pressure, "amplitude": "press"}],
        "solver": {"prefix": "pad_", "dt": dt, "dt_max": 5.0},
        "outputs": {
            "history": True,
            "fields": fields,
            "field_times": sorted(set(ends)) if fields else [],
        },
    }


# %% [markdown]
# ## What the demo measures
#
# For each stroke after a hold: the peak of the mean tangential traction $|F_t|/A$ during the
# stroke, the kinetic level just before the hold (the end of the previous stroke), and the static
# strength $g(f_n)\,\mu$ the hold restored, from the mean $\mu$ over the interface at the end of
# the hold. The peak stays below that strength (the subloading surface approaches the yield
# surface smoothly, and $\mu$ already softens on the way up).


# %%
def peaks(history, strokes, c_n: float):
    """Per hold: hold length, peak |F_t|/A, kinetic level before it, g(f_n) mu after the hold."""
    t = np.array([r["t"] for r in history])
    ft = np.abs(np.array([r["F_t1"] for r in history]) / history[-1]["area"])
    fn = np.array([r["f_n"] for r in history])
    mu = np.array([r["mu"] for r in history])
    rows = []
    for h, t0, t1 in strokes:
        i0 = int(np.argmin(np.abs(t - t0)))
        before = int(np.argmin(np.abs(t - (t0 - h))))
        seg = (t > t0 + 1e-9) & (t <= t1 + 1e-9)
        strength = (1.0 - math.exp(-c_n * fn[i0])) * mu[i0]
        rows.append((h, float(ft[seg].max()), float(ft[before]), float(strength)))
    return rows


# %% [markdown]
# ## Figures


# %%
def figures(result, outdir, strokes, c_n):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = result.history
    t = np.array([r["t"] for r in h])
    area = h[-1]["area"]
    F = np.array([r["F_t1"] for r in h]) / area
    slip = np.array([r["up_t1"] for r in h])
    files = []

    fig, ax = plt.subplots(figsize=(11, 4))
    ax.plot(t, F, lw=1.2)
    for hold, t0, t1 in strokes:
        if hold > 0:
            ax.axvspan(t0 - hold, t0, color="0.85", lw=0)
        seg = (t > t0) & (t <= t1)
        k = np.flatnonzero(seg)[np.argmax(np.abs(F[seg]))]
        up = F[k] > 0
        ax.annotate(
            f"{hold:g} s",
            (t[k], F[k]),
            xytext=(4, 4 if up else -12),
            textcoords="offset points",
            fontsize=8,
        )
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("mean tangential traction $F_{t}/A$ (MPa)")
    ax.set_title("Pad on a plate: reciprocal strokes, holds (grey) before each; peaks labelled")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "force_time.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 5))
    run_in = t <= strokes[0][1] - strokes[0][0] + 1e-9
    ax.plot(slip[run_in], F[run_in], color="0.6", lw=1, label="run-in")
    order = sorted(range(len(strokes)), key=lambda i: strokes[i][0])
    for rank, i in enumerate(order):
        hold, t0, t1 = strokes[i]
        seg = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
        ax.plot(slip[seg], F[seg], color=f"C{rank}", lw=1.5, label=f"after a {hold:g} s hold")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("mean plastic slip $u^p_{1}$ (mm)")
    ax.set_ylabel("mean tangential traction $F_{t}/A$ (MPa)")
    ax.set_title("Force against slip: each stroke starts with a peak")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "force_slip.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    rows = sorted(peaks(h, strokes, c_n))
    hold = np.array([r[0] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(
        hold,
        [r[3] for r in rows],
        "s--",
        color="C2",
        mfc="none",
        label=r"static strength $g(f_n)\,\mu$ at the end of the hold",
    )
    ax.plot(hold, [r[1] for r in rows], "o-", color="C0", label="peak after the hold")
    ax.plot(hold, [r[2] for r in rows], "v:", color="C1", label="kinetic level before the hold")
    ax.set_xlabel("hold time (s)")
    ax.set_ylabel("$|F_{t}|/A$ (MPa)")
    ax.set_ylim(bottom=0)
    ax.set_title("Recovery of static friction with the hold time")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "peak_vs_hold.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    return files


def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=6, help="elements along the pad's side")
    ap.add_argument(
        "--cell", choices=["hexahedron", "tetrahedron"], default="hexahedron", help="cell type"
    )
    ap.add_argument(
        "--holds",
        type=float,
        nargs="+",
        default=[5.0, 60.0, 0.0, 20.0],
        help="hold times in s, one before each stroke",
    )
    ap.add_argument("--amplitude", type=float, default=0.4, help="stroke amplitude in mm")
    ap.add_argument("--pressure", type=float, default=300.0, help="pressure in MPa")
    ap.add_argument(
        "--dt", type=float, default=0.025, help="time step at the start of the strokes in s"
    )
    ap.add_argument(
        "--fields",
        choices=["vtx", "xdmf", "none"],
        default="vtx",
        help="field output for ParaView",
    )
    ap.add_argument("--out", default="demos/output/pad_on_plate", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    fields = None if args.fields == "none" else args.fields
    sc = scene(args.n, args.cell, args.holds, args.amplitude, args.pressure, args.dt, fields)
    _, _, strokes = program(args.amplitude, args.holds, args.dt)
    result = run_scene(sc, outdir=outdir, comm=comm)
    c_n = PRESETS["sec7"].law.c_n
    result.info["peaks"] = peaks(result.history, strokes, c_n)
    if comm.rank == 0:
        for hold, peak, before, strength in sorted(result.info["peaks"]):
            print(
                f"[pad_on_plate] hold {hold:5.1f} s: peak {peak:6.2f} MPa (kinetic before "
                f"{before:5.2f}, restored strength g(f_n) mu {strength:6.2f})"
            )
        if not args.no_figures:
            for f in figures(result, outdir, strokes, c_n):
                print(f"wrote {f}")
    return result


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
