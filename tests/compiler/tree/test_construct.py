"""The recursions' expression helpers (_add, _mul) build what SymPy's operators build.

They skip SymPy's flatten for plain shapes (distinct Symbols, products of them): the C
the recursions give must not change, so the objects must be identical -- same type, same
args in the same order -- to the left-to-right ``t1 + t2 + ...`` / ``f1 * f2 * ...`` of
the non-zero operands, for every input, including the shapes the fast paths must refuse
(like terms that combine, repeated factors, numbers, Floats, nested sums, zeros); and
equal in value to ``sum(terms, S.Zero)``.
"""
import functools
import operator
import random

import sympy as sm

from eomc.compiler.tree.construct import _add, _mul

SYMS = sm.symbols("_t0:6 a b", real=True)
C = sm.Symbol("c")                     # no assumptions


def _pool():
    s = SYMS
    x = s[0]
    return list(s) + [C, s[1] * s[2], -s[1] * s[2], 2 * s[3], sm.Rational(1, 3) * s[4] * s[5],
                      sm.Float(0.25) * s[0], s[0] ** 2, sm.sin(x), s[1] + s[2], -x, 3, 0,
                      sm.S.Zero, sm.S.One, sm.Float(0.0), sm.Float(1.5), sm.Rational(-2, 7)]


def _same(a, b):
    a, b = sm.sympify(a), sm.sympify(b)
    return type(a) is type(b) and a == b and a.args == b.args


def _structural_zero(x):
    return x is sm.S.Zero or (type(x) is int and x == 0)


def _value(e, at):
    return complex(sm.sympify(e).subs(at))


def test_add_and_mul_are_sympys_own():
    pool = _pool()
    rng = random.Random(19)
    at = {s: rng.uniform(-2, 2) for s in list(SYMS) + [C]}
    for _ in range(1500):
        terms = [rng.choice(pool) for _ in range(rng.randint(1, 6))]
        kept = [t for t in terms if not _structural_zero(t)]
        got = _add(terms)
        assert _same(got, functools.reduce(operator.add, kept) if kept else sm.S.Zero), (terms, got)
        assert abs(_value(got, at) - _value(sum(terms, sm.S.Zero), at)) < 1e-12
        factors = [rng.choice(pool) for _ in range(rng.randint(1, 4))]
        got = _mul(*factors)
        want = (sm.S.Zero if any(_structural_zero(f) for f in factors)
                else functools.reduce(operator.mul, factors))
        assert _same(got, want), (factors, got)


def test_fast_paths_are_taken_and_ordered():
    a, b, c = sm.symbols("_t10 _t2 _t7", real=True)
    p = _mul(c, a, b)
    assert p.args == sm.Mul(a, b, c).args and p.func is sm.Mul
    q = _add([c * a, -a * b, b])
    assert q.args == (a * c - a * b + b).args
    assert _add([a * b, -a * b]) == 0          # like terms: SymPy's flatten combines them
    assert _mul(a, a) == a ** 2                # a repeated factor: SymPy makes a power
