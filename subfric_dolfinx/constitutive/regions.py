"""Several friction laws on one interface, each on its own points (interface regions).

:class:`RegionalLaw` is a :class:`~.protocol.FrictionLaw` made of a default law and named region
laws, with the region of every point (``0`` the default, ``i`` the ``i``-th region). Its return
map calls each law on its own points, so the laws stay as they are (a new law is still one
module) and everything generic over a law (the interface element, state arrays, outputs,
checkpoints) works unchanged. Its internal variables are the union of the laws' (a variable a
law does not declare keeps its value on that law's points, e.g. ``mu`` on Coulomb points); a
variable declared by two laws must have the same shape in both.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from .laws import law_description
from .protocol import FrictionLaw, Variable
from .result import ReturnMapResult, Status
from .state import InterfaceState

__all__ = ["DEFAULT_REGION", "RegionalLaw"]

DEFAULT_REGION = "default"
"""Name of region 0: the points outside every named region."""


class RegionalLaw:
    """A default law and region laws, each integrating its own points.

    Args:
        default: The law of the points outside every region (region 0).
        regions: Region name -> its law (regions ``1, 2, ...`` in this order).
        region: The region of every point, (N,) integers in ``[0, len(regions)]``.

    Raises:
        ValueError: A region named ``default``, region numbers out of range, or a variable
            declared with different shapes by two laws.
    """

    name: ClassVar[str] = "regions"

    def __init__(
        self,
        default: FrictionLaw,
        regions: Mapping[str, FrictionLaw],
        region: npt.ArrayLike,
    ) -> None:
        if DEFAULT_REGION in regions:
            raise ValueError(f"a region may not be named {DEFAULT_REGION!r}")
        self.names: tuple[str, ...] = (DEFAULT_REGION, *regions)
        self.laws: tuple[FrictionLaw, ...] = (default, *regions.values())
        idx = np.asarray(region)
        if idx.ndim != 1 or (idx.size and (idx.min() < 0 or idx.max() >= len(self.laws))):
            raise ValueError(f"region numbers must be a 1-D array in [0, {len(self.laws) - 1}]")
        self.region = idx.astype(np.int64)
        self.points = [np.flatnonzero(self.region == k) for k in range(len(self.laws))]
        shapes: dict[str, Variable] = {}
        for law in self.laws:
            for v in law.variables:
                if v.name in shapes and shapes[v.name].shape != v.shape:
                    raise ValueError(
                        f"the region laws declare {v.name!r} with different shapes "
                        f"({shapes[v.name].shape} and {v.shape})"
                    )
                shapes.setdefault(v.name, v)
        self.variables: tuple[Variable, ...] = tuple(shapes.values())

    @property
    def alpha_t(self) -> float:
        """The largest tangential penalty of the laws (MPa/mm)."""
        return max(float(law.alpha_t) for law in self.laws)

    @property
    def alpha_n(self) -> float:
        """The largest normal penalty of the laws (MPa/mm)."""
        return max(float(law.alpha_n) for law in self.laws)

    def parameters(self) -> dict[str, Any]:
        """``{"default": {"law", "params"}, "regions": {name: {"law", "params"}}}``."""
        return {
            "default": law_description(self.laws[0]),
            "regions": {
                n: law_description(law)
                for n, law in zip(self.names[1:], self.laws[1:], strict=True)
            },
        }

    def _check(self, n: int) -> None:
        if n != self.region.size:
            raise ValueError(f"this regional law has {self.region.size} points, got {n}")

    def initial_state(self, n_points: int, n_tangential: int) -> InterfaceState:
        """The virgin state: each law's initial values on its points."""
        self._check(n_points)
        st = InterfaceState.zeros(self.variables, n_points, n_tangential)
        for law, idx in zip(self.laws, self.points, strict=True):
            if idx.size:
                init = law.initial_state(idx.size, n_tangential)
                for name, a in init.items():
                    st[name][idx] = a
        return st

    def _sub(self, law: FrictionLaw, state: InterfaceState, idx: np.ndarray) -> InterfaceState:
        return InterfaceState(
            {v.name: state[v.name][idx] for v in law.variables}, state.n_tangential, copy=True
        )

    def return_map(
        self,
        gap: npt.ArrayLike,
        state: InterfaceState,
        dt: float,
        *,
        out: InterfaceState | None = None,
    ) -> ReturnMapResult:
        """Each law's return map on its points, put together (see the protocol)."""
        gap = np.asarray(gap, dtype=np.float64)
        n, nt = state.n_points, state.n_tangential
        self._check(n)
        if gap.shape != (n, nt + 1):
            raise ValueError(f"gap must have shape ({n}, {nt + 1}) to match the state")
        if out is state:
            raise ValueError("out must not be the input state (inputs are never mutated)")
        new = InterfaceState.zeros(self.variables, n, nt) if out is None else out
        m = nt + 1
        traction = np.zeros((n, m))
        tangent = np.zeros((n, m, m))
        status = np.full(n, Status.FAILED, dtype=np.int8)
        unstable = np.zeros(n, dtype=bool)
        iterations = np.zeros(n, dtype=np.int64)
        for law, idx in zip(self.laws, self.points, strict=True):
            if not idx.size:
                continue
            res = law.return_map(gap[idx], self._sub(law, state, idx), dt)
            traction[idx] = res.traction
            tangent[idx] = res.tangent
            status[idx] = res.status
            unstable[idx] = res.unstable
            iterations[idx] = res.iterations
            for v in self.variables:  # a variable the law does not declare keeps its value
                own = v.name in res.state
                new[v.name][idx] = res.state[v.name] if own else state[v.name][idx]
        return ReturnMapResult(traction, tangent, new, status, unstable, iterations)

    def strength(self, state: InterfaceState, f_n: npt.ArrayLike, dt: float = 0.0) -> np.ndarray:
        """Each law's strength on its points, (N,)."""
        n = state.n_points
        self._check(n)
        fn = np.broadcast_to(np.asarray(f_n, dtype=float), (n,))
        out = np.zeros(n)
        for law, idx in zip(self.laws, self.points, strict=True):
            if idx.size:
                out[idx] = law.strength(self._sub(law, state, idx), fn[idx], dt)
        return out
