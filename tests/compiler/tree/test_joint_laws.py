"""compiler/tree/joint_laws.py: what ``ramp`` tells SymPy's assumptions."""
import math

import sympy as sm

from eomc.compiler.tree.joint_laws import limit_spring, ramp


def test_ramp_of_a_real_argument_is_real_and_finite():
    """max(x, 0) of a real x is real and finite (what SymPy's Mul.flatten asks of the limit law's
    r**3/(r + E)**2 while the MJCF build renames it: unanswered, it rebuilt sub-sums to find out);
    of an argument SymPy knows nothing about, it says nothing."""
    x = sm.Symbol("x", real=True)
    assert ramp(x).is_real is True and ramp(x).is_finite is True
    assert ramp(x - sm.Symbol("p", real=True)).is_finite is True
    assert (sm.Symbol("E", real=True) + ramp(x)).is_infinite is False
    y = sm.Symbol("y")
    assert ramp(y).is_real is None and ramp(y).is_finite is None
    assert ramp(sm.Symbol("z", extended_real=True)).is_finite is None


def test_ramp_values_are_unchanged():
    x = sm.Symbol("x", real=True)
    assert ramp(sm.Integer(-2)) == 0 and ramp(sm.Rational(3, 2)) == sm.Rational(3, 2)
    assert ramp(x).subs(x, -1) == 0 and ramp(x).subs(x, 2) == 2
    s = limit_spring(x, sm.Float(0.1))
    assert math.isclose(float(s.subs(x, 0.3)), 0.3 ** 3 / 0.4 ** 2, rel_tol=1e-15)
    assert s.subs(x, -0.3) == 0
