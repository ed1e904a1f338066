"""measure_numbers.tidy: exact rewrites of the user's measure numbers in Kane's reader."""
import random

import pytest
import sympy as sm

from eomc.compiler.mechanics.measure_numbers import tidy

a, b, d, r, u1, u2, x = sm.symbols("a b d r u1 u2 x")
s, c = sm.sin, sm.cos
ANGLES = {a + b, -(a + b), a - b, b - a, a + b + d}


def _same_value(e, f):
    rng = random.Random(7)
    for _ in range(3):
        vals = {v: rng.uniform(-2, 2) for v in (a, b, d, r, u1, u2, x)}
        assert abs(float(e.subs(vals)) - float(f.subs(vals))) < 1e-12


@pytest.mark.parametrize("expr, want", [
    (c(a) * c(b) - s(a) * s(b), c(a + b)),
    (c(a) * c(b) + s(a) * s(b), c(a - b)),
    (s(a) * c(b) + c(a) * s(b), s(a + b)),
    (s(a) * c(b) - c(a) * s(b), s(a - b)),
    (3 * r * (c(a) * c(b) - s(a) * s(b)) + x, 3 * r * c(a + b) + x),
    (-s(a) * s(b) * s(d) + s(d) * c(a) * c(b), s(d) * c(a + b)),
    # nested products of rotations contract bottom-up to a sum of three angles
    ((c(a) * c(b) - s(a) * s(b)) * c(d) - (s(a) * c(b) + c(a) * s(b)) * s(d), c(a + b + d)),
])
def test_contracts_angle_sums_it_is_given(expr, want):
    out = tidy(expr, angles=ANGLES)
    assert out == want
    _same_value(out, expr)


def test_contracts_across_products_of_a_sine_or_cosine_and_a_sum():
    """cos a (cos b X − sin b Y) + sin a (−sin b X − cos b Y): pairs meet only multiplied out."""
    X, Y = sm.symbols("X Y")
    expr = c(a) * (c(b) * X - s(b) * Y) + s(a) * (-s(b) * X - c(b) * Y)
    out = tidy(expr, angles=ANGLES)
    assert out == X * c(a + b) - Y * s(a + b)
    _same_value(out.subs({X: x, Y: r}), expr.subs({X: x, Y: r}))


@pytest.mark.parametrize("expr", [
    c(a) * c(d) - s(a) * s(d),              # a + d is not one of the angles: left alone
    2 * c(a) * c(b) - 3 * s(a) * s(b),      # coefficients fit no identity
    c(a) * c(b),
])
def test_leaves_other_sums_alone(expr):
    assert tidy(expr, angles=ANGLES) == expr


def test_groups_terms_that_differ_only_in_the_speed():
    expr = u1 * r * c(a) + 2 * u2 * r * c(a) + u1 * x + u1 * u2 * r
    out = tidy(expr, speeds={u1, u2})
    assert out == r * c(a) * (u1 + 2 * u2) + u1 * x + u1 * u2 * r
    _same_value(out, expr)
