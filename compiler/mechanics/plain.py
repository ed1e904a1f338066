"""Plain-symbol algebra for forming equations of motion quickly.

Differentiating and substituting expressions that hold ``q(t)``-style
``Function`` objects is slow in SymPy (every ``diff`` walks ``Derivative``
machinery, every ``xreplace`` rebuilds applied functions).  During the heavy
algebra of Kane's method we therefore replace each dynamic symbol -- and each
time derivative that may appear -- by a plain :class:`sympy.Dummy`, do the
work on ordinary polynomial-trigonometric expressions, and map the results
back once at the end.

:class:`PlainSpace` owns that mapping and the total time derivative in the
plain representation (chain rule through the kinematic differential
equations ``q' = f(q, u, t)``).
"""
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.vector import dynamicsymbols

from eomc.runtime.errors import ModelError

__all__ = ["PlainSpace", "linear_coefficients"]


def _is_dynamic(atom, t):
    """True for ``f(t)`` and ``Derivative(f(t), t, ...)``."""
    if isinstance(atom, AppliedUndef):
        return atom.args == (t,)
    if isinstance(atom, sm.Derivative):
        return isinstance(atom.expr, AppliedUndef) and atom.expr.args == (t,)
    return False


class PlainSpace:
    """Two-way map between dynamic symbols and plain Dummies, plus d/dt.

    ``q``, ``u`` and ``uaux`` are lists of dynamic symbols; ``qdot_map`` maps
    each ``q'`` to an expression in q, u (and possibly t or inputs).  Any
    other dynamic symbol met later (an input such as a motor torque ``T(t)``)
    is registered on the fly, with its derivatives.
    """

    def __init__(self, q, u, uaux, qdot_map):
        self.t = dynamicsymbols._t
        self._fwd_memo = {}
        self._states = set(q) | set(u) | set(uaux)
        self.fwd, self.back, self.ddt = {}, {}, {}
        self.ddt[self.t] = sm.S.One
        self.q = [self._new(x) for x in q]
        self.u = [self._new(x) for x in u]
        self.uaux = [self._new(x) for x in uaux]
        self.udot = [self._new(x.diff(self.t)) for x in u]
        self.uauxdot = [self._new(x.diff(self.t)) for x in uaux]
        for U, Ud in zip(self.u + self.uaux, self.udot + self.uauxdot):
            self.ddt[U] = Ud
        qd_symbols = [qi.diff(self.t) for qi in q]
        # q' are not symbols of their own: they become their kinematic expression.
        for qi, Qi, qd in zip(q, self.q, qd_symbols):
            self.fwd[qd] = self.to_plain(qdot_map[qd]) if qdot_map else self._new(qd)
            self.ddt[Qi] = self.fwd[qd]
        self.speed_set = set(self.u) | set(self.uaux)
        self._dt_memo, self._back_memo = {}, {}

    def _new(self, dyn):
        name = str(dyn).replace("(t)", "")
        if isinstance(dyn, sm.Derivative):
            name = str(dyn.expr.func) + "_d" * dyn.derivative_count
        d = sm.Dummy(name)
        self.fwd[dyn] = d
        self.back[d] = dyn
        return d

    def _register(self, dyn):
        """Register an unknown dynamic symbol (an input) and its derivative chain."""
        if isinstance(dyn, sm.Derivative):
            base, order = dyn.expr, dyn.derivative_count
        else:
            base, order = dyn, 0
        if base in self._states:
            raise ModelError(
                f"{dyn} (a derivative of a coordinate or speed beyond the first) "
                "appears in a velocity, load or constraint; eomc cannot form equations with it")
        prev = self.fwd.get(base) or self._new(base)
        for k in range(1, order + 2):
            key = base.diff(self.t, k)
            cur = self.fwd.get(key) or self._new(key)
            self.ddt[prev] = cur
            prev = cur

    def to_plain(self, expr):
        """Replace every dynamic symbol in ``expr`` (a SymPy expression) by its Dummy."""
        expr = sm.sympify(expr)
        hit = self._fwd_memo.get(expr)
        if hit is not None:
            return hit
        out = expr
        if self.t in expr.free_symbols:
            for atom in expr.atoms(AppliedUndef, sm.Derivative):
                if atom not in self.fwd and _is_dynamic(atom, self.t):
                    self._register(atom)
            out = expr.xreplace(self.fwd)
        self._fwd_memo[expr] = out
        return out

    def to_dynamic(self, expr):
        """Map a plain expression back to dynamic symbols (memoized over subtrees)."""
        return _memo_xreplace(expr, self.back, self._back_memo)

    def matrix_to_dynamic(self, mat):
        memo = self._back_memo
        return mat.applyfunc(lambda e: _memo_xreplace(e, self.back, memo))

    def dt(self, expr, udot=True):
        """Total time derivative of a plain expression.

        With ``udot=False`` the terms in u' are left out: this gives the part of
        an acceleration that remains when all u' are zero.  Terms of sums are
        differentiated one by one and memoized: the velocities of a chain's
        bodies share most of their terms.
        """
        if expr.is_Add:
            return sm.Add(*[self._dt_term(a, udot) for a in expr.args])
        return self._dt_term(expr, udot)

    def _dt_term(self, term, udot):
        key = (term, udot)
        hit = self._dt_memo.get(key)
        if hit is not None:
            return hit
        if term.is_Mul:
            parts = []
            args = term.args
            for i, f in enumerate(args):
                if not (f.free_symbols & self.ddt.keys()):
                    continue
                df = self._dt_term(f, udot)
                if df != 0:
                    parts.append(sm.Mul(*(args[:i] + (df,) + args[i + 1:])))
            out = sm.Add(*parts)
        elif term.is_Pow and not (term.exp.free_symbols & self.ddt.keys()):
            out = term.exp * term.base ** (term.exp - 1) * self.dt(term.base, udot)
        elif isinstance(term, sm.Function) and len(term.args) == 1 and hasattr(term, "fdiff"):
            out = term.fdiff(1) * self.dt(term.args[0], udot)
        else:
            terms = []
            for s in term.free_symbols:
                d = self.ddt.get(s)
                if d is None or (not udot and s in self.speed_set):
                    continue
                terms.append(term.diff(s) * d)
            out = sm.Add(*terms)
        self._dt_memo[key] = out
        return out

    def dt_vector(self, comps, udot=True):
        return tuple(self.dt(c, udot) for c in comps)


def _memo_xreplace(expr, mapping, memo):
    """``expr.xreplace(mapping)`` that remembers rebuilt subtrees across calls."""
    hit = memo.get(expr)
    if hit is not None:
        return hit
    if expr in mapping:
        out = mapping[expr]
    elif not expr.args:
        out = expr
    else:
        args = tuple(_memo_xreplace(a, mapping, memo) for a in expr.args)
        out = expr.func(*args) if args != expr.args else expr
    memo[expr] = out
    return out


def linear_coefficients(expr, symbols):
    """Coefficients of ``expr`` in ``symbols`` (a list), for expr linear in them.

    Returns a list of coefficients (same order as ``symbols``).  Terms of an
    Add that hold a symbol as a plain factor are split without calling
    ``diff``; anything else falls back to differentiation.
    """
    index = {s: i for i, s in enumerate(symbols)}
    out = [[] for _ in symbols]
    for term in sm.Add.make_args(expr):
        hit = [s for s in term.free_symbols if s in index]
        if not hit:
            continue
        if len(hit) == 1 and term.is_Mul and hit[0] in term.args:
            s = hit[0]
            rest = list(term.args)
            rest.remove(s)
            if not any(s in r.free_symbols for r in rest):
                out[index[s]].append(sm.Mul(*rest))
                continue
        if len(hit) == 1 and term == hit[0]:
            out[index[hit[0]]].append(sm.S.One)
            continue
        for s in hit:
            out[index[s]].append(term.diff(s))
    return [sm.Add(*c) for c in out]
