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


class _Poses:
    """A body's placement as symbols (what _clearance reads: origin and rotation)."""
    o = sm.symbols("ox oy oz", real=True)
    R = [[sm.Symbol(f"R{a}{b}", real=True) for b in range(3)] for a in range(3)]

    def origin(self, i):
        return self.o

    def rotation(self, i):
        return self.R


def _points(normals):
    r, cx, cy = sm.symbols("r cx cy", real=True)
    offs = [(cx, 0, 0), (0, cy, sm.Float(0.1, 17)), (cx, cy, 0)]
    return [(n, 0, r, off, (), sm.S.Zero, (), ()) for n, off in zip(normals, offs)]


def test_one_normal_clearance_is_what_sympy_min_of_it_gives():
    """A body whose points share one plane (every ground) gets its one term, which is what sm.Min
    of one argument returns (the C of every case is unchanged, benchmarks/c_identity.py); with two
    normals the clearance is still SymPy's Min of both."""
    poses = _Poses()
    one = contacts._clearance(poses, 0, _points([(0, 0, 1)] * 3))
    assert not isinstance(one, sm.Min) and one == sm.Min(one)
    two = contacts._clearance(poses, 0, _points([(0, 0, 1), (1, 0, 0), (0, 0, 1)]))
    assert isinstance(two, sm.Min) and len(two.args) == 2
    points = _points([(0, 0, 1), (1, 0, 0), (0, 0, 1)])
    z = contacts._clearance(poses, 0, [points[0], points[2]])
    x = contacts._clearance(poses, 0, [points[1]])
    assert two == sm.Min(z, x)


def test_bounding_sphere_radii_max_is_sympys_where_it_orders_none():
    """The bounding-sphere Max (contacts._sphere_max) is built as it stands: the Max SymPy's
    evaluation gives where it finds no radius bounding another (the humanoid's capsule ends, with
    parameter offsets), every distinct radius where it would find one (the same value), and the
    number where all radii are numbers."""
    a, b, c = sm.symbols("a b c", real=True)
    radii = [sm.sqrt(a ** 2 + (b - sm.Float(1.5e-17)) ** 2 + sm.Float(0.0049)),
             sm.sqrt(a ** 2 + (sm.Float(0.19) - b) ** 2), sm.sqrt((-a - sm.Float(0.01)) ** 2 + (b + 0.12) ** 2 + c ** 2)]
    got = contacts._sphere_max(radii + radii[:1])
    assert got == sm.Max(*radii) and got.args == sm.Max(*radii).args
    assert contacts._sphere_max(radii[:1] * 3) == radii[0]
    assert contacts._sphere_max([sm.Float(0.2), sm.Float(0.3), sm.Float(0.3)]) == sm.Float(0.3)
    ordered = [sm.sqrt(a ** 2 + 1), sm.sqrt(a ** 2 + 1) + 1]     # SymPy drops the first
    assert sm.Max(*ordered) == ordered[1]
    kept = contacts._sphere_max(ordered)
    f = sm.lambdify([a], kept)
    assert len(kept.args) == 2 and all(f(x) == float(ordered[1].subs(a, x)) for x in (-2.0, 0.0, 0.5))
