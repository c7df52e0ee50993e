"""Bad loading programs: times that do not increase, are not finite or too few; channels with
non-finite values or of the wrong length; unknown channels."""

import pytest

from subfric_dolfinx.loading import LoadingError, LoadingProgram
from tests.helpers import raised_on_every_rank

pytestmark = pytest.mark.numpy_only

NAN, INF = float("nan"), float("inf")
TIMES = [0.0, 1.0, 2.0, 3.0]
LOADING_CASES = {
    # name: (times, channels, words)
    "times-equal": ([0.0, 1.0, 1.0, 2.0], {}, ["times[2] = 1.0 after times[1] = 1.0"]),
    "times-decreasing": ([0.0, 2.0, 1.0, 3.0], {}, ["times[2] = 1.0 after times[1] = 2.0"]),
    "times-nan": ([0.0, NAN, 2.0, 3.0], {}, ["times[1] = nan", "not finite"]),
    "times-inf": ([0.0, 1.0, 2.0, INF], {}, ["times[3] = inf", "not finite"]),
    "times-minus-inf": ([-INF, 1.0, 2.0, 3.0], {}, ["times[0] = -inf", "not finite"]),
    "times-single": ([0.0], {}, ["at least two breakpoints", "[0.0]"]),
    "times-empty": ([], {}, ["at least two breakpoints", "[]"]),
    "times-2d": ([[0.0, 1.0], [2.0, 3.0]], {}, ["at least two breakpoints", "[[0.0, 1.0]"]),
    "channel-nan": (TIMES, {"slide": [0.0, NAN, 1.0, 1.0]}, ["'slide'", "[1] = nan"]),
    "channel-inf": (TIMES, {"slide": [0.0, 1.0, 1.0, -INF]}, ["'slide'", "[3] = -inf"]),
    "channel-short": (
        TIMES,
        {"press": [0, 1, 1, 1], "slide": [0, 1, 1]},
        ["'slide'", "3 values for 4 breakpoint times"],
    ),
    "channel-long": (TIMES, {"slide": [0, 1, 1, 1, 1]}, ["'slide'", "5 values for 4"]),
    "channel-scalar": (TIMES, {"slide": 1.0}, ["'slide'", "1 values for 4"]),
}


@pytest.mark.parametrize("name", list(LOADING_CASES))
def test_bad_loading_program(name):
    times, channels, words = LOADING_CASES[name]
    with raised_on_every_rank(LoadingError, *words):
        LoadingProgram(times, channels)


def test_unknown_channel_of_a_loading_program():
    program = LoadingProgram(TIMES, {"press": [0, 1, 1, 1], "slide": [0, 0, 1, -1]})
    with raised_on_every_rank(LoadingError, "'slyde'", "['press', 'slide']"):
        program.amplitude("slyde", 0.5)
