"""Hypothesis-generated open chains (tests/random_chains.py): eomc's KanesMethod vs SymPy's."""
import pytest
import sympy.physics.mechanics as sme
from hypothesis import given, settings

import eomc.mechanics as em
from eomc.errors import ModelError
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
    M = ours.mass_matrix
    if any(all(M[i, j] == 0 for i in range(M.rows)) for j in range(M.cols)):
        # a link whose particle sits on its own pin axis: no inertia about it (issue 8, bad input)
        with pytest.raises(ModelError, match="has no inertia"):
            ours.formed()
        return
    f = ours.formed()
    assert f.dynamics_matrix.shape == (f.nu, f.nu)
