"""A third friction law, defined here and nowhere in the package, runs everywhere a law runs.

Coulomb friction with linear slip weakening (the law of earthquake-rupture models): the friction
coefficient falls from ``mu_static`` to ``mu_dynamic`` over an accumulated slip ``d_c``. Its
internal variables are the plastic slip ``up``, the accumulated slip ``slip`` (a scalar no
other law has) and, to exercise the third shape of variable, the end-of-step traction ``last``
(a local vector). Through the protocol alone it goes through the material-point driver, an FE scene
on 1 and 2 ranks, the HDF5 interface history and a checkpoint/restart.
"""

import dataclasses
from typing import ClassVar

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from demos import block_on_base
from subfric_dolfinx.constitutive import (
    LOCAL,
    SCALAR,
    TANGENTIAL,
    FrictionLaw,
    LawBase,
    ReturnMapResult,
    Status,
    Variable,
    register_law,
)
from subfric_dolfinx.driver import run_case
from subfric_dolfinx.io import read_checkpoint
from subfric_dolfinx.logs import PenetrationWarning
from subfric_dolfinx.scenes import run_scene
from tests.helpers import everywhere, on_root


@register_law
@dataclasses.dataclass(frozen=True)
class SlipWeakening(LawBase):
    """Penalty Coulomb friction whose coefficient weakens linearly with accumulated slip."""

    alpha_t: float
    alpha_n: float
    mu_static: float
    mu_dynamic: float
    d_c: float

    name: ClassVar[str] = "slip-weakening"
    variables: ClassVar[tuple[Variable, ...]] = (
        Variable("up", TANGENTIAL, "plastic slip (mm)"),
        Variable("slip", SCALAR, "accumulated slip (mm)"),
        Variable("last", LOCAL, "traction at the end of the step (MPa)"),
    )

    def coefficient(self, s):
        w = np.clip(1.0 - np.asarray(s) / self.d_c, 0.0, 1.0)
        return self.mu_dynamic + (self.mu_static - self.mu_dynamic) * w

    def strength(self, state, f_n, dt=0.0):
        return self.coefficient(state["slip"]) * np.maximum(np.asarray(f_n, dtype=float), 0.0)

    def return_map(self, gap, state, dt, *, out=None):
        gap = np.asarray(gap, dtype=float)
        n, nt = state.n_points, state.n_tangential
        up0, s0 = state["up"], state["slip"]
        ft_trial = self.alpha_t * (gap[:, :nt] - up0)
        A = np.linalg.norm(ft_trial, axis=1)
        fn = self.alpha_n * gap[:, nt]
        contact = gap[:, nt] > 0.0
        plastic = contact & (A > self.coefficient(s0) * fn)
        # linear weakening: A - alpha_t dl = (mu(s0) - w dl) f_n while s0 + dl <= d_c
        w = (self.mu_static - self.mu_dynamic) / self.d_c
        H = np.where(s0 < self.d_c, self.alpha_t - w * fn, self.alpha_t)
        dl = np.where(plastic, (A - self.coefficient(s0) * fn) / H, 0.0)
        past = plastic & (s0 + dl > self.d_c)  # weakened through: mu_dynamic from then on
        H = np.where(past, self.alpha_t, H)
        dl = np.where(past, (A - self.mu_dynamic * fn) / self.alpha_t, dl)
        with np.errstate(invalid="ignore", divide="ignore"):
            nstar = np.where(A[:, None] > 0, ft_trial / A[:, None], 0.0)
        new = self.initial_state(n, nt) if out is None else out
        new["up"][:] = up0 + dl[:, None] * nstar
        new["slip"][:] = s0 + dl
        ft_mag = A - self.alpha_t * dl
        traction = np.zeros((n, nt + 1))
        traction[:, :nt] = np.where(contact[:, None], ft_mag[:, None] * nstar, 0.0)
        traction[:, nt] = np.where(contact, fn, 0.0)
        new["last"][:] = traction
        tangent = np.zeros((n, nt + 1, nt + 1))
        eye = np.eye(nt)
        touching = contact | (gap[:, nt] == 0.0)
        tangent[touching, :nt, :nt] = self.alpha_t * eye
        tangent[touching, nt, nt] = self.alpha_n
        nn = nstar[:, :, None] * nstar[:, None, :]
        mu_end = self.coefficient(s0 + dl)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(A > 0, ft_mag / A, 1.0)
        p = plastic
        tangent[p, :nt, :nt] = self.alpha_t * (
            (1.0 - self.alpha_t / H[p])[:, None, None] * nn[p]
            + ratio[p][:, None, None] * (eye - nn[p])
        )
        tangent[p, :nt, nt] = (self.alpha_t * self.alpha_n * mu_end[p] / H[p])[:, None] * nstar[p]
        status = np.where(
            contact, np.where(plastic, Status.PLASTIC, Status.ELASTIC), Status.SEPARATED
        ).astype(np.int8)
        return ReturnMapResult(
            traction, tangent, new, status, np.zeros(n, bool), np.zeros(n, np.int64)
        )


LAW = SlipWeakening(alpha_t=500.0, alpha_n=500.0, mu_static=0.3, mu_dynamic=0.1, d_c=0.5)
FN = 300.0  # MPa


def test_it_is_a_friction_law_and_has_its_own_variables():
    assert isinstance(LAW, FrictionLaw)
    st = LAW.initial_state(4, 2)
    assert st.names == ("up", "slip", "last")
    assert st["up"].shape == (4, 2) and st["slip"].shape == (4,) and st["last"].shape == (4, 3)


def test_its_tangent_is_consistent():
    """Central differences of the traction against the tangent, in the weakening range."""
    rng = np.random.default_rng(0)
    st = LAW.initial_state(20, 2)
    st["slip"][:] = rng.uniform(0.0, 0.15, 20)
    gap = np.column_stack([rng.normal(0, 0.3, (20, 2)), np.full(20, FN / LAW.alpha_n)])
    res = LAW.return_map(gap, st, 0.0)
    assert np.count_nonzero(res.status == Status.PLASTIC) > 10
    h = 1e-7
    for j in range(3):
        gp, gm = gap.copy(), gap.copy()
        gp[:, j] += h
        gm[:, j] -= h
        fd = (LAW.return_map(gp, st, 0.0).traction - LAW.return_map(gm, st, 0.0).traction) / 2 / h
        np.testing.assert_allclose(res.tangent[:, :, j], fd, rtol=1e-5, atol=1e-4)


def test_the_material_point_driver_runs_it_by_name():
    case = {
        "law": "slip-weakening",
        "params": LAW.parameters(),
        "control": "disp",
        "path": [[0, 0, 0, FN / 500], [1, 1.0, 0, FN / 500]],
        "t_samples": [0.0, 0.05, 1.0],
    }
    res = run_case(case, steps_per_mm=400)
    s = res.samples
    assert set(s) >= {"up_t1", "up_t2", "slip", "last_t1", "last_t2", "last_n"} and "mu" not in s
    np.testing.assert_array_equal(s["last_t1"], s["f_t1"])
    np.testing.assert_array_equal(s["last_n"], s["f_n"])
    # stuck then sliding at the static strength, then the dynamic one once slip > d_c
    assert s["f_t1"][1] == pytest.approx(LAW.alpha_t * 0.05, rel=1e-12)
    assert s["f_t1"][-1] == pytest.approx(LAW.mu_dynamic * FN, rel=1e-12)
    assert s["slip"][-1] == pytest.approx(1.0 - LAW.mu_dynamic * FN / LAW.alpha_t, rel=1e-9)


def scene(**outputs):
    s = block_on_base.scene(n=8, hold=1.0, dt=0.05)
    s["name"] = "weakening"
    s["law"] = {"law": "slip-weakening", "params": LAW.parameters()}
    s["solver"]["prefix"] = None
    s["solver"]["linear"] = "lu"  # the restart is compared to round-off (see test_checkpoint)
    s["outputs"] = outputs
    return s


@pytest.mark.leaves_validity(
    PenetrationWarning,
    reason="the law's 500 MPa/mm normal penalty (the paper's) on the main demo's block",
)
def test_fe_scene_interface_history_and_restart(shared_tmp):
    """FE: the force drops from the static to the dynamic level; the HDF5 history holds the
    law's own variables; a restart from a mid-run checkpoint gives the uninterrupted history."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "w"
    full = run_scene(
        scene(history=True, interface_history=True, checkpoint_times=[2.5]),
        outdir=out,
        comm=comm,
    )
    h = full.history
    ratio = np.array([r["F_t1"] / r["F_n"] for r in h])
    assert "slip" in h[-1] and "mu" not in h[-1]
    # a static peak (below mu_static: the edges weaken before the centre slips) ...
    mid = 0.5 * (LAW.mu_static + LAW.mu_dynamic)
    assert mid < ratio.max() <= LAW.mu_static * (1 + 1e-12)
    i_end_fwd = max(i for i, r in enumerate(h) if r["t"] <= 2.0 + 1e-9)
    # ... and, once every point has slid past d_c, exactly the dynamic level
    assert ratio[i_end_fwd] == pytest.approx(LAW.mu_dynamic, rel=1e-6)

    def check_interface_history():
        with h5py.File(out / "interface_history.h5") as f:
            assert {"up", "slip", "last", "f_t", "f_n", "status"} <= set(f) and "mu" not in f
            assert f["slip"].shape == (len(h), f["x"].shape[0])
            np.testing.assert_array_equal(f["last"][:, :, 0], f["f_t"][:, :, 0])
            np.testing.assert_array_equal(f["last"][:, :, 1], f["f_n"][()])
            np.testing.assert_allclose(f["slip"][-1].min(), h[-1]["slip"], rtol=0.5)

    on_root(comm, check_interface_history)
    ck = read_checkpoint(out / "checkpoint.h5", comm)
    assert set(ck.interface) == {"up", "slip", "last"}
    again = run_scene(
        scene(history=True, interface_history=True),
        outdir=out,
        comm=comm,
        restart=out / "checkpoint.h5",
    )
    a = np.array([[r["F_t1"], r["slip"]] for r in again.history])
    b = np.array([[r["F_t1"], r["slip"]] for r in h])
    assert everywhere(comm, a.shape == b.shape)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
