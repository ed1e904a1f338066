"""The reverse-mode pass (compiler/passes/adjoint.py) against SymPy's derivatives of the
unshared expressions, and forward-over-reverse (tangent of its results) against the
Hessian-vector product SymPy computes."""
import sympy as sm
from hypothesis import given, settings, strategies as st

from eomc.compiler.ir import Program, evaluate, verify
from eomc.compiler.passes import adjoint, cse, tangent
from eomc.compiler.passes.adjoint import _partial

from helpers.random_expressions import LEAVES, P, X, exprs, values  # noqa: F401

L = sm.symbols("l_0:4", real=True)      # weights (C: an array the caller fills)
V = sm.symbols("v_0:6", real=True)      # a direction for the Hessian-vector product


def _program(es):
    return Program(inputs=X + P + L + V, results=tuple((("out", i), e) for i, e in enumerate(es)))


def _env(v, weights, direction):
    env = dict(zip(X + P, v))
    env.update(zip(L, weights))
    env.update(zip(V, direction))
    return env


def _num(e, env):
    return complex(sm.sympify(e).xreplace({s: sm.Float(x, 30) for s, x in env.items()}).evalf(30))


@settings(max_examples=60, deadline=None)
@given(st.lists(exprs, min_size=1, max_size=4), values,
       st.lists(st.floats(-2, 2), min_size=4, max_size=4),
       st.lists(st.floats(-2, 2), min_size=6, max_size=6))
def test_gradient_and_hessian_vector_product(es, v, weights, direction):
    wrt = X + P
    prog = cse(_program(es))
    prog = verify(adjoint(prog, {("out", i): L[i] for i in range(len(es))}, wrt, "g"))
    prog = verify(tangent(prog, "g", dict(zip(wrt, V)), "h"))
    env = _env(v, weights, direction)
    got = evaluate(prog, env)
    S = sm.Add(*[L[i] * e for i, e in enumerate(es)])
    for k, s in enumerate(wrt):
        ref = _num(sm.diff(S, s), env)
        assert abs(got.get(("g", k), 0) - ref) <= 1e-12 * max(1.0, abs(ref)), (k, s)
        hv = _num(sm.Add(*[sm.diff(S, s, r) * V[j] for j, r in enumerate(wrt)]), env)
        assert abs(got.get(("h", k), 0) - hv) <= 1e-11 * max(1.0, abs(hv)), (k, s)


def test_only_active_temporaries_get_adjoints():
    """A subexpression that does not depend on the wrt symbols costs nothing in reverse."""
    x0, p0 = X[0], P[0]
    heavy = sm.sin(p0) * sm.cos(p0) + sm.exp(p0)
    prog = cse(_program([heavy * x0, heavy * x0 ** 2]))
    n = len(prog.assignments)
    out = adjoint(prog, {("out", 0): L[0], ("out", 1): L[1]}, (x0,), "g")
    assert len(out.assignments) - n <= 1
    assert set(k for k, _ in out.results if k[0] == "g") == {("g", 0)}


def test_deterministic_names_and_order():
    es = [sm.sin(X[0] * X[1]) + X[2] ** 3, sm.cos(X[0] * X[1]) * P[0]]
    a = adjoint(cse(_program(es)), {("out", 0): L[0], ("out", 1): L[1]}, X + P, "g")
    b = adjoint(cse(_program(es)), {("out", 0): L[0], ("out", 1): L[1]}, X + P, "g")
    assert a == b


def test_partial_of_rare_shapes():
    x = X[0]
    assert sm.simplify(_partial(sm.atan2(x, X[1]), x) - sm.diff(sm.atan2(x, X[1]), x)) == 0
    assert _partial(x ** X[1], X[1]) == sm.diff(x ** X[1], X[1])


def test_equal_symbols_that_are_different_objects():
    """SymPy's symbol cache is bounded: an expression may hold a symbol equal to, but not
    the same object as, the one differentiated for (a second build in one process once
    lost terms this way)."""
    x = sm.Symbol("x_0", real=True)
    twin = sm.Symbol.__xnew__(sm.Symbol, "x_0", real=True)
    assert twin == x and twin is not x
    e = sm.Mul(X[1], sm.Add(sm.Mul(-1, X[2], twin), X[3]))
    assert sm.expand(_partial(e, x) - sm.diff(e, x)) == 0 and _partial(e, x) != 0


def test_the_contact_laws_cusp_is_guarded_in_second_derivatives():
    """k·|δ₊|^{3/2} (compiler/contact/law.py), δ₊ = (δ + |δ|)/2: forward over reverse (hvp) and
    forward over forward (hess_id) give 0 out of contact (they gave (3/4)k|δ₊|^{-1/2}·0 = ∞·0 = NaN),
    the closed form (3/4)k δ^{-1/2} in contact, and 0 at δ = 0 exactly (the law's branch δ ≤ 0:
    docs/derivatives.md); first derivatives hold no guard."""
    from eomc.compiler.passes import differentiate
    from eomc.compiler.passes.diff import _slope, cusp_pow
    d, k = X[0], P[0]
    law = k * sm.Abs((d + sm.Abs(d)) / 2) ** sm.Rational(3, 2)
    prog = cse(_program([law]))
    rev = verify(tangent(verify(adjoint(prog, {("out", 0): L[0]}, (d,), "g")), "g", {d: V[0]}, "h"))
    fwd = verify(differentiate(verify(differentiate(prog, "out", (d,), "j")), "j", (d,), "jj"))
    for at, want in ((-0.3, 0.0), (0.0, 0.0), (0.25, 0.75 * 2.0 * 0.25 ** -0.5)):
        env = {**{s: 0.5 for s in X + P + L + V}, d: at, k: 2.0, L[0]: 1.0, V[0]: 1.0}
        h, jj = evaluate(rev, env)[("h", 0)], evaluate(fwd, env)[("jj", 0, 0, 0)]
        assert h == want and jj == want if want == 0 else abs(h - want) + abs(jj - want) <= 1e-12 * want
    assert isinstance(_slope(sm.Abs(d), sm.Rational(1, 2))[1], cusp_pow)
    assert _slope(sm.Abs(d), sm.Rational(3, 2))[1] == sm.Pow(sm.Abs(d), sm.Rational(1, 2))   # first order
    assert _slope(d, sm.Rational(1, 2))[1] == sm.Pow(d, -sm.Rational(1, 2))               # not an |.| base
    assert sm.ccode(cusp_pow(sm.Abs(d), -sm.Rational(1, 2))).endswith(" : 0.0)")
