"""The builders check the size of a mesh against the machine before gmsh allocates anything.

``demos/block_on_base.py --n 100000000`` once took all of a 24 GB host in a minute. A builder
estimates the number of cells from the volume of its bodies and the element size (with grading:
the integral of the cell density over the bodies), and the memory to mesh them and hold the
mesh at :data:`BYTES_PER_CELL`; beyond the machine's memory it refuses, naming the option. The
estimate covers the mesh only (gmsh and the DOLFINx mesh): the problem and its factorisation
need several times more, so a mesh accepted here may still not fit a run; a refused one never
could.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

__all__ = ["BYTES_PER_CELL", "CELLS_PER_VOLUME", "check_mesh_size", "estimate_cells"]

BYTES_PER_CELL = 2048
"""Memory to mesh a cell and hold it: above the peak resident memory per cell of gmsh's meshing
and the DOLFINx mesh for every cell type (``docs/design.md``, *Mesh size limits*)."""

CELLS_PER_VOLUME = {"triangle": 2.31, "quadrilateral": 1.0, "tetrahedron": 7.0, "hexahedron": 1.0}
"""Cells per ``h^d`` of volume: equilateral triangles, a structured grid, regular tetrahedra
(an upper bound for gmsh's unstructured ones), a structured grid."""


def machine_memory() -> int:
    """Physical memory of the machine, bytes (0 where it cannot be read)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - Linux has both
        return 0


def estimate_cells(
    boxes: Sequence[tuple[Sequence[float], Sequence[float]]],
    h: float,
    cell_type: str,
    grading: tuple[float, float, Sequence[float], float] | None = None,
) -> float:
    """Estimated number of cells of the boxes meshed at size ``h`` (or graded).

    Args:
        boxes: ``(lower corner, upper corner)`` of each body.
        h: Element size.
        cell_type: DOLFINx cell type.
        grading: ``(far_size, growth, center, radius)``: the size is ``min(far_size, h + growth
            max(0, |x - center| - radius))`` (:func:`~.builders.graded_mesh`), integrated over
            each box on a grid of 32 points per side.
    """
    d = len(boxes[0][0])
    density = CELLS_PER_VOLUME[cell_type]
    total = 0.0
    for lo, hi in boxes:
        lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
        volume = float(np.prod(hi_ - lo_))
        if grading is None:
            total += density * volume / h**d
            continue
        far, growth, center, radius = grading
        k = 32
        axes = [lo_[i] + (np.arange(k) + 0.5) * (hi_[i] - lo_[i]) / k for i in range(d)]
        x = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
        r = np.linalg.norm(x - np.asarray(center, float)[:d], axis=1)
        size = np.minimum(far, h + growth * np.maximum(0.0, r - radius))
        total += density * volume * float(np.mean(size ** (-d)))
    return total


def check_mesh_size(cells: float, option: str, value: object) -> None:
    """Refuse a mesh of about ``cells`` cells whose memory exceeds the machine's.

    Args:
        cells: From :func:`estimate_cells`.
        option: The option that sets the size, as the caller names it (``"n_interface"``).
        value: Its value.

    Raises:
        ValueError: Naming the option, the estimate and the machine's memory.
    """
    hint = " (the demos' --n)" if option == "n_interface" else ""
    need = cells * BYTES_PER_CELL
    have = machine_memory()
    if have and not need <= have:  # also catches a NaN or infinite estimate
        raise ValueError(
            f"{option} = {value!r}{hint} asks for about {cells:.3g} cells, about "
            f"{need / 2**30:.3g} GiB to mesh them ({BYTES_PER_CELL} bytes per cell), more than "
            f"this machine's {have / 2**30:.3g} GiB of memory: use fewer elements"
        )
    if not math.isfinite(cells):  # pragma: no cover - no memory figure and no finite estimate
        raise ValueError(f"{option} = {value!r} asks for an unbounded number of cells")
