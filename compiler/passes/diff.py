"""Forward-mode differentiation of a program (the Jacobians "from the same IR").

``differentiate(program, source, wrt, target)`` adds results
``(target, i, k) = d(source_i)/d(wrt_k)`` by the chain rule over the
program's assignments: every temporary that depends on ``wrt_k`` gets a
derivative temporary, computed from the (small, post-CSE) expression that
defines it.  This is linear in the program's size times the number of
directions, where SymPy's ``diff`` of the unshared expressions is not.
Zero derivatives are never created (dependencies are tracked).
"""
import sympy as sm

from ..ir import Names
from .timing import compiler_pass

__all__ = ["differentiate", "tangent"]


def _zero(e):
    """``e == 0`` as SymPy answers it, without the sympify that ``!=`` costs on every
    call: only a Number can equal zero (whether Float(0.0) does depends on SymPy's
    version, so the Number itself is asked)."""
    return e is _ZERO or (e.is_Number and e == 0)


_ZERO = sm.S.Zero


def _add(terms):
    """Sum without SymPy's canonicalization (the terms are already small and distinct);
    ``_from_args`` skips even the argument checks of ``evaluate=False``."""
    terms = [t for t in terms if not _zero(t)]
    if not terms:
        return sm.S.Zero
    return terms[0] if len(terms) == 1 else sm.Add._from_args(tuple(terms), True)


def _mul(factors):
    """Product without canonicalization; drops factors 1 and folds a leading number."""
    num, rest = sm.S.One, []
    for f in factors:
        if f.is_Number:
            num *= f
        else:
            rest.append(f)
    if _zero(num):
        return sm.S.Zero
    if num is not sm.S.One and num != 1:
        rest.insert(0, num)
    if not rest:
        return num
    return rest[0] if len(rest) == 1 else sm.Mul._from_args(tuple(rest), True)


# sign(x), the derivative of |x| (the pair schemes' clamps: min and max as (a + b ± |a - b|)/2), has
# the derivative 0 but at 0, where it has none: the passes take 0 (SymPy's is an unprintable
# Derivative, or a DiracDelta), so that a second derivative through |x| (hvp, hess_id) is generated.
_FLAT = (sm.sign,)


def _pow(base, exp):
    if exp == 1:
        return base
    return sm.Pow(base, exp, evaluate=False)


class cusp_pow(sm.Function):
    """|u|^e with e < 0 (``cusp_pow(|u|, e)``), taken as 0 where |u| = 0: the slope factor of
    |u|^(e + 1) with 0 < e + 1 < 1, guarded.

    Why: the contact law's k δ₊^{3/2} (compiler/contact/law.py) is written |δ₊|^{3/2}; its first
    derivative (3/2)|δ₊|^{1/2}·sign(δ₊)·dδ₊ is finite everywhere, but the second (hvp, hess_id)
    holds (3/4)|δ₊|^{-1/2}·sign(δ₊)·dδ₊, which is ∞·0 = NaN wherever the point is out of contact
    (δ₊ = 0 exactly).  The factor that multiplies it there is sign(0) = 0: out of contact the law
    is identically 0 near the state, so every derivative is 0, and the guarded factor gives 0·0.
    At δ = 0 exactly the one-sided second derivative is +∞; the convention is the law's own
    branch, δ ≤ 0 out of contact: 0 (docs/derivatives.md).  In C a conditional expression, which
    evaluates only the branch it takes, so no ∞ is ever formed."""
    nargs = 2

    def fdiff(self, argindex=1):
        if argindex != 1:
            raise sm.ArgumentIndexError(self, argindex)
        base, exp = self.args
        return exp * cusp_pow(base, exp - 1)

    def _eval_evalf(self, prec):
        base = self.args[0].evalf(prec)
        if not base.is_Number:
            return None
        return sm.S.Zero if base == 0 else sm.Pow(base, self.args[1]).evalf(prec)

    def _guarded(self, printer, zero):
        base, exp = self.args
        return (f"(({printer._print(base)}) != {zero} ? "
                f"{printer._print(sm.Pow(base, exp, evaluate=False))} : {zero})")

    def _ccode(self, printer):
        return self._guarded(printer, "0.0")

    def _numpycode(self, printer):
        base = printer._print(self.args[0])
        return f"numpy.where(({base}) != 0, {base}, 1.0) ** ({printer._print(self.args[1])}) * (({base}) != 0)"

    def _pythoncode(self, printer):
        return self._guarded(printer, "0")


def _slope(base, exp):
    """The factors (exp, base^(exp - 1)) of d(base^exp)/d(base), with the cusp of |u|^exp (0 < exp < 1, where the
    factor |u|^(exp - 1) is ∞ at u = 0) guarded by :class:`cusp_pow`.  Only an |.| base with a
    fractional exponent below 1 is guarded: that is a derivative of the contact law's |δ₊|^{3/2}
    taken a second time; every first derivative the generated C held before is unchanged."""
    low = exp - 1
    if isinstance(base, sm.Abs) and low.is_Number and low < 0 and not low.is_Integer:
        return exp, cusp_pow(base, low)
    return exp, _pow(base, low)


class _Diff:
    """Chain rule over a program.  ``dirs`` maps an input symbol to (direction k, its
    derivative along k): (k, 1) for a Jacobian column, (0, seed symbol) for a tangent."""

    def __init__(self, program, dirs):
        self.names = Names(program)
        self.program_assignments = program.assignments
        self.dirs = dirs
        self.deps = {}      # temp -> frozenset of directions it depends on
        self.deriv = {}     # (temp, k) -> symbol or number
        self.out = []
        self.memo = {}
        self.extra = {}     # a node's own derivative state (a called routine's tangent call per direction)
        self._defs = None

    def definition(self, sym):
        """The expression assigned to temporary ``sym``."""
        if self._defs is None:
            self._defs = dict(self.program_assignments)
        return self._defs[sym]

    def deps_of(self, expr):
        d = set()
        for s in expr.free_symbols:
            hit = self.dirs.get(s)
            if hit is not None:
                d.add(hit[0])
            else:
                d |= self.deps.get(s, frozenset())
        return d

    def d(self, expr, k):
        """d expr along direction k, as an expression of existing symbols."""
        if expr.is_Number:
            return sm.S.Zero
        if expr.is_Symbol:
            hit = self.dirs.get(expr)
            if hit is not None:
                return hit[1] if hit[0] == k else sm.S.Zero
            return self.deriv.get((expr, k), sm.S.Zero)
        key = (expr, k)
        if key in self.memo:
            return self.memo[key]
        forward = getattr(expr, "forward", None)
        if forward is not None:     # a call node with its own rule (a routine's tangent call)
            res = forward(self, k)
        elif expr.is_Add:
            res = _add([self.d(a, k) for a in expr.args])
        elif expr.is_Mul:
            terms = []
            args = expr.args
            for i, a in enumerate(args):
                da = self.d(a, k)
                if not _zero(da):
                    terms.append(_mul(args[:i] + (da,) + args[i + 1:]))
            res = _add(terms)
        elif expr.is_Pow and k not in self.deps_of(expr.exp):
            db = self.d(expr.base, k)
            res = _mul(_slope(expr.base, expr.exp) + (db,)) if not _zero(db) else sm.S.Zero
        elif isinstance(expr, _FLAT):       # |x|'s derivative: flat but at 0
            res = sm.S.Zero
        elif isinstance(expr, sm.Function) and len(expr.args) == 1:
            da = self.d(expr.args[0], k)
            res = _mul((expr.fdiff(1), da)) if not _zero(da) else sm.S.Zero
        else:   # rare shapes: let SymPy do it on the symbols, then chain through temporaries
            res = sm.Add(*[expr.diff(s) * self.d(s, k) for s in expr.free_symbols])
        self.memo[key] = res
        return res

    def assign(self, target, expr):
        deps = self.deps_of(expr)
        self.deps[target] = frozenset(deps)
        for k in sorted(deps):
            de = self.d(expr, k)
            if _zero(de):
                continue
            if de.is_Atom:
                self.deriv[(target, k)] = de
            else:
                sym = self.names.fresh()
                self.out.append((sym, de))
                self.deriv[(target, k)] = sym


def _reads(expr):
    """The symbols ``expr``'s derivative reads: its free symbols and those of the nodes with a
    forward rule of their own that reads other temporaries (``tangent_reads``: the ground points'
    loop outputs, whose tangent is their straight-line twin's, compiler/contact/ground_table.py)."""
    got = set(expr.free_symbols)
    for node in expr.atoms(sm.Function):
        more = getattr(node, "tangent_reads", None)
        if more is not None:
            got |= more()
    return got


def _needed_by(program, source):
    """Temporaries the results of group ``source`` read, directly or through each other (or
    through a node's forward rule: :func:`_reads`; without it the ground loop's twins were not
    differentiated and their outputs' derivatives read 0 on the tangent path)."""
    need = set()
    for key, expr in program.results:
        if key[0] == source:
            need |= _reads(expr)
    for target, expr in reversed(program.assignments):
        if target in need:
            need |= _reads(expr)
    return need


def _run(program, dd, source, key_of):
    # only what the differentiated group reads: the other functions' temporaries (and the
    # derivative temporaries of earlier passes) would get derivatives nothing uses
    need = _needed_by(program, source)
    assignments = []
    for t, e in program.assignments:
        assignments.append((t, e))
        if t not in need:
            continue
        dd.memo.clear()
        dd.assign(t, e)
        assignments.extend(dd.out)
        dd.out = []
    results = list(program.results)
    for key, expr in program.results:
        if key[0] != source:
            continue
        dd.memo.clear()
        for k in sorted(dd.deps_of(expr)):
            de = dd.d(expr, k)
            if not _zero(de):
                results.append((key_of(key, k), de))
        assignments.extend(dd.out)
        dd.out = []
    return program.with_(assignments=tuple(assignments), results=tuple(results),
                         ntemp=dd.names.count)


@compiler_pass
def differentiate(program, source, wrt, target):
    """Add ``(target, i, k)`` results: derivatives of group ``source`` w.r.t. symbols ``wrt``."""
    dd = _Diff(program, {v: (k, sm.S.One) for k, v in enumerate(wrt)})
    return _run(program, dd, source, lambda key, k: (target,) + key[1:] + (k,))


@compiler_pass
def tangent(program, source, seeds, target):
    """Add ``(target, i)`` results: the derivative of group ``source`` along the direction
    whose components are the input symbols ``seeds`` ({wrt symbol: seed symbol}).

    The tangent program is about as large as the program itself, whatever the number of
    directions; the C code evaluates it once per Jacobian column with a unit seed.
    """
    dd = _Diff(program, {v: (0, s) for v, s in seeds.items()})
    return _run(program, dd, source, lambda key, k: (target,) + key[1:])
