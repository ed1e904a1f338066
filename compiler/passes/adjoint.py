"""Reverse-mode differentiation of a program (an adjoint sweep over the CSE'd DAG).

``adjoint(program, weights, wrt, target)`` adds results ``(target, k) = dS/d(wrt_k)``
of the scalar ``S = Σ weights[key] · result[key]``, the weights being input symbols
(C arrays the caller fills at run time).  Why reverse mode: forward mode
(:mod:`.diff`) costs one tangent per direction, so a gradient with respect to all
states and parameters costs (nx + nparam) tangents; one reverse sweep costs a small
multiple of the program whatever the number of ``wrt`` symbols.  That is what a
vector-Jacobian product (adjoint sensitivities) and, differentiated again forward
(:func:`.diff.tangent` over this pass's results), a Hessian-vector product need.

The sweep visits the assignments once, last to first: a temporary's adjoint is the sum
of ``adjoint(user) · ∂user/∂temporary`` over the temporaries and weighted results that
read it, and becomes a new temporary when it is not an atom.  Only *active* temporaries
(those that depend on some ``wrt`` symbol and that the weighted results read) get an
adjoint, so constant subprograms cost nothing.  Local partial derivatives use the same
rules as the forward pass (sums, products, powers, one-argument functions); anything
else is SymPy's ``diff`` of the (small, post-CSE) expression.  The order of every
emitted term follows the program's own order, never a set's, so the result is
deterministic.
"""
import sympy as sm

from eomc.runtime.errors import ModelError
from ..ir import Names
from .diff import _FLAT, _add, _mul, _pow, _zero
from .timing import compiler_pass

__all__ = ["adjoint"]


def _partial(expr, s):
    """∂expr/∂s with every other symbol held fixed (expr small: one CSE'd assignment).

    Symbols compare by ``==``, never ``is``: SymPy's symbol cache is bounded, so two
    equal symbols made at different times can be different objects."""
    if expr.is_Symbol:
        return sm.S.One if expr == s else sm.S.Zero
    if expr.is_Atom:
        return sm.S.Zero
    if s not in expr.free_symbols:
        return sm.S.Zero
    if expr.is_Add:
        return _add([_partial(a, s) for a in expr.args])
    if expr.is_Mul:
        args = expr.args
        terms = []
        for i, a in enumerate(args):
            da = _partial(a, s)
            if not _zero(da):
                terms.append(_mul(args[:i] + (da,) + args[i + 1:]))
        return _add(terms)
    if expr.is_Pow and s not in expr.exp.free_symbols:
        db = _partial(expr.base, s)
        if _zero(db):
            return sm.S.Zero
        return _mul((expr.exp, _pow(expr.base, expr.exp - 1), db))
    if isinstance(expr, _FLAT):
        return sm.S.Zero
    if isinstance(expr, sm.Function) and len(expr.args) == 1:
        da = _partial(expr.args[0], s)
        return sm.S.Zero if _zero(da) else _mul((expr.fdiff(1), da))
    return expr.diff(s)


def _calls(program, active):
    """The active temporaries holding a call that writes its outputs into an array (``c_declaration``:
    compiler/contact/narrow.py's tokens), whose outputs nodes read; those with a ``reverse`` have a
    reverse sweep, through the others (tangent calls) a reverse sweep is refused."""
    return {t for t, e in program.assignments if t in active and hasattr(e, "c_declaration")}


@compiler_pass
def adjoint(program, weights, wrt, target):
    """Add ``(target, k)`` results: d(Σ weights[key]·result[key]) / d(wrt[k]).

    ``weights``: {result key: weight symbol (an input of the program)}; ``wrt``: input
    symbols (states, parameters, or the solved values a caller treats as independent).
    Results whose derivative is zero are not added.
    """
    wrt = tuple(wrt)
    rank = {s: i for i, s in enumerate(program.inputs)}
    base = len(rank)
    for i, (t, _) in enumerate(program.assignments):
        rank[t] = base + i
    # active: depends on some wrt symbol (forward), and read by a weighted result (backward)
    forward = set(wrt)
    for t, e in program.assignments:
        if not forward.isdisjoint(e.free_symbols):
            forward.add(t)
    weighted = [(k, e, weights[k]) for k, e in program.results if k in weights]
    need = set()
    for _, e, _ in weighted:
        need |= e.free_symbols
    for t, e in reversed(program.assignments):
        if t in need:
            need |= e.free_symbols
    active = forward & (need | set(wrt))

    terms = {}      # symbol -> [terms of its adjoint], in visiting order
    names = Names(program)
    out = []
    # called routines (compiler/contact/narrow.py, table.py): a temporary holding a call token
    # whose outputs other nodes read (``reverse_read()``); the bars of its outputs are gathered
    # per output, and its own ``reverse`` emits the reverse call and gives its inputs' bars
    calls = _calls(program, active)
    outs = {}       # call temporary -> {output index: [terms of its bar]}

    def push(expr, bar):
        syms = sorted((s for s in expr.free_symbols if s in active), key=rank.__getitem__)
        for s in syms:
            if s in calls:
                continue
            d = _partial(expr, s)
            if not _zero(d):
                terms.setdefault(s, []).append(d if bar is sm.S.One else _mul((bar, d)))
        if calls.isdisjoint(syms):
            return
        reads = sorted({n for n in sm.preorder_traversal(expr) if hasattr(n, "reverse_read")
                        and n.reverse_read()[0] in active}, key=lambda n: (rank[n.reverse_read()[0]], n.reverse_read()[1]))
        for node in reads:
            call, index = node.reverse_read()
            if not hasattr(program_defs()[call], "reverse"):
                raise ModelError(f"no reverse sweep is generated through {type(program_defs()[call]).__name__} "
                                 f"(a second derivative's reverse sweep)")
            dummy = sm.Dummy(real=True)
            d = _partial(expr.xreplace({node: dummy}), dummy)
            if not _zero(d):
                d = d.xreplace({dummy: node})
                outs.setdefault(call, {}).setdefault(index, []).append(d if bar is sm.S.One else _mul((bar, d)))

    defs = {}

    def program_defs():
        if not defs:
            defs.update(program.assignments)
        return defs

    for _, e, w in weighted:
        push(e, w)
    for t, e in reversed(program.assignments):
        if t in calls:      # every reader is after it: its outputs' bars are complete
            got = outs.pop(t, None)
            if got:
                bars = {}
                for index in sorted(got):
                    bar = _add(got[index])
                    if not bar.is_Atom:
                        sym = names.fresh()
                        out.append((sym, bar))
                        bar = sym
                    bars[index] = bar
                new, pairs = e.reverse(names.fresh, bars)
                out.extend(new)
                for x, bar in pairs:
                    push(x, bar)
            continue
        ts = terms.pop(t, None)
        if not ts:
            continue
        bar = _add(ts)
        if _zero(bar):
            continue
        if not bar.is_Atom:
            sym = names.fresh()
            out.append((sym, bar))
            bar = sym
        push(e, bar)
    results = list(program.results)
    for k, s in enumerate(wrt):
        ts = terms.get(s)
        if ts:
            g = _add(ts)
            if not _zero(g):
                results.append(((target, k), g))
    return program.with_(assignments=program.assignments + tuple(out), results=tuple(results),
                         ntemp=names.count)
