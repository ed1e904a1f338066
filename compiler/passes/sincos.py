"""Share sin and cos of the same argument.

Every distinct ``sin(a)`` / ``cos(a)`` becomes one temporary; when both
appear they are assigned next to each other from the same argument
temporary, which is the pattern C compilers turn into one ``sincos`` call.
"""
import sympy as sm
from sympy.core.traversal import preorder_traversal

from ..ir import Names
from .timing import compiler_pass

__all__ = ["share_sincos"]


def _trig_terms(program):
    seen = {}
    exprs = [e for _, e in program.assignments] + [e for _, e in program.results]
    for expr in exprs:
        for node in preorder_traversal(expr):
            if isinstance(node, (sm.sin, sm.cos)) and node not in seen:
                seen[node] = None
    return list(seen)


@compiler_pass
def share_sincos(program):
    """Hoist each sin/cos into its own temporary, sin and cos of one argument adjacent."""
    terms = _trig_terms(program)
    if not terms:
        return program
    by_arg = {}
    for node in terms:
        by_arg.setdefault(node.args[0], {})[node.func] = node
    names = Names(program)
    mapping, inserts = {}, {}
    position = {t: i for i, (t, _) in enumerate(program.assignments)}

    def rewrite(expr):
        return expr.xreplace(mapping)

    # inner calls first, so sin(cos(a)) is placed after the temporary of cos(a)
    nested = sorted(by_arg, key=lambda a: sum(isinstance(n, (sm.sin, sm.cos))
                                              for n in preorder_traversal(a)))
    for arg in nested:
        funcs = by_arg[arg]
        new_arg = rewrite(arg)
        # Renaming inner calls can reorder the argument so that SymPy would rewrite
        # sin(a) as -sin(-a), leaving a call inline; hoist the canonical sign instead.
        flip = new_arg.could_extract_minus_sign()
        if flip:
            new_arg = -new_arg
        where = max((position[s] for s in new_arg.free_symbols if s in position), default=-1)
        for func in (sm.sin, sm.cos):
            if func in funcs:
                sym = names.fresh()
                mapping[funcs[func]] = -sym if (flip and func is sm.sin) else sym
                position[sym] = where
                inserts.setdefault(where, []).append((sym, func, new_arg))
    out = [(sym, func(arg)) for sym, func, arg in inserts.get(-1, [])]
    for i, (target, expr) in enumerate(program.assignments):
        out.append((target, rewrite(expr)))
        out.extend((sym, func(arg)) for sym, func, arg in inserts.get(i, []))
    results = tuple((k, rewrite(e)) for k, e in program.results)
    return program.with_(assignments=tuple(out), results=results, ntemp=names.count)
