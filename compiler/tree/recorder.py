"""The recursions' registry of temporaries: every value a body produces gets one name.

The recursions (:mod:`.aba`, :mod:`.rnea`, :mod:`.crba`, :mod:`.velocities`) walk the tree
and return SymPy expressions; every vector component and matrix entry a body produces is
handed to a :class:`Recorder`, which names it with a fresh temporary (value-numbered: the
same expression gets the same name).  So the program stays a flat DAG whose size grows
linearly with the number of bodies -- the trace a numeric ABA would execute, with
structural zeros (planar joints, point masses) already dropped by SymPy.
"""
import sympy as sm

__all__ = ["Recorder"]


class Recorder:
    """Names intermediate values ``_t<k>`` (the IR's registry) and keeps them in order."""

    def __init__(self, start=0):
        self.count = start
        self.apart = 0            # let_apart's own count
        self.assignments = []
        self._seen = {}

    def let(self, expr):
        """A name for ``expr`` (atoms and -atom stay as they are; a repeat gets the same name)."""
        return self._named(expr, False)

    def let_apart(self, expr):
        """As :meth:`let`, but a new name is ``_e<k>`` from a count of its own, so naming a value
        that only some functions read leaves every other temporary's name, and so the canonical
        order of SymPy's sums and products that print the other functions, as it was.  Why: the
        energy's per-body shares (.contacts._energy) named with ``let`` renumbered the recursion's
        later temporaries and reordered a sum in Talos' rhs and in the hopper's NAME_implicit."""
        return self._named(expr, True)

    def _named(self, expr, apart):
        if not isinstance(expr, sm.Basic):
            expr = sm.sympify(expr)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1
                            and expr.args[1].is_Atom):
            return expr
        hit = self._seen.get(expr)
        if hit is not None:
            return hit
        if apart:
            sym = sm.Symbol(f"_e{self.apart}", real=True)
            self.apart += 1
        else:
            sym = sm.Symbol(f"_t{self.count}", real=True)
            self.count += 1
        self.assignments.append((sym, expr))
        self._seen[expr] = sym
        return sym

    def shared(self, exprs):
        """The loads' components ``exprs`` with their common subexpressions named once (a joint's
        law appears in its child's and its parent's load, and in every component of each); loads
        without function calls (plain inputs, springs) are left as they are.  Used by the
        straight-line rhs (.lower) and the limbs' routines (.limbs) alike."""
        exprs = list(exprs)
        if not any(isinstance(e, sm.Expr) and e.atoms(sm.Function) - e.atoms(sm.core.function.AppliedUndef)
                   for e in exprs):
            return exprs
        repl, reduced = sm.cse(exprs, symbols=sm.numbered_symbols("_load"), order="none")
        names = {}
        for s, e in repl:
            names[s] = self.let(e.xreplace(names))
        return [sm.sympify(e).xreplace(names) for e in reduced]

    def fork(self):
        """A Recorder that goes on from this one's names without changing it (a trial: what
        would this recursion add?)."""
        other = Recorder(self.count)
        other.apart, other.assignments, other._seen = self.apart, list(self.assignments), dict(self._seen)
        return other

    def vec(self, items):
        return [self.let(e) for e in items]

    def sym6(self, M):
        """A symmetric 6x6 (list of lists), lower triangle named, mirrored."""
        out = [[None] * 6 for _ in range(6)]
        for i in range(6):
            for j in range(i + 1):
                out[i][j] = out[j][i] = self.let(M[i][j])
        return out
