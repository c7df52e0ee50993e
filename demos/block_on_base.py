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
"""# Block on a base: press, slide forward, back, hold, slide again

The main demo of subfric-dolfinx. An aluminium block (A6111-T4 in the paper's Sec. 7), 10 mm long
and 5 mm high, sits on a steel base (tool steel) 20 mm long; the interface between them is a
zero-thickness interface element whose traction follows the subloading-friction law with
saturation, with the paper's Sec. 7 parameter set (normalised reading, see
`subfric_dolfinx.constitutive.presets`) and one change, its normal stiffness (below).

Loading program (1 mm/s sliding as in the paper's experiments):

| time (s)   | what happens                                                   |
|------------|----------------------------------------------------------------|
| 0 - 1      | a pressure of 300 MPa is applied on the top of the block       |
| 1 - 2      | the top of the block is moved +1 mm: static peak, softening    |
| 2 - 4      | moved back to -1 mm: reverse sliding                           |
| 4 - 24     | held still for 20 s: the static friction recovers              |
| 24 - 26    | moved to +1 mm again: a new, smaller peak                      |

Run it on two ranks (`./run demo` does exactly this):

    mpirun -n 2 python3 demos/block_on_base.py [--n 32] [--fields vtx] [--out DIR]

With `--checkpoint-every N` it writes `checkpoint.h5` every N steps; `--restart
DIR/checkpoint.h5` continues from one, on any number of ranks. To stop a run cleanly, send
SIGUSR1 to `mpirun` (`kill -USR1 <pid of mpirun>`): every rank finishes its step, the checkpoint
is written and the demo exits with code 75 and one line (SIGTERM to `mpirun` is followed by a
kill ~0.2 s later, usually too soon; SIGTERM, SIGUSR1 or SIGUSR2 to a single process work alike).

It prints a line per stage of the program on rank 0 (what the interface does at its end: sliding,
sticking, open), the steps and time taken (`-v`: a line per step and the timing breakdown), and
writes the CSV history and two figures into the output directory. PETSc options apply under the
prefix `block_`, e.g. `-block_snes_monitor`.
"""

# %%
import argparse

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.scenes import cli, run_scene

# %% [markdown]
# ## The interface's stiffness
#
# The law's tangential stiffness $\alpha_t = 500$ MPa/mm is part of the calibrated law (the
# elastic part of the slip before sliding, Sec. 7's curves). Its normal stiffness $\alpha_n$ is a
# penalty: the contact itself does not let the bodies interpenetrate, so $\alpha_n$ should be
# stiff relative to the bodies. The paper's 500 MPa/mm would let the block sink 0.6-0.74 mm
# into the base at 300 MPa, a layer as compliant as $\ell = E^*/\alpha_n = 117$ mm of the
# bodies ($E^* = 5.9 \cdot 10^4$ MPa, their contact modulus,
# $1/E^* = (1-\nu_1^2)/E_1 + (1-\nu_2^2)/E_2$): more than ten times the block itself, spreading
# the pressure over the whole contact. The demo uses ten times the stiffness of one interface
# element of the bodies, $\alpha_n = 10 E^*/h \approx 10^6$ MPa/mm with $h = 0.625$ mm at the
# default 16 elements: the block sinks 0.37 µm, $\ell = 0.06$ mm, a tenth of an element.
# The mean friction hardly notices (measured at the default size: the forward and reload peaks
# of the 500 MPa/mm run are 0.3 and 0.5 % higher, its reverse peak 5 %; $10^5$ and $10^6$ agree
# within 0.02 %, `tests/demos/test_fe_demos.py`), but the profiles of $f_n$ along the interface now
# show the pressure the bodies carry (peaks at the block's edges), not the penalty's.
#
# The run stays **small-sliding**: the interface pairs and frames are fixed at the reference
# geometry, so the slide must stay short against the interface elements. The block slides 1 mm,
# 1.6 of its 0.625 mm elements. (`subfric_dolfinx.fem.validity` warns, at the end of a run, about
# a penetration beyond $\max(h, L/10)$ of bodies' material, with $L$ the interface's size, or a
# slide beyond three interface elements; this run gets neither.)


# %%
ALPHA_N = 1e6  # MPa/mm, normal stiffness: 10 E*/h at the default mesh (E* = 5.9e4 MPa)
GEOMETRY = {"base_width": 20.0, "base_height": 5.0, "block_width": 10.0, "block_height": 5.0}

# %% [markdown]
# ## The scene
#
# A scene is a declarative description; the runner builds the mesh (gmsh, with the interface nodes
# duplicated), the problem, the SNES solver and only the outputs asked for.


# %%
def snapshot_times(hold: float) -> list[float]:
    """The interface profiles' times (s): pressed, the peak and end of each stroke, the hold."""
    return [1.0, 1.25, 2.0, 4.0, 4.0 + hold, 4.0 + hold + 1.25, 6.0 + hold]


def scene(
    n: int = 16,
    hold: float = 20.0,
    dt: float = 0.02,
    fields: str | None = None,
    checkpoint_every: int = 0,
) -> dict:
    """The block-on-base scene with ``n`` elements along the interface."""
    t = [0.0, 1.0, 2.0, 4.0, 4.0 + hold, 6.0 + hold]
    snapshots = snapshot_times(hold)
    return {
        "kind": "fe",
        "name": "block_on_base",
        "mesh": {
            "builder": "block_on_base",
            "options": {**GEOMETRY, "n_interface": n, "cell_type": "triangle"},
        },
        "law": {"law": "subloading", "params": {"preset": "sec7", "alpha_n": ALPHA_N}},
        "materials": {
            "primary": {"E": 2.1e5, "nu": 0.3},  # tool steel
            "secondary": {"E": 7.0e4, "nu": 0.33},  # aluminium
        },
        "program": {
            "times": t,
            "channels": {"press": [0, 1, 1, 1, 1, 1], "slide": [0, 0, 1, -1, -1, 1]},
        },
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0]},
            {"group": "top", "component": 0, "value": 1.0, "amplitude": "slide"},
        ],
        "loads": [{"type": "pressure", "group": "top", "value": 300.0, "amplitude": "press"}],
        # the hold in steps of 5 s: nothing moves, the return map integrates the recovery of mu
        # exactly whatever the step (docs/model.md §6.7); the 0.05 s steps of the sliding
        # would take 400 steps there
        "solver": {"prefix": "block_", "dt": dt, "dt_max": 2.5 * dt, "hold_dt": 5.0},
        "outputs": {
            "history": True,
            "fields": fields,
            "snapshots": snapshots,
            "checkpoint_every": checkpoint_every,
        },
    }


# %% [markdown]
# ## Figures
#
# The tangential force on the block against the displacement of its top and against the mean
# plastic slip, and the interface fields along the interface at a few instants.


# %%
def figures(result, outdir, hold):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = result.history
    t = np.array([r["t"] for r in h])
    F = np.array([r["F_t1"] for r in h])
    area = h[-1]["area"]
    top = np.interp(t, [0, 1, 2, 4, 4 + hold, 6 + hold], [0, 0, 1, -1, -1, 1])
    slip = np.array([r["up_t1"] for r in h])
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for a, x, label in (
        (ax[0], top, "top displacement (mm)"),
        (ax[1], slip, "mean slip $u^p$ (mm)"),
    ):
        a.plot(x[t <= 4], F[t <= 4] / area, label="forward and back")
        a.plot(x[t >= 4 + hold], F[t >= 4 + hold] / area, label=f"after a {hold:g} s hold")
        a.set_xlabel(label)
        a.set_ylabel("mean tangential traction $F_t / A$ (MPa)")
        a.grid(True, alpha=0.3)
    ax[0].legend()
    fig.suptitle("Block on a base, 300 MPa: tangential force against slip")
    fig.tight_layout()
    f1 = outdir / "force_slip.png"
    fig.savefig(f1, dpi=120)
    plt.close(fig)

    # each snapshot by its place in the program (snapshot_times); those after the hold dashed, so
    # that the end of the return stroke shows under the end of the hold (the same f_t, f_n, slip)
    phases = dict(
        zip(
            snapshot_times(hold),
            [
                "pressed",
                "forward, at the peak",
                "end of forward",
                "end of back",
                f"end of the {hold:g} s hold",
                "again, at the peak",
                "end",
            ],
            strict=True,
        )
    )
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    for time_, s in sorted(result.snapshots.items()):
        x = s["x"][:, 0]
        phase = phases.get(time_, "")
        style = {"ls": "--" if time_ > 4.0 else "-", "lw": 1.6}
        ax[0, 0].plot(x, s["f_t"][:, 0], label=f"t = {time_:g} s: {phase}", **style)
        ax[0, 1].plot(x, s["f_n"], **style)
        ax[1, 0].plot(x, s["up"][:, 0], **style)
        ax[1, 1].plot(x, s["mu"], **style)
    for a, name in zip(
        ax.ravel(), ["$f_t$ (MPa)", "$f_n$ (MPa)", "slip $u^p$ (mm)", r"$\mu$ (MPa)"], strict=True
    ):
        a.set_ylabel(name)
        a.grid(True, alpha=0.3)
    for a in ax[1]:
        a.set_xlabel("x along the interface (mm)")
    ax[0, 0].legend(fontsize=7, ncol=2)
    fig.suptitle("Interface fields along the interface")
    fig.tight_layout()
    f2 = outdir / "interface_profiles.png"
    fig.savefig(f2, dpi=120)
    plt.close(fig)
    return [f1, f2]


def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements along the interface")
    ap.add_argument("--hold", type=float, default=20.0, help="hold time in s")
    ap.add_argument("--dt", type=float, default=0.02, help="initial time step in s")
    ap.add_argument("--fields", choices=["vtx", "xdmf"], default=None, help="field output")
    ap.add_argument("--out", default="demos/output/block_on_base", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    ap.add_argument(
        "--checkpoint-every", type=int, default=0, help="write checkpoint.h5 every N steps"
    )
    ap.add_argument("--restart", default=None, help="continue from this checkpoint")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    sc = scene(args.n, args.hold, args.dt, args.fields, args.checkpoint_every)
    result = run_scene(sc, outdir=outdir, comm=comm, restart=args.restart)
    if comm.rank == 0 and not args.no_figures:
        for f in figures(result, outdir, args.hold):
            print(f"wrote {f}")
    return result


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
