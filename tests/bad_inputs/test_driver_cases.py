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
    ("where", "value", "field"), [(("path", 1, 1), NAN, "path[1][1]"), (("t_samples", 1), INF,
                                                                         "t_samples[1]")]
)  # fmt: skip
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
