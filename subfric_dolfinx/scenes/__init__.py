"""Declarative scenes: a JSON-like description of a run, and one runner that builds only that.

* :mod:`.schema`: the dataclasses of a scene and :class:`SceneError`.
* :mod:`.parser`: strict parsing (:func:`parse_scene`; :func:`load_scene` from a JSON file),
  errors named by their key path.
* :mod:`.runner`: :func:`run_scene`; a pointwise scene needs numpy only.
* :mod:`.fe`: the FE run, from :mod:`.build` (mesh, problem), :mod:`.outputs` (one object with
  ``on_step``/``close``) and :mod:`.signals` (the stop-signal guard). Imported only for FE scenes.
* :mod:`.cli`: the demos' command line (their options, PETSc's, log level, exit codes), imported
  by programs only.

May import: everything else in the package (this is the top layer).
"""

from .parser import load_scene, parse_scene
from .result import SceneResult
from .runner import run_scene
from .schema import (
    DirichletSpec,
    FEScene,
    LoadSpec,
    MeshSpec,
    OutputSpec,
    PointScene,
    SceneError,
    SolverSpec,
)
from .signals import SceneInterrupted

__all__ = [
    "DirichletSpec",
    "FEScene",
    "LoadSpec",
    "MeshSpec",
    "OutputSpec",
    "PointScene",
    "SceneError",
    "SceneInterrupted",
    "SceneResult",
    "SolverSpec",
    "load_scene",
    "parse_scene",
    "run_scene",
]
