"""A body guard's clearance takes a Max over its points' terms (compiler/tree/contacts._max)."""
import numpy as np
import sympy as sm

from eomc.compiler.tree import contacts


def _terms(n):
    a, b, c = sm.symbols("a b c", real=True)
    return [sm.sqrt((a + k) ** 2 + (b - k) ** 2 + c ** 2) for k in range(n)], (a, b, c)


def test_many_terms_are_kept_as_they_stand_and_give_the_same_value():
    """Above MAX_EVALUATED terms SymPy's pairwise search is skipped: every distinct term stays an
    argument (a duplicate is dropped), and the value is the evaluated Max's at random points."""
    n = contacts.MAX_EVALUATED + 4
    terms, syms = _terms(n)
    got = contacts._max(terms + terms[:3])
    assert isinstance(got, sm.Max) and len(got.args) == n
    want = sm.Max(*terms)
    f, g = sm.lambdify(syms, got), sm.lambdify(syms, want)
    for x in np.random.default_rng(3).uniform(-5, 5, (20, 3)):
        assert f(*x) == g(*x)


def test_few_terms_are_evaluated_as_sympy_does():
    """Up to MAX_EVALUATED terms the Max is SymPy's own: terms it can order are dropped, so the
    C of small bodies (boxes, spheres, capsules) is what it was."""
    x = sm.Symbol("x", real=True)
    few = [x + k for k in range(contacts.MAX_EVALUATED)]
    assert contacts._max(few) == x + contacts.MAX_EVALUATED - 1 == sm.Max(*few)
    many = [x + k for k in range(contacts.MAX_EVALUATED + 1)]
    assert len(contacts._max(many).args) == len(many)
