"""The bodies' materials of a scene: linear elastic, or J2 plasticity (``"model": "j2"``).

``scene.materials.<body or cell group>`` is an object:

* ``{"E": ..., "nu": ...}`` (or with ``"model": "elastic"``): isotropic linear elasticity, the
  built-in fast path when every body is elastic;
* ``{"model": "j2", "E": ..., "nu": ..., "sigma_y": ..., "H_iso": ..., "H_kin": ...}``: small-strain
  J2 (von Mises) plasticity with linear isotropic and kinematic hardening
  (:class:`~subfric_dolfinx.constitutive.J2Material`; ``H_iso`` and ``H_kin`` default to 0, perfect
  plasticity). A scene with a J2 body runs the bodies through
  :class:`~subfric_dolfinx.fem.plasticity.J2Bulk` (the elastic bodies too, as
  :class:`~subfric_dolfinx.constitutive.LinearElastic`): the bulk residual is assembled at every
  Newton iterate and its state (plastic strain, backstress, ``p``) is committed with the
  interfaces' and written to checkpoints.

J2 is refused in the ``plane_stress`` mode (no plane-stress return map), and so are the bodies'
stress outputs (``outputs.stress``, probes of ``sigma``/``von_mises``: the stress of a J2 body lives
at its quadrature points, not in the displacement's polynomial space).

Numpy only (pointwise scenes import the parser without DOLFINx).
"""

from __future__ import annotations

from typing import Any

from ..constitutive import J2Material, LinearElastic
from ..values import short_repr
from .schema import DynamicsSpec, FEScene, SceneError, scene_number

__all__ = [
    "MATERIAL_MODELS",
    "check_materials_fit",
    "is_j2",
    "parse_material",
    "scene_dynamics",
    "scene_materials",
]

MATERIAL_MODELS = ("elastic", "j2")
"""The values of ``scene.materials.<name>.model``."""

_KEYS = {
    "elastic": ({"E", "nu"}, {"model", "density"}),
    "j2": ({"E", "nu", "model", "sigma_y"}, {"H_iso", "H_kin", "density"}),
}


def is_j2(spec: dict[str, Any]) -> bool:
    """Whether a material entry selects J2 plasticity."""
    return spec.get("model") == "j2"


def parse_material(spec: dict[str, Any], path: str) -> LinearElastic | J2Material:
    """The material of one entry of ``scene.materials``.

    Raises:
        SceneError: An unknown model, missing or unknown keys, a value out of range (the key path
            and the bad value named).
    """
    if not isinstance(spec, dict):
        raise SceneError(f"{path}: expected an object, got {short_repr(spec)}")
    model = spec.get("model", "elastic")
    if model not in MATERIAL_MODELS:
        raise SceneError(
            f"{path}.model: must be one of {list(MATERIAL_MODELS)}, got {short_repr(model)}"
        )
    required, optional = _KEYS[model]
    keys = set(spec)
    if not required - {"model"} <= keys or keys - required - optional:
        raise SceneError(
            f"{path}: keys must be {sorted(required)} (optional: {sorted(optional)}) for the "
            f"model {model!r}, got {sorted(keys)}"
        )
    params = {
        k: scene_number(v, f"{path}.{k}") for k, v in spec.items() if k not in ("model", "density")
    }
    if "density" in spec and not scene_number(spec["density"], f"{path}.density") > 0:
        raise SceneError(f"{path}.density: must be > 0 (tonne/mm^3), got {spec['density']!r}")
    try:
        return J2Material(**params) if model == "j2" else LinearElastic(**params)
    except (TypeError, ValueError) as e:
        raise SceneError(f"{path}: {e}") from None


def scene_materials(scene: FEScene) -> dict[str, LinearElastic | J2Material] | None:
    """The scene's materials as constitutive objects if a body is J2, else ``None``.

    Raises:
        SceneError: A bad entry (see :func:`parse_material`).
    """
    mats = {
        name: parse_material(spec, f"scene.materials.{name}")
        for name, spec in scene.materials.items()
    }
    return mats if any(isinstance(m, J2Material) for m in mats.values()) else None


def scene_dynamics(scene: FEScene) -> dict[str, Any] | None:
    """The scene's inertia as the arguments of :class:`~subfric_dolfinx.fem.dynamics.Dynamics`.

    From its materials' densities (tonne/mm^3) and ``scene.dynamics``; ``None``: quasi-static
    (no density). Checked here, without DOLFINx.

    Raises:
        SceneError: Densities on some materials only, ``scene.dynamics`` without densities, a
            value out of range or a vector of the wrong size (its key path named).
    """
    dens = {n: s["density"] for n, s in scene.materials.items() if "density" in s}
    if not dens:
        if scene.dynamics is not None:
            raise SceneError(
                "scene.dynamics: a dynamic scene needs a density in its materials "
                "(scene.materials.<body>.density, tonne/mm^3)"
            )
        return None
    without = sorted(n for n in scene.materials if n not in dens)
    if without:
        raise SceneError(
            f"scene.materials: a density for {sorted(dens)} but not for {without} (give every "
            "body its density, tonne/mm^3, or none: quasi-static)"
        )
    spec = scene.dynamics or DynamicsSpec()
    path = "scene.dynamics"
    if not 0.0 <= scene_number(spec.rho_inf, f"{path}.rho_inf") <= 1.0:
        raise SceneError(f"{path}.rho_inf: must be in [0, 1], got {spec.rho_inf!r}")
    for key in ("alpha_m", "alpha_k"):
        if not scene_number(getattr(spec, key), f"{path}.{key}") >= 0.0:
            raise SceneError(f"{path}.{key}: must be >= 0, got {getattr(spec, key)!r}")
    if spec.interface_forces not in ("mixed", "end"):
        raise SceneError(
            f"{path}.interface_forces: must be 'mixed' or 'end', got {spec.interface_forces!r}"
        )
    gdim = scene.mesh.geometric_dim
    vectors = {f"{path}.initial_velocity.{k}": v for k, v in spec.initial_velocity.items()}
    if spec.gravity is not None:
        vectors[f"{path}.gravity"] = spec.gravity
    for where, vec in vectors.items():
        if len(vec) != gdim:
            raise SceneError(f"{where}: {gdim} values wanted (one per coordinate), got {vec!r}")
        for i, x in enumerate(vec):
            scene_number(x, f"{where}[{i}]")
    return {
        "density": {n: float(v) for n, v in dens.items()},
        "rho_inf": float(spec.rho_inf),
        "alpha_m": float(spec.alpha_m),
        "alpha_k": float(spec.alpha_k),
        "initial_velocity": {k: tuple(map(float, v)) for k, v in spec.initial_velocity.items()},
        "gravity": None if spec.gravity is None else tuple(map(float, spec.gravity)),
        "interface_forces": spec.interface_forces,
    }


def check_materials_fit(scene: FEScene) -> None:
    """J2 bodies with the rest of the scene: the mode and the stress outputs.

    Raises:
        SceneError: J2 in plane stress, or stress outputs asked for with a J2 body.
    """
    j2 = sorted(n for n, s in scene.materials.items() if is_j2(s))
    if not j2:
        return
    if scene.mode == "plane_stress":
        raise SceneError(
            f"scene.mode: J2 plasticity (scene.materials {j2}) needs 'plane_strain', "
            "'axisymmetric' or '3d'; 'plane_stress' has no J2 return map"
        )
    out = scene.outputs
    if out.stress:
        raise SceneError(
            f"scene.outputs.stress: not available with J2 bodies (scene.materials {j2}): their "
            "stress lives at the quadrature points"
        )
    for i, probe in enumerate(out.probes):
        bad = sorted({"sigma", "von_mises"} & set(probe.fields))
        if bad:
            raise SceneError(
                f"scene.outputs.probes[{i}].fields: {bad} not available with J2 bodies "
                f"(scene.materials {j2})"
            )
