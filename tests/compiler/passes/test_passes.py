"""Every pass keeps a program's values; DCE keeps exactly what the results need."""
import sympy as sm
from hypothesis import example, given, settings, strategies as st
from sympy.core.traversal import preorder_traversal

from eomc.compiler.ir import IMul, Program, evaluate, verify
from eomc.compiler.passes import (cse, dce, expand_powers, finish_function, fold_constants,
                                  fold_parameters, optimize_shared, share_sincos)

from helpers.random_expressions import LEAVES, P, X, exprs, values  # noqa: F401


def _program(es):
    return Program(inputs=X + P, results=tuple((("out", i), e) for i, e in enumerate(es)))


def _close(a, b):
    assert a.keys() == b.keys()
    for k in a:
        assert abs(a[k] - b[k]) <= 1e-12 * max(1.0, abs(a[k])), k


def _vals(v):
    return dict(zip(X + P, v))


@settings(max_examples=60, deadline=None)
@given(st.lists(exprs, min_size=1, max_size=4), values)
def test_each_pass_keeps_values(es, v):
    prog = _program(es)
    ref = evaluate(prog, _vals(v))
    stages = [cse(prog)]
    stages.append(share_sincos(stages[-1]))
    stages.append(fold_constants(stages[-1]))
    stages.append(expand_powers(stages[-1]))
    stages.append(dce(stages[-1]))
    stages.append(finish_function(optimize_shared(prog), ["out"]))
    for s in stages:
        verify(s)
        _close(ref, evaluate(s, _vals(v)))


@settings(max_examples=40, deadline=None)
@given(st.lists(exprs, min_size=1, max_size=3), values)
def test_fold_parameters_matches_substitution(es, v):
    prog = cse(_program(es))
    folded = fold_parameters(prog, {P[0]: v[4], P[1]: v[5]})
    verify(folded)
    assert not any(s in folded.inputs for s in P)
    for _, e in folded.assignments + folded.results:
        assert not (e.free_symbols & set(P))
    _close(evaluate(prog, _vals(v)), evaluate(folded, dict(zip(X, v))))


@settings(max_examples=40, deadline=None)
@given(st.lists(exprs, min_size=2, max_size=4), st.data())
def test_dce_keeps_exactly_what_results_need(es, data):
    prog = cse(_program(es))
    keep = data.draw(st.sets(st.integers(0, len(es) - 1), min_size=1))
    sub = prog.with_(results=tuple(r for r in prog.results if r[0][1] in keep))
    out = dce(sub)
    # independent reachability: a temporary is needed iff some kept result reads it, directly or not
    defs = dict(prog.assignments)
    needed, frontier = set(), [s for _, e in sub.results for s in e.free_symbols]
    while frontier:
        s = frontier.pop()
        if s in defs and s not in needed:
            needed.add(s)
            frontier.extend(defs[s].free_symbols)
    assert {t for t, _ in out.assignments} == needed
    assert [t for t, _ in out.assignments] == [t for t, _ in prog.assignments if t in needed]


@settings(max_examples=40, deadline=None)
@given(st.lists(exprs, min_size=1, max_size=4))
@example([sm.sin(X[0] - sm.sin(X[0]))])   # renamed inner call made SymPy flip the outer sign
def test_sincos_shared_and_adjacent(es):
    out = fold_constants(share_sincos(cse(_program(es))))
    seen = {}
    for i, (t, e) in enumerate(out.assignments):
        if isinstance(e, (sm.sin, sm.cos)):
            assert e not in seen, "sin/cos of one argument computed twice"
            seen[e] = i
    for e, i in seen.items():
        other = (sm.cos if isinstance(e, sm.sin) else sm.sin)(e.args[0])
        if other in seen:
            assert abs(seen[other] - i) == 1
    for _, e in out.assignments + out.results:
        for node in preorder_traversal(e):
            if node is not e:
                assert not isinstance(node, (sm.sin, sm.cos)), "trig call left inline"


@settings(max_examples=40, deadline=None)
@given(st.lists(exprs, min_size=1, max_size=4))
def test_powers_become_multiplies(es):
    out = expand_powers(cse(_program(es)))
    for _, e in out.assignments + out.results:
        for node in preorder_traversal(e):
            if node.is_Pow and node.exp.is_Integer:
                assert node.exp == -1 or abs(int(node.exp)) > 8


def test_small_examples():
    x, y = X[:2]
    prog = _program([x**2 + sm.sin(x) * sm.cos(x), sm.sin(x) / y**3])
    out = finish_function(optimize_shared(prog), ["out"])
    assert [e for _, e in out.assignments][:2] == [sm.sin(x), sm.cos(x)]
    assert any(isinstance(n, IMul) for _, e in out.results for n in preorder_traversal(e))
    assert out == finish_function(optimize_shared(prog), ["out"])   # deterministic names
    assert dce(out, ["nothing"]).assignments == ()
