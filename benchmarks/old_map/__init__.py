"""The subloading return map as it was before issue 14 (main at 961eee5), for comparisons.

:class:`OldSubloadingLaw` is a :class:`~subfric_dolfinx.constitutive.SubloadingLaw` whose
return map is the previous one (radial return from the step start, safeguarded Newton in ``dl``,
no split, no rotation) and whose state has no start traction; the material-point driver runs it
like any law. Used by ``benchmarks/driver_steps.py``, ``benchmarks/return_map_throughput.py``
and ``report/mp_study.py`` (old and new map side by side).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from subfric_dolfinx.constitutive import SCALAR, TANGENTIAL, SubloadingLaw, Variable

from .subloading_v1 import subloading_return_map

__all__ = ["OldSubloadingLaw", "old"]


@dataclasses.dataclass(frozen=True)
class OldSubloadingLaw(SubloadingLaw):
    """The same parameters, the previous return map."""

    variables: ClassVar[tuple[Variable, ...]] = (
        Variable("up", TANGENTIAL, "plastic slip (mm)"),
        Variable("mu", SCALAR, "hardening function (MPa)"),
        Variable("r", SCALAR, "normal-yield ratio F / mu"),
    )

    def return_map(self, gap, state, dt, *, out=None, tol=1e-13, max_iter=100, **_):  # noqa: D102
        return subloading_return_map(self, gap, state, dt, out=out, tol=tol, max_iter=max_iter)


def old(law: SubloadingLaw) -> OldSubloadingLaw:
    """The previous map with the parameters of ``law``."""
    return OldSubloadingLaw(**law.parameters())
