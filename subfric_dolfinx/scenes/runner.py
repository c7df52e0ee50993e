"""Running a scene, building only what it needs.

A scene is a small JSON-like configuration (or the dataclasses of :mod:`.schema`), validated
strictly: an unknown key or a wrong type is an error naming its path (``scene.solver.dt``).

* ``{"kind": "pointwise", ...}``: material-point cases run by the driver. No mesh, no MPI, no
  DOLFINx: running one imports numpy and the constitutive core only.
* ``{"kind": "fe", ...}``: two bodies with a frictional interface. The mesh comes from a builder of
  :mod:`subfric_dolfinx.meshing` or a ``.msh`` file; its dimension decides the number of
  components (a 2-D scene has no third one). Output files (CSV history, VTX/XDMF fields) exist only
  if the scene asks for them; interface profiles at chosen times are returned in memory.

Example (the skeleton of the main demo)::

    scene = parse_scene({
        "kind": "fe", "name": "block",
        "mesh": {"builder": "block_on_base", "options": {"n_interface": 16}},
        "law": {"params": {"preset": "sec7"}},
        "materials": {"primary": {"E": 2.1e5, "nu": 0.3}, "secondary": {"E": 2.1e5, "nu": 0.3}},
        "program": {"times": [0, 1, 2], "channels": {"press": [0, 1, 1], "slide": [0, 0, 1]}},
        "dirichlet": [{"group": "bottom", "value": [0, 0]},
                      {"group": "top", "component": 0, "value": 0.5, "amplitude": "slide"}],
        "loads": [{"type": "pressure", "group": "top", "value": 200, "amplitude": "press"}],
        "solver": {"prefix": "block_", "dt": 0.05},
        "outputs": {"history": True, "snapshots": [1.0, 2.0]},
    })
    result = run_scene(scene, outdir="output/block")
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..driver import run_case
from ..driver.cli import write_atomically
from .parser import load_scene, parse_scene
from .result import SceneResult
from .schema import FEScene, PointScene, SceneError

__all__ = ["run_scene"]


def run_scene(
    scene: dict[str, Any] | FEScene | PointScene | str | os.PathLike[str],
    *,
    outdir: str | Path | None = None,
    comm: Any = None,
    restart: str | Path | None = None,
) -> SceneResult:
    """Run a scene, building only what it needs.

    Args:
        scene: The scene (validated with :func:`parse_scene`), or the name of a JSON file
            holding it (read with :func:`~.parser.load_scene`: a key given twice is refused).
        outdir: Directory of the files the scene asks for (required if it asks for any).
        comm: MPI communicator of an FE scene (default ``COMM_WORLD``); unused for pointwise.
        restart: A checkpoint of this scene to continue from (any number of ranks).

    Raises:
        SceneError: Invalid scene, or outputs requested without ``outdir``.
        SceneInterrupted: A stop signal was received; a checkpoint was written.
        subfric_dolfinx.fem.StepFailure: A step could not be solved (with checkpoints enabled,
            the last converged state is in the checkpoint).
        subfric_dolfinx.io.CheckpointError: An unusable ``restart`` file.
    """
    scene = load_scene(scene) if isinstance(scene, str | os.PathLike) else parse_scene(scene)
    if isinstance(scene, PointScene):
        if restart is not None:
            raise SceneError("a pointwise scene cannot be restarted")
        return _run_pointwise(scene, outdir)
    from .fe import run_fe_scene  # DOLFINx only for FE scenes

    return run_fe_scene(scene, outdir, comm, restart)


def _run_pointwise(scene: PointScene, outdir: str | Path | None) -> SceneResult:
    if scene.save and outdir is None:
        raise SceneError("scene.save is true but no output directory was given")
    res = SceneResult(scene.name, "pointwise")
    for name, case in scene.cases.items():  # the parsed case, or the dict of a scene made otherwise
        res.cases[name] = run_case(
            scene.model[name] if scene.model is not None else case,
            steps_per_mm=scene.steps_per_mm,
            on_instability=scene.on_instability,
        )
    if scene.save:
        assert outdir is not None  # (checked above)
        out = Path(outdir) / f"{scene.name}.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps({k: v.to_dict() for k, v in res.cases.items()}, indent=1)
        write_atomically(out, text)  # a new file renamed over: never through a link
        res.files.append(str(out))
    return res
