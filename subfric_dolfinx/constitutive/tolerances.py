"""Round-off tolerances of the return maps: when a point touches, and when a trial loads.

Both laws (:mod:`.subloading`, :mod:`.coulomb`) use them, so that a status never depends on the
rounding of the gap a caller computed (in a finite-element model
``ubar = u_secondary - u_primary`` carries a rounding of about ``eps |u|``, different on 1 and 2
MPI ranks).

**Contact band** (``CONTACT_TOL``, the ``contact_tol`` argument of the maps). A point *touches*
when ``|ubar_n| <= contact_tol * L`` with the length

    ``L = max(|ubar_t|, |up_n|, L_law)``

(Euclidean norms: the band is invariant under rotations of the tangential plane; the gap's own
size, so that the band covers the rounding of the gap; ``L_law`` is
``1 / (c_n alpha_n)`` for the subloading law, the normal gap at which the saturation ``g(f_n)``
reaches ``1 - 1/e``, so that a touching point carries a strength below ``contact_tol g mu`` of
any loaded one; 0 for Coulomb, which has no length). A touching point behaves exactly as
``ubar_n = 0`` did before: status ``SEPARATED``, zero traction, ``r = 0``, plastic slip frozen,
``mu`` recovering, and the one-sided elastic tangent of the contact side (a touching interface
is stiff). Default ``1e-12``: a displacement rounding of ``2 eps |u|`` stays inside the band for
``|u|`` up to about 2000 times ``L``, while the normal traction ignored,
``alpha_n contact_tol L``, is ``1e-12 / c_n`` MPa at most for the subloading law (5e-9 MPa for the
paper's sets), far below anything a model resolves.

**Loading test** (``LOAD_TOL``, equal to the default consistency tolerance ``tol`` of the
subloading map). A step is plastic only when the trial leaves the loading surface by more than
the rounding of the surface itself: ``|f_t*| - g r mu > LOAD_TOL g mu`` (subloading, ``mu`` after
the recovery of the step; after a reversal split, the surface at the split point) and
``|f_t*| - mu_c f_n > LOAD_TOL mu_c f_n`` (Coulomb). A trial within that margin is elastic (its
``r = F / mu`` is clipped to 1), so that pressing with ``ubar_t = 0`` to round-off (``|f_t*|`` of
1e-22 MPa from ``r = 0``, where any nonzero trial would load) reports ``ELASTIC``, not
``PLASTIC``, and identically on any number of ranks.

Both are module constants; the maps take them as keyword arguments (``contact_tol=``;
``tol=`` for the subloading loading test) for callers that need other values.

**Norms** of tangential vectors (the band's ``|ubar_t|`` and ``|up|``, Coulomb's trial
``|f_t*|``): :func:`tangential_norm`, safe from overflow and underflow over the whole double
range.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CONTACT_TOL", "LOAD_TOL", "contact_band", "tangential_norm"]

CONTACT_TOL = 1e-12
"""Relative width of the contact band (see the module docstring)."""

LOAD_TOL = 1e-13
"""Relative margin of the loading test (see the module docstring)."""


def contact_band(gap: np.ndarray, up: np.ndarray, length: float, contact_tol: float) -> np.ndarray:
    """Half-width of the contact band per point: ``contact_tol * max(|ubar_t|, |up|, length)``.

    Args:
        gap: Local gaps (N, nt + 1), finite.
        up: Plastic slips (N, nt), finite.
        length: The law's own length ``L_law`` (mm, >= 0; may be inf: then every point in the
            band touches).
        contact_tol: Relative width (>= 0).
    """
    nt = up.shape[1]
    scale = np.maximum(tangential_norm(gap[:, :nt]), tangential_norm(up))
    return contact_tol * np.maximum(scale, length)


def tangential_norm(v: np.ndarray) -> np.ndarray:
    """Row norms of ``v`` (N, 1) or (N, 2) without squaring.

    ``sqrt(x**2 + y**2)`` overflows above about 1.3e154 and loses everything below about 1.5e-154;
    ``hypot`` scales internally and is exact to an ulp over the whole double range.
    """
    if v.shape[1] == 1:
        return np.abs(v[:, 0])
    return np.hypot(v[:, 0], v[:, 1])
