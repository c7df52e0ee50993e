"""Loading programs: named amplitude channels, piecewise linear between breakpoints (numpy only).

A program is a list of breakpoint times and, per channel, the amplitude at each breakpoint, e.g.
press, slide forward, slide back, hold (time passes, nothing moves), slide again::

    LoadingProgram(
        times=[0.0, 1.0, 2.0, 4.0, 5.0, 6.0],
        channels={"press": [0, 1, 1, 1, 1, 1], "slide": [0, 0, 1, -1, -1, 1]},
    )

Boundary conditions and loads refer to a channel by name and scale a reference value by it. Load
steps are aligned to the breakpoints (a reversal or the start of a hold is never stepped over).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import cast

import numpy as np
import numpy.typing as npt

__all__ = ["LoadingError", "LoadingProgram"]


class LoadingError(ValueError):
    """An invalid loading program; the message names the offending value."""


@dataclasses.dataclass(frozen=True)
class LoadingProgram:
    """Piecewise-linear amplitude channels.

    Args:
        times: Breakpoint times, strictly increasing (s).
        channels: Channel name -> amplitude at each breakpoint.

    Raises:
        LoadingError: Times not strictly increasing, non-finite values, or a channel whose length
            differs from the number of times; the message names the value.
    """

    times: npt.NDArray[np.float64]
    channels: Mapping[str, npt.NDArray[np.float64]]

    def __init__(self, times: Sequence[float], channels: Mapping[str, Sequence[float]]) -> None:
        t = np.asarray(times, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise LoadingError(f"times must be a list of at least two breakpoints, got {times!r}")
        for i, v in enumerate(
            cast(list[float], t.tolist())
        ):  # Python floats: messages show 1.0, not np.float64
            if not math.isfinite(v):
                raise LoadingError(f"times[{i}] = {v!r} is not finite")
        for i in range(1, t.size):
            if not t[i] > t[i - 1]:
                raise LoadingError(
                    f"times must increase strictly: times[{i}] = {float(t[i])!r} after "
                    f"times[{i - 1}] = {float(t[i - 1])!r}"
                )
        ch: dict[str, npt.NDArray[np.float64]] = {}
        for name, vals in channels.items():
            a = np.asarray(vals, dtype=float)
            if a.shape != t.shape:
                raise LoadingError(
                    f"channel {name!r} has {a.size} values for {t.size} breakpoint times"
                )
            for i, v in enumerate(cast(list[float], a.tolist())):
                if not math.isfinite(v):
                    raise LoadingError(f"channel {name!r} value [{i}] = {v!r} is not finite")
            ch[name] = a
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "channels", ch)

    @property
    def t_start(self) -> float:
        """First breakpoint."""
        return float(self.times[0])

    @property
    def t_end(self) -> float:
        """Last breakpoint."""
        return float(self.times[-1])

    def amplitude(self, name: str | None, t: float) -> float:
        """Amplitude of channel ``name`` at time ``t`` (1 for ``None``: a constant load).

        Raises:
            LoadingError: Unknown channel.
        """
        if name is None:
            return 1.0
        try:
            a = self.channels[name]
        except KeyError:
            raise LoadingError(
                f"unknown loading channel {name!r}; the program has {sorted(self.channels)}"
            ) from None
        return float(np.interp(t, self.times, a))

    def next_breakpoint(self, t: float) -> float:
        """The first breakpoint strictly after ``t`` (``t_end`` at or after the end)."""
        i = np.searchsorted(self.times, t, side="right")
        if i >= self.times.size:
            return self.t_end
        b = float(self.times[i])
        # treat a breakpoint within round-off of t as reached
        if b - t <= 1e-12 * max(1.0, abs(b)) and i + 1 < self.times.size:
            return float(self.times[i + 1])
        return b

    def is_hold(self, t: float) -> bool:
        """Whether the segment that starts at or after ``t`` keeps every channel constant.

        The segment runs from ``t`` to :meth:`next_breakpoint` ``(t)``; in a hold time passes and
        nothing is moved or loaded (a load stepper may take long steps there).
        """
        if t >= self.t_end:
            return False
        j = int(np.searchsorted(self.times, self.next_breakpoint(t), side="left"))
        return all(a[j - 1] == a[j] for a in self.channels.values())

    def segment(self, t: float) -> int:
        """Index of the segment ``[times[i], times[i+1]]`` containing ``t``."""
        return int(
            np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, self.times.size - 2)
        )

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-ready form."""
        # (1-D arrays: lists of floats)
        return {
            "times": cast(list[float], self.times.tolist()),
            **{k: cast(list[float], v.tolist()) for k, v in self.channels.items()},
        }
