"""Random Lagrangians (hypothesis) against SymPy, and Lagrange vs Kane on the same cart."""

import numpy as np
import sympy as sm
import sympy.physics.mechanics as sme
from hypothesis import given, settings, strategies as st

from helpers import lagrange_numeric as num
from helpers import zoo

import eomc.mechanics as em

t = sme.dynamicsymbols._t
Q = sme.dynamicsymbols("q1:4")
F = sme.dynamicsymbols("F")
a, b = sm.symbols("a b")


def _factor(draw, n):
    """A random function of the coordinates, time and an input."""
    atoms = [sm.sin(Q[draw(st.integers(0, n - 1))]), sm.cos(Q[draw(st.integers(0, n - 1))]),
             Q[draw(st.integers(0, n - 1))], a, sm.cos(t), F,
             Q[draw(st.integers(0, n - 1))].diff(t),
             sm.exp(Q[draw(st.integers(0, n - 1))] / 3),  # via the fallback
             sm.sqrt(2 + sm.sin(Q[draw(st.integers(0, n - 1))] * t))]
    picks = draw(st.lists(st.integers(0, len(atoms) - 1), min_size=1, max_size=3))
    return draw(st.integers(-3, 3)) * sm.Mul(*[atoms[i] for i in picks])


@st.composite
def lagrangians(draw):
    """L = 1/2 q'^T (D + S(q)) q' + (terms linear in q', with q, t, F) - V(q, t)."""
    n = draw(st.integers(1, 3))
    qd = [q.diff(t) for q in Q[:n]]
    L = sum((i + 2) * b * v**2 for i, v in enumerate(qd)) / 2
    for _ in range(draw(st.integers(0, 4))):
        i, j = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
        L += _factor(draw, n) * qd[i] * qd[j] / 10
    for _ in range(draw(st.integers(0, 3))):
        L += _factor(draw, n) * (qd[draw(st.integers(0, n - 1))] if draw(st.booleans()) else 1)
    cons = []
    if n > 1 and draw(st.booleans()):
        cons = [qd[0] - sm.cos(Q[1]) * qd[1] + _factor(draw, n) / 5]
    return L, list(Q[:n]), cons


@settings(max_examples=10, deadline=None)
@given(lagrangians())
def test_random_lagrangians_match_sympy(case):
    L, qs, cons = case
    ours = em.LagrangesMethod(L, qs, nonhol_coneqs=cons or None)
    theirs = sme.LagrangesMethod(L, qs, nonhol_coneqs=cons or None)
    ours.form_lagranges_equations()
    theirs.form_lagranges_equations()
    num.assert_same_at_seeds([("M_full", ours.mass_matrix_full, theirs.mass_matrix_full),
                              ("f_full", ours.forcing_full, theirs.forcing_full)],
                             seeds=(0, 1), rtol=1e-11)


def test_lagrange_and_kane_give_the_same_accelerations():
    """n-link pendulum on a cart (n = 5): eomc Lagrange vs eomc Kane, rhs numerically."""
    n = 5
    lag, _ = zoo.n_link_pendulum_on_cart_lagrange(n, em)
    kane, _ = zoo.n_link_pendulum_on_cart(n, em)
    u, qd = list(kane.u), list(lag.u)
    keys = list(num.random_values([kane.mass_matrix_full, kane.forcing_full]))
    lkeys = [dict(zip(u, qd)).get(k, k) for k in keys]
    fk = [num.compile_matrix(m, keys) for m in (kane.mass_matrix_full, kane.forcing_full)]
    fl = [num.compile_matrix(m, lkeys) for m in (lag.mass_matrix_full, lag.forcing_full)]
    for seed in range(3):
        kvals = num.random_values([kane.mass_matrix_full, kane.forcing_full], seed=seed)
        lvals = {lk: kvals[k] for k, lk in zip(keys, lkeys)}
        xk = np.linalg.solve(fk[0](kvals), fk[1](kvals))
        xl = np.linalg.solve(fl[0](lvals), fl[1](lvals))
        assert np.allclose(xk, xl, rtol=1e-11, atol=1e-11 * np.max(np.abs(xk)))
