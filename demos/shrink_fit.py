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
r"""# Axisymmetric shrink fit: a hub on a shaft, the contact pressure against Lamé, then pushed off

A steel hub (inner radius $b$, outer radius $c$, length $L$) is shrunk on a solid steel shaft of
radius $b$ with a radial interference $\delta$, then the shaft is pushed out axially. The model
is axisymmetric (coordinates $(r, z)$; every integral, the interface's included, weighted by
$2\pi r$: forces are totals over the circumference), the interference is the interface's initial
gap $g_0 = -\delta$, and both bodies are held in $z$ on their ends, so that the fit is in plane
strain along $z$ and the pressure has a closed form (Lamé):

$$ \delta = p\left[\frac{1}{\alpha_n} + \frac{b(1+\nu)}{E}\,\frac{(1-2\nu)b^2 + c^2}{c^2-b^2}
   + \frac{b(1+\nu)(1-2\nu)}{E}\right] $$

(hub under internal pressure, solid shaft under external pressure, and the penalty's own
compliance $p/\alpha_n$, which the interface adds in series). Then the shaft is moved along $z$ as
a whole (its axial displacement prescribed), the hub held at its ends: the push force is the
shaft's reaction. With Coulomb's law the fit slides when the force reaches
$\mu\,2\pi b L\,p$; the subloading-friction law starts sliding smoothly (its subloading surface
moves from the first increment) and saturates at $2\pi b L\,g(p)\,\mu$.

The mesh is the demo's own: two rectangles meshed together with gmsh, the groups named by the
demo (`shaft`, `hub`, `fit`, `axis`, `hub_ends`), the interface's nodes split with
`meshing.duplicate_interface_nodes`, read with `meshing.read_interface_mesh(..., interfaces=
{"fit": ("hub", "shaft")})`.

    mpirun -n 2 python3 demos/shrink_fit.py [--h 1.25] [--out DIR]
"""

# %%
import argparse
import types
from pathlib import Path

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import CoulombLaw, preset
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    Interface,
    InterfaceProblem,
    LoadStepper,
    Material,
    ProblemSettings,
    StepControl,
)
from subfric_dolfinx.io import gather_interface, interface_summary, write_history_file
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import cli

B, C, L = 10.0, 20.0, 30.0  # mm: shaft radius (hub bore), hub outer radius, length
DELTA = 0.01  # mm, radial interference
E, NU = 2.1e5, 0.3  # MPa, steel (both)
ALPHA = 1e6  # MPa/mm, the interface's penalties
MU = 0.15  # Coulomb's friction coefficient
PUSH = {"coulomb": 0.004, "subloading": 0.2}  # mm, the shaft's axial travel
SIDES = {"fit": ("hub", "shaft")}


def lame_pressure() -> float:
    """The contact pressure of the fit in plane strain, the penalty's compliance included."""
    hub = B * (1 + NU) / E * ((1 - 2 * NU) * B**2 + C**2) / (C**2 - B**2)
    shaft = B * (1 + NU) * (1 - 2 * NU) / E
    return DELTA / (1.0 / ALPHA + hub + shaft)


# %% [markdown]
# ## The mesh: your own gmsh model, your own names


# %%
def build(h: float):
    """Shaft and hub meshed together (gmsh, rank 0), the fit's nodes duplicated."""
    import gmsh

    gmsh.model.add("shrink_fit")
    occ = gmsh.model.occ
    shaft, hub = occ.addRectangle(0, 0, 0, B, L), occ.addRectangle(B, 0, 0, C - B, L)
    occ.fragment([(2, shaft)], [(2, hub)])
    occ.synchronize()
    cells = {"shaft": [], "hub": []}
    for _, t in gmsh.model.getEntities(2):
        cells["shaft" if occ.getCenterOfMass(2, t)[0] < B else "hub"].append(t)
    lines: dict[str, list[int]] = {"fit": [], "axis": [], "hub_ends": []}
    for _, t in gmsh.model.getEntities(1):
        x, y, _ = occ.getCenterOfMass(1, t)
        if abs(x - B) < 1e-9 and 0 < y < L:
            lines["fit"].append(t)
        elif abs(x) < 1e-9:
            lines["axis"].append(t)
        elif x > B and (abs(y) < 1e-9 or abs(y - L) < 1e-9):
            lines["hub_ends"].append(t)
    for name, ents in cells.items():
        gmsh.model.addPhysicalGroup(2, ents, name=name)
    for name, ents in lines.items():
        gmsh.model.addPhysicalGroup(1, ents, name=name)
    for _, t in gmsh.model.getEntities(1):  # a structured-like mesh of size h
        n = max(1, round(occ.getMass(1, t) / h))
        gmsh.model.mesh.setTransfiniteCurve(t, n + 1)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.model.mesh.generate(2)
    meshing.duplicate_interface_nodes(None, SIDES)
    return types.SimpleNamespace(gdim=2)


# %% [markdown]
# ## The problem
#
# The hub is the interface's primary body (its outward normal on the fit points to the axis), the
# shaft its secondary. The axis holds `u_r = 0`; the hub's ends `u_z = 0`; the shaft's `u_z` is
# prescribed everywhere (channel `push`): 0 during the fit (t < 1 s), then up to `PUSH`.


# %%
def problem(domain, law, push: float) -> InterfaceProblem:
    program = LoadingProgram([0.0, 1.0, 2.0], {"push": [0.0, 0.0, 1.0]})
    steel = Material(E, NU)
    return InterfaceProblem.two_bodies(
        domain,
        law,
        {"shaft": steel, "hub": steel},
        program,
        [
            Dirichlet("axis", 0.0, component=0),
            Dirichlet("hub_ends", 0.0, component=1),
            Dirichlet("shaft", push, component=1, amplitude="push"),
        ],
        interface=Interface("fit", initial_gap=-DELTA),
        settings=ProblemSettings(degree=2, mode="axisymmetric"),
    )


def run(domain, law, steps: int, push: float) -> dict:
    """The fit (one step), then the push; the history and the pressure profile after the fit."""
    p = problem(domain, law, push)
    rows, fit = [], {}

    def on_step(rec):
        s = interface_summary(p)
        rows.append(
            {
                "t": rec.t,
                "push": push * max(rec.t - 1.0, 0.0),
                "force": p.reactions["shaft"][1],
                **s,
            }
        )
        if abs(rec.t - 1.0) < 1e-12:
            el = p.interface
            fit.update(gather_interface(el, {"f_n": el.last.traction[:, el.nt]}))

    with FrictionSolver(p, linear="lu") as solver:
        LoadStepper(solver, 1.0 / steps, control=StepControl(hold_dt=1.0), on_step=on_step).run()
    return {"history": rows, "fit": fit, "problem": p}


def laws():
    """Coulomb (mu = 0.15) and the subloading law (Sec. 7 set), with the same penalties."""
    return {
        "coulomb": CoulombLaw(alpha_t=ALPHA, alpha_n=ALPHA, mu_c=MU),
        "subloading": preset("sec7").replace(alpha_t=ALPHA, alpha_n=ALPHA),
    }


# %% [markdown]
# ## What it shows


# %%
def report(results: dict, comm: MPI.Comm) -> dict:
    """The numbers the demo states (every rank); rank 0 prints them."""
    p0 = lame_pressure()
    area = 2 * np.pi * B * L
    fit = results["coulomb"]["fit"]
    fn = fit["f_n"]
    co = results["coulomb"]["history"]
    sub = results["subloading"]["history"]
    onset = MU * area * p0
    force_c = np.array([r["force"] for r in co])
    force_s = np.array([r["force"] for r in sub])
    law_s = laws()["subloading"]
    g = -np.expm1(-law_s.c_n * p0)
    out = {
        "p_lame": p0,
        "p_mean_error": float(np.mean(fn) / p0 - 1.0),
        "p_max_error": float(np.abs(fn / p0 - 1.0).max()),
        "coulomb_onset": onset,
        "coulomb_max": float(force_c.max()),
        "coulomb_onset_error": float(force_c.max() / onset - 1.0),
        "coulomb_F_n": co[-1]["F_n"],
        "subloading_peak": float(force_s.max()),
        "subloading_bound": area * g * law_s.mu_s,
        "subloading_final": float(force_s[-1]),
    }
    if comm.rank == 0:
        print(
            f"Lame (plane strain, penalty included): p = {p0:.4f} MPa; the fit's pressure: "
            f"mean {100 * out['p_mean_error']:+.3f} %, largest deviation "
            f"{100 * out['p_max_error']:.3f} % ({fn.size} interface points)"
        )
        print(
            f"Coulomb (mu = {MU}): slides at {out['coulomb_max']:.1f} N against "
            f"2 pi b L mu p = {onset:.1f} N ({100 * out['coulomb_onset_error']:+.2f} %)"
        )
        print(
            f"subloading law: peak {out['subloading_peak']:.1f} N (saturation bound "
            f"2 pi b L g(p) mu_s = {out['subloading_bound']:.1f} N), "
            f"{out['subloading_final']:.1f} N after {PUSH['subloading']} mm"
        )
    return out


def figure(results: dict, outdir: Path) -> None:
    """The push force of both laws with their bounds; the fit's pressure against Lamé's."""
    import matplotlib.pyplot as plt

    p0 = lame_pressure()
    area = 2 * np.pi * B * L
    law_s = laws()["subloading"]
    fig, ax = plt.subplots(1, 2, figsize=(10.5, 4))
    for k, (name, res) in enumerate(results.items()):
        h = res["history"]
        ax[0].plot(
            [1e3 * r["push"] for r in h], [1e-3 * r["force"] for r in h], color=f"C{k}", label=name
        )
    ax[0].axhline(1e-3 * MU * area * p0, ls=":", c="C0", label=r"Coulomb: $2\pi b L \mu p$")
    ax[0].axhline(
        1e-3 * area * -np.expm1(-law_s.c_n * p0) * law_s.mu_s,
        ls="--",
        c="C1",
        label=r"saturation: $2\pi b L\, g(p)\, \mu_s$",
    )
    ax[0].set_xlabel("push of the shaft (µm)")
    ax[0].set_ylabel("push force (kN, over the circumference)")
    ax[0].legend(fontsize=8)
    ax[0].grid(True, alpha=0.3)
    fit = results["coulomb"]["fit"]
    ax[1].plot(fit["x"][:, 1], 100 * (fit["f_n"] / p0 - 1.0), ".", label="FE, interface points")
    ax[1].axhline(0.0, c="k", ls=":", label=f"Lamé, p = {p0:.2f} MPa")
    ax[1].set_xlabel("z along the fit (mm)")
    ax[1].set_ylabel("contact pressure after the fit, off Lamé's (%)")
    ax[1].legend(fontsize=8)
    ax[1].grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(outdir / "shrink_fit.png", dpi=120)
    plt.close(fig)


# %% [markdown]
# ## The command line


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--h", type=float, default=1.25, help="element size (mm)")
    ap.add_argument("--steps", type=int, default=50, help="steps of the push")
    ap.add_argument("--out", default="demos/output/shrink_fit", help="output directory")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)
    domain, _ = meshing.create_interface_mesh(build, comm, interfaces=SIDES, h=args.h)
    results = {name: run(domain, law, args.steps, PUSH[name]) for name, law in laws().items()}
    out = report(results, comm)
    if comm.rank == 0:
        outdir = Path(args.out)
        outdir.mkdir(parents=True, exist_ok=True)
        columns = {  # the history's own columns (the others: the package's names and units)
            "push": ("mm", "axial displacement of the shaft's end"),
            "force": ("N", "axial force on the shaft (its reaction), over the circumference"),
        }
        for name, res in results.items():  # <law>.csv and <law>.csv-metadata.json (units)
            write_history_file(outdir / f"{name}.csv", res["history"], res["problem"], columns)
        figure(results, outdir)
    return {"results": results, "report": out}


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
