"""A dynamic scene: densities in the materials, ``scene.dynamics``, the energy columns.

The main demo's scene at a small size, pressed and slid over seconds: far slower than the bodies'
periods (microseconds), so that with inertia (rho_inf = 0: the high frequencies annihilated) the
scene runs to the quasi-static one's forces; its history has the energy accounts, with their
units, and they balance. Densities on some materials only, ``scene.dynamics`` without densities
and values out of range are refused, naming their key.
"""

from __future__ import annotations

import json

import pytest
from mpi4py import MPI

from subfric_dolfinx.fem.dynamics import ENERGY_COLUMNS
from subfric_dolfinx.scenes import SceneError, parse_scene, run_scene
from tests.helpers import small_scene

DENSITIES = {"primary": 7.85e-9, "secondary": 2.7e-9}  # steel, aluminium (tonne/mm^3)


def dynamic(scene: dict, **dynamics) -> dict:
    for body, rho in DENSITIES.items():
        scene["materials"][body]["density"] = rho
    if dynamics:
        scene["dynamics"] = dynamics
    return scene


def test_a_slow_dynamic_scene_runs_to_the_quasi_static_forces(shared_tmp):
    comm = MPI.COMM_WORLD
    static = run_scene(small_scene(short=True), comm=comm)
    s = dynamic(small_scene(short=True), rho_inf=0.0)
    s["outputs"] = {"history": True}
    s["solver"]["prefix"] = None
    out = shared_tmp / "dyn"
    res = run_scene(s, comm=comm, outdir=out)
    last, ref = res.history[-1], static.history[-1]
    assert last["t"] == pytest.approx(ref["t"])
    for key in ("F_t1", "F_n"):
        assert last[key] == pytest.approx(ref[key], rel=1e-3), key
    assert set(ENERGY_COLUMNS) <= set(last)
    work = max(abs(r["W_external"]) for r in res.history)
    assert work > 0
    assert max(abs(r["E_balance"]) for r in res.history) <= 1e-6 * work
    assert min(r["D_friction"] for r in res.history[1:]) >= 0.0
    if comm.rank == 0:
        meta = json.loads((out / "history.csv-metadata.json").read_text())
        units = {c["name"]: c.get("schema:unitText") for c in meta["tableSchema"]["columns"]}
        assert units["E_kinetic"] == "mJ/mm" and units["D_numerical"] == "mJ/mm"


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda s: s["materials"]["secondary"].pop("density"), r"scene.materials: a density for"),
        (
            lambda s: [m.pop("density") for m in s["materials"].values()],
            r"scene.dynamics: a dynamic scene needs a density",
        ),
        (lambda s: s["dynamics"].update(rho_inf=1.5), r"scene.dynamics.rho_inf"),
        (lambda s: s["dynamics"].update(alpha_m=-1.0), r"scene.dynamics.alpha_m"),
        (lambda s: s["dynamics"].update(gravity=[0.0]), r"scene.dynamics.gravity"),
        (lambda s: s["materials"]["primary"].update(density=0.0), r"primary.density"),
        (lambda s: s["dynamics"].update(unknown=1), r"scene.dynamics"),
    ],
)
def test_bad_dynamics_are_refused(change, match):
    s = dynamic(small_scene(short=True), rho_inf=0.5)
    change(s)
    with pytest.raises(SceneError, match=match):
        parse_scene(s)
