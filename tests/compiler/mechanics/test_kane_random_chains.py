"""Hypothesis-generated open chains (tests/random_chains.py): eomc's KanesMethod vs SymPy's."""
import sympy.physics.mechanics as sme
from hypothesis import given, settings

import eomc.mechanics as em
from helpers.kane_oracle import assert_close, evaluate, random_point
from helpers.random_chains import build, chain


@settings(max_examples=12, deadline=None)
@given(chain)
def test_random_chain_matches_sympy(spec):
    ours = build(em, spec)
    ref = build(sme, spec)
    mats = [ours.mass_matrix_full, ours.forcing_full, ref.mass_matrix_full, ref.forcing_full]
    pt = random_point(mats, 0)
    assert_close(evaluate(mats[0], pt), evaluate(mats[2], pt), what="mass_matrix_full")
    assert_close(evaluate(mats[1], pt), evaluate(mats[3], pt), what="forcing_full")
    f = ours.formed()
    assert f.dynamics_matrix.shape == (f.nu, f.nu)
