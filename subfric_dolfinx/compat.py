"""What differs between the DOLFINx versions this package supports, in one place.

Supported: DOLFINx 0.9 (Debian 13 "trixie": PETSc 3.22, Python 3.13) and DOLFINx 0.11 (Debian
sid: PETSc 3.25, Python 3.14). The rest of the package calls the functions below instead of
testing the version itself. Each difference was read in the installed sources of both versions
(``dolfinx/io/gmshio.py`` vs ``dolfinx/io/gmsh.py``, ``dolfinx/la.py`` vs ``dolfinx/la/petsc.py``,
``dolfinx/mesh.py``, ``dolfinx/graph.py``, the nanobind signatures of ``dolfinx.cpp``):

- gmsh model to mesh: ``io.gmshio.model_to_mesh`` returns ``(mesh, cell_tags, facet_tags)``
  (0.9); ``io.gmsh.model_to_mesh`` returns a ``MeshData`` named tuple (0.11).
- PETSc vector of an index map: ``la.create_petsc_vector(im, bs)`` (0.9);
  ``la.petsc.create_vector([(im, bs)])`` (0.11).
- Index map with ghosts: ``IndexMap(comm, n, ghosts, owners)`` (0.9); the same with the MPI
  ``tag`` of its set-up communication (0.11).
- ``create_submesh``: the parent entity of each sub-mesh cell as an array (0.9); an ``EntityMap``
  that maps them on demand (0.11).
- ``graph.adjacencylist``: the C++ adjacency list (0.9); a Python wrapper (0.11), while a cell
  partitioner must still return the C++ object.
- Default cell partitioner: ``create_cell_partitioner(mode)`` (0.9);
  ``create_cell_partitioner(mode, max_facet_to_cell_links)`` (0.11).
- Geometry of a mesh of one cell type: ``geometry.dofmap`` and ``geometry.cmap`` (0.9);
  ``geometry.dofmaps[0]`` and ``geometry.cmaps[0]`` (0.11, the former deprecated).
- Interpolation points of a space's element: ``element.interpolation_points()`` (0.9); a
  property, ``element.interpolation_points`` (0.11).
- ``geometry.bb_tree``: ``entities`` is the third positional argument (0.9), keyword-only (0.11).
- SNES's reason for a NaN or infinite residual: ``DIVERGED_FNORM_NAN`` (petsc4py 3.22),
  ``DIVERGED_FUNCTION_NANORINF`` (3.25; the value, -4, is the same): :data:`SNES_DIVERGED_NAN`.
- ``Expression.eval`` on cells: an array ``(cells, points * value_size)`` (0.9);
  ``(cells, points, *value_shape)`` (0.11). The memory order is the same.
- ``mesh.create_mesh``: ``(comm, cells, x, element)`` (0.9); ``(comm, cells, element, x)`` (0.11).
- ``mesh.refine``: its partitioner defaults to DOLFINx's graph partitioner (0.9: the refined cells
  are redistributed) or to an identity placeholder (0.11); ``None`` keeps every refined cell on
  its parent's rank in both, which the transfer of facet tags (``transfer_meshtag``) requires.
  Its ``option`` defaults to none (0.9) or to the parent cells (0.11): :func:`refine_uniform`
  asks for both parents.
- The graph partitioner: both stacks' DOLFINx call PT-Scotch with a fixed seed, but sid's Scotch
  (7.0.16) partitions with threads and gives a different partition from call to call (a 2-rank
  block mesh: 162 or 164 owned dofs on rank 0, 152 once; trixie's 7.0.7 always 162). One thread
  (``SCOTCH_PTHREAD_NUMBER=1``, read at each call) makes it repeatable:
  :func:`repeatable_partitions`, for whoever needs two meshes partitioned alike (the test suite
  sets the variable). It is not the default: the one-thread partition can be worse for the
  solver (see the function).
- PETSc's multiple inner product ``VecMDot`` (GMRES's Gram-Schmidt): from PETSc 3.21 (both
  stacks) it calls BLAS ``gemv`` on vectors that happen to lie one after the other in memory, so
  that the same solve rounds differently from run to run; :func:`petsc_vector` makes its vectors
  under :func:`repeatable_vectors`, which turns that off.
- ``SNES.setFunctionDomainError``: missing in petsc4py 3.22, present from 3.23 (handled in
  :mod:`subfric_dolfinx.fem._petsc`, the one place that calls PETSc beyond petsc4py).
- DOLFINx's own nonlinear solver: ``fem.petsc.NonlinearProblem`` with ``nls.petsc.NewtonSolver``
  (0.9: the problem's ``F(x, b)`` and ``J(x, A)`` are methods, the solver a C++ Newton loop);
  ``fem.petsc.NonlinearProblem`` is a PETSc SNES with ``assemble_residual`` and
  ``assemble_jacobian`` callbacks (0.11; the Newton-solver pair is deprecated there).
  :func:`dolfinx_newton` hides it.

Everything else the package uses (forms, assembly into a given matrix, ``Expression`` objects,
``Function.eval``, VTX/XDMF writers, geometry searches, ``SparsityPattern``) has the same
signature in both versions.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Mapping
from typing import Any, cast

import dolfinx
import dolfinx.common
import dolfinx.cpp
import dolfinx.fem
import dolfinx.graph
import dolfinx.la
import dolfinx.mesh
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

__all__ = [
    "DOLFINX_VERSION",
    "REPEATABLE_VECTOR_OPTIONS",
    "SNES_DIVERGED_NAN",
    "SUPPORTED",
    "adjacency_list",
    "coordinate_element",
    "create_mesh",
    "create_submesh",
    "default_partitioner",
    "dolfinx_newton",
    "eval_expression",
    "geometry_dofmap",
    "ghosted_index_map",
    "interpolation_points",
    "model_to_mesh",
    "petsc_vector",
    "pushed_options",
    "read_from_msh",
    "refine_uniform",
    "repeatable_partitions",
    "repeatable_vectors",
]


def _version(text: str) -> tuple[int, int]:
    major, minor = text.split(".")[:2]
    return int(major), int(minor)


DOLFINX_VERSION: tuple[int, int] = _version(dolfinx.__version__)
"""(major, minor) of the DOLFINx in use."""

SUPPORTED: tuple[tuple[int, int], ...] = ((0, 9), (0, 11))
"""The DOLFINx versions the package is tested with (0.10 is not: between the two, untested)."""

_NEW = DOLFINX_VERSION >= (0, 10)

if _NEW:
    import dolfinx.io.gmsh as _gmsh_io
    import dolfinx.la.petsc as _la_petsc
else:  # pragma: no cover - the other stack's branch
    import dolfinx.io.gmshio as _gmsh_io

    _la_petsc = None


_SCOTCH_THREADS = "SCOTCH_PTHREAD_NUMBER"


@contextlib.contextmanager
def repeatable_partitions() -> Iterator[None]:
    """Within the block, PT-Scotch partitions a graph the same way at every call.

    A threaded Scotch (Debian sid's) gives a different partition of the same mesh from one call to
    the next, so that two runs of a script, or two problems built in one process, number and place
    their dofs differently; one thread makes it repeatable. Building the mesh costs the same, but
    the partition differs, and the solver may pay for it (a larger MUMPS factor:
    ``docs/design.md``, *Repeatable partitions*). Hence opt-in, not the package's default.
    The variable is set only if the user has not set it, and restored afterwards.
    """
    if _SCOTCH_THREADS in os.environ:
        yield
        return
    os.environ[_SCOTCH_THREADS] = "1"
    try:
        yield
    finally:
        os.environ.pop(_SCOTCH_THREADS, None)


def model_to_mesh(
    model,
    comm: MPI.Comm,
    rank: int,
    gdim: int,
    partitioner: Callable | None = None,
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """A distributed mesh and its cell and facet tags from the gmsh model on rank ``rank``.

    ``dolfinx.io.gmshio.model_to_mesh`` (0.9) or ``dolfinx.io.gmsh.model_to_mesh`` (0.11, whose
    ``MeshData`` also holds ridge and peak tags, not used here).
    """
    out = _gmsh_io.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
    if _NEW:  # (0.11's MeshData: tags None without groups of that dimension: see _tags)
        return out.mesh, _tags(out.cell_tags), _tags(out.facet_tags)
    return out


def _tags(tags: dolfinx.mesh.MeshTags | None) -> dolfinx.mesh.MeshTags:
    """Tags of DOLFINx 0.11's ``MeshData``, typed as 0.9's (always given there).

    0.11 gives ``None`` where the model has no physical group of that dimension, 0.9 empty
    tags: passed on as they are (the package's meshes have cell and facet groups).
    """
    return cast(dolfinx.mesh.MeshTags, tags)


def read_from_msh(
    path, comm: MPI.Comm, gdim: int, rank: int = 0
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """DOLFINx's own reader of an MSH file: the mesh and its cell and facet tags.

    ``io.gmshio.read_from_msh`` (0.9) or ``io.gmsh.read_from_msh`` (0.11, a ``MeshData``).
    """
    out = _gmsh_io.read_from_msh(str(path), comm, rank, gdim=gdim)
    if _NEW:  # (0.11's MeshData: tags None without groups of that dimension: see _tags)
        return out.mesh, _tags(out.cell_tags), _tags(out.facet_tags)
    return out


REPEATABLE_VECTOR_OPTIONS: dict[str, str] = {"vec_mdot_use_gemv": "0", "vec_maxpy_use_gemv": "0"}
"""PETSc's options (global, no prefix) under which :func:`petsc_vector` makes its vectors.

A vector takes its operations when it is made, and its duplicates inherit them: the work vectors
of SNES and the Krylov basis of GMRES, which are duplicates of the solution vector. With
``vec_mdot_use_gemv`` on (PETSc's default since 3.21: both stacks), ``VecMDot`` (GMRES's
Gram-Schmidt) treats vectors that lie one after the other in memory, at most 64 entries apart, as
the columns of one matrix and calls BLAS ``gemv``, which sums in another order than the
vector-by-vector product. Vectors made one by one (PETSc's ghosted vectors and their duplicates)
are so placed or not as ``malloc`` finds room, which depends on everything the process allocated
before (the hash seed of Python's strings, the addresses of objects): the same solve of the same
data rounds differently from run to run, and Newton's stopping tests may then take another number
of iterations. ``VecMAXPY`` has the same choice (off by default). With both off, these products do
not depend on where the vectors lie.
"""


@contextlib.contextmanager
def pushed_options(prefix: str, *layers: Mapping[str, Any]) -> Iterator[None]:
    """Set options under ``prefix`` for the duration of the block, then restore the database.

    Layers are applied in order (later ones win). Options whose name starts with ``?`` are
    defaults: set only where the database has no value. Not collective.
    """
    opts = PETSc.Options()
    saved: dict[str, str | None] = {}
    for layer in layers:
        for key, value in layer.items():
            default = key.startswith("?")
            name = prefix + key.lstrip("?")
            if name not in saved:
                saved[name] = opts.getString(name) if opts.hasName(name) else None
            if default and opts.hasName(name):
                continue
            opts[name] = value
    try:
        yield
    finally:
        for name, old in saved.items():
            if old is None:
                opts.delValue(name)
            else:
                opts[name] = old


@contextlib.contextmanager
def repeatable_vectors() -> Iterator[None]:
    """Within the block, new PETSc vectors take :data:`REPEATABLE_VECTOR_OPTIONS`.

    An option the database has already (the user's, e.g. ``-vec_mdot_use_gemv 1`` on the command
    line) is kept; the others are deleted again on exit. Not collective.
    """
    with pushed_options("", {"?" + k: v for k, v in REPEATABLE_VECTOR_OPTIONS.items()}):
        yield


def petsc_vector(index_map: dolfinx.common.IndexMap, bs: int) -> PETSc.Vec:
    """A ghosted PETSc vector laid out by ``index_map`` with block size ``bs``.

    Made under :func:`repeatable_vectors`: its inner products and those of its duplicates (a
    solver's work and Krylov vectors) do not depend on where they lie in memory.
    """
    with repeatable_vectors():
        if _NEW:
            return _la_petsc.create_vector([(index_map, bs)])
        return dolfinx.la.create_petsc_vector(index_map, bs)


def ghosted_index_map(
    comm: MPI.Comm, size_local: int, ghosts: np.ndarray, owners: np.ndarray
) -> dolfinx.common.IndexMap:
    """An index map with ``size_local`` owned indices and the given ghosts and their owners."""
    ghosts = np.asarray(ghosts, dtype=np.int64)
    owners = np.asarray(owners, dtype=np.int32)
    if _NEW:
        # the tag of the communication that sets the map up (DOLFINx's own default)
        return dolfinx.common.IndexMap(comm, size_local, ghosts, owners, tag=1302)
    return dolfinx.common.IndexMap(comm, size_local, ghosts, owners)


def create_submesh(
    mesh: dolfinx.mesh.Mesh, dim: int, entities: np.ndarray
) -> tuple[dolfinx.mesh.Mesh, np.ndarray]:
    """The sub-mesh of the ``dim``-dimensional ``entities`` and each of its cells' parent entity.

    Returns:
        The sub-mesh and an int32 array: the parent mesh's entity of each sub-mesh cell.
    """
    sub, emap, _, _ = dolfinx.mesh.create_submesh(mesh, dim, entities)
    if _NEW:
        n = sub.topology.index_map(dim).size_local + sub.topology.index_map(dim).num_ghosts
        parents = emap.sub_topology_to_topology(np.arange(n, dtype=np.int32), inverse=False)
        return sub, np.asarray(parents, dtype=np.int32)
    return sub, np.asarray(emap, dtype=np.int32)


def create_mesh(
    comm: MPI.Comm,
    cells: np.ndarray,
    x: np.ndarray,
    element,
    partitioner: Callable | None = None,
) -> dolfinx.mesh.Mesh:
    """A distributed mesh from cells (global node numbers) and node coordinates.

    ``dolfinx.mesh.create_mesh``, whose coordinates and element swapped places in 0.11.
    """
    if _NEW:
        return dolfinx.mesh.create_mesh(comm, cells, element, x, partitioner=partitioner)
    return dolfinx.mesh.create_mesh(comm, cells, x, element, partitioner=partitioner)


def refine_uniform(
    mesh: dolfinx.mesh.Mesh,
) -> tuple[dolfinx.mesh.Mesh, np.ndarray, np.ndarray]:
    """Refine every cell of a simplex mesh once, each refined cell on its parent's rank.

    Returns:
        The refined mesh, the parent cell of each of its cells and, for each of its cells' facets
        (cell by cell), the parent cell's local facet holding it (-1: inside the parent).
    """
    option = dolfinx.mesh.RefinementOption.parent_cell_and_facet
    keep = cast(Callable, None)  # no redistribution (both versions take None for it)
    fine, parent_cell, parent_facet = dolfinx.mesh.refine(mesh, None, keep, option)
    return fine, np.asarray(parent_cell), np.asarray(parent_facet)


def adjacency_list(data: np.ndarray, offsets: np.ndarray | None = None):
    """An adjacency list as DOLFINx's C++ layer takes it (e.g. from a cell partitioner)."""
    adj = (
        dolfinx.graph.adjacencylist(data)
        if offsets is None
        else dolfinx.graph.adjacencylist(data, offsets)
    )
    return getattr(adj, "_cpp_object", adj)


def default_partitioner(ghost_mode: dolfinx.mesh.GhostMode) -> Callable:
    """DOLFINx's graph partitioner with the given ghost mode (facets shared by two cells)."""
    if _NEW:  # (DOLFINx's singledispatch: mypy sees the first signature only)
        return dolfinx.mesh.create_cell_partitioner(ghost_mode, 2)  # type: ignore[call-arg]
    return dolfinx.mesh.create_cell_partitioner(ghost_mode)


def geometry_dofmap(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """The geometry dofmap (cells x nodes) of a mesh of one cell type.

    ``geometry.dofmap`` in 0.9, ``geometry.dofmaps[0]`` in 0.11 (``dofmap`` is deprecated there).
    """
    if _NEW:  # (statements, not a conditional expression: mypy checks one stack's branch)
        return mesh.geometry.dofmaps[0]
    return mesh.geometry.dofmap


def coordinate_element(mesh: dolfinx.mesh.Mesh):
    """The coordinate element of a mesh of one cell type (``geometry.cmap`` / ``cmaps[0]``)."""
    if _NEW:
        return mesh.geometry.cmaps[0]
    return mesh.geometry.cmap


def interpolation_points(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """The reference interpolation points of ``V``'s element (for a ``dolfinx.fem.Expression``)."""
    pts = V.element.interpolation_points
    if _NEW:  # (a property from 0.10 on)
        return pts
    return pts()


class DolfinxNewton:
    """DOLFINx's own Newton solver on ``F(u; v) = 0``, with extra terms in residual and Jacobian.

    Made by :func:`dolfinx_newton`; :meth:`solve` solves for ``u`` from its current value.
    :meth:`destroy` (collective) frees its PETSc objects at the same point on every rank; it is
    also a context manager that does so on leaving. Left to the garbage collector, DOLFINx 0.11's
    ``NonlinearProblem.__del__`` destroys its SNES (a collective call) whenever each rank's
    collector happens to run, which can hang a parallel run.
    """

    def __init__(
        self, solve: Callable[[], tuple[int, bool]], objects: list, petsc: Callable[[], list]
    ) -> None:
        self._solve: Callable[[], tuple[int, bool]] | None = solve
        self._objects = objects  # kept alive with the solver
        self._petsc = petsc  # the PETSc objects destroy() frees

    def solve(self) -> tuple[int, bool]:
        """Newton from the current ``u``: (iterations, converged); ``u`` holds the result."""
        if self._solve is None:
            raise RuntimeError("the solver was destroyed")
        return self._solve()

    def destroy(self) -> None:
        """Free the solver's PETSc objects (collective: call it on every rank; idempotent)."""
        if self._solve is None:
            return
        for obj in self._petsc():
            if obj is not None:
                obj.destroy()
        self._solve, self._objects, self._petsc = None, [], list

    def __enter__(self) -> DolfinxNewton:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()


def dolfinx_newton(
    F,
    u: dolfinx.fem.Function,
    bcs: list,
    J,
    A: PETSc.Mat,
    *,
    add_residual: Callable[[PETSc.Vec, PETSc.Vec], None],
    add_jacobian: Callable[[PETSc.Vec, PETSc.Mat], None],
    prefix: str,
    rtol: float = 1e-12,
    atol: float = 1e-10,
    max_it: int = 30,
) -> DolfinxNewton:
    """DOLFINx's nonlinear machinery with extra residual and Jacobian contributions.

    0.9: ``fem.petsc.NonlinearProblem`` (its ``F`` and ``J`` extended) and
    ``nls.petsc.NewtonSolver`` (the residual criterion, ``error_on_nonconvergence`` off); 0.11:
    the SNES-based ``fem.petsc.NonlinearProblem`` whose residual and Jacobian callbacks call
    DOLFINx's ``assemble_residual``/``assemble_jacobian`` and then the extras (Newton with a full
    step, the same tolerances). Both: LU (MUMPS), the Jacobian assembled into ``A`` (a matrix
    that holds the extra couplings, e.g. :func:`~subfric_dolfinx.fem.create_matrix`).

    Args:
        F: The residual form ``F(u; v)``.
        u: The unknown.
        bcs: DOLFINx Dirichlet conditions.
        J: The Jacobian form.
        A: The matrix to assemble the Jacobian into.
        add_residual: ``(x, b)``: add to the residual ``b`` at ``x`` (after DOLFINx's assembly
            with lifting and the boundary values).
        add_jacobian: ``(x, A)``: add to the Jacobian (``ADD_VALUES``; ``A`` is assembled after).
        prefix: PETSc options prefix of the solver.
        rtol: Relative residual tolerance.
        atol: Absolute residual tolerance.
        max_it: Iteration limit.
    """
    import dolfinx.fem.petsc

    lu = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    if not _NEW:  # pragma: no cover - the other stack's branch
        import dolfinx.nls.petsc

        class _Problem(dolfinx.fem.petsc.NonlinearProblem):
            def F(self, x: PETSc.Vec, b: PETSc.Vec) -> None:
                super().F(x, b)
                add_residual(x, b)

            def J(self, x: PETSc.Vec, mat: PETSc.Mat) -> None:
                super().J(x, mat)
                add_jacobian(x, mat)
                mat.assemble()

        problem = _Problem(F, u, bcs, J)
        solver = dolfinx.nls.petsc.NewtonSolver(u.function_space.mesh.comm, problem)
        solver.setJ(problem.J, A)
        solver.convergence_criterion = "residual"
        solver.rtol, solver.atol, solver.max_it = rtol, atol, max_it
        solver.error_on_nonconvergence = False
        ksp = solver.krylov_solver
        ksp.setOptionsPrefix(prefix)
        opts = PETSc.Options()
        for k, v in lu.items():
            opts[prefix + k] = v
        ksp.setFromOptions()
        for k in lu:
            del opts[prefix + k]
        # No reference cycle here: dropping the objects frees them at once (the C++ solver).
        return DolfinxNewton(lambda: solver.solve(u), [problem, solver], list)
    options = {
        **{k: v for k, v in lu.items()},
        "snes_type": "newtonls",
        "snes_linesearch_type": "basic",
        "snes_rtol": rtol,
        "snes_atol": atol,
        "snes_stol": 0.0,
        "snes_max_it": max_it,
    }
    problem = dolfinx.fem.petsc.NonlinearProblem(
        F, u, petsc_options_prefix=prefix, bcs=bcs, J=J, petsc_options=options
    )
    snes = problem.solver
    # The callbacks hold the forms, not ``problem``: a reference cycle problem -> SNES ->
    # callback -> problem would leave ``problem`` to the cyclic garbage collector, whose
    # ``__del__`` (a collective destroy) then runs at a different moment on each rank.
    F_form, J_form = problem.F, problem.J

    def residual(snes_: PETSc.SNES, x: PETSc.Vec, b: PETSc.Vec) -> None:
        dolfinx.fem.petsc.assemble_residual(snes_, x, b, u, F_form, J_form, bcs)
        add_residual(x, b)

    def jacobian(snes_: PETSc.SNES, x: PETSc.Vec, mat: PETSc.Mat, P: PETSc.Mat) -> None:
        dolfinx.fem.petsc.assemble_jacobian(snes_, x, mat, P, u, J_form, None, bcs)
        add_jacobian(x, mat)
        mat.assemble()

    snes.setFunction(residual, problem.b)
    snes.setJacobian(jacobian, A, A)

    def solve() -> tuple[int, bool]:
        problem.solve()
        return snes.getIterationNumber(), bool(snes.getConvergedReason() > 0)

    return DolfinxNewton(
        solve, [problem], lambda: [problem.solver, problem.A, problem.P_mat, problem.b, problem.x]
    )


def _snes_diverged_nan() -> int:
    reasons = PETSc.SNES.ConvergedReason
    for name in ("DIVERGED_FUNCTION_NANORINF", "DIVERGED_FNORM_NAN"):
        if hasattr(reasons, name):
            return int(getattr(reasons, name))
    raise ImportError("petsc4py names no SNES reason for a NaN residual")  # pragma: no cover


SNES_DIVERGED_NAN: int = _snes_diverged_nan()
"""SNES's converged reason for a NaN or infinite residual (named differently by version)."""


def eval_expression(
    expr: dolfinx.fem.Expression, mesh: dolfinx.mesh.Mesh, cells: np.ndarray, value_size: int
) -> np.ndarray:
    """Values of a (coefficient-only) ``Expression`` at its points in ``cells``.

    Returns:
        An array ``(cells, points, value_size)``: the ``eval`` array of 0.9
        ``(cells, points * value_size)`` or 0.11 ``(cells, points, *value_shape)``, reshaped.
    """
    cells = np.ascontiguousarray(cells, dtype=np.int32)
    values = expr.eval(mesh, cells)
    return np.reshape(values, (cells.size, expr.X().shape[0], value_size))
