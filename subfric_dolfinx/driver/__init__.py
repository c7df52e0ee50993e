"""Material-point driver: one interface point along a prescribed path (numpy only).

Library use::

    from subfric_dolfinx.driver import load_case, run_case, run_cases
    result = run_case(load_case("case.json"), steps_per_mm=500)
    results = run_cases([case_100MPa, case_300MPa, case_600MPa])  # advanced together

Command line::

    subfric-driver CASE.json [--steps-per-mm N] [--out OUT.json]
    python3 -m subfric_dolfinx.driver CASE.json ...      # the same

CASE.json::

    {
      "law": "subloading",                 # or "coulomb"; optional, default "subloading"
      "params": {"preset": "sec7", "mu0": 400.0},   # or every parameter by name
      "control": "disp",                   # "disp": x is ubar_t (mm); "stress": x is f_t (MPa)
      "path": [[t, x1, x2, ubar_n], ...],  # linear in between; times strictly increasing
      "path": {"csv": "path.csv", "columns": {"t": "time"}},   # or from a CSV file (below)
      "t_samples": [t, ...],               # output times within the path, or "path" (its times)
      "n_tangential": 2,                   # optional: 1 (2-D, x2 must be 0) or 2 (3-D)
      "steps_per_mm": 200                  # optional; --steps-per-mm overrides it
    }

A path from a CSV file (relative to the case file's folder, and in it: a table elsewhere, through
``..``, an absolute path or a link leading out, is refused unread): a header line naming the
columns ``t, x1, x2, ubar_n`` (``x2`` may be left out with ``n_tangential`` 1; ``columns`` maps
them to the file's own names), then rows of numbers; ``,``, ``;`` or tab; lines starting with ``#``
(e.g. units) are skipped (:func:`~.case.read_table`).

Units: MPa, mm, s. The subloading law's ``mu0``, ``mu_s``, ``mu_k`` are values of its hardening
function, a stress in MPa (the strength is ``g(f_n) mu``, ``g`` dimensionless), not friction
coefficients as Coulomb's ``mu_c``.

Steps are split at every path breakpoint and sample time; between them a segment gets
``ceil(steps_per_mm * L)`` equal steps, ``L`` being the largest change of ``|ubar_t|`` or ``ubar_n``
in mm (under stress control the tangential change counts as ``|f_t| / alpha_t`` mm). A hold (no
change) is one step: recovery integrates exactly. Every step count is checked before the first
step: at most ``MAX_STEPS_PER_SEGMENT`` per segment and ``MAX_TOTAL_STEPS`` in all (an option).
A step interpolates the path within its segment: its cost does not depend on the number of rows.

Output (JSON): at each sample time ``t, f_t1, f_t2, f_n, up_t1, up_t2, mu, r, ubar_t1, ubar_t2,
ubar_n`` and the status of the step ending there; the number of steps per status; and
``stability_lost``: ``null``, or the first time the rate-form denominator went non-positive or the
solution jumped at a fold, with the state there. By default the driver stops there, because no
stable quasi-static solution exists beyond (``on_instability="continue"`` goes on, flagged).
Under stress control, loading beyond what the interface can sustain raises :class:`RunawayError`
at the time it happened.

The dynamic control ``"control": "slider"`` (a spring-slider: mass, spring, driving velocity,
constant normal stress, integrated in time with adaptive steps) has its own case fields and
result: :mod:`.slider`.

Modules: :mod:`.case` (parsing and validation), :mod:`.checks` (the case error and the check of
a case's numbers), :mod:`.path` (the plan of steps), :mod:`.run` (the step loop of one case),
:mod:`.batch` (many cases through one vectorised loop), :mod:`.slider` (the spring-slider: the
dynamic control), :mod:`.cli` (the command line: exit codes, ``--out`` checked up front and
written atomically, progress).

May import: :mod:`subfric_dolfinx.constitutive`, the layer-0 modules (:mod:`subfric_dolfinx.logs`,
:mod:`subfric_dolfinx.values`, :mod:`subfric_dolfinx.commandline`), numpy and the standard
library only.
"""

from .batch import run_cases
from .case import (
    DEFAULT_STEPS_PER_MM,
    MAX_STEPS_PER_SEGMENT,
    MAX_TOTAL_STEPS,
    Case,
    load_case,
    parse_case,
)
from .checks import CaseError
from .cli import main
from .run import DriverResult, RunawayError, fields, run_case
from .slider import (
    SliderCase,
    SliderResult,
    SteadySliding,
    parse_slider,
    run_slider,
    steady_sliding,
    stick_slip_cycles,
)

__all__ = [
    "DEFAULT_STEPS_PER_MM",
    "MAX_STEPS_PER_SEGMENT",
    "MAX_TOTAL_STEPS",
    "Case",
    "CaseError",
    "DriverResult",
    "RunawayError",
    "SliderCase",
    "SliderResult",
    "SteadySliding",
    "fields",
    "load_case",
    "main",
    "parse_case",
    "parse_slider",
    "run_case",
    "run_cases",
    "run_slider",
    "steady_sliding",
    "stick_slip_cycles",
]
