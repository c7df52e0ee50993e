"""The stability cases' outcome and case types, and the material-point helpers they share."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from subfric_dolfinx.constitutive import UNSTABLE, InterfaceState, Status, SubloadingLaw, preset
from subfric_dolfinx.driver import RunawayError, run_case

# --------------------------------------------------------------------------------------------
# Outcome and case


@dataclasses.dataclass
class Outcome:
    """What a case did.

    Attributes:
        outcome: ``"converged"``, ``"flagged"`` or ``"error"``.
        detail: One line of what happened, with numbers.
        it_mean: Mean iterations (return map per plastic point-step, or Newton per step).
        it_max: Largest iteration count.
        it_kind: ``"return map"`` or ``"Newton"``.
        nan_free: No NaN or inf anywhere in the outputs seen.
        message: The error message, or the reason of the flag.
        data: Numbers for the checks.
    """

    outcome: str
    detail: str
    it_mean: float
    it_max: int
    it_kind: str
    nan_free: bool
    message: str = ""
    data: dict[str, Any] = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (numpy scalars converted)."""
        d = dataclasses.asdict(self)
        d["data"] = {k: _plain(v) for k, v in self.data.items()}
        d["it_mean"] = float(self.it_mean)
        d["it_max"] = int(self.it_max)
        return d


def _plain(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


@dataclasses.dataclass(frozen=True)
class Case:
    """A stability case (see the module docstring)."""

    name: str
    level: str
    what: str
    expect: str
    must: str
    run: Callable[[Any], Outcome]
    check: Callable[[Outcome], None]


def require(ok: bool, message: str) -> None:
    if not ok:
        raise AssertionError(message)


# --------------------------------------------------------------------------------------------
# Material point helpers


class Counting:
    """A law that forwards to ``law`` and records the return-map iterations and finiteness.

    ``isinstance(proxy, SubloadingLaw)`` holds (the driver's runaway message asks).
    """

    def __init__(self, law: Any) -> None:
        self._law = law
        self.iterations: list[int] = []
        self.finite = True

    @property
    def __class__(self) -> type:  # type: ignore[override]
        return type(self._law)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._law, name)

    def return_map(self, gap: Any, state: Any, dt: float, **kw: Any) -> Any:
        res = self._law.return_map(gap, state, dt, **kw)
        plastic = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
        self.iterations.extend(res.iterations[plastic].tolist())
        self.finite &= finite(res)
        return res


def finite(res: Any) -> bool:
    arrays = (res.traction, res.tangent, res.state.up, res.state.mu, res.state.r)
    return bool(all(np.all(np.isfinite(a)) for a in arrays))


def iteration_stats(its: list[int] | np.ndarray) -> tuple[float, int]:
    a = np.asarray(its, dtype=float)
    return (float(a.mean()), int(a.max())) if a.size else (0.0, 0)


def g_factor(p: SubloadingLaw, f_n: float) -> float:
    return -math.expm1(-p.c_n * max(f_n, 0.0))


def drive(
    law: Any,
    path: list[list[float]],
    samples: list[float] | None = None,
    *,
    control: str = "disp",
    spm: float = 200.0,
    on_instability: str = "stop",
) -> tuple[Outcome, Any]:
    """Run the material-point driver on ``law`` (counted); classify the result."""
    from subfric_dolfinx.driver import Case as DriverCase

    counting = Counting(law)
    path_a = np.asarray(path, dtype=float)
    ts = np.asarray(samples if samples is not None else path_a[:, 0], dtype=float)
    case = DriverCase(counting, control, path_a, ts, 1, spm)  # type: ignore[arg-type]
    try:
        res = run_case(case, on_instability=on_instability)
    except RunawayError as e:
        m, k = iteration_stats(counting.iterations)
        part = e.partial
        fin = counting.finite and (
            part is None or all(np.all(np.isfinite(v)) for v in part.samples.values())
        )
        out = Outcome("error", f"RunawayError at t = {e.t:.6g} s", m, k, "return map", fin, str(e))
        out.data.update(t=e.t)
        return out, e
    m, k = iteration_stats(counting.iterations)
    fin = counting.finite and all(np.all(np.isfinite(v)) for v in res.samples.values())
    lost = res.stability_lost
    if lost is not None:
        detail = (
            f"stability lost at t = {lost['t']:.4g} s ({lost['reason']}, r = {lost['r']:.3g}, "
            f"f_t = {lost['f_t1']:.4g} MPa); {res.n_steps} steps"
        )
        out = Outcome("flagged", detail, m, k, "return map", fin, lost["reason"])
        out.data.update({f"lost_{q}": lost[q] for q in ("t", "r", "f_t1", "mu")})
    else:
        counts = ", ".join(f"{q} {v}" for q, v in res.status_counts.items() if v)
        out = Outcome("converged", f"{res.n_steps} steps ({counts})", m, k, "return map", fin)
    out.data.update(
        mu_min=float(res.samples["mu"].min()) if res.samples["mu"].size else float("nan"),
        complete=res.complete,
        n_steps=res.n_steps,
        unstable_steps=res.status_counts[UNSTABLE],
        jump_steps=res.status_counts[Status.JUMP.name],
    )
    return out, res


def one_step(
    law: SubloadingLaw, gaps: np.ndarray, state: InterfaceState, dt: float
) -> tuple[Any, list[int], bool]:
    res = law.return_map(gaps, state, dt)
    plastic = (res.status == Status.PLASTIC) | (res.status == Status.JUMP)
    return res, res.iterations[plastic].tolist(), finite(res)


SEC7 = preset("sec7")
UN300 = 300.0 / SEC7.alpha_n  # normal gap of 300 MPa


def leg_path(un: float, *legs: tuple[float, float], t0: float = 0.0) -> list[list[float]]:
    """Rows ``[t, x, 0, un]``: legs ``(duration, x_end)``, x linear in between."""
    rows = [[t0, 0.0, 0.0, un]]
    for dur, x in legs:
        rows.append([rows[-1][0] + dur, x, 0.0, un])
    return rows
