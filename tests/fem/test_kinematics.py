"""The modes' strain, elastic stress and weight against closed forms (fields whose strain is
known exactly, integrated over a mesh)."""

import math

import dolfinx
import dolfinx.fem
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from subfric_dolfinx.fem.kinematics import (
    check_mode,
    elastic_stress,
    point_weight,
    strain,
    weight,
)

E, NU = 210e3, 0.3


def integral(expr, mesh):
    return mesh.comm.allreduce(
        dolfinx.fem.assemble_scalar(dolfinx.fem.form(expr * ufl.dx(domain=mesh))), op=MPI.SUM
    )


def field(mesh, fn):
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (mesh.geometry.dim,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(fn)
    return u


def rectangle(x0=0.0):
    return dolfinx.mesh.create_rectangle(
        MPI.COMM_WORLD, [[x0, 0.0], [x0 + 2.0, 1.0]], [8, 4], dolfinx.mesh.CellType.triangle
    )


def test_plane_strain_and_3d_strain_of_affine_fields():
    m = rectangle()
    u = field(m, lambda x: np.stack([0.01 * x[0] + 0.02 * x[1], 0.03 * x[0] - 0.04 * x[1]]))
    e = strain(u, "plane_strain")
    area = 2.0
    exact = {(0, 0): 0.01, (0, 1): 0.025, (1, 1): -0.04, (2, 2): 0.0, (0, 2): 0.0}
    for (i, j), v in exact.items():
        assert integral(e[i, j], m) == pytest.approx(v * area, abs=1e-14)
    m3 = dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 2, 2, 2)
    u3 = field(m3, lambda x: np.stack([0.01 * x[2], 0.0 * x[0], 0.02 * x[2]]))
    e3 = strain(u3, "3d")
    assert integral(e3[0, 2], m3) == pytest.approx(0.005, abs=1e-14)
    assert integral(e3[2, 2], m3) == pytest.approx(0.02, abs=1e-14)


def test_axisymmetric_hoop_strain_and_weight():
    """u_r = c r, u_z = d z: eps = diag(c, d, c); the weight 2 pi r makes the integral over the
    section the volume of the ring: pi (r1^2 - r0^2) h."""
    m = rectangle(x0=1.0)  # r in [1, 3], z in [0, 1]
    c, d = 1e-3, -2e-3
    u = field(m, lambda x: np.stack([c * x[0], d * x[1]]))
    e = strain(u, "axisymmetric")
    w = weight(m, "axisymmetric")
    vol = math.pi * (3.0**2 - 1.0**2) * 1.0
    assert integral(w, m) == pytest.approx(vol, rel=1e-12)
    assert integral(e[2, 2] * w, m) == pytest.approx(c * vol, rel=1e-9)
    assert integral(e[0, 0] * w, m) == pytest.approx(c * vol, rel=1e-12)
    assert integral(e[1, 1] * w, m) == pytest.approx(d * vol, rel=1e-12)
    x = np.array([[0.5, 7.0], [2.0, -1.0]])
    assert point_weight(x, "axisymmetric") == pytest.approx(2 * math.pi * x[:, 0])
    assert point_weight(x, "plane_strain") == pytest.approx([1.0, 1.0])


def test_plane_stress_is_uniaxial_stress_and_others_hooke():
    """Uniaxial stress in plane stress: eps = (e, -nu e): sigma = (E e, 0, 0); in plane strain the
    same strain gives Hooke's sigma_zz = lambda tr(eps)."""
    m = rectangle()
    e0 = 1e-3
    u = field(m, lambda x: np.stack([e0 * x[0], -NU * e0 * x[1]]))
    s = elastic_stress(strain(u, "plane_stress"), E, NU, "plane_stress")
    assert integral(s[0, 0], m) / 2.0 == pytest.approx(E * e0, rel=1e-12)
    assert abs(integral(s[1, 1], m)) < 1e-9 * E * e0
    assert integral(s[2, 2], m) == 0.0
    s2 = elastic_stress(strain(u, "plane_strain"), E, NU, "plane_strain")
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    assert integral(s2[2, 2], m) / 2.0 == pytest.approx(lam * (1 - NU) * e0, rel=1e-12)


@pytest.mark.parametrize(
    ("mode", "gdim", "message"),
    [
        ("axi", 2, "mode must be one of"),
        ("3d", 2, "needs a 3-D mesh"),
        ("plane_stress", 3, "needs a 2-D mesh"),
    ],
)
def test_bad_modes_are_named(mode, gdim, message):
    with pytest.raises(ValueError, match=message):
        check_mode(mode, gdim)
    assert check_mode("axisymmetric", 2) == "axisymmetric"
