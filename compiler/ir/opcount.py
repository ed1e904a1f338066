"""Operation counts (adds, muls, divs, calls) of IR expressions, as the C printer writes them."""
from collections import Counter
from functools import lru_cache

import sympy as sm

from .nodes import IMul

__all__ = ["count_ops", "count_program"]


def count_ops(expr, counter=None):
    """Add the operations of one expression tree to ``counter`` (a Counter) and return it."""
    c = Counter() if counter is None else counter
    stack = [expr]
    while stack:
        e = stack.pop()
        if e.is_Atom:
            continue
        if e.is_Add:
            c["adds"] += len(e.args) - 1
        elif e.is_Mul:
            num = [a for a in e.args if not (a.is_Pow and a.exp.is_negative) and a != -1]
            den = [a for a in e.args if a.is_Pow and a.exp.is_negative]
            c["muls"] += max(len(num) - 1, 0) + max(len(den) - 1, 0)
            if den:
                c["divs"] += 1
                stack.extend(d.base if d.exp == -1 else sm.Pow(d.base, -d.exp) for d in den)
                stack.extend(num)
                continue
        elif isinstance(e, IMul):
            c["muls"] += len(e.args) - 1
        elif e.is_Pow:
            if e.exp == -1:
                c["divs"] += 1
            elif e.exp.is_negative:
                c["divs"] += 1
                c["calls"] += 1
            else:
                c["calls"] += 1
        elif isinstance(e, sm.Function):
            c["calls"] += 1
        stack.extend(e.args)
    return c


@lru_cache(maxsize=1 << 17)
def _counts(expr):
    """count_ops of one expression as ((kind, n), ...), remembered: the op counts of the
    functions that share the kernel's inputs (mass_matrix, forcing, inverse_dynamics, jac_x,
    jac_r) walk the same assignments once each (G1's default build: ~0.07 s)."""
    return tuple(count_ops(expr).items())


def count_program(program):
    """Counter of operations over a program's assignments and results."""
    c = Counter()
    for _, e in program.assignments + program.results:
        for kind, n in _counts(e):
            c[kind] += n
    return c
