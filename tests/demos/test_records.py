"""The records still describe the code: results re-checked, not commit ids.

The README's and the docs' quotes come from records of one run of a named commit
(``docs/demo_results.json``, ``report/data/``; ``./run refresh`` makes them). Here every quoted
accuracy figure that is cheap to recompute, and every demo's results at its smallest size, are
re-derived on the current code and compared with their record; a change that moves one fails,
naming it (a refactoring that keeps the results passes without regenerating anything). Times
are never compared.

* **Demos** (:data:`RECHECKED`): each demo's smallest run (``<demo>_small``) and the default runs
  the README quotes that take a few seconds, run in this process and compared number by number
  with their record (:func:`differences`: :data:`RTOL` of each number plus :data:`ATOL` of the
  record's largest; Newton counts within one iteration; Newton's last residual and the bounds
  built from it are the solver's, not results, and are left out). The FE runs are recorded on 2
  ranks and re-checked in the 2-rank leg (the ``two_ranks`` mark), the numpy-only demos in the
  1-rank leg. The package's warnings a run issues are part of its record.
* **The report's material-point study** (numpy only): the :data:`MP_CHEAP_RUNS` coarsest runs
  of this law and of Coulomb on both paths, against the reference (LSODA): their errors
  compared with the record, and the quoted orders refitted with them (the finer runs enter as
  recorded).
* **The report's FE study**: its runs of at most :data:`CHEAP_FE_WORK` dofs x steps re-run on
  the suite's ranks (the 1-rank study and the 2-rank joint runs are recorded apart), their
  histories compared with the record, and the quoted orders re-derived with the re-run
  histories in place of the recorded ones (the finer runs, minutes each, enter as recorded).
* **The stack**: the records are made on the default stack (``report.stamp.RECORD_DOLFINX``)
  and these re-runs (the ``records`` mark) run on it; the other stack's legs deselect them.
* **The report's stability cases**: each is a test of ``tests/verification/test_stability.py``
  (which asserts its outcome); here the record's cases are those cases, every one recorded as
  passed, as the README's count says.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any, NamedTuple

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.logs import PenetrationWarning
from tests.helpers import ROOT

RESULTS = json.loads((ROOT / "docs" / "demo_results.json").read_text())
REPORT = ROOT / "report" / "data"

RTOL = 1e-6
"""A re-run number may differ from its record by this fraction of itself...
(the records are 2-rank runs; the suite runs on 1 and 2 ranks, where results agree to
Newton's tolerance, ``snes_rtol`` 1e-9 of a step's first residual)."""
ATOL = 1e-9
"""... plus this fraction of the largest number of the run's record (a quantity that is zero
up to round-off, such as a force off the sliding direction, is compared at that scale)."""
NEWTON = re.compile(r"^(newton.*|iterations|it_max|it_mean|newton_max)$")
"""Newton counts: within one iteration of the record (2-rank factorisations are not
bit-reproducible run to run, so a step's last iterate may land on either side of the
tolerance)."""
SOLVER = re.compile(r"^(residual.*|balance_newton|.*_bound|bound)$")
"""Newton's last residual and the bounds built from it: the solver's, not results."""
SKIPPED = re.compile(r"^(ranks|wall.*|.*_s|seconds|elapsed|load|time)$")
"""Times and the rank count: not results."""

FE_QUOTED = (
    "pad_on_plate",
    "punch",
    "lap_joint",
    "bolted_joint",
    "hertz",
    "hertz_n4",
    "hertz_n8",
    "hertz_apart_n4",
    "hertz_apart_n8",
    "block_sliding_far",
    "cattaneo_mindlin",
    "cattaneo_mindlin_n4",
    "cattaneo_mindlin_n16",
)
"""The default runs the README quotes that take a few seconds (re-run as recorded)."""


def _demo_results():
    from docs import demo_results

    return demo_results


class Tolerance(NamedTuple):
    """How far a re-run may be from its record: :data:`RTOL`, :data:`ATOL`, Newton counts."""

    rtol: float = RTOL
    atol: float = ATOL
    newton: int = 1
    only: tuple[str, ...] = ()  # the parts of the record re-checked (all if empty)


DEFAULT = Tolerance()

TOLERANCES = {
    key: Tolerance(rtol=1e-5, atol=1e-8, only=("hertz",))
    for key in ("hertz_apart_n4", "hertz_apart_n8")
}
"""Runs re-checked more loosely, and why. Hertz meshed apart (finite sliding, 2 ranks): its
steps' Newton counts differ by up to two iterations from run to run with DOLFINx 0.11 and PETSc
3.25 (MUMPS's parallel factorisation is not bit-reproducible, and the contact's search is redone
at every iteration), and the stepper grows its step after easy steps: the step sequence differs
(12 or 13 steps), the end state agrees to Newton's tolerance. Its quoted figures, the contact's
size and pressure against Hertz at the end (``hertz``), are re-checked: each to 1e-5 of itself
(the fitted ``p0`` moved by 1.2e-6) plus 1e-8 of the load (the relative errors, fractions such
as 4e-4, to 2e-5)."""


OLDER_NAMES = re.compile(r"^([RS])_(master|slave)(?=_)")
"""A reaction's or spring's column of a built-in mesh's group under its older name
(``R_master_xmin_x``, ``S_slave_left_x``): records made before the groups were renamed
(``primary``/``secondary``) are read through the alias, as the reader and the scenes read the
older names: a record stands until its demo changes."""


def today(key: Any) -> Any:
    """A recorded column's name today (:data:`OLDER_NAMES`)."""
    if not isinstance(key, str):
        return key
    new = {"master": "primary", "slave": "secondary"}
    return OLDER_NAMES.sub(lambda m: f"{m.group(1)}_{new[m.group(2)]}", key)


def differences(
    record: Any, now: Any, scale: float, path: str = "", tol: Tolerance = DEFAULT
) -> list[str]:
    """Where ``now`` differs from ``record`` beyond the tolerances (empty: it does not).

    Args:
        record: The recorded numbers (JSON values).
        now: The re-run's.
        scale: The record's largest number (for :data:`ATOL`).
        path: The place in the record (for messages).
        tol: The tolerances.
    """
    if isinstance(record, dict):
        if not isinstance(now, dict):
            return [f"{path}: recorded a mapping, now {type(now).__name__}"]
        record = {today(k): v for k, v in record.items()}
        out = []
        for k in sorted(set(record) | set(now)):
            where = f"{path}.{k}" if path else str(k)
            if SKIPPED.match(str(k)) or SOLVER.match(str(k)):
                continue
            if k not in record or k not in now:
                out.append(f"{where}: {'new' if k not in record else 'gone'}")
                continue
            if NEWTON.match(str(k)):
                out += _newton(record[k], now[k], where, tol.newton)
                continue
            out += differences(record[k], now[k], scale, where, tol)
        return out
    if isinstance(record, list):
        if not isinstance(now, list) or len(now) != len(record):
            n = len(now) if isinstance(now, list) else type(now).__name__
            return [f"{path}: recorded {len(record)} values, now {n}"]
        out = []
        for i, (a, b) in enumerate(zip(record, now, strict=True)):
            out += differences(a, b, scale, f"{path}[{i}]", tol)
        return out
    if isinstance(record, bool) or isinstance(record, str) or record is None:
        return [] if record == now else [f"{path}: recorded {record!r}, now {now!r}"]
    if isinstance(record, int | float):
        if not isinstance(now, int | float) or isinstance(now, bool):
            return [f"{path}: recorded {record!r}, now {now!r}"]
        if math.isnan(record) or math.isnan(now):
            same = math.isnan(record) and math.isnan(now)
            return [] if same else [f"{path}: recorded {record!r}, now {now!r}"]
        if abs(now - record) <= tol.rtol * abs(record) + tol.atol * scale:
            return []
        return [f"{path}: recorded {record:.10g}, now {now:.10g} ({_rel(record, now)})"]
    return [f"{path}: unexpected value {record!r}"]


def _rel(a: float, b: float) -> str:
    return f"relative change {abs(b - a) / abs(a):.2e}" if a else f"change {abs(b - a):.2e}"


def _newton(record: Any, now: Any, path: str, most: int = 1) -> list[str]:
    if isinstance(record, dict):  # a history's digest of its Newton column: max, min, last
        if not isinstance(now, dict) or set(now) != set(record):
            return [f"{path}: recorded {record!r}, now {now!r}"]
        return [d for k in sorted(record) for d in _newton(record[k], now[k], f"{path}.{k}", most)]
    a, b = np.asarray(record, dtype=float), np.asarray(now, dtype=float)
    if a.shape != b.shape:
        return [f"{path}: recorded {a.shape} Newton counts, now {b.shape}"]
    worst = float(np.abs(a - b).max()) if a.size else 0.0
    return [] if worst <= most else [f"{path}: Newton counts differ by up to {worst:g} iterations"]


def largest(value: Any) -> float:
    """The largest absolute number in a JSON value (0 if none)."""
    if isinstance(value, dict):
        return max((largest(v) for v in value.values()), default=0.0)
    if isinstance(value, list):
        return max((largest(v) for v in value), default=0.0)
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return abs(float(value))
    return 0.0


def test_the_comparison_sees_a_moved_figure():
    rec = {"hertz": {"err_a_fit": 6.4e-4, "P": 1980.7}, "iterations": [3, 4], "wall_s": 1.0}
    assert differences(rec, rec, largest(rec)) == []
    moved = {"hertz": {"err_a_fit": 6.5e-4, "P": 1980.7}, "iterations": [3, 4], "wall_s": 9.0}
    (d,) = differences(rec, moved, largest(rec))
    assert d.startswith("hertz.err_a_fit: recorded 0.00064, now 0.00065")
    assert differences(rec, {**rec, "iterations": [4, 5]}, largest(rec)) == []
    assert differences(rec, {**rec, "iterations": [3, 6]}, largest(rec))
    digest = {"iterations": {"max": 5, "min": 1, "last": 2}}
    assert differences(digest, {"iterations": {"max": 6, "min": 1, "last": 2}}, 5.0) == []
    assert differences(digest, {"iterations": {"max": 7, "min": 1, "last": 2}}, 5.0)
    assert differences(rec, {**rec, "hertz": {"err_a_fit": 6.4e-4}}, 1.0) == ["hertz.P: gone"]
    # round-off at the record's scale passes, a change of a small number beyond it does not
    small = {"F_t1": 424.0, "F_t2": 7.0e-5}
    assert differences(small, {"F_t1": 424.0, "F_t2": 7.0e-5 + 1e-10}, 424.0) == []
    assert differences(small, {"F_t1": 424.0, "F_t2": 7.0e-5 + 1e-5}, 424.0)


# --------------------------------------------------------------------------------------------
# Demos


def _recheck_keys(numpy_only: bool) -> list[str]:
    dr = _demo_results()
    keys = [k for k in dr.RUNS if k.endswith("_small")] + list(FE_QUOTED)
    return sorted(k for k in keys if (dr.RUNS[k].demo in dr.NUMPY_ONLY) == numpy_only)


def _recheck(key: str, tmp) -> None:
    dr = _demo_results()
    record = RESULTS["demos"].get(key)
    assert record is not None, f"docs/demo_results.json has no record {key!r}: ./run refresh"
    comm = None if dr.RUNS[key].demo in dr.NUMPY_ONLY else MPI.COMM_WORLD
    now = dr.measure(key, tmp / "files", comm)
    tol = TOLERANCES.get(key, DEFAULT)
    rec, got = record["numbers"], now["numbers"]
    if tol.only:
        rec, got = ({k: v for k, v in d.items() if k in tol.only} for d in (rec, got))
    diff = differences(rec, got, largest(rec), tol=tol)
    assert not diff, (
        f"{' '.join(record['command'])} no longer gives its record (docs/demo_results.json, "
        f"{key}): " + "; ".join(diff[:8]) + (f"; and {len(diff) - 8} more" if diff[8:] else "")
    )
    kinds = sorted({w.split(":")[0] for w in now["warnings"]})
    assert kinds == sorted({w.split(":")[0] for w in record["warnings"]}), (key, now["warnings"])


@pytest.mark.records
@pytest.mark.two_ranks
@pytest.mark.parametrize("key", _recheck_keys(numpy_only=False))
def test_an_fe_demo_gives_its_record(key, shared_tmp):
    _recheck(key, shared_tmp)


@pytest.mark.records
@pytest.mark.serial
@pytest.mark.parametrize("key", _recheck_keys(numpy_only=True))
def test_a_numpy_demo_gives_its_record(key, tmp_path):
    _recheck(key, tmp_path)


@pytest.mark.serial
def test_every_demo_has_its_records():
    dr = _demo_results()
    assert sorted(RESULTS["demos"]) == sorted(dr.RUNS), "./run refresh records every run"
    for demo in dr.DEMOS:
        assert f"{demo}_small" in dr.RUNS, f"{demo} has no smallest run in docs/demo_results.SMALL"
    for key, rec in RESULTS["demos"].items():
        assert rec["command"] == dr.RUNS[key].command, key
        assert rec["wall_s"] > 0, key


@pytest.mark.serial
def test_every_recorded_default_run_printed_at_most_30_lines():
    """A demo's default run is quiet (issue 37): what its command printed, as recorded (runs
    recorded before the count was kept have none)."""
    dr = _demo_results()
    counted = {
        key: rec["output_lines"]
        for key, rec in RESULTS["demos"].items()
        if key in dr.DEMOS and "output_lines" in rec
    }
    assert all(n <= 30 for n in counted.values()), counted


@pytest.mark.serial
def test_no_recorded_demo_run_warns_about_its_validity():
    """Every recorded demo run (each demo's default run, its smallest one, the quoted variants)
    ended without a warning of the package: a demo stays within its model's validity, finite
    sliding where its slide is long, and declares a penalty compliance it chose
    (``intended_compliance``). The re-runs above hold the smallest runs' warnings to these
    records; ``test_demos_run.py`` runs them with the package's warnings as errors."""
    warned = {key: rec["warnings"] for key, rec in RESULTS["demos"].items() if rec["warnings"]}
    assert not warned, warned


# --------------------------------------------------------------------------------------------
# The report: material point


MP_CHEAP_RUNS = 3
"""The coarsest runs of each law on each path re-run (chosen by their steps, not their time: a
record made on a loaded machine selects the same runs)."""


@pytest.mark.records
@pytest.mark.serial
def test_the_material_point_study_gives_its_record():
    """This law's and Coulomb's cheap runs, both paths: their errors, then the quoted orders
    refitted with them (the finer runs, seconds each, enter as recorded)."""
    from report import mp_study

    recorded = json.loads((REPORT / "mp_study.json").read_text())
    cheap = set()
    for key, rec in recorded["paths"].items():
        for law in ("subloading", "coulomb"):
            runs = sorted((r for r in rec["runs"] if r["law"] == law), key=lambda r: r["steps"])
            cheap |= {(key, law, r["spm"]) for r in runs[:MP_CHEAP_RUNS]}
    assert len(cheap) == 4 * MP_CHEAP_RUNS, "the study has too few runs to re-check"
    now = mp_study.run(
        repeats=1,
        laws=("subloading", "coulomb"),
        log=lambda *a: None,
        select=lambda key, law, spm: (key, law, spm) in cheap,
        check_reference=False,
    )
    problems = []
    for key, rec in recorded["paths"].items():
        fresh = {(r["law"], r["spm"]): r for r in now["paths"][key]["runs"]}
        for law in ("subloading", "coulomb"):
            runs = [r for r in rec["runs"] if r["law"] == law]
            errs = []
            for r in runs:
                new = fresh.get((law, r["spm"]))
                if new is None:
                    errs.append(r["error"])
                    continue
                errs.append(new["error"])
                # errors of order 1e-15 (Coulomb's exact radial return) are round-off: compared
                # at 1e-13 of the peak, the others to 1e-6 of themselves
                if new["steps"] != r["steps"] or abs(new["error"] - r["error"]) > (
                    1e-6 * r["error"] + 1e-13
                ):
                    problems.append(
                        f"{key} {law} {r['steps']} steps: error {r['error']:.6e} recorded, now "
                        f"{new['error']:.6e} ({new['steps']} steps)"
                    )
            order = rec[f"order_{law}"]
            if order is not None and min(errs) > 1e-13:
                refit = mp_study.lsq_order([r["steps"] for r in runs], errs)
                if abs(refit - order) > 1e-4:
                    problems.append(f"{key} order_{law}: {order:.4f} recorded, now {refit:.4f}")
    assert not problems, "report/data/mp_study.json: " + "; ".join(problems)


# --------------------------------------------------------------------------------------------
# The report: FE study

CHEAP_FE_WORK = 70_000
"""FE-study runs of at most this many dofs x load steps are re-run (chosen by their size, not
their time: a record made on a loaded machine selects the same runs)."""


def _fe_recorded(size: int) -> list[dict]:
    return json.loads((REPORT / f"fe_study_{size}.json").read_text())["runs"]


def _cheap(runs: list[dict]) -> list[dict]:
    """The study's converged runs of at most CHEAP_FE_WORK, not the coarsest-step probes."""
    return [
        r
        for r in runs
        if r["converged"]
        and "max_cuts" not in r
        and r["info"]["dofs"] * len(r["t"]) <= CHEAP_FE_WORK
    ]


@pytest.mark.records
@pytest.mark.leaves_validity(
    PenetrationWarning,
    reason="the report's FE study: the paper's Sec. 7 set (500 MPa/mm) on the pad, as published",
)
def test_the_fe_study_gives_its_record():
    """The study's cheap runs on this rank count re-run: histories, then the quoted orders."""
    from report import fe_study, running
    from report.fe_analysis import fe_analysis

    comm = MPI.COMM_WORLD
    recorded = {n: _fe_recorded(n) for n in (1, 2)}
    hold = json.loads((REPORT / "fe_study_1.json").read_text())["hold"]
    fresh = {n: list(runs) for n, runs in recorded.items()}
    problems = []
    cheap = _cheap(recorded[comm.size])
    assert len(cheap) >= 4, "the FE study has too few cheap runs to re-check"
    for i, rec in enumerate(cheap):
        run = {k: rec[k] for k in ("case", "law", "n", "dt") if k in rec}
        got = fe_study.one_run(run, hold, f"rec{i}_")
        name = f"{run['case']} {run['law']} n={run['n']} dt={run['dt']}"
        if not got["converged"]:
            problems.append(f"{name}: did not converge ({got['failure']})")
            continue
        if got["t"] != rec["t"]:
            problems.append(f"{name}: {len(got['t'])} steps, {len(rec['t'])} recorded")
            continue
        peak = max(abs(x) for x in rec["ft"])
        worst = max(abs(a - b) for a, b in zip(rec["ft"], got["ft"], strict=True)) / peak
        if worst > RTOL:
            problems.append(f"{name}: F_t1/A differs from its record by {worst:.2e} of the peak")
        fresh[comm.size][recorded[comm.size].index(rec)] = dict(rec, ft=got["ft"])
    assert not problems, "report/data/fe_study: " + "; ".join(problems)
    # the quoted orders, with the re-run histories in place of the recorded ones
    summary_now, _, _ = fe_analysis(fresh, running.fe_config(False))
    summary = json.loads((REPORT / "fe_summary.json").read_text())
    for key, rec in summary.items():
        for field in ("p_time", "p_space", "p_joint"):
            assert abs(summary_now[key][field] - rec[field]) <= 1e-3, (
                f"report/data/fe_summary.json {key} {field}: {rec[field]:.4f} recorded, "
                f"now {summary_now[key][field]:.4f}"
            )


# --------------------------------------------------------------------------------------------
# The report: stability


@pytest.mark.serial
def test_the_stability_record_is_the_tests_cases():
    from tests.stability import FE_CASES, POINT_CASES

    point = json.loads((REPORT / "stability_point.json").read_text())
    assert sorted(c["name"] for c in point) == sorted(c.name for c in POINT_CASES)
    assert all(c["passed"] for c in point)
    for n in (1, 2):
        fe = json.loads((REPORT / f"stability_fe_{n}.json").read_text())
        assert sorted(fe) == sorted(c.name for c in FE_CASES)
        assert all(c["passed"] for c in fe.values()), n


# --------------------------------------------------------------------------------------------
# The records' stack


@pytest.mark.serial
def test_the_records_are_rechecked_on_their_own_stack_only():
    """The re-runs (the ``records`` mark) are collected where the records are made, and only
    there (a collection in a child process: this session's own may be filtered with -k)."""
    import subprocess
    import sys

    from report.stamp import on_record_stack

    test = str(ROOT / "tests" / "demos" / "test_records.py")
    args = ["--collect-only", "-q", "-m", "records", "-p", "no:cacheprovider", test]
    p = subprocess.run(
        [sys.executable, "-m", "pytest", *args], capture_output=True, text=True, cwd=ROOT
    )
    collected = [line for line in p.stdout.splitlines() if "::" in line]
    assert bool(collected) == on_record_stack(), p.stdout[-2000:] + p.stderr[-2000:]
    if on_record_stack():
        assert any("test_a_numpy_demo_gives_its_record" in c for c in collected)
        assert any("test_the_fe_study_gives_its_record" in c for c in collected)


@pytest.mark.serial
def test_records_are_refused_on_another_stack(monkeypatch):
    import dolfinx

    from report import stamp

    monkeypatch.setattr(dolfinx, "__version__", "0.11.0")
    with pytest.raises(stamp.WrongStack, match=r"DOLFINx 0\.9\.x .* not on DOLFINx 0\.11\.0"):
        stamp.require_record_stack()
    monkeypatch.setattr(dolfinx, "__version__", "0.9.0")
    stamp.require_record_stack()
