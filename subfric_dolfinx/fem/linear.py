"""Linear strategies: how :class:`~.solver.FrictionSolver` solves each Newton correction.

Newton stays exact in every strategy (the Krylov method works on the true Jacobian ``J``); they
differ in the preconditioner and in how often it is rebuilt. Measurements behind the choices:
``report/fe_scaling.md`` (written by ``benchmarks/fe_scaling.py``).

``"auto"`` (the default)
    In 3-D, ``"reuse"`` for a problem of :data:`AUTO_REUSE_DOFS_PER_RANK` dofs per rank or more
    and fewer than :data:`AUTO_GAMG_DOFS` dofs in all, ``"gamg"`` otherwise (smaller per rank
    or larger in all); in 2-D ``"reuse"`` at every size (:func:`auto_choice`). Below the
    per-rank threshold MUMPS's fixed costs (analysis, and on several ranks its communicating
    triangular solves) outweigh GAMG's cheap set-up; above it the reused factor's one or two
    GMRES iterations a Newton win or tie; beyond the global threshold the factor's fill and
    set-up grow faster than GAMG's, and only ``"gamg"`` reaches a million dofs in the memory of
    a small machine. The thresholds come from the measurements in ``docs/design.md``
    (*Linear strategies*).
    In 2-D a factorisation grows nearly linearly with the size (nested dissection fill
    ``N log N``): ``"reuse"`` at every size. A 3-D problem between ``AUTO_REUSE_DOFS_PER_RANK``
    and twice that takes ``"reuse"`` on 1 rank and ``"gamg"`` on 2: both are Newton on the same
    Jacobian, their results agree to Newton's tolerance (not to round-off); name the strategy to
    have the same one everywhere.

``"reuse"``
    GMRES (right preconditioning, so its residual is the true one) on ``J``, preconditioned by
    a MUMPS LU of a separate matrix ``P``: a copy of ``J`` taken only when a *refresh* is wanted.
    PETSc refactorises only when ``P`` changes, so one factorisation serves many Newton
    iterations and steps (the bulk stiffness never changes; only the interface blocks do). With
    a soft interface (the Sec. 7 set, alpha = 500 MPa/mm) the factor of the first Jacobian
    serves a whole run of press, peak, softening, reversal and separation at about 2 GMRES
    iterations per solve. Refresh (``P := J`` at the next Jacobian) when

    * the wasted Krylov work exceeds a factorisation: after each solve, the iterations beyond
      those the factor needed right after its last refresh (at its rate then) are counted, and
      when they exceed what one factorisation costs in Krylov iterations, the factor is renewed
      (ski rental: never more than about twice the cost of the best fixed schedule). That price
      is a model of the ratio of a MUMPS factorisation to one GMRES iteration,
      ``20 (N / 5000)^0.38`` for ``N`` dofs (:func:`refresh_price`), not a timing: the
      decisions, hence the results, do not depend on the load of the machine and are the same on
      every rank;
    * or the last solve converged slower than ``rho_stag`` per iteration (near stagnation);
    * or the Krylov solve failed; a Newton solve that failed that way with a stale factor is
      repeated at once with a factor refreshed at each of its Newton iterations (same step, no
      cut: it does what ``"lu"`` would); any failed solve refreshes.

    Where an interface pairs again as the bodies move, its Jacobian changes most between steps (each
    step's search pairs its points anew, a segment further at a steady slide), and in 3-D (the
    compact copy's case, below) a refresh comes at a step's first Jacobian rather than within the
    step when the waste so far and that of the last step (the one expected by the step's end) exceed
    the price: that factor serves all the step's iterations. (Elsewhere the Jacobian changes with
    the interface's state, most within the step where the program turns: the factor of a later
    iterate serves the following steps better.) There the factor also outlives a change of the
    pattern: it is an operator of the right size and a former Jacobian's, a preconditioner of the
    new one like any stale factor, renewed by the same rules (and a Krylov failure with it
    refreshes, as above); ``P`` is the compact copy of ``J`` that ``"lu"`` factorises (below).
    In 2-D a new pattern refreshes, as elsewhere (with both rules a 2-D finite-sliding demo's
    step at a turn failed on PETSc 3.25).

``"lu"``
    A MUMPS LU of ``J`` at every Newton iteration (``ksp_type preonly``): the reference the
    other strategies are compared with. Where the problem's pattern is much wider than the
    Jacobian's entries (a 3-D interface that pairs again as the bodies move holds every pairing
    until its next search: the problem's ``compact_factor``), the LU is of a compact copy of
    ``J``, its entries alone (:class:`CompactCopy`): the same values, a factor with less fill,
    and the symbolic factorisation kept while the entries stay within the copy's pattern
    (``"reuse"`` factorises such a copy too).

``"gamg"``
    GMRES on ``J`` with PETSc's smoothed-aggregation AMG (GAMG) set up on ``P`` with the rigid
    body modes of the whole mesh as near-nullspace (6 in 3-D, 3 in 2-D; per-body modes converge
    worse), refreshed by the same rules. The aggregation drops the couplings weaker than
    ``pc_gamg_threshold`` of the diagonals, chosen per model (:func:`gamg_threshold`): 0.1 on
    the finest level and 0.01 on the coarser ones, but 0.01 on every level on tetrahedra
    (triangles) unless an interface's normal penalty is stiff against its bodies, ``alpha_n h /
    E*`` of at least :data:`STIFF_INTERFACE` (:func:`interface_stiffness`). 0.1 on the finest
    level keeps the aggregates along the strong couplings: on hexahedra and across a stiff
    interface it takes up to a third fewer Krylov iterations than 0.01; 0.01 below keeps the coarse
    levels sparse (0.1 on every level makes them dense on tetrahedra: twice the memory and the
    flops of a cycle). On tetrahedra without a stiff interface 0.1 on the finest level takes as
    many iterations as 0.01 at a quarter more flops (``docs/design.md``). A user's
    ``pc_gamg_threshold`` wins. No factorisation: memory grows linearly with the size. GAMG's
    iterations grow with the model, so GMRES restarts only after 200 (its vectors are allocated
    as it goes: a short solve holds few), and it orthogonalises each new vector twice (classical
    Gram-Schmidt with a second pass, one more reduction an iteration): with PETSc's single pass
    the basis loses its orthogonality over long cycles, the residual GMRES computes by its
    recursion parts from the true one, and GMRES slows down or, at a restart where the two
    differ by a tenth, stops with ``DIVERGED_BREAKDOWN`` (``docs/design.md``). A Krylov failure
    is named, with the option to change, in the solve's result and the step's failure
    (:func:`~.solver.krylov_failure`).

Krylov tolerance (``"reuse"``, ``"gamg"``): tied to Newton's residual so that Newton stays
quadratic, ``eta_k = min(eta_max, c |F_k| / |F_0|)``, never below 1 % of the Newton target over
``|F_k|`` (no oversolving), and at a step's first iteration 1 % of that target (a linear step
then converges in one Newton iteration, as with LU; 1 % rather than 10 % keeps the histories
an order of magnitude closer to LU's: ``docs/design.md``). The target is the largest of
``snes_atol``, ``snes_rtol |F_0|`` and the round-off floor of the convergence test
(:meth:`~.convergence.ScaledConvergence.floor`). ``"gamg"``, whose Krylov iterations are the
run's cost, loosens the first solve of a Newton solve where the previous Newton solve's first
iterate was left above its target (the law's nonlinearity needed a second Newton iteration
there, and likely does here): it aims at ``relax`` = 0.1 times the residual that first iterate
left (taken relative to its target), never above the target itself; solving the linear
system far below the residual the nonlinearity leaves buys nothing. Elsewhere (after a
Newton solve that ended at its first iterate, or failed) the first solve aims at the 1 %.
An iterate from a loosened solve is never the answer: where the convergence test would accept
it, Newton takes one more iteration, whose solve aims at the 1 %
(:attr:`LinearStrategy.loosened`, :class:`~.solver.FrictionSolver`). So the last Krylov solve
of every Newton solve, hence the accuracy of the converged state and its agreement between
rank counts, is that of the 1 %.

Every default is overridden by the options database or the solver's options (e.g.
``-<prefix>ksp_type``, ``-<prefix>pc_type``, ``-<prefix>ksp_rtol`` -- the last one, or
``snes_ksp_ew``, replaces the tied tolerance; ``ksp_type preonly`` makes ``"reuse"`` refresh at
every Newton iteration, i.e. exact LU).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

__all__ = [
    "AUTO_GAMG_DOFS",
    "AUTO_REUSE_DOFS_PER_RANK",
    "GAMG_THRESHOLD",
    "GAMG_THRESHOLD_SOFT_SIMPLICES",
    "SIMPLICES",
    "STIFF_INTERFACE",
    "STRATEGIES",
    "STRATEGY_OPTIONS",
    "LinearStrategy",
    "auto_choice",
    "choose_strategy",
    "gamg_threshold",
    "interface_stiffness",
    "make_strategy",
    "rigid_modes",
    "strategy_options",
]

_KRYLOV = {"ksp_type": "gmres", "ksp_pc_side": "right", "ksp_norm_type": "unpreconditioned"}
STRATEGY_OPTIONS: dict[str, dict[str, Any]] = {
    "reuse": {
        **_KRYLOV,
        "ksp_gmres_restart": 60,
        "ksp_max_it": 60,
        "pc_type": "lu",
        "pc_factor_mat_solver_type": "mumps",
    },
    "lu": {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"},
    "gamg": {
        **_KRYLOV,
        "ksp_gmres_restart": 200,
        "ksp_gmres_cgs_refinement_type": "refine_always",
        "ksp_max_it": 300,
        "pc_type": "gamg",
    },
}
"""PETSc options of each strategy (defaults: the database and the solver's options win); a
problem's own are :func:`strategy_options` (``"gamg"``'s threshold chosen for the model)."""
STRATEGIES = tuple(STRATEGY_OPTIONS)
"""The strategies; ``"auto"`` (:func:`choose_strategy`) stands for one of them."""
AUTO_GAMG_DOFS = 75_000
"""``"auto"`` picks ``"gamg"`` for 3-D problems of at least this many dofs (module docstring)."""
AUTO_REUSE_DOFS_PER_RANK = 30_000
"""``"auto"`` picks ``"gamg"`` for 3-D problems of fewer dofs than this per rank (docstring)."""
GAMG_THRESHOLD: tuple[float, ...] = (0.1, 0.01)
"""``pc_gamg_threshold`` of ``"gamg"``: the finest level's, then every coarser level's
(:func:`gamg_threshold`)."""
GAMG_THRESHOLD_SOFT_SIMPLICES: tuple[float, ...] = (0.01,)
"""``pc_gamg_threshold`` of ``"gamg"`` on triangles and tetrahedra without a stiff interface,
every level (:func:`gamg_threshold`)."""
SIMPLICES = ("triangle", "tetrahedron")
"""The cell types :data:`GAMG_THRESHOLD_SOFT_SIMPLICES` is for."""
STIFF_INTERFACE = 0.1
"""An interface is stiff for GAMG from this ``alpha_n h / E*`` up (:func:`interface_stiffness`)."""


def auto_choice(gdim: int, dofs: int, ranks: int) -> str:
    """The strategy ``"auto"`` takes for a problem of ``gdim`` dimensions, ``dofs`` over ``ranks``.

    In 3-D ``"reuse"`` from :data:`AUTO_REUSE_DOFS_PER_RANK` dofs per rank up to (not including)
    :data:`AUTO_GAMG_DOFS` dofs in all, ``"gamg"`` outside; in 2-D ``"reuse"`` (the module
    docstring gives the measurements behind it).
    """
    if gdim != 3:
        return "reuse"
    if dofs >= AUTO_GAMG_DOFS or dofs < AUTO_REUSE_DOFS_PER_RANK * ranks:
        return "gamg"
    return "reuse"


def choose_strategy(name: str, problem) -> str:
    """The strategy ``name`` stands for: ``"auto"`` chosen by :func:`auto_choice`, else itself.

    ``"auto"`` counts the dofs over all ranks and the ranks of the problem's communicator: the
    same choice on every rank. With a finite-sliding interface (pairs made at every iterate) it
    takes ``"reuse"`` (MUMPS) below :data:`AUTO_GAMG_DOFS` where :func:`auto_choice` says
    ``"gamg"``: GMRES preconditioned by GAMG breaks down on that tangent.

    Raises:
        ValueError: An unknown name (the known ones listed).
    """
    if name == "auto":
        dofs = problem.global_dofs
        choice = auto_choice(problem.gdim, dofs, problem.comm.size)
        if choice == "gamg" and problem.repairs and dofs < AUTO_GAMG_DOFS:
            # GMRES on GAMG breaks down on a finite-sliding tangent (docs/design.md)
            return "reuse"
        return choice
    if name not in STRATEGY_OPTIONS:
        raise ValueError(f"unknown linear strategy {name!r}; known: {['auto', *STRATEGIES]}")
    return name


def interface_stiffness(problem) -> float | None:
    """The stiffest interface's normal penalty over its bodies' stiffness at one element's scale.

    ``alpha_n h / E*`` per interface, ``h`` its mean facet's size (the square root of its area
    in 3-D, its length in 2-D), ``E*`` the contact modulus of its two bodies
    (:func:`.validity.interface_modulus`): the penalty against the stiffness ``E*/h`` of one
    interface element of the bodies. The largest over the interfaces whose ``E*`` is known;
    ``None`` if none is (a user bulk law). The same on every rank (collective: one all-reduce).
    """
    from .validity import interface_modulus

    interfaces = getattr(problem, "interfaces", None) or {}
    names = list(interfaces)
    local = np.zeros(2 * len(names))
    for i, name in enumerate(names):
        weights = np.asarray(interfaces[name].law_points.facet_weights)
        local[2 * i] = weights.shape[0] if weights.size else 0
        local[2 * i + 1] = float(weights.sum())
    total = problem.comm.allreduce(local)
    fdim = max(problem.gdim - 1, 1)
    found = []
    for i, name in enumerate(names):
        modulus = interface_modulus(problem, name)
        count, area = total[2 * i], total[2 * i + 1]
        if modulus is None or count <= 0 or area <= 0:
            continue
        h = (area / count) ** (1.0 / fdim)
        found.append(float(interfaces[name].law.alpha_n) * h / modulus)
    return max(found) if found else None


def gamg_threshold(cell: str, stiffness: float | None) -> tuple[float, ...]:
    """``pc_gamg_threshold`` of ``"gamg"`` for ``cell``-s and an interface ``stiffness``.

    ``stiffness``: the stiffest interface's (:func:`interface_stiffness`; ``None``: unknown).
    Per level from the finest, the last value serving the coarser levels:
    :data:`GAMG_THRESHOLD_SOFT_SIMPLICES` on :data:`SIMPLICES` where no interface reaches
    :data:`STIFF_INTERFACE` (or the stiffness is unknown), :data:`GAMG_THRESHOLD` otherwise
    (hexahedra and quadrilaterals at every stiffness; other cells, unmeasured, as they). The
    module docstring gives the reasons, ``docs/design.md`` the measurements.
    """
    stiff = stiffness is not None and stiffness >= STIFF_INTERFACE
    if cell in SIMPLICES and not stiff:
        return GAMG_THRESHOLD_SOFT_SIMPLICES
    return GAMG_THRESHOLD


def strategy_options(name: str, problem) -> dict[str, Any]:
    """The PETSc options of strategy ``name`` for ``problem``.

    :data:`STRATEGY_OPTIONS`, and for ``"gamg"`` the thresholds :func:`gamg_threshold` chooses
    for the problem's cells and interfaces (:func:`interface_stiffness`).

    Collective for ``"gamg"``. Defaults: the options database and the solver's options win
    over them.

    Raises:
        ValueError: An unknown name (the known ones listed).
    """
    if name not in STRATEGY_OPTIONS:
        raise ValueError(f"unknown linear strategy {name!r}; known: {list(STRATEGIES)}")
    options = dict(STRATEGY_OPTIONS[name])
    if name == "gamg":
        cell = problem.V.mesh.topology.cell_type.name
        levels = gamg_threshold(cell, interface_stiffness(problem))
        options["pc_gamg_threshold"] = ",".join(f"{v:g}" for v in levels)
    return options


_REFRESH = {  # refresh policy and forcing term: cost factor, rho_stag, forcing c
    "reuse": {"cost": 1.0, "rho_stag": 0.5, "c": 1e-2, "relax": 0.0},
    "gamg": {"cost": 1.0, "rho_stag": 0.9, "c": 1e-3, "relax": 0.1},
}


def refresh_price(name: str, dofs: int) -> float:
    """A preconditioner set-up in Krylov iterations (the cost rule's price; module docstring).

    MUMPS LU (``"reuse"``): ``20 (N / 5000)^0.38``, at least 10; GAMG: 50 (both fitted to
    timings of set-ups and iterations: ``docs/design.md``, *Linear strategies*).
    """
    if name == "gamg":
        return 50.0
    return max(10.0, 20.0 * (max(dofs, 1) / 5000.0) ** 0.38)


_ETA_MAX = 0.1
_ETA_MIN = 1e-12
_TARGET_FRACTION = 0.01  # the Krylov solve aims at this fraction of Newton's target


def nonzeros(A: PETSc.Mat) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The owned rows of ``A`` without their explicit zeros: CSR with global columns.

    The diagonal is kept, zero or not.
    """
    indptr, cols, vals = A.getValuesCSR()
    n = indptr.size - 1
    rows = np.repeat(np.arange(n), np.diff(indptr))
    keep = (vals != 0.0) | (cols == rows + A.getOwnershipRange()[0])
    counts = np.bincount(rows[keep], minlength=n)
    kept = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
    return kept, cols[keep], vals[keep]


class CompactCopy:
    """A copy of a matrix without its explicit zeros, to factorise (collective methods).

    The pattern of a problem whose interfaces pair again as the bodies move holds every
    coupling a pairing may take until the next search (:mod:`.interface.finite.reach`), far more
    than one Jacobian's entries; a factorisation of the matrix as stored orders and fills that
    whole pattern. The copy holds the entries of the Jacobian it was made from; a later Jacobian
    whose entries it holds is copied into it (the same pattern: PETSc keeps the symbolic
    factorisation), another one makes a new copy (a new symbolic factorisation). Its values
    are those of the Jacobian: its factor solves the same equations.

    Attributes:
        P: The copy (``None`` before the first :meth:`update`).
        patterns: How many patterns it took (symbolic factorisations).
    """

    def __init__(self) -> None:
        self.P: PETSc.Mat | None = None
        self.patterns = 0
        self._keys: np.ndarray | None = None
        self._retired: PETSc.Mat | None = None  # the former copy, still the SNES's until rebound

    def update(self, J: PETSc.Mat) -> bool:
        """Copy the entries of ``J``; whether :attr:`P` is a new matrix (collective)."""
        if self._retired is not None:
            self._retired.destroy()
            self._retired = None
        indptr, cols, vals = nonzeros(J)
        n_cols = J.getSize()[1]
        rows = np.repeat(np.arange(indptr.size - 1, dtype=np.int64), np.diff(indptr))
        keys = rows * n_cols + cols  # sorted: rows in order, columns sorted in each
        held = self._keys
        fits = held is not None and bool(
            keys.size == 0
            or (
                held.size > 0
                and np.all(held[np.minimum(np.searchsorted(held, keys), held.size - 1)] == keys)
            )
        )
        comm = J.getComm().tompi4py()
        if self.P is not None and comm.allreduce(int(fits), op=MPI.MIN):
            self.P.zeroEntries()
            self.P.setValuesCSR(indptr, cols, vals)
            self.P.assemble()
            return False
        self._retired = self.P
        P = PETSc.Mat().createAIJ(J.getSizes(), csr=(indptr, cols, vals), comm=J.getComm())
        P.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        P.assemble()
        self.P, self._keys = P, keys
        self.patterns += 1
        return True

    def destroy(self) -> None:
        """Free the copies (safe to call more than once)."""
        for m in (self.P, self._retired):
            if m is not None:
                m.destroy()
        self.P = self._retired = None
        self._keys = None


def rigid_modes(problem) -> PETSc.NullSpace:
    """The rigid-body modes of the whole mesh (3 in 2-D, 6 in 3-D) as a near-nullspace.

    Orthonormal, on the layout of the problem's vectors (collective).
    """
    V = problem.V
    gdim = problem.gdim
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n, :gdim]
    x = x - problem.comm.allreduce(x.sum(axis=0)) / max(problem.comm.allreduce(n), 1)
    vecs: list[PETSc.Vec] = []
    rotations = [(0, 1)] if gdim == 2 else [(1, 2), (2, 0), (0, 1)]
    for k in range(gdim + len(rotations)):
        v = problem.create_vector()
        a = v.array_w.reshape(n, V.dofmap.bs)
        a[:] = 0.0
        if k < gdim:
            a[:, k] = 1.0
        else:
            i, j = rotations[k - gdim]
            a[:, i] = -x[:, j]
            a[:, j] = x[:, i]
        for w in vecs:  # modified Gram-Schmidt
            v.axpy(-v.dot(w), w)
        v.normalize()
        vecs.append(v)
    return PETSc.NullSpace().create(vectors=vecs, comm=problem.comm)


class LinearStrategy:
    """One strategy's state and hooks, called by :class:`~.solver.FrictionSolver`.

    Args:
        name: One of :data:`STRATEGIES`.
        problem: The problem (its matrices and layout).
    """

    def __init__(self, name: str, problem) -> None:
        if name not in STRATEGY_OPTIONS:
            raise ValueError(f"unknown linear strategy {name!r}; known: {list(STRATEGIES)}")
        self.name = name
        self.problem = problem
        self.policy = dict(_REFRESH[name]) if name in _REFRESH else None
        self.P: PETSc.Mat | None = None
        self.nullspace: PETSc.NullSpace | None = None
        # a factorisation on a pattern much wider than the Jacobian's entries: the factor's
        # matrix is a compact copy (the SNES's preconditioning matrix; ``rebind``: a new one
        # since the last Jacobian)
        compact = bool(getattr(problem, "compact_factor", False))
        factor = name in ("lu", "reuse")
        self.compact = CompactCopy() if factor and compact else None
        self.rebind = False
        if self.policy is not None and self.compact is None:
            self.P = problem.create_matrix()
        if name == "gamg":
            assert self.P is not None  # (gamg has a refresh policy: P is made above)
            self.nullspace = rigid_modes(problem)
            self.P.setNearNullSpace(self.nullspace)
        if self.policy is not None:
            dofs = problem.global_dofs
            self.policy["price"] = refresh_price(name, dofs)
        # counts over the solver's life
        self.refreshes = 0
        self.retries = 0
        self.held = 0  # Newton iterations taken because a loosened solve's iterate was not accepted
        self.loosened_solves = 0
        self.krylov = 0
        self.solves = 0
        # state
        self.force = True  # refresh at the next Jacobian
        self.exact = False  # ksp preonly: refresh at every Newton iteration
        self._fresh_each = False  # the same, for one Newton solve (a retry)
        self.forcing = self.policy is not None
        self._pending: tuple[float, bool] | None = None  # (|b|, refreshed)
        self._stale_failure = False
        self._f0 = 0.0
        self._target = 0.0  # Newton's target in the current Newton solve
        self._first = 0.0  # |F_1| / target of the last Newton solve (0: none, or it failed)
        self.loosened = False
        """The last Krylov solve was a loosened first solve (module docstring): its iterate is
        not to be accepted."""
        self._waste = 0.0
        self._solve_waste = 0.0  # of this Newton solve, since its last refresh
        self._last_waste = 0.0  # of the last Newton solve, since its last refresh
        self._rho_fresh: float | None = None

    # -- set-up ---------------------------------------------------------------------------------
    def configure(self, snes: PETSc.SNES, user_keys: set[str]) -> None:
        """After ``setFromOptions``: read what the user chose.

        ``user_keys``: the option names given by the user under the prefix, without it.
        """
        ksp = snes.getKSP()
        self.exact = ksp.getType() == "preonly"
        self.forcing = (
            self.policy is not None
            and not self.exact
            and "ksp_rtol" not in user_keys
            and "snes_ksp_ew" not in user_keys
        )
        ksp.setConvergenceHistory(reset=True)

    def new_pattern(self) -> None:
        """The problem's matrix pattern changed.

        ``"reuse"`` on a compact copy (3-D) keeps its factor: the former Jacobian's factor still
        preconditions the new one (an interface pairs again a segment further), until the refresh
        rules ask for a new one (the copy takes the new entries then). Otherwise a new ``P`` on
        the new pattern, refreshed at the next use.
        """
        if self.compact is not None:  # ("lu" refactorises at every iteration anyway)
            return
        if self.P is not None:
            self.P.destroy()
            self.P = self._new_P()
        self.force = True

    def _new_P(self) -> PETSc.Mat:
        P = self.problem.create_matrix()
        if self.nullspace is not None:
            P.setNearNullSpace(self.nullspace)
        return P

    def matrices(self, J: PETSc.Mat) -> tuple[PETSc.Mat, PETSc.Mat]:
        """The operator and the preconditioning matrix to give SNES."""
        if self.compact is not None and self.compact.P is not None:
            return J, self.compact.P
        return J, (self.P if self.P is not None else J)

    # -- hooks ----------------------------------------------------------------------------------
    def start(self, fresh: bool = False) -> None:
        """Before a Newton solve (``fresh``: refresh at each of its Newton iterations)."""
        self._fresh_each = fresh
        self._last_waste, self._solve_waste = self._solve_waste, 0.0
        self._pending = None
        self.loosened = False
        self._stale_failure = False

    def jacobian(
        self, snes: PETSc.SNES, J: PETSc.Mat, floor: float, reference: float = 0.0
    ) -> None:
        """After ``J`` is assembled: refresh ``P`` if wanted, set the Krylov tolerance.

        ``floor``: the residual the convergence test accepts at the round-off floor (0 if
        none); Newton's target is the largest of it, ``snes_atol`` and ``snes_rtol |F_0|``,
        where ``|F_0|`` is at least ``reference`` (the residual of the step's start without
        the predictor's extrapolation, 0 without one).
        """
        self.linear_done(snes)
        if self.policy is None:  # "lu": P is J (or its compact copy), factorised every iteration
            if self.compact is not None:
                self.rebind = self.compact.update(J)
            self._pending = (0.0, True)
            return
        k = snes.getIterationNumber()
        fnorm = snes.getFunctionNorm()
        if k == 0:
            self._f0 = max(fnorm, reference)
        elif k == 1 and self._target > 0:
            self._first = fnorm / self._target
        refresh = self.force or self.exact or self._fresh_each
        if k == 0 and self.compact is not None:
            # a step's start: refresh now if the waste expected by its end (that of the last
            # step) would exceed a factorisation, rather than at a Jacobian within the step
            refresh = refresh or self._wasteful(self._waste + self._last_waste)
        if refresh:
            self._refresh(J)
            self.refreshes += 1
            self.force = False
            self._waste, self._solve_waste, self._rho_fresh = 0.0, 0.0, None
        if self.forcing:
            rtol, atol, _, max_it = snes.getTolerances()
            target = max(atol, rtol * self._f0, floor)
            if k == 0:
                self._target = target
            eta, self.loosened = self._eta(k, fnorm, target, max_it > 1)
            self.loosened_solves += self.loosened
            snes.getKSP().setTolerances(rtol=eta)
        else:
            self.loosened = False
        self._pending = (fnorm, refresh)

    def _refresh(self, J: PETSc.Mat) -> None:
        """``P := J`` (its compact copy, or a copy on ``J``'s pattern); ``rebind`` if new."""
        if self.compact is not None:
            self.rebind = self.compact.update(J) or self.rebind
            return
        assert self.P is not None  # (a strategy with a refresh policy)
        J.copy(self.P, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)

    def _eta(self, k: int, fnorm: float, target: float, loosen: bool) -> tuple[float, bool]:
        """The Krylov rtol at Newton iteration ``k``, and whether it is a loosened first solve.

        ``loosen``: a first solve may be loosened (Newton may take a second iteration).
        """
        if fnorm <= 0:
            return _ETA_MAX, False
        floor = _TARGET_FRACTION * target / fnorm
        assert self.policy is not None  # (forcing: a strategy with a policy)
        if k == 0:
            aim = self.policy["relax"] * self._first if loosen and self._first > 1.0 else 0.0
            eta = max(min(1.0, aim) * target / fnorm, floor)
        else:
            eta = max(min(_ETA_MAX, self.policy["c"] * fnorm / self._f0), floor)
        eta = min(max(eta, _ETA_MIN), _ETA_MAX)
        return eta, k == 0 and eta > min(max(floor, _ETA_MIN), _ETA_MAX)

    def linear_done(self, snes: PETSc.SNES) -> None:
        """After a Krylov solve: count it, decide whether to refresh.

        Called at the next residual, Jacobian, or the end of the Newton solve; acts once per
        Krylov solve.
        """
        if self._pending is None:
            return
        b, refreshed = self._pending
        self._pending = None
        ksp = snes.getKSP()
        its = ksp.getIterationNumber()
        self.krylov += its
        self.solves += 1
        if ksp.getConvergedReason() < 0:
            self.force = True
            self._stale_failure = not refreshed
            return
        if self.policy is None:
            return
        hist = ksp.getConvergenceHistory()
        r0 = hist[0] if len(hist) else b
        red = hist[-1] / r0 if len(hist) > 1 and r0 > 0 else 0.0
        rate = red ** (1.0 / its) if its > 0 and red > 0 else 0.0
        if refreshed or self._rho_fresh is None:
            self._rho_fresh = min(max(rate, 1e-300), 0.5)
        elif its > 0 and red > 0:
            fresh = max(1.0, math.log(red) / math.log(self._rho_fresh))
            self._waste += max(0.0, its - fresh)
            self._solve_waste += max(0.0, its - fresh)
        # every quantity here is global (the same on every rank): so is the decision
        stagnating = rate > self.policy["rho_stag"]
        wasteful = self._wasteful(self._waste)
        self.force = self.force or stagnating or wasteful

    def _wasteful(self, waste: float) -> bool:
        assert self.policy is not None  # (a strategy with a refresh policy)
        return waste > self.policy["cost"] * self.policy["price"]

    def finish(self, snes: PETSc.SNES, converged: bool) -> bool:
        """After a Newton solve: whether to repeat it at once with a fresh preconditioner.

        True when it failed in a Krylov solve with a stale one.
        """
        self.linear_done(snes)
        if not converged:
            self._first = 0.0
        elif snes.getIterationNumber() == 1 and self._target > 0:
            self._first = snes.getFunctionNorm() / self._target
        if converged or self.policy is None:
            return False
        self.force = True  # a failed solve refreshes
        reason = snes.getConvergedReason()
        return reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE and self._stale_failure

    @property
    def stats(self) -> dict[str, Any]:
        """Counts over the solver's life.

        ``refreshes`` (preconditioner rebuilt from ``J``), ``retries`` (Newton solves repeated
        with a fresh one), ``loosened`` (first Krylov solves of a Newton solve loosened),
        ``held`` (Newton iterations taken where the convergence test would have accepted the
        iterate of a loosened Krylov solve), ``krylov`` iterations and ``solves`` (Krylov
        solves).
        """
        return {
            "strategy": self.name,
            "refreshes": self.refreshes,
            "retries": self.retries,
            "held": self.held,
            "loosened": self.loosened_solves,
            "krylov": self.krylov,
            "solves": self.solves,
        }

    def destroy(self) -> None:
        """Free the PETSc objects (safe to call more than once)."""
        for name in ("P", "nullspace", "compact"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)


def make_strategy(name: str, problem) -> LinearStrategy:
    """The strategy ``name`` (one of :data:`STRATEGIES`) for ``problem``.

    Raises:
        ValueError: An unknown name (the known ones listed).
    """
    return LinearStrategy(name, problem)
