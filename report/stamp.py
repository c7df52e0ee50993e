"""Stamps of measured results: the commit they measured, when, and on how busy a machine.

The report (``report/README.md``, its figures and ``report/data/``) and the demo results
(``docs/demo_results.json``, the figures of the demo pages, the numbers the README and the docs
quote) are records of one run of the code. Each carries a stamp made when it was produced
(:func:`make`): the commit, the date, the machine's load and cores, and the files of the package,
the demos or the benchmarks that had uncommitted changes then. The stamp is a label
(:func:`label`): it says which code a record measured, never whether that is still the code here.

Whether the records still describe the code is checked on results, not on commit ids:
``tests/demos/test_records.py`` re-runs every quoted accuracy figure that is cheap to recompute
and compares it with its record within a stated tolerance (a refactoring that keeps the results
passes without regenerating anything; a change that moves a quoted figure fails, naming it).
:func:`on_history` only says whether the stamped commit is part of this checkout's history (a
record of a commit on another branch, or of uncommitted changes, is not a record of main).
"""

from __future__ import annotations

import os
import socket
import subprocess
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MEASURED = (
    "subfric_dolfinx",
    "demos",
    "benchmarks",
    "report/*.py",
    "docs/*.py",
    "tests/stability",
    "tests/reference_ode.py",
)
"""The code a record may have measured (git pathspecs): a stamp lists its uncommitted changes
(not those of the records themselves, which a run writes as it goes)."""

RECORD_DOLFINX = "0.9."
"""The records are made on the default stack (Debian 13, DOLFINx 0.9: ``./run refresh``) and
re-checked on it: ``tests/demos/test_records.py`` marks its re-runs ``records``, which the other
stack's legs deselect (the other stack's results are checked against closed forms and references
by the rest of the suite, not against another stack's records)."""


class WrongStack(RuntimeError):
    """Records made, or about to be made, on another stack than :data:`RECORD_DOLFINX`'s."""


def on_record_stack() -> bool:
    """Whether this process runs the DOLFINx the records are made on (imports DOLFINx)."""
    import dolfinx

    return dolfinx.__version__.startswith(RECORD_DOLFINX)


def require_record_stack() -> None:
    """Refuse to make records on another stack than the records' own.

    Raises:
        WrongStack: this process runs another DOLFINx (the message says which, and what to run).
    """
    if not on_record_stack():
        import dolfinx

        raise WrongStack(
            f"the records are made on DOLFINx {RECORD_DOLFINX}x (SUBFRIC_STACK=trixie), not on "
            f"DOLFINx {dolfinx.__version__}: run ./run refresh without SUBFRIC_STACK=sid"
        )


class NoHistory(RuntimeError):
    """There is no git repository (or no git) to stamp results with."""


def git(*args: str, root: Path = ROOT, check: bool = True) -> str:
    """A git command's output (stripped).

    Raises:
        NoHistory: git is missing, or (with ``check``) the command failed.
    """
    try:
        p = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
    except FileNotFoundError:
        raise NoHistory("git is not installed") from None
    if check and p.returncode != 0:
        raise NoHistory(f"git {' '.join(args)}: {p.stderr.strip()}")
    return p.stdout.strip()


def make(root: Path = ROOT) -> dict[str, Any]:
    """The stamp of results measured now from the checkout at ``root``.

    Raises:
        NoHistory: ``root`` is not a git checkout.
    """
    if git("rev-parse", "--is-inside-work-tree", root=root, check=False) != "true":
        raise NoHistory(f"{root} is not a git checkout: results cannot be stamped")
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", *MEASURED, root=root)
    load1, load5, _ = os.getloadavg()
    return {
        "commit": git("rev-parse", "HEAD", root=root),
        # "XY path" lines; git() stripped the first one's leading space (" M path")
        "dirty": sorted({ln[2:].strip() for ln in dirty.splitlines()}),
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "load": [round(load1, 2), round(load5, 2)],
        "cores": os.cpu_count(),
        "host": socket.gethostname(),
    }


def label(stamp: dict[str, Any]) -> str:
    """A short text for figures and pages: the commit, the date and the load."""
    text = f"commit {stamp['commit'][:10]}, {stamp['date']}"
    if stamp.get("load"):
        text += f", load {stamp['load'][0]:.1f} on {stamp.get('cores', '?')} cores"
    return text + (" + uncommitted changes" if stamp.get("dirty") else "")


def on_history(stamp: dict[str, Any], root: Path = ROOT) -> str | None:
    """Why the stamp is not a record of a commit of this checkout's history (``None``: it is).

    Raises:
        NoHistory: No git repository to look in.
    """
    if git("rev-parse", "--is-inside-work-tree", root=root, check=False) != "true":
        raise NoHistory(f"{root} is not a git checkout")
    if stamp.get("dirty"):
        return f"it was made from uncommitted changes to {', '.join(stamp['dirty'][:5])}"
    commit = stamp["commit"]
    if not _succeeds("cat-file", "-e", f"{commit}^{{commit}}", root=root):
        return f"its commit {commit[:10]} is not in this repository"
    if not _succeeds("merge-base", "--is-ancestor", commit, "HEAD", root=root):
        return f"its commit {commit[:10]} is not an ancestor of HEAD"
    return None


def _succeeds(*args: str, root: Path) -> bool:
    """Whether a git command exits with 0."""
    return subprocess.run(["git", "-C", str(root), *args], capture_output=True).returncode == 0
