"""Is the small-sliding penalty interface still describing the contact? Penetration and slide.

The interface is a penalty layer (``f_n = alpha_n ubar_n``) whose pairs and local frames stay at
the reference geometry. Two things can make a converged result mean less than it seems, and
:class:`ValidityWatch` follows both over a run (after every converged step, collectively) and
warns once at its end, naming the worst point, where and when (:func:`subfric_dolfinx.logs.warn`:
a :class:`~subfric_dolfinx.logs.PenetrationWarning` or
:class:`~subfric_dolfinx.logs.SlideWarning`, visible in a plain script, one per MPI job):

* **Penetration.** A pressed point sinks by ``ubar_n``: the two bodies overlap by that much. It
  is judged twice, and warned about when either check fails:

  - *interpenetration*: ``ubar_n`` against the interface element size ``h`` there. An overlap
    beyond :data:`INTERPENETRATION_FRACTION` of an element is one the mesh resolves: the contact
    is then not where the bodies touch (finite sliding pairs its points at that depth). Always
    judged.
  - *compliance*: the interface is as compliant as a layer of the bodies ``l = E* ubar_n / f_n``
    thick (``E*`` the contact modulus of the two bodies, ``1/E* = (1 - nu_1^2)/E_1 + (1 -
    nu_2^2)/E_2``; ``l = E*/alpha_n`` for a linear penalty), and it spreads the contact pressure
    over about ``l`` (``demos/punch.py`` measures it). The bodies' own compliance over a contact
    of size ``L`` is about ``L / E*``: with ``l`` below a tenth of ``L`` the penalty adds less
    than a tenth to it. A mesh cannot resolve anything shorter than its interface elements
    ``h`` either, so the tolerance is ``max(h, PENETRATION_FRACTION L)``: on a fine mesh it is a
    fixed fraction of the contact (refining never makes this check fail), on a coarse one the
    element. ``L`` is the interface's size (its length in 2-D, the square root of its area in
    3-D). The warning says which ``alpha_n`` passes it (``E*/tolerance``) and which makes the
    interface ten times stiffer than one interface element of the bodies (``10 E*/h``, the usual
    rule for a penalty that the mesh cannot see). A compliance chosen on purpose (a soft layer,
    the roughness of the surfaces: the pressure it spreads is the model's) is not a fault: an
    interface declared with ``intended_compliance`` (:class:`~subfric_dolfinx.fem.Interface`,
    the scene key ``interfaces.<name>.intended_compliance``) is judged on its interpenetration
    only.

* **Slide.** The traction at a secondary point acts on the primary point that faced it at the
  start: a slide ``|ubar_t|`` longer than :data:`SLIDE_ELEMENTS` interface elements puts it
  several elements away from the point the secondary body really touches. Results stay those of that
  idealisation (exact for a uniformly loaded flat interface, not where the contact's state
  varies over the slide, e.g. near its edges).

A finite-sliding interface (:class:`~subfric_dolfinx.fem.interface.SlidingInterface`) is a
penalty layer too, and its penetration is judged the same way (``h`` its secondary facets); its
slide is not: its points are paired again in the current configuration as they slide, so no
traction acts where the bodies no longer touch.

**Overhang** (finite sliding only). A secondary facet pressed while some of its points lie beyond
the primary surface (a block slid past the end of its base, a shaft pushed out of its hub; or a
block slid past the end of an interface that the mesh made only as long as the block): its
points beyond are open, and the force of the others is given to the primary where they project,
all of it (:func:`~subfric_dolfinx.fem.interface.finite.transfer.complete_transfer`: the forces
balance), but the contact's edge is then resolved only to the secondary's facets. Warned where
such a facet has more than :data:`OVERHANG_FRACTION` of it beyond, with an
:class:`~subfric_dolfinx.logs.OverhangWarning` that names the interface.

A problem of several interfaces has one watch per interface (the
:class:`~subfric_dolfinx.fem.LoadStepper` keeps them all); each uses the contact modulus of its
own two bodies and names its interface in its warnings. A user bulk law without
:class:`~subfric_dolfinx.fem.Material` values for an interface's bodies leaves ``E*`` unknown:
that interface's compliance is then not judged (its interpenetration and its slide are).

The checks cost one all-reduce of two numbers per step (and a gather when a maximum grows).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from mpi4py import MPI

from .. import logs

__all__ = [
    "INTERPENETRATION_FRACTION",
    "OVERHANG_FRACTION",
    "PENETRATION_FRACTION",
    "SLIDE_ELEMENTS",
    "ValidityWatch",
    "WorstPoint",
    "contact_modulus",
    "interface_modulus",
]

PENETRATION_FRACTION = 0.1
"""A penetration is tolerated while ``l = E* ubar_n / f_n`` stays below the larger of the
interface element size and this fraction of the interface's size (unless the interface declares
its compliance intended)."""

INTERPENETRATION_FRACTION = 0.1
"""A penetration ``ubar_n`` beyond this fraction of the interface element size is warned about,
whatever the interface declares."""

SLIDE_ELEMENTS = 3.0
"""A slide ``|ubar_t|`` beyond this many interface element sizes is warned about."""

OVERHANG_FRACTION = 1e-6
"""A pressed secondary facet of a finite-sliding interface with points beyond the primary surface
and more than this fraction of its measure beyond it is warned about (an overhang)."""


def contact_modulus(materials: Mapping[str, Any]) -> float:
    """``E*`` of the two bodies: ``1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2`` (MPa).

    Args:
        materials: Body name -> :class:`~subfric_dolfinx.fem.Material`; ``primary`` and
            ``secondary`` (or their input aliases ``master`` and ``slave``) if given, otherwise
            the two most compliant.
    """
    mats = [materials[k] for k in ("primary", "secondary") if k in materials]
    if len(mats) < 2:
        mats = [materials[k] for k in ("master", "slave") if k in materials]
    if len(mats) < 2:
        mats = sorted(materials.values(), key=lambda m: m.E / (1.0 - m.nu**2))[:2]
        mats = (mats * 2)[:2]
    return 1.0 / sum((1.0 - m.nu**2) / m.E for m in mats)


@dataclasses.dataclass(frozen=True)
class WorstPoint:
    """The point where a check was furthest beyond its tolerance over the run.

    Attributes:
        ratio: The measure over its tolerance (> 1: warned).
        value: The penetration ``ubar_n`` or the slide ``|ubar_t|`` there (mm), or the fraction
            of its secondary facet beyond the primary surface (an overhang).
        h: The interface element size there (mm).
        x: Coordinates of the point (an overhang's: where it is at ``t``).
        t: Time of the step.
        f_n: Normal traction there (MPa; an overhang's: the largest of its facet).
    """

    ratio: float
    value: float
    h: float
    x: tuple[float, ...]
    t: float
    f_n: float


class ValidityWatch:
    """Follows the penetration and the slide of an interface over a run; warns at its end.

    Made by :class:`~subfric_dolfinx.fem.LoadStepper` (collective): :meth:`track` after every
    converged step, :meth:`warn` when the run ends, however it ends.

    Args:
        problem: The :class:`~subfric_dolfinx.fem.InterfaceProblem`.
        interface: The interface's name (``None``: the problem's first interface).

    Attributes:
        interface: The interface's name.
        penetration: The worst penetration beyond its tolerance so far, or ``None``.
        slide: The worst slide beyond :data:`SLIDE_ELEMENTS` elements so far, or ``None``.
        overhang: The pressed secondary facet (finite sliding) most beyond the primary surface
            so far (more than :data:`OVERHANG_FRACTION` of it), or ``None``.
        contact_modulus: ``E*`` of the interface's two bodies (MPa), ``None`` if unknown.
        intended_compliance: The interface declares its normal compliance intended: its
            penetration is judged against the element size only.
        size: The interface's size ``L`` (mm).
        h_min: The smallest interface element size (mm).
    """

    def __init__(self, problem: Any, interface: str | None = None) -> None:
        self.problem = problem
        self.comm = problem.comm
        ifaces = problem.interfaces
        self.interface = next(iter(ifaces)) if interface is None else interface
        if self.interface not in ifaces:
            raise KeyError(f"no interface {self.interface!r}; the problem has {list(ifaces)}")
        self._named = len(ifaces) > 1
        iface = self._iface = ifaces[self.interface]
        el = self._elements = iface.law_points
        # the slide matters where the pairs stay; finite sliding re-pairs as the bodies move
        self.slides_small = iface.fixed_pairs
        self.gdim = el.gdim
        # length (2-D), area (3-D) per facet; not the axisymmetric weights' 2 pi r
        area = el.facet_weights.reshape(-1, el.nq).sum(axis=1)
        dim = max(self.gdim - 1, 1)
        self.h = np.repeat(area ** (1.0 / dim), el.nq)  # element size at each point
        self.size = float(self.comm.allreduce(float(area.sum()))) ** (1.0 / dim)
        self.h_min = self.comm.allreduce(float(self.h.min()) if self.h.size else np.inf, MPI.MIN)
        self.contact_modulus = interface_modulus(problem, self.interface)
        self.intended_compliance = _intended_compliance(problem, self.interface)
        self.tolerance = np.maximum(self.h, PENETRATION_FRACTION * self.size)
        self.penetration: WorstPoint | None = None
        self.slide: WorstPoint | None = None
        self.overhang: WorstPoint | None = None
        self._said: set[type[Warning]] = set()

    def track(self, t: float) -> None:
        """Look at the committed step that ended at ``t`` (collective).

        Penetration: the worst point is the deepest among those beyond a tolerance (the
        interpenetration's or the compliance's; for a linear penalty ``l`` is the same at every
        pressed point); slide: the point of the most elements.
        """
        el = self._elements
        nt = el.nt
        res = el.last
        n = self.h.size
        gap = el.last_gap if n else np.zeros((0, nt + 1))
        f_n = res.traction[:, nt] if res is not None and n else np.zeros(n)
        un = gap[:, nt]
        pressed = (un > 0.0) & (f_n > 0.0)
        pen = np.where(pressed, un / (INTERPENETRATION_FRACTION * self.h), 0.0)
        if self.judges_compliance:
            es = self.contact_modulus or 0.0
            layer = np.where(pressed, es * un / np.where(pressed, f_n, 1.0), 0.0)
            pen = np.maximum(pen, layer / self.tolerance)
        slide = np.linalg.norm(gap[:, :nt], axis=1) if self.slides_small else np.zeros(n)
        over, facet_fn = self._overhang(f_n)
        checks = {  # name -> (ratio, value, what selects the worst point)
            "penetration": (pen, un, np.where(pen > 1.0, un, -np.inf)),
            "slide": (slide / (SLIDE_ELEMENTS * self.h), slide, slide / self.h),
            "overhang": (
                over / OVERHANG_FRACTION,
                over,
                np.where(over > OVERHANG_FRACTION, over, -np.inf),
            ),
        }
        local = np.array([key.max() if n else -np.inf for _, _, key in checks.values()])
        largest = np.zeros_like(local)
        self.comm.Allreduce(local, largest, op=MPI.MAX)
        for k, (name, (ratio, value, key)) in enumerate(checks.items()):
            known = getattr(self, name)
            if not np.isfinite(largest[k]):  # nothing beyond the tolerance
                continue
            if known is not None:
                floor = known.ratio * SLIDE_ELEMENTS if name == "slide" else known.value
                if not largest[k] > floor * (1.0 + 1e-3):  # details only when it grows
                    continue
            elif name == "slide" and not largest[k] > SLIDE_ELEMENTS:
                continue
            mine = None
            if n and local[k] == largest[k]:
                i = int(np.argmax(key))
                where, fn = el.points, f_n
                if name == "overhang":  # where the facet is now, its largest pressure
                    overhang = self._iface.overhang()
                    assert overhang is not None  # (a facet beyond the tolerance was found)
                    where, fn = overhang.x, facet_fn
                x = tuple(float(v) for v in where.reshape(-1, self.gdim)[i])
                mine = WorstPoint(
                    float(ratio[i]), float(value[i]), float(self.h[i]), x, float(t), float(fn[i])
                )
            found = [p for p in self.comm.allgather(mine) if p is not None]
            setattr(self, name, min(found, key=lambda p: p.x))  # the same on every rank

    def _overhang(self, f_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each point's facet's fraction beyond the primary surface, and its largest pressure.

        The fraction where the facet is pressed and a point of it faces no primary facet; 0
        elsewhere, and for a small-sliding interface.
        """
        n = self.h.size
        overhang = None if self.slides_small else self._iface.overhang()
        if overhang is None or n == 0:
            return np.zeros(n), np.zeros(n)
        nq = self._elements.nq
        fn = f_n.reshape(-1, nq).max(axis=1)
        over = np.where((fn > 0.0) & overhang.beyond, np.abs(overhang.uncovered), 0.0)
        return np.repeat(over, nq), np.repeat(fn, nq)

    @property
    def judges_compliance(self) -> bool:
        """Whether the penetration is judged as a compliance too (E* known, not intended)."""
        return self.contact_modulus is not None and not self.intended_compliance

    def messages(self) -> list[tuple[type[Warning], str]]:
        """The warnings of the run so far: (category, text) (the same on every rank)."""
        out: list[tuple[type[Warning], str]] = []
        on = f"on the interface {self.interface!r}: " if self._named else ""
        p = self.penetration
        if p is not None:
            out.append((logs.PenetrationWarning, self._penetration_text(p, on)))
        s = self.slide
        if s is not None:
            out.append(
                (
                    logs.SlideWarning,
                    (
                        f"{on}long slide: |ubar_t| up to {s.value:.3g} mm (at {_xy(s.x)}, "
                        f"t = {s.t:.6g} s), {s.value / s.h:.3g} interface elements "
                        f"(h = {s.h:.3g} mm; warned beyond {SLIDE_ELEMENTS:g}). The interface is "
                        "small-sliding: a secondary point's traction still acts on the primary "
                        f"point that faced it at the start, {s.value:.3g} mm away, which is right "
                        "for a uniformly loaded flat interface, not where the contact's state "
                        "varies over that distance (e.g. at its edges). Make the interface "
                        "finite-sliding (Interface(..., kinematics='finite_sliding'); scene: "
                        "interfaces.<name>.kinematics: 'finite_sliding'), which pairs its points "
                        "again as they slide, or keep the slide within a few interface elements"
                    ),
                )
            )
        o = self.overhang
        if o is not None:
            out.append(
                (
                    logs.OverhangWarning,
                    (
                        f"contact leaves its primary surface on the interface {self.interface!r}: "
                        f"a secondary facet pressed (f_n up to {o.f_n:.4g} MPa) with {o.value:.3g} "
                        f"of it beyond the primary surface's end (near {_xy(o.x)}, t = {o.t:.6g} "
                        "s). Its points beyond are open and the force of the others is given to "
                        "the primary where they project (the forces balance), but the contact's "
                        f"edge is resolved only to the secondary's facets there (h = {o.h:.3g} "
                        "mm): refine the secondary near the primary's end, or extend the primary "
                        "surface if the bodies should stay in contact"
                    ),
                )
            )
        return out

    def _penetration_text(self, p: WorstPoint, on: str) -> str:
        """The penetration warning's text: the point, then each check it fails, with its remedy."""
        frac = INTERPENETRATION_FRACTION
        text = (
            f"{on}large penetration: ubar_n up to {p.value:.3g} mm (at {_xy(p.x)}, "
            f"t = {p.t:.6g} s, f_n = {p.f_n:.4g} MPa)."
        )
        overlap = p.value / p.h
        if overlap > frac:
            text += (
                f" The bodies overlap by {overlap:.3g} of the interface element there (h = "
                f"{p.h:.3g} mm; tolerated up to {frac:g} h, an overlap the mesh does not "
                f"resolve): set alpha_n >= f_n / ({frac:g} h) = {p.f_n / (frac * p.h):.3g} "
                "MPa/mm."
            )
        if self.judges_compliance:
            assert self.contact_modulus is not None  # (judges_compliance: E* known)
            es = float(self.contact_modulus)
            layer = es * p.value / p.f_n
            tol = max(p.h, PENETRATION_FRACTION * self.size)
            if layer > tol:
                text += (
                    f" The interface is as compliant as l = E* ubar_n / f_n = {layer:.3g} mm of "
                    f"the bodies (E* = {es:.4g} MPa, their contact modulus), {layer / tol:.3g} "
                    f"times the {tol:.3g} mm tolerated there, max(h, {PENETRATION_FRACTION:g} L) "
                    f"with h = {p.h:.3g} mm the interface element and L = {self.size:.3g} mm the "
                    "interface's size: the penalty spreads the contact pressure over about l. "
                    f"Set alpha_n >= E*/{tol:.3g} mm = {es / tol:.3g} MPa/mm; 10 E*/h = "
                    f"{10 * es / self.h_min:.3g} MPa/mm makes the interface ten times stiffer "
                    "than its smallest elements; or, if this compliance is the model's on "
                    "purpose (a soft layer, rough surfaces), declare it: Interface(..., "
                    "intended_compliance=True) (scene: interfaces.<name>.intended_compliance: "
                    "true)."
                )
        return text

    def warn(self) -> None:
        """Warn about what went beyond its tolerance, each kind once per watch.

        Not collective (safe while an error unwinds); every rank applies the warning filters,
        rank 0 shows the warning.
        """
        for category, text in self.messages():
            if category not in self._said:
                self._said.add(category)
                logs.warn(text, category, self.comm)


def interface_modulus(problem: Any, name: str) -> float | None:
    """``E*`` of the two bodies an interface joins, from the problem's materials.

    A body's material is given by its name or by one of its cell groups (the most compliant of
    those given); the input aliases of the first interface's bodies are resolved by the
    problem's topology. ``None`` when either body has none (a user bulk law).
    """
    materials = getattr(problem, "materials", None) or {}
    topo = getattr(problem, "topology", None)
    sides = None if topo is None else topo.interfaces.get(name)
    if sides is None:  # not a problem of the model layer: its two bodies are the materials
        return contact_modulus(materials) if materials else None
    assert topo is not None  # (sides are its)
    mats = []
    for body in (sides.primary, sides.secondary):
        keys = [body, *topo.bodies.get(body, ())]
        given = [materials[k] for k in keys if k in materials]
        if not given:
            return None
        mats.append(min(given, key=lambda m: m.E / (1.0 - m.nu**2)))
    return contact_modulus({"primary": mats[0], "secondary": mats[1]})


def _intended_compliance(problem: Any, name: str) -> bool:
    """Whether the interface's spec declares its normal compliance intended."""
    specs = getattr(problem, "specs", None) or []
    spec = next((s for s in specs if s.group == name), None)
    return bool(getattr(spec, "intended_compliance", False))


def _xy(x: tuple[float, ...]) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in x) + ")"
