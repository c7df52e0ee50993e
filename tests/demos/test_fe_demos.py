"""The FE demos at a small size, run in-process on the test's ranks: each checks the physics its
demo claims (and that could fail), not just that it runs.

* pad_on_plate (3-D): the peak after a longer hold is higher than after a shorter one.
* punch (2-D): the edge pressure peak is there, and under it this law's tangential stress
  saturates (below g(f_n) mu_s, clearly below Coulomb's mu_c f_n), while Coulomb's f_t/f_n is
  mu_c at every sliding point.
* lap_joint (2-D): slip ratchets cycle by cycle with this law and not with Coulomb.
* block_on_base (2-D, the main demo) at its default size: no warning; the paper's soft normal
  penalty (500 MPa/mm) is warned about and moves the peaks as the demo says.
"""

import math
import warnings

import numpy as np
import pytest
from mpi4py import MPI

from demos import block_on_base, lap_joint, pad_on_plate, punch
from subfric_dolfinx import logs
from subfric_dolfinx.constitutive import PRESETS, Status
from subfric_dolfinx.driver import run_case


def test_the_main_demo_trusts_itself():
    """The default run (16 elements, alpha_n = 1e6 MPa/mm): no warning at all. With the paper's
    500 MPa/mm: a PenetrationWarning; its forward and reload peaks 0.3 and 0.5 % above, its
    reverse peak 5 % (the demo's text: 0.3, 0.5 and 5 %)."""
    from subfric_dolfinx.scenes import run_scene

    comm = MPI.COMM_WORLD
    peaks, seen = {}, {}
    for alpha in (block_on_base.ALPHA_N, 500.0):
        s = block_on_base.scene()
        s["law"]["params"]["alpha_n"] = alpha
        s["outputs"], s["solver"]["prefix"] = {}, None
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = run_scene(s, comm=comm)
        seen[alpha] = comm.allreduce([w.category.__name__ for w in caught])
        t = np.array([r["t"] for r in res.history])
        ft = np.array([r["F_t1"] / r["area"] for r in res.history])
        peaks[alpha] = np.array(
            [ft[(t > 1) & (t <= 2)].max(), -ft[(t > 2) & (t <= 4)].min(), ft[t > 24].max()]
        )
    assert seen[block_on_base.ALPHA_N] == [], seen
    assert seen[500.0] == [logs.PenetrationWarning.__name__], seen
    change = 100 * (peaks[500.0] / peaks[block_on_base.ALPHA_N] - 1)
    assert change[0] == pytest.approx(0.3, abs=0.05), change
    assert change[2] == pytest.approx(0.5, abs=0.05), change
    assert change[1] == pytest.approx(5.0, abs=0.5), change


def test_pad_on_plate_peak_grows_with_the_hold(shared_tmp):
    comm = MPI.COMM_WORLD
    argv = ["--n", "3", "--holds", "0", "20", "5", "--amplitude", "0.5", "--dt", "0.05"]
    argv += ["--fields", "vtx", "--out", str(shared_tmp), "--no-figures"]
    res = pad_on_plate.main(argv, comm)
    assert res.info["gdim"] == 3
    rows = {hold: (peak, before, strength) for hold, peak, before, strength in res.info["peaks"]}
    assert sorted(rows) == [0.0, 5.0, 20.0]
    p0, p5, p20 = (rows[h][0] for h in (0.0, 5.0, 20.0))
    # longer hold, higher peak (the holds ran in the order 0, 20, 5: not a drift with time)
    assert p5 > 1.1 * p0
    assert p20 > 1.3 * p5
    for hold, (peak, before, strength) in rows.items():
        assert peak <= strength * 1.001, hold  # the peak stays below the restored strength
        if hold > 0:
            assert peak > 1.1 * before, hold  # a real peak above the kinetic level
    assert (shared_tmp / "history.csv").is_file()
    assert (shared_tmp / "fields" / "interface.bp").is_dir()
    assert (shared_tmp / "fields" / "interface_points.xdmf").is_file()  # the quadrature points


def test_punch_figure_plots_the_top_displacement_the_scene_imposes():
    """The force-displacement figure's abscissa: the top's sideways displacement, from the
    scene's own program (its ``slide`` channel times the Dirichlet value), 0 to SLIDE mm."""
    sc = punch.scene(punch.subloading_law(), "p")
    (bc,) = [d for d in sc["dirichlet"] if d.get("amplitude") == "slide"]
    times, channel = sc["program"]["times"], sc["program"]["channels"]["slide"]
    t = np.linspace(0.0, times[-1], 41)
    np.testing.assert_allclose(punch.top_slide(t), bc["value"] * np.interp(t, times, channel))
    assert punch.top_slide(np.array([times[-1]]))[0] == pytest.approx(punch.SLIDE)


def test_punch_saturates_under_the_pressure_peak(shared_tmp):
    comm = MPI.COMM_WORLD
    argv = ["--n", "8", "--dt", "0.02", "--out", str(shared_tmp), "--no-figures"]
    sub, coul = punch.main(argv, comm)
    key = sub.info["punch"]
    mu_c = key["mu_c"]
    end = max(sub.snapshots)
    s, c = sub.snapshots[end], coul.snapshots[end]
    p_mean = sub.history[-1]["f_n"]
    assert 800.0 < p_mean < 1200.0
    assert 0.05 < mu_c < 0.3  # mu softened little over the 0.08 mm slide
    # the stiff penalty keeps the pressure peak at the punch edges
    fn = s["f_n"]
    assert fn.max() > 1.4 * p_mean
    i = int(np.argmax(fn))
    assert abs(s["x"][i, 0] - 1.5) > 0.2  # at an edge (the punch spans 1.25 - 1.75)
    c_n = punch.C_N
    mu_s = PRESETS["sec7"].law.mu_s
    g = 1.0 - math.exp(-c_n * fn[i])
    ft = s["f_t"][i, 0]
    assert 0.0 < ft <= g * mu_s
    assert ft < 0.85 * mu_c * fn[i]  # clearly below Coulomb's bound there
    assert c["f_t"][i, 0] > ft / 0.85  # and below what Coulomb carries there
    # this law: the whole interface slides and f_t / f_n falls with f_n (saturation)
    assert np.all((s["status"] == Status.PLASTIC) | (s["status"] == Status.JUMP))
    ratio = s["f_t"][:, 0] / fn
    order = np.argsort(fn)
    assert np.corrcoef(fn, ratio)[0, 1] < -0.95
    assert ratio[order[-1]] < 0.85 * ratio[order[0]]
    # Coulomb: f_t / f_n = mu_c at every sliding point
    sliding = (c["status"] == Status.PLASTIC) | (c["status"] == Status.JUMP)
    assert sliding.sum() >= 0.9 * sliding.size
    np.testing.assert_allclose(c["f_t"][sliding, 0] / c["f_n"][sliding], mu_c, rtol=1e-8)


def test_lap_joint_ratchets_with_this_law_not_with_coulomb(shared_tmp):
    comm = MPI.COMM_WORLD
    cycles = 4
    argv = ["--n", "8", "--cycles", str(cycles), "--dt", "0.1", "--out", str(shared_tmp)]
    res = lap_joint.main([*argv, "--no-figures"], comm)
    s = lap_joint.slip_per_cycle(res["subloading"].history, cycles)
    c = lap_joint.slip_per_cycle(res["coulomb"].history, cycles)
    inc = np.diff(s)
    # this law: positive increments that grow (softening of mu raises r_max cycle by cycle)
    assert np.all(inc > 5e-3), inc
    assert np.all(np.diff(inc) > 0), inc
    # Coulomb with the same peak strength: at most a little edge slip in the first cycle, then
    # nothing (shakedown)
    cinc = np.diff(c)
    assert abs(cinc[0]) < 0.05 * inc[0], cinc
    assert np.all(np.abs(cinc[1:]) < 1e-3 * inc[0]), cinc
    # the first cycle's slip matches the material-point driver under the same stress cycle
    p = lap_joint.PRESSURE
    q = 0.4 * lap_joint.strength(p)
    un = p / lap_joint.ALPHA
    law = lap_joint.laws(p)["subloading"]
    ref = run_case(
        {
            **law,
            "control": "stress",
            "n_tangential": 1,
            "path": [[0, 0, 0, 0], [1, 0, 0, un], [2, q, 0, un], [3, 0, 0, un]],
            "t_samples": [3.0],
            "steps_per_mm": 2000,
        }
    )
    assert inc[0] == pytest.approx(ref.samples["up_t1"][-1], rel=0.1)
    assert sorted(p.name for p in shared_tmp.iterdir()) == ["coulomb", "subloading"]
