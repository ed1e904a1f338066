"""Share sin and cos of the same argument.

Every distinct ``sin(a)`` / ``cos(a)`` becomes one temporary; when both
appear they are assigned next to each other from the same argument
temporary, which is the pattern C compilers turn into one ``sincos`` call.

An assignment that already is ``t = sin(a)`` (CSE writes one for every call used
twice) keeps its target: it only moves up beside its partner.  Giving it a fresh
temporary instead would leave ``t = fresh`` copies for constant folding to
substitute into, and re-canonicalize, every expression that reads ``t``; on the
Whipple bicycle that rebuilt 40 thousand expressions and took a third of generation.
"""
import sympy as sm
from sympy.core.traversal import preorder_traversal

from ..ir import Names
from .replace import Replacer
from .timing import compiler_pass

__all__ = ["share_sincos"]

_TRIG = (sm.sin, sm.cos)


class _Scan:
    """Every distinct sin/cos node in the order a preorder traversal of the program first
    meets it, and which nodes contain one or a symbol in ``renamed``.  A node object met before is not walked again:
    preorder finishes a subtree before it leaves it, so its calls were all seen then."""

    def __init__(self, exprs, renamed):
        self.renamed = renamed
        self.seen = {}
        self.has = {}       # id(node) -> (node, contains a sin/cos)
        for e in exprs:
            if id(e) not in self.has:
                if e.args:
                    self.visit(e)
                else:
                    self.has[id(e)] = (e, e.is_Symbol and e in renamed)

    def visit(self, node):
        has = self.has
        found = isinstance(node, _TRIG)
        if found:
            if node not in self.seen:
                self.seen[node] = None
        for a in node.args:
            hit = has.get(id(a))
            if hit is not None:
                found = found or hit[1]
            elif a.args:
                found = self.visit(a) or found      # every argument: the order of first meeting
            else:
                leaf = a.is_Symbol and a in self.renamed
                has[id(a)] = (a, leaf)
                found = found or leaf
        has[id(node)] = (node, found)
        return found


@compiler_pass
def share_sincos(program):
    """Hoist each sin/cos into its own temporary, sin and cos of one argument adjacent."""
    # the first assignment that is exactly a call keeps its target as the shared temporary;
    # later ones (the derivative passes add cos(a) next to an existing cos(a)) are renamed
    holder, duplicate = {}, {}
    for target, expr in program.assignments:
        if isinstance(expr, _TRIG):
            if expr in holder:
                duplicate[target] = expr
            else:
                holder[expr] = target
    exprs = [e for _, e in program.assignments] + [e for _, e in program.results]
    scan = _Scan(exprs, duplicate)
    terms = list(scan.seen)
    if not terms:
        return program
    by_arg = {}
    for node in terms:
        by_arg.setdefault(node.args[0], {})[node.func] = node
    names = Names(program)
    mapping, inserts, moved = {}, {}, set()
    position = {t: i for i, (t, _) in enumerate(program.assignments)}

    def rewrite(expr):
        return expr.xreplace(mapping)

    # inner calls first, so sin(cos(a)) is placed after the temporary of cos(a)
    nested = sorted(by_arg, key=lambda a: sum(isinstance(n, _TRIG)
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
        for func in _TRIG:
            if func in funcs:
                node = funcs[func]
                sym = holder.get(node)
                if sym is None or flip:
                    sym = names.fresh()
                else:
                    moved.add(sym)
                mapping[node] = -sym if (flip and func is sm.sin) else sym
                position[sym] = where
                inserts.setdefault(where, []).append((sym, func, new_arg))
    moved |= set(duplicate)
    mapping.update((target, mapping[expr]) for target, expr in duplicate.items())
    # the mapping is complete now: one memoized walk, skipping subtrees with no call
    # and no renamed duplicate
    rewrite = Replacer(mapping, rename=True)
    rewrite.memo.update((k, (n, n)) for k, (n, found) in scan.has.items() if not found)

    def hoisted(where):
        return [(sym, func(arg)) for sym, func, arg in inserts.get(where, [])]

    out = hoisted(-1)
    for i, (target, expr) in enumerate(program.assignments):
        if target not in moved:
            out.append((target, rewrite(expr)))
        out.extend(hoisted(i))
    results = tuple((k, rewrite(e)) for k, e in program.results)
    return program.with_(assignments=tuple(out), results=results, ntemp=names.count)
