"""Bad DATA.json of the calibration: refused by the library (``CalibrationError`` naming the
field or the parameters) and by the command line (exit 2, one ``error:`` line, no traceback, no
FIT.json), before the fit; parameters the curves cannot identify likewise."""

import json

import numpy as np
import pytest

from subfric_dolfinx.calibrate import CalibrationError, fit, parse_data, synthetic_curves
from subfric_dolfinx.calibrate.cli import main
from subfric_dolfinx.constitutive import preset
from tests.helpers import module_cli

pytestmark = pytest.mark.numpy_only

TRUE = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}
SLIP = np.linspace(0.0, 3.0, 31)
CURVES = synthetic_curves(TRUE, [150.0, 450.0], [1.0, 1.0], SLIP)
GOOD = {"params": TRUE, "fit": ["mu_k", "kappa"], "curves": CURVES}


def data(**changes):
    d = json.loads(json.dumps(GOOD))
    d.update(changes)
    return d


def curve(i=0, **changes):
    cs = json.loads(json.dumps(CURVES))
    cs[i].update(changes)
    return data(curves=cs)


def rejected(tmp_path, obj_or_text, *words):
    """Refused by parse_data (when an object) and by main (exit 2, nothing written)."""
    if not isinstance(obj_or_text, str | bytes):
        with pytest.raises(CalibrationError) as e:
            parse_data(obj_or_text)
        for w in words:
            assert w in str(e.value), (w, str(e.value))
        obj_or_text = json.dumps(obj_or_text)
    src = tmp_path / "data.json"
    if isinstance(obj_or_text, bytes):
        src.write_bytes(obj_or_text)
    else:
        src.write_text(obj_or_text)
    out = tmp_path / "fit.json"
    assert main([str(src), "--out", str(out), "--quiet"]) == 2
    assert not out.exists()


BIG = "1" + "0" * 399


@pytest.mark.parametrize(
    ("obj", "words"),
    [
        (data(params={**TRUE, "mu_static": 500.0}), ("unknown parameter names", "mu_static")),
        (data(params={k: v for k, v in TRUE.items() if k != "xi"}), ("missing", "xi")),
        (data(params={**TRUE, "kappa": "1.5"}), ("params.kappa", "number")),
        (data(params={**TRUE, "mu_k": float("nan")}), ("params.mu_k", "finite")),
        (data(params={**TRUE, "mu_k": 600.0}), ("mu_s >= mu_k",)),
        (data(fit=["mu_k", "friction"]), ("'fit'", "friction")),
        (data(fit=[]), ("'fit'", "non-empty")),
        (data(fit=["kappa", "kappa"]), ("more than once", "kappa")),
        (data(bounds={"xi": [0, 1]}), ("bounds", "xi", "not fitted")),
        (data(bounds={"kappa": [2.0, 3.0]}), ("params.kappa", "outside its bounds")),
        (data(bounds={"kappa": [3.0, 2.0]}), ("bounds.kappa", "lo < hi")),
        (data(bounds={"kappa": [1.0]}), ("bounds.kappa", "[lo, hi]")),
        (data(params={**TRUE, "kappa": 0.0}), ("params.kappa", "must be > 0")),
        (data(extra=1), ("unknown fields", "extra")),
        (data(curves=[]), ("'curves'", "non-empty")),
        (curve(slip=[0.0, 0.2, 0.2, *SLIP[3:].tolist()]), ("curves[0].slip[2]", "increase")),
        (curve(1, slip=list(SLIP[::-1])), ("curves[1].slip", "increase")),
        (curve(slip=list(SLIP - 0.5)), ("curves[0].slip[0]", ">= 0")),
        (curve(f_t=CURVES[0]["f_t"][:-1]), ("curves[0].f_t", "30 values for 31")),
        (curve(f_t=[None] * 31), ("curves[0].f_t[0]", "number")),
        (curve(f_n=0.0), ("curves[0].f_n", "> 0")),
        (curve(1, velocity=-1.0), ("curves[1].velocity", "> 0")),
        (curve(velocity=float("inf")), ("curves[0].velocity", "finite")),
        (curve(slip=[0.0], f_t=[0.0]), ("curves[0].slip", "at least two")),
        (curve(mu=1), ("curves[0]", "unknown keys", "mu")),
        (data(curves=[{"f_n": 300, "velocity": 1, "slip": [0, 1]}]), ("curves[0].f_t", "missing")),
        (
            data(
                curves=[{"f_n": 300, "velocity": 1, "slip": [0, 1], "f_t": [0, 1]}],
                fit=["mu_s", "mu_k", "kappa"],
            ),
            ("2 points for 3",),
        ),
    ],
)
def test_bad_data(tmp_path, obj, words):
    rejected(tmp_path, obj, *words)


@pytest.mark.parametrize(
    "text",
    [
        b"\xff\xfe{\x00}",
        "[" * 100_000 + "]" * 100_000,
        json.dumps(GOOD).replace("500.0", BIG, 1),
        '"a string"',
        "",
        json.dumps(GOOD)[:-5],
        '{"curves": [], ' + json.dumps(GOOD)[1:],
    ],
    ids=["utf16", "deep", "400-digits", "string", "empty", "truncated", "duplicate-key"],
)
def test_malformed_files(tmp_path, text):
    rejected(tmp_path, text)


def test_missing_file_and_bad_out(tmp_path, capsys):
    out = tmp_path / "fit.json"
    assert main([str(tmp_path / "nope.json"), "--out", str(out)]) == 2
    assert "cannot read data file" in capsys.readouterr().err
    src = tmp_path / "data.json"
    src.write_text(json.dumps(GOOD))
    assert main([str(src), "--out", str(tmp_path / "missing" / "fit.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main([str(src), "--out", str(out), "--plot", str(tmp_path / "fit.pdf")]) == 2
    assert ".png" in capsys.readouterr().err
    assert main([str(src)]) == 2  # --out is required
    assert "--out" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("fitted", "f_n", "velocity", "words"),
    [
        (["alpha_n", "mu_k"], [150, 450], [1, 1], ("alpha_n", "normal gap")),
        (["xi", "kappa"], [150, 450], [1, 1], ("xi together with kappa", "one velocity")),
        (["xi", "mu_k"], [150, 450], [1, 1], ("xi together with mu_k", "one velocity")),
        (["c_n", "mu_s", "mu_k"], [300, 300], [1, 2], ("c_n together with mu_s and mu_k",)),
    ],
)
def test_parameters_the_curves_cannot_identify_by_rule(tmp_path, fitted, f_n, velocity, words):
    curves = synthetic_curves(TRUE, f_n, velocity, SLIP)
    d = parse_data(data(fit=fitted, curves=curves))
    with pytest.raises(CalibrationError, match="cannot identify") as e:
        fit(d)
    for w in words:
        assert w in str(e.value), str(e.value)
    src = tmp_path / "data.json"
    src.write_text(json.dumps(data(fit=fitted, curves=curves)))
    proc = module_cli("calibrate", src, "--out", tmp_path / "fit.json", timeout=300)
    assert proc.returncode == 2 and proc.stderr.startswith("error: the data cannot identify")
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "fit.json").exists()


def test_parameters_the_curves_cannot_identify_by_the_jacobian():
    """What no rule lists, the Jacobian at the start values finds, before the fit: without
    softening (kappa = 0) mu stays at mu_s, so neither mu_k nor xi changes any curve; and the
    curves at one normal stress show only g(f_n) mu_s, so c_n and mu_s trade off (the
    combination is named)."""
    p = {**TRUE, "kappa": 0.0}
    two = synthetic_curves(p, [300.0, 600.0], [1.0, 0.1], SLIP)
    with pytest.raises(CalibrationError, match="mu_k, xi: the curves do not change with them"):
        fit(parse_data({"params": p, "fit": ["mu_k", "xi"], "curves": two}))
    one = synthetic_curves(p, [300.0, 300.0], [1.0, 0.5], SLIP)
    with pytest.raises(CalibrationError, match="along the combination") as e:
        fit(parse_data({"params": p, "fit": ["c_n", "mu_s"], "curves": one}))
    assert "c_n" in str(e.value) and "mu_s" in str(e.value)
