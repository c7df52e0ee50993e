"""The paper-figure demo (demos/paper_figures.py) in --quick mode: files, and the physics the
paper describes, checked on the written CSV data."""

import collections
import csv
import math
import subprocess
import sys

import numpy as np
import pytest

from demos import paper_figures
from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.logs import singleton_environment
from tests.helpers import ROOT, python_env

pytestmark = pytest.mark.numpy_only

DEMO = ROOT / "demos" / "paper_figures.py"
FIGS = ("fig5", "fig6", "fig7", "fig8", "fig9", "fig10", "fig11")


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    d = tmp_path_factory.mktemp("paper_figures")
    written = paper_figures.run_demo(d, quick=True, verbose=False)
    assert sorted(written) == sorted(FIGS)
    return d


def read(out, fig):
    """CSV -> {(panel, series): {column: array}} (numeric columns only)."""
    groups = collections.defaultdict(lambda: collections.defaultdict(list))
    with (out / f"{fig}.csv").open() as f:
        for row in csv.DictReader(f):
            key = (row.pop("panel"), row.pop("series"))
            for k, v in row.items():
                groups[key][k].append(float(v))
    return {k: {c: np.array(v) for c, v in cols.items()} for k, cols in groups.items()}


def g(name, f_n):
    return -math.expm1(-PRESETS[name].law.c_n * f_n)


def mu_steady(name):
    p, v = PRESETS[name].law, PRESETS[name].slip_rate
    return (p.kappa * v * p.mu_k + p.xi * p.mu_s) / (p.kappa * v + p.xi)


def test_files_exist(out):
    for fig in FIGS:
        png, data = out / f"{fig}.png", out / f"{fig}.csv"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", fig
        assert png.stat().st_size > 10_000
        lines = data.read_text().splitlines()
        assert len(lines) > 10 and lines[0].startswith("panel,series,"), fig


def test_fig10_peak_then_softening_to_a_kinetic_level(out):
    d = read(out, "fig10")
    for f_n in (100, 200, 300, 400, 500, 600):
        c = d["subloading", f"f_n={f_n}"]
        u, ft = c["ubar_t_mm"], c["f_t_MPa"]
        k = int(np.argmax(ft))
        assert 0.05 < u[k] < 0.5  # an early static peak ...
        final = ft[-1]
        assert ft[k] > 4.0 * final  # ... far above the kinetic level ...
        assert np.all(np.diff(ft[k:]) <= 1e-9 * ft[k])  # ... reached by monotonic softening,
        at10 = np.interp(10.0, u, ft)
        assert abs(at10 - final) < 1e-3 * final  # settled by 10 mm,
        # at the steady-sliding level g(f_n) mu_inf of the 1 mm/s test (kinetic + recovery)
        assert final == pytest.approx(g("sec7", f_n) * mu_steady("sec7"), rel=2e-3)
        cc = d["coulomb", f"f_n={f_n}"]["f_t_MPa"]
        assert cc.max() == pytest.approx(cc[-1], rel=1e-12)  # Coulomb: no peak
    # the peak grows with the normal stress, sublinearly (saturation)
    peaks = np.array([d["subloading", f"f_n={f}"]["f_t_MPa"].max() for f in (100, 600)])
    assert peaks[1] > peaks[0] and peaks[1] / peaks[0] < 6.0


def test_fig11_ratio_falls_with_normal_stress_while_coulombs_is_constant(out):
    d = read(out, "fig11")
    for slip in ("1", "5", "10", "20"):
        s = d["subloading", f"slip={slip}mm"]
        c = d["coulomb", f"slip={slip}mm"]
        assert np.all(np.diff(s["f_n_MPa"]) > 0)
        assert np.all(np.diff(s["ratio"]) < 0.0), (slip, s["ratio"])  # saturation
        np.testing.assert_allclose(c["ratio"], c["ratio"][0], rtol=1e-12)  # Coulomb: constant
        i100 = int(np.flatnonzero(s["f_n_MPa"] == 100.0)[0])
        assert s["f_t_MPa"][i100] == pytest.approx(c["f_t_MPa"][i100], rel=1e-12)  # calibration
        assert s["f_t_MPa"][-1] < c["f_t_MPa"][-1]  # below the line at 600 MPa
    # fully softened (5, 10, 20 mm): the ratio follows g(f_n) / f_n exactly
    s = d["subloading", "slip=20mm"]
    expect = np.array([g("sec7", f) / f for f in s["f_n_MPa"]])
    np.testing.assert_allclose(s["ratio"] / s["ratio"][0], expect / expect[0], rtol=2e-3)
    # at 0.5 mm it rises slightly (see the demo: more of the displacement is elastic)
    assert np.all(np.diff(d["subloading", "slip=0.5mm"]["ratio"]) > 0.0)


def unload_end(c):
    """Index of the first sample after t = 0 at zero stress (the end of the unloading)."""
    ft = c["f_t_MPa"]
    return int(np.flatnonzero(np.abs(ft[1:]) < 1e-6 * np.abs(ft).max())[0]) + 1


def test_fig7_longer_holds_recover_more(out):
    d = read(out, "fig7")
    holds = ("0", "20", "60", "180", "600")
    gain = {}
    for panel in ("sec6-mus10000", "sec6-mus7500"):
        peaks = []
        for h in holds:
            c = d[panel, f"hold={h}s"]
            k = unload_end(c)
            if h != "0":  # one sample at the end of the hold: at rest, mu recovered
                assert c["t_s"][k + 1] - c["t_s"][k] == pytest.approx(float(h))
                assert c["f_t_MPa"][k + 1] == c["f_t_MPa"][k]
                assert c["mu_MPa"][k + 1] > c["mu_MPa"][k]
            peaks.append(c["f_t_MPa"][k + 1 :].max())
        peaks = np.array(peaks)
        assert np.all(np.diff(peaks) > 0.0), (panel, peaks)  # longer hold, higher peak
        first = d[panel, "hold=0s"]["f_t_MPa"].max()  # the virgin peak
        assert peaks[0] < first
        assert peaks[-1] == pytest.approx(first, rel=0.01)  # 600 s: recovered almost fully
        gain[panel] = peaks[-1] / peaks[0]
    # more to recover with the higher static level
    assert gain["sec6-mus10000"] > gain["sec6-mus7500"] > 1.0


def test_higher_static_level_gives_a_higher_peak(out):
    d5, d6 = read(out, "fig5"), read(out, "fig6")
    for f_n in (1000, 2000, 3000, 4000, 5000):
        hi = d6["sec6-mus10000", f"f_n={f_n}"]["f_t_MPa"].max()
        lo = d6["sec6-mus7500", f"f_n={f_n}"]["f_t_MPa"].max()
        assert hi > lo
        p_hi = d5["sec6-mus10000", f"peak f_n={f_n}"]["f_t_MPa"][0]
        p_lo = d5["sec6-mus7500", f"peak f_n={f_n}"]["f_t_MPa"][0]
        assert p_hi > p_lo
        for name in ("sec6-mus10000", "sec6-mus7500"):
            peak = d5[name, f"peak f_n={f_n}"]["f_t_MPa"][0]
            end = d5[name, f"end f_n={f_n}"]["f_t_MPa"][0]
            mu_s = PRESETS[name].law.mu_s
            assert peak < g(name, f_n) * mu_s  # inside the normal-yield surface
            assert end == pytest.approx(g(name, f_n) * mu_steady(name), rel=5e-3)


def test_fig6_reverse_sliding_has_no_new_static_peak(out):
    d = read(out, "fig6")
    for f_n in (1000, 3000, 5000):
        c = d["sec6-mus10000", f"f_n={f_n}"]["f_t_MPa"]
        assert -c.min() < c.max()  # the reverse branch stays below the forward peak
        assert c[-1] < 0.0 and abs(c[-1]) < c.max()


def test_fig9_pulsating_maxima_fall_with_cycles_and_rise_with_hold(out):
    d = read(out, "fig9")
    for panel in ("sec6-mus10000", "sec6-mus7500"):
        maxima = {h: d[panel, f"max hold={h}s"]["f_t_MPa"] for h in ("10", "60", "300")}
        short = maxima["10"]
        assert len(short) == 5
        assert np.all(np.diff(short[1:]) < 0.0), short  # decreasing with the cycles ...
        assert short[1] < short[0]  # (the first is the virgin peak)
        for c in range(1, 5):  # ... and higher after longer holds
            assert maxima["10"][c] < maxima["60"][c] < maxima["300"][c], (panel, c)


def test_fig8_reciprocal_reload_peaks_grow_with_hold(out):
    d = read(out, "fig8")
    holds = ("0", "20", "60", "180", "600")
    for panel in ("sec6-mus10000", "sec6-mus7500"):
        # backward reloads: the most negative stress after the first unloading
        mins = []
        for h in holds:
            c = d[panel, f"hold={h}s"]
            mins.append(-c["f_t_MPa"].min())
        assert np.all(np.diff(mins) > 0.0), (panel, mins)


def test_demo_command_line(tmp_path):
    """The script runs as a program (MPI launcher variables removed: this may run under mpirun,
    and the demo must not start MPI in a child)."""
    env = python_env(singleton_environment())
    env["MPLBACKEND"] = "Agg"
    cmd = [sys.executable, str(DEMO), "--quick", "--only", "fig5", "--out", str(tmp_path)]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "fig5.png").exists() and (tmp_path / "fig5.csv").exists()
    assert not (tmp_path / "fig6.png").exists()
    proc = subprocess.run(
        [sys.executable, str(DEMO), "--only", "fig12", "--out", str(tmp_path)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and "fig12" in proc.stderr
