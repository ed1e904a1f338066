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
