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
"""# Hertz contact of a cylinder on a flat (2-D plane strain), checked against the closed form.

Two flat bodies with the initial gap ``g0 = x**2 / 2R`` on their interface stand for a cylinder
of radius ``R`` pressed on a flat; the contact half-width and the pressure are compared with
Hertz's solution for the measured load.
"""

# %% [markdown]
r"""
## Hertz: a cylinder pressed on a flat, against the closed form

A long cylinder of radius $R$ pressed on a flat by a force $P$ per unit length touches it over
a strip of half-width $a$ under the elliptical pressure

$$p(x) = p_0\sqrt{1 - x^2/a^2},\qquad a = \sqrt{\frac{4PR}{\pi E^*}},\qquad
  p_0 = \frac{2P}{\pi a} = \sqrt{\frac{PE^*}{\pi R}},$$

with the plane-strain contact modulus $1/E^* = (1-\nu_1^2)/E_1 + (1-\nu_2^2)/E_2$ (Hertz 1882;
Johnson, *Contact Mechanics*, 1985, Sec. 4.3). Near the contact the cylinder's surface is the
parabola $x^2/2R$ above the flat, and the theory treats both bodies as half-planes, so the
problem is that of **two flat bodies whose interface starts open by $g_0(x) = x^2/2R$**: the
initial gap of the scene (`"initial_gap": {"parabola": {"R": R, "center": ...}}`), which the
interface law sees as $\bar u_n - g_0$. Points outside the contact stay SEPARATED.

## The model and what makes it close to the theory

* **Half-planes**: the bodies are $2L \times L$ boxes with $L = 50$ mm, 50 times the contact
  half-width ($a \approx 1$ mm). The mesh (P2 triangles) is fine ($h = a_t/n$, $a_t = 1$ mm)
  within $1.5 a_t$ of the first touch and grows by 0.25 per mm beyond, up to $L/4$
  (`far_size`, `refine_radius` of the builder): a few thousand cells.
* **Stiff penalty**: $\alpha_n = \alpha_t = 10^8$ MPa/mm. The penalty smooths the pressure over
  about $E^*/\alpha_n = 1.2$ µm ($a/870$) and adds $p_0/\alpha_n = 0.012$ µm to the approach,
  0.1 % of the gap closed at the contact edge ($a^2/2R = 10$ µm).
* **Same material** (steel, $E = 210$ GPa, $\nu = 0.3$, so $E^* = 115$ GPa): with elastically
  similar bodies the normal load makes no tangential traction (Dundurs' $\beta = 0$), so the
  friction law (Coulomb, $\mu = 0.3$) plays no part here; it does in `cattaneo_mindlin.py`.
* **Loading**: the bottom of the flat is clamped and the top of the cylinder's body is moved
  down by $\delta = 50$ µm (and held sideways) in ten steps; $P$ is the reaction on the top.
  The theory is compared at the measured $P$ ($a$ and $p_0$ are functions of $P$ only; the
  approach of 2-D bodies depends on their size, the contact does not).

## What is measured

* $a$, two ways: the **edge** (where the law's normal input $\bar u_n - g_0$ changes sign
  between neighbouring quadrature points, interpolated linearly; accurate to about a point
  spacing) and the **fit** of $p^2 = p_0^2(1 - (x - x_c)^2/a^2)$ to the points carrying more than
  30 % of the peak (least squares; its $p_0$ too);
* the peak pressure, and the error of $p(x)$ against $p_H(x)$ (relative to $p_0$): its largest
  value over $|x| \le 0.8 a_H$, over the whole contact, and its RMS over the points in
  $|x| \le a_H$ (the points are evenly spaced there: an $L^2$ norm). Next to the edge the
  pressure falls like a square root, which the element holding the edge cannot follow: the
  largest error over the whole contact stays at several per cent; its RMS falls with $h$.

## What it gives

Errors against Hertz at the measured load ($P$ = 1980 N/mm, $a_H$ = 1.045 mm,
$p_0$ = 1206 MPa), for 4, 8 and 16 elements per half-width ($h$ = 0.25, 0.125, 0.0625 mm):

| `--n` | $a$ fit | $a$ edge | peak $p$ | $p_0$ fit | $e_{0.8}$ | $e_{max}$ | RMS |
|---|---|---|---|---|---|---|---|
| 4  | +0.054 % | -5.9 % | -0.32 % | -0.14 % | 0.48 % | 0.48 % | 0.29 % |
| 8  | +0.008 % | -4.0 % | +0.011 % | -0.070 % | 0.26 % | 0.49 % | 0.19 % |
| 16 | +0.064 % | +0.73 % | -0.000 % | -0.025 % | 0.049 % | 3.0 % | 0.59 % |

($e_{0.8}$: largest $|p - p_H|/p_0$ over $|x| \le 0.8a$; $e_{max}$: over the whole contact.)
The fitted half-width sits at a few hundredths of a per cent from the start (what remains is
of the size of the penalty's and the finite bodies' effects); the edge is found within the
spacing of the points ($h/2$); the interior error falls with $h$, while the largest error over
the whole contact is set by the element that holds the edge. The interface is integrated at
the nodes (`"quadrature": "nodal"`): with Gauss points the same meshes give an oscillating
traction next to the edge and larger errors (fitted half-width +0.73, +0.22, +0.009 %; interior
error 1.1, 0.92, 0.22 %; and in `cattaneo_mindlin.py` a tangential traction oscillating by
$\pm 170$ MPa between the two points of an element at `--n 4`).

    mpirun -n 2 python3 demos/hertz.py [--n 16] [--meshed-apart] [--out DIR]

PETSc options go under the prefix `hertz_` (e.g. `-hertz_snes_monitor`).
"""

# %%
import argparse
import math

# %%
import numpy as np
from mpi4py import MPI

# %%
from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.io import collective
from subfric_dolfinx.scenes import cli, run_scene

# %%
E, NU = 2.1e5, 0.3  # MPa, steel (both bodies)
R = 50.0  # mm, radius of the cylinder
A_TARGET = 1.0  # mm, about the contact half-width at the default approach
L = 50.0  # mm: the bodies are 2L wide and L high
ALPHA = 1e8  # MPa/mm, normal and tangential penalty
DELTA = 0.05  # mm, approach of the top face
MU = 0.3  # Coulomb's friction coefficient (inactive under normal load alone)


# %%
def contact_modulus(E1: float = E, nu1: float = NU, E2: float = E, nu2: float = NU) -> float:
    """Plane-strain contact modulus ``E*``: ``1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2`` (MPa)."""
    return 1.0 / ((1 - nu1**2) / E1 + (1 - nu2**2) / E2)


# %%
def hertz(P: float, radius: float = R, Estar: float | None = None) -> tuple[float, float]:
    """Hertz's half-width ``a`` (mm) and peak pressure ``p0`` (MPa) for a load ``P`` (N/mm)."""
    Es = contact_modulus() if Estar is None else Estar
    a = math.sqrt(4.0 * P * radius / (math.pi * Es))
    return a, 2.0 * P / (math.pi * a)


# %% [markdown]
"""
## The scene

`cattaneo_mindlin.py` reuses it with a second channel that moves the top sideways.
"""


# %% [markdown]
r"""
## The bodies meshed apart (`--meshed-apart`)

The same two boxes meshed independently with gmsh (not fragmented: each body has its own nodes
on the contact), the flat's elements 2/3 of the cylinder's everywhere (3 : 2 across the contact,
so no node of one faces a node of the other but at the ends), with the same grading. The
interface is then finite-sliding (`interfaces.contact.kinematics: "finite_sliding"`): the
cylinder's points (the secondary side, at the matched mesh's resolution) are projected on the flat's
facets and the flat's nodes receive the segment transfer of their tractions.

Measured (`--meshed-apart`, 1 and 2 ranks alike), against the matched meshes above:

| `--n` | mesh | $a$ fit | $a$ edge | peak $p$ | $p_0$ fit | $e_{0.8}$ | $e_{max}$ | RMS |
|---|---|---|---|---|---|---|---|---|
| 4 | matched | +0.054 % | -5.9 % | -0.32 % | -0.14 % | 0.48 % | 0.48 % | 0.29 % |
| 4 | apart | +0.21 % | -5.8 % | +0.014 % | +0.041 % | 0.57 % | 0.65 % | 0.32 % |
| 6 | matched | -0.087 % | -5.2 % | +0.011 % | -0.11 % | 0.42 % | 2.0 % | 0.53 % |
| 6 | apart | +0.011 % | -5.2 % | -0.047 % | -0.028 % | 0.29 % | 2.1 % | 0.59 % |
| 8 | matched | +0.008 % | -4.0 % | +0.011 % | -0.070 % | 0.26 % | 0.49 % | 0.19 % |
| 8 | apart | +0.20 % | -4.1 % | -0.027 % | -0.046 % | 0.067 % | 0.83 % | 0.28 % |

The same accuracy as the matched meshes, the largest error included: it is that of the P2 nodal
point nearest the contact's edge, set by where the edge falls between the cylinder's nodes (2.0
% at `--n 6` on both meshes; the matched meshes' at 5, 7, 10, 12, 16: 1.2, 1.4, 1.7, 1.6, 3.0
%). The cylinder's mesh is the same with any `ratio` (the size cap is the larger body's), so
`ratio` 1 is the matched twin of the apart mesh. (Before this cap the cylinder's elements far
from the contact were capped at the flat's size, which moved its nodes near the edge: the largest
error was then 2.5, 4.6, 5.1 % at `--n` 4, 6, 8, from the nodes alone.) The segment transfer
gives the flat the forces the cylinder's nodes get by their nodal rule (the dual basis of mortar
methods): with equal element sizes, whose interface nodes coincide, the finite-sliding
interface gives the small-sliding one's pressures within 1e-4 of $p_0$
(`tests/verification/test_verification_demos.py`). With the flat coarser instead (`ratio` 1.5:
the cylinder's points the finer side) the pressure oscillates by about 1 % of $p_0$ between
neighbouring points (`--n 4`: $e_{0.8}$ = 1.1 %, $e_{max}$ = 2.4 %, $a$ fit +0.74 %; `--n 6`:
1.3 %, 4.0 %, +1.5 %): stiff penalty points finer than the primary surface they are pressed on.
Both converge (`--n 6` stopped at the edge while the transfer was the consistent mass). Newton
takes its most iterations at the first touch (the records `hertz_apart_n4` and `hertz_apart_n8`
say how many), fewer once the contact has formed: the press closes several points a step as the
contact grows.
"""


# %%
def write_apart_mesh(path, n: int, comm: MPI.Comm, ratio: float = 2.0 / 3.0) -> None:
    """The flat (``base``) and the cylinder's body (``block``) meshed apart, written by rank 0.

    The block's element size is that of :func:`scene` (``A_TARGET / n`` near the first touch,
    graded to ``L / 4``), the base's ``ratio`` times it; the block's mesh does not depend on
    ``ratio`` (``ratio`` 1 is the matched twin: the same block, the base's contact nodes on the
    block's). Collective: an error is raised on every rank.
    """
    from pathlib import Path

    def build() -> None:  # rank 0
        with meshing.gmsh_session("hertz_apart") as gmsh:
            occ = gmsh.model.occ
            base = occ.addRectangle(0.0, 0.0, 0.0, 2 * L, L)
            block = occ.addRectangle(0.0, L, 0.0, 2 * L, L)
            occ.synchronize()
            f = gmsh.model.mesh.field
            h, far = A_TARGET / n, L / 4
            dist = f"Max(0, Sqrt((x-{L!r})^2+(y-{L!r})^2) - {1.5 * A_TARGET!r})"
            restricted = []
            for surface, scale in ((block, 1.0), (base, ratio)):
                grade = f.add("MathEval")
                size = f"Min({scale * far!r}, {scale * h!r} + {scale * 0.25!r}*{dist})"
                f.setString(grade, "F", size)
                curves = [c for _, c in gmsh.model.getBoundary([(2, surface)], oriented=False)]
                points = {p for _, p in gmsh.model.getBoundary([(2, surface)], recursive=True)}
                only = f.add("Restrict")
                f.setNumber(only, "InField", grade)
                f.setNumbers(only, "SurfacesList", [surface])
                f.setNumbers(only, "CurvesList", curves)
                f.setNumbers(only, "PointsList", sorted(points))
                restricted.append(only)
            both = f.add("Min")
            f.setNumbers(both, "FieldsList", restricted)
            f.setAsBackgroundMesh(both)
            for option, value in (
                ("Mesh.MeshSizeMax", max(1.0, ratio) * far),
                ("Mesh.MeshSizeExtendFromBoundary", 0),
                ("Mesh.MeshSizeFromPoints", 0),
                ("Mesh.MeshSizeFromCurvature", 0),
            ):
                gmsh.option.setNumber(option, value)
            groups: dict[str, list[int]] = {"contact": [], "bottom": [], "top": []}
            for _, t in gmsh.model.getEntities(1):
                _, y0, _, _, y1, _ = gmsh.model.getBoundingBox(1, t)
                if abs(y1 - y0) > 1e-6 * L:
                    continue
                y = 0.5 * (y0 + y1)
                key = "bottom" if y < 0.5 * L else "top" if y > 1.5 * L else "contact"
                groups[key].append(t)
            gmsh.model.addPhysicalGroup(2, [base], name="base")
            gmsh.model.addPhysicalGroup(2, [block], name="block")
            for name, ents in groups.items():
                gmsh.model.addPhysicalGroup(1, ents, name=name)
            gmsh.model.mesh.generate(2)
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(path))

    collective(comm, build, f"building the mesh {str(path)!r}", error=RuntimeError)


# %%
def scene(
    n: int = 16,
    *,
    law: dict | None = None,
    name: str = "hertz",
    delta: float = DELTA,
    slide: float = 0.0,
    degree: int = 2,
    steps: int = 10,
    quadrature: str = "nodal",
    apart: str | None = None,
) -> dict:
    """The contact scene with ``n`` elements per target half-width.

    An approach ``delta`` (mm) in ``steps`` steps (0 - 1 s), then, if ``slide`` is not 0, the top
    moved sideways by ``slide`` (mm) in as many steps (1 - 2 s). With ``apart``, the mesh file of
    :func:`write_apart_mesh` (made with the same ``n``) and a finite-sliding interface.
    """
    times, press, side = [0.0, 1.0], [0.0, 1.0], [0.0, 0.0]
    if slide:
        times, press, side = [*times, 2.0], [*press, 1.0], [*side, 1.0]
    sc = {
        "kind": "fe",
        "name": name,
        "mesh": {
            "builder": "block_on_base",
            "options": {
                "base_width": 2 * L,
                "base_height": L,
                "block_width": 2 * L,
                "block_height": L,
                "block_x": 0.0,
                "mesh_size": A_TARGET / n,
                "far_size": L / 4,
                "growth": 0.25,
                "refine_radius": 1.5 * A_TARGET,
            },
        },
        "law": law
        or {"law": "coulomb", "params": {"alpha_t": ALPHA, "alpha_n": ALPHA, "mu_c": MU}},
        "materials": {"primary": {"E": E, "nu": NU}, "secondary": {"E": E, "nu": NU}},
        "initial_gap": {"parabola": {"R": R, "center": [L, L]}},
        "degree": degree,
        "quadrature": quadrature,
        "program": {"times": times, "channels": {"press": press, "slide": side}},
        "dirichlet": [
            {"group": "bottom", "value": [0.0, 0.0]},
            {"group": "top", "component": 1, "value": -delta, "amplitude": "press"},
            {"group": "top", "component": 0, "value": slide, "amplitude": "slide"},
        ],
        "solver": {"prefix": f"{name}_", "dt": 1.0 / steps},
        "outputs": {"history": True, "snapshots": [1.0, 2.0] if slide else [1.0]},
    }
    if apart is not None:
        sc["mesh"] = {"file": str(apart), "gdim": 2}
        sc["materials"] = {"base": {"E": E, "nu": NU}, "block": {"E": E, "nu": NU}}
        sc["interfaces"] = {
            "contact": {
                "primary": "base",
                "secondary": "block",
                "kinematics": "finite_sliding",
                # the bodies do not slide, and their surfaces stay within the approach of each
                # other: the defaults (the largest facet, L / 4 far from the contact) would make
                # every point search the whole flat
                "reach": A_TARGET,
                "search_radius": A_TARGET,
            }
        }
    return sc


# %% [markdown]
"""
## Measuring the contact
"""


# %%
def contact_edges(x: np.ndarray, gap_n: np.ndarray) -> tuple[float, float]:
    """Left and right ends of the contact.

    Where ``gap_n`` (> 0 in contact) changes sign, linearly interpolated between neighbouring
    points (``x`` sorted).
    """
    c = np.flatnonzero(gap_n > 0)
    if c.size == 0 or c[0] == 0 or c[-1] == x.size - 1:
        raise ValueError("the contact does not end inside the interface")

    def cross(i: int, j: int) -> float:
        return float(x[i] + gap_n[i] * (x[j] - x[i]) / (gap_n[i] - gap_n[j]))

    return cross(c[0], c[0] - 1), cross(c[-1], c[-1] + 1)


# %%
def fit_ellipse(x: np.ndarray, v: np.ndarray, floor: float = 0.3) -> tuple[float, float, float]:
    """Least-squares fit of ``v^2 = v0^2 (1 - (x - xc)^2 / w^2)``.

    Over the points with ``v > floor * max(v)``; returns ``(w, v0, xc)``.
    """
    m = v > floor * v.max()
    X = np.column_stack([np.ones(m.sum()), x[m], x[m] ** 2])
    c0, c1, c2 = np.linalg.lstsq(X, v[m] ** 2, rcond=None)[0]
    xc = -c1 / (2.0 * c2)
    v02 = c0 - c2 * xc**2
    return math.sqrt(-v02 / c2), math.sqrt(v02), xc


# %%
def measure(result, t: float = 1.0) -> dict:
    """The contact at time ``t`` of a run, against Hertz at the measured load."""
    snap = result.snapshots[t]
    row = next(r for r in result.history if abs(r["t"] - t) < 1e-9)
    x = snap["x"][:, 0] - L
    p = snap["f_n"]
    P = abs(row["R_top_y"])
    aH, p0H = hertz(P)
    left, right = contact_edges(x, snap["gap"][:, 1])
    a_fit, p0_fit, xc = fit_ellipse(x, p)
    pH = p0H * np.sqrt(np.clip(1.0 - x**2 / aH**2, 0.0, None))
    inner = np.abs(x) <= 0.8 * aH
    zone = np.abs(x) <= aH
    return {
        "P": P,
        "F_n": row["F_n"],
        "a_H": aH,
        "p0_H": p0H,
        "a_edge": 0.5 * (right - left),
        "a_fit": a_fit,
        "p0_fit": p0_fit,
        "p_max": float(p.max()),
        "x_c": xc,
        "err_a_edge": 0.5 * (right - left) / aH - 1.0,
        "err_a_fit": a_fit / aH - 1.0,
        "err_p0": float(p.max()) / p0H - 1.0,
        "err_p0_fit": p0_fit / p0H - 1.0,
        "err_p_inner": float(np.max(np.abs(p - pH)[inner]) / p0H),
        "err_p_all": float(np.max(np.abs(p - pH)) / p0H),
        "err_p_rms": float(np.sqrt(np.mean((p - pH)[zone] ** 2)) / p0H),
    }


# %%
def report(key: dict, n: int) -> str:
    """One block of text with the numbers of :func:`measure`."""
    return (
        f"[hertz] n = {n}: P = {key['P']:.2f} N/mm -> Hertz a = {key['a_H']:.5f} mm, "
        f"p0 = {key['p0_H']:.2f} MPa\n"
        f"[hertz]   a (edge) = {key['a_edge']:.5f} mm ({key['err_a_edge']:+.3%}), a (fit) = "
        f"{key['a_fit']:.5f} mm ({key['err_a_fit']:+.3%})\n"
        f"[hertz]   peak p = {key['p_max']:.2f} MPa ({key['err_p0']:+.3%}), p0 (fit) = "
        f"{key['p0_fit']:.2f} MPa ({key['err_p0_fit']:+.3%})\n"
        f"[hertz]   |p - p_H| / p0: max {key['err_p_inner']:.3%} over |x| <= 0.8 a, "
        f"max {key['err_p_all']:.3%} and RMS {key['err_p_rms']:.3%} over the contact"
    )


# %% [markdown]
"""
## Figure
"""


# %%
def figure(result, key: dict, outdir) -> str:
    """Pressure along the interface against Hertz's ellipse."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    snap = result.snapshots[1.0]
    x = snap["x"][:, 0] - L
    aH, p0H = key["a_H"], key["p0_H"]
    xs = np.linspace(-aH, aH, 400)
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.plot(xs, p0H * np.sqrt(1 - xs**2 / aH**2), "-", color="k", lw=1, label="Hertz")
    ax.plot(x, snap["f_n"], "o", ms=3, color="C0", label="FE (quadrature points)")
    sep = snap["status"] == Status.SEPARATED
    ax.plot(x[sep], 0 * x[sep], "x", ms=3, color="C3", label=Status.SEPARATED.name)
    ax.set_xlim(-1.6 * aH, 1.6 * aH)
    ax.set_xlabel("x from the first touch (mm)")
    ax.set_ylabel("contact pressure $f_n$ (MPa)")
    ax.set_title(
        f"Cylinder on a flat: a = {key['a_fit']:.4f} mm (fit; Hertz {aH:.4f}), "
        f"p0 = {key['p_max']:.1f} MPa (Hertz {p0H:.1f})",
        fontsize=9,
    )
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = outdir / "pressure.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements per contact half-width")
    ap.add_argument("--degree", type=int, default=2, choices=(1, 2), help="displacement degree")
    ap.add_argument(
        "--quadrature", default="nodal", choices=("nodal", "gauss"), help="interface quadrature"
    )
    ap.add_argument(
        "--meshed-apart",
        action="store_true",
        help="mesh the bodies independently (3 : 2 across the contact; finite sliding)",
    )
    ap.add_argument("--out", default="demos/output/hertz", help="output directory")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    return ap


# %%
def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)
    outdir = Path(args.out)
    apart = None
    if args.meshed_apart:
        apart = outdir / "apart.msh"
        write_apart_mesh(apart, args.n, comm)
    sc = scene(args.n, degree=args.degree, quadrature=args.quadrature, apart=apart)
    result = run_scene(sc, outdir=outdir, comm=comm)
    result.info["n"] = args.n
    key = measure(result)
    result.info["hertz"] = key
    if comm.rank == 0:
        print(report(key, args.n))
        if not args.no_figures:
            print(f"wrote {figure(result, key, outdir)}")
    return result


# %%


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
