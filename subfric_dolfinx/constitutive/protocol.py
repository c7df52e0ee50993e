"""The friction-law protocol: what a law declares and provides, so that everything else is generic.

A friction law integrates the traction of interface points over a step. The finite-element layer,
the state arrays, the outputs, the interface history, the checkpoints and the material-point driver
know a law only through this protocol, so **a new law is one module**: a frozen dataclass whose
fields are its parameters, deriving from :class:`LawBase`, that declares its internal variables
and implements :meth:`FrictionLaw.return_map` and :meth:`FrictionLaw.strength`. Register it with
:func:`~subfric_dolfinx.constitutive.laws.register_law` to use it by name in scenes and driver
cases (``{"law": "<name>", "params": {...}}``); a law object can also be given to the Python API
directly.

Conventions (all laws): local components ``(t1, [t2,] n)``; the gap ``ubar`` (secondary minus
primary displacement) has ``ubar_n > 0`` on approach; the traction ``(f_t, f_n)`` has ``f_n > 0`` in
compression. Units MPa, mm, s.

Example, Coulomb with linear slip weakening (a complete law)::

    @dataclasses.dataclass(frozen=True)
    class SlipWeakening(LawBase):
        alpha_t: float
        alpha_n: float
        mu_static: float
        mu_dynamic: float
        d_c: float

        name: ClassVar[str] = "slip-weakening"
        variables: ClassVar[tuple[Variable, ...]] = (
            Variable("up", TANGENTIAL, "plastic slip (mm)"),
            Variable("slip", SCALAR, "accumulated slip (mm)"),
        )

        def return_map(self, gap, state, dt, *, out=None): ...
        def strength(self, state, f_n, dt=0.0): ...
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from .result import ReturnMapResult
from .state import LOCAL, SCALAR, TANGENTIAL, InterfaceState, Variable

__all__ = [
    "LOCAL",
    "SCALAR",
    "TANGENTIAL",
    "FrictionLaw",
    "LawBase",
    "LawError",
    "Variable",
    "non_negative",
    "positive",
    "real",
    "validate_fields",
]


class LawError(ValueError):
    """Invalid law parameters (unknown, missing, wrong type, out of range), named in the message."""


@runtime_checkable
class FrictionLaw(Protocol):
    """What a friction law provides.

    Attributes:
        name: The law's name, as used in scenes and cases (``"subloading"``, ``"coulomb"``).
    """

    name: ClassVar[str]

    # read-only: properties in the protocol (a law is a frozen dataclass; its variables are
    # its class's, or, for a RegionalLaw, its laws')
    @property
    def variables(self) -> tuple[Variable, ...]:
        """The internal variables it declares, in storage order.

        A ``SCALAR`` variable has one value per point, a ``TANGENTIAL`` one a component per
        tangential direction (1 in 2-D, 2 in 3-D), a ``LOCAL`` one a vector in the local frame
        (the tangential components, then the normal one).
        """
        ...

    @property
    def alpha_t(self) -> float:
        """Tangential penalty (elastic) modulus, MPa/mm."""
        ...

    @property
    def alpha_n(self) -> float:
        """Normal penalty modulus, MPa/mm."""
        ...

    def parameters(self) -> dict[str, Any]:
        """The parameters as a plain (JSON-serialisable) dictionary."""
        ...

    def initial_state(self, n_points: int, n_tangential: int) -> InterfaceState:
        """The virgin state of ``n_points`` points."""
        ...

    def return_map(
        self,
        gap: npt.ArrayLike,
        state: InterfaceState,
        dt: float,
        *,
        out: InterfaceState | None = None,
    ) -> ReturnMapResult:
        """Integrate over one step from ``state`` (never modified) to the local ``gap`` (N, nt+1).

        Returns the traction (N, nt+1), the consistent tangent ``d traction / d gap`` (N, nt+1,
        nt+1), the end-of-step state (written into ``out`` when given), a status per point and
        the stability flags. Must never return NaN: a point that cannot be integrated gets
        status FAILED, zero traction and its last converged state.
        """
        ...

    def strength(self, state: InterfaceState, f_n: npt.ArrayLike, dt: float = 0.0) -> np.ndarray:
        """Largest tangential traction ``|f_t|`` the points can carry at normal traction ``f_n``.

        ``dt`` is the time the state has had to recover (rate-dependent laws), (N,).
        """
        ...


@dataclasses.dataclass(frozen=True)
class LawBase:
    """Common behaviour of laws written as frozen dataclasses of their parameters.

    Subclasses declare ``name`` and ``variables`` as class variables, validate their fields in
    ``__post_init__`` (with :func:`validate_fields`), and implement ``return_map`` and ``strength``;
    they may override :meth:`initial_value` (the virgin value of a variable, default 0).
    """

    name: ClassVar[str] = ""
    variables: ClassVar[tuple[Variable, ...]] = ()

    @classmethod
    def from_parameters(cls, params: Mapping[str, Any]) -> Any:
        """Build the law from a dictionary of parameters.

        Raises:
            LawError: Unknown or missing names, wrong types or values out of range (named).
        """
        if not isinstance(params, Mapping):
            raise LawError(
                f"the parameters of the {cls.name} law must be an object, got {params!r}"
            )
        fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
        unknown = sorted(set(params) - set(fields))
        if unknown:
            raise LawError(
                f"unknown parameter(s) {unknown} for the {cls.name} law; allowed: {sorted(fields)}"
            )
        missing = sorted(
            n
            for n, f in fields.items()
            if n not in params
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
        )
        if missing:
            raise LawError(f"the {cls.name} law misses parameter(s) {missing}")
        try:
            return cls(**params)
        except (TypeError, ValueError) as e:
            raise LawError(str(e)) from None

    def parameters(self) -> dict[str, Any]:
        """The parameters as a plain dictionary (JSON-serialisable)."""
        return dataclasses.asdict(self)

    def replace(self, **changes: Any) -> Any:
        """A validated copy with some parameters changed."""
        return dataclasses.replace(self, **changes)

    def initial_value(self, name: str) -> float:
        """Virgin value of the internal variable ``name`` (0 unless overridden)."""
        return 0.0

    def initial_state(self, n_points: int, n_tangential: int) -> InterfaceState:
        """The virgin state: every variable at :meth:`initial_value`."""
        st = InterfaceState.zeros(self.variables, n_points, n_tangential)
        for v in self.variables:
            value = self.initial_value(v.name)
            if value:
                st[v.name][...] = value
        return st


# -- Validation of law parameters: real, finite, in range; errors name the parameter


def real(name: str, value: Any, ok: Callable[[float], bool], allowed: str) -> float:
    """Return ``value`` as a float, or raise an error naming the parameter and its allowed range.

    Raises:
        TypeError: Not a real number (``bool`` is refused too).
        ValueError: Not finite, or ``ok(value)`` is false.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"parameter {name} must be a real number ({allowed}), got {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond the double range
        raise ValueError(
            f"parameter {name} = {value!r} is not finite; allowed: {allowed}"
        ) from None
    if not math.isfinite(v):
        raise ValueError(f"parameter {name} = {v!r} is not finite; allowed: {allowed}")
    if not ok(v):
        raise ValueError(f"parameter {name} = {v!r} is out of range; allowed: {allowed}")
    return v


def validate_fields(obj: Any, rules: Mapping[str, tuple[Callable[[float], bool], str]]) -> None:
    """Validate and convert fields of a frozen dataclass in place (``__post_init__``)."""
    for name, (ok, allowed) in rules.items():
        object.__setattr__(obj, name, real(name, getattr(obj, name), ok, allowed))


def positive(v: float) -> bool:
    """``v > 0``."""
    return v > 0.0


def non_negative(v: float) -> bool:
    """``v >= 0``."""
    return v >= 0.0
