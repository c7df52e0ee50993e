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
r"""# A clamped joint under a cyclic tangential load: slip that accumulates (ratcheting)

(A lap joint reduced to its essentials: one clamped block on a base.)

Bolted and clamped joints loosen under vibration even when the tangential load never reaches
the force that would make them slide: the paper's introduction names this loosening as one of
the things a friction model should describe. Coulomb's law cannot: below its sliding force a
Coulomb contact is elastic (or, where the stress concentrates, it slips a little in the first
cycle and then shakes down), and the slip does not grow from cycle to cycle.

The subloading-friction law has no purely elastic domain: the subloading surface
$|f_t| = r\,g(f_n)\,\mu$ always passes through the current stress, and every increase of the
stress ratio produces some plastic slip, with a rate $\dot u^p = \dot r / U(r)$ that is small
at low stress ($U(r) = \tilde u \cot(\pi r/2)$ is large) and grows smoothly towards the yield
surface. Unloading is elastic. So a load that pulses between zero and a fraction of the
strength slips forward a little in every loading half-cycle and never slips back: the slip
ratchets. For a point at constant $\mu$ unloaded to zero stress the slip per cycle is
$\frac{2}{\pi\tilde u}\ln\frac{1}{\cos(\pi r_{\max}/2)}$: with $\tilde u = 15$ 1/mm, 9.0 µm
at this demo's $r_{\max} = 0.4$ (the FE run gives 8.97 µm in its first cycle). And since slip
softens $\mu$ towards the kinetic $\mu_k$, each cycle reaches a higher $r_{\max}$ than the
one before: the increments grow, which is the loosening.

## The model

A block (aluminium, the paper's A6111-T4) is clamped on a base (tool steel) by a pressure of
300 MPa on its top. The same top carries a tangential traction $q(t)$ that pulses between 0 and
$q_{\max}$: force control, as a vibration load is. The base is clamped at its bottom; the block
is held only by the interface (whose elastic-plastic tangent stays positive below the yield
surface, so there is no rigid-body mode to suppress).

* This law: the paper's Sec. 7 set (preset `sec7`): static strength at 300 MPa
  $g(f_n)\,\mu_s = 29.1$ MPa, kinetic strength $g(f_n)\,\mu_k = 3.7$ MPa; with one change, a
  stiff interface, $\alpha_t = \alpha_n = 10^5$ MPa/mm instead of 500 (`--alpha`). With the
  paper's soft layer the interface stresses are uniform and Coulomb is simply elastic below its
  sliding force; with a stiff one the shear concentrates at the block's edges, as it does in
  a real joint, and Coulomb slips there a little in the first cycle, which makes the
  comparison a fair one. This law's ratcheting hardly depends on $\alpha$ (the plastic slip
  per cycle comes from $r$ and $U(r)$, not from the elastic part). Stiff against the paper's,
  this penalty is still as compliant as 0.6 mm of the bodies: a choice of the model, which the
  scene declares (`interfaces.interface.intended_compliance`), so the validity check judges only
  how far the bodies overlap (3.5 µm, a twentieth of an interface element).
* Coulomb with the **same peak strength**: $\mu_c = g(p)\,\mu_s / p = 0.097$, so that its
  sliding stress at the clamp pressure equals this law's static strength.
* $q_{\max} = 0.4\,g(p)\,\mu_s = 11.6$ MPa: 40 % of Coulomb's sliding force, and 40 % of
  this law's static strength (though above its kinetic strength: once slipping, the joint
  would not stop; the ratcheting softens $\mu$ towards that point cycle by cycle).
* 15 cycles of 2 s (`--cycles`); the slip per cycle is checked against the material-point
  driver in `tests/demos/test_fe_demos.py`. The block ratchets less than three interface
  elements in all, within the validity of the small-sliding interface (more cycles on this mesh
  would want finite sliding).

| time (s)            | what happens                                           |
|---------------------|--------------------------------------------------------|
| 0 - 1               | the clamp pressure is applied                          |
| 1 + 2k - 2 + 2k     | the traction rises from 0 to $q_{\max}$ (cycle k + 1)  |
| 2 + 2k - 3 + 2k     | and falls back to 0                                    |

Run it on two ranks:

    mpirun -n 2 python3 demos/lap_joint.py [--n 16] [--cycles 15] [--load 0.4] [--out DIR]

It prints progress on rank 0 (`-v`: a line per step, the timing breakdown of each run) and the slip
per cycle, and writes each law's CSV history (`subloading/history.csv`, `coulomb/history.csv`) and
two figures into the output directory. PETSc options apply under the prefixes `lap_sub_` and
`lap_coul_`.
"""

# %%
import argparse
import math

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.scenes import cli, run_scene

PRESSURE = 300.0  # MPa
PERIOD = 2.0  # s
CLAMP_TIME = 1.0  # s
ALPHA = 1e5  # MPa/mm, alpha_t = alpha_n

# %% [markdown]
# ## The scenes
#
# One function makes both: only the law and the solver prefix differ.


# %%
def strength(pressure: float = PRESSURE) -> float:
    """This law's static strength g(p) mu_s at the clamp pressure (Sec. 7 set), MPa."""
    p = PRESETS["sec7"].law
    return (1.0 - math.exp(-p.c_n * pressure)) * p.mu_s


def laws(pressure: float = PRESSURE, alpha: float = ALPHA) -> dict[str, dict]:
    """The two laws: this one (Sec. 7, stiff penalty) and Coulomb with the same peak strength."""
    a = alpha
    mu_c = strength(pressure) / pressure
    return {
        "subloading": {
            "law": "subloading",
            "params": {"preset": "sec7", "alpha_t": a, "alpha_n": a},
        },
        "coulomb": {"law": "coulomb", "params": {"alpha_t": a, "alpha_n": a, "mu_c": mu_c}},
    }


def cycle_ends(cycles: int) -> list[float]:
    """Times at which the traction is back to zero after each cycle."""
    return [CLAMP_TIME + PERIOD * (k + 1) for k in range(cycles)]


def scene(
    law: dict,
    name: str,
    n: int = 16,
    cycles: int = 15,
    load: float = 0.4,
    pressure: float = PRESSURE,
    dt: float = 0.05,
) -> dict:
    """The clamped-joint scene: ``n`` elements along the interface, ``cycles`` load pulses."""
    times, clamp, cyc = [0.0, CLAMP_TIME], [0.0, 1.0], [0.0, 0.0]
    for k in range(cycles):
        t0 = CLAMP_TIME + PERIOD * k
        times += [t0 + 0.5 * PERIOD, t0 + PERIOD]
        clamp += [1.0, 1.0]
        cyc += [1.0, 0.0]
    return {
        "kind": "fe",
        "name": name,
        "mesh": {
            "builder": "block_on_base",
            "options": {"n_interface": n, "cell_type": "quadrilateral"},
        },
        "law": law,
        "materials": {
            "primary": {"E": 2.1e5, "nu": 0.3},  # tool steel base
            "secondary": {"E": 7.0e4, "nu": 0.33},  # aluminium block
        },
        # the stiff-but-soft penalty is the model's (see above): its penetration is judged against
        # the interface element size only
        "interfaces": {"interface": {"intended_compliance": True}},
        "program": {"times": times, "channels": {"clamp": clamp, "cycle": cyc}},
        "dirichlet": [{"group": "bottom", "value": [0.0, 0.0]}],
        "loads": [
            {"type": "pressure", "group": "top", "value": pressure, "amplitude": "clamp"},
            {
                "type": "traction",
                "group": "top",
                "value": [load * strength(pressure), 0.0],
                "amplitude": "cycle",
            },
        ],
        "solver": {"prefix": f"{name}_", "dt": dt, "dt_max": 2.0 * dt},
        "outputs": {"history": True},
    }


# %% [markdown]
# ## What the demo measures
#
# The mean plastic slip over the interface (`up_t1` of the history) at the end of each cycle,
# when the traction is back to zero, and its increments from cycle to cycle.


# %%
def slip_per_cycle(history, cycles: int) -> np.ndarray:
    """Mean plastic slip at the end of each cycle (index 0: before the first cycle)."""
    t = np.array([r["t"] for r in history])
    up = np.array([r["up_t1"] for r in history])
    ends = [CLAMP_TIME, *cycle_ends(cycles)]
    return np.array([up[int(np.argmin(np.abs(t - te)))] for te in ends])


# %% [markdown]
# ## Figures


# %%
def figures(results, cycles, load, outdir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    style = {"subloading": ("C0", "subloading (this law)"), "coulomb": ("C3", "Coulomb")}
    files = []
    fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True, height_ratios=[1, 2.5])
    for name, res in results.items():
        h = res.history
        t = np.array([r["t"] for r in h])
        col, label = style[name]
        ax[1].plot(t, 1e3 * np.array([r["up_t1"] for r in h]), color=col, label=label)
        if name == "subloading":
            ax[0].plot(t, np.array([r["F_t1"] for r in h]) / h[-1]["area"], color="k", lw=1)
    ax[0].set_ylabel("$F_t/A$ (MPa)")
    ax[0].set_title(
        f"Clamped joint, {PRESSURE:g} MPa: traction pulsing to {load:g} x the static strength"
    )
    ax[1].set_ylabel(r"mean plastic slip $u^p$ (µm)")
    ax[1].set_xlabel("time (s)")
    ax[1].legend(fontsize=8)
    for a in ax:
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "slip_time.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    k = np.arange(cycles + 1)
    for name, res in results.items():
        col, label = style[name]
        s = 1e3 * slip_per_cycle(res.history, cycles)
        label += f" (cycle 1: {s[1] - s[0]:.2f} µm, last: {s[-1] - s[-2]:.2f} µm)"
        ax[0].plot(k, s, "o-", color=col, label=label)
        ax[1].plot(k[1:], np.diff(s), "o-", color=col, label=label)
    from matplotlib.ticker import MaxNLocator

    for a in ax:
        a.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax[0].set_xlabel("cycle")
    ax[0].set_ylabel(r"mean plastic slip at the end of the cycle (µm)")
    ax[1].set_xlabel("cycle")
    ax[1].set_ylabel(r"slip increment in the cycle (µm)")
    ax[1].set_ylim(bottom=min(0.0, ax[1].get_ylim()[0]))
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle("Ratcheting: slip accumulated cycle by cycle below the sliding force")
    fig.tight_layout()
    files.append(outdir / "slip_per_cycle.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    return files


def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements along the interface")
    ap.add_argument("--cycles", type=int, default=15, help="number of load cycles")
    ap.add_argument(
        "--load", type=float, default=0.4, help="peak traction over the static strength"
    )
    ap.add_argument("--dt", type=float, default=0.05, help="initial time step in s")
    ap.add_argument("--alpha", type=float, default=ALPHA, help="alpha_t = alpha_n in MPa/mm")
    ap.add_argument("--out", default="demos/output/lap_joint", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    results = {}
    for name, law in laws(PRESSURE, args.alpha).items():
        tag = "lap_sub" if name == "subloading" else "lap_coul"
        sc = scene(law, tag, args.n, args.cycles, args.load, PRESSURE, args.dt)
        results[name] = run_scene(sc, outdir=outdir / name, comm=comm)
    if comm.rank == 0:
        mu_c = laws()["coulomb"]["params"]["mu_c"]
        print(
            f"[lap_joint] static strength g(p) mu_s = {strength():.2f} MPa, Coulomb mu_c = "
            f"{mu_c:.4f}, peak traction {args.load * strength():.2f} MPa"
        )
        for name, res in results.items():
            s = slip_per_cycle(res.history, args.cycles)
            inc = " ".join(f"{1e3 * d:.2f}" for d in np.diff(s))
            print(f"[lap_joint] {name}: slip per cycle (µm) {inc}; total {1e3 * s[-1]:.2f} µm")
            if name == "subloading":
                mu = [r["mu"] for r in res.history]
                print(f"[lap_joint] {name}: mean mu {mu[0]:.1f} -> {mu[-1]:.1f} MPa (softening)")
        if not args.no_figures:
            for f in figures(results, args.cycles, args.load, outdir):
                print(f"wrote {f}")
    return results


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
