"""Memoized partial derivatives of large SymPy expressions.

Why: ``Expr.diff`` goes through ``Derivative.__new__`` and the general
n-th-derivative machinery at every node and re-queries assumptions, which
dominates the cost of Lagrange's method (hundreds of first derivatives of the
same large Lagrangian and momenta).  This differentiator handles the node
types that make up mechanics expressions directly (Add, Mul, Pow with a
constant exponent, sin, cos), skips every subtree that does not contain the
variable (the variable sets are memoized per node), memoizes ``(node, var)``
results so shared subtrees are differentiated once, and falls back to
``Expr.diff`` for anything else.  The result is mathematically equal to
``expr.diff(var)``; it is not necessarily in the same printed form.
"""
import sympy as sm

__all__ = ["Differentiator"]


class Differentiator:
    """Differentiates with respect to a fixed set of plain symbols (and ``t``).

    ``variables`` lists every symbol that may be differentiated for; the
    per-node dependency sets are restricted to them.
    """

    def __init__(self, variables):
        self._vars = frozenset(variables)
        self._deps = {}
        self._memo = {}

    def deps(self, node):
        """The differentiation variables that occur in ``node``."""
        got = self._deps.get(node)
        if got is None:
            if node.is_Symbol:
                got = frozenset((node,)) & self._vars
            elif not node.args:
                got = frozenset()
            elif node.is_Function and not isinstance(node, (sm.sin, sm.cos)):
                got = frozenset(node.free_symbols) & self._vars
            else:
                got = frozenset().union(*[self.deps(a) for a in node.args])
            self._deps[node] = got
        return got

    def diff(self, node, var):
        """``d node / d var``."""
        if var not in self.deps(node):
            return sm.S.Zero
        key = (node, var)
        got = self._memo.get(key)
        if got is None:
            got = self._diff(node, var)
            self._memo[key] = got
        return got

    def _diff(self, node, var):
        if node.is_Symbol:  # var is in deps(node), so node == var
            return sm.S.One
        if node.is_Add:
            return sm.Add(*[self.diff(a, var) for a in node.args])
        if node.is_Mul:
            args = node.args
            terms = []
            for k, a in enumerate(args):
                da = self.diff(a, var)
                if da is not sm.S.Zero:
                    terms.append(sm.Mul(*args[:k], da, *args[k + 1:]))
            return sm.Add(*terms)
        if node.is_Pow:
            base, exp = node.args
            if var not in self.deps(exp):
                db = self.diff(base, var)
                if exp == 2:
                    return 2 * base * db
                return exp * base ** (exp - 1) * db
        elif isinstance(node, sm.sin):
            return sm.cos(node.args[0]) * self.diff(node.args[0], var)
        elif isinstance(node, sm.cos):
            return -sm.sin(node.args[0]) * self.diff(node.args[0], var)
        return node.diff(var)
