"""The bolted lap joint demo (3-D) at a small size, run in-process on the test's ranks.

* The clamping resultant (the interface's normal resultant) equals the bolt load applied on the
  meshed head annulus, at every step (the upper plate is free in z: nothing else can carry it).
* The shear force is the interface's tangential resultant (x-equilibrium of the upper plate) and
  the lower plate's clamp carries it back (global equilibrium), never exceeds the saturation bound
  mu_s A g(F_b / A) (Jensen: g is concave), and the first stroke slips past the kinetic strength.
* Once mu has softened to its steady sliding value the loop is symmetric: the force at the end of
  a forward stroke is minus the one at the end of the backward stroke.
* On 2 ranks, the history equals a serial run's (on rank 0) to round-off.
"""

import dolfinx
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from demos import bolted_joint
from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import PRESETS
from subfric_dolfinx.scenes import cli
from tests.helpers import everywhere, on_root

N = 6
ARGV = ["--n", str(N), "--amplitude", "1", "--cycles", "2", "--steps", "8", "--no-figures"]
COMPARED = [
    "t",
    "F_t1",
    "F_t2",
    "F_n",
    "f_t_norm",
    "up_norm",
    "up_t1",
    "up_t2",
    "mu",
    "r",
    "f_n",
    "plastic",
    "separated",
    "R_primary_xmin_x",
    "R_primary_xmin_y",
    "R_primary_xmin_z",
    "R_secondary_xmax_x",
    "R_secondary_xmax_y",
    "R_secondary_xmax_z",
]


def column(history, name):
    return np.array([r[name] for r in history])


def group_area(comm, name):
    dom, _ = meshing.create_interface_mesh(
        meshing.build_bolted_lap_joint, comm, **bolted_joint.GEOMETRY, n_interface=N
    )
    ds = ufl.Measure("ds", domain=dom.mesh, subdomain_data=dom.facet_tags)
    one = dolfinx.fem.Constant(dom.mesh, 1.0)
    form = dolfinx.fem.form(one * ds(dom.tag(name)))
    return comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)


def test_the_builder_makes_two_plates_joined_over_the_overlap_minus_the_hole():
    comm = MPI.COMM_WORLD
    g = bolted_joint.GEOMETRY
    dom, info = meshing.create_interface_mesh(
        meshing.build_bolted_lap_joint, comm, **g, n_interface=N
    )
    assert info.h == pytest.approx(g["width"] / N)
    assert set(dom.tags) == {
        "primary",
        "secondary",
        "interface",
        "primary_xmin",
        "secondary_xmax",
        "bolt_head",
        "bolt_nut",
    }
    L, W, t, c = g["plate_length"], g["width"], g["thickness"], g["overlap"]
    assert info.interface_min == pytest.approx((L - c, 0.0, t))
    assert info.interface_max == pytest.approx((L, W, t))
    ds = ufl.Measure("ds", domain=dom.mesh, subdomain_data=dom.interface_side_tags())
    dx = ufl.Measure("dx", domain=dom.mesh, subdomain_data=dom.cell_tags)
    one = dolfinx.fem.Constant(dom.mesh, 1.0)

    def integral(measure):
        return comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * measure)))

    # the two sides of the interface: the same area, the overlap minus the (polygonal) hole
    m, s = integral(ds(dom.tag("primary"))), integral(ds(dom.tag("secondary")))
    assert m == pytest.approx(s, rel=1e-12)
    hole = np.pi * g["hole_radius"] ** 2
    assert c * W - hole < m < c * W - 0.9 * hole
    # each plate: its box minus the hole
    for body in ("primary", "secondary"):
        v = integral(dx(dom.tag(body)))
        assert L * W * t - hole * t < v < L * W * t - 0.9 * hole * t
    assert group_area(comm, "bolt_head") == pytest.approx(group_area(comm, "bolt_nut"), rel=1e-3)


def test_bolted_joint_clamps_saturates_and_is_the_same_on_every_rank(shared_tmp):
    comm = MPI.COMM_WORLD
    res = bolted_joint.main([*ARGV, "--out", str(shared_tmp)], comm)
    h = res.history
    assert res.info["gdim"] == 3
    assert (shared_tmp / "history.csv").is_file()
    t = column(h, "t")
    clamped = t >= bolted_joint.CLAMP_TIME - 1e-9
    preload = 30.0e3  # N, the demo's default

    # clamping: the interface carries exactly the load put on the meshed head annulus
    pressure = preload / bolted_joint.annulus_area()
    applied = pressure * group_area(comm, "bolt_head")
    assert applied == pytest.approx(preload, rel=0.05)  # the polygonal annulus: a few % less
    np.testing.assert_allclose(column(h, "F_n")[clamped], applied, rtol=1e-7)
    assert 0.05 < h[-1]["separated"] < 0.6  # the pressure cone: the overlap's corners open

    # shear force: the interface's tangential resultant, returned by the lower plate's clamp
    R = column(h, "R_secondary_xmax_x")
    scale = np.abs(R).max()
    np.testing.assert_allclose(column(h, "F_t1"), R, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(column(h, "R_primary_xmin_x"), -R, rtol=0, atol=1e-6 * scale)
    # below mu_s A g(F_b / A) always (with the applied load), above the kinetic strength at the
    # first stroke's peak: the joint slipped as a whole
    law = PRESETS["sec7"].law
    A = h[-1]["area"]
    bound = law.mu_s * A * (1.0 - np.exp(-law.c_n * applied / A))
    assert scale <= bound
    assert R.max() > 2.0 * law.mu_k / law.mu_s * bound
    strokes = res.info["strokes"]
    assert [np.sign(f) for _, f in strokes] == [1, -1, 1, -1]
    assert strokes[0][1] == pytest.approx(R.max())
    # the loops shrink as mu softens, then repeat: the steady loop is symmetric
    peaks = np.abs([f for _, f in strokes])
    assert np.all(np.diff(peaks) < 0)
    ends = [R[np.argmin(np.abs(t - t1))] for t1, _ in strokes]
    assert ends[3] == pytest.approx(-ends[2], rel=0.01)
    assert abs(ends[3]) < 0.3 * peaks[0]

    # 2 ranks: the same history as a serial run on rank 0
    if comm.size > 1:

        def serial():
            ser = bolted_joint.main(
                [*ARGV, "--out", str(shared_tmp / "serial")], MPI.COMM_SELF
            ).history
            assert len(ser) == len(h)
            scales = {"F": applied, "R": applied, "f": pressure, "u": 1.0, "m": law.mu_s}
            for name in COMPARED:
                a, b = column(h, name), column(ser, name)
                tol = 1e-8 * scales.get(name[0], 1.0)  # of the quantity's scale
                np.testing.assert_allclose(a, b, rtol=0, atol=tol, err_msg=name)

        on_root(comm, serial)


@pytest.mark.parametrize(
    ("argv", "word"),
    [
        (["--n", "0"], "--n must be at least 1"),
        (["--preload", "-30"], "--preload must be positive"),
    ],
)
def test_bad_demo_arguments_exit_with_code_2(argv, word, capsys):
    comm = MPI.COMM_WORLD
    code = cli.run_main(lambda a: bolted_joint.main(a, comm), argv)
    assert comm.allgather(code) == [cli.EXIT_BAD_INPUT] * comm.size
    err = capsys.readouterr().err
    assert everywhere(comm, comm.rank != 0 or word in err), err
