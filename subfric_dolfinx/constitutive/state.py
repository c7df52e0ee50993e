"""Internal-variable arrays of interface points, with commit and revert.

A law declares its internal variables (:class:`Variable`: a name and a shape, ``SCALAR``,
``TANGENTIAL`` or ``LOCAL``). An :class:`InterfaceState` holds, for ``N`` points with ``nt``
tangential components (1 in 2-D, 2 in 3-D), one array per variable: (N,) for a scalar, (N, nt)
for a tangential one, (N, nt + 1) for a local vector (tangential components, then the normal);
e.g. the subloading law's plastic slip ``up`` (N, nt), hardening function ``mu`` (N,) and
normal-yield ratio ``r`` (N,). Arrays are read as ``state["mu"]`` or ``state.mu``. A
state can wrap existing arrays without copying (e.g. the arrays of DOLFINx Quadrature functions),
so that in-place updates are seen by their owner.

A :class:`StatePair` keeps the last converged state (``old``) and the trial state of the current
step (``new``): ``commit()`` copies new into old after a converged step, ``revert()`` copies old
into new after a failed one (the pattern of MGIS's material data manager).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["LOCAL", "SCALAR", "TANGENTIAL", "InterfaceState", "StatePair", "Variable"]

SCALAR = "scalar"
TANGENTIAL = "tangential"
LOCAL = "local"


@dataclasses.dataclass(frozen=True)
class Variable:
    """An internal variable a law declares.

    Attributes:
        name: Its name (a Python identifier; used for arrays, fields, datasets, columns).
        shape: ``SCALAR`` (one value per point), ``TANGENTIAL`` (one per tangential direction,
            in the local frame) or ``LOCAL`` (a vector in the local frame: the tangential
            components, then the normal one, like a traction).
        description: What it is, with its unit.
        unit: Its unit (``"mm"``, ``"MPa"``, ``"1"`` for a pure number), written with it in
            every output file; ``""`` when the law does not say.
        output: Whether the outputs (history, fields, point cloud, interface history, probes)
            write it; ``False`` for a variable that repeats another output (the subloading
            law's end-of-step traction ``f`` is the traction ``f_t``, ``f_n`` itself).
            Checkpoints always hold it.
    """

    name: str
    shape: str = SCALAR
    description: str = ""
    unit: str = ""
    output: bool = True

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"variable name {self.name!r} is not an identifier")
        if self.shape not in (SCALAR, TANGENTIAL, LOCAL):
            raise ValueError(
                f"variable shape must be {SCALAR!r}, {TANGENTIAL!r} or {LOCAL!r}, "
                f"got {self.shape!r}"
            )

    def components(self, n_tangential: int) -> int:
        """Number of values per point: 1, ``n_tangential`` or ``n_tangential + 1``."""
        return {SCALAR: 1, TANGENTIAL: n_tangential, LOCAL: n_tangential + 1}[self.shape]

    def array_shape(self, n_points: int, n_tangential: int) -> tuple[int, ...]:
        """Shape of the variable's array over ``n_points`` points."""
        if self.shape == SCALAR:
            return (n_points,)
        return (n_points, self.components(n_tangential))

    def column_names(self, n_tangential: int = 2) -> list[str]:
        """Names of its components in tables: ``v``; ``v_t1`` [``v_t2``]; then ``v_n`` if local."""
        if self.shape == SCALAR:
            return [self.name]
        names = [f"{self.name}_t{i + 1}" for i in range(n_tangential)]
        return [*names, f"{self.name}_n"] if self.shape == LOCAL else names


class InterfaceState:
    """Internal variables of ``N`` interface points, one array per variable.

    Args:
        arrays: Variable name -> array, (N,) for scalars and (N, nt) for tangential variables.
        n_tangential: ``nt``, 1 (2-D) or 2 (3-D).
        copy: Copy the arrays (default) or wrap them (they must then be float64 and writable).

    Raises:
        ValueError: Shapes that do not agree, or nt not 1 or 2.
    """

    __slots__ = ("_arrays", "n_points", "n_tangential")

    def __init__(
        self,
        arrays: Mapping[str, npt.ArrayLike],
        n_tangential: int,
        *,
        copy: bool = True,
    ) -> None:
        if n_tangential not in (1, 2):
            raise ValueError(f"n_tangential must be 1 or 2, got {n_tangential!r}")
        conv = (lambda a: np.array(a, dtype=np.float64)) if copy else np.asarray
        out: dict[str, np.ndarray] = {}
        n = None
        for name, a in arrays.items():
            arr = conv(a)
            wide = arr.ndim == 2 and arr.shape[1] not in (n_tangential, n_tangential + 1)
            if wide or arr.ndim not in (1, 2):
                raise ValueError(
                    f"{name} must have shape (N,), (N, {n_tangential}) or (N, {n_tangential + 1}), "
                    f"got {arr.shape}"
                )
            if n is None:
                n = arr.shape[0]
            elif arr.shape[0] != n:
                raise ValueError(f"{name} has {arr.shape[0]} points, the other variables {n}")
            if not copy and (arr.dtype != np.float64 or not arr.flags.writeable):
                raise ValueError(f"{name} must be a writable float64 array to be wrapped")
            out[name] = arr
        self._arrays = out
        self.n_points = 0 if n is None else int(n)
        self.n_tangential = int(n_tangential)

    @classmethod
    def from_arrays(cls, **arrays: npt.ArrayLike) -> InterfaceState:
        """A copied state from keyword arrays, ``nt`` from the first 2-D one (1 when none).

        The first 2-D array must be a tangential one (N, nt).

        Example: ``InterfaceState.from_arrays(up=np.zeros((n, 2)), mu=mu, r=r)``.
        """
        two_d = [np.shape(a)[1] for a in arrays.values() if np.ndim(a) == 2]
        return cls(arrays, two_d[0] if two_d else 1)

    @classmethod
    def zeros(
        cls, variables: Iterable[Variable], n_points: int, n_tangential: int
    ) -> InterfaceState:
        """A state of zeros for the declared ``variables``."""
        if n_points < 0:
            raise ValueError(f"n_points must be >= 0, got {n_points!r}")
        arrays = {v.name: np.zeros(v.array_shape(n_points, n_tangential)) for v in variables}
        return cls(arrays, n_tangential, copy=False)

    @classmethod
    def wrap(
        cls, arrays: dict[str, np.ndarray], n_points: int, n_tangential: int
    ) -> InterfaceState:
        """Wrap float64 arrays of the right shapes without any check (a return map's outputs)."""
        st = object.__new__(cls)
        st._arrays = arrays
        st.n_points = n_points
        st.n_tangential = n_tangential
        return st

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._arrays[name]
        except KeyError:
            raise KeyError(f"no internal variable {name!r}; this state has {self.names}") from None

    def __getattr__(self, name: str) -> np.ndarray:
        try:
            return self._arrays[name]
        except (KeyError, AttributeError):
            raise AttributeError(f"no internal variable {name!r}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._arrays

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def items(self) -> Iterator[tuple[str, np.ndarray]]:
        """``(name, array)`` pairs in storage order."""
        return iter(self._arrays.items())

    @property
    def names(self) -> tuple[str, ...]:
        """Variable names in storage order."""
        return tuple(self._arrays)

    def copy(self) -> InterfaceState:
        """Return a deep copy."""
        return InterfaceState(self._arrays, self.n_tangential, copy=True)

    def assign(self, other: InterfaceState) -> None:
        """Copy the values of ``other`` into this state's arrays, in place."""
        if other.names != self.names or other.n_points != self.n_points:
            raise ValueError(
                f"cannot assign a state of {other.n_points} points with {other.names} to one of "
                f"{self.n_points} points with {self.names}"
            )
        for name, a in self._arrays.items():
            np.copyto(a, other[name])

    def take(
        self, index: npt.NDArray[np.integer[Any]] | npt.NDArray[np.bool_] | Sequence[int] | slice
    ) -> InterfaceState:
        """Return a copy of the state at some points."""
        return InterfaceState(
            {k: a[index] for k, a in self._arrays.items()}, self.n_tangential, copy=True
        )

    def __repr__(self) -> str:
        return (
            f"InterfaceState(n_points={self.n_points}, n_tangential={self.n_tangential}, "
            f"variables={self.names})"
        )


class StatePair:
    """The last converged state and the trial state of the current step.

    Args:
        old: Last converged (committed) state; the pair owns it from now on.
        new: Trial state; a copy of ``old`` when omitted.
    """

    __slots__ = ("new", "old")

    def __init__(self, old: InterfaceState, new: InterfaceState | None = None) -> None:
        self.old = old
        self.new = old.copy() if new is None else new
        if self.new.names != self.old.names or self.new.n_points != self.old.n_points:
            raise ValueError("old and new states must hold the same variables and points")

    def commit(self) -> None:
        """Accept the trial state: copy ``new`` into ``old``."""
        self.old.assign(self.new)

    def revert(self) -> None:
        """Reject the trial state: copy ``old`` into ``new``."""
        self.new.assign(self.old)
