"""J2 plasticity in the bodies (:class:`~subfric_dolfinx.fem.plasticity.J2Bulk`) against closed
forms, solved by the small Newton loop of ``tests/bulk_newton.py`` (LU):

* homogeneous bars in uniaxial stress, loading-unloading-reloading (3-D; axisymmetric rod):
  the bilinear closed form with its Bauschinger shift, to Newton's tolerance;
* plane strain against a 3-D block with ``u_z = 0`` on both faces (the 4-component reduction);
* the thick cylinder under internal pressure (axisymmetric, plane strain ``u_z = 0``): Lamé in
  the elastic range, Hill's elastic-perfectly-plastic solution (pressure vs plastic radius, the
  stresses, the limit pressure), quadratic convergence of Newton's method;
* a body of J2 beside an elastic one; the protocol: revert, state/restore, errors.
"""

import itertools
import math

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from subfric_dolfinx.constitutive import J2Material, LinearElastic
from subfric_dolfinx.fem.plasticity import J2Bulk, PlasticityError
from tests.bulk_newton import Newton, component_dofs, context, tag_all_cells
from tests.constitutive.test_j2_material import uniaxial_closed_form
from tests.helpers import raised_on_every_rank

E, NU, SY = 200e3, 0.3, 250.0
EY = SY / E
ELASTIC = LinearElastic(E, NU)


def near(i, v):
    return lambda x: np.isclose(x[i], v)


def bar_3d(comm, mat, n=2):
    mesh = dolfinx.mesh.create_unit_cube(comm, n, n, n)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    ctx = context(mesh, V, "3d", tag_all_cells(mesh), {"bar": (1,)})
    bulk = J2Bulk({"bar": mat})
    u = dolfinx.fem.Function(V)
    cons = {
        "x0": (0, component_dofs(V, 0, near(0, 0.0))),
        "y0": (1, component_dofs(V, 1, near(1, 0.0))),
        "z0": (2, component_dofs(V, 2, near(2, 0.0))),
        "x1": (0, component_dofs(V, 0, near(0, 1.0))),
    }
    return bulk, Newton(bulk, ctx, u, cons), u


@pytest.mark.parametrize(
    "Hi, Hk", [(0.0, 0.0), (0.0, 10e3), (4e3, 6e3)], ids=["perfect", "kinematic", "mixed"]
)
def test_3d_bar_uniaxial_load_unload_reload(Hi, Hk):
    """Unit cube (2 x 2 x 2 x 6 tets, P1), symmetry planes, u_x prescribed on x = 1 along
    0 -> 4 eps_y -> -4 eps_y -> 4 eps_y (4 steps a leg). Reaction force, every point's stress
    (uniaxial: lateral stresses 0), p and the lateral contraction against the closed form:
    measured < 1e-11 sigma_y; Newton's iterations per step printed (<= 7)."""
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=Hi, H_kin=Hk)
    bulk, nw, u = bar_3d(MPI.COMM_WORLD, mat)
    e, s, ep, p, _ = uniaxial_closed_form(E, SY, Hi, Hk, 4 * EY, -4 * EY, 4)
    V = u.function_space
    y1 = component_dofs(V, 1, near(1, 1.0))
    worst = 0.0
    for k in range(e.size):
        norms = nw.solve({"x1": e[k]})
        bulk.commit()
        assert len(norms) <= 8
        sig = bulk.at_points("stress")
        worst = max(worst, abs(nw.reaction("x1") - s[k]))
        assert abs(nw.reaction("x1") - s[k]) < 1e-9 * SY
        assert np.allclose(sig[:, 0], s[k], rtol=0, atol=1e-9 * SY)
        assert np.allclose(sig[:, 1:], 0.0, rtol=0, atol=1e-9 * SY)
        assert np.allclose(bulk.at_points("p"), p[k], rtol=0, atol=1e-12)
        lateral = -NU * s[k] / E - ep[k] / 2
        assert np.allclose(u.x.array[y1], lateral, rtol=0, atol=1e-13)
    its = [len(h) - 1 for h in nw.history]
    print(f"max reaction error {worst / SY:.1e} sigma_y, Newton: {its}")


def test_axisymmetric_rod_uniaxial():
    """A solid rod (r <= 0.5, 0 <= z <= 1; 2 x 4 x 2 triangles, P1) pulled along z: uniaxial
    stress, hoop strain = radial strain; the reaction (2 pi r weighted) is sigma pi R^2; kinematic
    hardening, load and reverse: measured 1e-13 of sigma_y pi R^2."""
    mesh = dolfinx.mesh.create_rectangle(
        MPI.COMM_WORLD, [[0.0, 0.0], [0.5, 1.0]], [2, 4], dolfinx.mesh.CellType.triangle
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    ctx = context(mesh, V, "axisymmetric", tag_all_cells(mesh), {"rod": (1,)})
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_kin=8e3)
    bulk = J2Bulk({"rod": mat})
    u = dolfinx.fem.Function(V)
    cons = {
        "axis": (0, component_dofs(V, 0, near(0, 0.0))),
        "z0": (1, component_dofs(V, 1, near(1, 0.0))),
        "z1": (1, component_dofs(V, 1, near(1, 1.0))),
    }
    nw = Newton(bulk, ctx, u, cons)
    e, s, ep, _, _ = uniaxial_closed_form(E, SY, 0.0, 8e3, 3 * EY, -3 * EY, 3)
    r1 = component_dofs(V, 0, near(0, 0.5))
    area = math.pi * 0.25
    for k in range(e.size):
        nw.solve({"z1": e[k]})
        bulk.commit()
        assert nw.reaction("z1") == pytest.approx(s[k] * area, abs=1e-10 * SY)
        sig = bulk.at_points("stress")  # (rr, zz, tt, sqrt2 rz)
        assert np.allclose(sig[:, 1], s[k], rtol=0, atol=1e-9 * SY)
        assert np.allclose(sig[:, [0, 2, 3]], 0.0, rtol=0, atol=1e-9 * SY)
        lateral = -NU * s[k] / E - ep[k] / 2
        assert np.allclose(u.x.array[r1], 0.5 * lateral, rtol=0, atol=1e-13)


def test_plane_strain_block_is_a_3d_block_with_fixed_z():
    """Unit square (plane strain, P1, 3 x 3 x 2 triangles) and unit cube (3 x 3 x 1 x 6 tets)
    with u_z = 0 on both z faces, pulled in x and pushed back with y free: same reaction and
    sigma_zz (mixed hardening) to Newton's tolerance (measured 1e-12 sigma_y)."""
    comm = MPI.COMM_WORLD
    mat = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=3e3, H_kin=2e3)
    m2 = dolfinx.mesh.create_unit_square(comm, 3, 3)
    V2 = dolfinx.fem.functionspace(m2, ("Lagrange", 1, (2,)))
    b2 = J2Bulk({"b": mat})
    u2 = dolfinx.fem.Function(V2)
    n2 = Newton(
        b2,
        context(m2, V2, "plane_strain", tag_all_cells(m2), {"b": (1,)}),
        u2,
        {
            "x0": (0, component_dofs(V2, 0, near(0, 0.0))),
            "y0": (1, component_dofs(V2, 1, near(1, 0.0))),
            "x1": (0, component_dofs(V2, 0, near(0, 1.0))),
        },
    )
    b3, n3, _ = bar_3d(comm, mat, n=3)
    V3 = n3.u.function_space
    n3.constraints["z1"] = (2, component_dofs(V3, 2, near(2, 1.0)))
    n3.bcs.append(dolfinx.fem.dirichletbc(0.0, n3.constraints["z1"][1], V3.sub(2)))
    for strain in (2 * EY, 4 * EY, 0.0, -3 * EY):
        n2.solve({"x1": strain})
        n3.solve({"x1": strain, "z1": 0.0})
        b2.commit()
        b3.commit()
        assert n2.reaction("x1") == pytest.approx(n3.reaction("x1"), abs=1e-9 * SY)
        assert b2.plastic_points > 0 or strain == 0.0
        s2 = b2.at_points("stress")
        s3 = b3.at_points("stress")
        if s2.size:
            assert np.allclose(s2[:, 2], s2[0, 2], atol=1e-9 * SY)  # homogeneous
        if s3.size:
            assert np.allclose(s3[:, 2], s3[0, 2], atol=1e-9 * SY)
        zz2 = comm.allgather(s2[0, 2] if s2.size else None)
        zz3 = comm.allgather(s3[0, 2] if s3.size else None)
        z2 = next(z for z in zz2 if z is not None)
        z3 = next(z for z in zz3 if z is not None)
        assert z2 == pytest.approx(z3, abs=1e-9 * SY)
        assert abs(z2) > 10.0  # sigma_zz is really there


# ---------------------------------------------------------------------------------------------
# The thick cylinder: a <= r <= b, plane strain (u_z = 0 on z = 0 and z = H), in axisymmetric mode
A, B, HZ = 1.0, 2.0, 0.1
NU_HILL = 0.4999  # Hill's closed form is for an incompressible material (nu = 1/2)
K_SHEAR = SY / math.sqrt(3.0)
P_LIMIT = 2 * K_SHEAR * math.log(B / A)


def hill(ua, G):
    """Hill's elastic-perfectly-plastic tube (plane strain, nu = 1/2) at an inner displacement
    ``ua`` past first yield: the plastic radius c, the pressure and the stresses as functions of
    r (sigma_r, sigma_theta, sigma_z)."""
    k = K_SHEAR
    c = min(math.sqrt(2 * G * A * ua / k), B)  # u = k c^2 / (2 G r) in both zones
    p = k * (1 - c**2 / B**2 + 2 * math.log(c / A))

    def stresses(r):
        r = np.asarray(r)
        pl = r <= c
        sr = np.where(pl, -p + 2 * k * np.log(r / A), -k * c**2 / B**2 * (B**2 / r**2 - 1))
        st = np.where(pl, sr + 2 * k, k * c**2 / B**2 * (B**2 / r**2 + 1))
        return sr, st, (sr + st) / 2

    return c, p, stresses


def lame(ua, mat):
    """The elastic tube (plane strain) with inner displacement ``ua``: pressure and stresses."""
    E_, nu = mat.E, mat.nu
    p = ua * E_ * (B**2 - A**2) / ((1 + nu) * A**2 * ((1 - 2 * nu) * A + B**2 / A))
    q = p * A**2 / (B**2 - A**2)

    def stresses(r):
        r = np.asarray(r)
        return q * (1 - B**2 / r**2), q * (1 + B**2 / r**2), 2 * nu * q + 0 * r

    return p, stresses


def cylinder(comm, nr=40, nu=NU_HILL, Hi=0.0):
    mesh = dolfinx.mesh.create_rectangle(
        comm, [[A, 0.0], [B, HZ]], [nr, 1], dolfinx.mesh.CellType.triangle
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 2, (2,)))
    ctx = context(mesh, V, "axisymmetric", tag_all_cells(mesh), {"tube": (1,)})
    mat = J2Material(E=E, nu=nu, sigma_y=SY, H_iso=Hi)
    bulk = J2Bulk({"tube": mat})
    u = dolfinx.fem.Function(V)
    cons = {
        "z0": (1, component_dofs(V, 1, near(1, 0.0))),
        "z1": (1, component_dofs(V, 1, near(1, HZ))),
        "ra": (0, component_dofs(V, 0, near(0, A))),
    }
    return mat, bulk, Newton(bulk, ctx, u, cons), u


def pressure(nw):
    return nw.reaction("ra") / (2 * math.pi * A * HZ)


def first_yield(mat):
    """The inner displacement at first yield (Lamé; plane strain sigma_z = nu (sr + st))."""
    _, st = lame(1.0, mat)
    sr, stt, sz = st(A)
    return SY / math.sqrt(0.5 * ((sr - stt) ** 2 + (stt - sz) ** 2 + (sz - sr) ** 2))


def test_thick_cylinder_elastic_range_against_lame():
    """The tube (a = 1, b = 2; 40 x 1 x 2 triangles, P2) with nu = 0.3 up to first yield: the
    pressure (reaction / (2 pi a H)), the stresses at the points and the radial displacement
    at the nodes against Lamé. Measured: pressure 5e-9, stresses 1.7e-4 sigma_y (P2 near the
    inner radius), u_r 1e-6 (relative); no point yields just below u_y, the inner ones do at
    1.01 u_y."""
    mat, bulk, nw, u = cylinder(MPI.COMM_WORLD, nu=0.3)
    u_y = first_yield(mat)
    V = u.function_space
    x = V.tabulate_dof_coordinates()
    for f in (0.5, 1.0 - 1e-9, 1.01):
        ua = f * u_y
        nw.solve({"ra": ua}, rtol=1e-14, atol=1e-12 * SY)
        bulk.commit()
        pe, st = lame(ua, mat)
        r = bulk.points[:, 0]
        if f > 1:
            assert bulk.plastic_points > 0
            assert np.all(bulk.at_points("p")[r > A + 0.1] == 0.0)
            continue
        assert pressure(nw) == pytest.approx(pe, rel=1e-7)
        sig = bulk.at_points("stress")
        sr, stt, sz = st(r)
        err = np.abs(np.stack([sig[:, 0] - sr, sig[:, 2] - stt, sig[:, 1] - sz, sig[:, 3]]))
        print(f"Lamé: pressure {pressure(nw) / pe - 1:.1e}, stresses {err.max() / SY:.1e} sigma_y")
        assert err.max(initial=0.0) < 3e-4 * SY
        assert bulk.plastic_points == 0
        q = pe * A**2 / (B**2 - A**2)
        nu = mat.nu
        ur = (1 + nu) * q / E * ((1 - 2 * nu) * x[:, 0] + B**2 / x[:, 0])
        n_owned = V.dofmap.index_map.size_local
        ur_fe = u.x.array.reshape(-1, 2)[:n_owned, 0]
        assert np.allclose(ur_fe, ur[:n_owned], rtol=1e-5, atol=0)
        assert np.allclose(u.x.array.reshape(-1, 2)[:n_owned, 1], 0.0, atol=1e-6 * ua)


def test_thick_cylinder_against_hill():
    """Hill's elastic-perfectly-plastic tube (plane strain). Tube a = 1, b = 2 (40 x 1 x 2
    triangles, P2, quadrature degree 4, 480 points), E = 200 GPa, nu = 0.4999, sigma_y = 250
    MPa, the inner radius displaced by u_a (multiples of the first-yield u_y), the pressure
    p = reaction / (2 pi a H), k = sigma_y / sqrt(3).

    Hill's closed form is for nu = 1/2; the pressure's difference to it scales with 1 - 2 nu
    (measured 2.8e-3 p_L at nu = 0.49, 2.8e-4 at 0.499, 2.8e-5 at 0.4999, the same with 40 and
    160 elements). At nu = 0.4999 the hydrostatic stress at the points oscillates (the
    displacement formulation near incompressibility): only the deviatoric stress is compared
    pointwise. Measured:
    * u_a = 1.5, 2, 3 u_y (c = 1.22, 1.41, 1.73): pressure vs Hill's p(c) 2.9e-5 p_L;
      sigma_theta - sigma_r at the points within 3e-4 k of Hill's; every point yielded inside
      c - h and none beyond c + h (h the element size);
    * u_a = 6, 12 u_y (fully plastic): pressure vs the limit p_L = 2 k ln(b/a): 2.0e-5, 3.9e-5
      above it (the weak equilibrium of the discretisation; at nu = 0.4999 the excess grows
      slowly with u_a, 1.3e-4 at 40 u_y, the displacement formulation's stiffness near
      incompressibility);
    * Newton converges quadratically: once the residual is below 10 % of the force scale, each
      is below the square of the previous (relative to the force scale); 4-5 iterations a step.
    """
    comm = MPI.COMM_WORLD
    mat, bulk, nw, _ = cylinder(comm)
    u_y = first_yield(mat)
    force = P_LIMIT * 2 * math.pi * A * HZ
    h = (B - A) / 40
    report = []
    for f in (1.5, 2.0, 3.0, 6.0, 12.0):
        ua = f * u_y
        norms = nw.solve({"ra": ua}, rtol=1e-14, atol=1e-8 * force)
        bulk.commit()
        e = np.array(norms) / force
        for a_, b_ in itertools.pairwise(e):
            if a_ < 0.1:
                assert b_ <= a_**2 or b_ <= 1e-8, f"not quadratic: {e}"
        p = pressure(nw)
        c, ph, st = hill(ua, mat.G)
        if c < B:
            assert abs(p - ph) < 1e-4 * P_LIMIT
            r = bulk.points[:, 0]
            sig = bulk.at_points("stress")  # (rr, zz, tt, sqrt2 rz)
            sr, stt, _ = st(r)
            err = np.abs((sig[:, 2] - sig[:, 0]) - (stt - sr))
            print(
                f"Hill: c = {c:.3f}, pressure {(p - ph) / P_LIMIT:.1e} p_L, "
                f"deviator {err.max() / K_SHEAR:.1e} k, its {len(norms) - 1}"
            )
            assert err.max(initial=0.0) < 2e-3 * K_SHEAR
            pp = bulk.at_points("p")
            assert np.all(pp[r < c - h] > 0) and np.all(pp[r > c + h] == 0)
            report.append((f, (p - ph) / P_LIMIT, len(norms) - 1))
        else:
            assert p == pytest.approx(P_LIMIT, rel=1e-4)
            report.append((f, (p - P_LIMIT) / P_LIMIT, len(norms) - 1))
            print(f"limit: {(p - P_LIMIT) / P_LIMIT:.1e}, its {len(norms) - 1}")
    print("u_a/u_y, relative pressure error, Newton iterations:", report)


# ---------------------------------------------------------------------------------------------
# The protocol: commit, revert, state, restore


def snapshot(bulk):
    return {k: f.x.array.copy() for k, f in bulk.functions.items()}


def test_revert_leaves_the_state_bitwise_unchanged():
    """A step solved and reverted: every state array (committed and trial) is bitwise the
    committed one before the step; solving the step again gives the first attempt's result
    (bitwise on 1 rank, 1e-12 on 2: MUMPS's factors may vary in the last bits)."""
    mat, bulk, nw, u = cylinder(MPI.COMM_WORLD, nr=10, nu=0.3, Hi=2e3)
    u_y = first_yield(mat)
    nw.solve({"ra": 2 * u_y})
    bulk.commit()
    before = snapshot(bulk)
    u_before = u.x.array.copy()
    nw.solve({"ra": 4 * u_y})
    first = snapshot(bulk)
    assert not np.array_equal(first["p"], before["p_old"])  # the trial state moved
    bulk.revert()
    after = snapshot(bulk)
    for k in ("plastic_strain", "backstress", "p"):
        assert np.array_equal(after[k + "_old"], before[k + "_old"])
        assert np.array_equal(after[k], before[k + "_old"])
    u.x.array[:] = u_before
    nw.solve({"ra": 4 * u_y})
    again = snapshot(bulk)
    tight = MPI.COMM_WORLD.size == 1
    for k in ("plastic_strain", "backstress", "p", "stress"):
        if tight:
            assert np.array_equal(again[k], first[k])
        else:
            assert np.allclose(again[k], first[k], rtol=1e-12, atol=1e-12 * np.abs(first[k]).max())


def test_restore_of_state_continues_the_run():
    """Run A: 2 steps, state() and u kept, 2 more steps. Run B (new objects): restore(state),
    u set, the same 2 steps: pressures and states equal to 1e-10 (relative). The state is laid
    out by owned cell: nq rows a cell."""
    comm = MPI.COMM_WORLD
    mat, bulk, nw, u = cylinder(comm, nr=10, nu=0.3, Hi=1e3)
    u_y = first_yield(mat)
    for f in (1.5, 3.0):
        nw.solve({"ra": f * u_y})
        bulk.commit()
    saved, u_saved = bulk.saved_state(), u.x.array.copy()
    mesh = u.function_space.mesh
    n_cells = mesh.topology.index_map(2).size_local
    nq = bulk.functions["p"].function_space.dofmap.list.shape[1]
    assert sorted(saved) == ["backstress", "p", "plastic_strain"]
    assert saved["p"].shape == (n_cells * nq,)
    assert saved["plastic_strain"].shape == (n_cells * nq, 4)
    assert np.array_equal(np.sort(saved["p"]), np.sort(bulk.at_points("p_old")))
    assert comm.allreduce(np.count_nonzero(saved["p"]), op=MPI.SUM) > 0
    run_a = []
    for f in (4.5, 6.0):
        nw.solve({"ra": f * u_y})
        bulk.commit()
        run_a.append((pressure(nw), bulk.saved_state()))
    _, bulk_b, nw_b, u_b = cylinder(comm, nr=10, nu=0.3, Hi=1e3)
    bulk_b.restore_state(saved)
    assert all(np.array_equal(v, saved[k]) for k, v in bulk_b.saved_state().items())
    u_b.x.array[:] = u_saved
    for (p_a, st_a), f in zip(run_a, (4.5, 6.0), strict=True):
        nw_b.solve({"ra": f * u_y})
        bulk_b.commit()
        assert pressure(nw_b) == pytest.approx(p_a, rel=1e-10)
        st_b = bulk_b.saved_state()
        for k in ("plastic_strain", "backstress", "p"):
            assert np.allclose(st_b[k], st_a[k], rtol=1e-10, atol=1e-10 * np.abs(st_a[k]).max())


def test_restore_errors_are_raised_on_every_rank():
    comm = MPI.COMM_WORLD
    _, bulk, _, _ = cylinder(comm, nr=6, nu=0.3)
    st = bulk.saved_state()
    with raised_on_every_rank(PlasticityError, "missing: ['backstress']"):
        bulk.restore_state({k: v for k, v in st.items() if k != "backstress"})
    with raised_on_every_rank(PlasticityError, "unknown: ['x']"):
        bulk.restore_state(st | {"x": np.zeros(3)})
    with raised_on_every_rank(PlasticityError, "'plastic_strain' has shape"):
        bulk.restore_state(st | {"plastic_strain": np.zeros((st["p"].size, 6))})
    # on rank 0 only: every rank raises
    bad = st["p"].copy()
    if comm.rank == 0:
        bad[:] = np.nan
    with raised_on_every_rank(PlasticityError, "non-finite"):
        bulk.restore_state(st | {"p": bad})
    short = {k: v[1:] if comm.rank == 0 else v for k, v in st.items()}
    with raised_on_every_rank(PlasticityError, "has shape"):
        bulk.restore_state(short)
    assert all(np.array_equal(v, st[k]) for k, v in bulk.saved_state().items())  # untouched


# ---------------------------------------------------------------------------------------------
# Bodies and set-up


def two_body_cube(comm, materials, mode="3d", groups=None):
    mesh = dolfinx.mesh.create_unit_cube(comm, 4, 2, 2)
    tdim = 3
    n = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    mid = dolfinx.mesh.compute_midpoints(mesh, tdim, np.arange(n, dtype=np.int32))
    ct = dolfinx.mesh.meshtags(
        mesh, tdim, np.arange(n, dtype=np.int32), np.where(mid[:, 0] < 0.5, 1, 2).astype(np.int32)
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    ctx = context(mesh, V, mode, ct, {"a": (1,), "b": (2,)})
    if groups:  # one body "cube" of the cell groups a and b (the problem's BulkContext)
        ctx.tags["cube"] = (1, 2)
        ctx.groups = {"cube": ("a", "b")}
    bulk = J2Bulk(materials)
    u = dolfinx.fem.Function(V)
    cons = {
        "x0": (0, component_dofs(V, 0, near(0, 0.0))),
        "y0": (1, component_dofs(V, 1, near(1, 0.0))),
        "z0": (2, component_dofs(V, 2, near(2, 0.0))),
        "x1": (0, component_dofs(V, 0, near(0, 1.0))),
        "y1": (1, component_dofs(V, 1, near(1, 1.0))),
    }
    return bulk, Newton(bulk, ctx, u, cons), (mesh, ct)


def test_j2_body_beside_an_elastic_body():
    """Two bodies of a cube (x < 1/2: J2, mixed hardening; x > 1/2: elastic, E/2), pulled in x
    with u_y = 0 on y = 1 (a non-homogeneous state): the same reactions and J2 states as with
    the second body a J2 material that never yields (sigma_y = 1e12), to 1e-10; the J2 points
    are those of body a only; the state of every owned cell (b's: zeros) is the same. The same
    with one body of two cell groups (materials by body and by group)."""
    comm = MPI.COMM_WORLD
    ja = J2Material(E=E, nu=NU, sigma_y=SY, H_iso=2e3, H_kin=3e3)
    one, n1, (mesh, ct) = two_body_cube(comm, {"a": ja, "b": LinearElastic(E=E / 2, nu=0.25)})
    two, n2, _ = two_body_cube(comm, {"a": ja, "b": J2Material(E=E / 2, nu=0.25, sigma_y=1e12)})
    # a body of two cell groups: a takes the body's material, b its own
    three, n3, _ = two_body_cube(comm, {"cube": ja, "b": LinearElastic(E=E / 2, nu=0.25)}, groups=1)
    assert np.array_equal(three.points, one.points)
    nq = one.functions["p"].function_space.dofmap.list.shape[1]
    n_owned = mesh.topology.index_map(3).size_local
    cells_a = np.count_nonzero(ct.values[ct.indices < n_owned] == 1)
    assert one.points.shape[0] == cells_a * nq
    assert comm.allreduce(one.points.shape[0], op=MPI.SUM) == 4 * 2 * 2 * 6 // 2 * nq
    assert np.all(one.points[:, 0] < 0.5)
    for strain in (1.5 * EY, 3 * EY, 0.0):
        n1.solve({"x1": strain, "y1": 0.0})
        n2.solve({"x1": strain, "y1": 0.0})
        n3.solve({"x1": strain, "y1": 0.0})
        one.commit()
        two.commit()
        three.commit()
        assert n1.reaction("x1") == pytest.approx(n2.reaction("x1"), rel=1e-10)
        assert n1.reaction("x1") == pytest.approx(n3.reaction("x1"), rel=1e-12)
        assert one.plastic_points > 0 or strain == 0.0
        s1, s2 = one.saved_state(), two.saved_state()  # every owned cell: zeros in b's for `one`
        for k in ("plastic_strain", "backstress", "p"):
            scale = np.abs(s1[k]).max(initial=0.0)
            assert np.allclose(s1[k], s2[k], rtol=1e-10, atol=1e-10 * scale)


def test_plane_stress_accepts_elastic_bodies_only():
    """Plane stress: elastic bodies through kinematics' reduced law (a uniaxial square: the
    reaction is E eps exactly); a J2 body is refused with the reason."""
    comm = MPI.COMM_WORLD
    m = dolfinx.mesh.create_unit_square(comm, 2, 2)
    V = dolfinx.fem.functionspace(m, ("Lagrange", 1, (2,)))
    ctx = context(m, V, "plane_stress", tag_all_cells(m), {"s": (1,)})
    bulk = J2Bulk({"s": LinearElastic(E=E, nu=NU)})
    nw = Newton(
        bulk,
        ctx,
        dolfinx.fem.Function(V),
        {
            "x0": (0, component_dofs(V, 0, near(0, 0.0))),
            "y0": (1, component_dofs(V, 1, near(1, 0.0))),
            "x1": (0, component_dofs(V, 0, near(0, 1.0))),
        },
    )
    nw.solve({"x1": 1e-3})
    assert nw.reaction("x1") == pytest.approx(E * 1e-3, rel=1e-12)
    bad = J2Bulk({"s": J2Material(E=E, nu=NU, sigma_y=SY)})
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    u = dolfinx.fem.Function(V)
    with raised_on_every_rank(PlasticityError, "plane stress needs its own return map", "'s'"):
        bad.forms(u, v, du, ctx)


@pytest.mark.parametrize(
    "materials, tags, words",
    [
        ({"a": ELASTIC}, {"a": (1,), "b": (2,)}, ["bodies without one: ['b']"]),
        ({"a": ELASTIC, "c": ELASTIC}, {"a": (1,)}, ["unknown bodies: ['c']"]),
        ({"a": ELASTIC, "b": ELASTIC}, {"a": (1,), "b": (1,)}, ["share cell tag 1"]),
        ({}, {}, ["no bodies"]),
    ],
)
def test_set_up_errors_name_the_bodies(materials, tags, words):
    m = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)
    V = dolfinx.fem.functionspace(m, ("Lagrange", 1, (2,)))
    ctx = context(m, V, "plane_strain", tag_all_cells(m), tags)
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    with raised_on_every_rank(PlasticityError, *words):
        J2Bulk(materials).forms(dolfinx.fem.Function(V), v, du, ctx)
    with pytest.raises(TypeError, match="body 'a' must be a J2Material or LinearElastic"):
        J2Bulk({"a": (E, NU)})
    with pytest.raises(ValueError, match="quadrature_degree must be an integer >= 1"):
        J2Bulk({"a": LinearElastic(E, NU)}, quadrature_degree=0)
    with pytest.raises(ValueError, match="mode 'plane_strain' needs a 2-D mesh"):
        m3 = dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 1, 1, 1)
        V3 = dolfinx.fem.functionspace(m3, ("Lagrange", 1, (3,)))
        c3 = context(m3, V3, "plane_strain", tag_all_cells(m3), {"a": (1,)})
        J2Bulk({"a": LinearElastic(E, NU)}).forms(
            dolfinx.fem.Function(V3), ufl.TestFunction(V3), ufl.TrialFunction(V3), c3
        )
