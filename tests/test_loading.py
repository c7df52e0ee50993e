"""Loading programs: holds (segments where no channel changes) as the load stepper sees them."""

import pytest

from subfric_dolfinx.loading import LoadingProgram

pytestmark = pytest.mark.numpy_only


def test_a_hold_is_a_segment_where_every_channel_is_constant():
    p = LoadingProgram(
        [0.0, 1.0, 2.0, 4.0, 24.0, 26.0],
        {"press": [0, 1, 1, 1, 1, 1], "slide": [0, 0, 1, -1, -1, 1]},
    )
    assert [p.is_hold(t) for t in (0.0, 1.0, 2.0, 4.0, 24.0)] == [False] * 3 + [True, False]
    assert p.is_hold(10.0) and p.is_hold(4.0 - 1e-14)  # inside; a breakpoint within round-off
    assert not p.is_hold(3.9) and not p.is_hold(26.0)  # before it; at the end: no segment
    one = LoadingProgram([0.0, 1.0, 3.0], {"press": [0, 1, 1], "slide": [0, 1, 0]})
    assert not one.is_hold(1.5)  # one channel moves
    assert LoadingProgram([0.0, 5.0], {}).is_hold(0.0)  # no channel: time passes only
