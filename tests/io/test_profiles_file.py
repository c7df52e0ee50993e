"""Interface profiles written without gathering the interface (1, 2 and 3 ranks).

* The parallel sample sort that numbers the interface points (:func:`sorted_rows`) gives the
  positions of a stable sort of all ranks' rows gathered in rank order, with many ties, a rank
  without rows, and no rank receiving more than about twice its share (spied on); its splitters
  cost a rank other than rank 0 the ``size - 1`` splitters it receives (nothing is all-gathered),
  and rank 0 at most ``size`` samples of every rank; with every row a sample, the shares are
  exact.
* ``outputs.snapshot_file``: ``interface_profiles.h5`` holds, at each snapshot time, exactly
  the profiles the run returns in memory when the file is not asked for (the same rows, every
  variable), and nothing gathers the interface meanwhile; a restart keeps the profiles written
  before the restart time and writes the later ones as the uninterrupted run does.
"""

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.io import slabs
from subfric_dolfinx.scenes import SceneError, run_scene
from tests.helpers import hang_fails, on_root, raised_on_every_rank
from tests.io.test_output import short_scene

pytestmark = [hang_fails(), pytest.mark.three_ranks]

SNAPS = [1.0, 1.5, 2.0]


@pytest.mark.parametrize("n", [0, 7, 2000])
def test_the_sample_sort_gives_the_gathered_stable_order(n, monkeypatch):
    comm = MPI.COMM_WORLD
    rng = np.random.default_rng(1234 + comm.rank)
    n_local = 0 if comm.rank == 1 else n + 13 * comm.rank
    keys = rng.integers(-3, 4, size=(n_local, 3))  # many ties
    received = []
    real = slabs._exchange

    def spy(c, dest, payload):
        out = real(c, dest, payload)
        received.append(out[0].shape[0])
        return out

    monkeypatch.setattr(slabs, "_exchange", spy)
    pos, total = slabs.sorted_rows(comm, keys)
    monkeypatch.undo()
    allkeys = np.concatenate(comm.allgather(keys.reshape(-1, 3)))
    allpos = np.concatenate(comm.allgather(pos))
    assert total == allkeys.shape[0] == allpos.size
    expect = np.empty(total, dtype=np.int64)
    expect[np.lexsort(allkeys.T[::-1])] = np.arange(total)  # lexsort is stable
    np.testing.assert_array_equal(allpos, expect)
    if comm.size > 1 and total >= 1000:
        # the rows a rank receives to sort: at most about twice its share
        assert received[0] <= 2 * total / comm.size + comm.size, (received, total)


class CommSpy:
    """A communicator that records the rows (int64 elements) each collective delivers here."""

    def __init__(self, comm):
        self.comm = comm
        self.received = []  # (call, int64 elements received on this rank)

    def __getattr__(self, name):
        return getattr(self.comm, name)

    def Gatherv(self, send, recv, root=0):
        self.comm.Gatherv(send, recv, root=root)
        if recv is not None:
            self.received.append(("Gatherv", recv[0].size))

    def Bcast(self, buf, root=0):
        self.comm.Bcast(buf, root=root)
        if self.comm.rank != root:
            self.received.append(("Bcast", buf[0].size))

    def allgather(self, *a, **k):
        raise AssertionError("the sample sort all-gathers")

    Allgather = Allgatherv = allgather


@pytest.mark.parametrize("n", [2, 3000])
def test_the_splitters_cost_a_rank_what_it_receives_of_them(n):
    """Keys ``(n_local, 3)`` sorted with rank and index (5 columns): a rank other than rank 0
    receives the ``size - 1`` splitters (5 int64 each), rank 0 at most ``size`` samples of every
    rank (6 int64: a row and its weight) and never more rows than exist. With ``n`` rows a rank
    (2 <= size: every row a sample), each rank sorts exactly its share."""
    comm = MPI.COMM_WORLD
    spy = CommSpy(comm)
    rng = np.random.default_rng(99 + comm.rank)
    keys = rng.integers(0, 50, size=(n, 3))
    sorting = []  # rows received to sort, then the positions sent back
    real = slabs._exchange

    def exchange(c, dest, payload):
        out = real(c, dest, payload)
        sorting.append(out[0].shape[0])
        return out

    with pytest.MonkeyPatch.context() as m:
        m.setattr(slabs, "_exchange", exchange)
        pos, total = slabs.sorted_rows(spy, keys)
    allkeys = np.concatenate(comm.allgather(keys))
    expect = np.empty(total, dtype=np.int64)
    expect[np.lexsort(allkeys.T[::-1])] = np.arange(total)
    np.testing.assert_array_equal(np.concatenate(comm.allgather(pos)), expect)
    if comm.size == 1:
        assert spy.received == []
        return
    got = dict(spy.received)
    if comm.rank == 0:
        assert set(got) == {"Gatherv"}
        assert got["Gatherv"] == 6 * comm.size * min(n, comm.size) <= 6 * total
    else:
        assert spy.received == [("Bcast", 5 * (comm.size - 1))]
    if n <= comm.size:  # exact quantiles: every rank sorts total / size = n rows
        assert sorting[0] == n, (sorting, total)


def read_profiles(path):
    with h5py.File(path, "r") as f:
        return {k: f[k][()] for k in f}, dict(f.attrs)


def compare(file, snapshots):
    """The file's rows at each snapshot time are the gathered profile's, exactly."""
    data, _ = file
    np.testing.assert_array_equal(data["time"], sorted(snapshots))
    for j, t in enumerate(sorted(snapshots)):
        snap = snapshots[t]
        assert set(snap) <= set(data), (sorted(snap), sorted(data))
        for k, v in snap.items():
            got = data[k] if data[k].ndim == np.asarray(v).ndim else data[k][j]
            np.testing.assert_array_equal(got.reshape(np.shape(v)), v, err_msg=k)


def test_the_profiles_file_holds_the_gathered_snapshots(shared_tmp, monkeypatch):
    """One run writes the file; at each snapshot the test gathers the profile itself (the old
    output) to compare: two runs on several ranks differ at Newton's tolerance."""
    comm = MPI.COMM_WORLD
    import subfric_dolfinx.scenes.outputs as outputs

    real_gather, real_on_step = outputs.gather_interface, outputs.SceneOutputs.on_step
    allowed = [False]
    gathered = {}

    def no_gather(*a, **k):
        if not allowed[0]:
            raise AssertionError("the interface was gathered")
        return real_gather(*a, **k)

    def on_step(self, rec, stopping=False):
        real_on_step(self, rec, stopping)
        hit = [t for t in SNAPS if abs(t - rec.t) < 1e-9]
        if hit:
            allowed[0] = True
            gathered[hit[0]] = outputs.interface_profile(self.problem)
            allowed[0] = False

    monkeypatch.setattr(outputs, "gather_interface", no_gather)
    monkeypatch.setattr(outputs.SceneOutputs, "on_step", on_step)
    out = shared_tmp / "run"
    res = run_scene(short_scene(snapshots=SNAPS, snapshot_file=True), outdir=out, comm=comm)
    monkeypatch.undo()
    assert res.snapshots == {} and sorted(gathered) == SNAPS
    assert str(out / "interface_profiles.h5") in res.files
    assert "f" in gathered[1.0]  # every variable of the law, the non-output one too
    on_root(comm, lambda: compare(read_profiles(out / "interface_profiles.h5"), gathered))


def test_a_restart_continues_the_profiles_file(shared_tmp):
    comm = MPI.COMM_WORLD
    ref = run_scene(short_scene(snapshots=SNAPS), comm=comm)
    out = shared_tmp / "run"
    first = short_scene(snapshots=SNAPS, snapshot_file=True, checkpoint_times=[1.25])
    run_scene(first, outdir=out, comm=comm)
    again = short_scene(snapshots=SNAPS, snapshot_file=True)
    run_scene(again, outdir=out, comm=comm, restart=out / "checkpoint.h5")
    data, _ = on_root(comm, lambda: read_profiles(out / "interface_profiles.h5"))
    np.testing.assert_array_equal(data["time"], SNAPS)
    # the restarted run's profiles equal the uninterrupted run's to the restart's round-off
    for j, t in enumerate(SNAPS):
        for k, v in ref.snapshots[t].items():
            got = data[k] if data[k].ndim == np.asarray(v).ndim else data[k][j]
            scale = max(float(np.abs(v).max()), 1e-12)
            np.testing.assert_allclose(got.reshape(np.shape(v)), v, atol=1e-8 * scale, err_msg=k)


def test_a_profiles_file_needs_snapshots():
    with raised_on_every_rank(SceneError, "scene.outputs.snapshot_file", "no snapshots"):
        run_scene(short_scene(snapshot_file=True), comm=MPI.COMM_WORLD)
