"""Memoized partial derivatives of large SymPy expressions.

Why: ``Expr.diff`` goes through ``Derivative.__new__`` and the general
n-th-derivative machinery at every node and re-queries assumptions, which
dominates the cost of Lagrange's method (hundreds of first derivatives of the
same large Lagrangian and momenta).  This differentiator handles the node
types that make up mechanics expressions directly (Add, Mul, Pow with a
constant exponent, sin, cos), skips every subtree that does not contain the
variable (the variable sets are memoized per node), memoizes ``(node, var)``
results so shared subtrees are differentiated once, and hands anything else
to a fallback (by default ``Expr.diff``).  The result is mathematically equal
to the partial derivative; it is not necessarily in the same printed form.

The variables may be any atoms of the expression tree -- plain symbols or
``q(t)``, ``q'(t)`` treated as independent variables.  A variable is a leaf:
the differentiator never looks inside it.
"""
import sympy as sm

__all__ = ["Differentiator", "PointDifferentiator"]


def _default_fallback(node, var):
    return node.diff(var)


class Differentiator:
    """Partial derivatives with respect to a fixed set of independent variables.

    ``variables``: every node that may be differentiated for (a leaf each).
    ``fallback(node, var)``: the derivative of a node type not handled here.
    ``time``: a variable that may also hide inside other nodes (e.g. ``t`` in
    ``F(t)``); nodes that contain it outside the variables depend on it.
    """

    def __init__(self, variables, fallback=_default_fallback):
        self._vars = frozenset(variables)
        self._fallback = fallback
        self._deps = {}
        self._memo = {}

    def deps(self, node):
        """The variables that occur in ``node``."""
        got = self._deps.get(node)
        if got is None:
            if node in self._vars:
                got = frozenset((node,))
            elif not node.args:
                got = frozenset()
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
        if node in self._vars:  # var is in deps(node), so node == var
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
        return self._fallback(node, var)


class PointDifferentiator(Differentiator):
    """Partial derivatives evaluated at a point, without forming them symbolically first.

    ``diff(node, var)`` equals ``Differentiator.diff(node, var).xreplace(point)``
    but applies the chain rule to the *values* of the sub-expressions at the
    point (memoized per node), so a product whose other factors vanish there
    (sin(0), a zero speed) costs nothing and no large derivative is ever built.
    This is what makes linearizing about an operating point fast: the Whipple
    bicycle's full derivatives are huge, their values at upright are small.
    """

    def __init__(self, variables, point, fallback=_default_fallback):
        super().__init__(variables, fallback)
        self._point = dict(point)
        self._values = {}

    def value(self, node):
        """``node.xreplace(point)``, memoized per sub-expression."""
        got = self._values.get(node)
        if got is None:
            if node in self._point:
                got = self._point[node]
            elif not node.args:
                got = node
            else:
                args = [self.value(a) for a in node.args]
                got = node if all(a is b for a, b in zip(args, node.args)) else node.func(*args)
            self._values[node] = got
        return got

    def _diff(self, node, var):
        if node in self._vars:
            return sm.S.One
        if node.is_Add:
            return sm.Add(*[self.diff(a, var) for a in node.args])
        if node.is_Mul:
            args = node.args
            vals = [self.value(a) for a in args]
            terms = []
            for k, a in enumerate(args):
                if any(vals[j] == 0 for j in range(len(args)) if j != k):
                    continue
                da = self.diff(a, var)
                if da != 0:
                    terms.append(sm.Mul(*vals[:k], da, *vals[k + 1:]))
            return sm.Add(*terms)
        if node.is_Pow:
            base, exp = node.args
            if var not in self.deps(exp):
                db = self.diff(base, var)
                if db == 0:
                    return sm.S.Zero
                b = self.value(base)
                e = self.value(exp)
                return 2 * b * db if e == 2 else e * b ** (e - 1) * db
        elif isinstance(node, sm.sin):
            d = self.diff(node.args[0], var)
            return sm.cos(self.value(node.args[0])) * d if d != 0 else sm.S.Zero
        elif isinstance(node, sm.cos):
            d = self.diff(node.args[0], var)
            return -sm.sin(self.value(node.args[0])) * d if d != 0 else sm.S.Zero
        return self._fallback(node, var).xreplace(self._point)
