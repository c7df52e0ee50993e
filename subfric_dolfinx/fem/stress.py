"""Cauchy stress and von Mises stress in the bodies, as discontinuous fields.

The stress of a degree-``p`` displacement is a polynomial of degree ``p - 1`` in each simplex, so
it is *interpolated* (a DOLFINx :class:`~dolfinx.fem.Expression` evaluated at the interpolation
points of a discontinuous Lagrange space of degree ``p - 1``), not projected: degree 1 gives one
value per cell (DG0), exact on triangles and tetrahedra (on quadrilaterals and hexahedra the
value at the cell's centre); degree 2 gives DG1, exact on simplices. The stress is the full 3 x 3
tensor: in 2-D (plane strain) ``sigma_zz = lambda tr(eps)`` is not zero and enters von Mises,
``sqrt(3/2 s:s)`` with ``s`` the deviator of the 3 x 3 tensor. The stress is the bulk model's
(``stress(u, ctx)`` of :mod:`.bulk`: the built-in linear elasticity in every mode, piecewise by
cell group), or that of given materials.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import dolfinx
import dolfinx.fem
import numpy as np
import ufl

from ..compat import interpolation_points
from .conditions import Material

__all__ = ["STRESS_COMPONENTS", "StressField"]

STRESS_COMPONENTS = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz")
"""Names of the 9 components of the stress tensor, row by row (as stored in the DG function)."""


class StressField:
    """The Cauchy stress ``sigma`` (3 x 3, MPa) and von Mises stress of a problem's displacement.

    Args:
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem` (its displacement ``u``).
        materials: Body name -> :class:`Material`; ``None``: the stress of the problem's bulk
            model (its ``stress(u, ctx)``, e.g. the built-in linear elasticity in any mode).

    Attributes:
        sigma: DG function of the stress tensor (value shape (3, 3)), named ``sigma``.
        von_mises: DG function of the von Mises stress, named ``von_mises``.
        degree: Degree of the DG space (the displacement's minus one).
    """

    def __init__(self, problem: Any, materials: Mapping[str, Material] | None = None) -> None:
        mesh = problem.mesh
        gdim = mesh.geometry.dim
        degree = problem.V.ufl_element().embedded_superdegree - 1
        self.degree = degree
        bulk = getattr(problem, "bulk", None)
        if materials is None and bulk is not None:
            stress = getattr(bulk, "stress", None)
            if stress is None:
                raise ValueError(
                    f"the bulk model {type(bulk).__name__} gives no stress (a method "
                    "stress(u, ctx)): no stress output"
                )
            sig = stress(problem.u, problem.bulk_context)
        else:
            D0 = dolfinx.fem.functionspace(mesh, ("DG", 0))
            lam, mu = dolfinx.fem.Function(D0), dolfinx.fem.Function(D0)
            for body, mat in (materials or {}).items():
                if body not in problem.tags:
                    continue
                cells = problem.domain.cell_tags.find(problem.tags[body])
                lam.x.array[cells] = mat.E * mat.nu / ((1 + mat.nu) * (1 - 2 * mat.nu))
                mu.x.array[cells] = mat.E / (2 * (1 + mat.nu))
            e = ufl.sym(ufl.grad(problem.u))
            eps = ufl.as_matrix(
                [[e[i, j] if i < gdim and j < gdim else 0 for j in range(3)] for i in range(3)]
            )
            sig = 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(3)
        s = ufl.dev(sig)
        vm = ufl.sqrt(1.5 * ufl.inner(s, s))
        Vs = dolfinx.fem.functionspace(mesh, ("DG", degree, (3, 3)))
        Vv = dolfinx.fem.functionspace(mesh, ("DG", degree))
        self.sigma = dolfinx.fem.Function(Vs, name="sigma")
        self.von_mises = dolfinx.fem.Function(Vv, name="von_mises")
        self._exprs = (
            dolfinx.fem.Expression(sig, interpolation_points(Vs)),
            dolfinx.fem.Expression(vm, interpolation_points(Vv)),
        )

    def update(self) -> None:
        """Interpolate the stress of the current displacement (after a converged step)."""
        self.sigma.interpolate(self._exprs[0])
        self.von_mises.interpolate(self._exprs[1])

    @staticmethod
    def von_mises_of(sigma: np.ndarray) -> np.ndarray:
        """Von Mises stress of stress tensors (..., 3, 3) (a reference for tests)."""
        s = sigma - np.trace(sigma, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) / 3.0
        return np.sqrt(1.5 * np.einsum("...ij,...ij->...", s, s))
