"""Bad CASE.json of the material-point driver: refused by the library (``CaseError`` naming the
field) and by the command line (exit code 2, the field named on stderr, nothing on stdout, no
output file), before any step."""

import json

import pytest

from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.driver import CaseError, load_case, main, parse_case, run_case
from tests.helpers import driver_cli, raised_on_every_rank

pytestmark = pytest.mark.numpy_only

NAN, INF = float("nan"), float("inf")
CASE = {
    "params": {"preset": "sec7"},
    "control": "disp",
    "path": [[0.0, 0.0, 0.0, 1.2], [0.3, 0.3, 0.0, 1.2], [0.5, 0.3, 0.2, 1.2]],
    "t_samples": [0.0, 0.3, 0.5],
    "n_tangential": 2,
    "steps_per_mm": 100,
}


def base_case():
    return json.loads(json.dumps(CASE))


def mutated(where, value):
    """A copy of CASE with the item at ``where`` (a tuple of keys/indices) set to ``value``."""
    case = base_case()
    obj = case
    for k in where[:-1]:
        obj = obj[k]
    obj[where[-1]] = value
    return case


def write(tmp_path, obj, name="case.json"):
    f = tmp_path / name
    f.write_text(obj if isinstance(obj, str) else json.dumps(obj))  # NaN, Infinity allowed
    return f


def run_cli(tmp_path, case, *args):
    """Write ``case`` and run the CLI's main in-process with ``--out``; return (exit code, out
    path)."""
    out = tmp_path / "result.json"
    return main([str(write(tmp_path, case)), "--out", str(out), *args]), out


def check_rejected(tmp_path, case, *words):
    """Refused by the library and by the command line (a separate process), naming ``words``."""
    with raised_on_every_rank(CaseError, *words):
        parse_case(case)
    proc = driver_cli(write(tmp_path, case))
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert proc.stderr.startswith("error: ")
    for w in words:
        assert w in proc.stderr, (w, proc.stderr)
    assert proc.stdout == ""


# --------------------------------------------------------------------------------------------
# Missing, unknown and wrongly typed fields


@pytest.mark.parametrize("field", ["params", "control", "path", "t_samples"])
def test_missing_field(tmp_path, field):
    case = base_case()
    del case[field]
    check_rejected(tmp_path, case, f"'{field}'")


def test_missing_parameter(tmp_path):
    case = base_case()
    case["params"] = {k: v for k, v in preset("sec7").parameters().items() if k != "kappa"}
    check_rejected(tmp_path, case, "'params'", "kappa")


@pytest.mark.parametrize(
    ("where", "key", "words"),
    [("top", "stepsPerMM", ("stepsPerMM",)), ("params", "alpha", ("'params'", "alpha"))],
)
def test_unknown_field(tmp_path, where, key, words):
    case = base_case()
    (case if where == "top" else case["params"])[key] = 1.0
    check_rejected(tmp_path, case, *words)


@pytest.mark.parametrize(
    ("mutate", "words"),
    [
        (lambda c: c["path"][1].__setitem__(1, "0.3"), ("path[1][1]", "number")),
        (lambda c: c.__setitem__("t_samples", 0.3), ("t_samples",)),
        (lambda c: c.__setitem__("n_tangential", "2"), ("n_tangential",)),
        (lambda c: c.__setitem__("params", ["sec7"]), ("'params'", "object")),
        (lambda c: c["params"].__setitem__("mu0", "400"), ("mu0", "real number")),
        (lambda c: c.__setitem__("steps_per_mm", True), ("steps_per_mm",)),
        (lambda c: c["path"].__setitem__(2, [0.5, 0.3, 0.2]), ("path[2]",)),
    ],
    ids=["path-str", "samples-scalar", "nt-str", "params-list", "param-str", "spm-bool", "row3"],
)
def test_wrong_type(tmp_path, mutate, words):
    case = base_case()
    mutate(case)
    check_rejected(tmp_path, case, *words)


@pytest.mark.parametrize("control", ["force", "", None, "Disp"])
def test_bad_control(tmp_path, control):
    case = base_case()
    case["control"] = control
    check_rejected(tmp_path, case, "'control'")


def test_unreadable_or_invalid_json(tmp_path):
    proc = driver_cli(tmp_path / "missing.json")
    assert proc.returncode == 2 and "cannot read" in proc.stderr
    proc = driver_cli(write(tmp_path, '{"params": {"preset": "sec7"},'))
    assert proc.returncode == 2 and "not valid JSON" in proc.stderr


# --------------------------------------------------------------------------------------------
# Times


@pytest.mark.parametrize(
    ("mutate", "words"),
    [
        (lambda c: c["path"][2].__setitem__(0, 0.3), ("path[2][0]", "increase")),
        (lambda c: c["path"][1].__setitem__(0, -0.1), ("path[1][0]",)),
        (lambda c: c.__setitem__("t_samples", [0.0, 0.3, 0.1]), ("t_samples[2]",)),
    ],
    ids=["path-equal", "path-decreasing", "samples-decreasing"],
)
def test_non_increasing_times(tmp_path, mutate, words):
    case = base_case()
    mutate(case)
    check_rejected(tmp_path, case, *words)


@pytest.mark.parametrize("t", [-0.01, 0.51, 1e9])
def test_sample_out_of_range(tmp_path, t):
    case = base_case()
    case["t_samples"] = [0.0, t]
    check_rejected(tmp_path, case, "t_samples[1]", "outside")


# --------------------------------------------------------------------------------------------
# Non-finite values


NON_FINITE_CASES = [
    (("path", 1, 0), NAN, "path[1][0]"),
    (("path", 1, 1), NAN, "path[1][1]"),
    (("path", 2, 2), INF, "path[2][2]"),
    (("path", 0, 3), -INF, "path[0][3]"),
    (("path", 2, 0), INF, "path[2][0]"),
    (("t_samples", 1), NAN, "t_samples[1]"),
    (("t_samples", 2), INF, "t_samples[2]"),
    (("t_samples", 0), -INF, "t_samples[0]"),
    (("steps_per_mm",), INF, "steps_per_mm"),
    (("steps_per_mm",), NAN, "steps_per_mm"),
]


@pytest.mark.parametrize(
    ("where", "value", "field"),
    NON_FINITE_CASES,
    ids=[f"{f}={v!r}" for _, v, f in NON_FINITE_CASES],
)
def test_case_with_non_finite_value(tmp_path, capsys, where, value, field):
    case = mutated(where, value)
    words = [f"'{field}'", repr(value)]
    with raised_on_every_rank(CaseError, *words):
        parse_case(case)
    with raised_on_every_rank(CaseError, *words):
        load_case(write(tmp_path, case, "c.json"))
    code, out = run_cli(tmp_path, case)
    err = capsys.readouterr()
    assert code == 2 and err.out == "" and err.err.startswith("error: ")
    assert all(w in err.err for w in words), err.err
    assert not out.exists(), "a bad case created the output file"


@pytest.mark.parametrize(
    ("where", "value", "field"),
    [(("path", 1, 1), NAN, "path[1][1]"), (("t_samples", 1), INF, "t_samples[1]")],
)
def test_cli_process_on_a_bad_case_writes_nothing(tmp_path, where, value, field):
    """The real command line (a separate process): exit code 2, the field named, no file."""
    out = tmp_path / "result.json"
    proc = driver_cli(write(tmp_path, mutated(where, value)), "--out", out)
    assert proc.returncode == 2, proc.stderr
    assert f"'{field}'" in proc.stderr and repr(value) in proc.stderr
    assert proc.stdout == "" and not out.exists()


# --------------------------------------------------------------------------------------------
# Parameters and steps


@pytest.mark.parametrize("value", [NAN, INF, -1.0])
def test_case_with_invalid_parameter_value(tmp_path, capsys, value):
    case = mutated(("params", "kappa"), value)
    with raised_on_every_rank(CaseError, "'params'", f"kappa = {value!r}"):
        parse_case(case)
    code, out = run_cli(tmp_path, case)
    assert code == 2 and f"kappa = {value!r}" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("params", "words"),
    [
        ({"preset": "sec7", "alpha_t": -500.0}, ("alpha_t", "alpha_t > 0")),
        ({"preset": "sec7", "mu0": 600.0}, ("mu0",)),
        ({"preset": "sec7", "mu_s": 10.0}, ("mu_s", "mu_k")),
        ({"preset": "sec7", "xi": -1.0}, ("xi",)),
        ({"preset": "sec8"}, ("params.preset", "sec8")),
    ],
    ids=["alpha_t", "mu0", "mu_s", "xi", "preset"],
)
def test_case_with_invalid_parameters_over_a_preset(tmp_path, params, words):
    case = base_case()
    case["params"] = params
    check_rejected(tmp_path, case, *words)


def test_case_with_zero_steps_per_mm(tmp_path):
    check_rejected(tmp_path, mutated(("steps_per_mm",), 0), "steps_per_mm")


@pytest.mark.parametrize("value", ["0", "-5", "nan", "inf"])
def test_cli_bad_steps_per_mm(tmp_path, capsys, value):
    code, out = run_cli(tmp_path, CASE, "--steps-per-mm", value)
    err = capsys.readouterr().err
    assert code == 2 and "--steps-per-mm" in err and repr(float(value)) in err, err
    assert not out.exists()


@pytest.mark.parametrize("value", [1e300, 1e100, 1e12])
def test_case_with_absurd_path_magnitude(tmp_path, capsys, value):
    """A path change needing more than 1e7 steps per segment (overflowing at 1e300 mm)."""
    case = mutated(("path", 1, 1), value)
    with raised_on_every_rank(CaseError, "field 'path'", f"{value:g} mm", "steps_per_mm = 100"):
        run_case(case)
    code, out = run_cli(tmp_path, case)
    err = capsys.readouterr().err
    assert code == 2 and "field 'path'" in err and f"{value:g} mm" in err, err
    assert not out.exists()


# --------------------------------------------------------------------------------------------
# Malformed files (issue 12, item 8): one error line and exit code 2, never a traceback


def cli_rejects(tmp_path, text_or_bytes, *words, name="case.json"):
    """The real command line on a file with these contents: exit 2, ``error:`` naming ``words``,
    no traceback, nothing on stdout, no output file."""
    f = tmp_path / name
    if isinstance(text_or_bytes, bytes):
        f.write_bytes(text_or_bytes)
    else:
        f.write_text(text_or_bytes)
    out = tmp_path / "result.json"
    proc = driver_cli(f, "--out", out)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert proc.stderr.startswith("error: ") and "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    for w in words:
        assert w in proc.stderr, (w, proc.stderr)
    assert proc.stdout == "" and not out.exists()
    return proc


BIG = "1" + "0" * 399  # a 400-digit integer


@pytest.mark.parametrize(
    ("contents", "words"),
    [
        (b"\xff\xfe{\x00}", ("not UTF-8",)),
        (json.dumps(CASE).encode("utf-8").replace(b"disp", b"d\xe9sp"), ("not UTF-8",)),
        ("[" * 100_000 + "]" * 100_000, ("nests too deeply",)),
        ('{"params": ' + "[" * 5000 + "]" * 5000 + "}", ("'params'",)),
        (
            json.dumps(CASE).replace('"steps_per_mm": 100', f'"steps_per_mm": {BIG}'),
            ("steps_per_mm", "must be finite"),
        ),
        (
            json.dumps(CASE).replace("[0.3, 0.3, 0.0, 1.2]", f"[0.3, {BIG}, 0.0, 1.2]"),
            ("path[1][1]", "must be finite"),
        ),
        (
            json.dumps(CASE).replace('"n_tangential": 2', f'"n_tangential": {BIG}'),
            ("n_tangential",),
        ),
        (
            json.dumps(CASE).replace('"preset": "sec7"', f'"preset": "sec7", "kappa": {BIG}'),
            ("kappa",),
        ),
        (
            json.dumps(CASE).replace('"steps_per_mm": 100', '"steps_per_mm": ' + "9" * 5000),
            ("is not valid",),
        ),
        ('"a string"', ("JSON object",)),
        ("", ("not valid JSON",)),
        (json.dumps({**CASE, "control": ["disp"]}), ("'control'",)),
        (json.dumps({**CASE, "t_samples": {"a": 1}}), ("t_samples",)),
        (json.dumps({**CASE, "law": {"subloading": 1}}), ("'law'",)),
        (json.dumps({**CASE, "path": [[0, 0, 0, 1.2], [0.3, "x", 0, 1.2]]}), ("path[1][1]",)),
        (
            json.dumps(CASE).replace(
                '"steps_per_mm": 100', '"steps_per_mm": 100, "steps_per_mm": 1'
            ),
            ("the key 'steps_per_mm' twice in one object", "JSON would keep the last"),
        ),
        (
            json.dumps(CASE).replace('"preset": "sec7"', '"preset": "sec7", "preset": "sec7"'),
            ("the key 'preset' twice",),
        ),
    ],
    ids=[
        "bom16",
        "latin1",
        "deep",
        "deep-field",
        "big-spm",
        "big-path",
        "big-nt",
        "big-param",
        "5000-digits",
        "string",
        "empty",
        "control-list",
        "samples-dict",
        "law-dict",
        "row-str",
        "duplicate-key",
        "duplicate-nested",
    ],
)
def test_malformed_file_gets_one_error_line(tmp_path, contents, words):
    cli_rejects(tmp_path, contents, *words)


def test_a_directory_as_case_file(tmp_path):
    (tmp_path / "dir.json").mkdir()
    out = tmp_path / "result.json"
    proc = driver_cli(tmp_path / "dir.json", "--out", out)
    assert proc.returncode == 2 and "is a directory" in proc.stderr and not out.exists()


# --------------------------------------------------------------------------------------------
# --out is checked before the run and written atomically


@pytest.mark.parametrize(
    ("target", "words"),
    [
        ("missing/result.json", ("does not exist",)),
        (".", ("directory",)),
        ("adir", ("is a directory",)),
        ("/dev/full", ("not a regular file",)),
    ],
)
def test_bad_out_is_refused_before_the_run(tmp_path, target, words):
    (tmp_path / "adir").mkdir()
    case = base_case()
    case["steps_per_mm"] = 1e6  # (a run that would take minutes: refused before it starts)
    f = write(tmp_path, case)
    out = target if target.startswith("/") else str(tmp_path / target)
    proc = driver_cli(f, "--out", out, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: ") and "--out" in proc.stderr, proc.stderr
    for w in words:
        assert w in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""


def test_out_is_written_atomically(tmp_path, monkeypatch, capsys):
    """A write that fails (disk full, injected at the flush to disk) leaves the previous result
    intact and no temporary file behind; exit code 1, one error line."""
    import errno
    import os

    out = tmp_path / "result.json"
    out.write_text("previous result\n")

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    code = main([str(write(tmp_path, CASE)), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "error: cannot write" in err and "No space left" in err, err
    assert out.read_text() == "previous result\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.json", "result.json"]
    monkeypatch.undo()
    assert main([str(write(tmp_path, CASE)), "--out", str(out)]) == 0
    assert json.loads(out.read_text())["complete"] is True


# --------------------------------------------------------------------------------------------
# Step limits: per knot interval and in total, before any step


def test_total_step_limit_is_checked_up_front(tmp_path, capsys):
    """10^4 segments of 5e6 steps each: every segment is within the per-segment limit (1e7), the
    total (5e10) is not; refused at once, naming the total."""
    import time

    rows = [[float(i), 0.5 * (i % 2), 0.0, 1.2] for i in range(10_001)]
    case = {**base_case(), "path": rows, "t_samples": [0.0, 10_000.0], "steps_per_mm": 1e7}
    t0 = time.perf_counter()
    with raised_on_every_rank(CaseError, "field 'path'", "steps in all", "5e+10"):
        run_case(case)
    assert time.perf_counter() - t0 < 30.0  # (generous: it is a check, not a run)
    code, out = run_cli(tmp_path, case)
    assert code == 2 and "steps in all" in capsys.readouterr().err and not out.exists()
    code, out = run_cli(tmp_path, CASE, "--max-steps", "10")  # the limit is an option too
    assert code == 2 and "steps in all" in capsys.readouterr().err and not out.exists()
