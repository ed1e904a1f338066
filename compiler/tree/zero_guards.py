"""Broad phase for the laws that switch on past a threshold: a joint limit's side (or a tendon's)
skipped while its joint is inside the range, in the rhs and in NAME_implicit (.emit).

Why: a limit law (compiler/tree/joint_laws.joint_torque: a ramp r = max(d, 0) of how far the
joint is past its bound, a smooth clip with a square root, two divisions, MJCF's hold tanh) and
its slopes in q and u were computed for both sides of every limited joint at every call, though
a joint is almost always inside its range, where all of it is exactly zero.  Measured on
gymnasium's humanoid (17 limited hinges, 34 sides): NAME_implicit 4492 ns a call, 3829 ns with
the limits off; the ant 1799 against 1499 (session 47).  Guarded against not, in one run
(benchmarks/bench_limit_guards.py): NAME_implicit 4186 -> 3743 and 1779 -> 1329 ns, the rhs
2457 -> 2342 and 717 -> 672 ns.

How: an abstract walk of the final program (after CSE and DCE) finds, for each temporary, the
thresholds d whose ``ramp(d)`` or ``step(d)`` makes it exactly ±0 whenever d <= 0: a product
is zero if one factor is and no factor can be infinite there (a division by something zero
there), a sum if every term is, a positive power or an odd function that keeps 0 (tanh, sin,
...) if its argument is.  Each threshold's temporaries become one guard of
compiler/emit/guards.py, clearance -d, exports those read from outside the threshold's own:
the block runs only where d > 0 (or d is NaN), else its exports are 0 -- the same numbers up to
the sign of a zero, as for the contacts' guards.  A threshold whose temporaries (or clearance) meet
what another guard's exports read (a ground contact's depth inside its body's guard, a pair's
choice between its candidate points) is left to that guard, and
one whose temporaries are too few to pay for a branch is printed straight.
"""
import sympy as sm

from ..contact.law import step
from ..ir import Names
from ..ir.program import needed_assignments
from ..ir.nodes import IMul
from ..ir.opcount import count_ops
from .joint_laws import ramp

__all__ = ["with_threshold_guards", "MIN_OPS"]

# a threshold's guard is kept when its temporaries hold at least this many operations (a compare
# and a branch cost about as much as a few)
MIN_OPS = 8

_ODD = (sm.tanh, sm.sinh, sm.sin, sm.tan, sm.atan, sm.asinh, sm.asin, sm.atanh)
_NONE = frozenset()


class _Walk:
    """Z(e): the thresholds d at which ``e`` is ±0 whenever d <= 0; I(e): those at which it may be
    infinite (a division by a Z-zero), which make a product with it no longer zero."""

    def __init__(self, only=None):
        self.only = only         # the thresholds looked at (None: every one)
        self.sym = {}            # temporary -> (Z, I)
        self.memo = {}
        self.order = {}          # threshold -> its first place (a deterministic choice among several)

    def __call__(self, e):
        if e.is_Symbol:
            return self.sym.get(e, (_NONE, _NONE))
        if e.is_Number or not e.args:
            return _NONE, _NONE
        got = self.memo.get(e)
        if got is None:
            got = self.memo[e] = self._walk(e)
        return got

    def _walk(self, e):
        if isinstance(e, (ramp, step)):
            d = e.args[0]
            self.order.setdefault(d, len(self.order))
            return (frozenset((d,)) if self.only is None or d in self.only else _NONE), self(d)[1]
        parts = [self(a) for a in e.args]
        inf = frozenset().union(*(i for _, i in parts))
        if e.is_Mul or isinstance(e, IMul):
            return frozenset().union(*(z for z, _ in parts)) - inf, inf
        if e.is_Add:
            return frozenset.intersection(*(z for z, _ in parts)) - inf, inf
        if e.is_Pow:
            (zb, ib), exp = parts[0], e.exp
            if exp.is_Number and exp > 0:
                return zb - ib, ib
            return _NONE, ib | zb
        if isinstance(e, _ODD):
            return parts[0][0] - inf, inf
        return _NONE, inf


def _ops(e):
    return sum(count_ops(e).values())


def with_threshold_guards(program, guards=()):
    """(``program`` with each threshold's terms of a sum named, the guards: ``guards`` and one per
    threshold (module docstring) in the order they first appear).  ``guards``: those already
    given (compiler/emit/guards.py's form), whose blocks (what their exports read) a threshold keeps
    out of.

    Why the terms named: a joint's torque is one sum (its damping, its actuator, both limit sides)
    and each slope result another, so a side's term is no temporary a guard could skip; named,
    it is, and the sum reads it from outside the block.  Only the guarded thresholds' terms are
    named (a second plan with those alone): a sum whose threshold gets no guard keeps its order,
    and a program with none is returned as it came (the same C, the same bits)."""
    _, chosen = _plan(program, guards, None)
    if not chosen:
        return program, list(guards)
    program, chosen = _plan(program, guards, frozenset(d for d, _ in chosen))
    return program, list(guards) + [(-d, exports, ()) for d, exports in chosen]


def _plan(program, given, only):
    """(``program`` with the terms of ``only``'s thresholds named (every threshold's if None),
    [(threshold, exports)] of the thresholds that get a guard)."""
    walk = _Walk(only)
    program = _split(program, walk)
    members = {}
    for t, _ in program.assignments:
        z = walk.sym[t][0]
        if z:
            members.setdefault(min(z, key=walk.order.__getitem__), []).append(t)
    chosen = []
    if not members:
        return program, chosen
    taken = _reach(program, _exports(given))
    owner = {t: d for d, ts in members.items() for t in ts}
    read = set()                                 # read by a result or a clearance: never absorbed
    for _, e in program.results:
        read.update(e.free_symbols)
    for d in members:
        read.update(d.free_symbols)
    readers = {}
    for t, e in program.assignments:
        for s in e.free_symbols:
            readers.setdefault(s, []).append(t)
    # a temporary that only one threshold's temporaries read is computed inside its block too
    # (r + e of a limit's g = r/(r + e)): it is not zero outside, so never an export
    for t, _ in reversed(program.assignments):
        if t in owner or t in read or t not in readers:
            continue
        got = {owner.get(r) for r in readers[t]}
        if len(got) == 1 and None not in got:
            owner[t] = got.pop()
    outside = {s for s in read if s in owner}    # zero temporaries read from outside their block
    for t, e in program.assignments:
        mine = owner.get(t)
        outside.update(s for s in e.free_symbols if s in owner and owner[s] != mine)
    exprs = dict(program.assignments)
    for d, ts in sorted(members.items(), key=lambda kv: walk.order[kv[0]]):
        if taken.intersection(ts) or d.free_symbols & (taken | set(ts)):
            continue
        exports = tuple(t for t in ts if t in outside)
        if exports and sum(_ops(exprs[t]) for t in ts) >= MIN_OPS:
            chosen.append((d, exports))
    return program, chosen


def _exports(guards):
    """Every export of ``guards``, inner guards' included."""
    out, stack = set(), list(guards)
    while stack:
        _, exports, inner = stack.pop()
        out.update(exports)
        stack.extend(inner)
    return out


def _reach(program, exports):
    """``exports`` and every temporary they read, through each other: what the given guards'
    blocks may hold.  A threshold with a temporary there, or a clearance reading one, is left to
    them (a pair's choice between its candidate points is a step() of their distances, inside the
    pair's own block: two guards over one temporary would place it after its reader)."""
    return {t for t, _ in needed_assignments(program.assignments, exports)}


def _split(program, walk):
    """``program`` with the terms of a sum (an assignment's or a result's) that one threshold makes
    zero, where the sum itself is not, named as temporaries just before it (one per threshold);
    fills ``walk.sym`` for every temporary."""
    names = Names(program)
    assignments, changed = [], False

    def split(e):
        if not e.is_Add:
            return e, []
        groups = {}
        for term in e.args:
            z = walk(term)[0]
            if z and not term.is_Symbol:
                groups.setdefault(min(z, key=walk.order.__getitem__), []).append(term)
            else:
                groups.setdefault(None, []).append(term)
        if len(groups) < 2 or None not in groups and len(groups) == 1:
            return e, []
        new, rest = [], list(groups.pop(None, []))
        for terms in groups.values():
            t = names.fresh()
            value = sm.Add(*terms)
            walk.sym[t] = walk(value)
            new.append((t, value))
            rest.append(t)
        return sm.Add(*rest), new

    for t, e in program.assignments:
        z = walk(e)
        if not z[0]:
            e2, new = split(e)
            if new:
                assignments += new
                e, changed = e2, True
        walk.sym[t] = walk(e)
        assignments.append((t, e))
    results = []
    for k, e in program.results:
        e2, new = split(e)
        if new:
            assignments += new
            e, changed = e2, True
        results.append((k, e))
    if not changed:
        return program
    return program.with_(assignments=tuple(assignments), results=tuple(results), ntemp=names.count)
