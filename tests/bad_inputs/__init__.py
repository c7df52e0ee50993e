"""The catalogue of bad inputs: every bad input the package refuses, each case once.

Every bad input must fail early with a message that names the offending value (and the field,
file, channel or prefix it came in), raised on every rank alike (a rank raising alone would leave
the others waiting in the next collective), and leave no partial output (no output file, no
registered options prefix, no options set). :func:`tests.helpers.raised_on_every_rank` gathers
the outcome of every rank and checks that all raised the same error with the same message.

One module per kind of input:

* ``test_laws.py``: parameters of both laws (every field out of range, NaN, +-inf, wrong type,
  missing); numpy only.
* ``test_driver_cases.py``: the material-point driver's CASE.json, by library and command line
  (missing, unknown, wrongly typed or non-finite fields, times that do not increase, samples out
  of range, bad parameters and steps per mm, absurd path magnitudes, unreadable JSON); numpy only.
* ``test_loading.py``: loading programs (non-increasing, non-finite or too few times, non-finite
  channel values, channels of the wrong length, unknown channels); numpy only.
* ``test_meshes.py``: mesh files and gmsh models (missing, not a file, not a mesh, not an MSH
  file — a gmsh script as .geo or named .msh is refused before gmsh opens it, a required
  physical group missing, sides that do not pair by count or position, bodies sharing nodes,
  group elements lost, wrong dimension, bad gdim, no current model) and meshing arguments.
* ``test_problems.py``: boundary conditions naming an unknown channel or group; options prefixes
  (empty, without the trailing '_', with '-' or spaces, not a string, in use).
* ``test_scenes.py``: scene configurations (unknown keys, wrong types, values the dataclasses
  would let through — a list as a pressure, a vector with ``component``, 10**400, a list as a
  PETSc option —, keys that would be ignored — mesh options beside a file, output times outside
  the program, ``dt_min > dt`` —, names that are not plain file names, loads and springs on a
  cell group, files requested without a directory) and checkpoints (missing, truncated, foreign,
  other law or mesh).
* ``test_checkpoints.py``: damaged checkpoint contents (shapes, dtypes, NaN/inf, attribute types
  and ranges, JSON) and restarts with other materials, loads, boundary values or program.
* ``test_scene_features.py``: springs, named points, point forces, probes, reaction frames and
  stress output of a scene (wrong lengths, negative or zero stiffness, unknown channels, points
  or probe fields, frames of groups without a reaction or with non-orthogonal axes, stress
  without fields; points outside their body, node groups that are not vertices).

The numpy-only modules run on 1 rank; the others on 1 and 2 ranks.
"""
