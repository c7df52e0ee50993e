"""The paper's parameter sets of the subloading law, by name.

The project implements the absolute form of the evolution law of the hardening function (Eq. 21 of
Hashiguchi et al., 2022)::

    mu' = -kappa (mu - mu_k) |up'| + xi (mu_s - mu)

The paper's parameter sets reproduce its curves only in the normalised reading of the same law,
``mu' = -kappa_N (mu/mu_k - 1)|up'| + xi_N (1 - mu/mu_s)``, i.e. with::

    kappa = kappa_N / mu_k,    xi = xi_N / mu_s

The presets below store the paper's sets in that normalised reading (converted with
:func:`normalised_to_absolute`); the literal readings are available under ``...-literal`` names as
stress tests (the literal Sec. 6 set has no stable quasi-static solution). Units: MPa, mm, s;
``mu_s``, ``mu_k`` (and ``mu0``) are values of the hardening function, a stress in MPa (the
strength is ``g(f_n) mu``, ``g`` dimensionless), not friction coefficients: ``sec7``'s
``mu_s = 500`` MPa gives a static strength of 29 MPa at 300 MPa.
"""

from __future__ import annotations

import dataclasses

from .subloading import SubloadingLaw

__all__ = ["PRESETS", "Preset", "normalised_to_absolute", "preset"]


def normalised_to_absolute(
    kappa_normalised: float, xi_normalised: float, mu_k: float, mu_s: float
) -> tuple[float, float]:
    """Convert ``kappa`` and ``xi`` from the normalised reading to the absolute form (Eq. 21).

    Normalised: ``mu' = -kappa_N (mu/mu_k - 1)|up'| + xi_N (1 - mu/mu_s)``; absolute:
    ``mu' = -kappa (mu - mu_k)|up'| + xi (mu_s - mu)``. Hence ``kappa = kappa_N / mu_k`` and
    ``xi = xi_N / mu_s``.

    Returns:
        ``(kappa, xi)`` in the absolute form.
    """
    return kappa_normalised / mu_k, xi_normalised / mu_s


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named parameter set of the paper.

    Attributes:
        name: Preset name.
        law: The law with the set's parameters (absolute form).
        slip_rate: Tangential sliding velocity of the paper's experiments, mm/s.
        description: Where the set comes from and how it was read.
    """

    name: str
    law: SubloadingLaw
    slip_rate: float
    description: str


def _paper_sets() -> dict[str, Preset]:
    sets: dict[str, Preset] = {}
    sec6 = {"alpha_t": 5000.0, "alpha_n": 5000.0, "mu_k": 7000.0, "u_tilde": 15.0, "c_n": 2e-4}
    sec7 = {"alpha_t": 500.0, "alpha_n": 500.0, "mu_k": 63.0, "u_tilde": 15.0, "c_n": 2e-4}
    cases = [
        (
            "sec6-mus10000",
            sec6,
            10000.0,
            15000.0,
            110.0,
            1.0 / 60.0,
            "Sec. 6 (Figs. 5-9), mu_s = 10000 MPa",
        ),
        (
            "sec6-mus7500",
            sec6,
            7500.0,
            15000.0,
            110.0,
            1.0 / 60.0,
            "Sec. 6 (Figs. 5-9), mu_s = 7500 MPa",
        ),
        ("sec7", sec7, 500.0, 98.0, 11.0, 1.0, "Sec. 7 (Figs. 10-11), A16111-T4 / tool steel"),
    ]
    for name, base, mu_s, kappa_n, xi_n, rate, what in cases:
        kappa, xi = normalised_to_absolute(kappa_n, xi_n, base["mu_k"], mu_s)
        sets[name] = Preset(
            name,
            SubloadingLaw(mu_s=mu_s, kappa=kappa, xi=xi, **base),
            rate,
            f"{what}; mu_s = {mu_s:g} MPa, mu_k = {base['mu_k']:g} MPa (values of the hardening "
            f"function, a stress); normalised reading: kappa = {kappa_n:g}/mu_k = {kappa:.6g} "
            f"1/mm, xi = {xi_n:g}/mu_s = {xi:.6g} 1/s",
        )
        sets[name + "-literal"] = Preset(
            name + "-literal",
            SubloadingLaw(mu_s=mu_s, kappa=kappa_n, xi=xi_n, **base),
            rate,
            f"{what}; literal reading of Eq. 21: kappa = {kappa_n:g} 1/mm, xi = {xi_n:g} 1/s "
            "(a stress test, not a physical set)",
        )
    return sets


PRESETS: dict[str, Preset] = _paper_sets()
"""The paper's parameter sets, by name (``sec6-mus10000``, ``sec6-mus7500``, ``sec7`` and their
``-literal`` variants)."""


def preset(name: str) -> SubloadingLaw:
    """Return the law of a named preset.

    Raises:
        KeyError: Unknown name; the message lists the known ones.
    """
    try:
        return PRESETS[name].law
    except KeyError:
        raise KeyError(f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}") from None
