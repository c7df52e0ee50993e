"""The interface element on real boundary-value problems (1 and 2 ranks)."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from subfric_dolfinx import meshing
from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.driver import run_case
from subfric_dolfinx.fem import (
    Dirichlet,
    FrictionSolver,
    InterfaceProblem,
    LoadStepper,
    Material,
    Pressure,
    ProblemSettings,
    StepControl,
    StepFailure,
)
from subfric_dolfinx.loading import LoadingProgram
from subfric_dolfinx.logs import PenetrationWarning
from tests.helpers import (
    LAW,
    PROGRAM,
    SEC7_PENALTY,
    block_problem,
    everywhere,
    global_spread,
    jacobian_against_differences,
    prefix,
)

pytestmark = pytest.mark.three_ranks  # FE: run on 3 ranks too (./run test3)

E, P, H = 2.0e4, 300.0, 0.5


def patch_problem(comm, gdim, cell_type, degree=1, partitioner=None, law=LAW, slide=(0.4, 0.3)):
    """Block on an equal base, nu = 0, pressure on top, slide prescribed on top, and the sides
    carrying the exact linear vertical displacement: the exact solution is uniform."""
    if gdim == 2:
        dom, _ = meshing.create_interface_mesh(
            meshing.build_block_on_base,
            comm,
            partitioner=partitioner,
            base_width=1.0,
            block_width=1.0,
            base_height=H,
            block_height=H,
            n_interface=4,
            cell_type=cell_type,
        )
        m_sides, s_sides = ["primary_left", "primary_right"], ["secondary_left", "secondary_right"]
        top_value = slide[:1]
    else:
        dom, _ = meshing.create_interface_mesh(
            meshing.build_pad_on_plate,
            comm,
            partitioner=partitioner,
            plate_size=(1.0, 1.0, H),
            pad_size=(1.0, 1.0, H),
            n_interface=2,
            cell_type=cell_type,
        )
        m_sides = [f"primary_{s}" for s in ("xmin", "xmax", "ymin", "ymax")]
        s_sides = [f"secondary_{s}" for s in ("xmin", "xmax", "ymin", "ymax")]
        top_value = slide
    v = gdim - 1
    ey = -P / E
    un = P / law.alpha_n
    bcs = [Dirichlet("bottom", (0.0,) * gdim)]
    bcs += [Dirichlet(g, lambda x: ey * x[v], component=v, amplitude="press") for g in m_sides]
    bcs += [
        Dirichlet(g, lambda x: ey * H - un + ey * (x[v] - H), component=v, amplitude="press")
        for g in s_sides
    ]
    bcs += [Dirichlet("top", s, component=i, amplitude="slide") for i, s in enumerate(top_value)]
    mats = {"primary": Material(E, 0.0), "secondary": Material(E, 0.0)}
    return InterfaceProblem(
        dom,
        law,
        mats,
        PROGRAM,
        bcs,
        [Pressure("top", P, amplitude="press")],
        settings=ProblemSettings(degree=degree),
    ), top_value


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
@pytest.mark.parametrize(
    ("gdim", "cell_type", "degree"),
    [
        (2, "triangle", 1),
        (2, "quadrilateral", 1),
        (2, "triangle", 2),
        (3, "tetrahedron", 1),
        (3, "hexahedron", 1),
    ],
)
def test_patch_test_equals_the_material_point_driver(gdim, cell_type, degree):
    comm = MPI.COMM_WORLD
    part = "bodies" if comm.size > 1 else None
    prob, top = patch_problem(comm, gdim, cell_type, degree, part)
    if comm.size > 1:  # the partition really splits the pairs across ranks
        assert comm.allreduce(prob.pairs.n_split) == comm.allreduce(prob.interface.n_elements) > 0
    solver = FrictionSolver(prob, prefix("patch"), {"snes_rtol": 1e-12})
    el = prob.interface
    nt = gdim - 1
    hist = []

    def on_step(rec):
        tr, st = el.last.traction, el.state.old
        row = []
        # uniform to the Newton tolerance, on the scales P (tractions), 1 mm (slip) and mu_s;
        # r ~ sqrt(slip) near r = 0 (U(0) = inf) magnifies slip noise, hence its own bound
        tols = [1e-9 * P] * gdim + [1e-9] * nt + [1e-9 * LAW.mu_s, 1e-6]
        for a, tol in zip((*tr.T, *st.up.T, st.mu, st.r), tols, strict=True):
            spread, value = global_spread(comm, a)
            assert spread <= tol, (rec.t, spread, value)
            row.append(value)
        gap = el.last_gap  # uniform too: take its value
        g = [global_spread(comm, gap[:, i])[1] for i in range(gdim)]
        hist.append((rec.t, row, g))

    LoadStepper(solver, 0.125, control=StepControl(dt_max=0.125), on_step=on_step).run()
    assert len(hist) == 40
    # the material-point driver along the same gap history, one step per FE step
    times = [0.0] + [h[0] for h in hist]
    path = [[0.0, 0.0, 0.0, 0.0]] + [[t, g[0], g[1] if nt == 2 else 0.0, g[-1]] for t, _, g in hist]
    case = {
        "params": LAW.parameters(),
        "control": "disp",
        "path": path,
        "t_samples": times[1:],
        "n_tangential": nt,
        "steps_per_mm": 1e-9,
    }
    ref = run_case(case)
    assert ref.n_steps == len(hist) + 1 and ref.complete
    S = ref.samples
    fe = np.array([h[1] for h in hist])
    names = [*["f_t1", "f_t2"][:nt], "f_n", *["up_t1", "up_t2"][:nt], "mu", "r"]
    atol = {"r": 1e-6, "mu": 1e-9 * LAW.mu_s, "up_t1": 1e-9, "up_t2": 1e-9}
    for j, name in enumerate(names):
        np.testing.assert_allclose(
            fe[:, j], S[name], rtol=1e-9, atol=atol.get(name, 1e-9 * P), err_msg=name
        )
    # and the bulk in series: top slide = interface slip + f_t * (h + H) / G, with G = E / 2
    for i in range(nt):
        s_top = np.array([PROGRAM.amplitude("slide", t) * top[i] for t in times[1:]])
        ubar = S[f"ubar_t{i + 1}"]
        np.testing.assert_allclose(s_top, ubar + S[f"f_t{i + 1}"] * 2 * H / (E / 2), atol=1e-9)
    # it did slide, forwards and back, with softening
    assert S["up_t1"].max() > 0.1 and S["up_t1"].min() < -0.1 and S["mu"].min() < 0.5 * LAW.mu_s
    assert everywhere(comm, solver.J.getInfo()["mallocs"] == 0)
    solver.destroy()


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_jacobian_matches_finite_differences_and_newton_is_quadratic():
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    solver = FrictionSolver(prob, prefix("jac"))
    stepper = LoadStepper(solver, 0.1)
    stepper.run(t_end=1.5)
    # a plastic step with a non-uniform state
    counts = stepper.records[-1].counts
    assert counts[Status.PLASTIC.name] > 0
    res = stepper.records[-1].residuals
    # quadratic convergence: an observed order near 2 before round-off takes over
    orders = [
        np.log(res[k + 1] / res[k]) / np.log(res[k] / res[k - 1])
        for k in range(1, len(res) - 1)
        if res[k + 1] > 1e-13 * res[0]
    ]
    assert max(orders) > 1.8, (res, orders)
    # Jacobian at a plastic state of the next step against central differences of the residual
    prob.set_step(1.6, 0.1)
    x = solver.x.copy()
    prob.apply_dirichlet(x)
    rng = np.random.default_rng(comm.rank)
    x.array_w[:] += 1e-3 * rng.standard_normal(x.array_r.size)
    F0 = prob.create_vector()
    prob.residual(x, F0)
    assert comm.allreduce(int(np.count_nonzero(prob.interface.last.status == Status.PLASTIC))) > 0
    J = prob.create_matrix()
    prob.jacobian(x, J)
    for trial in range(3):
        err, nrm = jacobian_against_differences(prob, x, J, rng, 1e-7)
        assert err <= 1e-6 * nrm, (trial, err, nrm)
    solver.destroy()


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_partial_separation_and_recontact():
    comm = MPI.COMM_WORLD
    program = LoadingProgram(
        [0, 1, 2, 3, 4],
        {"press": [0, 1, 1, 1, 1], "slide": [0, 0, 0.5, 0.5, 1.0], "lift": [0, 0, 0, 1, 0]},
    )
    # press by displacement, slide, then lift the left part of the block's top: the contact
    # opens there; lower it again: it closes
    prob = block_problem(
        comm, program=program, lift=lambda x: 0.6 * np.clip((1.25 - x[0]) / 0.75, 0, 1)
    )
    solver = FrictionSolver(prob, prefix("sep"))
    seen = {}

    def on_step(rec):
        el = prob.interface
        tr, st = el.last.traction, el.state.old
        sep = el.last.status == Status.SEPARATED
        assert everywhere(comm, np.all(tr[:, -1] >= 0.0))  # no tension
        assert everywhere(comm, np.all(tr[sep] == 0.0) and np.all(st.r[sep] == 0.0))
        seen[round(rec.t, 6)] = (
            rec.counts[Status.SEPARATED.name],
            sum(rec.counts[s.name] for s in (Status.ELASTIC, Status.PLASTIC, Status.JUMP)),
        )

    LoadStepper(solver, 0.25, on_step=on_step).run()
    n_sep_lifted, _ = seen[3.0]
    n_sep_end, n_contact_end = seen[4.0]
    assert seen[2.0][0] == 0 and n_sep_lifted > 0 and n_sep_end == 0 and n_contact_end > 0
    solver.destroy()


class FlakyLaw:
    """Wraps a law; fails the return map at point 0 of each rank when ``fail(t, dt)`` says so."""

    name = "flaky"

    def __init__(self, law, fail):
        self.law, self.fail, self.t = law, fail, 0.0
        self.alpha_t, self.alpha_n = law.alpha_t, law.alpha_n
        self.variables = law.variables

    def parameters(self):
        return self.law.parameters()

    def initial_state(self, n, nt):
        return self.law.initial_state(n, nt)

    def strength(self, state, f_n, dt=0.0):
        return self.law.strength(state, f_n, dt)

    def return_map(self, gap, state, dt, **kw):
        gap = np.array(gap)
        if self.fail(self.t, dt) and gap.shape[0]:
            gap[0, 0] = np.nan
        return self.law.return_map(gap, state, dt, **kw)


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_a_failed_return_map_is_a_domain_error_and_the_step_is_cut_and_recovered():
    comm = MPI.COMM_WORLD
    # fails for steps longer than 0.15 s once t > 1.2: the stepper must cut and go on
    law = FlakyLaw(LAW, lambda t, dt: t > 1.2 and dt > 0.15)
    prob = block_problem(comm, law=law)
    solver = FrictionSolver(prob, prefix("flaky"))
    orig = prob.set_step

    def set_step(t, dt):
        law.t = t
        orig(t, dt)

    prob.set_step = set_step
    recs = LoadStepper(solver, 0.25).run(t_end=2.0)
    assert any(r.cuts > 0 for r in recs)
    assert all(r.dt <= 0.15 + 1e-12 for r in recs if r.t > 1.2 + 1e-9)
    assert recs[-1].t == pytest.approx(2.0)
    solver.destroy()


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_too_many_cuts_raise_with_the_last_converged_state_intact():
    comm = MPI.COMM_WORLD
    law = FlakyLaw(LAW, lambda t, dt: t > 1.6)
    prob = block_problem(comm, law=law)
    solver = FrictionSolver(prob, prefix("fail"))
    orig = prob.set_step

    def set_step(t, dt):
        law.t = t
        orig(t, dt)

    prob.set_step = set_step
    stepper = LoadStepper(solver, 0.25, control=StepControl(max_cuts=3))
    snapshot = {}

    def on_step(rec):
        snapshot.update(
            t=rec.t,
            u=prob.u.x.array.copy(),
            up=prob.interface.state.old.up.copy(),
            mu=prob.interface.state.old.mu.copy(),
        )

    stepper.on_step = on_step
    with pytest.raises(StepFailure, match=r"no convergence at t = 1\.6") as e:
        stepper.run()
    # cutting got as close to the failing region as it could, then stopped there
    assert 1.5 <= e.value.last_t < 1.6 and e.value.last_t == snapshot["t"] and e.value.t > 1.6
    assert f"step is {e.value.last_step} at t = {e.value.last_t:.6g}" in str(e.value)
    np.testing.assert_array_equal(prob.u.x.array, snapshot["u"])
    np.testing.assert_array_equal(prob.interface.state.old.up, snapshot["up"])
    np.testing.assert_array_equal(prob.interface.state.new.mu, snapshot["mu"])
    np.testing.assert_array_equal(solver.x.array_r, prob.u.x.array[: prob.layout.n_owned])
    solver.destroy()


def test_options_are_read_from_the_options_database():
    """Options under the solver's prefix in PETSc's database (the command line) apply. Bad
    prefixes (empty, in use, ...) are in the catalogue of bad inputs (tests/bad_inputs/)."""
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    name = prefix("opts")
    opts = PETSc.Options()
    opts[name + "ksp_type"] = "gmres"
    opts[name + "pc_type"] = "jacobi"
    try:
        with FrictionSolver(prob, name) as s:
            ksp = s.snes.getKSP()
            assert ksp.getType() == "gmres" and ksp.getPC().getType() == "jacobi"
    finally:
        opts.delValue(name + "ksp_type")
        opts.delValue(name + "pc_type")
