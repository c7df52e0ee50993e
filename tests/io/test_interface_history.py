"""The interface history file and the checkpoint: what they hold, how they are written.

* The gap ``ubar`` is in the interface history, and it is the gap the law saw: the elastic
  relations ``f_n = alpha_n ubar_n`` and ``f_t = alpha_t (ubar_t - up)`` hold at every contact
  point of every step (read back with plain h5py).
* A restart into a directory whose interface history cannot be continued (truncated, ending
  before the restart time) is one ``OutputError`` on every rank, naming the file.
* Per-rank slabs: every read and write of a row dataset (the checkpoint's displacement and
  interface state, the history's fields) touches the rows of the rank's own slab only, and the
  ranks together touch every row: no rank reads or writes the whole (h5py's ``Dataset`` item
  access is spied on; meaningful on 2 ranks).
"""

import json

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from demos import block_on_base
from subfric_dolfinx.constitutive import Status, preset
from subfric_dolfinx.io import OutputError
from subfric_dolfinx.io.slabs import slab
from subfric_dolfinx.scenes import run_scene
from tests.helpers import hang_fails, on_root, raised_on_every_rank
from tests.io.test_output import short_scene

pytestmark = hang_fails()


def test_the_gap_in_the_interface_history_is_the_gap_the_law_saw(shared_tmp):
    comm = MPI.COMM_WORLD
    res = run_scene(short_scene(interface_history=True), outdir=shared_tmp, comm=comm)
    law = preset("sec7").replace(alpha_n=block_on_base.ALPHA_N)  # the small scene's law

    def check():
        with h5py.File(shared_tmp / "interface_history.h5") as f:
            gap, f_t, f_n, up = (f[k][()] for k in ("gap", "f_t", "f_n", "up"))
            status, t = f["status"][()], f["time"][()]
            # the vocabulary of every output file: units, frame, status legend; no dataset
            # repeats the traction (the law's end-of-step traction is f_t, f_n itself)
            units = {k: f[k].attrs["unit"] for k in f}
            assert units == {
                "x": "mm",
                "time": "s",
                "g0": "mm",
                "f_t": "MPa",
                "f_n": "MPa",
                "gap": "mm",
                "status": "1",
                "up": "mm",
                "mu": "MPa",
                "r": "1",
            }
            assert json.loads(f.attrs["units"])["gap_n"] == "mm" and "f" not in f
            legend = json.loads(f.attrs["status_legend"])
            assert legend[str(int(Status.SEPARATED))].startswith(Status.SEPARATED.name)
        n, p = f_n.shape
        assert n == len(res.history) and gap.shape == (n, p, 2) and up.shape == (n, p, 1)
        contact = status != Status.SEPARATED
        assert contact.all()  # pressed throughout
        np.testing.assert_allclose(f_n, law.alpha_n * gap[..., 1], rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(
            f_t, law.alpha_t * (gap[..., :1] - up), rtol=1e-10, atol=1e-9 * np.abs(f_n).max()
        )
        # pressed at 300 MPa: ubar_n = 300 / alpha_n at the end of the press (t = 1)
        i = int(np.argmin(np.abs(t - 1.0)))
        assert t[i] == pytest.approx(1.0)
        assert gap[i, :, 1].mean() == pytest.approx(300.0 / law.alpha_n, rel=1e-6)
        # then slid: the tangential gap grows with the slide and ends well past the elastic
        # part (the slip up follows it)
        assert np.abs(gap[-1, :, 0]).max() > 0.1 and np.abs(up[-1]).max() > 0.05

    on_root(comm, check)


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])


def _end_early(path):
    with h5py.File(path, "r+") as f:
        f["time"].resize(3, axis=0)


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (_truncate, "not a readable HDF5 file"),
        (_end_early, "without the restart time t = 1"),
    ],
    ids=["truncated", "ends-early"],
)
def test_a_restart_into_a_broken_interface_history_fails_on_every_rank(shared_tmp, damage, words):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "run"
    run_scene(short_scene(interface_history=True, checkpoint_times=[1.0]), outdir=out, comm=comm)
    ih = out / "interface_history.h5"
    on_root(comm, lambda: damage(ih))
    with raised_on_every_rank(OutputError, f"interface history {str(ih)!r}", words):
        run_scene(
            short_scene(interface_history=True),
            outdir=out,
            comm=comm,
            restart=out / "checkpoint.h5",
        )
    # the lock was released: moved away, a fresh history lets the restart run
    on_root(comm, lambda: ih.rename(out / "broken.h5"))
    res = run_scene(
        short_scene(interface_history=True),
        outdir=out,
        comm=comm,
        restart=out / "checkpoint.h5",
    )
    assert res.history[-1]["t"] == pytest.approx(2.0)


CHECKPOINT_ROWS = {
    "/displacement",
    "/interfaces/interface/x",
    "/interfaces/interface/up",
    "/interfaces/interface/mu",
    "/interfaces/interface/r",
}
"""Checkpoint datasets with one row per cell or interface point (axis 0)."""
SERIES = {"/f_t", "/f_n", "/gap", "/status", "/up", "/mu", "/r"}
"""Interface history datasets (step, point, ...): the points are on axis 1."""


def rows_touched(ds, key):
    """``(dataset, rows, lo, hi)`` of an item access on a row dataset, else ``None``."""
    name = ds.name
    if name not in CHECKPOINT_ROWS | SERIES | {"/x"}:
        return None
    axis = 1 if name in SERIES else 0
    k = key if isinstance(key, tuple) else (key,)
    if Ellipsis in k or len(k) <= axis:
        sel = slice(None)
    else:
        sel = k[axis]
    n = ds.shape[axis]
    if isinstance(sel, slice):
        lo, hi, _ = sel.indices(n)
    else:
        lo, hi = int(sel), int(sel) + 1
    return name, n, lo, hi


def test_checkpoint_and_interface_history_are_read_and_written_in_slabs(shared_tmp, monkeypatch):
    comm = MPI.COMM_WORLD
    seen = []
    real_get, real_set = h5py.Dataset.__getitem__, h5py.Dataset.__setitem__

    def get(self, key, *a, **k):
        seen.append(("read", rows_touched(self, key)))
        return real_get(self, key, *a, **k)

    def put(self, key, value):
        seen.append(("write", rows_touched(self, key)))
        return real_set(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__getitem__", get)
    monkeypatch.setattr(h5py.Dataset, "__setitem__", put)
    out = shared_tmp / "slabs"
    s = short_scene(interface_history=True, checkpoint_times=[1.0])
    run_scene(s, outdir=out, comm=comm)
    restarted = short_scene(interface_history=True)
    run_scene(restarted, outdir=out, comm=comm, restart=out / "checkpoint.h5")
    monkeypatch.undo()
    mine = [(how, *r) for how, r in seen if r is not None]
    everyone = comm.allgather(mine)
    size = comm.size
    # every rank within its own slab
    for rank, accesses in enumerate(everyone):
        for how, name, n, lo, hi in accesses:
            s_lo, s_hi = slab(n, size, rank)
            assert s_lo <= lo and hi <= s_hi, (
                f"rank {rank} {how}s rows {lo}..{hi} of {name} ({n} rows), its slab is "
                f"{s_lo}..{s_hi}"
            )
    # and together every row, both ways, of every row dataset
    for how in ("write", "read"):
        names = {a[1] for acc in everyone for a in acc if a[0] == how}
        expect = CHECKPOINT_ROWS | ({"/x"} | SERIES if how == "write" else {"/x"})
        assert names == expect, (how, names)
        for name in names:
            got = [
                (lo, hi, n)
                for acc in everyone
                for h, nm, n, lo, hi in acc
                if h == how and nm == name
            ]
            n = got[0][2]
            covered = np.zeros(n, dtype=bool)
            for lo, hi, _ in got:
                covered[lo:hi] = True
            assert covered.all(), (how, name)
