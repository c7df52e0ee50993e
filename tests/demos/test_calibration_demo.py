"""The calibration demo (demos/calibration.py) in --quick mode: its files, the refused fit, and
a fit that lands within a few standard errors of the truth the curves were made from."""

import json

import pytest

from demos import calibration

pytestmark = pytest.mark.numpy_only


def test_quick_demo(tmp_path, capsys):
    res = calibration.run_demo(tmp_path, quick=True)
    out = capsys.readouterr().out
    assert "refused on purpose: the data cannot identify xi together with kappa" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "DATA.json",
        "FIT.json",
        "calibration.png",
    ]
    assert json.loads((tmp_path / "FIT.json").read_text()) == json.loads(json.dumps(res))
    data = json.loads((tmp_path / "DATA.json").read_text())
    assert data["fit"] == ["mu_s", "mu_k", "kappa"] and len(data["curves"]) == 2
    assert res["converged"]
    for k in data["fit"]:
        assert abs(res["params"][k] - calibration.TRUE[k]) < 4.0 * res["stderr"][k], k
    assert 0.1 < res["rms"] < 0.3  # noise 0.2 MPa
    assert (tmp_path / "calibration.png").read_bytes()[:4] == b"\x89PNG"
