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
"""# Block sliding far: the main demo's block slid ten widths along a long base (finite sliding)

The aluminium block of `block_on_base` (10 mm long, 5 mm high, the paper's Sec. 7 law, 300 MPa)
is pressed on a steel base 120 mm long and slid 100 mm, ten times its own width, at 1 mm/s. The
interface is **finite-sliding** (the scene key `interfaces.contact.kinematics:
"finite_sliding"`): the block's points are paired with the base in the current configuration,
so the base carries the block's load where the block is. The two bodies are meshed apart (gmsh,
the demo's own mesh): the base's elements are 1.3 times the block's, so no node of the block
faces a node of the base.

Outputs: the history (forces, mean `mu`, status fractions), the block's mean traction against
the slide and against the material-point driver on the same slip path (the block's points all
slide alike), and the vertical stress `sigma_yy` of the base 1 mm below its surface (probes every
5 mm): its compressed zone travels with the block. Printed on rank 0: the friction at the end
against the material point, and at a few instants the centre of the base's compression against
the block's centre.

    mpirun -n 2 python3 demos/block_sliding_far.py [--n 8] [--slide 100] [--out DIR]
"""

# %%
import argparse
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from subfric_dolfinx import meshing
from subfric_dolfinx.io import collective
from subfric_dolfinx.scenes import cli, run_scene

# %% [markdown]
# ## Geometry and mesh
#
# Two rectangles meshed independently with gmsh (not fragmented: each body has its own nodes on
# the contact), the groups named by the demo: `base`, `block`, `contact` (the base's whole top
# and the block's bottom), `bottom` (held) and `top` (pressed and moved). The file is written by
# rank 0 and read by the scene like any `.msh`.

# %%
BLOCK = 10.0  # mm, the block's width (and height / 2: 5 mm high)
HEIGHT = 5.0  # mm, the block's and the base's height
MARGIN = 5.0  # mm of base before the block and after its end position
ALPHA_N = 1e6  # MPa/mm, block_on_base's normal stiffness
DEPTH = 1.0  # mm, depth of the base's stress probes below its surface


def base_length(slide: float) -> float:
    """The base's length: the block, the slide and a margin at both ends (mm)."""
    return 2 * MARGIN + BLOCK + slide


def write_mesh(path: Path, n: int, slide: float, comm: MPI.Comm) -> None:
    """The block and the base meshed apart, written to ``path`` by rank 0 (collective).

    The block has ``n`` elements along its bottom, the base elements 1.3 times larger; an error
    is raised on every rank.
    """

    def build() -> None:  # rank 0
        with meshing.gmsh_session("block_sliding_far") as gmsh:
            occ = gmsh.model.occ
            length = base_length(slide)
            base = occ.addRectangle(0.0, -HEIGHT, 0.0, length, HEIGHT)
            block = occ.addRectangle(MARGIN, 0.0, 0.0, BLOCK, HEIGHT)
            occ.synchronize()
            h = BLOCK / n
            groups: dict[str, list[int]] = {"contact": [], "bottom": [], "top": []}
            for _, t in gmsh.model.getEntities(1):
                x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, t)
                on_base = x1 - x0 > BLOCK + 1e-6 or (y1 < 1e-6 and y0 < -1e-6)
                size = 1.3 * h if on_base else h
                gmsh.model.mesh.setTransfiniteCurve(t, max(1, round(occ.getMass(1, t) / size)) + 1)
                if abs(y1 - y0) > 1e-6:
                    continue
                y = 0.5 * (y0 + y1)
                key = "contact" if abs(y) < 1e-6 else "bottom" if y < 0 else "top"
                groups[key].append(t)
            gmsh.model.addPhysicalGroup(2, [base], name="base")
            gmsh.model.addPhysicalGroup(2, [block], name="block")
            for name, ents in groups.items():
                gmsh.model.addPhysicalGroup(1, ents, name=name)
            gmsh.option.setNumber("Mesh.MeshSizeMax", 1.3 * h)
            gmsh.model.mesh.generate(2)
            path.parent.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(path))

    collective(comm, build, f"building the mesh {str(path)!r}", error=RuntimeError)


# %% [markdown]
# ## The scene
#
# As `block_on_base`'s, with the interface named and made finite-sliding. A step may slide as far
# as the interface's `reach` (by default its largest facet: 1.3 element sizes of the block), so
# the largest step is 0.8 of the block's element size (at 1 mm/s). The probes are points of the
# base: their `sigma` columns join the history.


# %%
def probes(slide: float) -> dict[str, dict]:
    """Points of the base ``DEPTH`` below its surface, every 5 mm."""
    xs = np.arange(MARGIN, base_length(slide) - MARGIN + 1e-9, 5.0)
    return {f"b{i:02d}": {"x": [float(x), -DEPTH], "body": "base"} for i, x in enumerate(xs)}


def scene(mesh: Path, n: int = 8, slide: float = 100.0) -> dict:
    """The finite-sliding scene on the mesh file ``mesh`` (:func:`write_mesh`)."""
    h = BLOCK / n
    points = probes(slide)
    return {
        "kind": "fe",
        "name": "block_sliding_far",
        "mesh": {"file": str(mesh), "gdim": 2},
        "law": {"law": "subloading", "params": {"preset": "sec7", "alpha_n": ALPHA_N}},
        "materials": {"base": {"E": 2.1e5, "nu": 0.3}, "block": {"E": 7.0e4, "nu": 0.33}},
        "interfaces": {
            "contact": {"primary": "base", "secondary": "block", "kinematics": "finite_sliding"}
        },
        "program": {
            "times": [0.0, 1.0, 1.0 + slide],
            "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]},
        },
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0]},
            {"group": "top", "component": 0, "value": slide, "amplitude": "slide"},
        ],
        "loads": [{"type": "pressure", "group": "top", "value": 300.0, "amplitude": "press"}],
        "points": points,
        "solver": {"prefix": "far_", "dt": min(0.8 * h, 1.0), "dt_max": 0.8 * h},
        "outputs": {
            "history": True,
            "probes": [{"point": p, "fields": ["sigma"]} for p in points],
        },
    }


# %% [markdown]
# ## What the run shows
#
# The mean traction `F_t / A` against the slide, beside the law at one material point slid as
# the block's top (the block's elastic shear and its points' own paths aside: the same kinetic
# friction once it slides), and the centre of the base's compression: the `-sigma_yy`-weighted
# mean of the probes' `x`.


# %%
def material_point(t: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """The scene's law at one point slid as the block's top, at 300 MPa: its ``f_t`` (MPa)."""
    from subfric_dolfinx.scenes.parser import parse_law

    law = parse_law({"law": "subloading", "params": {"preset": "sec7", "alpha_n": ALPHA_N}})
    old = law.initial_state(1, 1)
    new = old.copy()
    out = []
    for i in range(1, t.size):
        gap = np.array([[moved[i], 300.0 / ALPHA_N]])
        res = law.return_map(gap, old, t[i] - t[i - 1], out=new)
        old.assign(new)
        out.append(float(res.traction[0, 0]))
    return np.array([0.0, *out])


def compression_centre(row: dict, names: list[str], xs: np.ndarray) -> float:
    """The ``-sigma_yy``-weighted mean of the probes' ``x`` (where the base is compressed)."""
    s = np.array([-min(row[f"{p}.sigma_yy"], 0.0) for p in names])
    return float(s @ xs / s.sum()) if s.sum() > 0 else float("nan")


class Track(NamedTuple):
    """What the report and the figure read off a run.

    The base's probes (names, x), the history's times, the block top's slide and the material
    point's ``f_t`` (MPa) on the same slide.
    """

    names: list[str]
    xs: np.ndarray
    t: np.ndarray
    moved: np.ndarray
    point: np.ndarray


def track(result, slide: float) -> Track:
    """The run's :class:`Track` (the material point integrated once)."""
    pts = probes(slide)
    names = list(pts)
    t = np.array([r["t"] for r in result.history])
    moved = np.interp(t, [0.0, 1.0, 1.0 + slide], [0.0, 0.0, slide])
    xs = np.array([pts[p]["x"][0] for p in names])
    return Track(names, xs, t, moved, material_point(t, moved))


def report(result, slide: float, tr: Track) -> dict:
    """Friction at the end and the base's compression following the block (rank 0)."""
    h = result.history
    names, xs, t, moved, point = tr
    centre = MARGIN + 0.5 * BLOCK + moved
    found = np.array([compression_centre(r, names, xs) for r in h])
    sliding = t >= 1.0 + 0.2 * slide  # after the first fifth of the slide
    offset = found[sliding] - centre[sliding]
    mean_tr = np.array([r["F_t1"] / r["area"] for r in h])
    # the force that pushes the block (its top's reaction) against the interface's friction
    # force: equal in equilibrium; their difference is what the interface's transfer loses
    push = np.array([r["R_top_x"] for r in h])
    friction = np.array([r["F_t1"] for r in h])
    out = {
        "slide": slide,
        "steps": len(h),
        "newton_max": int(max(r["newton"] for r in h)),
        "friction_end": float(mean_tr[-1] / (h[-1]["F_n"] / h[-1]["area"])),
        "compression_offset_max": float(np.abs(offset).max()),
        "F_n_end": float(h[-1]["F_n"]),
        "material_point_end": float(point[-1] / 300.0),
        "push_end": float(push[-1]),
        "friction_force_end": float(friction[-1]),
        "push_minus_friction_max": float(
            np.abs(push - friction).max() / max(np.abs(friction).max(), 1e-300)
        ),
    }
    print(
        f"slid {slide:g} mm in {len(h)} steps (Newton <= {out['newton_max']} per step); "
        f"friction F_t/F_n at the end {out['friction_end']:.4f} (the material point's "
        f"{out['material_point_end']:.4f}); the base's compression centre "
        f"within {out['compression_offset_max']:.3f} mm of the block's centre over the last "
        "four fifths of the slide"
    )
    print(
        f"the push on the block's top {out['push_end']:.4f} N/mm, the interface's friction "
        f"force {out['friction_force_end']:.4f} N/mm at the end; they differ by at most "
        f"{out['push_minus_friction_max']:.2e} of the peak friction force over the run"
    )
    for tt in np.linspace(1.0 + 0.2 * slide, 1.0 + slide, 5):
        i = int(np.argmin(np.abs(t - tt)))
        print(
            f"  t = {t[i]:7.2f} s: block centre {centre[i]:7.2f} mm, base compressed around "
            f"{found[i]:7.2f} mm, F_t/A {mean_tr[i]:7.2f} MPa"
        )
    return out


def figure(result, slide: float, tr: Track, outdir: Path) -> Path:
    """Mean traction against the slide; the base's sigma_yy along its length at five instants."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = result.history
    names, xs, t, moved, point = tr
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].plot(moved, [r["F_t1"] / r["area"] for r in h], label="block (finite sliding)")
    ax[0].plot(moved, point, "--", label="material point, same slide")
    ax[0].legend(fontsize=8)
    ax[0].set_xlabel("slide of the block's top (mm)")
    ax[0].set_ylabel("mean tangential traction $F_t / A$ (MPa)")
    ax[0].grid(True, alpha=0.3)
    for tt in np.linspace(1.0, 1.0 + slide, 5):
        i = int(np.argmin(np.abs(t - tt)))
        ax[1].plot(xs, [h[i][f"{p}.sigma_yy"] for p in names], label=f"slide {moved[i]:.0f} mm")
    ax[1].set_xlabel(f"x along the base, {DEPTH:g} mm below its surface (mm)")
    ax[1].set_ylabel(r"$\sigma_{yy}$ of the base (MPa)")
    ax[1].legend(fontsize=7)
    ax[1].grid(True, alpha=0.3)
    fig.suptitle(f"Block slid {slide:g} mm along a long base (finite sliding, 300 MPa)")
    fig.tight_layout()
    path = outdir / "block_sliding_far.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=8, help="elements along the block's bottom")
    ap.add_argument("--slide", type=float, default=100.0, help="slide of the block (mm)")
    ap.add_argument("--out", default="demos/output/block_sliding_far", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    return ap


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)
    outdir = Path(args.out)
    mesh = outdir / "block_sliding_far.msh"
    write_mesh(mesh, args.n, args.slide, comm)
    result = run_scene(scene(mesh, args.n, args.slide), outdir=outdir, comm=comm)
    out = {"result": result}
    if comm.rank == 0:
        tr = track(result, args.slide)
        out["report"] = report(result, args.slide, tr)
        if not args.no_figures:
            print(f"wrote {figure(result, args.slide, tr, outdir)}")
    return out


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
