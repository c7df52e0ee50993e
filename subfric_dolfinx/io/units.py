"""One vocabulary for every output file: interface quantities' names, units, frame, legend.

Every file that holds interface values uses the same names (the history's columns, the datasets
of ``interface_history.h5``, the arrays of the VTX/XDMF fields and of the point cloud, the
probes), and carries their units and the status legend (HDF5 attributes, XDMF ``Information``
elements, a JSON sidecar beside the VTX/XDMF fields, the W3C CSV-on-the-Web sidecar
``history.csv-metadata.json`` beside the history):

* ``f_t``: tangential traction, local frame, components ``f_t1`` [``f_t2``] (MPa);
* ``f_n``: normal traction, > 0 in compression (MPa);
* ``traction_global``: the traction on the primary body in global components (MPa);
* ``gap``: the gap the law sees, local frame: ``gap_t1`` [``gap_t2``], ``gap_n`` (``ubar_n -
  g0``, > 0 on approach) (mm); ``g0``: the initial normal gap, > 0 open (mm);
* ``status``: the return-map status, an integer (legend: :func:`status_legend`);
* ``<v>``: a law variable (its own unit), a vector by its local components (``up_t1`` ...) and,
  where fields are drawn, as ``<v>_global`` in global components.

Units MPa, mm, s; forces N (3-D, and the totals over the circumference of an axisymmetric model)
or N/mm, per unit thickness (2-D plane strain and plane stress); areas mm² (3-D, axisymmetric) or
mm (2-D). The local frame of a point is ``(e1, [e2,] n)``, ``n`` the primary body's outward
normal: :data:`FRAME`.
"""

from __future__ import annotations

import json
import re
from typing import Any

from ..constitutive import LOCAL, SCALAR, Status

__all__ = [
    "FRAME",
    "column_unit",
    "file_attributes",
    "interface_units",
    "status_legend",
]

FRAME = (
    "local components (t1[, t2], n) of each interface point: n the primary body's outward normal "
    "at the reference geometry, t1 [t2] tangential (the frames stay fixed: small sliding); "
    "'_global' names a vector in the global x, y[, z] components; f_n > 0 in compression, "
    "gap_n > 0 on approach"
)
"""The frame of the interface quantities, as written in the files."""


def status_legend() -> dict[str, str]:
    """``status`` code (as a string, JSON's keys) -> ``"NAME: meaning"``."""
    return {str(k): v for k, v in Status.legend().items()}


def _force_units(gdim: int, mode: str | None = None) -> tuple[str, str]:
    """(force, area) units: N and mm² in 3-D and axisymmetric, else N/mm and mm (per thickness)."""
    return ("N", "mm2") if gdim == 3 or mode == "axisymmetric" else ("N/mm", "mm")


def interface_units(law: Any, gdim: int) -> dict[str, str]:
    """Unit of every interface quantity of a problem, by name, vectors and components.

    Args:
        law: The friction law (its output variables and their units).
        gdim: The geometric dimension.
    """
    nt = gdim - 1
    tang = [f"t{i + 1}" for i in range(nt)]
    units = {
        "x": "mm",
        "f_t": "MPa",
        "f_n": "MPa",
        "traction_global": "MPa",
        "gap": "mm",
        "g0": "mm",
        "status": "1",
        "region": "1",
        "rank": "1",
        "time": "s",
    }
    units.update({f"f_{t}": "MPa" for t in tang})
    units.update({f"gap_{t}": "mm" for t in [*tang, "n"]})
    for var in law.variables:
        if not var.output:
            continue
        unit = var.unit or "?"
        units[var.name] = unit
        if var.shape != SCALAR:
            units[f"{var.name}_global"] = unit
            units.update({c: unit for c in var.column_names(nt)})
            if var.shape == LOCAL:
                units[f"{var.name}_n"] = unit
    return units


_HISTORY = [  # (pattern, unit or a key of the dimension-dependent units, description)
    (r"step", "1", "converged step number"),
    (r"t", "s", "time at the end of the step"),
    (r"dt", "s", "step length"),
    (r"newton", "1", "Newton iterations of the step"),
    (r"cuts", "1", "failed attempts before the step converged"),
    (r"(?:(?P<region>\w+)\.)?area", "area", "interface area (length in 2-D)"),
    (r"(?:\w+\.)?F_t\d", "force", "resultant tangential interface force, local frame"),
    (r"(?:\w+\.)?F_n", "force", "resultant normal interface force, > 0 in compression"),
    (r"f_t_norm", "MPa", "area-weighted mean of |f_t|"),
    (r"f_n", "MPa", "mean normal traction F_n / area"),
    (r"(?:\w+\.)?plastic", "1", "fraction of points with status PLASTIC or JUMP"),
    (r"(?:\w+\.)?separated", "1", "fraction of points SEPARATED (open)"),
    (r"unstable", "1", "fraction of points where the law has no stable quasi-static solution"),
    (r"R_\w+_[xyz]", "force", "reaction force of a Dirichlet group, global component"),
    (r"R_\w+_(?:t\d?|n)", "force", "reaction of a group in its local frame (reaction_frames)"),
    (r"S_\w+_[xyz]", "force", "force of a group's springs on the body, global component"),
    (r"E_kinetic", "energy", "kinetic energy v M v / 2 (a dynamic problem)"),
    (r"E_strain", "energy", "strain energy of the bodies and elastic energy of the interfaces"),
    (r"W_external", "energy", "work of the loads and supports since the start"),
    (r"D_friction", "energy", "work of the interfaces' plastic slip since the start"),
    (r"D_damping", "energy", "work of the Rayleigh damping since the start"),
    (r"D_numerical", "energy", "the time integrator's numerical dissipation since the start"),
    (r"E_balance", "energy", "W_external - energy change - dissipations: Newton's residual"),
    (r"[\w.]+\.u_[xyz]", "mm", "probe: displacement"),
    (r"[\w.]+\.sigma_\w\w", "MPa", "probe: Cauchy stress component"),
    (r"[\w.]+\.von_mises", "MPa", "probe: von Mises stress"),
]


def column_unit(name: str, law: Any, gdim: int, mode: str | None = None) -> tuple[str, str]:
    """Unit and description of a history column (``"?"`` and ``""`` if unknown).

    Law variables appear as area-weighted means (``mu``, ``up_t1``; ``up_norm`` the mean
    magnitude) and probes as ``<point>.<quantity>`` with the interface names above. ``mode``
    (the problem's, e.g. ``"axisymmetric"``) decides the force and area units in 2-D.
    """
    force, area = _force_units(gdim, mode)
    energy = "mJ" if force == "N" else "mJ/mm"  # N mm (per unit thickness in plane modes)
    for pattern, unit, what in _HISTORY:
        if re.fullmatch(pattern, name):
            return {"force": force, "area": area, "energy": energy}.get(unit, unit), what
    iface = interface_units(law, gdim)
    point, _, quantity = name.rpartition(".")
    if point and quantity in iface:
        return iface[quantity], f"probe at point {point}: {quantity} at the nearest interface point"
    base = name[: -len("_norm")] if name.endswith("_norm") else name
    if base in iface:
        kind = "mean magnitude" if name.endswith("_norm") else "area-weighted mean"
        return iface[base], f"{kind} of the law variable {base} over the interface"
    return "?", ""


def file_attributes(law: Any, gdim: int) -> dict[str, str]:
    """The attributes every interface output file carries: ``units``, ``frame``, legend.

    ``units`` (name -> unit) and ``status_legend`` (code -> meaning) are JSON strings.
    """
    return {
        "units": json.dumps(interface_units(law, gdim)),
        "frame": FRAME,
        "status_legend": json.dumps(status_legend()),
    }
