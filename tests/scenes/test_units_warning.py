"""The subloading law's ``mu_s``, ``mu_k`` are stresses (MPa): values that look like friction
coefficients are warned about (:class:`~subfric_dolfinx.logs.UnitsWarning`), naming them, what
they give and what a coefficient would be, before a scene builds anything.

The rule (``LOW_STRENGTH``): the static strength ``g(f_n) mu_s`` at the scene's largest pressure
below 1 % of that pressure. Checked against the closed form of ``g``, on every rank alike.
"""

import math
import warnings

import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import preset
from subfric_dolfinx.constitutive.subloading import LOW_STRENGTH
from subfric_dolfinx.logs import UnitsWarning
from subfric_dolfinx.scenes import parse_scene, run_scene
from subfric_dolfinx.scenes.fe import largest_pressure, warn_units
from tests.scenes.test_scene_command import SCENE

TRAP = {**SCENE, "law": {"params": {"preset": "sec7", "mu_s": 0.3, "mu_k": 0.2}}}  # coefficients


def test_friction_coefficients_given_as_mu_are_named_with_what_they_give():
    law = preset("sec7")
    assert law.units_check(300.0) is None and law.units_check(1000.0) is None
    trap = law.replace(mu_s=0.3, mu_k=0.2)
    text = trap.units_check(300.0)
    g = 1.0 - math.exp(-law.c_n * 300.0)
    for words in ("mu_s = 0.3", "mu_k = 0.2", "stresses in MPa", "not friction coefficients"):
        assert words in text, text
    assert f"{g * 0.3:.3g} MPa static" in text and f"{g * 0.2:.3g} MPa kinetic" in text, text
    assert f"mu_s = {0.3 * 300 / g:.4g} MPa" in text, text  # what a coefficient of 0.3 needs
    # the rule's edge: a static strength just above / below 1 % of f_n
    edge = LOW_STRENGTH * 300.0 / g
    assert law.replace(mu_s=1.01 * edge, mu_k=0.5 * edge).units_check(300.0) is None
    assert law.replace(mu_s=0.99 * edge, mu_k=0.5 * edge).units_check(300.0)
    assert trap.units_check(0.0) is None and trap.units_check(-5.0) is None  # nothing pressed


def test_a_scene_warns_before_building_anything():
    comm = MPI.COMM_WORLD
    scene = parse_scene(TRAP)
    assert largest_pressure(scene) == 300.0
    with warnings.catch_warnings():  # an "error" filter raises on every rank (rank 0 shows it)
        warnings.simplefilter("error", UnitsWarning)
        with pytest.raises(UnitsWarning, match=r"scene\.law \(the largest pressure: 300 MPa\)"):
            warn_units(scene, comm)
        warn_units(parse_scene(SCENE), comm)  # the Sec. 7 values: silent
        # an "error" filter stops the run on every rank before the mesh is built
        with pytest.raises(UnitsWarning, match="are stresses in MPa"):
            run_scene(TRAP, outdir=None, comm=comm)
