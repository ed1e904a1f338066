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
block is printed where its first outside reader would otherwise begin.  Exports the passes
dropped (nothing read them) are left out of their guard (:func:`_present`).  A guard whose
clearance the passes have dropped or renamed, whose exports are all gone, or whose outside
inputs would only be defined after that point, is printed straight (never wrong, only not
faster).
"""
from .bodies import IND
from .printer import CPrinter

__all__ = ["guarded_temps", "ARRAY"]

ARRAY = "G_"      # the exports' local array (rhs has x, p, r, xdot, S_)


def _closure(roots, reads, stop=frozenset()):
    """Targets read by ``roots`` (symbols), through each other (``reads``: {target: the
    targets its expression reads}), not expanding past ``stop``."""
    seen, stack = set(), list(roots)
    while stack:
        s = stack.pop()
        if s in seen:
            continue
        seen.add(s)
        if s not in stop:
            stack.extend(reads[s])
    return seen


def _blocks(assignments, roots, known, guards, reads):
    """[(guard index, block targets, position)] of the ``guards`` [(clearance, exports)] that can
    be printed guarded among ``assignments``; ``roots``: the targets read after them (by the
    results; a block's exports one level up); ``known``: every symbol defined anywhere (the
    program's inputs and assignments); ``reads``: {target: targets its expression reads}.
    ``position`` is the index before which the block goes; what ``assignments`` read from
    outside them is defined before all of them."""
    order = {t: i for i, (t, _) in enumerate(assignments)}
    usable = [(g, clearance, tuple(exports)) for g, (clearance, exports) in enumerate(guards)
              if exports and all(e in order for e in exports) and clearance.free_symbols <= known]
    if not usable:
        return []
    local = {t: [s for s in reads[t] if s in order] for t in order}
    stop = frozenset(e for _, _, ex in usable for e in ex)
    cread = {g: [s for s in c.free_symbols if s in order] for g, c, _ in usable}
    candidates = [_closure(ex, local) for _, _, ex in usable]
    count = {}
    for c in candidates:
        for t in c:
            count[t] = count.get(t, 0) + 1
    # read from outside every block: by the roots and clearances, by whatever is not a block's
    # own (a shared candidate, a non-candidate), and through them -- never through an export
    starts = [s for s in roots if s in order] + [s for g in cread.values() for s in g]
    outside = _closure(starts, local, stop) - stop
    while True:
        inner = {t for t in count if count[t] == 1 and t not in outside} | stop
        more = _closure([s for t in order if t not in inner for s in local[t]], local, stop) - stop
        if more <= outside:
            break
        outside |= more
    first = {}                       # export -> the first assignment outside its block reading it
    for t, _ in assignments:
        for s in local[t]:
            if s in stop and t not in inner and s not in first:
                first[s] = order[t]
    out = []
    for (g, clearance, exports), cand in zip(usable, candidates):
        block = {t for t in cand if t in inner}
        first_reader = min((first.get(e, len(assignments)) for e in exports), default=len(assignments))
        needs = {s for t in block for s in local[t] if s not in block} | set(cread[g])
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
        self.reads = {t: [s for s in e.free_symbols if s in self.known] for t, e in program.assignments}
        self.slots = 0

    def lines(self, assignments, roots, guards, indent):
        """``guards``: [(clearance, exports, inner guards)]."""
        found = _blocks(assignments, roots, self.known, [(c, ex) for c, ex, _ in guards], self.reads)
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


def _present(guards, defined):
    """``guards`` with only the exports the program still defines (``defined``), and without the
    guards left with none.  Why: dead-code elimination drops the exports nothing reads (a planar
    model's out-of-plane wrench components); a guard is kept exact by its remaining exports alone
    (a dropped export is not computed, and what the passes renamed is read from outside the block,
    so it stays outside), where before one missing export printed the whole pair straight
    (dm_control's stacker: 56 of its pairs' 62 narrow-phase calls unguarded)."""
    out = []
    for clearance, exports, inner in guards:
        exports = tuple(e for e in exports if e in defined)
        if exports:
            out.append((clearance, exports, tuple(_present(inner, defined))))
    return out


def guarded_temps(program, printer, guards):
    """(C lines of ``program``'s assignments with the guards' blocks, the printer to use for the
    rest of the function: the exports named ``G_[k]``).  ``guards``: [(clearance, exports,
    inner guards)], an inner guard's exports among its outer guard's (a contact point inside
    its body).  Without a usable guard: temps()'s lines unchanged."""
    from .bodies import temps
    p = _Printer(program, printer)
    roots = sorted({s for _, e in program.results for s in e.free_symbols if s in p.reads}, key=str)
    lines = p.lines(list(program.assignments), roots, _present(guards, p.reads), IND)
    if not p.slots:
        return temps(program, printer), printer
    return [f"{IND}double {ARRAY}[{p.slots}];"] + lines, p.pr
