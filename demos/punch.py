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
r"""# A flat punch at high pressure: saturation of the tangential stress, against Coulomb

A narrow, stiff flat punch (cemented carbide, 0.5 mm wide) is pressed into an aluminium base and
then slid sideways. Under a rigid flat punch the contact pressure is far from uniform: elastic
theory gives $p(x) \propto 1/\sqrt{a^2 - x^2}$, infinite at the edges $x = \pm a$. The
subloading-friction law bounds the tangential stress by $g(f_n)\,\mu$ with
$g(f_n) = 1 - e^{-c_n f_n}$, which *saturates* at high pressure; Coulomb's bound $\mu_c f_n$
grows without limit. Under the punch edges the two laws must therefore differ, and this demo
shows by how much: the same mesh, the same loading, once with each law.

## Making the pressure peaks visible: the penalty stiffness

The interface is a penalty layer, $f_n = \alpha_n \bar u_n$. In series with the bulk it smooths
the pressure over a length of about $\ell = E^*/\alpha_n$ ($E^*$ the plane-strain modulus of
the softer body, 79 GPa here). With the paper's $\alpha = 500$ MPa/mm that length is 160 m: the
layer is so soft that the punch sinks into it uniformly and the pressure is flat. Only when
$\ell$ is small compared with the punch (and comparable to an element) do the edge peaks
appear. Peak over mean pressure under the punch for this mesh (16 elements across the punch),
measured with this scene's geometry:

| $\alpha_n$ (MPa/mm) | 500  | 1e4  | 1e5  | 1e6  | 1e7  |
|---------------------|------|------|------|------|------|
| $\ell$ (mm)         | 160  | 7.9  | 0.79 | 0.079| 0.0079 |
| peak / mean         | 1.00 | 1.02 | 1.15 | 1.87 | 3.29 |

(1.95 at $\alpha_n = 10^6$ with 32 elements: the penalty regularises the edge singularity over
$\ell$, so the peak converges with the mesh.) The demo uses $\alpha_t = \alpha_n = 10^6$ MPa/mm
(`--alpha` changes both).

## Parameters of the two laws

* This law: the paper's Sec. 7 set (preset `sec7`, $\mu_s = 500$, $\mu_k = 63$ MPa,
  $\kappa = 98/63$ 1/mm, $\xi = 11/500$ 1/s, $\tilde u = 15$ 1/mm) with the stiff penalties and
  **$c_n = 10^{-3}$ 1/MPa** instead of $2\cdot 10^{-4}$: the punch is pressed to a mean pressure
  of about 1000 MPa, with peaks near 1900 MPa at the edges, so $c_n f_n = 1$ at the mean and
  about 2 at the peaks: $g$ = 0.63 at the mean and 0.85 at the peaks, well into the saturation
  range. (With the paper's $c_n$, $g$ would be almost linear up to several GPa.)
* Coulomb: $\mu_c$ is calibrated to **this law at the mean pressure**: it is the ratio
  $f_t/f_n$ that this law gives for a uniform contact at the mean pressure $\bar p$, slid the
  same distance at the same rate (computed with the material-point driver, so with the same
  softening of $\mu$ from $\mu_s$ towards $\mu_k$ and the same smooth approach to the yield
  surface). A uniformly loaded contact would therefore carry the same friction with both laws;
  every difference between the two runs comes from the non-uniform pressure. Coulomb has no
  static peak and no softening: the comparison is made at the end of the slide, where the whole
  interface slides under both laws.

## Loading (1 mm/s sliding, as the paper's Sec. 7 tests)

| time (s) | what happens                                                                |
|----------|-----------------------------------------------------------------------------|
| 0 - 1    | the top of the punch is pushed down 8.3 µm (mean pressure about 1000 MPa)   |
| 1 - 1.08 | the top is moved 0.08 mm sideways, the depth held: the punch slides         |

The top of the punch is held by a stiff fixture: both displacement components are prescribed
there, so the moment of the friction force is taken by the fixture and the punch does not tilt.
The base is clamped at its bottom.

The slide is short, 2.6 of the interface elements: the interface is small-sliding (its pairs
stay those of the reference geometry), valid while the slide stays within a few elements, and
the whole interface slides long before that. The penalty's compliance is chosen on purpose (the
table above): the scene declares it (`interfaces.interface.intended_compliance`), so the
validity check judges only how far the bodies overlap (2 µm, a fifteenth of an element).

## What it shows (default run)

The mean pressure is 996 MPa and Coulomb's calibrated $\mu_c = 0.257$. At the end of the slide
the whole interface slides under both laws and the pressure is the same under both (2029 MPa at
the edge points, 786 MPa in the middle). Under the highest pressure this law carries
$f_t = 350$ MPa, close to its bound $g(f_n)\,\mu = 392$ MPa ($\mu$ = 451 MPa: 0.08 mm of slip
has softened it a tenth of the way from 500 to its kinetic level) and below the static bound
$g(f_n)\,\mu_s = 434$ MPa; Coulomb carries $\mu_c f_n = 521$ MPa there, 49 % more. In the
middle, under less than the mean pressure, it is the other way round (219 against 202 MPa): the
concave $g$ gives more to low pressures and less to high ones. The two friction forces are
nearly equal (249 and 256 MPa on average), as the calibration intends: what differs is *where*
the tangential stress sits, which matters for wear, fretting and crack initiation at the edges
of a contact. In `ft_vs_fn.png` the points of this law lie on the curve $g(f_n)\,\mu$, their
$f_t/f_n$ falling with $f_n$; Coulomb's lie on the straight line $\mu_c f_n$.

Run it on two ranks:

    mpirun -n 2 python3 demos/punch.py [--n 16] [--alpha 1e6] [--out DIR]

It prints progress on rank 0 (`-v`: a line per step and the timing breakdown of each run), and
writes each law's CSV history (`subloading/history.csv`, `coulomb/history.csv`) and three figures
into the output directory. PETSc options apply under the prefixes `punch_sub_` and `punch_coul_`.
"""

# %%
import argparse

import numpy as np
from mpi4py import MPI

from subfric_dolfinx.constitutive import build_law
from subfric_dolfinx.driver import run_case
from subfric_dolfinx.scenes import cli, run_scene

SLIDE = 0.08  # mm, at 1 mm/s: within small sliding's validity (3 elements at the default n)
DEPTH = 0.0083  # mm: mean pressure about 1000 MPa with alpha_n = 1e6
C_N = 1e-3  # 1/MPa

# %% [markdown]
# ## The scenes
#
# One function makes both: only the law and the solver prefix differ.


# %%
def subloading_law(alpha: float = 1e6, c_n: float = C_N) -> dict:
    """The law of this demo: the Sec. 7 set with stiff penalties and a larger c_n."""
    return {
        "law": "subloading",
        "params": {"preset": "sec7", "alpha_t": alpha, "alpha_n": alpha, "c_n": c_n},
    }


def scene(law: dict, name: str, n: int = 16, depth: float = DEPTH, dt: float = 0.01) -> dict:
    """The punch scene with ``n`` elements across the punch."""
    return {
        "kind": "fe",
        "name": name,
        "mesh": {
            "builder": "block_on_base",
            "options": {
                "n_interface": n,
                "cell_type": "quadrilateral",
                "base_width": 3.0,
                "base_height": 1.0,
                "block_width": 0.5,
                "block_height": 0.5,
            },
        },
        "law": law,
        "materials": {
            "primary": {"E": 7.0e4, "nu": 0.33},  # aluminium base
            "secondary": {"E": 6.0e5, "nu": 0.22},  # cemented-carbide punch
        },
        # the penalty's compliance is the model's (the table above): its penetration is judged
        # against the interface element size only
        "interfaces": {"interface": {"intended_compliance": True}},
        "program": {
            "times": [0.0, 1.0, 1.0 + SLIDE],
            "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]},
        },
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0]},
            {"group": "top", "component": 0, "value": SLIDE, "amplitude": "slide"},
            {"group": "top", "component": 1, "value": -depth, "amplitude": "press"},
        ],
        "solver": {"prefix": f"{name}_", "dt": dt, "dt_max": 2.5 * dt},
        "outputs": {"history": True, "snapshots": [1.0, 1.0 + SLIDE]},
    }


# %% [markdown]
# ## Calibrating Coulomb
#
# The material-point driver runs this law at one point: pressed to the mean pressure, then slid
# by the same distance at the same rate. Its $f_t/f_n$ at the end is Coulomb's $\mu_c$.


# %%
def calibrate_mu_c(law: dict, p_mean: float) -> float:
    """Coulomb's mu_c: this law's f_t / f_n at the end of the same slide, at the mean pressure."""
    params = build_law(law)
    un = p_mean / params.alpha_n
    res = run_case(
        {
            **law,
            "control": "disp",
            "n_tangential": 1,
            "path": [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, un], [1.0 + SLIDE, SLIDE, 0.0, un]],
            "t_samples": [1.0 + SLIDE],
            "steps_per_mm": 2000,
        }
    )
    return float(res.samples["f_t1"][-1] / res.samples["f_n"][-1])


# %% [markdown]
# ## What the demo measures
#
# At the end of the slide, for each law: the interface profiles $f_n(x)$, $f_t(x)$, and at the
# point of highest pressure the tangential stress of each law against both bounds.


# %%
def summary(sub, coul, mu_c: float, c_n: float, mu_s: float) -> dict:
    """Key numbers at the end of the slide (the highest-pressure point of the subloading run)."""
    end = max(sub.snapshots)
    s, c = sub.snapshots[end], coul.snapshots[end]
    i = int(np.argmax(s["f_n"]))
    fn = float(s["f_n"][i])
    g = 1.0 - np.exp(-c_n * fn)
    area = sub.history[-1]["area"]
    return {
        "p_mean": sub.history[-1]["f_n"],
        "fn_peak": fn,
        "x_peak": float(s["x"][i, 0]),
        "ft_sub": float(s["f_t"][i, 0]),
        "ft_coul": float(c["f_t"][i, 0]),
        "g_mu_s": float(g * mu_s),
        "g_mu": float(g * s["mu"][i]),
        "mu_c_fn": mu_c * fn,
        "F_sub": sub.history[-1]["F_t1"] / area,
        "F_coul": coul.history[-1]["F_t1"] / area,
    }


# %% [markdown]
# ## Figures


# %%
def top_slide(t: np.ndarray) -> np.ndarray:
    """The sideways displacement of the punch's top (mm) at the times ``t`` (s).

    The scene's ``slide`` channel (0 until t = 1, then up to 1 at t = 1 + SLIDE) times ``SLIDE``.
    """
    return SLIDE * np.clip((np.asarray(t, dtype=float) - 1.0) / SLIDE, 0.0, 1.0)


def figures(sub, coul, mu_c, c_n, mu_s, outdir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    end = max(sub.snapshots)
    s, c = sub.snapshots[end], coul.snapshots[end]
    files = []

    fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for snap, label, col in ((s, "subloading (this law)", "C0"), (c, "Coulomb", "C3")):
        x = snap["x"][:, 0]
        ax[0].plot(x, snap["f_n"], "o-", ms=3, color=col, label=label)
        ax[1].plot(x, snap["f_t"][:, 0], "o-", ms=3, color=col, label=label)
    # the bounds, as wide pale bands under the points: at full sliding the points lie on them
    x = s["x"][:, 0]
    bound = (1 - np.exp(-c_n * s["f_n"])) * s["mu"]
    ax[1].plot(x, bound, "-", color="C0", lw=6, alpha=0.25, label=r"bound $g(f_n)\,\mu$")
    ax[1].plot(x, mu_c * c["f_n"], "-", color="C3", lw=6, alpha=0.25, label=r"bound $\mu_c f_n$")
    ax[0].set_ylabel("contact pressure $f_n$ (MPa)")
    ax[1].set_ylabel("tangential stress $f_t$ (MPa)")
    ax[1].set_xlabel("x along the interface (mm); the punch spans 1.25 - 1.75")
    ax[0].set_ylim(bottom=0)
    ax[1].set_ylim(bottom=0)
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(fontsize=8)
    ax[0].set_title(f"Flat punch, end of a {SLIDE:g} mm slide: the pressure peaks at the edges")
    fig.tight_layout()
    files.append(outdir / "profiles.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 5.5))
    fmax = 1.1 * max(s["f_n"].max(), c["f_n"].max())
    f = np.linspace(0.0, fmax, 200)
    g = 1 - np.exp(-c_n * f)
    ax.plot(f, g * mu_s, ":", color="C0", lw=1, label=r"$g(f_n)\,\mu_s$ (static bound)")
    mu_end = float(np.mean(s["mu"]))
    ax.plot(
        f,
        g * mu_end,
        "-",
        color="C0",
        lw=1,
        label=rf"$g(f_n)\,\mu$, $\mu$ = {mu_end:.0f} MPa (mean at the end)",
    )
    ax.plot(f, mu_c * f, "-", color="C3", lw=1, label=rf"$\mu_c f_n$, $\mu_c$ = {mu_c:.3f}")
    ax.plot(s["f_n"], s["f_t"][:, 0], "o", color="C0", ms=4, label="subloading, interface points")
    ax.plot(
        c["f_n"],
        c["f_t"][:, 0],
        "s",
        color="C3",
        ms=4,
        mfc="none",
        label="Coulomb, interface points",
    )
    ax.set_xlim(0, fmax)
    top = max(mu_c * fmax, (g * mu_end).max(), s["f_t"].max(), c["f_t"].max())
    ax.set_ylim(0, 1.15 * top)  # the static bound g mu_s runs off the top: it is far above
    ax.set_xlabel("contact pressure $f_n$ (MPa)")
    ax.set_ylabel("tangential stress $f_t$ (MPa)")
    ax.set_title("Saturation: the tangential stress against the pressure")
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "ft_vs_fn.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for res, label, col in ((sub, "subloading (this law)", "C0"), (coul, "Coulomb", "C3")):
        h = res.history
        t = np.array([r["t"] for r in h])
        F = np.array([r["F_t1"] for r in h]) / h[-1]["area"]
        ax.plot(top_slide(t), F, color=col, marker=".", ms=4, label=label)
    ax.set_xlabel("sideways displacement of the punch top (mm)")
    ax.set_ylabel("mean tangential stress $F_t/A$ (MPa)")
    ax.set_title("Friction force of the punch")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    files.append(outdir / "force_displacement.png")
    fig.savefig(files[-1], dpi=120)
    plt.close(fig)
    return files


def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements across the punch")
    ap.add_argument("--alpha", type=float, default=1e6, help="alpha_t = alpha_n in MPa/mm")
    ap.add_argument("--c-n", type=float, default=C_N, help="c_n in 1/MPa")
    ap.add_argument("--depth", type=float, default=DEPTH, help="indentation in mm")
    ap.add_argument("--dt", type=float, default=0.01, help="initial time step in s")
    ap.add_argument("--out", default="demos/output/punch", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)  # one-dash options go to PETSc
    outdir = Path(args.out)
    law = subloading_law(args.alpha, args.c_n)
    sub = run_scene(
        scene(law, "punch_sub", args.n, args.depth, args.dt),
        outdir=outdir / "subloading",
        comm=comm,
    )
    p_mean = sub.history[-1]["f_n"]
    mu_c = calibrate_mu_c(law, p_mean)
    if comm.rank == 0:
        print(f"[punch] mean pressure {p_mean:.1f} MPa: Coulomb calibrated to mu_c = {mu_c:.4f}")
    coulomb = {
        "law": "coulomb",
        "params": {"alpha_t": args.alpha, "alpha_n": args.alpha, "mu_c": mu_c},
    }
    coul = run_scene(
        scene(coulomb, "punch_coul", args.n, args.depth, args.dt),
        outdir=outdir / "coulomb",
        comm=comm,
    )
    mu_s = build_law(law).mu_s
    key = summary(sub, coul, mu_c, args.c_n, mu_s)
    sub.info["punch"] = {**key, "mu_c": mu_c}
    if comm.rank == 0:
        print(
            f"[punch] highest pressure {key['fn_peak']:.0f} MPa at x = {key['x_peak']:.3f} mm "
            f"(mean {key['p_mean']:.0f}): f_t = {key['ft_sub']:.1f} MPa with this law "
            f"(bounds g mu = {key['g_mu']:.1f}, g mu_s = {key['g_mu_s']:.1f}), "
            f"{key['ft_coul']:.1f} MPa with Coulomb (mu_c f_n = {key['mu_c_fn']:.1f})"
        )
        print(
            f"[punch] mean friction stress at the end: {key['F_sub']:.1f} MPa (this law), "
            f"{key['F_coul']:.1f} MPa (Coulomb)"
        )
        if not args.no_figures:
            for f in figures(sub, coul, mu_c, args.c_n, mu_s, outdir):
                print(f"wrote {f}")
    return sub, coul


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
