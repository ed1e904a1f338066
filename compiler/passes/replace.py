"""``xreplace`` over a whole program at once, each shared subtree visited once.

SymPy's ``expr.xreplace(rule)`` walks every node of ``expr`` and rebuilds, with
SymPy's canonicalization, every node above a replacement.  Across a program the
same subtree objects recur many times (the derivative passes build their products
from the factors of the expressions they differentiate), and on the Jacobians of the
Whipple bicycle re-canonicalizing sums of hundreds of terms after a mere renaming
cost seconds.  :class:`Replacer` walks each node object once (a memo keyed by
identity) and, with ``rename=True``, rebuilds a sum or product whose arguments
were only renamed as it stood, without sorting it again (the C printer prints terms
in the IR's order anyway).  A sum or product in which a number appears is rebuilt
with SymPy's evaluation, so folded constants still fold.

The memo holds each node itself, so an id cannot be reused while the memo lives,
and nodes that merely compare equal (``2.0*x`` and ``2*x`` in some SymPy versions)
are never confused.  The rule may grow while a Replacer is in use only if no node
already visited contains a newly added key: true for a single-assignment program
walked in order, where a target is added to the rule before anything reads it.
"""
__all__ = ["Replacer"]


class Replacer:
    """``replacer(expr)``: ``expr.xreplace(rule)``, memoized over all calls."""

    def __init__(self, rule, rename=False):
        self.rule = rule
        self.rename = rename
        self.memo = {}      # id(node) -> (node, replacement)

    def __call__(self, expr):
        return self._walk(expr)

    def _walk(self, node):
        hit = self.memo.get(id(node))
        if hit is not None:
            return hit[1]
        args = getattr(node, "args", None)     # non-Basic arguments are leaves, as in xreplace
        new = self.rule.get(node) if args is not None else None
        if new is None:
            new = node
            if args:
                walked = [self._walk(a) for a in args]
                changed = [w for w, a in zip(walked, args) if w is not a]
                if changed:
                    if (self.rename and (node.is_Add or node.is_Mul)
                            and not any(w.is_Number for w in changed)):
                        new = node.func._from_args(tuple(walked), node.is_commutative)
                    else:
                        new = node.func(*walked)
        self.memo[id(node)] = (node, new)
        return new
