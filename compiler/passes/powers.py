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


@compiler_pass
def expand_powers(program):
    """Rewrite small integer powers everywhere in the program as products."""
    rw = _Rewriter(program)
    out = []
    for target, expr in program.assignments:
        new = rw.rewrite(expr)
        out.extend(rw.pending)
        rw.pending = []
        out.append((target, new))
    results = []
    for key, expr in program.results:
        new = rw.rewrite(expr)
        out.extend(rw.pending)
        rw.pending = []
        results.append((key, new))
    return program.with_(assignments=tuple(out), results=tuple(results), ntemp=rw.names.count)
