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
"""# Cattaneo-Mindlin partial slip of a cylinder on a flat (2-D), and the subloading law on it.

The Hertz contact of ``hertz.py`` is sheared by moving the top sideways: with Coulomb friction
the stick zone and the tangential traction are compared with Cattaneo's and Mindlin's solution
for the measured ``Q / mu P``; the subloading law (calibrated to the same sliding force) shows how
its smooth elastic-plastic transition and its saturation change the partial-slip picture.
"""

# %% [markdown]
r"""
## Cattaneo–Mindlin: partial slip under a tangential force

Press the cylinder of `hertz.py` on the flat with $P$, then push it sideways with $Q < \mu P$.
With Coulomb friction the contact does not slide as a whole: a central **stick zone**
$|x| < c$ stays put while the outer parts slip, and (Cattaneo 1938, Mindlin 1949; Johnson,
*Contact Mechanics*, Sec. 7.1, for elastically similar bodies)

$$\frac{c}{a} = \sqrt{1 - \frac{Q}{\mu P}},\qquad
q(x) = \mu p_0\left(\sqrt{1 - \frac{x^2}{a^2}} - \frac{c}{a}\sqrt{1 - \frac{x^2}{c^2}}\right)
\ (|x| < c),\qquad q(x) = \mu p(x)\ (c \le |x| \le a).$$

**Loading.** Hertz's scene (approach $\delta = 50$ µm, 0 - 1 s), then the top face is moved
sideways by $s = 12$ µm with the approach held (1 - 2 s). $Q$ is measured (the reaction on the
top); the closed form is evaluated at the measured $Q/\mu P$ (0.56 at the default mesh). The
tangential force is applied through a prescribed displacement because the scene had no
traction vector on a face when this demo was written; with the same material on both sides the
shear does not change the pressure (Dundurs' $\beta = 0$), as the closed form assumes.

**Measured.** The stick zone is where the Coulomb points are ELASTIC. Its half-width $c$ two
ways: the **edge** (midway between the outermost sticking and the first slipping point) and the
**fit**: in the stick zone the slack $\mu p - |q| = \mu p_0 (c/a)\sqrt{1 - x^2/c^2}$ is an
ellipse of half-width $c$, fitted like Hertz's pressure. And the largest error of $q(x)$
against the closed form, relative to $\mu p_0$.

## The subloading-friction law on the same contact

Two things differ from Coulomb:

* **Saturation**: the strength is $g(f_n)\,\mu$ with $g = 1 - e^{-c_n f_n}$, not $\mu_c f_n$.
  With $c_n = 10^{-3}$ 1/MPa, $g$ is 0.70 at the peak pressure $p_0 \approx 1200$ MPa where a
  linear law would give 1.2: the strength profile is flatter than the pressure. $\mu_s$ is
  calibrated so that the whole contact carries the same sliding force as Coulomb's,
  $\int g(p(x))\,\mu_s\,dx = \mu P$ (with Hertz's $p(x)$). No softening and no recovery
  ($\mu_k = \mu_s$, $\kappa = 0$): what remains is the law's shape.
* **Smooth transition**: the subloading surface grows with the plastic slip,
  $\dot r = \tilde u \cot(\pi r/2)|\dot u^p|$, so every loaded point slips a little, more as
  its stress ratio $\rho = |f_t|/(g\mu)$ nears 1: there is no sharp stick zone. With
  $\tilde u = 2000$ 1/mm the ratio reaches 0.5 after 0.11 µm of slip and 0.99 after 1.3 µm,
  the scale of the slips here (the paper's $\tilde u = 15$ 1/mm, made for millimetre slides,
  would let the whole contact slip by micrometres before anything like a stick zone forms).

Both laws get the same top displacement; the figure `partial_slip.png` shows $|q(x)|$ with the
closed form and each law's strength, and the plastic slip $u^p(x)$ (log scale).

## What it gives

Coulomb against the closed form at $Q/\mu P$ = 0.564 ($c$ = 0.690 mm), for 4, 8 and 16
elements per half-width: $c$ (fit) +0.14, -0.058, +0.18 %; $c$ (edge) -2.2, +3.6, +0.98 % (the
points are $h/2$ = 0.125, 0.0625, 0.031 mm apart); the largest error of $q(x)$ 3.7, 5.3, 3.0 %
of $\mu p_0$, its RMS 1.3, 1.6, 0.80 % (the largest at the cusp of $q$ at $|x| = c$).

The subloading law at `--n 8` ($\mu_s$ = 476.6 MPa): $Q$ = 332.1 N/mm against Coulomb's 335.3
for the same displacement. Under the centre it carries 130 MPa of a strength 334 (Coulomb: 123
of 362): **saturation** lowers the strength where the pressure is highest and, the total being
the same, raises it towards the edges. Its **smooth transition** makes every point slip: 0.064
µm at the centre, where Coulomb's points stick, up to 0.92 µm at the edges (Coulomb 0.84), and
no point reaches the yield surface (largest $\rho$ 0.965): there is no sharp stick zone; the
slip stays below a tenth of its largest value within $|x| \le 0.37$ mm (Coulomb: 0.75 mm,
about $c$).

## Newton and the subloading law

While the contact is pressed, the finite bodies make small tangential tractions (a few MPa
against 400-1200 MPa of pressure) whose sign changes from one Newton iterate to the next at a
few points near the contact edge. Coulomb's points stay elastic there; the subloading law's are
plastic as soon as they load (the subloading surface passes through the current stress), with
a plastic compliance of about $\pi r^2/(4\tilde u)$ that is ten times the elastic one for
$\tilde u$ = 2000 1/mm at $r \approx 0.04$: loading and unloading tangents differ by that
factor, and Newton cycles between the two branches (residual stuck near 1 N/mm from 9e3).
Full Newton steps and the stepper's l2 retry cycle too, and cutting the step does not help; a
backtracking line search does. So the subloading run is given `snes_linesearch_type bt`
(`SUBLOADING_SNES`): at `--n 8` it then takes 115 s instead of 424 s (both on a loaded
machine), and at `--n 4` it completes where the default fails at t = 0.35 s.

    mpirun -n 2 python3 demos/cattaneo_mindlin.py [--n 8] [--slide 0.012] [--out DIR]

PETSc options go under the prefixes `cm_coulomb_` and `cm_subloading_`.
"""

# %%
import argparse
import math

# %%
import numpy as np
from mpi4py import MPI

# %%
from demos import hertz
from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.scenes import cli, run_scene

# %%
SLIDE = 0.012  # mm, sideways displacement of the top
C_N = 1e-3  # 1/MPa, the subloading law's saturation
U_TILDE = 2000.0  # 1/mm, the subloading law's transition
LITTLE = 0.1  # a point slips "little" below this fraction of the largest slip
SUBLOADING_SNES = {"snes_linesearch_type": "bt"}  # see "Newton and the subloading law"


# %%
def cattaneo_mindlin(x: np.ndarray, a: float, p0: float, mu: float, ratio: float) -> np.ndarray:
    """The closed-form tangential traction ``|q(x)|`` for ``Q / mu P = ratio`` (< 1)."""
    c = a * math.sqrt(1.0 - ratio)
    q = mu * p0 * np.sqrt(np.clip(1.0 - x**2 / a**2, 0.0, None))
    inner = np.abs(x) < c
    q[inner] -= mu * p0 * (c / a) * np.sqrt(1.0 - x[inner] ** 2 / c**2)
    return q


# %%
def calibrated_mu_s(P: float, c_n: float = C_N, mu: float = hertz.MU) -> float:
    """``mu_s`` with ``int g(p(x)) mu_s dx = mu P`` over Hertz's pressure (Gauss-Chebyshev)."""
    a, p0 = hertz.hertz(P)
    m = 4000  # midpoints in theta, x = a cos(theta): p = p0 sin(theta), dx = a sin(theta) dtheta
    s = np.sin((np.arange(m) + 0.5) * math.pi / m)
    integral = a * (math.pi / m) * float(np.sum((1.0 - np.exp(-c_n * p0 * s)) * s))
    return mu * P / integral


# %%
def subloading_law(mu_s: float, c_n: float = C_N, u_tilde: float = U_TILDE) -> dict:
    """The subloading law of the demo: stiff penalties, no softening, no recovery."""
    return {
        "law": "subloading",
        "params": {
            "alpha_t": hertz.ALPHA,
            "alpha_n": hertz.ALPHA,
            "mu_s": mu_s,
            "mu_k": mu_s,
            "kappa": 0.0,
            "xi": 0.0,
            "u_tilde": u_tilde,
            "c_n": c_n,
        },
    }


# %%
def measure_coulomb(result) -> dict:
    """Stick zone and tangential traction of the Coulomb run against the closed form."""
    key = hertz.measure(result, 2.0)
    snap = result.snapshots[2.0]
    row = result.history[-1]
    x = snap["x"][:, 0] - hertz.L
    fn, ft = snap["f_n"], np.abs(snap["f_t"][:, 0])
    Q = abs(row["R_top_x"])
    ratio = Q / (hertz.MU * key["P"])
    a, p0 = key["a_H"], key["p0_H"]
    c = a * math.sqrt(1.0 - ratio)
    # the stick zone: the sticking points around the centre, up to the first slipping ones
    elastic = snap["status"] == Status.ELASTIC
    lo = hi = int(np.argmin(np.abs(x)))
    if not elastic[lo]:
        raise ValueError("the centre of the contact slips: no stick zone")
    while elastic[lo - 1]:
        lo -= 1
    while elastic[hi + 1]:
        hi += 1
    stick = np.zeros_like(elastic)
    stick[lo : hi + 1] = True
    # midway between the outermost sticking points and their slipping neighbours
    c_edge = 0.25 * ((x[hi] + x[hi + 1]) - (x[lo] + x[lo - 1]))
    slack = np.where(stick, hertz.MU * fn - ft, 0.0)
    c_fit, _, _ = hertz.fit_ellipse(x, slack)
    q = cattaneo_mindlin(x, a, p0, hertz.MU, ratio)
    return {
        **key,
        "Q": Q,
        "ratio": ratio,
        "c": c,
        "c_edge": c_edge,
        "c_fit": c_fit,
        "err_c_edge": c_edge / c - 1.0,
        "err_c_fit": c_fit / c - 1.0,
        "err_q": float(np.max(np.abs(ft - q)) / (hertz.MU * p0)),
        "err_q_rms": float(np.sqrt(np.mean((ft - q)[np.abs(x) <= a] ** 2)) / (hertz.MU * p0)),
    }


# %%
def slip_profile(result, strength) -> dict:
    """Slips and stress ratios ``rho = |f_t| / strength(f_n, snapshot)`` of a run at its end."""
    snap = result.snapshots[2.0]
    row = result.history[-1]
    x = snap["x"][:, 0] - hertz.L
    fn, ft = snap["f_n"], np.abs(snap["f_t"][:, 0])
    contact = fn > 0
    rho = np.where(contact, ft / np.where(contact, strength(fn, snap), 1.0), 0.0)
    up = np.abs(snap["up"][:, 0])
    centre = int(np.argmin(np.abs(x)))
    quiet = contact & (up < LITTLE * up.max())
    return {
        "Q": abs(row["R_top_x"]),
        "P": abs(row["R_top_y"]),
        "q_centre": float(ft[centre]),
        "strength_centre": float(strength(fn, snap)[centre]),
        "rho_centre": float(rho[centre]),
        "rho_max": float(rho.max()),
        "slip_centre": float(up[centre]),
        "slip_max": float(up.max()),
        "c_quiet": float(np.max(np.abs(x[quiet]))) if quiet.any() else 0.0,
    }


# %%
def coulomb_strength(fn: np.ndarray, snap: dict) -> np.ndarray:
    """``mu f_n``."""
    return hertz.MU * fn


# %%
def subloading_strength(fn: np.ndarray, snap: dict) -> np.ndarray:
    """``g(f_n) mu`` with the demo's ``c_n``."""
    return (1.0 - np.exp(-C_N * fn)) * snap["mu"]


# %%
def report(cou: dict, slips: dict, mu_s: float, u_tilde: float = U_TILDE) -> str:
    """The numbers of both runs."""
    co, su = slips.get("coulomb", {}), slips.get("subloading", {})

    def line(name: str, d: dict) -> str:
        return (
            f"[cm]   {name:10s}: Q = {d['Q']:7.2f} N/mm; at the centre |q| = "
            f"{d['q_centre']:6.1f} MPa of a strength {d['strength_centre']:6.1f} (rho = "
            f"{d['rho_centre']:.3f}), slip {d['slip_centre'] * 1e3:.4f} µm; largest rho "
            f"{d['rho_max']:.3f}, largest slip {d['slip_max'] * 1e3:.4f} µm; slip below "
            f"{LITTLE:g} of it within |x| <= {d['c_quiet']:.4f} mm"
        )

    return (
        f"[cm] Coulomb: P = {cou['P']:.2f} N/mm, Q = {cou['Q']:.2f} N/mm, Q/mu P = "
        f"{cou['ratio']:.4f}; Hertz a = {cou['a_H']:.5f} mm -> c = a sqrt(1 - Q/mu P) = "
        f"{cou['c']:.5f} mm\n"
        f"[cm]   stick zone: c (edge) = {cou['c_edge']:.5f} mm ({cou['err_c_edge']:+.3%}), "
        f"c (fit) = {cou['c_fit']:.5f} mm ({cou['err_c_fit']:+.3%}); "
        f"max |q - q_CM| / mu p0 = {cou['err_q']:.3%} (RMS {cou['err_q_rms']:.3%})"
        + (
            f"\n[cm] subloading: mu_s = {mu_s:.2f} MPa, c_n = {C_N:g} 1/MPa, "
            f"u_tilde = {u_tilde:g} 1/mm; the same top displacement\n"
            + line("Coulomb", co)
            + "\n"
            + line("subloading", su)
            if su
            else ""
        )
    )


# %%
def figure(cres, sres, cou: dict, mu_s: float, outdir) -> str:
    """Tangential traction and plastic slip along the contact, both laws."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    c, s = cres.snapshots[2.0], sres.snapshots[2.0]
    xc, xs = c["x"][:, 0] - hertz.L, s["x"][:, 0] - hertz.L
    a, p0 = cou["a_H"], cou["p0_H"]
    xx = np.linspace(-a, a, 801)
    fig, ax = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True)
    ax[0].plot(
        xx,
        hertz.MU * p0 * np.sqrt(1 - xx**2 / a**2),
        ":",
        color="C3",
        lw=1,
        label=r"Coulomb's strength $\mu p$",
    )
    ax[0].plot(
        xx,
        cattaneo_mindlin(xx, a, p0, hertz.MU, cou["ratio"]),
        "-",
        color="k",
        lw=1,
        label="Cattaneo-Mindlin",
    )
    ax[0].plot(xc, np.abs(c["f_t"][:, 0]), "o", ms=3, color="C3", label="Coulomb (FE)")
    ax[0].plot(
        xs,
        (1 - np.exp(-C_N * s["f_n"])) * s["mu"],
        "--",
        color="C0",
        lw=1,
        label=r"subloading's strength $g(f_n)\,\mu$",
    )
    ax[0].plot(
        xs, np.abs(s["f_t"][:, 0]), "s", ms=3, mfc="none", color="C0", label="subloading (FE)"
    )
    for sign in (-1, 1):
        ax[0].axvline(sign * cou["c"], color="k", lw=0.5, alpha=0.5)
    ax[0].set_ylabel("tangential traction $|f_t|$ (MPa)")
    ax[0].set_title(
        f"Q/µP = {cou['ratio']:.3f}: stick zone |x| < c = {cou['c']:.3f} mm", fontsize=9
    )
    ax[0].legend(fontsize=7)
    ax[1].semilogy(
        xc, np.maximum(np.abs(c["up"][:, 0]), 1e-9) * 1e3, "o", ms=3, color="C3", label="Coulomb"
    )
    ax[1].semilogy(
        xs,
        np.maximum(np.abs(s["up"][:, 0]), 1e-9) * 1e3,
        "s",
        ms=3,
        mfc="none",
        color="C0",
        label="subloading",
    )
    ax[1].set_ylabel("plastic slip $|u^p|$ (µm; floor 1e-6)")
    ax[1].set_xlabel("x from the centre of the contact (mm)")
    ax[1].set_xlim(-1.3 * a, 1.3 * a)
    ax[1].legend(fontsize=7)
    for a_ in ax:
        a_.grid(True, alpha=0.3)
    fig.tight_layout()
    path = outdir / "partial_slip.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=8, help="elements per contact half-width")
    ap.add_argument("--slide", type=float, default=SLIDE, help="sideways displacement, mm")
    ap.add_argument("--out", default="demos/output/cattaneo_mindlin", help="output directory")
    ap.add_argument("--u-tilde", type=float, default=U_TILDE, help="the subloading law's u_tilde")
    ap.add_argument("--no-subloading", action="store_true", help="the Coulomb run only")
    ap.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    return ap


# %%
def main(argv=None, comm=MPI.COMM_WORLD):
    from pathlib import Path

    args = cli.parse_args(parser(), argv, comm)
    outdir = Path(args.out)
    cres = run_scene(
        hertz.scene(args.n, name="cm_coulomb", slide=args.slide),
        outdir=outdir / "coulomb",
        comm=comm,
    )
    cou = measure_coulomb(cres)
    cres.info["cattaneo_mindlin"] = cou
    slips = {"coulomb": slip_profile(cres, coulomb_strength)}
    cres.info["slips"] = slips["coulomb"]
    if args.no_subloading:
        if comm.rank == 0:
            print(report(cou, {}, 0.0))
        return cres, None
    mu_s = calibrated_mu_s(cou["P"])
    law = subloading_law(mu_s, u_tilde=args.u_tilde)
    sc = hertz.scene(args.n, name="cm_subloading", slide=args.slide, law=law)
    sc["solver"]["options"] = dict(SUBLOADING_SNES)
    sres = run_scene(sc, outdir=outdir / "subloading", comm=comm)
    slips["subloading"] = slip_profile(sres, subloading_strength)
    sres.info["slips"] = {**slips["subloading"], "mu_s": mu_s, "u_tilde": args.u_tilde}
    if comm.rank == 0:
        print(report(cou, slips, mu_s, args.u_tilde))
        if not args.no_figures:
            print(f"wrote {figure(cres, sres, cou, mu_s, outdir)}")
    return cres, sres


# %%


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
