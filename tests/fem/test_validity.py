"""Warnings about the model's validity reach every user (issue 24, items 1 and 2).

* :func:`subfric_dolfinx.logs.warn`: ``warnings.warn`` with the user's filters acting on every
  rank (an "error" filter raises on each, never on one alone), shown once per job (rank 0).
* The penetration warning (:class:`~subfric_dolfinx.fem.validity.ValidityWatch`): tolerance
  ``max(h, L/10)`` of bodies' material, the deepest point beyond it (checked against the gap
  gathered at every step), the ``alpha_n`` that removes it; the same verdict once the mesh is
  finer than L/10 (refining does not make it appear). An interface declaring its compliance
  intended (``Interface(..., intended_compliance=True)``, the scene key) is judged on its
  interpenetration only: ``ubar_n`` against a tenth of the interface element.
* The slide warning: a slide beyond three interface elements, not below; its advice names
  finite sliding.
* A plain script (no logging set up) sees the warning on stderr, once under ``mpirun -n 2``,
  even when warnings go to ``logging`` (FFCx 0.9 routes them there when imported).
* The log says what the interface does (pressing: sticking), a line per long segment only, and
  progress lines at a fixed interval.
"""

import logging
import warnings

import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx import logs, meshing
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    Material,
    steplog,
)
from subfric_dolfinx.fem.validity import (
    INTERPENETRATION_FRACTION,
    SLIDE_ELEMENTS,
    contact_modulus,
)
from subfric_dolfinx.loading import LoadingProgram
from tests.helpers import LAW, everywhere, leaves_validity, mpirun, prefix, raised_on_every_rank

MATERIALS = {"primary": Material(2.1e5, 0.3), "secondary": Material(7.0e4, 0.33)}
E_STAR = 1.0 / (0.91 / 2.1e5 + (1 - 0.33**2) / 7.0e4)


def test_warn_acts_on_every_rank_and_shows_once():
    comm = MPI.COMM_WORLD
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        logs.warn("a test warning", logs.SlideWarning, comm)
    mine = [w for w in seen if w.category is logs.SlideWarning]
    assert everywhere(comm, len(mine) == (1 if comm.rank == 0 else 0)), len(mine)
    assert comm.rank or str(mine[0].message) == "a test warning"
    assert comm.rank or mine[0].filename == __file__  # the caller, outside the package
    with warnings.catch_warnings():
        warnings.simplefilter("error", logs.SubfricWarning)
        with raised_on_every_rank(logs.PenetrationWarning, "a test warning"):
            logs.warn("a test warning", logs.PenetrationWarning, comm)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("ignore", logs.SubfricWarning)
        logs.warn("ignored", logs.SlideWarning, comm)
    assert not seen


def test_the_suite_raises_the_packages_warnings_unless_a_test_declares_them():
    """The suite's filter (pyproject.toml) makes a package warning an error on every rank;
    :func:`~tests.helpers.leaves_validity` lets the categories it names through and fails, on
    every rank, when one of them does not come; another package warning inside still raises."""
    comm = MPI.COMM_WORLD
    with raised_on_every_rank(logs.SlideWarning, "undeclared"):
        logs.warn("undeclared", logs.SlideWarning, comm)
    with leaves_validity(logs.SlideWarning, logs.PenetrationWarning):
        logs.warn("declared", logs.SlideWarning, comm)
        logs.warn("declared", logs.PenetrationWarning, comm)
    with raised_on_every_rank(AssertionError, "['PenetrationWarning']", "drop the declaration"):
        with leaves_validity(logs.SlideWarning, logs.PenetrationWarning):
            logs.warn("declared", logs.SlideWarning, comm)
    with raised_on_every_rank(logs.PenetrationWarning, "another"):
        with leaves_validity(logs.SlideWarning):
            logs.warn("another", logs.PenetrationWarning, comm)


def block(comm, n):
    dom, _ = meshing.create_interface_mesh(
        meshing.build_block_on_base, comm, n_interface=n, cell_type="triangle"
    )
    return dom


def run_block(comm, n, alpha_n, slide, watch_steps=None, interfaces=None):
    """300 MPa on the 1 mm block (builder defaults), then its top moved by ``slide``.

    Returns the problem, the stepper's watch and the SubfricWarnings this rank saw;
    ``watch_steps(prob)`` is called after every step; ``interfaces`` go to the problem.
    """
    from subfric_dolfinx.fem import Pressure

    program = LoadingProgram([0, 1, 2], {"press": [0, 1, 1], "slide": [0, 0, 1]})
    bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", slide, component=0, amplitude="slide")]
    prob = InterfaceProblem(
        block(comm, n),
        LAW.replace(alpha_n=alpha_n),
        MATERIALS,
        program,
        bcs,
        [Pressure("top", 300.0, amplitude="press")],
        interfaces=interfaces,
    )
    on_step = None if watch_steps is None else (lambda rec: watch_steps(prob))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with FrictionSolver(prob, prefix("valid"), {"snes_atol": 1e-6}) as solver:
            stepper = LoadStepper(solver, 0.25, on_step=on_step)
            stepper.run()
            stepper.validity.warn()  # again: nothing more
    ours = [w for w in seen if issubclass(w.category, logs.SubfricWarning)]
    return prob, stepper.validity, ours


@pytest.mark.parametrize(
    ("alpha", "warned"), [(1.5, True), (500.0, True), (1e6, False)], ids=["200mm", "0.6mm", "stiff"]
)
def test_a_soft_penalty_is_warned_once_with_what_to_set(alpha, warned):
    """8 elements of 0.125 mm on a 1 mm interface: tolerance max(h, L/10) = 0.125 mm of bodies'
    material, so alpha_n >= E*/0.125 mm = 4.7e5 MPa/mm is silent; 1.5 and 500 MPa/mm are warned
    once, naming the deepest penetration (against the gap gathered at every step) and that
    value of alpha_n."""
    comm = MPI.COMM_WORLD
    seen = []

    def deepest(prob):
        un = prob.interface.last_gap[:, -1]
        seen.append(comm.allreduce(float(un.max()) if un.size else -1.0, op=MPI.MAX))

    _, watch, ours = run_block(comm, 8, alpha, 0.05, deepest)
    assert watch.contact_modulus == pytest.approx(E_STAR, rel=1e-12)
    assert watch.size == pytest.approx(1.0, rel=1e-9) and watch.h_min == pytest.approx(0.125)
    if not warned:
        assert everywhere(comm, watch.penetration is None and not ours)
        assert max(seen) < 300.0 * 2 / alpha
        return
    assert everywhere(comm, len(ours) == (1 if comm.rank == 0 else 0)), [str(w) for w in ours]
    pen = watch.penetration
    assert pen.value == pytest.approx(max(seen), rel=1e-3)  # the deepest, to the tracking step
    assert pen.value == pytest.approx(pen.f_n / alpha, rel=1e-9)
    assert pen.ratio == pytest.approx(E_STAR / alpha / 0.125, rel=1e-6)
    assert pen.t >= 1.0 - 1e-12 and pen.x[1] == pytest.approx(0.5)
    if comm.rank == 0:
        msg = str(ours[0].message)
        assert ours[0].category is logs.PenetrationWarning
        assert f"ubar_n up to {pen.value:.3g} mm" in msg, msg
        assert f"alpha_n >= E*/0.125 mm = {E_STAR / 0.125:.3g} MPa/mm" in msg, msg


@pytest.mark.parametrize(
    ("alpha", "intended", "warned"),
    [(1e5, False, "compliance"), (1e5, True, None), (1e4, True, "overlap")],
    ids=["1e5", "1e5-intended", "1e4-intended"],
)
def test_an_intended_compliance_is_judged_on_its_overlap_only(alpha, intended, warned):
    """8 elements of 0.125 mm, 300 MPa: alpha_n = 1e5 MPa/mm is a layer l = E*/alpha_n = 0.59
    mm, beyond the 0.125 mm tolerated, but it sinks ubar_n = 3 um, 0.024 of an element: warned
    as a compliance unless the interface declares it intended. 1e4 MPa/mm sinks 0.03 mm, 0.24 of
    an element, beyond the tenth tolerated: warned as an overlap even when intended, with the
    alpha_n = f_n / (0.1 h) that removes it."""
    from subfric_dolfinx.fem import Interface

    comm = MPI.COMM_WORLD
    spec = [Interface("interface", intended_compliance=intended)]
    _, watch, ours = run_block(comm, 8, alpha, 0.02, interfaces=spec)
    assert watch.intended_compliance is intended
    if warned is None:
        assert everywhere(comm, watch.penetration is None and not ours)
        return
    assert everywhere(comm, len(ours) == (1 if comm.rank == 0 else 0)), [str(w) for w in ours]
    pen = watch.penetration
    assert pen.value == pytest.approx(pen.f_n / alpha, rel=1e-9)
    overlap = pen.value / (INTERPENETRATION_FRACTION * 0.125)
    compliance = E_STAR / alpha / 0.125
    assert pen.ratio == pytest.approx(overlap if intended else compliance, rel=1e-6)
    if comm.rank == 0:
        msg = str(ours[0].message)
        assert ours[0].category is logs.PenetrationWarning
        assert ("compliant as l" in msg) is (warned == "compliance"), msg
        assert ("intended_compliance" in msg) is (warned == "compliance"), msg
        assert ("overlap by" in msg) is (warned == "overlap"), msg
        if warned == "overlap":
            need = pen.f_n / (INTERPENETRATION_FRACTION * 0.125)
            assert f"alpha_n >= f_n / (0.1 h) = {need:.3g} MPa/mm" in msg, msg


def test_an_intended_compliance_is_a_scene_key():
    """``interfaces.<name>.intended_compliance`` reaches the problem's interface spec."""
    from subfric_dolfinx.scenes import parse_scene
    from tests.helpers import small_scene

    raw = small_scene(short=True)
    raw["interfaces"] = {"interface": {"intended_compliance": True}}
    scene = parse_scene(raw)
    assert scene.interfaces["interface"].intended_compliance is True


def test_refining_below_a_tenth_of_the_interface_does_not_change_the_verdict():
    """Once the elements are shorter than L/10 the tolerance is L/10 whatever the mesh: the
    penetration's ratio to it (and the advice) is the same at 16 and 32 elements."""
    comm = MPI.COMM_WORLD
    ratios = []
    for n in (16, 32):
        _, watch, _ = run_block(comm, n, 500.0, 0.02)
        ratios.append(watch.penetration.ratio)
    assert ratios[0] == pytest.approx(E_STAR / 500.0 / 0.1, rel=1e-6)
    assert ratios[1] == pytest.approx(ratios[0], rel=1e-9)


@pytest.mark.parametrize(("slide", "warned"), [(0.1, False), (0.3, True)])
def test_a_slide_beyond_three_elements_is_warned(slide, warned):
    """16 elements of 0.0625 mm: a 0.1 mm slide (1.6 elements) is fine, 0.3 mm (4.8) is not."""
    comm = MPI.COMM_WORLD
    prob, watch, ours = run_block(comm, 16, 1e7, slide)
    el = prob.interface
    ut = np.abs(el.last_gap[:, 0])
    largest = comm.allreduce(float(ut.max()) if ut.size else 0.0, op=MPI.MAX)
    assert watch.penetration is None
    if not warned:
        assert largest < SLIDE_ELEMENTS * 0.0625 and watch.slide is None and not ours
        return
    assert watch.slide.value == pytest.approx(largest, rel=1e-6)  # the last step slid most
    assert watch.slide.value / watch.slide.h > SLIDE_ELEMENTS
    assert everywhere(comm, len(ours) == (1 if comm.rank == 0 else 0))
    if comm.rank == 0:
        assert ours[0].category is logs.SlideWarning
        msg = str(ours[0].message)
        assert f"{watch.slide.value / watch.slide.h:.3g} interface elements" in msg, msg
        assert "kinematics='finite_sliding'" in msg, msg  # the advice: finite sliding


def test_contact_modulus():
    steel, alu = Material(2.1e5, 0.3), Material(7.0e4, 0.33)
    assert contact_modulus({"primary": steel, "secondary": alu}) == pytest.approx(E_STAR, rel=1e-14)
    assert contact_modulus({"a": steel, "b": steel}) == pytest.approx(2.1e5 / 0.91 / 2)


SCRIPT = """
import logging
from mpi4py import MPI
from subfric_dolfinx.scenes import run_scene
logging.captureWarnings(True)  # as FFCx 0.9 does when imported (DOLFINx 0.11's does not)
run_scene({
    "kind": "fe", "name": "mine",
    "mesh": {"builder": "block_on_base", "options": {"n_interface": 4}},
    "law": {"law": "subloading", "params": {"preset": "sec7"}},
    "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 7.0e4, "nu": 0.33}},
    "program": {"times": [0, 1], "channels": {"press": [0, 1]}},
    "dirichlet": [{"group": "bottom", "value": [0, 0]},
                  {"group": "top", "component": 0, "value": 0.0}],
    "loads": [{"type": "pressure", "group": "top", "value": 300, "amplitude": "press"}],
    "solver": {"dt": 0.5},
}, comm=MPI.COMM_WORLD)
print("done")
"""


@pytest.mark.e2e
@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_a_plain_script_sees_the_warning_once(ranks):
    """The README's run_scene with the paper's soft penalty, as a plain script (no logging set
    up): one PenetrationWarning line on stderr, on 1 rank and under mpirun -n 2. Warnings are
    routed to logging (FFCx 0.9 does it when imported) with nobody listening: a plain warning
    would vanish, ours does not."""
    p = mpirun(SCRIPT, ranks)
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout.count("done") == ranks
    assert p.stderr.count("PenetrationWarning: large penetration") == 1, p.stderr


def stepping_lines(caplog, run):
    logger = logging.getLogger("subfric_dolfinx")
    old = logger.propagate
    logger.propagate = True  # logs.configure() (a demo run in this process) turns it off
    try:
        with caplog.at_level(logging.INFO, logger="subfric_dolfinx.fem.stepping"):
            run()
    finally:
        logger.propagate = old
    # one log call is one record object: on sid under mpirun a record can reach pytest's capture
    # handler twice (the handler attached on two loggers of the chain), which is not two lines
    seen: set[int] = set()
    records = [r for r in caplog.records if not (id(r) in seen or seen.add(id(r)))]
    return [r.getMessage() for r in records if r.name == "subfric_dolfinx.fem.stepping"]


def test_the_log_says_what_the_interface_does(caplog, monkeypatch):
    """Pressing is sticking, not "plastic", sliding is sliding; with the progress interval at 0
    every step prints a progress line (and every segment its line: it took that long)."""
    comm = MPI.COMM_WORLD
    monkeypatch.setattr(logs, "PROGRESS_SECONDS", 0.0)
    lines = stepping_lines(caplog, lambda: run_block(comm, 8, 1e6, 0.3))
    assert len(lines) == 8, lines
    progress = lines[:3] + lines[4:7]
    assert all(" %): 1 step, Newton" in ln for ln in progress), lines
    assert lines[3].startswith("t = 0 -> 1 s: 4 steps") and "sticking 100 %;" in lines[3], lines
    assert "sliding" not in lines[3] and "plastic" not in lines[3]
    assert lines[7].startswith("t = 1 -> 2 s: 4 steps") and "at its end sliding 100 %;" in lines[7]


def test_short_segments_get_no_line_and_long_ones_do(caplog, monkeypatch):
    """Segments of 4 steps, quickly done: no line (the progress interval has not passed); a
    segment of LONG_SEGMENT_STEPS steps: its line."""
    comm = MPI.COMM_WORLD
    monkeypatch.setattr(logs, "PROGRESS_SECONDS", 3600.0)
    assert not stepping_lines(caplog, lambda: run_block(comm, 4, 1e6, 0.05))
    caplog.clear()

    def pressed():
        from subfric_dolfinx.fem import Pressure

        program = LoadingProgram([0, 1], {"press": [0, 1]})
        bcs = [Dirichlet("bottom", (0.0, 0.0)), Dirichlet("top", 0.0, component=0)]
        prob = InterfaceProblem(
            block(comm, 4),
            LAW.replace(alpha_n=1e6),
            MATERIALS,
            program,
            bcs,
            [Pressure("top", 300.0, amplitude="press")],
        )
        with FrictionSolver(prob, prefix("seg"), {"snes_atol": 1e-6}) as solver:
            LoadStepper(solver, 1.0 / steplog.LONG_SEGMENT_STEPS).run()

    lines = stepping_lines(caplog, pressed)
    n = steplog.LONG_SEGMENT_STEPS
    assert len(lines) == 1 and lines[0].startswith(f"t = 0 -> 1 s: {n} steps"), lines
    # a run of more segments than SEGMENT_LINES (many cycles) prints no line per segment
    caplog.clear()
    monkeypatch.setattr(steplog, "SEGMENT_LINES", 0)
    assert not stepping_lines(caplog, pressed)
