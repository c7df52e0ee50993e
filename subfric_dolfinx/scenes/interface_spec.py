"""The scene's interface options beyond the law: the initial gap and interface regions.

``"initial_gap"`` (mm, > 0 where the interface starts open; the law sees ``ubar_n - g0``):

* a number: a uniform gap;
* ``{"expression": "(x - 1)**2 / (2*R)", "parameters": {"R": 50}}``: a function of the
  coordinates ``x``, ``y`` (, ``z``), parsed safely (:mod:`.expressions`: numbers, names,
  ``+ - * / **`` and a few functions; nothing is executed);
* ``{"parabola": {"R": 50, "center": [1, 0.5]}}``: ``d**2 / (2 R)`` with ``d`` the distance to
  ``center`` (the point of first touch), a cylinder (2-D) or sphere (3-D) of radius ``R`` near its
  apex, as in Hertz's theory;
* ``{"circle": {"R": 50, "center": [1, 0.5]}}``: the exact ``R - sqrt(R**2 - d**2)``;
* in a scene given from Python (code, trusted like the callables of conditions), a function of
  the coordinates ``x`` (gdim, n) returning (n,) values.

``"regions"``: ``{"<group>": {"law": ..., "params": {...}}}``: a named group of interface facets
(a physical group of the mesh lying on the interface) with its own law; ``"law"`` holds on the
rest of the interface.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..constitutive import DEFAULT_REGION, FrictionLaw, LawError, build_law
from ..driver.text import short_repr
from .expressions import COORDINATES, ExpressionError, compile_expression, finite_float
from .schema import SceneError

__all__ = ["SHAPES", "gap_function", "parse_initial_gap", "parse_regions"]

SHAPES = ("parabola", "circle")


def _shape(kind: str, spec: Any, path: str) -> tuple[float, list[float]]:
    if not isinstance(spec, dict) or set(spec) != {"R", "center"}:
        got = sorted(spec) if isinstance(spec, dict) else repr(spec)
        raise SceneError(f"{path}.{kind}: expected the keys ['R', 'center'], got {got}")
    R, c = spec["R"], spec["center"]
    Rf = None if isinstance(R, bool) or not isinstance(R, int | float) else finite_float(R)
    if Rf is None or not Rf > 0:
        raise SceneError(f"{path}.{kind}.R: must be a positive finite number, got {short_repr(R)}")
    ok = isinstance(c, list) and len(c) in (2, 3)
    ok = ok and all(
        isinstance(v, int | float) and not isinstance(v, bool) and finite_float(v) is not None
        for v in c
    )
    if not ok:
        raise SceneError(
            f"{path}.{kind}.center: must be 2 or 3 finite coordinates, got {short_repr(c)}"
        )
    return float(R), [float(v) for v in c]


def parse_initial_gap(value: Any, path: str = "scene.initial_gap") -> None:
    """Validate an initial-gap spec (see the module docstring).

    Raises:
        SceneError: Naming the offending key.
    """
    if value is None or callable(value):
        return
    if isinstance(value, int | float) and not isinstance(value, bool):
        if finite_float(value) is None:
            raise SceneError(f"{path}: expected a finite number, got {short_repr(value)}")
        return
    if not isinstance(value, dict) or len(value) == 0:
        raise SceneError(
            f"{path}: expected a number or an object with 'expression', 'parabola' or 'circle', "
            f"got {value!r}"
        )
    if "expression" in value:
        unknown = sorted(set(value) - {"expression", "parameters"})
        if unknown:
            raise SceneError(f"{path}: unknown key(s) {unknown} beside 'expression'")
        params = value.get("parameters", {})
        if not isinstance(params, dict):
            raise SceneError(f"{path}.parameters: expected an object, got {params!r}")
        try:
            compile_expression(value["expression"], params)
        except ExpressionError as e:
            raise SceneError(f"{path}.expression: {e}") from None
        return
    if len(value) != 1 or next(iter(value)) not in SHAPES:
        raise SceneError(
            f"{path}: expected one of 'expression', {', '.join(map(repr, SHAPES))}, "
            f"got {sorted(value)}"
        )
    kind = next(iter(value))
    _shape(kind, value[kind], path)


def gap_function(
    value: Any, gdim: int, path: str = "scene.initial_gap"
) -> float | Callable[[np.ndarray], np.ndarray] | None:
    """The initial gap of a validated spec for a ``gdim``-D mesh.

    Returns:
        ``None``, a number or a function of the coordinates (gdim, n).

    Raises:
        SceneError: ``z`` in a 2-D scene, a centre with the wrong number of coordinates.
    """
    if value is None or callable(value):
        return value
    if isinstance(value, int | float):
        return float(value)
    if "expression" in value:
        try:
            return compile_expression(
                value["expression"], value.get("parameters", {}), COORDINATES[:gdim]
            )
        except ExpressionError as e:
            raise SceneError(f"{path}.expression: {e} (a {gdim}-D mesh)") from None
    kind = next(iter(value))
    R, c = _shape(kind, value[kind], path)
    if len(c) != gdim:
        raise SceneError(f"{path}.{kind}.center: {len(c)} coordinates for a {gdim}-D mesh")
    centre = np.asarray(c)[:, None]

    def parabola(x: np.ndarray) -> np.ndarray:
        d2 = ((np.asarray(x)[:gdim] - centre) ** 2).sum(axis=0)
        return d2 / (2.0 * R)

    def circle(x: np.ndarray) -> np.ndarray:
        d2 = ((np.asarray(x)[:gdim] - centre) ** 2).sum(axis=0)
        if np.any(d2 > R * R):
            i = int(np.argmax(d2))
            where = ", ".join(f"{v:.6g}" for v in np.asarray(x)[:gdim, i])
            raise ValueError(f"the point ({where}) is farther than R = {R:g} from the centre")
        return R - np.sqrt(R * R - d2)

    return parabola if kind == "parabola" else circle


def parse_regions(regions: Any, path: str = "scene.regions") -> dict[str, FrictionLaw]:
    """The laws of the interface regions: name -> law.

    Raises:
        SceneError: Not an object, a bad region name, an invalid law (named by its path).
    """
    if not isinstance(regions, dict):
        raise SceneError(f"{path}: expected an object (region -> law), got {regions!r}")
    out: dict[str, FrictionLaw] = {}
    for name, law in regions.items():
        if not isinstance(name, str) or not name or name == DEFAULT_REGION or "\0" in name:
            raise SceneError(
                f"{path}: {name!r} cannot name a region (a physical group of interface facets, "
                f"not {DEFAULT_REGION!r})"
            )
        if isinstance(law, FrictionLaw):
            out[name] = law
            continue
        if not isinstance(law, dict) or set(law) - {"law", "params"}:
            raise SceneError(f"{path}.{name}: expected {{'law': ..., 'params': {{...}}}}")
        try:
            out[name] = build_law(law)
        except LawError as e:
            raise SceneError(f"{path}.{name}: {e}") from None
    return out
