"""Bad parameters of the friction laws: every field out of range, NaN, +-inf, of a wrong type."""

import dataclasses

import pytest

from subfric_dolfinx.constitutive import CoulombLaw, SubloadingLaw, preset
from tests.helpers import raised_on_every_rank

pytestmark = pytest.mark.numpy_only

NAN, INF = float("nan"), float("inf")
SUB = {k: v for k, v in preset("sec7").parameters().items() if k != "mu0"}
COUL = {"alpha_t": 1000.0, "alpha_n": 2000.0, "mu_c": 0.3}
OUT_OF_RANGE = {
    # field: values outside the allowed range, and the words of the range in the message
    "alpha_t": ([0.0, -500.0], "alpha_t > 0"),
    "alpha_n": ([0.0, -1e-300, -1.0], "alpha_n > 0"),
    "mu_k": ([0.0, -63.0], "mu_k > 0"),
    "mu_s": ([62.9, 10.0, -500.0], "mu_s >= mu_k = 63.0"),
    "kappa": ([-1e-3], "kappa >= 0"),
    "xi": ([-1.0], "xi >= 0"),
    "u_tilde": ([0.0, -15.0], "u_tilde > 0"),
    "c_n": ([0.0, -2e-4], "c_n > 0"),
    "mu0": ([500.1, 1000.0, 62.0, 10.0], "mu_k <= mu0 <= mu_s = [63.0, 500.0]"),
    "mu_c": ([0.0, -0.3], "mu_c > 0"),
}
WRONG_TYPES = ["500", True, None, 1 + 0j, [500.0]]


def law_of(field):
    return (CoulombLaw, COUL) if field == "mu_c" else (SubloadingLaw, SUB)


def parameter_cases():
    """(field, value, exception, words) for every field of both laws; the kind is in the id."""
    cases = []

    def case(field, value, exc, words, kind):
        cases.append(pytest.param(field, value, exc, words, id=f"{field}-{kind}"))

    for field, (values, allowed) in OUT_OF_RANGE.items():
        for v in values:
            case(field, v, ValueError, [f"{field} = {v!r}", allowed], f"range{v!r}")
        for v in (NAN, INF, -INF):
            case(field, v, ValueError, [f"{field} = {v!r}", "not finite"], repr(v))
        for v in WRONG_TYPES:
            if not (field == "mu0" and v is None):  # None is mu0's default (mu_s)
                case(field, v, TypeError, [field, "real number", repr(v)], type(v).__name__)
    # the Coulomb law's penalties are validated as well
    for field in ("alpha_t", "alpha_n"):
        for v, exc in [(-1.0, ValueError), (NAN, ValueError), (INF, ValueError), ("1", TypeError)]:
            case(f"coulomb.{field}", v, exc, [f"parameter {field}", repr(v)], repr(v))
    return cases


@pytest.mark.parametrize(("field", "value", "exc", "words"), parameter_cases())
def test_invalid_parameter(field, value, exc, words):
    if field.startswith("coulomb."):
        cls, valid, field = CoulombLaw, COUL, field.split(".", 1)[1]
    else:
        cls, valid = law_of(field)
    with raised_on_every_rank(exc, *words):
        cls(**{**valid, field: value})


def test_invalid_parameter_through_replace():
    with raised_on_every_rank(ValueError, "kappa = -1.0", "kappa >= 0"):
        preset("sec7").replace(kappa=-1.0)


def test_missing_parameter():
    with raised_on_every_rank(TypeError, "c_n"):
        SubloadingLaw(**{k: v for k, v in SUB.items() if k != "c_n"})


def test_every_field_of_both_laws_is_in_the_catalogue():
    """Guard: a new parameter field must get its bad-input cases here."""
    fields = {f.name for c in (SubloadingLaw, CoulombLaw) for f in dataclasses.fields(c)}
    assert fields == set(OUT_OF_RANGE), sorted(fields ^ set(OUT_OF_RANGE))
