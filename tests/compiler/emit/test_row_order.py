"""The compile-time row order of the unrolled LU (emit/sparse_lu.py) and its numeric evaluator."""
import math

import pytest
import sympy as sm

from eomc.compiler.emit.sparse_lu import _value, static_row_order

a, b, c = sm.symbols("a b c", real=True)
VALS = {a: 0.7, b: 1.3, c: -0.4}


@pytest.mark.parametrize("expr", [
    a * b + sm.sin(c) ** 2 - 3 * a / b,
    sm.cos(a * b) * sm.exp(c) + sm.sqrt(b) - sm.Rational(1, 3) * sm.pi,
    (a + b) ** -2 + sm.atan(c) * sm.tanh(a) + sm.Abs(c),
    sm.sqrt(c) * sm.sqrt(c),             # complex on the way: SymPy's answer (-0.4) is kept
    sm.Max(a, b) * c,                    # unknown to the fast path: SymPy evaluates it
])
def test_value_matches_sympy(expr):
    want = float(expr.xreplace({s: sm.Float(v) for s, v in VALS.items()}))
    assert math.isclose(_value(expr, VALS, {}), want, rel_tol=1e-13, abs_tol=1e-15)


def test_partial_pivoting_picks_the_larger_row():
    A = sm.Matrix([[a, 1], [10 * b + 5, 1]])
    pattern = frozenset((i, j) for i in range(2) for j in range(2))
    assert static_row_order(A, pattern) == (1, 0)
    assert static_row_order(sm.Matrix([[10 * b + 5, 1], [a, 1]]), pattern) == (0, 1)
