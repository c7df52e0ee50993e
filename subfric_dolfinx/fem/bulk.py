"""The bodies' own law: any UFL residual ``F(u; v)``, with or without quadrature-point state.

An :class:`~subfric_dolfinx.fem.InterfaceProblem` takes the bodies' behaviour as a *bulk model*,
an object of the small protocol :class:`BulkModel`:

* :meth:`BulkModel.forms` gives the residual ``F(u; v)`` (a UFL form over the bodies, already
  weighted by :func:`~.kinematics.weight` in axisymmetric mode) and its Jacobian (``None``: the
  problem takes ``ufl.derivative(F, u, du)``); it is called once, when the problem is built, with
  the problem's displacement ``u``, test function ``v``, trial function ``du`` and a
  :class:`BulkContext` (mesh, space, modelling mode, the measure ``dx`` over the bodies' cells and
  the cell tags of every body);
* :meth:`BulkModel.update` is called (collectively) before each residual assembly at a new Newton
  iterate, with ``u`` holding it (ghosts updated): a law with quadrature-point state runs its
  return map there, filling the trial state and the tangent its forms read;
* :meth:`BulkModel.commit` accepts the trial state when a step has converged,
  :meth:`BulkModel.revert` rejects it when a step failed (the load stepper calls them with the
  interfaces' own commit and revert);
* :meth:`BulkModel.saved_state` and :meth:`BulkModel.restore_state` give and take the committed
  state for checkpoints (the names the interfaces' law points use: one idiom for every holder of
  state): name -> array whose first axis runs over this rank's *owned cells*, cell by cell
  (``n_owned_cells * k`` rows for ``k`` values per cell, in the mesh's local cell order: the layout
  of the owned part of a DOLFINx Quadrature function's array), so that a checkpoint stores it by
  original cell index and restores it on any partition.

Shipped here:

* :class:`LinearElasticity`: isotropic linear elasticity per body or cell group, in every mode of
  :mod:`.kinematics` (3-D, plane strain, plane stress, axisymmetric). It declares ``linear =
  True``: the problem assembles its stiffness once and the residual is a matrix-vector product
  (the fast path). It is the default bulk.
* :class:`UFLBulk`: a stateless user form (a callable ``(u, v, ctx) -> F``, or a form written in
  the user's own ``u`` and ``v``, which the problem replaces by its own), with an optional
  Jacobian.

A bulk model may also declare ``linear = True`` (its ``F`` must then be linear in ``u``: the
problem assembles the Jacobian once and uses ``F(u) = J u``) and provide
``stress(u, ctx) -> 3 x 3 UFL tensor`` for stress outputs.

Every user form is checked before anything is compiled or assembled (:func:`check_forms`): a
form of the wrong rank (a ``TrialFunction`` in ``F``), a test or trial function of another
space than the problem's ``V``, an integral or a coefficient on another mesh would otherwise
corrupt memory in the assembler or end in an error that blames the interface; each is a
``ValueError`` naming the bulk model (:func:`bulk_name`) and what is wrong.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, Protocol, runtime_checkable

import dolfinx
import numpy as np
import ufl
from ufl.domain import extract_unique_domain

from .conditions import Material
from .kinematics import MODES, elastic_stress, strain, weight

__all__ = [
    "BulkContext",
    "BulkModel",
    "LinearElasticity",
    "UFLBulk",
    "bulk_forms",
    "bulk_name",
    "check_forms",
]


@dataclasses.dataclass(frozen=True)
class BulkContext:
    """What the problem gives the bulk model.

    Attributes:
        mesh: The mesh of all bodies.
        V: The displacement space.
        mode: One of :data:`~.kinematics.MODES`.
        dx: Cells of the bodies, ``subdomain_data`` = the cell tags (``dx(tag)``: one group).
        tags: Body name -> its cell tag(s) (a body of several cell groups has several); every
            cell group of a body is also listed under its own name.
        groups: Body name -> the names of its cell groups (empty: every name of ``tags`` is a
            body of one group).
    """

    mesh: dolfinx.mesh.Mesh
    V: dolfinx.fem.FunctionSpace
    mode: str
    dx: ufl.Measure
    tags: Mapping[str, tuple[int, ...]]
    groups: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)

    def bodies(self) -> dict[str, tuple[str, ...]]:
        """Body name -> its cell groups (:attr:`groups`, or every name of :attr:`tags`)."""
        return dict(self.groups) or {name: (name,) for name in self.tags}

    def measure(self, body: str) -> ufl.Measure:
        """``dx`` restricted to the cells of ``body`` (or of a cell group)."""
        tags = self.tags[body]
        return self.dx(tags[0] if len(tags) == 1 else tuple(tags))


@runtime_checkable
class BulkModel(Protocol):
    """The protocol of a bulk model (see the module docstring)."""

    def forms(self, u: Any, v: Any, du: Any, ctx: BulkContext) -> tuple[Any, Any]:
        """Residual ``F(u; v)`` and its Jacobian (``None``: ``ufl.derivative(F, u, du)``)."""
        ...

    def update(self, u: dolfinx.fem.Function) -> None:
        """Before each residual assembly at a new iterate (collective; ``u`` holds it)."""
        ...

    def commit(self) -> None:
        """The step converged: accept the trial state."""
        ...

    def revert(self) -> None:
        """The step failed: reject the trial state."""
        ...

    def saved_state(self) -> dict[str, np.ndarray]:
        """This rank's committed state, by owned cell (module docstring)."""
        ...

    def restore_state(self, data: dict[str, np.ndarray]) -> None:
        """Take a committed state given as :meth:`saved_state` gives it."""
        ...


class _Stateless:
    """Protocol methods of a bulk model without state."""

    linear = False

    def update(self, u: dolfinx.fem.Function) -> None:
        """Nothing to update."""

    def commit(self) -> None:
        """Nothing to commit."""

    def revert(self) -> None:
        """Nothing to revert."""

    def saved_state(self) -> dict[str, np.ndarray]:
        """No state."""
        return {}

    def restore_state(self, data: dict[str, np.ndarray]) -> None:
        """No state: ``data`` must be empty."""
        if data:
            raise ValueError(f"this bulk model has no state, got {sorted(data)}")


class LinearElasticity(_Stateless):
    """Isotropic linear elasticity of every body, in a modelling mode (the fast path).

    Args:
        materials: Body or cell-group name -> :class:`~.conditions.Material`; a cell group takes
            its own entry if it has one, else its body's.
        mode: ``None`` (the problem's mode) or one of :data:`~.kinematics.MODES`.

    The problem assembles ``J = int w sigma(du) : eps(v) dx`` once (``w`` the axisymmetric weight
    ``2 pi r``, else 1) and evaluates ``F(u) = J u``.
    """

    linear = True

    def __init__(self, materials: Mapping[str, Material], mode: str | None = None) -> None:
        if mode is not None and mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.materials = dict(materials)
        self.mode = mode

    def material_of(self, group: str, body: str) -> Material:
        """The material of a cell group of ``body``.

        Raises:
            ValueError: Neither the group nor the body has one (both named).
        """
        mat = self.materials.get(group, self.materials.get(body))
        if mat is None:
            where = f"the body {body!r}" + (f" (cell group {group!r})" if group != body else "")
            raise ValueError(
                f"no material given for {where}; materials are given for {sorted(self.materials)}"
            )
        return mat

    def forms(self, u: Any, v: Any, du: Any, ctx: BulkContext) -> tuple[Any, Any]:
        """``F = J u`` and ``J``, summed over the cell groups of every body."""
        mode = self.mode or ctx.mode
        w = weight(ctx.mesh, mode)
        a: Any = 0
        seen: set[str] = set()
        for body, groups in ctx.bodies().items():
            for g in groups:
                if g in seen:
                    continue
                seen.add(g)
                mat = self.material_of(g, body)
                sig = elastic_stress(strain(du, mode), mat.E, mat.nu, mode)
                a = a + w * ufl.inner(sig, strain(v, mode)) * ctx.measure(g)
        return ufl.action(a, u), a

    def stress(self, u: Any, ctx: BulkContext) -> Any:
        """The Cauchy stress (3 x 3) of ``u``, piecewise by cell group (for outputs)."""
        mode = self.mode or ctx.mode
        D0 = dolfinx.fem.functionspace(ctx.mesh, ("DG", 0))
        lam, mu = dolfinx.fem.Function(D0), dolfinx.fem.Function(D0)
        ct = ctx.dx.subdomain_data()
        for body, groups in ctx.bodies().items():
            for g in groups:
                mat = self.material_of(g, body)
                cells = np.concatenate([ct.find(t) for t in ctx.tags[g]])
                lam.x.array[cells] = mat.E * mat.nu / ((1 + mat.nu) * (1 - 2 * mat.nu))
                mu.x.array[cells] = mat.E / (2 * (1 + mat.nu))
        eps = strain(u, mode)
        if mode == "plane_stress":
            lam_s = 2 * lam * mu / (lam + 2 * mu)
            tr = eps[0, 0] + eps[1, 1]
            s = 2 * mu * eps + lam_s * tr * ufl.as_tensor([[1, 0, 0], [0, 1, 0], [0, 0, 0]])
            return ufl.as_tensor([[s[0, 0], s[0, 1], 0], [s[1, 0], s[1, 1], 0], [0, 0, 0]])
        return 2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(3)


class UFLBulk(_Stateless):
    """A stateless bulk model from the user's UFL residual.

    Args:
        F: A callable ``(u, v, ctx) -> form`` (``ctx`` the :class:`BulkContext`), or a UFL form
            written in the user's own unknown ``u`` (a Function) and test function.
        J: Its Jacobian: a callable ``(u, v, du, ctx) -> form``, a form (in the user's ``u``,
            test and trial functions), or ``None`` (``ufl.derivative``).
        u: The unknown ``F`` (and ``J``) is written in, when they are forms; the problem replaces
            it, and the form's test and trial functions, by its own.
        linear: ``F`` is linear in ``u`` and ``J`` constant: assemble ``J`` once (the fast path).
    """

    def __init__(
        self,
        F: Callable[..., Any] | Any,
        J: Callable[..., Any] | Any | None = None,
        *,
        u: dolfinx.fem.Function | None = None,
        linear: bool = False,
    ) -> None:
        if isinstance(F, ufl.Form) and u is None:
            raise ValueError("UFLBulk: a form F needs the unknown u it is written in (u=...)")
        self.F, self.J, self.u_user = F, J, u
        self.linear = bool(linear)

    def forms(self, u: Any, v: Any, du: Any, ctx: BulkContext) -> tuple[Any, Any]:
        """The user's forms in the problem's ``u``, ``v`` and ``du``.

        Raises:
            ValueError: A form in the user's functions whose unknown, test or trial function
                is not of the problem's space (element and mesh), naming it.
        """
        name = bulk_name(self)
        if isinstance(self.F, ufl.Form):  # (a UFL form is callable too: test it first)
            F = _replace(self.F, self.u_user, u, v, du, f"{name}: its residual F")
        else:
            F = self.F(u, v, ctx)
        if self.J is None:
            return F, None
        if isinstance(self.J, ufl.Form):
            return F, _replace(self.J, self.u_user, u, v, du, f"{name}: its Jacobian J")
        return F, self.J(u, v, du, ctx)


def _space_text(space: Any) -> str:
    text = " ".join(str(space.ufl_element()).split())
    return text if len(text) <= 120 else text[:117] + "..."


def _same_space(a: Any, b: Any) -> bool:
    """The same element on the same mesh (two spaces built alike are two objects)."""
    return a.ufl_element() == b.ufl_element() and a.ufl_domain() == b.ufl_domain()


def _replace(form: Any, u_user: Any, u: Any, v: Any, du: Any, what: str) -> Any:
    """``form`` with the user's unknown, test and trial functions replaced by the problem's."""
    V = v.ufl_function_space()
    if u_user is not None and not _same_space(u_user.ufl_function_space(), V):
        raise ValueError(
            f"{what}: the unknown u it is written in is of another space "
            f"({_space_text(u_user.ufl_function_space())}) than the problem's displacement "
            f"space ({_space_text(V)}) on its mesh"
        )
    mapping: dict[Any, Any] = {} if u_user is None else {u_user: u}
    for arg in form.arguments():
        if not _same_space(arg.ufl_function_space(), V):
            raise ValueError(
                f"{what}: its {_ARGUMENTS.get(arg.number(), 'argument')} is of another space "
                f"({_space_text(arg.ufl_function_space())}) than the problem's displacement "
                f"space ({_space_text(V)}) on its mesh"
            )
        mapping[arg] = v if arg.number() == 0 else du
    return ufl.replace(form, mapping)


_ARGUMENTS = {0: "test function", 1: "trial function"}


def bulk_name(bulk: Any) -> str:
    """How messages name a bulk model: ``the bulk model UFLBulk(my_residual)``."""
    if isinstance(bulk, UFLBulk):
        f = bulk.F
        what = (
            "a UFL form"
            if isinstance(f, ufl.Form)
            else getattr(f, "__qualname__", type(f).__name__)
        )
        return f"the bulk model UFLBulk({what})"
    return f"the bulk model {type(bulk).__name__}"


def _check_form(name: str, what: str, form: Any, rank: int, V: Any) -> None:
    if not isinstance(form, ufl.Form):
        hint = ""
        if isinstance(form, ufl.core.expr.Expr):
            hint = " (an expression: multiply it by a measure, e.g. ctx.dx)"
        raise ValueError(f"{name}: its {what} is not a UFL form but a {type(form).__name__}{hint}")
    if form.empty():
        raise ValueError(f"{name}: its {what} is an empty form (no integral)")
    try:
        args = form.arguments()
    except ValueError as e:  # UFL's own analysis: e.g. two test functions of different spaces
        text = " ".join(str(e).split("The Arguments found")[0].split())  # (a list in any order)
        raise ValueError(f"{name}: its {what}: {text}") from None
    numbers = sorted(a.number() for a in args)
    if numbers != list(range(rank)):
        got = ", ".join(_ARGUMENTS.get(n, f"argument {n}") for n in numbers) or "none"
        if rank == 1:
            want = "linear in the test function v alone (F(u; v): u the unknown Function"
            want += ", no TrialFunction)" if 1 in numbers else ")"
        else:
            want = "bilinear in the test function v and the trial function du"
        raise ValueError(
            f"{name}: its {what} has rank {len(numbers)} (arguments: {got}); it must be {want}"
        )
    for a in args:
        if a.ufl_function_space() != V:
            raise ValueError(
                f"{name}: the {_ARGUMENTS[a.number()]} of its {what} is of another space "
                f"({_space_text(a.ufl_function_space())}) than the problem's displacement space "
                f"V ({_space_text(V)}): write it with the v (and du) the problem gives"
            )
    domain = V.ufl_domain()
    if any(d != domain for d in form.ufl_domains()):
        raise ValueError(f"{name}: its {what} integrates over another mesh than the problem's")
    for c in (*form.coefficients(), *form.constants()):
        d = extract_unique_domain(c)
        if d is not None and d != domain:
            raise ValueError(
                f"{name}: its {what} holds {c!s}, defined on another mesh than the problem's"
            )


def check_forms(bulk: Any, F: Any, J: Any, V: Any) -> None:
    """Check a bulk model's residual and Jacobian before they are compiled.

    ``F`` must be a UFL form linear in one test function of ``V`` (rank 1), ``J`` bilinear in a
    test and a trial function of ``V`` (rank 2), both over ``V``'s mesh, their coefficients too.

    Raises:
        ValueError: Naming the bulk model (:func:`bulk_name`), the form and what is wrong.
    """
    name = bulk_name(bulk)
    _check_form(name, "residual F", F, 1, V)
    _check_form(name, "Jacobian J", J, 2, V)


def bulk_forms(bulk: Any, u: Any, v: Any, du: Any, ctx: BulkContext) -> tuple[Any, Any]:
    """The bulk's residual and Jacobian forms, the Jacobian derived where it is ``None``.

    Raises:
        TypeError: ``bulk`` lacks a method of :class:`BulkModel` (named).
        ValueError: A form of the wrong kind (:func:`check_forms`).
    """
    missing = [
        m
        for m in ("forms", "update", "commit", "revert", "saved_state", "restore_state")
        if not callable(getattr(bulk, m, None))
    ]
    if missing:
        raise TypeError(
            f"the bulk model {type(bulk).__name__} lacks the method(s) {missing} of BulkModel"
        )
    F, J = bulk.forms(u, v, du, ctx)
    _check_form(bulk_name(bulk), "residual F", F, 1, ctx.V)
    if J is None:
        J = ufl.derivative(F, u, du)
    check_forms(bulk, F, J, ctx.V)
    return F, J
