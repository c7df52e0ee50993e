"""What a run keeps in memory per step (issue 23, item 7: about 2 kB a step, measured, a dict
per history row and a StepRecord per step). The history's rows are one float64 array read as
dicts (:class:`~subfric_dolfinx.io.HistoryRows`); a scene's stepper keeps its last record only.
1 and 2 ranks."""

import gc
import tracemalloc

import pytest

from subfric_dolfinx.io import HistoryRows
from subfric_dolfinx.scenes import outputs as scene_outputs
from subfric_dolfinx.scenes import run_scene
from tests.helpers import prefix, small_scene


def test_rows_read_back_as_they_were_written():
    rows = [{"step": k, "t": 0.1 * k, "F_n": -1.5 * k, "newton": 3} for k in range(1, 40)]
    h = HistoryRows()
    for r in rows:
        h.append(r)
    assert len(h) == 39 and h == rows and list(h) == rows
    assert h[-1] == rows[-1] and h[3:7] == rows[3:7] and h[::-5] == rows[::-5]
    assert type(h[0]["step"]) is int and type(h[0]["t"]) is float
    h[0]["t"] = 99.0  # a fresh dict: the history does not change
    assert h[0]["t"] == pytest.approx(0.1)
    with pytest.raises(IndexError):
        h[39]
    assert h.nbytes() <= 2 * 8 * 4 * len(h)  # 8 bytes a value, at most twice the rows
    again = HistoryRows(rows)  # a restart's preloaded rows, then other columns (a new probe)
    again.append({"step": 40, "t": 4.0, "F_n": -60.0, "newton": 2, "P.u_x": 0.5})
    again.append({"step": 41, "t": 4.1, "newton": 1, "P.u_x": 0.25})
    assert again[:39] == rows
    assert again[39] == {"step": 40, "t": 4.0, "F_n": -60.0, "newton": 2, "P.u_x": 0.5}
    assert again[40] == {"step": 41, "t": 4.1, "newton": 1, "P.u_x": 0.25}


def scene(n_steps):
    s = small_scene()
    s["program"] = {"times": [0, 1], "channels": {"press": [0, 1], "slide": [0, 0]}}
    s["solver"].update(prefix=prefix("mem"), dt=1.0 / n_steps, dt_max=1.0 / n_steps)
    return s


def test_a_step_keeps_a_few_hundred_bytes(monkeypatch):
    """Python memory held at the end of a run (before the outputs close), measured with
    tracemalloc on runs of 40 and 160 steps: the difference per step is what a step keeps. It
    was 2.2 kB (1.4 kB a history row of 21 columns as a dict, 0.8 kB a StepRecord); now the
    row's 168 bytes (at most twice that while the array grows), the Newton count and what MPI
    and the logs keep in passing (measured: 440 to 520 bytes a step in all, 1 rank), below
    1,000 bytes."""
    held = {}
    real_close = scene_outputs.SceneOutputs.close

    def close(self, *args, **kwargs):
        gc.collect()
        held[len(self.history.rows)] = (tracemalloc.get_traced_memory()[0], self.history.rows)
        return real_close(self, *args, **kwargs)

    monkeypatch.setattr(scene_outputs.SceneOutputs, "close", close)
    run_scene(scene(10))  # forms compiled, caches filled
    gc.collect()
    tracemalloc.start()
    try:
        for n in (40, 160):
            run_scene(scene(n))
    finally:
        tracemalloc.stop()
    (n0, (m0, _)), (n1, (m1, rows)) = sorted(held.items())[-2:]
    assert (n0, n1) == (40, 160)
    per_step = (m1 - m0) / (n1 - n0)
    print(f"{per_step:.0f} bytes a step, {len(rows.columns)} columns")
    assert 8 * len(rows.columns) <= per_step < 1000
