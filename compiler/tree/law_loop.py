"""The joint laws' slopes in NAME_dyn_inputs as one loop per shape of law (issue 30's build bar).

Why: a robot's limit laws differ only in their joint's coordinate, speed and parameters
(:func:`.analytic._law_slopes` differentiates one per shape), yet NAME_dyn_inputs printed
each joint's ∂τ/∂q and ∂τ/∂u as ~27 statements of its own: on G1 ~795 of its ~2630
statements.  Here the laws whose statements print alike (the joint's state, parameter and
input slots as arguments, the temporaries by position) share one static function
(``NAME_law<k>``: those statements, the pair into out[0], out[1]), which NAME_dyn_inputs calls
in a loop over a table of each joint's slots, writing the pair into an[] block L.  The text
being the unrolled one, each joint's slopes are computed by the same operations in the same
order: the same bits (tests/compiler/tree/test_law_loop.py).

Only the shared NAME_dyn_inputs takes it: jac_x's and jac_id's own copies stay unrolled
(jac_x_batch rewrites jac_x's lines into lanes, which know no such call).  The helper is
double text like the rest, so the c99-f32 pass (compiler/emit/target.py) gives its float
twin, and it is defined only in the file whose NAME_dyn_inputs calls it (one of that
function's parts).
"""
import re

import sympy as sm

from ..emit.printer import CPrinter
from .analytic import ANX

__all__ = ["law_loops", "LAW_LOOPS"]

LAW_LOOPS = True     # False: the slopes unrolled, as before session 24 (for A/B)

_SLOT = re.compile(r"^(x|p|r)\[(\d+)\]$")


def law_loops(name, plan, pr, program, assignments, vals, ind="    "):
    """(C lines of the loops, [the helpers' C], the an[] indices they write), or None when no two
    laws print alike.  ``plan``: the :class:`.analytic.AnalyticPlan` (its ``law_code``); ``pr``:
    NAME_dyn_inputs' printer; ``assignments``, ``vals``: its temporaries and an[] values.

    Each law's statements are those NAME_dyn_inputs would print (the temporaries its two
    slopes read, after every pass), printed with the joint's symbols as the helper's
    arguments: laws whose text is the same share one helper, so each joint's slopes are
    computed by the very operations, in the very order, of its unrolled statements (the same
    bits); a law alone in its text, or reading anything but its own joint's slots, stays unrolled."""
    if not LAW_LOOPS or not plan.law_code:
        return None
    groups, program_index = {}, _Index(assignments)
    for at, _, back in plan.law_code:
        got = _law_text(at, back, pr, program_index, vals)
        if got is not None:
            groups.setdefault(got[0], []).append((at, got[1]))
    lines, helpers, covered = [], [], set()
    for text, entries in groups.items():
        if len(entries) < 2:
            continue
        k = len(helpers)
        fname = f"{name}_law{k}"
        nargs = len(entries[0][1])
        helpers.append(f"static void {fname}({', '.join(f'double a{i}' for i in range(nargs))}, double *out)\n"
                       f"{{\n{text}\n}}")
        lines += _loop(fname, k, entries, ind)
        covered.update(i for at, _ in entries for i in (at, at + 1))
    if not helpers:
        return None
    return lines, helpers, covered


class _Index:
    """NAME_dyn_inputs' temporaries by name, and their places, made once for all its laws.

    Why: :func:`~eomc.compiler.ir.program.needed_assignments` builds both for every call and
    then walks every assignment to keep their order; called once per law, that was G1's
    ~2,600 assignments 29 times over.  :meth:`needed` returns the same list."""

    def __init__(self, assignments):
        self.assignments = list(assignments)
        self.defined = {t: e for t, e in self.assignments}
        self.place = {t: k for k, (t, _) in enumerate(self.assignments)}

    def needed(self, exprs):
        """``needed_assignments(assignments, exprs)``: what ``exprs`` read, in program order."""
        from ..ir.program import symbols_of
        defined, need = self.defined, set()
        stack = [s for e in exprs for s in symbols_of(e)]
        while stack:
            s = stack.pop()
            if s in defined and s not in need:
                need.add(s)
                stack.extend(symbols_of(defined[s]))
        return [self.assignments[k] for k in sorted(self.place[t] for t in need)]


def _law_text(at, back, pr, index, vals):
    """(the helper body of the law whose slopes are an[at], an[at + 1], its arguments' slots
    as (array, index)), or None when it cannot be a helper's.  ``index``: :class:`_Index`."""
    from ..ir.program import symbols_of
    outs = [vals.get((ANX, at)), vals.get((ANX, at + 1))]
    if any(e is None for e in outs):
        return None
    own = index.needed(outs)
    joint = [v for _, v in back if isinstance(v, sm.Symbol)]
    names = {v: f"a{i}" for i, v in enumerate(joint)}
    names.update({s: f"w{i}" for i, (s, _) in enumerate(own)})
    read = set()
    for e in [e for _, e in own] + outs:
        read |= symbols_of(e) if isinstance(e, sm.Basic) else set()
    if read - set(names):
        return None
    joint_set = set(joint)
    order = {}      # the joint's symbols in the order the statements first read them
    for e in [e for _, e in own] + outs:
        for node in sm.preorder_traversal(e):
            if node.is_Symbol and node in joint_set and node not in order:
                order[node] = None
    used = list(order)
    slots = [_SLOT.match(pr._names.get(v, "")) for v in used]
    if any(m is None for m in slots):
        return None
    names.update({v: f"a{i}" for i, v in enumerate(used)})     # the arguments it reads, in order
    hp = CPrinter(names)
    body = [f"    const double w{i} = {hp.doprint(e)};" for i, (_, e) in enumerate(own)]
    body += [f"    out[{j}] = {hp.doprint(e)};" for j, e in enumerate(outs)]
    return "\n".join(body), [(m.group(1), int(m.group(2))) for m in slots]


def _loop(fname, k, entries, ind):
    """C: the tables of the laws' slots and an[] places, and the loop calling ``fname`` on each."""
    n, nargs = len(entries), len(entries[0][1])
    arrays = [a for a, _ in entries[0][1]]
    if any([a for a, _ in slots] != arrays for _, slots in entries):
        raise AssertionError("laws of one text read different arrays (compiler bug)")
    out = [f"{ind}{{   /* the joint laws' slopes, one loop per shape (law_loop.py): an[] block L */",
           f"{ind * 2}static const int li{k}[{n}][{nargs}] = {{"
           + ", ".join("{" + ", ".join(str(i) for _, i in slots) + "}" for _, slots in entries) + "};",
           f"{ind * 2}static const int lo{k}[{n}] = {{" + ", ".join(str(at) for at, _ in entries) + "};",
           f"{ind * 2}int j;",
           f"{ind * 2}for (j = 0; j < {n}; j++)",
           f"{ind * 3}{fname}({', '.join(f'{a}[li{k}[j][{i}]]' for i, a in enumerate(arrays))}, &an[lo{k}[j]]);",
           f"{ind}}}"]
    return out
