"""Units inside closed VTX files (ADIOS2 BP4) as ADIOS2 attributes.

DOLFINx's ``VTXWriter`` keeps its ADIOS2 ``IO`` to itself: nothing can be added to the file
while it is written. Once it is closed, ADIOS2 writes an attribute only with a step: the file
opened again in ``Append`` mode, an attribute defined and the file closed, BP4 writes it in one
more step (for every reader), BP5 not at all; defined within a new step, it is one more step
with either engine (ADIOS2 2.10 and 2.12). So :func:`annotate_vtx` copies
the closed file, step by step and block by block (each rank the blocks it wrote, in its own
step calls), into ``<name>.tmp`` with the attributes in its first step, then puts the copy in
place of the file:

* ``<variable>/unit`` for each variable named in ``units`` (ADIOS2's attribute of a variable,
  ``name``, ``"/"``, ``unit``: ``f_n/unit`` = ``"MPa"``), and the file-level attributes given
  (e.g. ``frame``, ``status_legend``);
* every attribute of the file (DOLFINx's ``vtk.xml``) as it was; every variable with its type,
  its shape kind (local array, local value, global value) and the dimensions of every block, at
  every step where it was written; the number of steps unchanged.

Safety: the file is never modified: the copy is written beside it, read back (steps, variables,
attributes), and only then exchanged with it (``renameat2(RENAME_EXCHANGE)``, atomic, where the
kernel and file system have it; otherwise the file is renamed ``<name>.old`` and the copy to
its name, then ``<name>.old`` removed). A failure anywhere (on any rank) removes the copy and
leaves the file as DOLFINx wrote it, with the same error on every rank. The copy needs the
file's size free on the file system: with less (or without ADIOS2's Python bindings) the file is
left as it is, with an :class:`~subfric_dolfinx.logs.OutputWarning`.

Collective: every rank makes the same ADIOS2 calls (open, every step's begin and end, close)
and the ranks agree on the outcome after each step. ADIOS2's Python bindings must be the MPI
build on several ranks (Debian's wrapper loads its serial build unless it sees ``mpirun`` or
``ADIOS2_ALWAYS_USE_MPI``: :func:`adios2_module` sets the latter when it is unset). Without
them (no bindings, or a serial build on several ranks) the file is left as it is.
"""

from __future__ import annotations

import ctypes
import errno
import os
import shutil
from collections.abc import Mapping
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..logs import OutputWarning, warn
from .collective import Failure, collective
from .links import refuse_links

__all__ = ["adios2_module", "annotate_vtx", "vtx_attributes"]

MARGIN = 64 << 10
"""Bytes asked for beyond the file's own size before copying it (the copy's metadata)."""

_DTYPES = {
    "int8_t": np.int8,
    "int16_t": np.int16,
    "int32_t": np.int32,
    "int64_t": np.int64,
    "uint8_t": np.uint8,
    "uint16_t": np.uint16,
    "uint32_t": np.uint32,
    "uint64_t": np.uint64,
    "float": np.float32,
    "double": np.float64,
    "float complex": np.complex64,
    "double complex": np.complex128,
}
"""ADIOS2's type names -> NumPy's (the types a VTX file holds)."""


def adios2_module(comm: Any) -> Any | None:
    """ADIOS2's Python bindings fit to copy a file on ``comm``, or ``None`` (collective).

    The MPI build is asked for (``ADIOS2_ALWAYS_USE_MPI``, when unset); on several ranks a
    serial build is refused. The answer is the same on every rank.
    """
    os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")
    module: Any = None
    try:
        import adios2

        module = adios2
        ok = comm.size == 1 or bool(getattr(adios2, "is_built_with_mpi", False))
    except Exception:
        ok = False
    return module if comm.allreduce(int(ok)) == comm.size else None


def _room(path: Path) -> tuple[int, int]:
    """(bytes free on the file system of ``path``, bytes of the directory ``path``)."""
    size = sum(p.lstat().st_size for p in path.rglob("*")) if path.is_dir() else 0
    return shutil.disk_usage(path.parent).free, size


def _remove(path: Path) -> None:
    """Remove a file, a link or a directory tree (never following a link)."""
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.is_dir():
        shutil.rmtree(path)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); ``False`` where that is not available."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(a))


def _put_into_place(path: Path, tmp: Path) -> None:
    """Replace the directory ``path`` by ``tmp`` and remove the old one (one process)."""
    refuse_links(path, tmp)
    if _exchange(tmp, path):
        shutil.rmtree(tmp, ignore_errors=True)  # the file as written: left over at worst
        return
    old = path.with_name(path.name + ".old")
    refuse_links(old)
    _remove(old)
    os.rename(path, old)
    try:
        os.rename(tmp, path)
    except OSError:
        os.rename(old, path)
        raise
    shutil.rmtree(old, ignore_errors=True)


class _Copy:
    """One rank's part of the copy of a BP file with attributes added (see the module)."""

    def __init__(self, adios2: Any, comm: Any, path: Path, tmp: Path, engine: str) -> None:
        self.adios2, self.comm = adios2, comm
        mpi = comm.size > 1 or bool(getattr(adios2, "is_built_with_mpi", False))
        self.ad = adios2.Adios(comm=comm) if mpi else adios2.Adios()
        self.rio = self.ad.declare_io("subfric-vtx-read")
        self.rio.set_engine("BPFile")
        self.wio = self.ad.declare_io("subfric-vtx-write")
        self.wio.set_engine(engine)
        self.mode = adios2.bindings.Mode
        self.shape_id = adios2.bindings.ShapeID
        self.reader: Any = self.rio.open(str(path), self.mode.ReadRandomAccess)
        self.writer: Any = None
        self.tmp = tmp
        self.steps = int(self.reader.steps())
        self.names = sorted(self.rio.available_variables())
        self.attributes: dict[str, Any] = {}  # name -> str (a string attribute) or array
        for n in sorted(self.rio.available_attributes()):
            a = self.rio.inquire_attribute(n)
            if a.type() == "string":
                v = a.data_string()  # a str (one string) or a list of them
                self.attributes[n] = v if isinstance(v, str) else list(v)
            else:
                self.attributes[n] = np.asarray(a.data())
        self.wvars: dict[str, Any] = {}
        self.in_step = False  # between this rank's begin_step and end_step of the copy

    def open(self) -> None:
        self.writer = self.wio.open(str(self.tmp), self.mode.Write)

    def _mine(self, n_blocks: int) -> range:
        return range(self.comm.rank, n_blocks, self.comm.size)

    def _dtype(self, var: Any, name: str) -> Any:
        t = var.type()
        if t not in _DTYPES:
            raise Failure(f"variable {name!r} of type {t!r}: not copied")
        return _DTYPES[t]

    def read_step(self, step: int) -> list[tuple[str, Any, Any, list[np.ndarray]]]:
        """This rank's blocks of each variable written at ``step``: (name, kind, dtype, arrays)."""
        out = []
        for name in self.names:
            blocks = self.reader.blocks_info(name, step)
            if not blocks:
                continue
            var = self.rio.inquire_variable(name)
            dtype = self._dtype(var, name)
            kind = var.shape_id()
            var.set_step_selection([step, 1])
            arrays = []
            if kind == self.shape_id.GlobalValue:
                value = np.zeros(1, dtype)
                self.reader.get(var, value, self.mode.Sync)
                arrays = [value for _ in self._mine(len(blocks))]
            elif kind == self.shape_id.LocalValue or var.single_value():
                # local values (one per writing rank) read as a global array of them
                kind = self.shape_id.LocalValue
                values = np.zeros(len(blocks), dtype)
                var.set_selection([[0], [len(blocks)]])
                self.reader.get(var, values, self.mode.Sync)
                arrays = [values[b : b + 1] for b in self._mine(len(blocks))]
            elif kind == self.shape_id.LocalArray:
                for b in self._mine(len(blocks)):
                    # an empty block of a 1-d array has no dimensions ("")
                    text = blocks[b]["Count"]
                    count = tuple(int(c) for c in text.split(",")) if text else (0,)
                    a = np.zeros(count, dtype)
                    if a.size:  # an empty block (a rank without cells) has nothing to read
                        var.set_block_selection(b)
                        self.reader.get(var, a, self.mode.Sync)
                    arrays.append(a)
            else:
                raise Failure(f"variable {name!r}: a global array, not copied")
            out.append((name, kind, dtype, arrays))
        return out

    def put_step(
        self,
        step: int,
        data: list[tuple[str, Any, Any, list[np.ndarray]]],
        units: Mapping[str, str],
        attributes: Mapping[str, str],
    ) -> None:
        """Begin a step of the copy and put this rank's blocks (the attributes in the first)."""
        w = self.writer
        for name, kind, dtype, arrays in data:
            if name not in self.wvars:  # a rank without a block of it defines it alike
                first = arrays[0] if arrays else np.zeros(1, dtype)
                if kind == self.shape_id.LocalArray:
                    var = self.wio.define_variable(name, first, [], [], list(first.shape))
                elif kind == self.shape_id.LocalValue:
                    var = self.wio.define_variable(name, first, [self.adios2.LocalValueDim])
                else:
                    var = self.wio.define_variable(name, first)
                self.wvars[name] = var
        if step == 0:  # before the first put: BP4 writes a step's attributes with its first
            mine = [n for n in self.wvars if n in units]
            given = {f"{n}/unit" for n in mine} | set(attributes)
            for name, value in self.attributes.items():
                if name not in given:  # an attribute given anew replaces the file's
                    self.wio.define_attribute(name, value)
            for name in mine:
                self.wio.define_attribute("unit", units[name], name, "/")
            for name, text in attributes.items():
                self.wio.define_attribute(name, text)
        w.begin_step()
        self.in_step = True
        for name, kind, _, arrays in data:
            var = self.wvars[name]
            for a in arrays:
                if kind == self.shape_id.LocalArray:
                    var.set_selection([[], list(a.shape)])
                w.put(var, np.ascontiguousarray(a), self.mode.Sync)

    def end_step(self) -> None:
        self.writer.end_step()
        self.in_step = False

    def close(self) -> None:
        for e in (self.writer, self.reader):
            if e is not None:
                e.close()
        self.writer = self.reader = None

    def abandon(self) -> None:
        """Close what is open, ignoring errors (collective: called on every rank).

        Closing the copy is collective (its metadata is gathered): when any rank failed within
        a step, the ranks are in different places of it, and the copy is dropped instead
        (ADIOS2's objects destroyed without closing it: no collective call; it is removed
        afterwards).
        """
        mid_step = any(self.comm.allgather(self.in_step))
        if self.writer is not None and mid_step:
            self.writer = self.reader = None  # both engines go with their IOs
            try:
                self.ad.remove_all_ios()
            except Exception:
                pass
        for e in (self.writer, self.reader):
            try:
                if e is not None:
                    e.close()
            except Exception:
                pass
        self.writer = self.reader = None


def vtx_attributes(adios2: Any, comm: Any, path: Path) -> tuple[int, dict[str, str], list[str]]:
    """(steps, string attributes, variables) of a BP file, as ADIOS2 reads them (collective)."""
    mpi = comm.size > 1 or bool(getattr(adios2, "is_built_with_mpi", False))
    ad = adios2.Adios(comm=comm) if mpi else adios2.Adios()
    io = ad.declare_io("subfric-vtx-check")
    io.set_engine("BPFile")
    e = io.open(str(path), adios2.bindings.Mode.ReadRandomAccess)
    try:
        attrs = {}
        for n in io.available_attributes():
            a = io.inquire_attribute(n)
            if a.type() == "string":
                v = a.data_string()  # a str (one string) or a list of them
                attrs[n] = v if isinstance(v, str) else "\n".join(v)
        return int(e.steps()), attrs, sorted(io.available_variables())
    finally:
        e.close()


def annotate_vtx(
    comm: Any,
    path: str | Path,
    units: Mapping[str, str],
    attributes: Mapping[str, str] | None = None,
    engine: str = "BP4",
) -> bool:
    """Write units into a closed VTX file as ADIOS2 attributes (collective; see the module).

    Args:
        comm: The communicator the file was written on (each rank copies its own blocks).
        path: The ``.bp`` directory.
        units: Variable name -> unit (``<name>/unit``; names the file lacks are left out).
        attributes: File-level name -> text.
        engine: The engine of the copy (the file's own: DOLFINx's ``VTXWriter`` is given
            ``"BP4"`` here).

    Returns:
        ``True`` if the file now holds the attributes; ``False`` if it was left as it is.

    Warns:
        OutputWarning: The file is left as it is: ADIOS2's Python bindings are missing, or
            the file system has less room than the file's size (and :data:`MARGIN`) for the
            copy.

    Raises:
        OutputError: On every rank: the copy failed (the file is then as it was, the copy
            removed).
    """
    path = Path(path)
    adios2 = adios2_module(comm)
    why = None
    if adios2 is None:
        why = "ADIOS2's Python bindings (the MPI build on several ranks) are not installed"
    else:
        room = collective(comm, lambda: _room(path), f"measuring {str(path)!r}", share=True)
        assert room is not None
        free, size = room
        if free < size + MARGIN:
            why = f"copying it with them needs {size + MARGIN} bytes, {free} are free"
    if why is not None:
        warn(f"{str(path)!r} is left without its units as attributes: {why}", OutputWarning, comm)
        return False
    tmp = path.with_name(path.name + ".tmp")
    what = f"writing the units into {str(path)!r}"

    def clear() -> None:
        refuse_links(tmp)
        _remove(tmp)

    collective(comm, clear, what, path=tmp)
    copy: list[_Copy] = []

    def cleanup() -> None:
        for c in copy:
            c.abandon()
        comm.Barrier()
        if comm.rank == 0:
            try:
                _remove(tmp)
            except OSError:
                pass

    def start() -> None:
        copy.append(_Copy(adios2, comm, path, tmp, engine))

    collective(comm, start, what, root=None, path=path, cleanup=cleanup)
    c = copy[0]

    def open_copy() -> None:
        if len(set(comm.allgather(c.steps))) != 1:
            raise Failure(f"the ranks read different numbers of steps ({c.steps} here)")
        c.open()

    collective(comm, open_copy, what, root=None, path=tmp, cleanup=cleanup)
    attrs = dict(attributes or {})
    for step in range(c.steps):
        read = partial(c.read_step, step)
        data = collective(comm, read, what, root=None, path=path, cleanup=cleanup)
        assert data is not None
        put = partial(c.put_step, step, data, units, attrs)
        collective(comm, put, what, root=None, path=tmp, cleanup=cleanup)
        collective(comm, c.end_step, what, root=None, path=tmp, cleanup=cleanup)
    collective(comm, c.close, what, root=None, path=tmp, cleanup=cleanup)

    def check() -> None:
        steps, found, names = vtx_attributes(adios2, comm, tmp)
        kept = {k: v for k, v in c.attributes.items() if isinstance(v, str)}
        want = kept | {f"{n}/unit": u for n, u in units.items() if n in names} | attrs
        if steps != c.steps or names != c.names:
            raise Failure(f"the copy has {steps} steps and variables {names}")
        missing = [k for k, v in want.items() if found.get(k) != v]
        if missing:
            raise Failure(f"the copy lacks the attributes {missing}")

    collective(comm, check, what, root=None, path=tmp, cleanup=cleanup)
    collective(comm, lambda: _put_into_place(path, tmp), what, path=path, cleanup=cleanup)
    return True
