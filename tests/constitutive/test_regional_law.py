"""RegionalLaw: several laws on one interface, each on its own points (numpy only).

Checked against each law run alone on its own points: tractions, tangents, states, statuses and
strengths equal bit for bit; a variable a law does not declare keeps its value on that law's
points; the law description lists every region; bad constructions are refused.
"""

import numpy as np
import pytest

from subfric_dolfinx.constitutive import (
    CoulombLaw,
    InterfaceState,
    RegionalLaw,
    Status,
    law_description,
    preset,
)

pytestmark = pytest.mark.numpy_only

COULOMB = CoulombLaw(alpha_t=500.0, alpha_n=500.0, mu_c=0.2)
ROUGH = CoulombLaw(alpha_t=500.0, alpha_n=800.0, mu_c=0.6)
SUB = preset("sec7")


def random_gap(rng, n, nt):
    gap = rng.normal(scale=0.5, size=(n, nt + 1))
    gap[:, nt] = rng.uniform(-0.2, 1.5, n)  # some points separated
    return gap


@pytest.mark.parametrize("nt", [1, 2])
def test_each_region_gets_its_own_law(nt):
    rng = np.random.default_rng(1)
    n = 60
    region = rng.integers(0, 3, n)
    law = RegionalLaw(COULOMB, {"rough": ROUGH, "sub": SUB}, region)
    # the union of the laws' variables, in order (the subloading law's start traction f last)
    assert [v.name for v in law.variables] == ["up", "mu", "r", "f"]
    state = law.initial_state(n, nt)
    # virgin values: the subloading points start at mu_s, Coulomb points have mu = 0
    np.testing.assert_array_equal(state.mu[region == 2], SUB.mu_s)
    np.testing.assert_array_equal(state.mu[region != 2], 0.0)
    # a few steps of random loading: each region as its own law alone
    alone = {k: m.initial_state(int(np.sum(region == k)), nt) for k, m in enumerate(law.laws)}
    for _ in range(4):
        gap = random_gap(rng, n, nt)
        res = law.return_map(gap, state, 0.1)
        for k, m in enumerate(law.laws):
            idx = region == k
            ref = m.return_map(gap[idx], alone[k], 0.1)
            np.testing.assert_array_equal(res.traction[idx], ref.traction)
            np.testing.assert_array_equal(res.tangent[idx], ref.tangent)
            np.testing.assert_array_equal(res.status[idx], ref.status)
            for name, a in ref.state.items():
                np.testing.assert_array_equal(res.state[name][idx], a)
            if k < 2:  # Coulomb points: mu and r untouched
                np.testing.assert_array_equal(res.state.mu[idx], state.mu[idx])
                np.testing.assert_array_equal(res.state.r[idx], state.r[idx])
            np.testing.assert_array_equal(
                law.strength(res.state, res.traction[:, nt], 0.1)[idx],
                m.strength(ref.state, ref.traction[:, nt], 0.1),
            )
            alone[k] = ref.state
        assert np.any(res.status == Status.PLASTIC) and np.any(res.status == Status.SEPARATED)
        state = res.state


def test_out_state_and_inputs():
    region = np.array([0, 1, 1, 0])
    law = RegionalLaw(COULOMB, {"rough": ROUGH}, region)
    st = law.initial_state(4, 1)
    before = {k: a.copy() for k, a in st.items()}
    out = InterfaceState.zeros(law.variables, 4, 1)
    res = law.return_map(np.full((4, 2), 0.01), st, 0.0, out=out)
    assert res.state is out
    for k, a in st.items():
        np.testing.assert_array_equal(a, before[k])  # inputs never mutated
    with pytest.raises(ValueError, match="out must not be the input state"):
        law.return_map(np.zeros((4, 2)), st, 0.0, out=st)
    with pytest.raises(ValueError, match="has 4 points, got 3"):
        law.initial_state(3, 1)


def test_description_lists_every_region():
    law = RegionalLaw(COULOMB, {"rough": ROUGH}, np.array([0, 1]))
    d = law_description(law)
    assert d == {
        "law": "regions",
        "params": {
            "default": law_description(COULOMB),
            "regions": {"rough": law_description(ROUGH)},
        },
    }
    assert law.alpha_n == 800.0 and law.alpha_t == 500.0  # the stiffest


def test_bad_regional_laws_are_refused():
    with pytest.raises(ValueError, match="may not be named 'default'"):
        RegionalLaw(COULOMB, {"default": ROUGH}, np.zeros(2, int))
    with pytest.raises(ValueError, match=r"region numbers must be a 1-D array in \[0, 1\]"):
        RegionalLaw(COULOMB, {"rough": ROUGH}, np.array([0, 2]))
    with pytest.raises(ValueError, match=r"region numbers"):
        RegionalLaw(COULOMB, {"rough": ROUGH}, np.array([-1, 0]))
