"""Material-point driver: library and command line, output, step splitting, stability reporting,
stress control and import isolation (bad cases are in the catalogue, tests/bad_inputs/)."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from subfric_dolfinx.constitutive import UNSTABLE, Status, preset
from subfric_dolfinx.driver import RunawayError, fields, load_case, run_case
from tests.helpers import ROOT, python_env, singleton_env
from tests.helpers import driver_cli as cli

pytestmark = pytest.mark.numpy_only

FIELDS = fields(preset("sec7"))
ELASTIC, PLASTIC, SEPARATED, JUMP = (
    s.name for s in (Status.ELASTIC, Status.PLASTIC, Status.SEPARATED, Status.JUMP)
)
STATUS_KEYS = {s.name for s in Status} | {UNSTABLE}


def write(tmp_path, obj, name="case.json"):
    f = tmp_path / name
    f.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return f


UN = 1.2  # Sec. 7 at f_n = 600 MPa

SEC7 = {
    "params": {"preset": "sec7"},
    "control": "disp",
    "path": [[0.0, 0.0, 0.0, UN], [0.3, 0.3, 0.0, UN], [0.5, 0.3, 0.2, UN]],
    "t_samples": [0.0, 0.1, 0.3, 0.45, 0.5],
    "n_tangential": 2,
    "steps_per_mm": 400,
}


# -------------------------------------------------------------------------------------------
# Library and command line, output


def test_cli_and_library_give_the_same_output_fields_at_the_sample_times(tmp_path):
    case_file = write(tmp_path, SEC7)
    out = tmp_path / "out.json"
    proc = cli(case_file, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.startswith("ok:") and PLASTIC in proc.stderr
    data = json.loads(out.read_text())
    assert set(data) >= {
        "samples",
        "sample_status",
        "status_counts",
        "stability_lost",
        "stable",
        "complete",
        "n_steps",
        "wall_time",
    }
    assert data["stable"] is True and data["complete"] is True and data["stability_lost"] is None
    s = data["samples"]
    assert set(s) == set(FIELDS)
    for k in FIELDS:
        assert len(s[k]) == len(SEC7["t_samples"]), k
    np.testing.assert_array_equal(s["t"], SEC7["t_samples"])
    path = np.array(SEC7["path"])
    for j, k in ((1, "ubar_t1"), (2, "ubar_t2"), (3, "ubar_n")):
        np.testing.assert_allclose(s[k], np.interp(s["t"], path[:, 0], path[:, j]), atol=1e-15)
    p = preset("sec7")
    np.testing.assert_allclose(s["f_n"], p.alpha_n * UN, rtol=1e-15)
    ft = np.array([s["f_t1"], s["f_t2"]])
    ue = np.array([s["ubar_t1"], s["ubar_t2"]]) - np.array([s["up_t1"], s["up_t2"]])
    np.testing.assert_allclose(ft, p.alpha_t * ue, atol=1e-9)  # elastic law
    g = -math.expm1(-p.c_n * p.alpha_n * UN)
    np.testing.assert_allclose(np.hypot(*ft), g * np.array(s["r"]) * s["mu"], rtol=1e-9, atol=1e-12)
    assert s["f_t2"][-1] > 0.0  # the turn to e2 shows
    assert data["sample_status"] == [ELASTIC, PLASTIC, PLASTIC, PLASTIC, PLASTIC]
    counts = data["status_counts"]
    assert set(counts) == STATUS_KEYS
    assert sum(v for k, v in counts.items() if k != UNSTABLE) == data["n_steps"]
    # 1 initial step + ceil(400 * length) per interval between knots {0, .1, .3, .45, .5}
    assert data["n_steps"] == 1 + 40 + 80 + 60 + 20
    # the library gives the same numbers
    lib = run_case(load_case(case_file))
    for k in FIELDS:
        np.testing.assert_array_equal(lib.samples[k], s[k])
    assert lib.status_counts == counts and lib.n_steps == data["n_steps"]


def test_cli_prints_json_without_out_and_steps_per_mm_overrides(tmp_path):
    case_file = write(tmp_path, SEC7)
    proc = cli(case_file, "--steps-per-mm", 50)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["n_steps"] == 1 + 5 + 10 + 8 + 3  # ceil(50 * length) per interval
    assert data["complete"]


@pytest.mark.e2e
@pytest.mark.serial
def test_under_mpirun_rank_0_alone_runs_and_writes(tmp_path):
    """``mpirun -n 2 python3 -m subfric_dolfinx.driver --out``: one run, one "ok:" line (two
    ranks writing the same files side by side raced and failed), exit 0, the same result as one
    process."""
    case_file = write(tmp_path, SEC7)
    out = tmp_path / "r.json"
    env = python_env(singleton_env())
    cmd = ["mpirun", "-n", "2", sys.executable, "-m", "subfric_dolfinx.driver", str(case_file)]
    cmd += ["--out", str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (proc.stdout + proc.stderr).count("ok:") == 1, proc.stdout + proc.stderr
    serial = json.loads(cli(case_file).stdout)
    assert json.loads(out.read_text())["samples"] == serial["samples"]


def test_launcher_rank_reads_the_launchers_environment(monkeypatch):
    from subfric_dolfinx.logs import launcher_rank

    for k in ("OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK", "PMI_SIZE", "PMI_RANK", "PMIX_RANK"):
        monkeypatch.delenv(k, raising=False)
    assert launcher_rank() == 0
    monkeypatch.setenv("PMI_RANK", "3")  # a rank without a launcher's size: not launched
    assert launcher_rank() == 0
    monkeypatch.setenv("PMI_SIZE", "4")
    assert launcher_rank() == 3
    monkeypatch.setenv("PMIX_RANK", "1")
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "1")
    monkeypatch.delenv("PMI_RANK")
    assert launcher_rank() == 1


def test_status_counts_with_separation_and_the_coulomb_law(tmp_path):
    """A path that opens the contact: SEPARATED steps, zero traction; the Coulomb law slides at
    mu_c f_n."""
    case = {
        "law": "coulomb",
        "params": {"alpha_t": 1000.0, "alpha_n": 1000.0, "mu_c": 0.3},
        "control": "disp",
        "path": [[0, 0, 0, 0.1], [1, 0.2, 0, 0.1], [2, 0.2, 0, -0.105], [3, 0.3, 0, 0.1]],
        "t_samples": [1, 2, 3],
        "n_tangential": 1,
        "steps_per_mm": 100,
    }
    proc = cli(write(tmp_path, case))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    s = data["samples"]
    np.testing.assert_allclose(s["f_t1"][0], 0.3 * 100.0)  # sliding: mu_c f_n
    assert s["f_t1"][1] == 0.0 and s["f_n"][1] == 0.0  # open
    assert data["sample_status"] == [PLASTIC, SEPARATED, PLASTIC]
    c = data["status_counts"]
    # the normal gap moves 0.205 mm on [1, 2] and on [2, 3]: 21 steps each, the last 11 open on
    # [1, 2] (ubar_n = 0.1 - 0.205 k / 21 <= 0 from k = 11) and the first 10 on [2, 3]
    assert c[SEPARATED] == 21 and c[PLASTIC] + c[ELASTIC] == 1 + 20 + 10 + 11
    assert sum(v for k, v in c.items() if k != UNSTABLE) == data["n_steps"] == 1 + 20 + 21 + 21


# -------------------------------------------------------------------------------------------
# Steps are split at breakpoints and sample times


def test_a_reversal_between_two_samples_is_not_lost():
    """One step per segment (steps_per_mm = 1): the reversal at t = 1, between the samples 0 and
    2, must still end a step; otherwise the single step 0 -> 2 would see no slip at all."""
    case = {
        "params": {"preset": "sec7"},
        "control": "disp",
        "path": [[0, 0, 0, UN], [1, 0.3, 0, UN], [2, 0.0, 0, UN]],
        "t_samples": [0, 2],
        "n_tangential": 1,
    }
    coarse = run_case(case, steps_per_mm=1)
    assert coarse.n_steps == 3  # the initial step, then one per segment
    up, ft = coarse.samples["up_t1"][-1], coarse.samples["f_t1"][-1]
    assert up > 0.05 and ft < -30.0  # slid forward, then back past zero stress (not 0 and 0)
    fine = run_case(case, steps_per_mm=2000)  # converged: up = 0.06995 mm, f_t = -34.97 MPa
    assert abs(fine.samples["up_t1"][-1] - up) < 0.005
    assert abs(fine.samples["f_t1"][-1] - ft) < 0.03 * abs(ft)


def test_sample_times_end_steps_and_holds_take_one_step():
    case = {
        "params": {"preset": "sec7"},
        "control": "disp",
        "path": [[0, 0, 0, UN], [1, 1.0, 0, UN], [101, 1.0, 0, UN]],
        "t_samples": [0.37, 1.0, 50.0, 101.0],
        "n_tangential": 1,
    }
    res = run_case(case, steps_per_mm=1)
    # initial, [0, .37], [.37, 1], hold [1, 50], hold [50, 101]
    assert res.n_steps == 5
    np.testing.assert_array_equal(res.samples["ubar_t1"], [0.37, 1.0, 1.0, 1.0])
    np.testing.assert_array_equal(res.samples["t"], case["t_samples"])
    assert res.sample_status[2:] == [ELASTIC, ELASTIC]
    # the hold recovers mu exactly in one step: the same as in many smaller ones
    many = run_case({**case, "t_samples": [0.37, *np.linspace(1, 101, 51)]}, steps_per_mm=1)
    assert many.samples["mu"][-1] == pytest.approx(res.samples["mu"][-1], rel=1e-13)
    assert res.samples["mu"][-1] > res.samples["mu"][1]  # recovered while at rest
    assert run_case(case, steps_per_mm=10).n_steps == 1 + 4 + 7 + 1 + 1


# -------------------------------------------------------------------------------------------
# Stability: the literal Sec. 6 set has no stable quasi-static solution


def sec6_monotonic(name):
    return {
        "params": {"preset": name},
        "control": "disp",
        "path": [[0, 0, 0, 0.2], [90, 1.5, 0, 0.2]],  # 1 mm/min at f_n = 1000 MPa
        "t_samples": [0, 15, 30, 45, 60, 75, 90],
        "n_tangential": 1,
    }


def test_literal_sec6_set_is_flagged_unstable_and_the_normalised_one_is_not(tmp_path):
    proc = cli(write(tmp_path, sec6_monotonic("sec6-mus10000-literal"), "lit.json"))
    assert proc.returncode == 3, proc.stderr
    assert "unstable" in proc.stderr and "stopped there" in proc.stderr
    data = json.loads(proc.stdout)
    lost = data["stability_lost"]
    assert lost is not None and data["stable"] is False
    assert {"t", "reason", "r", "f_t1", "mu"} <= set(lost)
    assert lost["reason"] in ("den <= 0", "jump at a fold")
    assert 0.0 < lost["t"] < 2.0 and 0.03 < lost["r"] < 0.08  # early: r ~ 0.05 (docs/model.md §8)
    assert data["complete"] is False
    assert len(data["samples"]["t"]) < 7  # no complete curve
    assert data["status_counts"][UNSTABLE] >= 1

    proc = cli(write(tmp_path, sec6_monotonic("sec6-mus10000"), "norm.json"))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["stable"] and data["complete"] and data["stability_lost"] is None
    assert len(data["samples"]["t"]) == 7
    assert data["status_counts"][UNSTABLE] == 0 and data["status_counts"][JUMP] == 0
    ft = np.array(data["samples"]["f_t1"])
    assert ft.argmax() not in (0, len(ft) - 1)  # a peak, then softening


def test_literal_sec6_loss_of_stability_is_step_independent():
    """Where stability is lost does not depend on the step once resolved: r ~ 0.047 at ~1 s.
    With --continue-unstable the curve is completed but flagged, and it is step-dependent."""
    case = sec6_monotonic("sec6-mus10000-literal")
    lost = [run_case(case, steps_per_mm=spm).stability_lost for spm in (1000, 5000)]
    assert abs(lost[0]["r"] - lost[1]["r"]) < 1e-3 and abs(lost[0]["t"] - lost[1]["t"]) < 0.05
    go_on = run_case(case, steps_per_mm=200, on_instability="continue")
    assert go_on.complete and go_on.stability_lost is not None
    assert go_on.status_counts[UNSTABLE] > 10


# -------------------------------------------------------------------------------------------
# Stress control


def stress_case(path):
    return {
        "params": {"preset": "sec7"},
        "control": "stress",
        "path": path,
        "t_samples": [row[0] for row in path],
        "n_tangential": 1,
    }


def test_stress_control_below_the_kinetic_strength_converges():
    p = preset("sec7")
    g = -math.expm1(-p.c_n * p.alpha_n * UN)
    f = 0.8 * g * p.mu_k  # 5.7 MPa
    case = stress_case([[0, 0, 0, UN], [10, f, 0, UN], [70, f, 0, UN]])
    res = [run_case(case, steps_per_mm=spm) for spm in (50, 200, 800)]
    for r in res:
        assert r.complete and r.stability_lost is None
        np.testing.assert_allclose(r.samples["f_t1"], [0.0, f, f], rtol=1e-10, atol=1e-10)
    ups = np.array([r.samples["up_t1"][-1] for r in res])
    assert ups[-1] > 0.0
    assert abs(ups[2] - ups[1]) < abs(ups[1] - ups[0]) and abs(ups[2] - ups[1]) < 1e-4 * ups[2]
    # at rest the held stress is sustained: no more slip while mu recovers
    assert res[-1].samples["up_t1"][1] == res[-1].samples["up_t1"][2]


def test_stress_control_between_the_kinetic_strength_and_the_peak_is_sustained():
    """Above g mu_k but reached before the interface has softened, a held stress does not run
    away: at constant stress the loading criterion is -m_c <= 0, so the hold is elastic and mu
    recovers (docs/model.md §8: "beyond the kinetic strength runs away" needs this
    qualification)."""
    p = preset("sec7")
    g = -math.expm1(-p.c_n * p.alpha_n * UN)
    f = 40.0
    assert f > 5.0 * g * p.mu_k
    res = run_case(stress_case([[0, 0, 0, UN], [40, f, 0, UN], [1040, f, 0, UN]]))
    assert res.complete and res.stability_lost is None
    up, mu = res.samples["up_t1"], res.samples["mu"]
    assert up[1] > 0.0 and up[2] == up[1]  # slid while loading, not while held
    assert mu[2] > mu[1] and mu[2] == pytest.approx(p.mu_s, rel=1e-6)
    assert res.sample_status[-1] == ELASTIC


def test_stress_control_beyond_the_strength_runs_away_at_a_converging_time(tmp_path):
    """A ramp of f_t at 1 MPa/s to 60 MPa > g mu_s = 56.5 MPa: the response passes its peak at
    ~47.45 MPa; the reported time converges as the steps are refined (measured 47.5105, 47.4529,
    47.4480 s at 50, 200, 800 steps/mm)."""
    case = stress_case([[0, 0, 0, UN], [60, 60, 0, UN]])
    times = []
    for spm in (50, 200, 800):
        with pytest.raises(RunawayError) as e:
            run_case(case, steps_per_mm=spm)
        times.append(e.value.t)
        assert "runaway" in str(e.value) and e.value.partial is not None
        assert not e.value.partial.complete
    d1, d2 = abs(times[1] - times[0]), abs(times[2] - times[1])
    assert d2 < 0.5 * d1 and d2 < 0.01, times
    assert 45.0 < times[-1] < 50.0
    proc = cli(write(tmp_path, case), "--steps-per-mm", 50)
    assert proc.returncode == 3 and "runaway" in proc.stderr
    err = json.loads(proc.stdout)["error"]
    assert err["kind"] == "runaway" and err["t"] == pytest.approx(times[0], rel=1e-12)


# -------------------------------------------------------------------------------------------
# Import isolation


def test_core_and_driver_import_no_fe_or_mpi_stack():
    code = (
        "import sys\n"
        "import subfric_dolfinx.constitutive\n"
        "from subfric_dolfinx.driver import run_case\n"
        f"res = run_case({SEC7!r}, steps_per_mm=50)\n"
        "assert res.complete\n"
        "bad = sorted(m for m in sys.modules\n"
        "             if m.split('.')[0] in ('dolfinx', 'petsc4py', 'mpi4py', 'gmsh'))\n"
        "print('LOADED', bad)\n"
        "assert not bad, bad\n"
    )
    env = python_env()
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert "LOADED []" in proc.stdout


# -------------------------------------------------------------------------------------------
# Long runs: progress, and a cost per step independent of the number of path rows


def test_progress_lines_on_stderr(tmp_path, monkeypatch, capsys):
    """A progress line at most every PROGRESS_SECONDS (set to 0 here: one per checkpoint of the
    step loop, every _PROGRESS_EVERY steps: 20 here instead of 2000, for a hundredth of the
    steps)."""
    from subfric_dolfinx.driver import cli as cli_mod
    from subfric_dolfinx.driver import run as run_mod

    monkeypatch.setattr(cli_mod, "PROGRESS_SECONDS", 0.0)
    monkeypatch.setattr(run_mod, "_PROGRESS_EVERY", 20)
    case = {**SEC7, "steps_per_mm": 200}  # 101 steps
    out = tmp_path / "r.json"
    assert cli_mod.main([str(write(tmp_path, case)), "--out", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    prog = [ln for ln in err if ln.startswith("progress:")]
    assert len(prog) == 5 and "of 101 steps" in prog[0], err
    assert err[-1].startswith("ok:")
    monkeypatch.setattr(cli_mod, "PROGRESS_SECONDS", 3600.0)  # a short run prints none
    assert cli_mod.main([str(write(tmp_path, case)), "--out", str(out)]) == 0
    assert not [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("progress")]


def test_a_path_of_many_rows_gives_the_same_steps():
    """The same straight path given as 2 rows or as 201 rows (with the knots as samples in the
    first): the same steps, the same result. (The cost per step does not depend on the number of
    rows: benchmarks/driver_steps.py measures it, up to 10^6 rows.)"""
    n = 200
    t = np.linspace(0.0, 0.3, n + 1)
    many = {
        **SEC7,
        "n_tangential": 1,
        "path": [[ti, ti, 0.0, UN] for ti in t],
        "t_samples": [0.0, 0.3],
    }
    few = {**many, "path": [[0.0, 0.0, 0.0, UN], [0.3, 0.3, 0.0, UN]], "t_samples": t.tolist()}
    a = run_case(many, steps_per_mm=1)  # one step per row interval
    b = run_case(few, steps_per_mm=1)
    assert a.n_steps == b.n_steps == n + 1
    for k in ("f_t1", "up_t1", "mu", "r"):
        assert a.samples[k][-1] == b.samples[k][-1], k


# -------------------------------------------------------------------------------------------
# The batch driver: many cases through one loop, the same results as one by one


def fig10_case(fn, law=None, n_samples=11):
    p = law or {"preset": "sec7"}
    un = fn / preset("sec7").alpha_n
    return {
        "params": p,
        "control": "disp",
        "path": [[0.0, 0.0, 0.0, un], [20.0, 20.0, 0.0, un]],  # 1 mm/s to 20 mm (Fig. 10)
        "t_samples": np.linspace(0.0, 20.0, n_samples).tolist(),
        "n_tangential": 1,
        "steps_per_mm": 20,
    }


def test_batch_driver_equals_one_by_one():
    """Six normal stresses (Fig. 10, at 5 steps/mm), two parameter sets, a turn in 3-D, a
    reversal at another velocity, a case that loses stability: every result equals run_case's."""
    from subfric_dolfinx.driver import run_cases

    coarse = {"steps_per_mm": 5}  # the comparison holds at any step: fewer steps, the same test
    cases = [{**fig10_case(fn), **coarse} for fn in (100, 200, 300, 400, 500, 600)]
    cases.append({**fig10_case(300, {"preset": "sec7", "kappa": 0.5, "mu0": 400.0}), **coarse})
    cases.append(SEC7)
    cases.append(
        {
            **fig10_case(300),
            "path": [[0, 0, 0, 0.6], [2, 0.5, 0, 0.6], [6, -0.5, 0, 0.6]],
            "t_samples": [0, 1, 2, 3, 4.5, 6],
        }
    )
    cases.append(sec6_monotonic("sec6-mus10000-literal"))
    batch = run_cases(cases)
    for c, b in zip(cases, batch, strict=True):
        one = run_case(c)
        assert b.n_steps == one.n_steps and b.complete == one.complete
        assert b.status_counts == one.status_counts and b.sample_status == one.sample_status
        assert (b.stability_lost is None) == (one.stability_lost is None)
        for k in one.samples:
            np.testing.assert_allclose(b.samples[k], one.samples[k], rtol=1e-12, atol=1e-12)
    assert batch[-1].stability_lost is not None and not batch[-1].complete


def test_batch_driver_with_many_cases_takes_the_numpy_path():
    """12 cases of one law (one call of the numpy map a step) equal the one-by-one runs to
    1e-12."""
    from subfric_dolfinx.driver import run_cases

    cases = [fig10_case(fn, n_samples=5) for fn in np.linspace(50.0, 700.0, 12)]
    for c, b in zip(cases, run_cases(cases, steps_per_mm=5), strict=True):
        one = run_case(c, steps_per_mm=5)
        np.testing.assert_allclose(b.samples["f_t1"], one.samples["f_t1"], rtol=1e-12)
        np.testing.assert_allclose(b.samples["mu"], one.samples["mu"], rtol=1e-12)


def test_batch_driver_refuses_stress_control():
    from subfric_dolfinx.driver import CaseError, run_cases

    with pytest.raises(CaseError, match="case 1: the batch driver runs displacement control"):
        run_cases([SEC7, stress_case([[0, 0, 0, UN], [10, 5.0, 0, UN]])])


def test_batch_driver_refuses_a_slider_case():
    """A slider case (parse_case gives a SliderCase, which has no control) is refused by name,
    as a stress-controlled one is (it raised an AttributeError: found by mypy)."""
    from subfric_dolfinx.driver import CaseError, run_cases

    slider = {
        "law": "subloading",
        "params": {"preset": "sec7"},
        "control": "slider",
        "slider": {"mass": 1e-3, "stiffness": 100.0, "velocity": 0.1, "f_n": 300.0, "t_end": 0.05},
    }
    with pytest.raises(CaseError, match=r"case 1: .* stress-controlled and slider cases"):
        run_cases([SEC7, slider])
