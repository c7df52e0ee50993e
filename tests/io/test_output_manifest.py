"""A run touches only the files it can show it wrote; a user's file is never moved or deleted.

Output files were recognised by name: a user's ``history.csv`` in the chosen output directory
was moved to ``previous_run/`` by the first run and deleted by the second; a per-interface
``interface_history_<name>.h5`` was not moved aside by a fresh run (an old one stayed beside the
new history). Now the directory's manifest (``.subfric-files.json``, written atomically before
the run writes) lists the run's files:

* a file the run would write that no manifest lists is refused on every rank, naming it,
  untouched (the issue's ``history.csv``, then a second run: still there);
* the user's other files (beside the run's, in ``fields/``) stay where they are through any
  number of runs; ``previous_run/`` holding a user's file is not deleted (refused, naming it);
* a killed run's manifest lists all it meant to write: the next run moves what it left aside;
* a manifest naming the lock, ``previous_run``, itself or a path outside is not obeyed;
* every file of an earlier run is moved aside by a fresh run, whatever its name (the
  per-interface histories of a two-interface scene).

Directory-level tests drive :class:`~subfric_dolfinx.io.OutputDirectory` with files made by
hand (no solve); two small scene runs check the real runs. 1 and 2 ranks.
"""

from __future__ import annotations

import json
import os

from mpi4py import MPI

from subfric_dolfinx.io import OutputDirectory, OutputError
from subfric_dolfinx.io.outdir import MANIFEST, read_manifest, write_manifest
from subfric_dolfinx.scenes import run_scene
from tests.helpers import on_root, prefix, raised_on_every_rank, small_scene
from tests.io.test_output_names import one_step_scene, renamed_stack
from tests.scenes.test_scene_bodies import write_model

MINE = "the user's own file\n"
FILES = ["history.csv", "fields/", "fields/displacement.bp", "fields/units.json", "checkpoint.h5"]
WRITTEN = [  # the manifest once the run has ended: a library's directory (.bp) with its files
    "history.csv",
    "fields/",
    "fields/displacement.bp/",
    "fields/displacement.bp/data.0",
    "fields/units.json",
    "checkpoint.h5",
]


def run_writing(out, files=FILES, fresh=True, written=None):
    """An :class:`OutputDirectory` for ``files``; rank 0 writes ``written`` (default: all)."""
    comm = MPI.COMM_WORLD
    with OutputDirectory(out, comm, fresh=fresh, files=files) as d:

        def write():
            for n in files if written is None else written:
                p = out / n
                if n.endswith(("/", ".bp")):
                    p.mkdir(exist_ok=True)
                    if n.endswith(".bp"):
                        (p / "data.0").write_text("bp")
                else:
                    p.write_text(f"run {n}\n")

        on_root(comm, write)
        return d


def tree(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_a_users_file_by_the_name_of_an_output_is_refused_not_moved(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"

    def setup():
        out.mkdir()
        (out / "history.csv").write_text(MINE)

    on_root(comm, setup)
    s = small_scene()
    s["outputs"] = {"history": True}
    s["solver"]["prefix"] = prefix("mine")
    for _ in range(2):  # the second run deleted it
        with raised_on_every_rank(
            OutputError, repr(str(out)), "history.csv", "no run of this code wrote", "not touched"
        ):
            run_scene(s, outdir=out, comm=comm)
        assert on_root(comm, lambda: (out / "history.csv").read_text()) == MINE
        assert on_root(comm, lambda: tree(out)) == ["history.csv"]


def test_the_users_files_beside_and_among_the_outputs_stay_through_runs(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"
    run_writing(out)

    def mine():
        (out / "notes.txt").write_text(MINE)
        (out / "fields" / "view.pvsm").write_text(MINE)

    on_root(comm, mine)
    assert on_root(comm, lambda: read_manifest(out)) == WRITTEN
    for _ in range(3):
        run_writing(out, written=["history.csv"])  # the next runs write less
    expected = [
        MANIFEST,
        "fields",
        "fields/view.pvsm",
        "history.csv",
        "notes.txt",
        "previous_run",
        "previous_run/.made-by-subfric-dolfinx",
        f"previous_run/{MANIFEST}",
        "previous_run/history.csv",
    ]
    assert on_root(comm, lambda: tree(out)) == expected
    assert on_root(comm, lambda: (out / "fields" / "view.pvsm").read_text()) == MINE
    assert on_root(comm, lambda: read_manifest(out)) == ["history.csv", "fields/"]  # what exists


def test_a_users_file_in_previous_run_is_never_deleted(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"
    run_writing(out)
    run_writing(out)
    before = on_root(comm, lambda: tree(out / "previous_run"))
    assert "previous_run/fields/displacement.bp/data.0" in ["previous_run/" + p for p in before]
    for where in ("fields/displacement.bp/notes.txt", "fields/view.pvsm", "notes.txt"):
        on_root(comm, lambda w=where: (out / "previous_run" / w).write_text(MINE))
        with raised_on_every_rank(OutputError, "previous_run", "not deleted"):
            run_writing(out)
        on_root(comm, lambda w=where: (out / "previous_run" / w).unlink())
    assert on_root(comm, lambda: tree(out / "previous_run")) == before  # nothing moved


def test_a_killed_runs_files_are_moved_aside_by_the_next(shared_tmp):
    """A run that never reached its end: its manifest lists all it meant to write."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"
    d = OutputDirectory(out, comm, files=FILES)
    d.__enter__()
    on_root(comm, lambda: (out / "history.csv").write_text("killed\n"))
    d._unlock()  # as the kernel does for a killed process: the lock goes, nothing else
    comm.Barrier()
    assert on_root(comm, lambda: read_manifest(out)) == FILES
    run_writing(out, written=[])
    assert on_root(comm, lambda: (out / "previous_run" / "history.csv").read_text()) == "killed\n"


def test_a_manifest_naming_what_is_not_a_runs_file_is_not_obeyed(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "run" / "out"

    def forge():
        out.mkdir(parents=True)
        (shared_tmp / "run" / "victim").write_text(MINE)
        (out / "previous_run").mkdir()
        (out / "previous_run" / "keep").write_text(MINE)
        names = ["../victim", "/etc/hostname", ".subfric.lock", "previous_run", MANIFEST, "a//b"]
        (out / MANIFEST).write_text(json.dumps({"files": names}))

    on_root(comm, forge)
    run_writing(out, files=["history.csv"])
    assert on_root(comm, lambda: (shared_tmp / "run" / "victim").read_text()) == MINE
    assert on_root(comm, lambda: (out / "previous_run" / "keep").read_text()) == MINE
    for bad in ("not json", json.dumps([1, 2]), json.dumps({"files": [3]})):
        on_root(comm, lambda b=bad: (out / MANIFEST).write_text(b))
        with raised_on_every_rank(OutputError, "history.csv", "no run of this code wrote"):
            run_writing(out, files=["history.csv"])


def test_a_restart_continues_only_its_own_files(shared_tmp):
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"
    run_writing(out, files=["history.csv"])
    run_writing(out, files=["history.csv"], fresh=False)  # listed: continued
    assert on_root(comm, lambda: tree(out)) == [MANIFEST, "history.csv"]
    on_root(comm, lambda: (out / "interface_history.h5").write_text(MINE))
    with raised_on_every_rank(OutputError, "interface_history.h5", "no run of this code wrote"):
        run_writing(out, files=["history.csv", "interface_history.h5"], fresh=False)
    assert on_root(comm, lambda: (out / "interface_history.h5").read_text()) == MINE


def test_the_manifest_is_replaced_never_written_in_place(shared_tmp, monkeypatch):
    """Written to a new file and renamed over: a reader sees the old list or the new one."""
    comm = MPI.COMM_WORLD
    out = shared_tmp / "out"
    on_root(comm, lambda: (out.mkdir(), write_manifest(out, ["a"])))
    ino = on_root(comm, lambda: os.stat(out / MANIFEST).st_ino)
    on_root(comm, lambda: write_manifest(out, ["a", "b"]))
    assert on_root(comm, lambda: os.stat(out / MANIFEST).st_ino) != ino
    assert on_root(comm, lambda: (read_manifest(out), sorted(os.listdir(out)))) == (
        ["a", "b"],
        [MANIFEST],
    )


def test_a_fresh_run_moves_the_per_interface_histories_aside(shared_tmp):
    comm = MPI.COMM_WORLD
    names = {"low": "low", "high": "high"}
    mesh = shared_tmp / "stack.msh"
    on_root(comm, lambda: write_model(renamed_stack(names), mesh))
    out = shared_tmp / "out"
    run_scene(one_step_scene(mesh, names, interface_history=True), outdir=out, comm=comm)
    run_scene(one_step_scene(mesh, names, history=True), outdir=out, comm=comm)
    assert on_root(comm, lambda: tree(out)) == [
        MANIFEST,
        "history.csv",
        "history.csv-metadata.json",
        "previous_run",
        "previous_run/.made-by-subfric-dolfinx",
        f"previous_run/{MANIFEST}",
        "previous_run/interface_history_high.h5",
        "previous_run/interface_history_low.h5",
    ]
