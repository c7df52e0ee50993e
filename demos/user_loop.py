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
"""# The interface in your own DOLFINx loop: DOLFINx's Newton solver, your time loop

A DOLFINx user already has a residual `F(u; v)`, Dirichlet conditions and a solver loop. This
demo keeps all of that DOLFINx's own: the bodies' residual is written in UFL here, the boundary
conditions are `dolfinx.fem.dirichletbc`, the nonlinear solver is DOLFINx's (DOLFINx 0.9:
`fem.petsc.NonlinearProblem` with `nls.petsc.NewtonSolver`; 0.11: the SNES-based
`fem.petsc.NonlinearProblem`), the time loop is a plain `for` loop. The frictional interface comes
in as one object, `FrictionInterface`, with four calls:

* `create_matrix(V, [iface])`: the Jacobian matrix with the interface's couplings;
* `iface.assemble_residual(b, x, bcs=bcs)`: its forces into the residual (DOLFINx's Dirichlet
  convention: free rows only, the lifting of constrained dofs included);
* `iface.assemble_jacobian(A, x, bcs=bcs)`: its consistent tangent into the matrix;
* `iface.commit()` after a converged step (`iface.revert()` after a failed one), and
  `iface.set_step(dt)` before each step (the recovery of static friction at rest needs `dt`).

The run: a block pressed on a base at 300 MPa, then slid 0.15 mm forward and back to -0.15 mm
(the main demo's first two segments, shorter: the interface is small-sliding, valid while the
block slides a few interface elements; `FrictionInterface` keeps the pairs of the reference
geometry). The same run through the library's own solver (`InterfaceProblem`,
`FrictionSolver`, `LoadStepper`) gives the same history to round-off; the demo prints the
difference (`tests/demos/test_user_loop.py` checks it on 1 and 2 ranks).

    mpirun -n 2 python3 demos/user_loop.py [--n 16] [--out DIR]
"""

# %%
import argparse
from pathlib import Path

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI

from subfric_dolfinx import compat, meshing
from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.fem import FrictionInterface, create_matrix
from subfric_dolfinx.io import element_summary, write_history_file
from subfric_dolfinx.scenes import cli

PRESSURE = 300.0  # MPa
SLIDE = 0.15  # mm: within small sliding's validity (3 interface elements at the default n)
TIMES = [0.0, 1.0, 2.0, 3.0]  # press, slide forward, slide back
E_BASE, NU_BASE = 2.1e5, 0.3  # steel
E_BLOCK, NU_BLOCK = 7.0e4, 0.33  # aluminium
RTOL, ATOL = 1e-12, 1e-10  # Newton's tolerances: both solvers end at round-off


def law():
    """The paper's Sec. 7 set with a stiff interface (1e5 MPa/mm)."""
    return preset("sec7").replace(alpha_t=1e5, alpha_n=1e5)


def amplitudes(t: float) -> tuple[float, float]:
    """(pressure factor, slide) at time ``t``: press in 1 s, slide +SLIDE, then back to -SLIDE."""
    press = float(np.interp(t, TIMES, [0.0, 1.0, 1.0, 1.0]))
    slide = float(np.interp(t, TIMES, [0.0, 0.0, SLIDE, -SLIDE]))
    return press, slide


# %% [markdown]
# ## The model, as a DOLFINx user writes it
#
# The mesh comes from the package's builder (two bodies, the interface nodes duplicated); any
# gmsh mesh read with `meshing.read_interface_mesh` will do. The residual is plain UFL: the two
# bodies' elasticity and the pressure on the block's top, scaled by a `fem.Constant`.


# %%
def model(comm: MPI.Comm, n: int, push: str = "top"):
    """Mesh, space, residual, Jacobian, boundary conditions and the load constants.

    ``push``: the facet group whose x-displacement slides the block (``"top"``; the block's left
    flank ``"secondary_left"`` holds an interface node: its condition reaches the interface's rows).
    """
    domain, _ = meshing.create_interface_mesh(meshing.build_block_on_base, comm, n_interface=n)
    mesh = domain.mesh
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    u, v, du = dolfinx.fem.Function(V), ufl.TestFunction(V), ufl.TrialFunction(V)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=domain.cell_tags)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=domain.facet_tags)

    def sigma(w, E, nu):
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        eps = ufl.sym(ufl.grad(w))
        return 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(2)

    p = dolfinx.fem.Constant(mesh, 0.0)
    eps_v = ufl.sym(ufl.grad(v))
    F = (
        ufl.inner(sigma(u, E_BASE, NU_BASE), eps_v) * dx(domain.tag("primary"))
        + ufl.inner(sigma(u, E_BLOCK, NU_BLOCK), eps_v) * dx(domain.tag("secondary"))
        + p * ufl.dot(ufl.FacetNormal(mesh), v) * ds(domain.tag("top"))
    )
    J = ufl.derivative(F, u, du)
    fdim = mesh.topology.dim - 1
    bottom = dolfinx.fem.locate_dofs_topological(V, fdim, domain.facets("bottom"))
    V0, _ = V.sub(0).collapse()
    top_x = dolfinx.fem.locate_dofs_topological((V.sub(0), V0), fdim, domain.facets(push))
    slide = dolfinx.fem.Function(V0)
    bcs = [
        dolfinx.fem.dirichletbc(np.zeros(2), bottom, V),
        dolfinx.fem.dirichletbc(slide, top_x, V.sub(0)),
    ]
    return domain, V, u, F, J, bcs, p, slide


# %% [markdown]
# ## The interface and the solver
#
# `FrictionInterface.from_mesh` pairs the interface's two sides on the user's space `V`. The
# two callbacks add its contributions after DOLFINx has assembled the bulk; `compat.dolfinx_newton`
# is only the switch between DOLFINx 0.9's Newton solver and 0.11's SNES (both DOLFINx's own
# classes; see `subfric_dolfinx/compat.py`).


# %%
def run(comm: MPI.Comm, n: int, dt: float, push: str = "top") -> list[dict[str, float]]:
    """The hand-written time loop; one history row per step."""
    domain, V, u, F, J, bcs, p, slide = model(comm, n, push)
    iface = FrictionInterface.from_mesh(V, domain, law())
    A = create_matrix(V, [iface])
    solver = compat.dolfinx_newton(
        F,
        u,
        bcs,
        J,
        A,
        add_residual=lambda x, b: iface.assemble_residual(b, x, bcs=bcs),
        add_jacobian=lambda x, mat: iface.assemble_jacobian(mat, x, bcs=bcs),
        prefix="user_loop_",
        rtol=RTOL,
        atol=ATOL,
    )
    steps = np.round(np.diff(TIMES) / dt).astype(int)
    times = np.concatenate(
        [np.linspace(a, b, k + 1)[1:] for a, b, k in zip(TIMES[:-1], TIMES[1:], steps, strict=True)]
    )
    history, t0 = [], TIMES[0]
    try:
        for t in times:
            press, s = amplitudes(t)
            p.value = PRESSURE * press
            slide.x.array[:] = s
            iface.set_step(t - t0)
            its, converged = solver.solve()
            if not converged:
                iface.revert()
                raise RuntimeError(f"no convergence at t = {t:g}")
            iface.commit()
            row = {"t": float(t), "newton": its}
            row.update(element_summary(iface.elements, iface.law, comm))
            history.append(row)
            t0 = t
    finally:  # PETSc objects are freed collectively, at the same point on every rank
        solver.destroy()
        iface.destroy()
        A.destroy()
    return history


# %% [markdown]
# ## The same run through the library's solver, for comparison


# %%
def reference(comm: MPI.Comm, n: int, dt: float, push: str = "top") -> list[dict[str, float]]:
    """``InterfaceProblem`` + ``FrictionSolver`` + ``LoadStepper`` on the same model and steps."""
    from subfric_dolfinx.fem import (
        Dirichlet,
        FrictionSolver,
        Interface,
        InterfaceProblem,
        LoadStepper,
        Material,
        Pressure,
        StepControl,
    )
    from subfric_dolfinx.io import interface_summary
    from subfric_dolfinx.loading import LoadingProgram

    domain, _ = meshing.create_interface_mesh(meshing.build_block_on_base, comm, n_interface=n)
    program = LoadingProgram(
        TIMES,
        {"press": [0.0, 1.0, 1.0, 1.0], "slide": [0.0, 0.0, SLIDE, -SLIDE]},
    )
    problem = InterfaceProblem(
        domain,
        law(),
        {"primary": Material(E_BASE, NU_BASE), "secondary": Material(E_BLOCK, NU_BLOCK)},
        program,
        [Dirichlet("bottom", [0.0, 0.0]), Dirichlet(push, 1.0, 0, amplitude="slide")],
        [Pressure("top", PRESSURE, amplitude="press")],
        # the stiff-but-soft penalty (a layer E*/alpha_n = 0.6 mm) is the model's, chosen on
        # purpose: its penetration is judged against the interface element size only
        interfaces=[Interface("interface", intended_compliance=True)],
    )
    rows = []

    def on_step(rec):
        rows.append({"t": rec.t, "newton": rec.iterations, **interface_summary(problem)})

    options = {"snes_rtol": 0.1 * RTOL}  # its own test stops at the round-off floor
    with FrictionSolver(problem, "user_loop_ref_", options, linear="lu") as solver:
        LoadStepper(
            solver, dt, control=StepControl(grow=1.0), retry_options=None, on_step=on_step
        ).run()
    return rows


def difference(a: list[dict], b: list[dict], key: str = "F_t1") -> float:
    """Largest difference of a history column, relative to its peak."""
    x, y = np.array([r[key] for r in a]), np.array([r[key] for r in b])
    if x.shape != y.shape:
        raise ValueError(f"{x.size} steps against {y.size}")
    return float(np.abs(x - y).max() / np.abs(y).max())


# %% [markdown]
# ## The command line


# %%
def parser() -> argparse.ArgumentParser:
    """The demo's command line (anything else on it goes to PETSc)."""
    ap = cli.demo_parser(__doc__)
    ap.add_argument("--n", type=int, default=16, help="elements along the interface")
    ap.add_argument("--dt", type=float, default=0.05, help="time step in s")
    ap.add_argument("--out", default="demos/output/user_loop", help="output directory")
    return ap


COLUMNS = {
    "t": ("s", "time at the end of the step"),
    "F_t1": ("N/mm", "tangential interface resultant (this loop)"),
    "F_n": ("N/mm", "normal interface resultant, > 0 in compression (this loop)"),
    "newton": ("1", "Newton iterations of the step (DOLFINx's solver)"),
    "F_t1_reference": ("N/mm", "tangential resultant of FrictionSolver + LoadStepper"),
}
"""Units and meanings of the history's columns (``history.csv-metadata.json``)."""


def main(argv=None, comm=MPI.COMM_WORLD) -> dict:
    args = cli.parse_args(parser(), argv, comm)
    mine = run(comm, args.n, args.dt)
    ref = reference(comm, args.n, args.dt)
    diff = {k: difference(mine, ref, k) for k in ("F_t1", "F_n")}
    if comm.rank == 0:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        rows = [
            {
                "t": r["t"],
                "F_t1": r["F_t1"],
                "F_n": r["F_n"],
                "newton": r["newton"],
                "F_t1_reference": q["F_t1"],
            }
            for r, q in zip(mine, ref, strict=True)
        ]
        write_history_file(out / "history.csv", rows, extra=COLUMNS, gdim=2)  # and its units
        peak = max(abs(r["F_t1"]) for r in mine)
        print(
            f"{len(mine)} steps; peak tangential force {peak:.6g} N/mm; Newton iterations "
            f"{sum(r['newton'] for r in mine)} (DOLFINx) against "
            f"{sum(r['newton'] for r in ref)} (FrictionSolver)"
        )
        print(
            f"largest difference to FrictionSolver + LoadStepper, relative to the peak: "
            f"F_t1 {diff['F_t1']:.2e}, F_n {diff['F_n']:.2e}"
        )
    return {"history": mine, "reference": ref, "difference": diff}


# %%
if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults
    cli.main_block(main)
