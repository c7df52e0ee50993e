"""J2 plasticity as the bodies' law of a full :class:`~subfric_dolfinx.fem.InterfaceProblem` run
(``bulk=J2Bulk(...)``) and of a scene (``scene.materials.<body>.model = "j2"``), 1 and 2 ranks.

* Two J2 bodies of one material pressed through a sticking interface (axisymmetric and 3-D):
  uniaxial stress, loaded beyond yield, unloaded, reloaded beyond the first peak. The displacement
  is linear in the coordinates (P1 is exact): every dof against the bilinear closed form with
  mixed hardening (axial ``-(sigma/E + eps_p)``, lateral ``nu sigma/E + eps_p/2``, the
  interface's compliance ``sigma/alpha_n``), every J2 point's ``p`` against ``eps_p``, the
  interface's normal resultant against ``sigma A``, at every converged step.
* The same column as a scene (axisymmetric, prescribed top displacement): the reaction against
  the closed form with the penalty in series, and a restart from a checkpoint taken with plastic
  strain locked in (state by cell) continuing the run to round-off.
* A J2 block on an elastic base as a scene: the elastic base's materials entry without
  ``model``, the plastic points in the block only.
* Scene errors naming the key path and the bad value (parse only, no mesh).
"""

import math

import numpy as np
import pytest

from subfric_dolfinx.constitutive import CoulombLaw, J2Material
from subfric_dolfinx.fem import (
    FrictionSolver,
    InterfaceProblem,
    J2Bulk,
    LoadStepper,
    Pressure,
    ProblemSettings,
)
from subfric_dolfinx.io import interface_summary
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.scenes import SceneError, parse_scene, run_scene
from tests.helpers import column, everywhere

E, NU, SY, HI, HK, ALPHA = 1.0e5, 0.3, 100.0, 5.0e3, 5.0e3, 1.0e6
H = HI + HK
P = 1.5 * SY  # the first peak
STICK = CoulombLaw(alpha_t=ALPHA, alpha_n=ALPHA, mu_c=0.5)
PATH = LoadingProgram([0.0, 1.0, 2.0, 3.0], {"press": [0.0, 1.0, 0.3, 1.2]})
MAT = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=HI, H_kin=HK)


def plastic_strain(peaks: np.ndarray) -> np.ndarray:
    """Uniaxial ``eps_p`` after the largest stress so far (monotone in one direction)."""
    return np.maximum(peaks - SY, 0.0) / H


def exact(x: np.ndarray, upper: np.ndarray, sigma: float, eps_p: float, gdim: int) -> np.ndarray:
    """Uniaxial compression ``sigma`` (> 0) along the last axis with plastic strain ``eps_p``."""
    lateral, axial = NU * sigma / E + eps_p / 2, -(sigma / E + eps_p)
    u = lateral * x[:, :gdim].copy()
    u[:, -1] = axial * x[:, gdim - 1] - np.where(upper, sigma / ALPHA, 0.0)
    return u


@pytest.mark.parametrize("mode", ["axisymmetric", "3d"])
def test_j2_bodies_in_a_problem_against_the_uniaxial_closed_form(comm, mode):
    dom, bcs = column(mode, comm)
    bulk = J2Bulk({"primary": MAT, "secondary": MAT})
    problem = InterfaceProblem(
        dom,
        STICK,
        bulk,
        PATH,
        bcs,
        [Pressure("top", P, amplitude="press")],
        settings=ProblemSettings(mode=mode),
    )
    V, gdim = problem.V, problem.gdim
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    upper = np.zeros(n, dtype=bool)
    owned = V.dofmap.list[dom.body_cells("secondary")].ravel()
    upper[owned[owned < n]] = True
    area = np.pi if mode == "axisymmetric" else 1.0
    worst = {"u": 0.0, "p": 0.0, "F_n": 0.0}
    peak = [0.0]
    plastic_steps = []

    def on_step(rec):
        sigma = P * PATH.amplitude("press", rec.t)
        peak[0] = max(peak[0], sigma)
        ep = float(plastic_strain(np.array(peak[0])))
        u = problem.u.x.array[: n * gdim].reshape(n, gdim)
        worst["u"] = max(worst["u"], np.abs(u - exact(x, upper, sigma, ep, gdim)).max(initial=0))
        worst["p"] = max(worst["p"], np.abs(bulk.at_points("p") - ep).max(initial=0.0))
        worst["F_n"] = max(worst["F_n"], abs(interface_summary(problem)["F_n"] - sigma * area))
        plastic_steps.append((rec.t, bulk.plastic_points))

    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.25, on_step=on_step).run()
    n_points = comm.allreduce(bulk.points.shape[0])
    yielding = [t for t, k in plastic_steps if k == n_points]
    elastic = [t for t, k in plastic_steps if k == 0]
    checks = {
        "u": worst["u"] < 1e-8 * (P / E),
        "p": worst["p"] < 1e-8 * (P / E),
        "F_n": worst["F_n"] < 1e-8 * P * area,
        # every point yields while the stress rises beyond its peak, none on the way back
        "yield": len(yielding) + len(elastic) == len(plastic_steps) and len(yielding) >= 3,
        "eps_p": float(plastic_strain(np.array(1.2 * P))) > 4 * P / E,  # plastic >> elastic
    }
    assert everywhere(comm, all(checks.values())), (checks, worst, plastic_steps)


# --- the scene ----------------------------------------------------------------------------------
HEIGHT = 1.0  # block_on_base: base and block 0.5 high each (the builder's defaults)
DROP = 0.006  # mm, the top's largest displacement


def j2_entry(**kw):
    return {"model": "j2", "E": E, "nu": NU, "sigma_y": SY, "H_iso": HI, "H_kin": HK, **kw}


def column_scene(**outputs):
    return {
        "kind": "fe",
        "name": "j2_column",
        "mesh": {
            "builder": "block_on_base",
            "options": {"base_width": 1.0, "block_width": 1.0, "n_interface": 4},
        },
        "mode": "axisymmetric",
        "law": {"law": "coulomb", "params": {"alpha_t": ALPHA, "alpha_n": ALPHA, "mu_c": 0.5}},
        "materials": {"primary": j2_entry(), "secondary": j2_entry()},
        "program": {"times": [0, 1, 2, 3], "channels": {"press": [0.0, 1.0, 0.85, 1.3]}},
        "points": {"pin": {"x": [0.0, 0.0], "body": "primary"}},
        "dirichlet": [
            {"group": "bottom", "component": 1, "value": 0.0},
            {"group": "pin", "component": 0, "value": 0.0},
            {"group": "top", "component": 1, "value": -DROP, "amplitude": "press"},
        ],
        "solver": {"dt": 0.25, "linear": "lu"},
        "outputs": {"history": True, **outputs},
    }


def column_stress(drops: np.ndarray) -> np.ndarray:
    """The compressive stress for top displacements ``drops`` (> 0): bodies and penalty in
    series; loading on the hardening branch beyond the largest stress so far."""
    elastic = HEIGHT / E + 1.0 / ALPHA
    out, peak_s, peak_d = [], 0.0, 0.0
    for d in drops:
        if d >= peak_d:  # on the monotone envelope
            s = d / elastic
            if s > SY:
                s = (d + HEIGHT * SY / H) / (HEIGHT / E + HEIGHT / H + 1.0 / ALPHA)
            peak_s, peak_d = s, d
        else:
            s = peak_s - (peak_d - d) / elastic
        out.append(s)
    return np.array(out)


def test_a_j2_scene_against_the_closed_form_and_its_restart(comm, shared_tmp):
    full = run_scene(column_scene(checkpoint_times=[1.5]), outdir=shared_tmp / "a", comm=comm)
    t = np.array([r["t"] for r in full.history])
    drops = DROP * np.interp(t, [0, 1, 2, 3], [0.0, 1.0, 0.85, 1.3])
    want = column_stress(drops) * np.pi  # 2 pi r: the force over the revolution (R = 1)
    got = np.array([r["R_bottom_y"] for r in full.history])
    again = run_scene(
        column_scene(),
        outdir=shared_tmp / "a",
        comm=comm,
        restart=shared_tmp / "a" / "checkpoint.h5",
    )
    tail = np.array([r["R_bottom_y"] for r in again.history])
    checks = {
        "reaction": np.abs(got - want).max() < 1e-8 * want.max(),
        "yielded": column_stress(np.array([DROP]))[0] > 1.3 * SY,
        "compressed": want[t > 0].min() > 0.3 * SY * np.pi,  # the interface stays closed
        "restart": tail.shape == got.shape and np.abs(tail - got).max() < 1e-10 * want.max(),
    }
    assert everywhere(comm, all(checks.values())), (checks, got - want, tail - got)


def test_a_j2_block_on_an_elastic_base_in_a_scene(comm, shared_tmp):
    """The block (``secondary``) J2, the base elastic (no ``model``): pressed beyond yield, the
    vertical reaction is the applied pressure's resultant, plastic points in the block only."""
    s = column_scene()
    s["materials"]["primary"] = {"E": E, "nu": NU}
    s["mode"] = "plane_strain"
    s["program"] = {"times": [0, 1], "channels": {"press": [0.0, 1.0]}}
    s["dirichlet"] = s["dirichlet"][:2]
    s["loads"] = [{"type": "pressure", "group": "top", "value": 1.2 * SY, "amplitude": "press"}]
    s["mesh"]["options"] = {"base_width": 2.0, "block_width": 1.0, "n_interface": 4}
    from subfric_dolfinx.scenes.build import build_mesh, build_problem

    scene = parse_scene(s)
    problem = build_problem(scene, build_mesh(scene.mesh, comm, scene))
    bulk = problem.bulk
    with FrictionSolver(problem, linear="lu") as solver:
        LoadStepper(solver, 0.25).run()
    block = np.unique(problem.domain.body_cells("secondary"))
    xs = bulk.points
    in_block = xs[:, 1] > 0.5 - 1e-12  # the base is 0.5 high
    p = bulk.at_points("p")
    checks = {
        "type": isinstance(bulk, J2Bulk),
        "base elastic": np.all(p[~in_block] == 0.0),
        "block yields": comm.allreduce(int(np.count_nonzero(p[in_block] > 0))) > 0,
        "reaction": abs(abs(problem.reactions["bottom"][1]) - 1.2 * SY) < 1e-8 * SY,
        "cells": block.size > 0 or comm.size > 1,
    }
    assert everywhere(comm, all(bool(v) for v in checks.values())), checks


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda s: s["materials"]["secondary"].update(model="j3"),
            r"scene.materials.secondary.model: must be one of \['elastic', 'j2'\], got 'j3'",
        ),
        (
            lambda s: s["materials"]["secondary"].pop("sigma_y"),
            r"scene.materials.secondary: keys must be \['E', 'model', 'nu', 'sigma_y'\]",
        ),
        (
            lambda s: s["materials"]["secondary"].update(sigma_y=-5.0),
            r"scene.materials.secondary: parameter sigma_y = -5.0 is out of range",
        ),
        (
            lambda s: s["materials"]["secondary"].update(H_kin="hard"),
            r"scene.materials.secondary.H_kin: expected a number, got 'hard'",
        ),
        (
            lambda s: s["materials"]["primary"].update(sigma_y=1.0, model="elastic"),
            r"scene.materials.primary: keys must be \['E', 'nu'\] "
            r"\(optional: \['density', 'model'\]\)",
        ),
        (
            lambda s: s.update(mode="plane_stress"),
            r"scene.mode: J2 plasticity \(scene.materials \['primary', 'secondary'\]\)",
        ),
        (
            lambda s: s["outputs"].update(stress=True),
            r"scene.outputs.stress: not available with J2 bodies",
        ),
    ],
)
def test_j2_scene_errors_name_the_key_and_value(change, message):
    s = column_scene()
    s["mode"] = "plane_strain"
    change(s)
    with pytest.raises(SceneError, match=message):
        parse_scene(s)


def test_the_closed_form_helpers_agree():
    """The scene's closed form at the first yield and on the envelope (a check of the check)."""
    d_y = SY * (HEIGHT / E + 1 / ALPHA)
    s = column_stress(np.array([d_y, 2 * d_y]))
    assert s[0] == pytest.approx(SY, rel=1e-12)
    # beyond yield: sigma_y + H eps_p with eps_p = (d - HEIGHT sigma/E - sigma/alpha) / HEIGHT
    ep = (2 * d_y - HEIGHT * s[1] / E - s[1] / ALPHA) / HEIGHT
    assert s[1] == pytest.approx(SY + H * ep, rel=1e-12)
    assert math.isclose(float(plastic_strain(np.array(SY + H * 0.01))), 0.01, rel_tol=1e-12)
