"""Write the stored meshes of ``meshes/`` (run serially: ``./run exec python3 meshes/generate.py``).

Importable as ``meshes.generate`` (the repository root on the path, as ``./run`` sets it).

Good meshes (two bodies joined by a duplicated-node interface, see :mod:`subfric_dolfinx.meshing`
for the physical groups):

* ``block_on_base_tri.msh``, ``block_on_base_quad.msh``: 2-D block on a base;
* ``pad_on_plate_tet.msh``, ``pad_on_plate_hex.msh``: 3-D pad on a plate.

Deliberately broken meshes, for error tests:

* ``broken_no_interface.msh``: the 2-D triangle mesh without its ``interface`` group;
* ``broken_mismatch_count.msh``: base and block meshed separately, 8 interface facets on the
  primary side and 9 on the secondary side (the reader rejects it: different facet counts);
* ``broken_mismatch_coords.msh``: as above with 8 facets on each side, but the secondary side
  graded (progression 1.3), so the sides have equal counts and nodes that do not pair (the reader
  accepts it; node-to-node pairing is checked by the interface layer).

``--outdir DIR`` writes elsewhere; ``--check`` regenerates into a temporary directory and compares
with the stored files (exit code 1 on a difference): the same lines, integers and words, and every
real number within 1e-12 relative (:func:`same_msh`). The files are ASCII MSH 4.1 and gmsh's
meshing is deterministic, so running this script reproduces them: byte for byte with the gmsh
that wrote them (4.13, Debian 13); gmsh 4.15 (Debian sid) writes the same meshes with some
coordinates different in the 16th digit (last-bit round-off of another build).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import gmsh

from subfric_dolfinx import meshing

HERE = Path(__file__).resolve().parent


def _block_tri() -> None:
    meshing.build_block_on_base(cell_type="triangle", n_interface=8)


def _block_quad() -> None:
    meshing.build_block_on_base(cell_type="quadrilateral", n_interface=12)


def _pad_tet() -> None:
    meshing.build_pad_on_plate(
        cell_type="tetrahedron", plate_size=(1.5, 1.5, 0.5), pad_size=(1.0, 1.0, 0.5), n_interface=3
    )


def _pad_hex() -> None:
    meshing.build_pad_on_plate(cell_type="hexahedron", n_interface=5)


def _no_interface() -> None:
    meshing.build_block_on_base(cell_type="triangle", n_interface=8)
    gmsh.model.removePhysicalGroups([(1, meshing.TAGS[meshing.INTERFACE])])
    gmsh.model.removePhysicalName(meshing.INTERFACE)


def _separate_bodies(n_primary: int, n_secondary: int, progression: float) -> None:
    """Base [0,1]x[0,0.5] and block [0,1]x[0.5,1] meshed independently (no shared entity).

    Their interface curves are both put in the ``interface`` group, with ``n_primary`` and
    ``n_secondary`` elements; the block's bottom curve is graded by ``progression``.
    """
    occ = gmsh.model.occ
    gmsh.model.add("separate_bodies")
    base = occ.addRectangle(0.0, 0.0, 0.0, 1.0, 0.5)
    block = occ.addRectangle(0.0, 0.5, 0.0, 1.0, 0.5)
    occ.synchronize()
    groups: dict[str, list[int]] = {}
    for body, surface in ((meshing.PRIMARY, base), (meshing.SECONDARY, block)):
        groups[body] = [surface]
        for _, curve in gmsh.model.getBoundary([(2, surface)], oriented=False):
            x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, curve)
            cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            horizontal = (x1 - x0) > (y1 - y0)
            if horizontal and abs(cy - 0.5) < 1e-6:
                name = meshing.INTERFACE
                n = n_primary if body == meshing.PRIMARY else n_secondary
                p = 1.0 if body == meshing.PRIMARY else progression
                gmsh.model.mesh.setTransfiniteCurve(curve, n + 1, "Progression", p)
            else:
                if horizontal:
                    name = meshing.BOTTOM if cy < 0.25 else meshing.TOP
                else:
                    name = f"{body}_{'left' if cx < 0.5 else 'right'}"
                gmsh.model.mesh.setTransfiniteCurve(curve, 9 if horizontal else 5)
            groups.setdefault(name, []).append(curve)
    for name, entities in groups.items():
        dim = 2 if name in meshing.BODIES else 1
        gmsh.model.addPhysicalGroup(dim, entities, meshing.TAGS[name], name=name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.125)
    gmsh.model.mesh.generate(2)


#: file name -> function building the model in the current gmsh session
MESHES: dict[str, Callable[[], None]] = {
    "block_on_base_tri.msh": _block_tri,
    "block_on_base_quad.msh": _block_quad,
    "pad_on_plate_tet.msh": _pad_tet,
    "pad_on_plate_hex.msh": _pad_hex,
    "broken_no_interface.msh": _no_interface,
    "broken_mismatch_count.msh": lambda: _separate_bodies(8, 9, 1.0),
    "broken_mismatch_coords.msh": lambda: _separate_bodies(8, 8, 1.3),
}


def generate(outdir: Path) -> list[Path]:
    """Write all meshes of :data:`MESHES` into ``outdir``; return their paths."""
    outdir.mkdir(parents=True, exist_ok=True)
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    written = []
    try:
        for name, build in MESHES.items():
            gmsh.option.setNumber("General.Verbosity", 2)
            gmsh.clear()
            gmsh.option.setNumber("General.NumThreads", 1)
            gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
            gmsh.option.setNumber("Mesh.Binary", 0)
            gmsh.option.setNumber("Mesh.SaveAll", 0)
            build()
            path = outdir / name
            gmsh.write(str(path))
            written.append(path)
            gmsh.model.remove()
    finally:
        if own:
            gmsh.finalize()
    return written


def same_msh(a: Path, b: Path, rtol: float = 1e-12) -> bool:
    """Whether two ASCII MSH files hold the same mesh.

    The same lines and tokens; numbers with a decimal point or exponent equal within ``rtol``
    (relative to the larger, 1 at least).
    """
    la, lb = a.read_text().splitlines(), b.read_text().splitlines()
    if len(la) != len(lb):
        return False
    for x, y in zip(la, lb, strict=True):
        if x == y:
            continue
        tx, ty = x.split(), y.split()
        if len(tx) != len(ty):
            return False
        for u, v in zip(tx, ty, strict=True):
            if u == v:
                continue
            if not any(c in u + v for c in ".eE"):
                return False
            try:
                fu, fv = float(u), float(v)
            except ValueError:
                return False
            if abs(fu - fv) > rtol * max(1.0, abs(fu), abs(fv)):
                return False
    return True


def main(argv: list[str] | None = None) -> int:
    """Command line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--outdir", type=Path, default=HERE, help="output directory")
    parser.add_argument("--check", action="store_true", help="compare with the stored files")
    args = parser.parse_args(argv)
    if not args.check:
        for path in generate(args.outdir):
            print(f"{path}  {path.stat().st_size / 1024:.1f} kB")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        differ = [
            p.name
            for p in generate(Path(tmp))
            if not (HERE / p.name).is_file() or not same_msh(p, HERE / p.name)
        ]
    for name in differ:
        print(f"differs from the stored file: {name}")
    print("stored meshes reproduced" if not differ else f"{len(differ)} file(s) differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
