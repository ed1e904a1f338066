"""The optimizer's IR: a flat, immutable single-assignment program.

A :class:`Program` is what every pass consumes and returns:

* ``inputs``: the symbols the C code reads (array slots such as ``x_3``,
  ``p_0``, the time ``t``); they are never assigned;
* ``assignments``: ``((target, expr), ...)`` in execution order; each target
  is assigned once and only after every symbol its expression reads;
* ``results``: ``((key, expr), ...)``: what the program computes.  A key is a
  tuple ``(group, i, j)`` the C emitter maps to an lvalue (``xdot[i]``, ...);
* ``ntemp``: the names registry's counter.  New temporaries are
  ``Symbol("_t<k>")`` with ``k`` taken from it, so a program's names depend
  only on its content, never on ``id()`` or global state.

The C names ``t0, t1, ...`` are given at print time by position
(:func:`c_names`), so renumbering never rebuilds expressions.
"""
from dataclasses import dataclass, replace
from functools import lru_cache

import sympy as sm

__all__ = ["Program", "Names", "IRError", "c_names", "free_inputs", "symbols_of", "needed_assignments", "distinct_atoms"]


@lru_cache(maxsize=1 << 17)
def symbols_of(expr):
    """``expr.free_symbols``, remembered (a frozenset).

    Why: SymPy walks the whole tree on every ``free_symbols``, and the passes ask it of the
    same assignments again and again (DCE once per generated function, verify, the body
    emitters): G1's default build spent ~0.1 s of its Python there.  Equal expressions have
    the same free symbols, so the cache is keyed by the expression itself; it is bounded."""
    return frozenset(expr.free_symbols)


def distinct_atoms(exprs):
    """The atoms of ``exprs``, each shared subexpression walked once (first-seen order).

    Why: formed equations are DAGs that can be far larger as trees; a walk of the tree (or
    ``has()`` per constant) revisits shared subtrees as often as they occur.  The checks for
    non-finite and non-real constants (formulations.select, model.validate) read the atoms."""
    atoms, seen, stack = [], set(), list(exprs)
    while stack:
        e = stack.pop()
        if id(e) in seen or not isinstance(e, sm.Basic):
            continue
        seen.add(id(e))
        if e.is_Atom:
            atoms.append(e)
        else:
            stack.extend(e.args)
    return atoms


def needed_assignments(assignments, exprs):
    """The assignments (order kept) that ``exprs`` read, directly or through each other.

    Why here: the body emitters (what a block of results needs) and the generator's
    weighing of a rewrite (seed_pairs) both walk a program backwards from some results."""
    defined = {t: e for t, e in assignments}
    need, stack = set(), [s for e in exprs for s in symbols_of(e)]
    while stack:
        s = stack.pop()
        if s in defined and s not in need:
            need.add(s)
            stack.extend(symbols_of(defined[s]))
    return [(t, e) for t, e in assignments if t in need]


class IRError(ValueError):
    """A program breaks the single-assignment rules (a compiler bug, not a user error)."""


@dataclass(frozen=True)
class Program:
    inputs: tuple
    assignments: tuple = ()
    results: tuple = ()
    ntemp: int = 0

    def with_(self, **changes):
        """A copy with some fields replaced (programs are immutable)."""
        return replace(self, **changes)

    def select(self, groups):
        """The same program restricted to results whose group is in ``groups``."""
        groups = set(groups)
        return self.with_(results=tuple(r for r in self.results if r[0][0] in groups))

    def result_exprs(self, group):
        """{key: expr} of one result group."""
        return {k: e for k, e in self.results if k[0] == group}


class Names:
    """Deterministic fresh temporaries for one pass over one program."""

    def __init__(self, program):
        self.count = program.ntemp

    def fresh(self):
        sym = sm.Symbol(f"_t{self.count}", real=True)
        self.count += 1
        return sym

    def stream(self):
        """An endless generator of fresh temporaries (for sympy.cse)."""
        while True:
            yield self.fresh()


def c_names(program):
    """{temporary: C name}: ``t0, t1, ...`` in assignment order."""
    return {target: f"t{i}" for i, (target, _) in enumerate(program.assignments)}


def free_inputs(program):
    """The input symbols the program really reads."""
    inputs = set(program.inputs)
    used = set()
    for _, e in program.assignments:
        used |= symbols_of(e) & inputs
    for _, e in program.results:
        used |= symbols_of(e) & inputs
    return used
