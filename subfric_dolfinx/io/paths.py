"""Names that become file names, and output paths confirmed inside their directory.

A run writes only inside its output directory. Some names in its files come from the user's data:
an interface is named by a physical group of the mesh, and with several interfaces its name is
part of file names (``interface_history_<name>.h5``, ``fields/interface_<name>.bp``,
``fields/interface_points_<name>.xdmf``). A mesh's group names are free text (``"a/../../x"``,
``"contact 1"``, ``".."``); they are data, never a path:

* :func:`file_part` maps a name to a safe part of a file name: ASCII letters, digits and
  ``_ - + .`` are kept, every other run of characters becomes one ``_``, a leading ``.`` or
  ``-`` becomes ``_`` (no hidden file, no ``.``/``..``, nothing read as an option), an empty
  name is ``_`` and a long one is cut to :data:`MAX_PART` characters ending in a digest of the
  whole name. A name already of that kind is kept as it is;
* :func:`interface_stems` gives each interface its stem and refuses two names that would map to
  the same file (naming both);
* :func:`inside` joins a relative name to a directory and confirms the result stays inside it
  (no absolute part, no ``..``, no empty part, and the resolved parent directory is the
  directory or below it: a subdirectory that is a link to elsewhere is refused). Every file of a
  scene's run is placed with it.

The user's names are kept unchanged where they are data: the history's column names, the
attributes of the HDF5 files.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Sequence
from pathlib import Path, PurePosixPath

from .collective import OutputError

__all__ = ["MAX_PART", "file_part", "inside", "interface_stems"]

MAX_PART = 64
"""The longest part of a file name :func:`file_part` makes (characters)."""

_UNSAFE = re.compile(r"[^A-Za-z0-9_.+-]+")


def file_part(name: str) -> str:
    """A safe part of a file name for ``name`` (see the module docstring).

    Args:
        name: Any text, e.g. a physical group's name.

    Returns:
        ``name`` itself if it is already safe, otherwise its mapped form.
    """
    part = _UNSAFE.sub("_", str(name))
    if part[:1] in (".", "-"):
        part = "_" + part[1:]
    part = part or "_"
    if len(part) > MAX_PART:
        digest = hashlib.sha256(str(name).encode("utf-8", "surrogatepass")).hexdigest()[:8]
        part = f"{part[: MAX_PART - 9]}-{digest}"
    return part


def interface_stems(base: str, names: Sequence[str]) -> dict[str, str]:
    """The stem of each interface's file: ``base`` with one interface, ``base_<part>`` with several.

    Args:
        base: The file's base name (``"interface_history"``).
        names: The interfaces' names, in order.

    Returns:
        Name -> stem.

    Raises:
        OutputError: Two names map to the same stem (both named).
    """
    names = list(names)
    if len(names) == 1:
        return {names[0]: base}
    stems: dict[str, str] = {}
    owner: dict[str, str] = {}
    for n in names:
        stem = f"{base}_{file_part(n)}"
        if stem in owner:
            raise OutputError(
                f"the interfaces {owner[stem]!r} and {n!r} would write the same file "
                f"({stem!r}: a name is kept to letters, digits and '_-+.' in file names); "
                "rename one of the mesh's physical groups"
            )
        owner[stem] = n
        stems[n] = stem
    return stems


def inside(directory: str | os.PathLike[str], name: str, resolve: bool = True) -> Path:
    """``directory / name``, confirmed to lie inside ``directory``.

    Args:
        directory: The directory (it need not exist yet; it may itself be a link, the user's
            choice).
        name: A relative name, ``/`` between parts (``"fields/interface_low.bp"``).
        resolve: Also confirm that the parent directory, resolved (its links followed), is
            ``directory`` or below it (``False``: the name's parts only).

    Raises:
        OutputError: ``name`` is absolute, has an empty, ``.`` or ``..`` part or a NUL, or its
            parent directory resolves outside ``directory`` (naming both).
    """
    root = Path(directory)
    parts = PurePosixPath(name).parts if isinstance(name, str) else ()
    bad = (
        not parts
        or name.startswith("/")
        or "\0" in name
        or "//" in name
        or any(p in (".", "..") for p in parts)
    )
    path = root.joinpath(*parts) if parts else root
    if not bad and resolve:
        top = os.path.realpath(root)
        parent = os.path.realpath(path.parent)
        bad = os.path.commonpath([top, parent]) != top
    if bad:
        why = ""
        for i in range(1, len(parts)):
            p = root.joinpath(*parts[:i])
            if os.path.islink(p):
                why = f" ({str(p)!r} is a symbolic link to {os.readlink(p)!r})"
                break
        raise OutputError(
            f"{name!r} is not a file inside the output directory {str(root)!r}{why}: not written",
            path,
        )
    return path
