"""No output is created, truncated or written through a symbolic link (issue 23, item 1).

Each case plants a link in the output directory, under the name of a file a run writes, to a
file outside it (whose content must survive) or to a missing one (that must not appear), then
runs a tiny scene with every output (history, interface history, VTX fields with the stress
and the interface points, a checkpoint at every step), fresh or restarted. The run either goes
on without touching the target (a fresh run moves a link the earlier run's manifest lists to
``previous_run/``, as a link; a rename replaces a link, not its target; a temporary name is
removed first) or is refused on every rank, naming the link (a link the manifest does not
list is not the run's). ``previous_run/`` holding a user's files, or made by the user, is never
deleted. 1 and 2 ranks.
"""

from __future__ import annotations

import os
import shutil

import pytest
from mpi4py import MPI

from demos import block_on_base
from subfric_dolfinx.io import OutputError, PointCloudError
from subfric_dolfinx.io.outdir import MANIFEST, read_manifest, write_manifest
from subfric_dolfinx.scenes import run_scene
from tests.helpers import on_root, prefix, raised_on_every_rank

PRECIOUS = "precious, not to be written\n"


def scene(checkpoint_every=1, fields="vtx"):
    s = block_on_base.scene(n=4, hold=1.0, fields=fields, checkpoint_every=checkpoint_every)
    s["program"] = {"times": [0.0, 0.2], "channels": {"press": [0, 0.2], "slide": [0, 0]}}
    s["solver"] = {"prefix": prefix("links"), "dt": 0.1}
    s["outputs"].update(interface_history=True, stress=True, snapshots=[])
    return s


@pytest.fixture
def place(shared_tmp):
    """(output directory, a file outside it, a missing name outside it, a directory outside)."""
    out, outside = shared_tmp / "out", shared_tmp / "outside"

    def make():
        out.mkdir()
        outside.mkdir()
        (outside / "victim").write_text(PRECIOUS)
        (outside / "dir").mkdir()
        (outside / "dir" / "keep").write_text(PRECIOUS)

    on_root(MPI.COMM_WORLD, make)
    return out, outside / "victim", outside / "ghost", outside / "dir"


def plant(out, name, target):
    def do():
        p = out / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if os.path.lexists(p):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
        p.symlink_to(target)

    on_root(MPI.COMM_WORLD, do)


def untouched(victim, ghost, directory):
    """The targets outside: the file unchanged, the missing one still missing, the directory
    with its one file (checked on rank 0, the verdict on every rank)."""
    on_root(
        MPI.COMM_WORLD,
        lambda: (
            (victim.read_text() == PRECIOUS or pytest.fail("the victim was written"))
            and (not os.path.lexists(ghost) or pytest.fail("the ghost was created"))
            and (
                sorted(os.listdir(directory)) == ["keep"]
                or pytest.fail(f"written in {directory}: {os.listdir(directory)}")
            )
        ),
    )


def fresh(out):
    return run_scene(scene(), outdir=out, comm=MPI.COMM_WORLD)


def earlier_run(out, *names):
    """The files of an earlier run of this code: ``checkpoint.h5`` and the manifest, which lists
    ``names`` too (files of the run later replaced by a link)."""

    def make():
        (out / "checkpoint.h5").write_text("an earlier run\n")
        write_manifest(out, ["checkpoint.h5", *names])

    on_root(MPI.COMM_WORLD, make)


# name planted, its target, listed in the earlier run's manifest -> the run is refused (True)
# or goes on (False): a listed link is moved aside as a link, an unlisted one is refused
FRESH = [
    (".subfric.lock", "victim", False, True),
    (".subfric.lock", "ghost", False, True),
    (".interface_history.h5.spare", "victim", False, True),
    (".checkpoint.h5.tmp.spare", "ghost", False, True),
    ("history.csv", "victim", True, False),
    ("history.csv", "ghost", False, True),
    ("checkpoint.h5.tmp", "ghost", True, False),
    ("checkpoint.h5.tmp", "ghost", False, True),
    ("interface_history.h5", "victim", True, False),
    ("interface_history.h5", "victim", False, True),
    ("fields", "dir", True, False),
    ("fields", "dir", False, True),
    ("previous_run", "dir", False, False),
    (f".subfric-probe-{os.getpid()}", "victim", False, False),
    (MANIFEST, "victim", False, False),
]


@pytest.mark.parametrize(
    ("name", "to", "listed", "refused"),
    FRESH,
    ids=[f"{n}->{t}{'-listed' if li else ''}" for n, t, li, _ in FRESH],
)
def test_a_fresh_run_never_writes_through_a_link(place, name, to, listed, refused):
    out, victim, ghost, directory = place
    target = {"victim": victim, "ghost": ghost, "dir": directory}[to]
    if name.startswith(".subfric-probe"):  # the probe is named by rank 0's pid
        name = f".subfric-probe-{MPI.COMM_WORLD.bcast(os.getpid(), root=0)}"
    if name != MANIFEST:  # a link there: no manifest (the run replaces the link with its own)
        earlier_run(out, *([name] if listed else []))
    plant(out, name, target)
    if refused:
        with raised_on_every_rank(OutputError, "symbolic link", name):
            fresh(out)
    else:
        fresh(out)
        if listed:  # moved aside as a link; the run wrote its own regular file or directory
            on_root(
                MPI.COMM_WORLD,
                lambda: (out / "previous_run" / name).is_symlink() or pytest.fail("not moved"),
            )
        if name == MANIFEST:
            on_root(MPI.COMM_WORLD, lambda: read_manifest(out) or pytest.fail("no manifest"))
    untouched(victim, ghost, directory)


RESTART = [
    ("history.csv", "victim", True),
    ("interface_history.h5", "victim", True),
    ("fields/displacement.bp", "dir", True),
    ("fields/displacement.h5", "victim", True),
    ("fields/interface_points.h5", "victim", True),
    ("fields", "dir", True),
    ("checkpoint.h5", "victim", False),
    ("checkpoint.h5.tmp", "ghost", True),  # not the run's (not listed once it had ended)
]


@pytest.mark.parametrize(
    ("name", "to", "refused"), RESTART, ids=[f"{n}->{t}" for n, t, _ in RESTART]
)
def test_a_restart_never_writes_through_a_link(place, name, to, refused):
    """The run's own file replaced by a link, then restarted from a copy of its checkpoint:
    refused where the restart continues a file (history, interface history, fields), the link
    replaced where it writes a new one (the checkpoint, by rename)."""
    out, victim, ghost, directory = place
    target = {"victim": victim, "ghost": ghost, "dir": directory}[to]
    fields = "xdmf" if name.endswith(".h5") and name.startswith("fields") else "vtx"
    first = scene(checkpoint_every=0, fields=fields)
    first["outputs"]["checkpoint_times"] = [0.1]  # the restart has a step to make
    run_scene(first, outdir=out, comm=MPI.COMM_WORLD)
    ck = out.parent / "saved.h5"
    on_root(MPI.COMM_WORLD, lambda: shutil.copy(out / "checkpoint.h5", ck))
    plant(out, name, target)
    comm = MPI.COMM_WORLD
    if refused:
        error = PointCloudError if "interface_points" in name else OutputError
        with raised_on_every_rank(error, "symbolic link", name):
            run_scene(scene(fields=fields), outdir=out, comm=comm, restart=ck)
    else:
        run_scene(scene(fields=fields), outdir=out, comm=comm, restart=ck)
    untouched(victim, ghost, directory)
    if name == "checkpoint.h5":
        on_root(comm, lambda: not (out / name).is_symlink() or pytest.fail("link followed"))


def test_previous_run_of_the_user_is_not_deleted(place):
    """A directory previous_run/ with a file this code does not write (the user's notes): a
    fresh run that would replace it is refused on every rank, naming it; nothing is deleted.
    One the user made that holds only names of a run's files (issue 23, item 7: the user's own
    earlier results, deleted with rmtree before) is refused too: this code replaces only the
    previous_run/ it made (marked) or an empty one."""
    out, *_ = place
    comm = MPI.COMM_WORLD
    prev = out / "previous_run"

    def setup():
        prev.mkdir()
        (prev / "notes.txt").write_text(PRECIOUS)
        (prev / "history.csv").write_text(PRECIOUS)

    on_root(comm, setup)
    earlier_run(out)
    with raised_on_every_rank(OutputError, "previous_run", "notes.txt", "not deleted"):
        fresh(out)
    on_root(comm, lambda: (prev / "notes.txt").read_text() == PRECIOUS or 1 / 0)
    on_root(comm, lambda: (prev / "notes.txt").unlink())
    with raised_on_every_rank(
        OutputError, repr(str(prev)), "was not made by this code", "not deleted"
    ):
        fresh(out)
    on_root(comm, lambda: (prev / "history.csv").read_text() == PRECIOUS or 1 / 0)
    on_root(comm, lambda: (prev / "history.csv").unlink())
    fresh(out)  # an empty previous_run/ is replaced: nothing lost
    fresh(out)  # previous_run/ holds the first run's files only, and the mark: replaced
    on_root(
        comm,
        lambda: (
            {"checkpoint.h5", ".made-by-subfric-dolfinx"} <= set(os.listdir(prev))
            or pytest.fail("not moved")
        ),
    )
    # a file of the user's among the fields this code moved there (a ParaView state)
    on_root(comm, lambda: (prev / "fields" / "view.pvsm").write_text(PRECIOUS))
    with raised_on_every_rank(OutputError, "fields/view.pvsm", "not deleted"):
        fresh(out)
    on_root(comm, lambda: (prev / "fields" / "view.pvsm").read_text() == PRECIOUS or 1 / 0)


@pytest.mark.parametrize("fields", ["vtx", "xdmf"])
def test_every_file_a_run_writes_is_in_its_manifest(shared_tmp, fields):
    """A fresh run moves aside only what the manifest lists: every file of a run with every
    output (history, interface history, checkpoint, displacement, interfaces, their points,
    stress) is listed, and nothing listed is missing once the run has ended."""
    out = shared_tmp / fields
    run_scene(scene(fields=fields), outdir=out, comm=MPI.COMM_WORLD)

    def check():
        listed = read_manifest(out)
        found = [str(p.relative_to(out)) + "/" * p.is_dir() for p in out.rglob("*")]
        assert {"displacement", "interface", "interface_points", "stress"} <= {
            n[len("fields/") :].split(".")[0] for n in found if n.startswith("fields/")
        }, found
        assert sorted(set(found) - {MANIFEST}) == sorted(listed), (found, listed)

    on_root(MPI.COMM_WORLD, check)
