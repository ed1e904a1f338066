"""C99 expression printer for IR expressions.

SymPy's C99CodePrinter does the precedence work; this subclass only

* maps symbols to C names (array slots ``x[3]``, temporaries ``t12``),
* prints floats so they round-trip exactly (``repr``), exact rationals as
  ``1.0/3.0`` (SymPy's rule), and named constants (pi, E) as literals rather than the
  non-C99 ``M_PI`` macros,
* prints :class:`~eomc.compiler.ir.IMul` products as ``(a*b*c)``,
* prints Max and Min (and the nodes whose ``_ccode`` calls :func:`c_minmax`) as calls of
  ``eomc_fmax`` / ``eomc_fmin``: the inline forms of :data:`MINMAX_C`, which the generated
  file defines, instead of libm's fmax and fmin.

While a :func:`print_memo` is open (generate_c's), each expression is printed by SymPy once,
as a template with a hole per symbol, and filled with the C names of the printer asking:
the functions of a model print many of the same expressions (the rhs's temporaries again
in NAME_implicit, jac_x, the mass matrix ...), under names that differ between functions
(a temporary is t12 in one, P[3] in another).  Sound because the printer never looks at a
symbol's printed text -- except a ``_ccode`` method that does (a table call's parameter
array, compiler/contact/table.py), which says so by calling :meth:`CPrinter.reads_names`:
that expression is then printed as before, uncached.  Templates are kept per shape too (a tree
up to its symbols' names, :func:`_shape`): ``t3*t7 + t9`` and ``t4*t8 + t2`` are printed once.
"""
import contextlib
import functools
import itertools
import threading

import sympy as sm
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE

__all__ = ["CPrinter", "HalfPow", "half_power", "NonFiniteLiteral", "print_memo", "c_minmax", "MINMAX_C", "MINMAX_NAMES",
           "CALLED_C"]

# fmax and fmin inline.  Why: on the ant's NAME_implicit (164 sites: joint limits, ctrl clamps,
# the broad phase) the libm calls were 3.6 % of its time (session 15, report-antfs.md).  Why this
# form: it is glibc 2.36's x86-64 fmax/fmin bit for bit -- maxsd/minsd (a > b ? a : b, so b when
# a == b: fmax(-0, +0) = +0), a NaN in one place gives the other argument, in both a -- checked
# over every pair of signed zeros, infinities, NaNs, subnormals (tests/compiler/emit/
# test_batch.py, test_vector_fabs_fmax_fmin_are_libm_bit_for_bit).  A fixed text (not gcc's builtin): gcc takes fmax as commutative and may swap
# the arguments of a call, which changes the sign of fmax(-0, +0); a conditional is not swapped.
MINMAX_NAMES = {"fmax": "eomc_fmax", "fmin": "eomc_fmin"}
# their C by name; a file defines only those it calls (clang warns of an unused static inline)
MINMAX_C = {"eomc_fmax": """static inline double eomc_fmax(double a, double b)
{
    return a > b ? a : (b != b ? a : b);
}""", "eomc_fmin": """static inline double eomc_fmin(double a, double b)
{
    return a < b ? a : (b != b ? a : b);
}""",
            # printer.HalfPow's; pow(±0, c) is +0 for these c, and a NaN or any other x goes to pow
            "eomc_pow0": """static inline double eomc_pow0(double x, double c)
{
    return x != 0.0 ? pow(x, c) : 0.0;
}""",
            # every tanh (CPrinter._print_tanh): tanh(±0) is ±0, x itself; a NaN or any other x goes to tanh
            "eomc_tanh0": """static inline double eomc_tanh0(double x)
{
    return x != 0.0 ? tanh(x) : x;
}""",
            # compiler/tree/joint_laws.tanhc: tanh(x)/x, 1 at x = ±0 (its limit; a NaN stays NaN) -- the
            # joint friction's secant slope in NAME_implicit
            "eomc_tanhc": """static inline double eomc_tanhc(double x)
{
    return x != 0.0 ? tanh(x) / x : 1.0;
}"""}

# Helpers that are not inline (gcc and clang warn of an unused static function: a file defines
# only those it calls, like MINMAX_C's; generate._minmax_code).  Each has its float twin by the
# c99-f32 pass (compiler/emit/target._KNOWN_CALLS: double -> float, log -> logf).
# eomc_limit_stored: a joint limit's stored spring energy past it by r >= 0 with width E
# (compiler/tree/joint_laws.stored): one function, not its sum per joint and side.  Not inline:
# NAME_energy calls it 2 nq times (G1 58), once per limit side.
CALLED_C = {"eomc_limit_stored": """static double eomc_limit_stored(double r, double E)
{
    return (1.0/2.0)*(r*r) - 2.0*E*r + 3.0*(E*E)*log(1.0 + r/E) + (E*E*E)/(E + r) - E*E;
}"""}


class HalfPow(sm.Function):
    """HalfPow(x, c): x**c for c = k/2, k odd and >= 3 (a contact law's 3/2 and 5/2) in NAME_energy.
    Printed as :func:`half_power`'s products where x is a fabs (every contact law's case), else
    as ``eomc_pow0(x, c)`` (:data:`MINMAX_C`), which skips libm's pow where x is 0: the same bits
    (pow(±0, c) = +0 for such c; any other x is pow's).  Why: NAME_energy's elastic terms are
    k δ₊^(5/2) per contact point, δ₊ = 0 for every point out of contact, and glibc's pow of 0 still
    takes ~4 ns (25 calls a step on the ant: a third of its 315 ns; compiler/emit/generate.py
    energy_program)."""
    nargs = 2
    is_real = True

    @classmethod
    def applies(cls, e):
        """Whether Pow ``e`` is one HalfPow prints."""
        c = e.exp
        return c.is_Rational and c.q == 2 and c.p >= 3

    def _ccode(self, printer):
        text = half_power(printer, *self.args)
        if text is not None:
            return text
        return f"eomc_pow0({printer._print(self.args[0])}, {printer._print(self.args[1])})"


# x**(p/2) for these p as products with one sqrt (half_power)
_HALF_POWERS = {-1: "(1.0/sqrt({x}))", 3: "({x}*sqrt({x}))", 5: "({x}*{x}*sqrt({x}))"}


def half_power(printer, base, exp):
    """C text of ``base**exp`` as products with sqrt where exp is -1/2, 3/2 or 5/2 and base is
    an Abs (a fabs: +0, positive, +inf or NaN), else None (pow).

    Why: the contact laws' d^(3/2) (Hunt-Crossley) printed as ``pow(fabs(d), 3.0/2.0)``, 75 calls
    in the ant's NAME_implicit and ~150 in the humanoid's, and gcc turns pow(x, 1.5) into
    x*sqrt(x) only under -ffast-math; in the lanes code (compiler/emit/batch.py) pow is a libm call
    lane by lane, sqrt one vector instruction.  Same values at every fabs: pow(+0, c) = +0 (and
    +inf for c = -1/2, as 1/sqrt(+0)), +inf stays +inf, NaN stays NaN.  Not the same bits: glibc's
    pow is within 1 ulp of the exact power, x*sqrt(x) rounds twice and x*x*sqrt(x) three times, and
    they differ from pow by at most 1 (3/2, -1/2) or 2 (5/2) ulp (tests/compiler/emit/test_printer.py
    measures it).  Only a fabs: pow and these products differ at x = -inf (+inf against NaN) and,
    for 5/2, at x = -0 (+0 against -0), which an Abs never is."""
    if not (isinstance(base, sm.Abs) and exp.is_Rational and exp.q == 2 and exp.p in _HALF_POWERS):
        return None
    return _HALF_POWERS[int(exp.p)].format(x=printer._print(base))


def c_minmax(printer, fn, *args):
    """C text of fmax or fmin (``fn``) of the printed ``args`` (two or more, nested to the
    right as SymPy's printer nests Max): eomc's inline form under :class:`CPrinter`, libm's
    name under any other printer (SymPy's own ccode of an eomc node)."""
    name = MINMAX_NAMES[fn] if isinstance(printer, CPrinter) else fn
    text = args[-1]
    for a in reversed(args[:-1]):
        text = f"{name}({a}, {text})"
    return text


# Per thread (two models may be generated at once in threads): .memo = {expr: (texts, symbols)
# or None (uncacheable)} while a print_memo is open; .tp = the thread's template printer.
_LOCAL = threading.local()
_HOLE = "\x00"  # around a symbol's slot number in a template (no C text holds it)


@contextlib.contextmanager
def print_memo():
    """Print templates kept for the duration (nested: the outer one's); dropped after."""
    outer = getattr(_LOCAL, "memo", None)
    outer_shapes = getattr(_LOCAL, "shapes", None)
    _LOCAL.memo = {} if outer is None else outer
    _LOCAL.shapes = {} if outer is None else outer_shapes
    try:
        yield
    finally:
        _LOCAL.memo, _LOCAL.shapes = outer, outer_shapes


class NonFiniteLiteral(ValueError):
    """A NaN or infinite constant reached the printer; generate_c turns it into a ModelError
    naming the function (C99 has no portable literal for them, and a model that computes a
    constant NaN is wrong: eomc refuses it rather than compile it)."""


class CPrinter(C99CodePrinter):
    def __init__(self, names):
        # order="none": print terms in the IR's own (deterministic) order instead of
        # sorting every sum again, the most expensive part of printing
        super().__init__({"math_macros": {}, "order": "none"})
        self._names = names

    def reads_names(self):
        """Called by a ``_ccode`` method whose text depends on its arguments' printed names
        (not only on their positions): its expression is not printed from a template."""

    def _handle_UnevaluatedExpr(self, expr):
        # SymPy's rebuilds every node on its way to the re(...) calls it rewrites: ~2 % of the
        # humanoid's generate phase for expressions that have none (then it returns expr itself)
        return super()._handle_UnevaluatedExpr(expr) if expr.has(sm.re) else expr

    def doprint(self, expr, assign_to=None):
        memo = getattr(_LOCAL, "memo", None)
        if memo is None or assign_to is not None or not isinstance(expr, sm.Basic):
            return super().doprint(expr, assign_to)
        hit = memo.get(expr, False)
        if hit is False:
            hit = memo[expr] = _shaped(expr)
        if hit is None:
            return super().doprint(expr)
        texts, symbols = hit
        names = self._names
        try:
            filled = [names[s] for s in symbols]
        except KeyError:
            missing = next(s for s in symbols if s not in names)
            raise KeyError(f"symbol {missing} has no C name (compiler bug)") from None
        return "".join(itertools.chain.from_iterable(zip(texts, filled))) + texts[-1]

    def _print_Symbol(self, expr):
        name = self._names.get(expr)
        if name is None:
            raise KeyError(f"symbol {expr} has no C name (compiler bug)")
        return name

    def _print_Float(self, expr):
        text = repr(float(expr))
        if "inf" in text or "nan" in text:
            raise NonFiniteLiteral(text)
        return text if ("." in text or "e" in text) else text + ".0"

    def _refuse(self, expr):
        raise NonFiniteLiteral(str(expr))

    _print_NaN = _refuse
    _print_Infinity = _refuse
    _print_NegativeInfinity = _refuse
    _print_ComplexInfinity = _refuse

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"

    def _print_NumberSymbol(self, expr):
        return self._print_Float(sm.Float(expr.evalf(17)))

    _print_Pi = _print_NumberSymbol
    _print_Exp1 = _print_NumberSymbol

    def _print_Pow(self, expr):
        text = half_power(self, expr.base, expr.exp)
        return super()._print_Pow(expr) if text is None else text

    def _print_tanh(self, expr):
        """``eomc_tanh0(x)`` (:data:`MINMAX_C`): libm's tanh but at x = ±0, where it is x (the same
        bits).  Why: a joint limit's stretch r + (G - 1) w tanh(r/w) (compiler/tree/joint_laws.py
        stretch; MJCF's limits) has r = max(lo - q, 0) = 0 whenever the joint is inside its range,
        and glibc's tanh(0) is still a call (~3 ns): 32 in the ant's NAME_implicit, 68 in the
        humanoid's, each per lane in the lanes code (compiler/emit/batch.py)."""
        return f"eomc_tanh0({self._print(expr.args[0])})"

    def _print_Max(self, expr):
        return c_minmax(self, "fmax", *(self._print(a) for a in expr.args))

    def _print_Min(self, expr):
        return c_minmax(self, "fmin", *(self._print(a) for a in expr.args))

    def _print_IMul(self, expr):
        # always parenthesized: SymPy's Mul printer may put it after "/" at Add precedence
        prec = PRECEDENCE["Mul"]
        return "(" + "*".join(self.parenthesize(a, prec) for a in expr.args) + ")"


class _TemplatePrinter(CPrinter):
    """Prints symbol k (in first-seen order) as a hole ``\\x00k\\x00``; ``impure`` once a
    ``_ccode`` method reads its arguments' names (:meth:`CPrinter.reads_names`)."""

    def __init__(self):
        super().__init__({})
        self.slots, self.impure = {}, False

    def reads_names(self):
        self.impure = True

    def _print_Symbol(self, expr):
        k = self.slots.setdefault(expr, len(self.slots))
        return f"{_HOLE}{k}{_HOLE}"


_UNSHARED = object()    # a shape whose template holds a symbol _shape does not see as a hole


@functools.lru_cache(maxsize=1 << 16)
def _kind(symbol):
    """A symbol's assumptions, as part of a shape's key (the printer may ask them)."""
    return tuple(sorted(symbol.assumptions0.items()))


def _shape(expr):
    """(key, holes): ``expr``'s tree with each plain Symbol replaced by its first-seen number and
    its assumptions (``holes``: the symbols in that order); other leaves as themselves.  Two
    expressions with one key are one tree up to the names of their symbols."""
    holes, seen = [], {}

    def walk(e):
        if type(e) is sm.Symbol:
            k = seen.get(e)
            if k is None:
                k = seen[e] = len(holes)
                holes.append(e)
            return (_HOLE, k, _kind(e))
        if not isinstance(e, sm.Basic) or not e.args:
            return (type(e), e, getattr(e, "_prec", None))
        return (type(e),) + tuple(map(walk, e.args))
    return walk(expr), holes


def _shaped(expr):
    """:func:`_template` of ``expr``, printed by SymPy once per shape (:func:`_shape`): the C of a
    tree does not depend on its symbols' names (the printer never reads them: holes), so
    ``t3*t7 + t9`` and ``t4*t8 + t2`` are one template filled with other symbols.  Why: the
    humanoid printed 10,656 templates of 1,837 shapes, 13 % of its generate phase."""
    shapes = _LOCAL.shapes
    try:
        key, holes = _shape(expr)
        hit = shapes.get(key, False)
    except TypeError:                       # a leaf that cannot be hashed: the expression's own
        return _template(expr)
    if hit is False:
        made = _template(expr)
        if made is None:
            hit = None
        else:
            at = {s: k for k, s in enumerate(holes)}
            texts, symbols = made
            hit = (texts, tuple(at[s] for s in symbols)) if all(s in at for s in symbols) else _UNSHARED
        shapes[key] = hit
        if hit is _UNSHARED:
            return made
    if hit is None:
        return None
    if hit is _UNSHARED:
        return _template(expr)
    texts, order = hit
    return texts, tuple(holes[k] for k in order)


def _template(expr):
    """(texts, symbols): the C of ``expr`` is texts[0] + name(symbols[0]) + texts[1] + ... +
    texts[-1]; None when it cannot be printed from a template."""
    tp = getattr(_LOCAL, "tp", None)
    if tp is None:                           # one per thread: a SymPy printer costs ~0.3 ms to make
        tp = _LOCAL.tp = _TemplatePrinter()
    tp.slots, tp.impure = {}, False
    parts = super(CPrinter, tp).doprint(expr).split(_HOLE)
    if tp.impure:
        return None
    order = list(tp.slots)
    return parts[0::2], tuple(order[int(k)] for k in parts[1::2])
