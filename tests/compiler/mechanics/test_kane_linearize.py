"""Linearization against closed forms: pendulum on a cart, rolling disc stability."""

import numpy as np
import pytest
import sympy as sm

from helpers import zoo

import eomc.mechanics as em


def test_pendulum_on_cart_state_space_matches_hand_derivation():
    km, (F,) = zoo.n_link_pendulum_on_cart(1, em)
    q0, q1 = km.q
    u0, u1 = km.u
    m0, m1, l0, g = sm.symbols("m0 m1 l0 g")
    A, B, r = km.linearize(A_and_B=True, op_point={q0: 0, q1: 0, u0: 0, u1: 0})
    # Inverted pendulum on a cart, by hand (Lagrange, small angles):
    # M = [[m0+m1, -m1 l], [-m1 l, m1 l^2]], M [q0'', q1''] = [F, m1 g l q1].
    A_hand = sm.Matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                        [0, m1 * g / m0, 0, 0], [0, (m0 + m1) * g / (m0 * l0), 0, 0]])
    B_hand = sm.Matrix([0, 0, 1 / m0, 1 / (m0 * l0)])
    assert list(r) == [F]
    assert sm.simplify(A - A_hand) == sm.zeros(4, 4)
    assert sm.simplify(B - B_hand) == sm.zeros(4, 1)


def test_bare_linearize_is_the_seeds_jacobian_of_forcing_full():
    km, (F,) = zoo.n_link_pendulum_on_cart(1, em)
    A, B = km.linearize()
    x = list(km.q) + list(km.u)
    assert A == km.forcing_full.jacobian(x)
    assert B == sm.Matrix([0, 0, 1, 0])
    M, A2, B2, r = km.linearize(op_point={s: 0 for s in x})
    assert M.shape == (4, 4) and list(r) == [F]


def _upright_A():
    """A(ω) of the rolling disc rolling upright at spin rate ω (m = r = g = 1)."""
    km, _ = zoo.rolling_disc(em)
    t = sm.Symbol("t")
    q = list(km.q)
    u = list(km.u)
    q1, q2, q3, q4, q5, q6 = q
    u1, u2, u3, u4, u5, u6 = u
    q1d, q2d, q3d, q4d, q5d, q6d = [qi.diff(t) for qi in q]
    u1d, u2d, u3d, u4d, u5d, u6d = [ui.diff(t) for ui in u]
    r, g, m = sm.symbols("r g m")
    # The operating point of SymPy's own rolling-disc linearization example.
    q_op = {q6: -r * sm.cos(q2)}
    u_op = {u1: 0, u2: sm.sin(q2) * q1d + q3d, u3: sm.cos(q2) * q1d,
            u4: -r * (sm.sin(q2) * q1d + q3d) * sm.cos(q3), u5: 0,
            u6: -r * (sm.sin(q2) * q1d + q3d) * sm.sin(q3)}
    qd_op = {q2d: 0, q4d: -r * (sm.sin(q2) * q1d + q3d) * sm.cos(q1),
             q5d: -r * (sm.sin(q2) * q1d + q3d) * sm.sin(q1), q6d: 0}
    ud_op = {u1d: 4 * g * sm.sin(q2) / (5 * r) + sm.sin(2 * q2) * q1d**2 / 2
             + 6 * sm.cos(q2) * q1d * q3d / 5,
             u2d: 0, u3d: 0,
             u4d: r * (sm.sin(q2) * sm.sin(q3) * q1d * q3d + sm.sin(q3) * q3d**2),
             u5d: r * (4 * g * sm.sin(q2) / (5 * r) + sm.sin(2 * q2) * q1d**2 / 2
                       + 6 * sm.cos(q2) * q1d * q3d / 5),
             u6d: -r * (sm.sin(q2) * sm.cos(q3) * q1d * q3d + sm.cos(q3) * q3d**2)}
    A, B, _ = km.linearize(op_point=[q_op, u_op, qd_op, ud_op], A_and_B=True)
    upright = {q1d: 0, q2: 0, m: 1, r: 1, g: 1}
    w = sm.Symbol("omega")
    A = A.subs(upright).subs(q3d, w).subs({q1: 0.3, q3: 0.2})
    f = sm.lambdify(w, A, "numpy")
    return lambda omega: np.array(f(omega), dtype=float)


@pytest.fixture(scope="module")
def upright():
    return _upright_A()


@pytest.mark.parametrize("omega2, stable", [(0.2, False), (0.3, False), (0.4, True), (1.0, True)])
def test_rolling_disc_upright_stability_threshold(upright, omega2, stable):
    """Upright rolling at spin rate ω is stable iff ω² > g/(3r) (here g = r = 1)."""
    eig = np.linalg.eigvals(upright(np.sqrt(omega2)))
    growth = max(eig.real)
    if stable:
        assert growth < 1e-9, eig
    else:
        assert growth > 1e-3, eig


def test_rolling_disc_critical_speed_all_eigenvalues_zero(upright):
    eig = np.linalg.eigvals(upright(1 / np.sqrt(3)))
    assert max(abs(eig)) < 1e-5, eig
