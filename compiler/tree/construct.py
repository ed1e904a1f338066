"""Fast SymPy sums and products for the recursions: the same objects as the operators, built for less."""
import sympy as sm
from sympy.core.mul import _args_sortkey


# Expression construction is most of a large tree's build time (0.1 s a body on a chain).
# The helpers below build the same SymPy expressions as the plain operators and
# sum(..., S.Zero) did, for less: structural zeros are dropped before any SymPy operation
# (``_nz`` answers for ints, Zero and Symbols without SymPy's __ne__), and the commonest
# shapes skip SymPy's flatten altogether: a product of distinct commutative Symbols, and a
# sum of Symbols and such products (a rational coefficient allowed) with no two alike, are
# their arguments in SymPy's canonical order (``_args_sortkey``, the key flatten sorts
# by) -- exactly the objects Mul(...) and Add(...) return.  Anything else is summed or
# multiplied left to right as before (an n-ary Add or Mul is not always the same: Floats
# that are zero, a rational times a sum).  So ``_add(ts)`` is ``t1 + t2 + ...`` of the
# terms that are not 0 / S.Zero, object for object (a Float 0.0 stays; SymPy's Zero + 0.0
# is Zero, so this can differ from sum(ts, S.Zero) in the type of a number, never in its
# value); tests/compiler/tree/test_construct.py checks both on random input.
_ZERO = sm.S.Zero
_Add, _Mul, _Symbol = sm.Add, sm.Mul, sm.Symbol


def _plain_mul(f):
    """f is a product of commutative Symbols and at most a leading number."""
    if type(f) is not _Mul:
        return False
    args = f.args
    first = 1 if args[0].is_Rational else 0
    return all(type(a) is _Symbol and a.is_commutative for a in args[first:])


def _term_key(t):
    """What Add.flatten collects ``t`` under (its non-numeric factors), or None when ``t``
    is not a Symbol or a plain product (then SymPy's own flatten decides)."""
    if type(t) is _Symbol:
        return (t,) if t.is_commutative else None
    if _plain_mul(t):
        args = t.args
        return args[1:] if args[0].is_Rational else args
    return None


def _fast_add(terms):
    keys = set()
    for t in terms:
        k = _term_key(t)
        if k is None or k in keys:
            return None
        keys.add(k)
    return _Add._from_args(tuple(sorted(terms, key=_args_sortkey)), True)


def _fast_mul(factors):
    for f in factors:
        if type(f) is not _Symbol or not f.is_commutative:
            return None
    if len(set(factors)) < len(factors):
        return None
    return _Mul._from_args(tuple(sorted(factors, key=_args_sortkey)), True)


def _nz(x):
    """``x != 0``, fast for the common cases (an int, Zero, a Symbol)."""
    t = type(x)
    if t is int:
        return x != 0
    if x is _ZERO:
        return False
    if t is _Symbol:
        return True
    return x != 0


def _add(terms):
    """The terms that are not zero, summed left to right (see above)."""
    terms = [t for t in terms if _nz(t)]
    if not terms:
        return _ZERO
    if len(terms) == 1:
        t = terms[0]
        return t if isinstance(t, sm.Basic) else sm.sympify(t)
    fast = _fast_add(terms)
    if fast is not None:
        return fast
    out = terms[0]
    for t in terms[1:]:
        out = out + t
    return out


def _mul(*factors):
    """The product (zero if a factor is)."""
    for f in factors:
        if not _nz(f):
            return _ZERO
    fast = _fast_mul(factors)
    if fast is not None:
        return fast
    out = factors[0]
    for f in factors[1:]:
        out = out * f
    return out
