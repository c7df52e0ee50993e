"""Every demo as a program, at a small size, once.

The demos' physics is tested in-process on the suite's ranks (``test_fe_demos.py``,
``test_scenes.py``, ``test_elastic_smoke.py``, ``test_paper_figures.py``), and every demo's
``main`` at its smallest size, files included, on the ranks its record was made on
(``test_records.py``: the FE demos on 2); here each demo runs the way a user runs it:
``python3 demos/<name>.py`` (its ``__main__`` block, the command line, the exit code, the
figures and files it writes, each CSV file's units), in a subprocess with a timeout; the
numpy-only demos under ``mpirun -n 2``, where rank 0 alone computes and writes; with the
package's warnings as errors (``-W error::subfric_dolfinx.logs.SubfricWarning``: no demo leaves
its model's validity; the default runs' records say the same, ``test_records.py``). Each demo's
output stays within 30 lines; the quick calibration's fit lands within a few standard errors of
the truth its curves were made from. The API demo (``two_bodies_api``) is also run in-process,
on the suite's ranks, and checked for what its text says.
"""

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI

from demos import two_bodies_api
from tests.helpers import ROOT, everywhere, on_root, singleton_env

# demo -> (small command line, files it must write into --out)
SMALL = {
    "block_on_base": (
        ["--n", "4", "--hold", "1", "--dt", "0.1"],
        ["history.csv", "force_slip.png", "interface_profiles.png"],
    ),
    "pad_on_plate": (
        ["--n", "2", "--holds", "0", "5", "--dt", "0.1", "--fields", "xdmf"],
        ["history.csv", "fields/interface_points.xdmf"],
    ),
    "punch": (["--n", "4", "--dt", "0.1"], ["subloading/history.csv", "coulomb/history.csv"]),
    "lap_joint": (
        ["--n", "4", "--cycles", "2", "--dt", "0.2"],
        ["subloading/history.csv", "coulomb/history.csv"],
    ),
    "elastic_smoke": (["--n", "4"], ["u.xdmf"]),
    "paper_figures": (["--quick", "--only", "fig5"], ["fig5.png", "fig5.csv"]),
    "calibration": (["--quick"], ["DATA.json", "FIT.json", "calibration.png"]),
    "hertz": (["--n", "4"], ["history.csv", "pressure.png"]),
    "cattaneo_mindlin": (
        ["--n", "4", "--no-subloading"],
        ["coulomb/history.csv"],
    ),
    "bolted_joint": (
        ["--n", "2", "--cycles", "1"],
        ["history.csv", "hysteresis.png"],
    ),
    "user_loop": (["--n", "4", "--dt", "0.25"], ["history.csv"]),
    "shrink_fit": (
        ["--h", "5", "--steps", "4"],
        ["coulomb.csv", "subloading.csv", "shrink_fit.png"],
    ),
    "bolt_clamped_joint": (
        ["--h", "5", "--cycles", "1", "--dt", "1"],
        ["history.csv", "bolt_clamped_joint.png"],
    ),
    "fretting": (
        ["--n", "4", "--cycles", "1", "--steps", "4", "--no-subloading"],
        ["coulomb.csv", "fretting.png"],
    ),
    "block_sliding_far": (["--n", "4", "--slide", "20"], ["history.csv", "block_sliding_far.png"]),
    "stick_slip": (
        ["--steps", "100"],
        ["history.csv", "stick_slip.png", "stick_slip_study.png"],
    ),
    "two_bodies_api": (
        ["--n", "4", "--dt", "0.1", "--fields", "vtx"],
        ["history.csv", "fields/interface_points.xdmf", "fields/interface.bp"],
    ),
}


PROGRESS = re.compile(r"^t = \S+ s of \S+ \(")
"""A progress line, printed every 10 s of a long program segment: as many as the machine is slow."""


def shown(text):
    """The lines of a demo's output but its progress lines (their count depends on the speed)."""
    return [ln for ln in text.splitlines() if not PROGRESS.match(ln)]


def demos_on_disk():
    return sorted(p.stem for p in (ROOT / "demos").glob("*.py") if p.stem != "__init__")


def test_every_demo_is_listed():
    assert sorted(SMALL) == demos_on_disk()


@pytest.mark.filterwarnings("ignore:Jupyter is migrating its paths:DeprecationWarning")
@pytest.mark.parametrize("name", sorted(SMALL))
def test_every_demo_is_a_notebook_whose_first_cell_is_its_docstring(name, capsys):
    """The jupytext (percent) header, the docstring as the first Markdown cell, and ``--help``:
    the docstring's title, then each option with its default, in a few lines (the docstring is
    the demo's page, not its help)."""
    import importlib

    import jupytext

    nb = jupytext.read(ROOT / "demos" / f"{name}.py")
    assert nb.metadata["jupytext"]["text_representation"]["format_name"] == "percent"
    module = importlib.import_module(f"demos.{name}")
    first = nb.cells[0]
    assert first.cell_type == "markdown" and first.source.strip() == module.__doc__.strip()
    assert first.source.startswith("# ")  # a title
    kinds = {c.cell_type for c in nb.cells}
    assert kinds == {"markdown", "code"}
    with pytest.raises(SystemExit) as e:
        module.main(["--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    if MPI.COMM_WORLD.rank == 0 or name in ("calibration", "paper_figures", "elastic_smoke"):
        title = module.__doc__.splitlines()[0].lstrip("# ")
        options = text.count("\n  -")
        assert " ".join(title.split()) in " ".join(text.split()), text
        assert "(default: " in text, text
        assert len(text.splitlines()) <= 3 * options + 8, text  # a line or two per option
        assert module.__doc__.splitlines()[2] not in text  # the docstring's body is not the help
        # each default once: argparse's "(default: ...)", not a number in the text before it too
        assert not re.search(r"\([-+\d.e]+\) \(default:", " ".join(text.split())), text


def check_calibration(out, text):
    """The quick calibration: the refused fit said, the fit within a few standard errors of the
    truth the curves were made from (the demo's ``TRUE``), the residual at the noise's level."""
    import json

    from demos import calibration

    assert "refused on purpose: the data cannot identify xi together with kappa" in text, text
    assert sorted(p.name for p in out.iterdir()) == ["DATA.json", "FIT.json", "calibration.png"]
    data = json.loads((out / "DATA.json").read_text())
    fit = json.loads((out / "FIT.json").read_text())
    assert data["fit"] == ["mu_s", "mu_k", "kappa"] and len(data["curves"]) == 2
    assert fit["converged"]
    for k in data["fit"]:
        assert abs(fit["params"][k] - calibration.TRUE[k]) < 4.0 * fit["stderr"][k], k
    assert 0.1 < fit["rms"] < 0.3  # noise 0.2 MPa
    assert (out / "calibration.png").read_bytes()[:4] == b"\x89PNG"


def check_stick_slip(out, text):
    """The smallest stick-slip run (a coarse step, 100 a spring period): the FE block's last
    cycle within 5 % of the spring-slider's, period and stress drop (the independent check, FE
    against the rate equations within 2 % at the default step: tests/fem/test_dynamics.py);
    the material-point study printed and drawn, its trends as the docstring says (its numbers:
    tests/driver/test_slider.py checks the slider against the rate equations)."""
    found = re.findall(r"^(period|stress drop): FE (\S+) \S+, spring-slider (\S+) ", text, re.M)
    assert [f[0] for f in found] == ["period", "stress drop"], text
    for _, fe, point in found:
        assert float(fe) == pytest.approx(float(point), rel=0.05), text
    assert (out / "stick_slip.png").read_bytes()[:4] == b"\x89PNG"
    # the material-point study: settled cycles at each velocity; the peak after a hold grows
    # with the hold and stays below the recovered strength; stick-slip below k_c only
    sweep = re.findall(
        r"^  V = (\S+) mm/s: period (\S+) \+- (\S+) s, .* \((\d+) cycles\)", text, re.M
    )
    assert [v for v, *_ in sweep] == ["0.03", "0.1", "0.3", "1"], text
    assert all(int(n) >= 4 and float(sd) < 0.05 * float(T) for _, T, sd, n in sweep), text
    assert re.search(r"^  half the step at V = 0.3: period [-+]\d", text, re.M), text
    rows = {
        m[0]: [float(x) for x in m[1].split()]
        for m in re.findall(r"^  (hold|peak|g mu|k/k_c|range)((?: +\S+)+)$", text, re.M)
    }
    peak, strength = np.array(rows["peak"]), np.array(rows["g mu"])
    assert np.all(np.diff(peak[1:]) >= 0.0) and peak[-1] > peak[0] + 1.0, text
    assert np.all(peak[1:] < strength[1:]), text
    ratio, amplitude = np.array(rows["k/k_c"]), np.array(rows["range"])
    assert np.all(amplitude[ratio < 1.0] > 1.0) and np.all(amplitude[ratio > 1.05] < 0.01), text
    assert (out / "stick_slip_study.png").read_bytes()[:4] == b"\x89PNG"


CHECKS = {"calibration": check_calibration, "stick_slip": check_stick_slip}
NUMPY_ONLY = ("calibration", "paper_figures")
"""What a demo's program run is checked for beyond its exit, its output and its files."""


@pytest.mark.serial
@pytest.mark.parametrize("name", sorted(SMALL))
def test_the_demo_runs_as_a_program(tmp_path, name):
    args, files = SMALL[name]
    out = tmp_path / name
    strict = ["-W", "error::subfric_dolfinx.logs.SubfricWarning"]  # no validity warning either
    cmd = [sys.executable, *strict, f"demos/{name}.py", *args, "--out", str(out)]
    if name in NUMPY_ONLY:  # rank 0 computes and writes, the other returns at once
        cmd = ["mpirun", "-n", "2", *cmd]
    p = subprocess.run(
        cmd, cwd=ROOT, env=singleton_env(), capture_output=True, text=True, timeout=240
    )
    text = p.stdout + p.stderr
    assert p.returncode == 0, text
    assert "Traceback" not in text and "error" not in text.lower(), text
    missing = [f for f in files if not (out / f).exists()]
    assert not missing, (missing, sorted(str(q.relative_to(out)) for q in out.rglob("*")))
    assert len(shown(text)) <= 30, text  # quiet by default: a line per program segment
    for table in out.rglob("*.csv"):  # every CSV has its units (text columns: none)
        meta = json.loads(table.with_name(table.name + "-metadata.json").read_text())
        columns = meta["tableSchema"]["columns"]
        units = {c["name"]: c["schema:unitText"] for c in columns}
        assert list(units) == table.read_text().splitlines()[0].split(","), table
        assert "?" not in units.values(), (table, units)
        numbers = [c for c in columns if c.get("datatype", "number") == "number"]
        assert numbers and all(c["schema:unitText"] for c in numbers), (table, columns)
    for xdmf in out.rglob("*.xdmf"):  # every XDMF file says its functions' units
        units = re.findall(r'<Information Name="unit" Value="([^"]*)"', xdmf.read_text())
        assert units and "?" not in units, (xdmf, units)
    if name in CHECKS:
        CHECKS[name](out, p.stdout)


def test_the_api_demo_shows_what_it_says(shared_tmp):
    """Peak, softening, recovery in the hold and a second peak; the hold in a few steps; the
    leading edge pressed harder than the trailing one; the outputs written."""
    comm = MPI.COMM_WORLD
    res = two_bodies_api.main(
        ["--n", "8", "--dt", "0.05", "--fields", "xdmf", "--out", str(shared_tmp)], comm
    )
    h = res["history"]
    t = np.array([r["t"] for r in h])
    ft = np.array([r["F_t1"] / r["area"] for r in h])
    hold0, hold1 = two_bodies_api.TIMES[2:4]
    first = ft[(t > 1.0) & (t <= hold0)].max()
    held = ft[np.isclose(t, hold1)][0]
    second = ft[t > hold1].max()
    checks = [
        first > 1.3 * ft[np.isclose(t, hold0)][0],  # a static peak, then softening
        second > 1.1 * held,  # the hold recovered a peak
        np.sum((t > hold0) & (t <= hold1 + 1e-9)) <= 5,  # the hold in a handful of steps
    ]
    for p in res["profiles"].values():
        checks.append(p["f_n"][-1] > 1.05 * p["f_n"][0])  # leading edge (right) pressed harder
    assert everywhere(comm, all(checks)), (checks, first, held, second)
    on_root(
        comm,
        lambda: [
            (shared_tmp / f).stat()
            for f in ("history.csv", "fields/interface.xdmf", "fields/interface_points.xdmf")
        ],
    )
