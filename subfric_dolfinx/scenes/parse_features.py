"""Strict checks of a scene's springs, named points, point forces, probes, frames and stress output.

Called by :func:`~.parser.parse_scene` once the scene's types are converted; every error names its
key path (``scene.springs[0].stiffness``). The number of components is the mesh's dimension
(the builder's, or ``mesh.gdim`` with a file).
"""

from __future__ import annotations

import math
import re
from typing import Any

from ..loading import LoadingError, LoadingProgram
from .schema import FEScene, SceneError

__all__ = ["PROBE_FIELDS", "check_features", "frame_axes"]

PROBE_FIELDS = ("u", "sigma", "von_mises", "f_t", "f_n", "gap", "status")
"""Probe fields every scene has; the law's internal variables come in addition."""

_POINT_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,63}$")


def _vector(path: str, value: Any, n: int, what: str = "values") -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        raise SceneError(
            f"{path}: expected a list of {n} {what} (one per component), got {value!r}"
        )
    return [float(v) for v in value]


def _channels(path: str, amplitude: Any, n: int, program: LoadingProgram) -> None:
    names = amplitude if isinstance(amplitude, list) else [amplitude]
    if isinstance(amplitude, list) and len(amplitude) != n:
        raise SceneError(
            f"{path}: {len(amplitude)} channels for {n} components (give one channel, or one "
            "per component)"
        )
    for i, ch in enumerate(names):
        try:
            program.amplitude(ch, program.t_start)
        except LoadingError as e:
            where = f"{path}[{i}]" if isinstance(amplitude, list) else path
            raise SceneError(f"{where}: {e}") from None


def frame_axes(normal: list[float], tangent: list[float], path: str) -> list[list[float]]:
    """The frame's unit axes (tangent [, normal x tangent], normal), rows of a rotation.

    Raises:
        SceneError: A zero vector, or vectors not orthogonal (to 1e-6 after normalising).
    """
    n2 = sum(v * v for v in normal)
    t2 = sum(v * v for v in tangent)
    if not n2 > 0 or not t2 > 0:
        raise SceneError(f"{path}: the normal and the tangent must not be zero")
    n = [v / math.sqrt(n2) for v in normal]
    t = [v / math.sqrt(t2) for v in tangent]
    if abs(sum(a * b for a, b in zip(n, t, strict=True))) > 1e-6:
        raise SceneError(
            f"{path}: the tangent {tangent!r} is not orthogonal to the normal {normal!r}"
        )
    if len(n) == 2:
        return [t, n]
    t2v = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]]
    return [t, t2v, n]


def check_features(scene: FEScene, program: LoadingProgram, variables: tuple[str, ...]) -> None:
    """Check the springs, points, point forces, probes, frames and stress output of a scene.

    Args:
        scene: The converted scene.
        program: Its loading program (channel names).
        variables: Names of the law's internal variables (allowed as probe fields).

    Raises:
        SceneError: Naming the key path of the first bad value.
    """
    gdim = scene.mesh.geometric_dim
    for i, sp in enumerate(scene.springs):
        path = f"scene.springs[{i}]"
        k = sp.stiffness if isinstance(sp.stiffness, list) else [sp.stiffness] * gdim
        k = _vector(f"{path}.stiffness", k, gdim, "stiffnesses")
        if any(v < 0 for v in k) or not any(v > 0 for v in k):
            raise SceneError(
                f"{path}.stiffness: must be >= 0 (MPa/mm) and not all zero, got {sp.stiffness!r}"
            )
        if sp.u0 is not None:
            _vector(f"{path}.u0", sp.u0, gdim)
        _channels(f"{path}.amplitude", sp.amplitude, gdim, program)
    for name, pt in scene.points.items():
        path = f"scene.points.{name}"
        if not _POINT_NAME.match(name):
            raise SceneError(
                f"{path}: a point's name is 1 to 64 letters, digits and '_', '.', '+', '-' (it "
                f"names history columns), got {name!r}"
            )
        _vector(f"{path}.x", pt.x, gdim, "coordinates")  # the body: parse_bodies
    for i, pf in enumerate(scene.point_forces):
        path = f"scene.point_forces[{i}]"
        _known_point(f"{path}.point", pf.point, scene)
        _vector(f"{path}.value", pf.value, gdim)
        _channels(f"{path}.amplitude", pf.amplitude, gdim, program)
    for i, ld in enumerate(scene.loads):
        if ld.type == "traction":
            if gdim:
                _vector(f"scene.loads[{i}].value", ld.value, gdim, "traction components")
            _channels(f"scene.loads[{i}].amplitude", ld.amplitude, gdim, program)
        elif isinstance(ld.amplitude, list):
            raise SceneError(
                f"scene.loads[{i}].amplitude: a pressure has one channel, got a list "
                f"{ld.amplitude!r}"
            )
    _check_outputs(scene, gdim, variables)


def _known_point(path: str, name: str, scene: FEScene) -> None:
    if name not in scene.points:
        raise SceneError(f"{path}: no point {name!r} in scene.points {sorted(scene.points)}")


def _check_outputs(scene: FEScene, gdim: int, variables: tuple[str, ...]) -> None:
    out = scene.outputs
    allowed = (*PROBE_FIELDS, *variables)
    for i, pr in enumerate(out.probes):
        path = f"scene.outputs.probes[{i}]"
        _known_point(f"{path}.point", pr.point, scene)
        if not pr.fields:
            raise SceneError(f"{path}.fields: empty; give some of {list(allowed)}")
        for j, f in enumerate(pr.fields):
            if f not in allowed:
                raise SceneError(f"{path}.fields[{j}]: must be one of {list(allowed)}, got {f!r}")
    supported = {d.group for d in scene.dirichlet} | {s.group for s in scene.springs}
    names = set()
    for i, fr in enumerate(out.reaction_frames):
        path = f"scene.outputs.reaction_frames[{i}]"
        if fr.group not in supported:
            raise SceneError(
                f"{path}.group: {fr.group!r} has no Dirichlet condition or spring (no reaction); "
                f"groups with one: {sorted(supported)}"
            )
        _vector(f"{path}.normal", fr.normal, gdim)
        _vector(f"{path}.tangent", fr.tangent, gdim)
        frame_axes(fr.normal, fr.tangent, path)
        name = fr.name or fr.group
        if name in names:
            raise SceneError(f"{path}.name: {name!r} is used by another frame")
        names.add(name)
    if out.stress and out.fields is None:
        raise SceneError("scene.outputs.stress: true, but no fields are written (fields is null)")
    if out.stress and out.fields == "xdmf" and scene.degree != 1:
        raise SceneError(
            "scene.outputs.stress: the stress of degree-2 displacement is DG1, which XDMF cannot "
            "write (cell values or the mesh's own nodes only); use fields 'vtx'"
        )
