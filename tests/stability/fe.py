"""Finite-element stability cases: a block (1 x 0.5 mm) on a base (2 x 0.5 mm), 8 elements along
the interface, run on ``comm``."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from subfric_dolfinx.constitutive import UNSTABLE, Status, preset

from .core import SEC7, Outcome, iteration_stats, require

_prefixes = itertools.count()


def _fe_run(
    comm: Any,
    law: Any,
    times: list[float],
    channels: dict[str, list[float]],
    *,
    dt: float,
    pressure: float | None = 300.0,
    slide: float | None = 0.3,
    push: float | None = None,
    lift: Callable[[np.ndarray], np.ndarray] | None = None,
    dt_max: float | None = None,
    max_cuts: int = 6,
    n: int = 8,
    options: dict[str, Any] | None = None,
    retry: bool = True,
) -> Outcome:
    """Run the block problem; classify: error (StepFailure) > flagged > converged.

    ``retry=False``: a failed step is cut at once, without the stepper's line-search retry.
    """
    from mpi4py import MPI

    from subfric_dolfinx import meshing
    from subfric_dolfinx.fem import (
        Dirichlet,
        DirichletField,
        FrictionSolver,
        InterfaceProblem,
        LoadStepper,
        Material,
        Pressure,
        StepControl,
        StepFailure,
        Traction,
    )
    from subfric_dolfinx.loading import LoadingProgram

    program = LoadingProgram(times, channels)
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=n, cell_type="triangle"
    )
    bcs: list[Any] = [Dirichlet("bottom", (0.0, 0.0))]
    if slide is not None:
        bcs.append(Dirichlet("top", slide, component=0, amplitude="slide"))
    loads: list[Any] = []
    if pressure is not None:
        loads.append(Pressure("top", pressure, amplitude="press"))
    if push is not None:
        loads.append(Traction("top", (push, 0.0), amplitude="push"))
    if lift is not None:

        def vertical(x: np.ndarray, t: float) -> np.ndarray:
            return -0.25 * program.amplitude("press", t) + program.amplitude("lift", t) * lift(x)

        bcs.append(DirichletField("top", vertical, component=1))
    mats = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
    prob = InterfaceProblem(dom, law, mats, program, bcs, loads)
    solver = FrictionSolver(prob, f"stab{next(_prefixes)}_", options)
    el = prob.interface
    rec: dict[str, Any] = {
        "finite": True,
        "unstable_steps": 0,
        "jump_steps": 0,
        "sep": [],
        "tension": False,
        "sep_traction": 0.0,
        "ft_mean": [],
        "t": [],
        "r_max": 0.0,
        "fn_max": 0.0,
        "ft_abs_max": 0.0,
        "cuts": 0,
    }

    def on_step(r: Any) -> None:
        tr, st, res = el.last.traction, el.state.old, el.last
        ok = all(np.all(np.isfinite(a)) for a in (tr, st.up, st.mu, st.r, prob.u.x.array))
        rec["finite"] &= bool(comm.allreduce(ok, op=MPI.LAND))
        rec["unstable_steps"] += int(r.counts.get(UNSTABLE, 0) > 0)
        rec["jump_steps"] += int(r.counts.get(Status.JUMP.name, 0) > 0)
        rec["sep"].append(int(r.counts.get(Status.SEPARATED.name, 0)))
        rec["cuts"] += r.cuts
        sep = res.status == Status.SEPARATED
        rec["tension"] |= bool(comm.allreduce(bool(np.any(tr[:, -1] < 0.0)), op=MPI.LOR))
        s_tr = float(np.abs(tr[sep]).max()) if np.any(sep) else 0.0
        rec["sep_traction"] = max(rec["sep_traction"], comm.allreduce(s_tr, op=MPI.MAX))
        w = el.weights.ravel()
        num = comm.allreduce(float(np.sum(w * tr[:, 0])))
        area = comm.allreduce(float(np.sum(w)))
        rec["ft_mean"].append(num / area)
        rec["t"].append(r.t)
        r_loc = float(st.r.max()) if st.r.size else 0.0
        rec["r_max"] = max(rec["r_max"], comm.allreduce(r_loc, op=MPI.MAX))
        fn_loc = float(tr[:, -1].max()) if tr.size else 0.0
        rec["fn_max"] = max(rec["fn_max"], comm.allreduce(fn_loc, op=MPI.MAX))
        ft_loc = float(np.abs(tr[:, 0]).max()) if tr.size else 0.0
        rec["ft_abs_max"] = max(rec["ft_abs_max"], comm.allreduce(ft_loc, op=MPI.MAX))

    stepper = LoadStepper(
        solver,
        dt,
        control=StepControl(dt_max=dt_max, max_cuts=max_cuts),
        on_step=on_step,
        **{} if retry else {"retry_options": None},
    )
    error = None
    try:
        stepper.run()
    except StepFailure as e:
        error = e
    finally:
        solver.destroy()
    its = [r.iterations for r in stepper.records]
    m, k = iteration_stats(its)
    n_steps = len(stepper.records)
    if error is not None:
        out = Outcome(
            "error",
            f"StepFailure after {n_steps} steps (last converged t = {error.last_t:.4g}); "
            f"{rec['unstable_steps']} earlier step(s) with unstable points",
            m,
            k,
            "Newton",
            rec["finite"],
            str(error),
        )
        out.data.update(t_fail=error.t, last_t=error.last_t)
    elif rec["unstable_steps"] or rec["jump_steps"]:
        out = Outcome(
            "flagged",
            f"{n_steps} steps, {rec['unstable_steps']} with unstable points, "
            f"{rec['jump_steps']} with JUMP points",
            m,
            k,
            "Newton",
            rec["finite"],
            "den <= 0" if rec["unstable_steps"] else "jump at a fold",
        )
    else:
        out = Outcome("converged", f"{n_steps} steps", m, k, "Newton", rec["finite"])
    if rec["cuts"]:
        out.detail += f", {rec['cuts']} step cut(s)"
    out.data.update(rec, n_steps=n_steps)
    return out


PRESS_SLIDE = ([0.0, 1.0, 2.0, 4.0], {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})


def fe_penalty_1e8(comm: Any) -> Outcome:
    """sec7 with alpha_t = alpha_n = 1e8 MPa/mm: press 300 MPa, slide 0.3 mm and back."""
    law = SEC7.replace(alpha_t=1e8, alpha_n=1e8)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def check_fe_conv(o: Outcome) -> None:
    require(o.data["cuts"] == 0, f"{o.data['cuts']} cuts")
    require(o.it_max <= 30, f"Newton max {o.it_max}")


def check_fe_penalty(o: Outcome) -> None:
    check_fe_conv(o)
    ft = o.data["ft_mean"]
    require(max(ft) > 10.0 and min(ft) < -3.0, f"no sliding both ways: {max(ft)}, {min(ft)}")


def fe_huge_step(comm: Any) -> Outcome:
    """sec7: press in one step, slide 0.3 mm forward in one step and back in one step."""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=2.0, dt_max=2.0)


def fe_tiny_steps(comm: Any) -> Outcome:
    """sec7: press 300 MPa in 10 steps of 1e-6 s, then 20 steps of 1e-6 s (3e-7 mm each) into
    the slide."""
    times = [0.0, 1e-5, 3e-5]
    ch = {"press": [0, 1, 1], "slide": [0, 0, 2e-5]}
    return _fe_run(comm, SEC7, times, ch, dt=1e-6, dt_max=1e-6)


def check_fe_tiny(o: Outcome) -> None:
    check_fe_conv(o)
    require(o.data["n_steps"] == 30, f"steps: {o.data['n_steps']}")


def fe_fn_to_zero(comm: Any) -> Outcome:
    """sec7 with a pressure of 1e-6 MPa: the block slides on a vanishing normal stress.

    (Not below ``alpha_n * CONTACT_TOL / (c_n alpha_n) = 5e-9`` MPa: a normal gap within the
    contact band of ``constitutive/tolerances.py`` touches, with zero traction, so a smaller
    pressure has no equilibrium.)"""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=0.25, pressure=1e-6)


def check_fe_fn0(o: Outcome) -> None:
    check_fe_conv(o)
    d = o.data
    # |f_t| <= g(f_n) mu_s <= c_n f_n mu_s, with f_n ~ 1e-5 MPa at most
    bound = SEC7.c_n * d["fn_max"] * SEC7.mu_s * (1.0 + 1e-9)
    require(d["fn_max"] < 1e-4 and d["ft_abs_max"] <= bound, f"traction not vanishing: {d}")


def fe_separation(comm: Any) -> Outcome:
    """Press by displacement, slide, lift the left part of the block's top (the contact opens
    there), lower it again (recontact)."""
    times = [0.0, 1.0, 2.0, 3.0, 4.0]
    ch = {"press": [0, 1, 1, 1, 1], "slide": [0, 0, 0.5, 0.5, 1.0], "lift": [0, 0, 0, 1, 0]}
    return _fe_run(
        comm,
        SEC7,
        times,
        ch,
        dt=0.25,
        pressure=None,
        lift=lambda x: 0.6 * np.clip((1.25 - x[0]) / 0.75, 0.0, 1.0),
    )


def check_fe_separation(o: Outcome) -> None:
    check_fe_conv(o)
    sep, t = o.data["sep"], o.data["t"]
    at = {round(a, 6): s for a, s in zip(t, sep, strict=True)}
    require(at[2.0] == 0 and at[3.0] > 0 and at[4.0] == 0, f"separated points {at}")
    require(not o.data["tension"] and o.data["sep_traction"] == 0.0, "traction when apart")


def fe_r_to_one(comm: Any) -> Outcome:
    """sec7 at 300 MPa: a 5 mm slide in steps of 0.25 mm, r -> 1 everywhere."""
    times, ch = [0.0, 1.0, 6.0], {"press": [0, 1, 1], "slide": [0, 0, 5.0 / 0.3]}
    return _fe_run(comm, SEC7, times, ch, dt=0.25)


def check_fe_r1(o: Outcome) -> None:
    check_fe_conv(o)
    require(o.data["r_max"] <= 1.0 and o.data["r_max"] > 1.0 - 1e-9, f"r {o.data['r_max']}")


def fe_reversal(comm: Any) -> Outcome:
    """sec7: slide 0.3 mm forward and back past zero in steps of 0.25 s (0.075 mm)."""
    return _fe_run(comm, SEC7, *PRESS_SLIDE, dt=0.25)


def check_fe_reversal(o: Outcome) -> None:
    check_fe_conv(o)
    ft = o.data["ft_mean"]
    require(max(ft) > 3.0 and ft[-1] < -3.0, f"no reversal: {max(ft)}, {ft[-1]}")


def fe_sec6_literal(comm: Any) -> Outcome:
    """The literal Sec. 6 set, 1000 MPa pressure, slide 0.3 mm in 18 s, steps of 0.5 s."""
    law = preset("sec6-mus10000-literal")
    times = [0.0, 1.0, 19.0]
    ch = {"press": [0, 1, 1], "slide": [0, 0, 1.0]}
    return _fe_run(comm, law, times, ch, dt=0.5, pressure=1000.0)


def check_fe_flag(o: Outcome) -> None:
    require(o.data["unstable_steps"] + o.data["jump_steps"] > 0, f"{o.data}")


def fe_large_kappa(comm: Any) -> Outcome:
    """sec7 with kappa = 1000 /mm: instant softening to mu_k, no fold (as at the point)."""
    law = SEC7.replace(kappa=1000.0)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def fe_large_kappa_and_xi(comm: Any) -> Outcome:
    """sec7 with kappa = 1000 /mm and xi = 1000 /s: the point-level snap-back, in FE."""
    law = SEC7.replace(kappa=1000.0, xi=1000.0)
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1)


def fe_sec7_literal_600(comm: Any) -> Outcome:
    """The literal Sec. 7 set at 600 MPa pressure: slide 0.3 mm and back, default options
    (Newton with full steps, a failed step tried again with the line search before a cut)."""
    return _fe_run(comm, preset("sec7-literal"), *PRESS_SLIDE, dt=0.1, pressure=600.0)


def fe_sec7_literal_600_no_retry(comm: Any) -> Outcome:
    """The same with Newton's full steps only (no line-search retry): it cycles and fails."""
    law = preset("sec7-literal")
    return _fe_run(comm, law, *PRESS_SLIDE, dt=0.1, pressure=600.0, retry=False)


def fe_sec7_literal_600_l2(comm: Any) -> Outcome:
    """The same with the l2 line search (``-<prefix>snes_linesearch_type l2``)."""
    return _fe_run(
        comm,
        preset("sec7-literal"),
        *PRESS_SLIDE,
        dt=0.1,
        pressure=600.0,
        options={"snes_linesearch_type": "l2"},
    )


def check_fe_newton_fails(o: Outcome) -> None:
    """Full-step Newton cannot finish the slide. Where it first cycles depends on the linear
    solver's round-off: near the forward peak (1.2 < t < 2) on DOLFINx 0.9 (1 and 2 ranks) and
    0.11 on 1 rank, on the reverse stroke (t = 3.76) with 0.11 on 2 ranks."""
    require("no convergence at t = " in o.message and "SNES reason" in o.message, o.message)
    require(1.2 < o.data["t_fail"] < 4.0, f"failure outside the slide: {o.data['t_fail']}")


def check_fe_literal_l2(o: Outcome) -> None:
    check_fe_flag(o)
    require(o.data["n_steps"] > 0 and o.data["t"][-1] == PRESS_SLIDE[0][-1], "incomplete run")
    # the flagged points are those where the block's edge raises f_n beyond the point fold
    require(o.data["fn_max"] > 615.0, f"largest f_n {o.data['fn_max']}")


def fe_stress_hold(comm: Any) -> Outcome:
    """Tangential traction on the block's top (no prescribed slide), 300 MPa pressure: ramp to
    12 MPa (> g mu_k = 3.7 MPa, below the peak) and hold 20 s."""
    times = [0.0, 1.0, 3.0, 23.0]
    ch = {"press": [0, 1, 1, 1], "push": [0, 0, 1, 1]}
    return _fe_run(comm, SEC7, times, ch, dt=0.25, slide=None, push=12.0)


def fe_stress_ramp(comm: Any) -> Outcome:
    """Tangential traction on the block's top ramped to 30 MPa > g mu_s = 29.1 MPa."""
    times = [0.0, 1.0, 4.0]
    ch = {"press": [0, 1, 1], "push": [0, 0, 1]}
    return _fe_run(comm, SEC7, times, ch, dt=0.1, slide=None, push=30.0, max_cuts=4)


def check_fe_runaway(o: Outcome) -> None:
    require("no convergence at t = " in o.message, o.message)
    require("last converged step" in o.message, o.message)
