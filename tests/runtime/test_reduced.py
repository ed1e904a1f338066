"""model.linearize_reduced: the Jacobian over the independent states of a constrained model.

Oracles: the Cartesian pendulum's small oscillations (eigenvalues +-i sqrt(g/l) instead of
the full A's spurious extra pair), and, away from equilibrium, central differences of the
rhs along the constraint manifold (model.consistent_state completes each perturbed state).
"""
import numpy as np
import pytest
import sympy as sm

from helpers import zoo

import eomc
import eomc.mechanics as me
from eomc.mechanics import LagrangesMethod, dynamicsymbols
from eomc.runtime.errors import ModelError


@pytest.fixture(scope="module")
def cpend(tmp_path_factory):
    x, y = dynamicsymbols("x y")
    m, g, l = sm.symbols("m g l")
    lm = LagrangesMethod(m / 2 * (x.diff() ** 2 + y.diff() ** 2) - m * g * y, [x, y],
                         hol_coneqs=[x ** 2 + y ** 2 - l ** 2])
    lm.form_lagranges_equations()
    return eomc.compile(lm, "cpend", parameters={m: 2.0, g: 9.81, l: 1.5},
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def _manifold_jacobian(model, x, states, h=1e-6):
    """Central differences of the independent rows of rhs along the manifold."""
    ind = [model.state_names.index(s) for s in states]
    J = np.empty((len(ind), len(ind)))
    for j, i in enumerate(ind):
        cols = []
        for sign in (1, -1):
            z = x.copy()
            z[i] += sign * h
            z = model.consistent_state(z, fixed=states)
            cols.append(model.rhs(0.0, z)[ind])
        J[:, j] = (cols[0] - cols[1]) / (2 * h)
    return J


def test_non_minimal_pendulum_has_two_eigenvalues(cpend):
    bottom = np.array([0.0, -1.5, 0.0, 0.0])
    A_full, _ = cpend.linearize(0.0, bottom)
    lin = cpend.linearize_reduced(0.0, bottom)
    assert lin.states == ("x", "x'") and lin.A.shape == (2, 2) and A_full.shape == (4, 4)
    np.testing.assert_allclose(lin.A, [[0, 1], [-9.81 / 1.5, 0]], atol=1e-12)
    np.testing.assert_allclose(sorted(np.linalg.eigvals(lin.A).imag), [-np.sqrt(9.81 / 1.5),
                                                                       np.sqrt(9.81 / 1.5)], rtol=1e-12)
    # away from equilibrium, moving: against differences along the manifold
    th, w = 0.6, 0.8
    X = np.array([1.5 * np.sin(th), -1.5 * np.cos(th), 1.5 * w * np.cos(th), 1.5 * w * np.sin(th)])
    lin = cpend.linearize_reduced(0.0, X)
    np.testing.assert_allclose(lin.A, _manifold_jacobian(cpend, X, lin.states), rtol=1e-6, atol=1e-7)
    other = cpend.linearize_reduced(0.0, X, fixed=["y", "y'"])
    assert other.states == ("y", "y'")
    np.testing.assert_allclose(other.A, _manifold_jacobian(cpend, X, other.states), rtol=1e-6,
                               atol=1e-7)


def test_four_bar_reduced_against_manifold_differences(tmp_path):
    kane, _ = zoo.four_bar(me)
    values = dict(l1=1.0, l2=2.0, l3=1.5, l4=2.0, g=9.81, m1=1.0, m2=1.0, m3=1.0, I1=0.1, I2=0.3,
                  I3=0.2)
    model = eomc.compile(kane, "fourbar", parameters={sm.Symbol(k): v for k, v in values.items()},
                         cache_dir=tmp_path, progress=False)
    x = model.consistent_state([0.9, 0.1, -1.5, 0.7, 0.0, 0.0])
    lin = model.linearize_reduced(0.0, x)
    assert lin.states == ("q1", "u1") and lin.B.shape == (2, 1)
    np.testing.assert_allclose(lin.A, _manifold_jacobian(model, x, lin.states), rtol=1e-6, atol=1e-6)
    with pytest.raises(ModelError, match="off the constraints"):
        model.linearize_reduced(0.0, [0.9, 0.1, -1.5, 0.7, 0.0, 0.0])
