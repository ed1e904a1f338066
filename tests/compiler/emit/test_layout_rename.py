"""compiler/emit/layout.py: the rename's powers built as they stand are the ones SymPy's evaluation builds."""
import itertools

import sympy as sm

from eomc.compiler.emit.layout import power_as_it_stands
from eomc.compiler.tree.joint_laws import ramp


def _bases():
    x, y, p = sm.symbols("x_0 x_1 p_0", real=True)
    f = sm.Function("f")(sm.Symbol("t"))
    E = sm.Symbol("E")
    return [x + p, ramp(x - p) + p, x ** 2 + sm.Float(0.0049) + (p - sm.Float(1.5e-17)) ** 2,
            sm.Float(0.25) * x * y - sm.tanh(x / p) + 3, f + E, -x - y, x * y + sm.sqrt(x ** 2 + 1),
            (x + ramp(y)) ** 2 + p ** 2]


EXPONENTS = [sm.S.Half, -sm.S.Half, sm.Rational(5, 2), sm.Integer(2), sm.Integer(3), sm.Integer(-1), sm.Integer(-2),
             sm.Rational(-3, 2), sm.Rational(1, 3)]


def test_power_as_it_stands_is_sympys_own_power():
    """Every (base, exponent) the shortcut takes gives the expression Pow's evaluation gives."""
    taken = 0
    for base, e in itertools.product(_bases(), EXPONENTS):
        got = power_as_it_stands(base, e)
        assert got is not None, (base, e)
        taken += 1
        assert got == sm.Pow(base, e) and got.args == sm.Pow(base, e).args, (base, e)
        assert got.is_commutative
    assert taken == len(_bases()) * len(EXPONENTS)


def test_power_as_it_stands_leaves_the_rest_to_sympy():
    """Numbers, sums with I or an infinity, exponents 0, 1 or symbolic, and bases that are not sums
    are evaluated by SymPy (None): there its evaluation can give something else."""
    x, p = sm.symbols("x p", real=True)
    for base, e in [(sm.sqrt(2) + 1, sm.S.Half), (x + sm.I, sm.Integer(2)), (x + sm.oo, sm.S.Half),
                    (x + sm.zoo, -sm.S.Half), (x + p, sm.S.Zero), (x + p, sm.S.One), (x + p, p),
                    (x * p, sm.S.Half), (x, sm.Integer(2)), (sm.Float(2.0) + sm.Integer(1), sm.S.Half)]:
        assert power_as_it_stands(sm.sympify(base), e) is None, (base, e)
    b = 1 + 2 * sm.I     # why: Add._eval_power evaluates a number's power (here with I) to something else
    assert not (b ** -1).is_Pow and sm.expand(b ** -1 - (1 - 2 * sm.I) / 5) == 0
