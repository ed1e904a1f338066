"""Broad phase in straight-line C: a block of temporaries run only when a cheap bound says its
result can be nonzero.

One job: given a function's assignments (in order) and *guards* -- (clearance, exports): a
scalar expression and the temporaries that are exactly 0 whenever ``clearance > 0`` -- print
the assignments with each guard's *block* (the temporaries computed only for its exports)
inside ``if (!(clearance > 0.0)) { ... } else { exports = 0 }``.

Why: the generated code is a flat trace, so every contact point's law ran at every call.  A
URDF robot's default ground (every link's collision box, issue 29) has 108-232 points, most of
them far above the floor at any instant; a body whose lowest possible point is above the plane
(its origin's height less the largest reach of its points) now costs one compare
(compiler/tree/contacts.py makes the bound; benchmarks/results/default_ground.md).

What makes it exact: the caller guarantees each export is exactly zero when the clearance is
positive (the contact law's depth is negative at every point of the body, so δ₊ = 0 and the
force is ±0), so the skipped block changes at most the sign of a zero.  A NaN clearance runs
the block (``!(c > 0)``), so non-finite states propagate as before.

How the block is found, on the final program (after CSE and DCE): its candidates are the
assignments the exports read, directly or through each other; one read by anything outside
(a result, another assignment that is not a candidate, another guard's candidates, a
clearance) stays outside, as does everything it reads.  The exports get slots of a local
array ``G_`` (an ordinary array to the sub-function splitter, compiler/emit/split.py); the
block is printed where its first outside reader would otherwise begin.  A guard whose
clearance or exports the passes have dropped or renamed, or whose outside inputs would only be
defined after that point, is printed straight (never wrong, only not faster).
"""
from .bodies import IND
from .printer import CPrinter

__all__ = ["guarded_temps", "ARRAY"]

ARRAY = "G_"      # the exports' local array (rhs has x, p, r, xdot, S_)


def _reads(expr, defined):
    return [s for s in expr.free_symbols if s in defined]


def _closure(roots, defined, stop=frozenset()):
    """Assignments (targets) read by ``roots`` (expressions), through each other, not
    expanding past ``stop``."""
    seen, stack = set(), [s for e in roots for s in _reads(e, defined)]
    while stack:
        s = stack.pop()
        if s in seen:
            continue
        seen.add(s)
        if s not in stop:
            stack.extend(_reads(defined[s], defined))
    return seen


def _blocks(assignments, roots, known, guards):
    """[(guard index, block targets, position)] of the ``guards`` [(clearance, exports)] that can
    be printed guarded among ``assignments``; ``roots``: the expressions read after them
    (results; a block's exports one level up); ``known``: every symbol defined anywhere (the
    program's inputs and assignments).  ``position`` is the index before which the block goes;
    what ``assignments`` read from outside them is defined before all of them."""
    defined = dict(assignments)
    order = {t: i for i, (t, _) in enumerate(assignments)}
    usable = [(g, clearance, tuple(exports)) for g, (clearance, exports) in enumerate(guards)
              if exports and all(e in defined for e in exports) and clearance.free_symbols <= known]
    if not usable:
        return []
    stop = frozenset(e for _, _, ex in usable for e in ex)
    candidates = [_closure(ex, defined) | set(ex) for _, _, ex in usable]
    count = {}
    for c in candidates:
        for t in c:
            count[t] = count.get(t, 0) + 1
    # read from outside every block: by the roots and clearances, by whatever is not a block's
    # own (a shared candidate, a non-candidate), and through them -- never through an export
    outside = _closure(list(roots) + [c for _, c, _ in usable], defined, stop) - stop
    while True:
        inner = {t for t in count if count[t] == 1 and t not in outside} | stop
        more = _closure([e for t, e in assignments if t not in inner], defined, stop) - stop
        if more <= outside:
            break
        outside |= more
    out = []
    for (g, clearance, exports), cand in zip(usable, candidates):
        block = {t for t in cand if t in inner}
        first_reader = min((order[t] for t, e in assignments
                            if t not in block and set(_reads(e, defined)) & set(exports)), default=len(assignments))
        needs = {s for t in block for s in _reads(defined[t], defined) if s not in block}
        needs |= set(_reads(clearance, defined))
        if any(order[s] >= first_reader for s in needs) or any(count[e] != 1 for e in exports):
            continue
        out.append((g, block, first_reader))
    return out


class _Printer:
    """The lines of one function's assignments, guards nested, exports in slots of ARRAY."""

    def __init__(self, program, printer):
        from .bodies import temps
        self.program, self.temps = program, temps
        self.names = dict(printer._names)
        self.pr = CPrinter(self.names)          # sees the slots as they are given
        self.known = set(program.inputs) | {t for t, _ in program.assignments}
        self.slots = 0

    def lines(self, assignments, roots, guards, indent):
        """``guards``: [(clearance, exports, inner guards)]."""
        found = _blocks(assignments, roots, self.known, [(c, ex) for c, ex, _ in guards])
        taken = {g for g, _, _ in found}
        # a guard that cannot be honoured here leaves its inner guards to this level
        promoted = [inner for g, (_, _, children) in enumerate(guards) if g not in taken for inner in children]
        if promoted:
            return self.lines(assignments, roots, [gd for g, gd in enumerate(guards) if g in taken] + promoted,
                              indent)
        in_block = {t for _, block, _ in found for t in block}
        at = {}
        for k, (_, _, pos) in enumerate(found):
            at.setdefault(pos, []).append(k)
        out = []
        for i, (t, e) in enumerate(assignments + [(None, None)]):
            for k in at.get(i, ()):
                out += self.block(assignments, guards[found[k][0]], found[k][1], indent)
            if t is not None and t not in in_block:
                out += [indent + line[len(IND):] for line in self.temps(self.program, self.pr, [(t, e)])]
        return out

    def block(self, assignments, guard, block, indent):
        clearance, exports, children = guard
        for e in exports:
            if e not in self.names or not self.names[e].startswith(ARRAY + "["):
                self.names[e] = f"{ARRAY}[{self.slots}]"
                self.slots += 1
        body = [(t, e) for t, e in assignments if t in block]
        inner_exports = {e for _, ex, _ in children for e in ex}
        roots = [e for e in exports if e not in inner_exports]
        head = f"{indent}if (!({self.pr.doprint(clearance)} > 0.0)) {{"
        return ([head] + self.lines(body, roots, list(children), indent + IND) + [f"{indent}}} else {{"]
                + [f"{indent}{IND}{self.names[e]} = 0.0;" for e in exports] + [f"{indent}}}"])


def guarded_temps(program, printer, guards):
    """(C lines of ``program``'s assignments with the guards' blocks, the printer to use for the
    rest of the function: the exports named ``G_[k]``).  ``guards``: [(clearance, exports,
    inner guards)], an inner guard's exports among its outer guard's (a contact point inside
    its body).  Without a usable guard: temps()'s lines unchanged."""
    from .bodies import temps
    p = _Printer(program, printer)
    lines = p.lines(list(program.assignments), [e for _, e in program.results], list(guards), IND)
    if not p.slots:
        return temps(program, printer), printer
    return [f"{IND}double {ARRAY}[{p.slots}];"] + lines, p.pr
