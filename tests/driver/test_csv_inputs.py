"""CSV input (issue 24 item 8): a driver path and calibration curves from CSV files, as a
tribometer exports them; the same numbers as the JSON forms; bad files named by line and column;
the console scripts ``subfric-driver`` and ``subfric-calibrate`` on them; the unit of ``mu_s``
said where a parameter is refused."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from subfric_dolfinx.calibrate import CalibrationError, load_data, parse_data, synthetic_curves
from subfric_dolfinx.constitutive import LawError, build_law, preset
from subfric_dolfinx.driver import CaseError, load_case, parse_case, run_case
from tests.helpers import ROOT, driver_cli, module_cli, python_env

pytestmark = pytest.mark.numpy_only

PATH = [[0.0, 0.0, 0.0, 0.6], [1.0, 0.0, 0.0, 0.6], [2.0, 0.5, 0.0, 0.6], [3.0, -0.2, 0.0, 0.6]]


def case(path):
    return {
        "params": {"preset": "sec7"},
        "control": "disp",
        "n_tangential": 1,
        "path": path,
        "t_samples": [1.0, 1.5, 2.0, 2.5, 3.0],
    }


def test_a_driver_path_from_csv_equals_the_json_rows(tmp_path):
    """A tribometer-like file: a units comment, its own column names mapped by ``columns``,
    semicolons, no x2 (2-D); relative to the case file's folder; the result equals the rows'."""
    (tmp_path / "data").mkdir()
    lines = ["# s; mm; mm", "time;slip;approach"]
    lines += [f"{t};{x};{n}" for t, x, _, n in PATH]
    (tmp_path / "data" / "path.csv").write_text("\n".join(lines) + "\n")
    spec = {"csv": "data/path.csv", "columns": {"t": "time", "x1": "slip", "ubar_n": "approach"}}
    (tmp_path / "case.json").write_text(json.dumps(case(spec)))
    from_csv = run_case(load_case(tmp_path / "case.json"))
    from_rows = run_case(parse_case(case(PATH)))
    for k in ("f_t1", "f_n", "up_t1", "mu"):
        np.testing.assert_array_equal(from_csv.samples[k], from_rows.samples[k])
    every = parse_case({**case(PATH), "t_samples": "path"})
    np.testing.assert_array_equal(every.t_samples, [0.0, 1.0, 2.0, 3.0])


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("t,x1,ubar_n\n0,0,0.6\n1,abc,0.6\n", ["line 3", "'x1'", "'abc' is not a finite number"]),
        ("t,x1,ubar_n\n0,0,0.6\n1,nan,0.6\n", ["line 3", "is not a finite number"]),
        ("t,x1,ubar_n\n0,0,0.6\n1,0.5\n", ["line 3 has 2 fields, the header 3"]),
        ("t,slip,ubar_n\n0,0,0.6\n1,0.5,0.6\n", ["no column 'x1'", "'slip'"]),
        ("# only a comment\n", ["no header line"]),
        ("t,x1,ubar_n\n0,0,0.6\n", ["holds 1 row(s), need two"]),
        ("t,x1,ubar_n\n0,0,0.6\n1,0.5,0.6\n2,1,0.6\n1.5,1,0.6\n", ["times must increase"]),
    ],
    ids=["not-a-number", "nan", "short-row", "missing-column", "no-header", "one-row", "time"],
)
def test_a_bad_path_csv_is_named(tmp_path, text, words):
    (tmp_path / "p.csv").write_text(text)
    (tmp_path / "case.json").write_text(json.dumps(case({"csv": "p.csv"})))
    with pytest.raises(CaseError) as e:
        load_case(tmp_path / "case.json")
    for w in words:
        assert w in str(e.value), (w, str(e.value))
    for bad, word in [
        ({"csv": "missing.csv"}, "is not a file"),
        ({"csv": "p.csv", "sep": ";"}, "unknown keys ['sep']"),
        ({"csv": "p.csv", "columns": {"y": "t"}}, "unknown names ['y']"),
        ({"csv": 3}, "must be a file name"),
    ]:
        with pytest.raises(CaseError, match=word.replace("[", r"\[")):
            parse_case(case(bad), tmp_path)


TRUE = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}


def test_calibration_curves_from_csv_equal_the_json_lists(tmp_path):
    """Two curves as a tribometer would give them (tab-separated with their own headers, and a
    byte-order mark): the same data as the lists, and the command line fits from them."""
    curves = synthetic_curves(TRUE, [150.0, 450.0], [1.0, 1.0], np.linspace(0, 2, 21))
    entries = []
    for i, c in enumerate(curves):
        pairs = zip(c["slip"], c["f_t"], strict=True)
        rows = "\n".join(f"{s}\t{f}\t{k}" for k, (s, f) in enumerate(pairs))
        (tmp_path / f"run{i}.csv").write_text("\ufeffdisp_mm\tshear_MPa\tsample\n" + rows + "\n")
        entries.append(
            {
                "f_n": c["f_n"],
                "velocity": c["velocity"],
                "csv": f"run{i}.csv",
                "columns": {"slip": "disp_mm", "f_t": "shear_MPa"},
            }
        )
    data = {"params": {**TRUE, "mu_k": 75.0}, "fit": ["mu_k"], "curves": entries}
    (tmp_path / "data.json").write_text(json.dumps(data))
    got = load_data(tmp_path / "data.json")
    want = parse_data({**data, "curves": curves})
    for a, b in zip(got.curves, want.curves, strict=True):
        np.testing.assert_array_equal(a.slip, b.slip)
        np.testing.assert_array_equal(a.f_t, b.f_t)
        assert (a.f_n, a.velocity) == (b.f_n, b.velocity)
    with pytest.raises(CalibrationError, match="not both"):
        parse_data({**data, "curves": [{**entries[0], "slip": [0, 1]}]}, tmp_path)
    proc = module_cli("calibrate", tmp_path / "data.json", "--out", tmp_path / "fit.json")
    assert proc.returncode == 0, proc.stderr
    fitted = json.loads((tmp_path / "fit.json").read_text())["params"]["mu_k"]
    assert fitted == pytest.approx(TRUE["mu_k"], rel=1e-4)


def test_a_refused_mu_says_it_is_a_stress_in_mpa():
    """mu_s = 0.5 (a user thinking of a friction coefficient) is refused with its unit."""
    with pytest.raises(LawError) as e:
        build_law({"params": {**TRUE, "mu_s": 0.5}})
    msg = str(e.value)
    assert "mu_s >= mu_k = 63.0, in MPa" in msg and "not a friction coefficient" in msg, msg
    assert "mu_s = 500 MPa" in preset.__globals__["PRESETS"]["sec7"].description


def scripts_dir():
    """Where pip put the console scripts of the package under test, if it was installed."""
    installed = os.environ.get("SUBFRIC_TEST_INSTALLED")
    return os.path.join(installed, "bin") if installed else None


def test_the_console_scripts_are_declared_and_work(tmp_path):
    """pyproject declares subfric-driver, subfric-calibrate and subfric-scene; from the installed
    package (./run test) they run a case and refuse bad data with exit code 2, saying their own
    name."""
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts == {
        "subfric-driver": "subfric_dolfinx.driver.cli:main",
        "subfric-calibrate": "subfric_dolfinx.calibrate.cli:main",
        "subfric-scene": "subfric_dolfinx.scenes.command:main",
    }
    where = scripts_dir()
    if where is None:  # the source tree: the entry points themselves, through -m
        assert module_cli("driver", "--help").returncode == 0
        return
    for name in scripts:
        assert shutil.which(name, path=where), (name, os.listdir(where))
    (tmp_path / "case.json").write_text(json.dumps(case(PATH)))
    env = python_env()

    def script(name, *args):
        return subprocess.run(
            [os.path.join(where, name), *args],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )

    run = script("subfric-driver", "case.json", "--out", "r.json")
    assert run.returncode == 0, run.stderr
    assert len(json.loads((tmp_path / "r.json").read_text())["samples"]["t"]) == 5
    bad = script("subfric-calibrate", "missing.json", "--out", "f.json")
    assert bad.returncode == 2 and bad.stderr.startswith("error:"), bad.stderr
    for name in ("subfric-calibrate", "subfric-scene"):
        usage = script(name, "--help")
        assert usage.returncode == 0 and f"usage: {name}" in usage.stdout, usage.stdout


SECRET = "the first line of a file elsewhere\n"


@pytest.mark.parametrize("how", ["dotdot", "absolute", "link", "link in a folder"])
def test_a_table_outside_the_case_files_folder_is_not_read(tmp_path, how):
    """A case (or data) file names its own tables: ``../x.csv``, an absolute path elsewhere or
    a link leading out (e.g. to a system file) is refused, and nothing of it is shown."""
    (tmp_path / "elsewhere.csv").write_text(SECRET)
    folder = tmp_path / "case"
    (folder / "sub").mkdir(parents=True)
    name = {
        "dotdot": "../elsewhere.csv",
        "absolute": str(tmp_path / "elsewhere.csv"),
        "link": "p.csv",
        "link in a folder": "sub/p.csv",
    }[how]
    if how.startswith("link"):
        (folder / name).symlink_to(tmp_path / "elsewhere.csv")
    (folder / "case.json").write_text(json.dumps(case({"csv": name})))
    curve = {"f_n": 1.0, "velocity": 1.0, "csv": name}
    data = {"params": {**TRUE, "mu_k": 75.0}, "fit": ["mu_k"], "curves": [curve]}
    (folder / "data.json").write_text(json.dumps(data))
    for load, error in ((load_case, CaseError), (load_data, CalibrationError)):
        file = folder / ("case.json" if load is load_case else "data.json")
        with pytest.raises(error) as e:
            load(file)
        msg = str(e.value)
        assert "lies outside the folder" in msg and "not read" in msg, msg
        assert "first line" not in msg and repr(name) in msg, msg
        if how.startswith("link"):
            assert "symbolic link" in msg, msg


def test_a_link_inside_the_folder_is_read(tmp_path):
    lines = ["t,x1,ubar_n"] + [f"{t},{x},{n}" for t, x, _, n in PATH]
    (tmp_path / "real.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "p.csv").symlink_to("real.csv")
    (tmp_path / "case.json").write_text(json.dumps(case({"csv": "p.csv"})))
    assert load_case(tmp_path / "case.json").path.shape[0] == len(PATH)


def test_a_field_beyond_the_csv_modules_limit_is_a_clear_error(tmp_path):
    import csv

    big = "1" * (csv.field_size_limit() + 10)
    (tmp_path / "p.csv").write_text(f"t,x1,ubar_n\n0,0,0.6\n1,{big},0.6\n")
    (tmp_path / "case.json").write_text(json.dumps(case({"csv": "p.csv"})))
    with pytest.raises(CaseError, match=r"p.csv' line 3: field larger than field limit"):
        load_case(tmp_path / "case.json")
    out = driver_cli(str(tmp_path / "case.json"))
    assert out.returncode == 2 and "field larger than field limit" in out.stderr, out
    assert "Traceback" not in out.stderr, out.stderr
