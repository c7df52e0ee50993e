"""Stability on stiff and extreme settings, material point and FE (1 and 2 ranks).

The cases are defined once, in the package ``tests/stability``, and the report
(``report/generate.py``) tabulates the same runs. Each case states the outcome that must occur
(converged, flagged as having no stable quasi-static solution, or a clear error) and its own
checks; here every case must also be free of NaN/inf, and an FE case must end the same way on
every rank.
"""

import pytest
from mpi4py import MPI

from subfric_dolfinx.logs import PenetrationWarning, SlideWarning
from tests.stability import CASES


def test_the_case_list_covers_both_levels_and_every_outcome():
    levels = {c.level for c in CASES}
    outcomes = {(c.level, c.expect) for c in CASES}
    assert levels == {"point", "fe"}
    for level in ("point", "fe"):
        for expect in ("converged", "flagged", "error"):
            assert (level, expect) in outcomes, (level, expect)
    assert len({c.name for c in CASES}) == len(CASES)


# The FE cases press the 1 mm block with the laws the cases name, most with the paper's soft
# normal penalties, on purpose (the report tabulates these runs); "FE r -> 1" slides it 5 mm.
VALID = {"FE penalty 1e8"}
SLIDING = {"FE r -> 1"}


def leaves(case):
    """The case's ``leaves_validity`` mark, if it has one."""
    if case.level != "fe" or case.name in VALID:
        return ()
    categories = (
        (PenetrationWarning, SlideWarning) if case.name in SLIDING else (PenetrationWarning,)
    )
    return (pytest.mark.leaves_validity(*categories, reason="the case's soft normal penalty"),)


@pytest.mark.parametrize("case", [pytest.param(c, id=c.name, marks=leaves(c)) for c in CASES])
def test_stability_case(case):
    comm = MPI.COMM_WORLD
    out = case.run(comm)
    if case.level == "fe":  # collective runs end the same way everywhere
        seen = comm.allgather((out.outcome, out.message, out.it_max))
        assert all(s == seen[0] for s in seen), seen
    assert out.nan_free, f"{case.name}: NaN or inf in the outputs ({out.detail})"
    assert out.outcome == case.expect, (
        f"{case.name}: expected {case.expect} ({case.must}), got {out.outcome}: "
        f"{out.detail} {out.message}"
    )
    if out.outcome in ("error", "flagged"):
        assert out.message, f"{case.name}: no message or reason given"
    # the iterations were counted, by the case's own measure (every case takes real steps)
    assert out.it_kind == ("Newton" if case.level == "fe" else "return map"), out.it_kind
    assert out.it_max >= 1 and out.it_mean > 0, (out.it_mean, out.it_max)
    case.check(out)
