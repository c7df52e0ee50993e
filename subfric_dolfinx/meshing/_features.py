"""Options of the builders beyond two uniform boxes: interface regions and graded meshes.

* Interface regions: strips ``x0 <= x <= x1`` of the interface, each a physical group of
  interface facets (a subgroup of ``interface``), e.g. two surface finishes with their own
  friction laws. The master is cut at the strips' ends so that each strip is its own curve
  (surface); the groups carry the tags ``REGION_TAG0 + i``.
* Grading (triangles and tetrahedra): the element size is ``h`` within ``refine_radius`` of a
  point (by default the centre of the interface) and grows by ``growth`` per unit distance
  beyond, up to ``far_size``, e.g. a contact zone resolved finely inside large bodies.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

from .groups import TAGS

__all__ = ["REGION_TAG0", "add_region_groups", "check_grading", "check_regions", "graded_mesh"]

REGION_TAG0 = 100
"""Tag of the first interface region group (then 101, ...)."""


def check_regions(
    regions: Mapping[str, Sequence[float]] | None, lo: float, hi: float
) -> list[tuple[str, float, float]]:
    """Validate interface strips ``name -> (x0, x1)`` inside the interface ``[lo, hi]``.

    Returns:
        ``(name, x0, x1)`` sorted by ``x0``.

    Raises:
        ValueError: Not a mapping, a bad name (empty, a name of the builders' groups), an
            interval that is not two finite increasing numbers inside ``[lo, hi]``, overlaps.
    """
    if not regions:
        return []
    if not isinstance(regions, Mapping):
        raise ValueError(f"interface_regions must map names to [x0, x1], got {regions!r}")
    out = []
    for name, iv in regions.items():
        if not isinstance(name, str) or not name.isidentifier() or name in TAGS:
            raise ValueError(
                f"interface region name {name!r} must be an identifier other than the builders' "
                f"group names {sorted(TAGS)}"
            )
        try:
            x0, x1 = (float(v) for v in iv)
        except (TypeError, ValueError):
            raise ValueError(f"interface region {name!r}: expected [x0, x1], got {iv!r}") from None
        tol = 1e-9 * max(1.0, abs(lo), abs(hi))
        if not (math.isfinite(x0) and math.isfinite(x1) and lo - tol <= x0 < x1 <= hi + tol):
            raise ValueError(
                f"interface region {name!r}: [{x0:g}, {x1:g}] must be an increasing interval "
                f"inside the interface [{lo:g}, {hi:g}]"
            )
        out.append((name, max(x0, lo), min(x1, hi)))
    out.sort(key=lambda r: r[1])
    for (a, _, a1), (b, b0, _) in itertools.pairwise(out):
        if b0 < a1:
            raise ValueError(f"interface regions {a!r} and {b!r} overlap")
    return out


def add_region_groups(
    gmsh: Any, gdim: int, entities: Sequence[int], regions: list[tuple[str, float, float]]
) -> dict[str, int]:
    """Physical groups of the interface entities inside each strip; name -> tag.

    Raises:
        RuntimeError: A strip holds no interface entity.
    """
    tags = {}
    tol = 1e-7
    for i, (name, x0, x1) in enumerate(regions):
        scale = max(1.0, abs(x0), abs(x1))
        inside = []
        for e in entities:
            b = gmsh.model.getBoundingBox(gdim - 1, e)
            if b[0] >= x0 - tol * scale and b[3] <= x1 + tol * scale:
                inside.append(e)
        if not inside:
            raise RuntimeError(f"interface region {name!r} holds no interface entity")
        tags[name] = gmsh.model.addPhysicalGroup(gdim - 1, inside, REGION_TAG0 + i, name=name)
    return tags


def check_grading(
    cell_type: str,
    far_size: float | None,
    growth: float,
    center: Sequence[float] | None,
    h: float,
    radius: float = 0.0,
) -> None:
    """Validate the grading options (``far_size`` None: no grading).

    Raises:
        ValueError: Grading asked for structured cells, or values out of range.
    """
    if far_size is None:
        return
    if cell_type in ("quadrilateral", "hexahedron"):
        raise ValueError(f"far_size (a graded mesh) needs triangles or tetrahedra, not {cell_type}")
    for name, v in (("far_size", far_size), ("growth", growth)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")
    if not (isinstance(radius, int | float) and math.isfinite(radius) and radius >= 0):
        raise ValueError(f"refine_radius must be a finite number >= 0, got {radius!r}")
    if far_size < h:
        raise ValueError(f"far_size = {far_size!r} must be at least the interface size h = {h:g}")
    if center is not None and not all(
        isinstance(v, int | float) and math.isfinite(v) for v in center
    ):
        raise ValueError(f"refine_center must be finite coordinates, got {center!r}")


def graded_mesh(
    gmsh: Any,
    gdim: int,
    h: float,
    far_size: float,
    growth: float,
    center: Sequence[float],
    radius: float = 0.0,
) -> None:
    """Generate the mesh with sizes ``min(far_size, h + growth * max(0, |x - center| - radius))``.

    The size field and the options it needs are removed again afterwards.
    """
    c = [float(v) for v in center] + [0.0] * (3 - len(center))
    f = gmsh.model.mesh.field
    fid = f.add("MathEval")
    dist = f"Sqrt((x-({c[0]!r}))^2+(y-({c[1]!r}))^2+(z-({c[2]!r}))^2)"
    grow = f"Max(0, {dist} - {float(radius)!r})"
    f.setString(fid, "F", f"Min({far_size!r}, {h!r} + {growth!r}*{grow})")
    f.setAsBackgroundMesh(fid)
    opts = {
        "Mesh.MeshSizeMax": far_size,
        "Mesh.MeshSizeMin": 0.0,
        "Mesh.MeshSizeExtendFromBoundary": 0,
        "Mesh.MeshSizeFromPoints": 0,
        "Mesh.MeshSizeFromCurvature": 0,
        "Mesh.ElementOrder": 1,
    }
    saved = {o: gmsh.option.getNumber(o) for o in opts}
    try:
        for o, v in opts.items():
            gmsh.option.setNumber(o, v)
        gmsh.model.mesh.generate(gdim)
    finally:
        for o, v in saved.items():
            gmsh.option.setNumber(o, v)
        f.remove(fid)
