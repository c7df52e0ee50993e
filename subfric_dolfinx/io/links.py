"""No output is ever written through a symbolic link.

A run writes only inside its output directory. A symbolic link planted there under the name of
one of its files (``.subfric.lock``, ``history.csv``, ``checkpoint.h5.tmp``, ``fields``, an HDF5
spare, ...) could otherwise make it create, truncate or overwrite a file anywhere the user can
write (a dangling link: create one). The rules:

* files this package opens itself (the lock, ``history.csv``, spares, the directory probe, the
  point cloud's XDMF) are opened with ``O_NOFOLLOW`` (:func:`open_nofollow`): a link there is
  refused (``ELOOP``), naming it;
* files opened by a library (HDF5 through h5py, ADIOS2 and XDMF through DOLFINx) cannot be
  given ``O_NOFOLLOW``: their names are checked just before (:func:`refuse_links`), and a
  temporary file is removed before it is created (``checkpoint.h5.tmp``);
* renames (the checkpoint, a fresh run moving the earlier run's files to ``previous_run/``)
  replace or move the link itself, never its target.

A refused link is an :class:`~.collective.OutputError` on every rank naming the link and where
it points; nothing is written. The output directory itself may be a link (the user chose that
path): only names inside it are checked. What remains: a link planted *between* the check and
a library's own open (a race with another process writing into the same directory) is not
caught for the library-opened files.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

__all__ = [
    "NOFOLLOW",
    "is_link_error",
    "open_nofollow",
    "opener",
    "refuse_links",
    "write_text_nofollow",
]

NOFOLLOW = os.O_NOFOLLOW | os.O_CLOEXEC


def _refused(path: str | os.PathLike[str]) -> OSError:
    try:
        target = f" (to {os.readlink(path)!r})"
    except OSError:
        target = ""
    return OSError(
        errno.ELOOP,
        f"{str(path)!r} is a symbolic link{target}; output is never written through a link: "
        "remove it, or give another output directory",
    )


def is_link_error(e: BaseException) -> bool:
    """Whether ``e`` is the refusal of a link by this module (or by ``O_NOFOLLOW``)."""
    return isinstance(e, OSError) and e.errno == errno.ELOOP


def refuse_links(*paths: str | os.PathLike[str]) -> None:
    """Raise ``OSError(ELOOP)`` naming the first of ``paths`` that is a symbolic link.

    For names a library will open (or create) for writing; a missing name is fine.
    """
    for p in paths:
        if os.path.islink(p):
            raise _refused(p)


def open_nofollow(path: str | os.PathLike[str], flags: int, mode: int = 0o644) -> int:
    """``os.open`` that never follows a link at ``path`` (``O_NOFOLLOW``).

    Raises:
        OSError: ``ELOOP`` naming the link and its target; any other error of ``os.open``.
    """
    try:
        return os.open(path, flags | NOFOLLOW, mode)
    except OSError as e:
        if e.errno == errno.ELOOP and os.path.islink(path):
            raise _refused(path) from None
        raise


def opener(path: str, flags: int) -> int:
    """An ``opener`` for :func:`open`: the file is opened with :func:`open_nofollow`."""
    return open_nofollow(path, flags)


def write_text_nofollow(path: Path, text: str) -> None:
    """Create or replace ``path`` with ``text``; a link there is refused, not followed."""
    with open(path, "w", encoding="utf-8", opener=opener) as f:
        f.write(text)
