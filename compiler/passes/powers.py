"""Integer powers become multiplies (``x**3`` -> ``x*x*x``; ``x**-2`` -> ``1/(x*x)``).

Powers up to :data:`MAX_EXPONENT` are rewritten; a non-symbol base is first
given its own temporary so it is computed once.  Products are :class:`IMul`
nodes, which SymPy does not fold back into powers.
"""
import sympy as sm

from ..ir import IMul, Names
from .timing import compiler_pass

__all__ = ["expand_powers", "MAX_EXPONENT"]

MAX_EXPONENT = 8


class _Rewriter:
    def __init__(self, program):
        self.names = Names(program)
        self.pending = []   # hoisted (symbol, expr) waiting to be emitted

    def hoist(self, expr):
        if expr.is_Symbol or expr.is_Number:
            return expr
        sym = self.names.fresh()
        self.pending.append((sym, expr))
        return sym

    def product(self, base, n):
        if n == 1:
            return base
        if n <= 3:
            return IMul(*([base] * n))
        half = self.hoist(IMul(base, base))
        rest = self.product(half, n // 2)
        return rest if n % 2 == 0 else IMul(base, rest)

    def rewrite(self, expr):
        if expr.is_Atom:
            return expr
        if not expr.is_Pow and all(a.is_Atom for a in expr.args):
            return expr             # nothing to rewrite below (most nodes: t1*t2, t3 + t4): no calls
        args = [self.rewrite(a) for a in expr.args]
        if expr.is_Pow and expr.exp.is_Integer and 2 <= abs(int(expr.exp)) <= MAX_EXPONENT:
            n = int(expr.exp)
            prod = self.product(self.hoist(args[0]), abs(n))
            return prod if n > 0 else sm.Pow(prod, -1, evaluate=False)
        if all(a is b for a, b in zip(args, expr.args)):
            return expr
        return expr.func(*args)


# expr -> its rewrite, for the expressions whose rewrite named nothing (then it depends on the
# expression alone, not on the program's names): see expand_powers
_MEMO = {}
_MEMO_MAX = 1 << 17


@compiler_pass
def expand_powers(program):
    """Rewrite small integer powers everywhere in the program as products.

    An expression whose rewrite hoisted no temporary is remembered (:data:`_MEMO`, bounded):
    the pass runs once per generated function over what that function keeps of the shared
    program (:func:`~.pipeline.finish_function`), so the same assignments came through
    again for every function, each power rebuilt as SymPy products again (G1's default
    build: 0.064 s here against the rhs-only build's 0.011 s).  A rewrite that hoists is
    not remembered: its names are the program's own (``Names``)."""
    rw = _Rewriter(program)
    out = []

    def rewritten(expr):
        new = _MEMO.get(expr)
        if new is None:
            new = rw.rewrite(expr)
            if not rw.pending:
                if len(_MEMO) >= _MEMO_MAX:
                    _MEMO.clear()
                _MEMO[expr] = new
        return new
    for target, expr in program.assignments:
        new = rewritten(expr)
        out.extend(rw.pending)
        rw.pending = []
        out.append((target, new))
    results = []
    for key, expr in program.results:
        new = rewritten(expr)
        out.extend(rw.pending)
        rw.pending = []
        results.append((key, new))
    return program.with_(assignments=tuple(out), results=tuple(results), ntemp=rw.names.count)
