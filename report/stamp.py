"""Stamps of measured results: which code they measured, and whether that is still the code here.

The report (``report/README.md``, its figures and ``report/data/``) and the demo results
(``docs/demo_results.json``, the figures of the demo pages, the numbers the README quotes) are
measurements of the code. Each carries a stamp made when it was produced (:func:`make`): the
commit, and the git *tree* of every measured folder at that commit (``constitutive/``, ``fem/``
and ``compat.py`` for the report; those and ``demos/`` for the demo results), and whether the
measured folders had uncommitted changes then. ``compat.py`` is measured because it holds what
differs between DOLFINx versions and the mesh partition helper: a change to the partition alone
changed the fretting demo's time 2.8x.

:func:`check` says whether a stamp still describes the code, comparing tree ids (not dates or
commit ancestry: a rebase or a merge that leaves the measured code as it was keeps the stamp
valid). Against which code:

* a branch that did not touch the stamped file is judged against ``main``: the results describe
  the code on ``main``, and keeping them current is the job of whoever merges into ``main`` (a
  helper's branch that changes ``fem/`` does not fail because of the report; ``main`` fails once
  that change is merged, until ``./run report`` is run);
* a branch that changed the stamped file (it regenerated the results) is judged against its own
  ``HEAD``: it must have measured its own code.

``SUBFRIC_STAMP_BASE`` names another reference than ``main`` (e.g. ``origin/main`` in a CI
clone). Without git metadata (a source archive, the Docker image) nothing can be checked and
:func:`check` says so.
"""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
REPORT_MEASURES = (
    "subfric_dolfinx/constitutive",
    "subfric_dolfinx/fem",
    "subfric_dolfinx/compat.py",
)
DEMOS_MEASURE = (*REPORT_MEASURES, "demos")


class NoHistory(RuntimeError):
    """There is no git repository (or no git) to compare a stamp with."""


def git(*args: str, root: Path = ROOT, check: bool = True) -> str:
    """A git command's output (stripped)."""
    try:
        p = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
    except FileNotFoundError:
        raise NoHistory("git is not installed") from None
    if check and p.returncode != 0:
        raise NoHistory(f"git {' '.join(args)}: {p.stderr.strip()}")
    return p.stdout.strip()


def tree(ref: str, path: str, root: Path = ROOT) -> str:
    """The git tree id of ``path`` at ``ref`` (empty if it does not exist there)."""
    return git("rev-parse", "--verify", "--quiet", f"{ref}:{path}", root=root, check=False)


def make(paths: Sequence[str], root: Path = ROOT) -> dict[str, Any]:
    """The stamp of results measured now from the checkout at ``root``."""
    if git("rev-parse", "--is-inside-work-tree", root=root, check=False) != "true":
        raise NoHistory(f"{root} is not a git checkout: results cannot be stamped")
    dirty = git("status", "--porcelain", "--", *paths, root=root)
    return {
        "commit": git("rev-parse", "HEAD", root=root),
        "trees": {p: tree("HEAD", p, root) for p in paths},
        # "XY path" lines; git() stripped the first one's leading space (" M path")
        "dirty": sorted({ln[2:].strip() for ln in dirty.splitlines()}),
        "date": time.strftime("%Y-%m-%d %H:%M"),
    }


def label(stamp: dict[str, Any]) -> str:
    """A short text for figures and pages: the commit (and '+ local changes')."""
    text = f"commit {stamp['commit'][:10]}, {stamp['date']}"
    return text + (" + uncommitted changes" if stamp.get("dirty") else "")


def check(stamp: dict[str, Any], stamped_file: str, root: Path = ROOT) -> list[str]:
    """Why the stamp no longer describes the code (empty: it does).

    Args:
        stamp: From :func:`make`, as stored.
        stamped_file: The stored file (relative to ``root``): whether this branch changed it
            decides which code the stamp is compared with.
        root: The checkout.

    Raises:
        NoHistory: No git repository to compare with.
    """
    if git("rev-parse", "--is-inside-work-tree", root=root, check=False) != "true":
        raise NoHistory(f"{root} is not a git checkout")
    base = os.environ.get("SUBFRIC_STAMP_BASE", "main")
    if not git("rev-parse", "--verify", "--quiet", base, root=root, check=False):
        base = "HEAD"  # a clone with main only as HEAD
    fork = git("merge-base", base, "HEAD", root=root, check=False) or base
    changed_here = bool(git("diff", "--name-only", fork, "HEAD", "--", stamped_file, root=root))
    ref = "HEAD" if changed_here else base
    why = []
    if stamp.get("dirty"):
        why.append(f"it was made from uncommitted changes to {', '.join(stamp['dirty'])}")
    for path, tree_id in stamp["trees"].items():
        now = tree(ref, path, root)
        if now != tree_id:
            last = git("log", "-1", "--format=%h %s", ref, "--", path, root=root)
            why.append(f"{path} at {ref} is not what it measured (last change: {last[:90]})")
    return why
