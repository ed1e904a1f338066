"""LagrangesMethod.linearize(): closed forms and SymPy 1.14's Linearizer results."""

import pytest
import sympy as sm
import sympy.physics.mechanics as sme

from helpers import lagrange_mechanisms as mechs
from helpers import lagrange_numeric as num
from helpers import zoo

import eomc.mechanics as em
from eomc.errors import ModelError

t = sme.dynamicsymbols._t


def _rest(qs):
    op = {q: 0 for q in qs}
    op.update({q.diff(t): 0 for q in qs})
    op.update({q.diff(t, 2): 0 for q in qs})
    return op


def test_pendulum_on_cart_A_and_B_closed_form():
    """Inverted pendulum (point mass m1, rod l0) on a cart m0, upright: textbook A, B."""
    lm, (F,) = zoo.n_link_pendulum_on_cart_lagrange(1, em)
    q0, q1 = lm.q
    m0, m1, l0, g = sm.symbols("m0 m1 l0 g")
    op = _rest([q0, q1])
    op[F] = 0
    A, B, r = lm.linearize(q_ind=[q0, q1], qd_ind=[q0.diff(t), q1.diff(t)],
                           op_point=op, A_and_B=True)
    A_expected = sm.Matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                            [0, m1 * g / m0, 0, 0],
                            [0, (m0 + m1) * g / (m0 * l0), 0, 0]])
    B_expected = sm.Matrix([0, 0, 1 / m0, 1 / (m0 * l0)])
    assert (A - A_expected).applyfunc(sm.simplify) == sm.zeros(4, 4)
    assert (B - B_expected).applyfunc(sm.simplify) == sm.zeros(4, 1)
    assert r == sm.Matrix([F])
    # without arguments the coordinates and speeds are all independent
    A2, B2, _ = lm.linearize(op_point=op, A_and_B=True)
    assert (A2 - A_expected).applyfunc(sm.simplify) == sm.zeros(4, 4)


def test_two_link_cart_M_A_B_match_sympy():
    ours, _ = zoo.n_link_pendulum_on_cart_lagrange(2, em)
    theirs, _ = zoo.n_link_pendulum_on_cart_lagrange(2, sme)
    kw = dict(q_ind=list(ours.q), qd_ind=list(ours.u))
    M1, A1, B1, r1 = ours.linearize(**kw)
    M2, A2, B2, r2 = theirs.linearize(**kw)
    assert r1 == r2
    num.assert_same_at_seeds([("M", M1, M2), ("A", A1, A2), ("B", B1, B2)], seeds=(0, 1))


def test_sphere_with_dependent_coordinate_closed_form():
    """At the bottom of the sphere the particle is a damped pendulum of length R."""
    lm = mechs.particle_on_sphere(em)
    x, y, z = lm.q
    F = sme.dynamicsymbols("F")
    m, g, R, c = sm.symbols("m g R c", positive=True)
    op = _rest([x, y, z])
    op.update({z: -R, F: 0})
    op.update(lm.solve_multipliers(op))
    A, B, r = lm.linearize(q_ind=[x, y], q_dep=[z], qd_ind=[x.diff(t), y.diff(t)],
                           qd_dep=[z.diff(t)], op_point=op, A_and_B=True)
    A_expected = sm.Matrix([[0, 0, 1, 0], [0, 0, 0, 1],
                            [-g / R, 0, -c / m, 0], [0, -g / R, 0, -c / m]])
    assert (A - A_expected).applyfunc(sm.simplify) == sm.zeros(4, 4)
    assert (B - sm.Matrix([0, 0, 1 / m, 0])).applyfunc(sm.simplify) == sm.zeros(4, 1)
    assert r == sm.Matrix([F])
    theirs = mechs.particle_on_sphere(sme)
    A2, B2, _ = theirs.linearize(q_ind=[x, y], q_dep=[z], qd_ind=[x.diff(t), y.diff(t)],
                                 qd_dep=[z.diff(t)], op_point=op, A_and_B=True)
    assert (A - A2).applyfunc(sm.simplify) == sm.zeros(4, 4)


def test_linearize_partition_errors():
    lm = mechs.particle_on_sphere(em)
    x, y, z = lm.q
    with pytest.raises(ModelError, match="dependent coordinates"):
        lm.linearize(q_ind=[x, y, z], qd_ind=list(lm.u))
    with pytest.raises(ModelError, match="partition q"):
        lm.linearize(q_ind=[x, x], q_dep=[z], qd_ind=list(lm.u[:2]), qd_dep=[lm.u[2]])


def test_to_linearizer_is_a_sympy_linearizer():
    lm = mechs.spring_damper_chain(2, em)
    lin = lm.to_linearizer(q_ind=list(lm.q), qd_ind=list(lm.u))
    assert isinstance(lin, sme.Linearizer)
    assert list(lin.r) == [sme.dynamicsymbols("F")]
