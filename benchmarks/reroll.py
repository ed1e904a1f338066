"""Prototype of issue 31 item 4's lever, for measurement (not wired into the compiler): the
repeated body pattern of a straight-line function emitted once as a small static routine.

Why: bench_cart_scaling.py --valgrind shows the recursive cart rhs's time per operation rising
with n once its code outgrows the 32 kB first-level instruction cache (no simulated I1 misses up
to n = 20, every line of code missed on every call from n = 40), while its instructions per
operation fall.  A chain of like links repeats the same statements once per link (the
articulated-inertia pass most of all), differing only in which temporaries they read.

How, on the printed lines (as compiler/emit/split.py works): every ``const double tN = E;`` of a
run gets a signature, E's tree with sums and products flattened and their operands sorted, its
temporaries and constant-index array reads (``x[12]``) as placeholders.  A stretch where
statement i's signature equals statement i + P's for K·P statements is K periods of P
statements; the periods must agree on which reads are their own earlier statements, which the
previous period's, and which come from elsewhere (inputs).  The period becomes ``static void
BASE(const double *restrict i_, const double *restrict p_, double *restrict o_)`` (noinline, the
command line's optimization level): its P statements, inputs from i_, the previous period's
values from its outputs p_, the values read after the period stored to o_.  Each period of the
caller is one call, ``{ const double i_[NI] = {...}; BASE(i_, R_ + (k-1)·NO, R_ + k·NO); }``
(the first period's p_ is a seed array of the values before the stretch), and later reads of
the outputs read ``R_[k·NO + q]``.  The operations are those of the straight-line code, but a
period whose operands were printed in another order (SymPy sorts them by name, and the names
change from link to link) is evaluated in the template's order: equal to rounding, not bit for
bit (bench_cart_scaling.py prints the difference).

Measured (benchmarks/results/cart_scaling.md): on the cart it rolls the articulated-inertia
pass (one stretch of 38 statements per link), the code shrinks by 40 % and the simulated I1
misses by 40 %, but the calls copy 13 inputs per link and write 15 outputs to memory: 20 % more
instructions, and the rhs ran 10-17 % slower than the straight-line code at every n >= 8.  So
it is not wired into the compiler.

Usage: python benchmarks/reroll.py MODEL -o DIR [eomc build options]: ``eomc build`` with the
rhs's body rerolled before split_body (monkeypatched: eomc.compiler.emit.generate.split_body).
"""
import ast
import re
import sys

import numpy as np

_TEMP_LINE = re.compile(r"^    const double (t\d+) = (.*);$")
_REF = re.compile(r"\bt\d+\b|\b[A-Za-z_]\w*\[\d+\]")
_TEMP = re.compile(r"^t\d+$")
MIN_PERIOD = 4
MAX_PERIOD = 400
MAX_REGIONS = 12


def _tree(e, src):
    """A statement's expression as a tuple tree: sums and products flattened (their terms and
    factors get sorted, see _canon), leaves ('ref', text) for temporaries and array reads."""
    if isinstance(e, ast.BinOp) and isinstance(e.op, (ast.Add, ast.Sub)):
        terms = []

        def walk(x, sign):
            if isinstance(x, ast.BinOp) and isinstance(x.op, (ast.Add, ast.Sub)):
                walk(x.left, sign)
                walk(x.right, sign if isinstance(x.op, ast.Add) else -sign)
            elif isinstance(x, ast.UnaryOp) and isinstance(x.op, ast.USub):
                walk(x.operand, -sign)
            else:
                terms.append((sign, _tree(x, src)))
        walk(e, 1)
        return ("sum", tuple(terms))
    if isinstance(e, ast.BinOp) and isinstance(e.op, ast.Mult):
        factors = []

        def walkm(x):
            if isinstance(x, ast.BinOp) and isinstance(x.op, ast.Mult):
                walkm(x.left)
                walkm(x.right)
            else:
                factors.append(_tree(x, src))
        walkm(e)
        return ("mul", tuple(factors))
    if isinstance(e, ast.BinOp) and isinstance(e.op, ast.Div):
        return ("div", (_tree(e.left, src), _tree(e.right, src)))
    if isinstance(e, ast.UnaryOp) and isinstance(e.op, ast.USub):
        return ("neg", (_tree(e.operand, src),))
    if isinstance(e, ast.Call) and isinstance(e.func, ast.Name):
        return ("call:" + e.func.id, tuple(_tree(a, src) for a in e.args))
    if isinstance(e, ast.Constant):
        return ("num", ast.get_source_segment(src, e))
    if isinstance(e, (ast.Name, ast.Subscript)):
        text = ast.get_source_segment(src, e)
        if _REF.fullmatch(text):
            return ("ref", text)
    raise ValueError(f"not a plain expression: {ast.dump(e)}")


def _key(node, own=None, prev=None):
    """The sort key and signature of a tree: its leaves as ('ref',), or with ``own`` (the
    period's temporaries: position) as ('loc', j) / ('in',)."""
    kind, args = node
    if kind == "ref":
        if own is not None and args in own:
            return ("loc", own[args])
        if prev is not None and args in prev:
            return ("prev", prev[args])
        return ("in",)
    if kind == "num":
        return node
    if kind == "sum":
        return ("sum", tuple(sorted((-sg, _key(t, own, prev)) for sg, t in args)))
    if kind == "mul":
        return ("mul", tuple(sorted(_key(f, own, prev) for f in args)))
    return (kind, tuple(_key(a, own, prev) for a in args))


def _canon(node, own=None, prev=None):
    """The tree with sums' terms and products' factors in _key order (ties: as printed)."""
    kind, args = node
    if kind in ("ref", "num"):
        return node
    if kind == "sum":
        return ("sum", tuple(sorted(((sg, _canon(t, own, prev)) for sg, t in args),
                                    key=lambda st: (-st[0], _key(st[1], own, prev)))))
    if kind == "mul":
        return ("mul", tuple(sorted((_canon(f, own, prev) for f in args), key=lambda f: _key(f, own, prev))))
    return (kind, tuple(_canon(a, own, prev) for a in args))


def _leaves(node):
    kind, args = node
    if kind == "ref":
        return [args]
    if kind == "num":
        return []
    if kind == "sum":
        return [leaf for _, t in args for leaf in _leaves(t)]
    return [leaf for a in args for leaf in _leaves(a)]


def _print(node, leaf):
    """C text of a canonical tree, every composite operand in parentheses; ``leaf``: the
    text of the k-th leaf (called in order)."""
    kind, args = node
    if kind == "ref":
        return leaf()
    if kind == "num":
        return args
    if kind == "sum":
        out = ""
        for k, (sg, t) in enumerate(args):
            text = _print(t, leaf)
            text = text if t[0] in ("ref", "num") else f"({text})"
            out += (("-" if sg < 0 else "") + text) if k == 0 else (" + " if sg > 0 else " - ") + text
        return out
    if kind == "mul":
        return "*".join(f"({_print(f, leaf)})" if f[0] not in ("ref", "num") else _print(f, leaf)
                        for f in args)
    if kind == "div":
        a, b = (f"({_print(f, leaf)})" if f[0] not in ("ref", "num") else _print(f, leaf) for f in args)
        return f"{a}/{b}"
    if kind == "neg":
        return f"-({_print(args[0], leaf)})"
    return f"{kind[5:]}({', '.join(_print(a, leaf) for a in args)})"


def _parse(line):
    """(temp, expression text, tree, signature) of a ``const double tN = E;`` line, or None."""
    m = _TEMP_LINE.match(line)
    if not m:
        return None
    name, expr = m.groups()
    try:
        tree = _tree(ast.parse(expr, mode="eval").body, expr)
    except (SyntaxError, ValueError):
        return name, expr, None, ("opaque", expr)
    return name, expr, tree, repr(_key(tree))


def _stretches(ids, period):
    """(start, statements) of every stretch where ids[i] == ids[i + period], at least 2 periods long."""
    if len(ids) < 2 * period:
        return []
    eq = np.concatenate([[False], ids[:-period] == ids[period:], [False]])
    d = np.diff(eq.astype(np.int8))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(s), int(e - s + period)) for s, e in zip(starts, ends) if e - s >= period]


def _template(stmts, start, period, count):
    """(start, count, per slot its kind) of the longest sequence of consecutive periods, among
    the ``count`` from ``start``, that agree on their reads: a slot (j, r) is ('loc', j') when
    it reads the period's own statement j', else ('in',).  (The first link of a chain reads
    its values from the code before the stretch, not from a period: it drops out.)"""
    def kinds(k):
        base = start + k * period
        own = {stmts[base + j][0]: j for j in range(period)}
        prev = {stmts[base - period + j][0]: j for j in range(period) if base - period + j >= 0}
        out = []
        for j in range(period):
            tree = stmts[base + j][2]
            if tree is None:
                return None
            local = {nm: p for nm, p in own.items() if p < j}
            out.append(_key(tree, local, prev))
        return out

    every = [kinds(k) for k in range(count)]
    best, k = (0, 1), 0
    while k < count:
        e = k + 1
        while e < count and every[k] is not None and every[e] == every[k]:
            e += 1
        if every[k] is not None and e - k > best[1]:
            best = (k, e - k)
        k = e
    return start + best[0] * period, best[1], every[best[0]]


def _best(stmts, ids):
    """The (start, period, count) of the stretch that replaces most statements."""
    best = None
    n = len(stmts)
    for period in range(MIN_PERIOD, min(MAX_PERIOD, n // 2) + 1):
        for s, length in _stretches(ids, period):
            count = length // period
            if best is None or (count - 1) * period > (best[2] - 1) * best[1]:
                best = (s, period, count)
    return best


def _region_code(stmts, start, period, count, readers, base, rname):
    """(helper text, caller lines, {temp: its R_ reference}, inputs, outputs) for one region."""
    leaves = []                       # per period, per statement: [(token, local position or None)]
    canon0 = []
    for k in range(count):
        first = start + k * period
        own = {stmts[first + j][0]: j for j in range(period)}
        prev = {stmts[first - period + j][0]: j for j in range(period) if first - period + j >= 0}
        per = []
        for j in range(period):
            local = {nm: p for nm, p in own.items() if p < j}
            tree = _canon(stmts[first + j][2], local, prev)
            if k == 0:
                canon0.append(tree)
            per.append([(tok, local.get(tok), prev.get(tok)) for tok in _leaves(tree)])
        leaves.append(per)
    outs = []
    for j in range(period):
        for k in range(count):
            lo, nm = start + k * period, stmts[start + k * period + j][0]
            if any(u < lo or u >= lo + period for u in readers.get(nm, ())):
                outs.append(j)
                break
    # a read of the previous period's statement j' (an output q) reads p_[q]: the previous
    # period's outputs, or for the first period a seed array of the values before the region
    carried, seed = {}, {}
    inputs, slot_of = [], {}          # input slots merged when they read the same value in every period
    for j in range(period):
        for r, (tok, pos, pj) in enumerate(leaves[0][j]):
            if pos is not None:
                continue
            if pj is not None and pj in outs:
                carried[(j, r)] = outs.index(pj)
                seed[outs.index(pj)] = tok
                continue
            key = tuple(leaves[k][j][r][0] for k in range(count))
            if key not in inputs:
                inputs.append(key)
            slot_of[(j, r)] = inputs.index(key)
    body = []
    for j in range(period):
        it = iter(range(len(leaves[0][j])))

        def leaf():
            r = next(it)
            pos = leaves[0][j][r][1]
            if pos is not None:
                return f"l{pos}"
            return f"p_[{carried[(j, r)]}]" if (j, r) in carried else f"i_[{slot_of[(j, r)]}]"
        body.append(f"    const double l{j} = {_print(canon0[j], leaf)};")
    body += [f"    o_[{q}] = l{j};" for q, j in enumerate(outs)]
    helper = (f"static EOMC_REP void {base}(const double *restrict i_, const double *restrict p_, "
              f"double *restrict o_)\n{{\n" + "\n".join(body) + "\n}\n")
    ni, no = len(inputs), len(outs)
    caller = [f"    double {rname}[{count * no}];",
              f"    const double {rname}seed[{no}] = {{{', '.join(seed.get(q, '0.0') for q in range(no))}}};"]
    rename = {}
    for k in range(count):
        prev = f"{rname}seed" if k == 0 else f"{rname} + {(k - 1) * no}"
        caller.append(f"    {{ const double i_[{max(ni, 1)}] = {{{', '.join(inputs[s][k] for s in range(ni)) or '0.0'}}}; "
                      f"{base}(i_, {prev}, {rname} + {k * no}); }}")
        for q, j in enumerate(outs):
            rename[stmts[start + k * period + j][0]] = f"{rname}[{k * no + q}]"
    return helper, caller, rename, ni, no


def reroll(lines, base):
    """(new lines, helper texts) of one function body: the repeated stretches of its longest
    runs of temporaries replaced by calls of one routine per stretch."""
    lines = list(lines)
    helpers = []
    for region in range(MAX_REGIONS):
        parsed = [_parse(line) for line in lines]
        readers = {}
        for i, line in enumerate(lines):
            for ref in set(re.findall(r"\bt\d+\b", line.split(" = ", 1)[1] if parsed[i] else line)):
                readers.setdefault(ref, []).append(i)
        # runs of temporaries
        runs, s = [], None
        for i, p in enumerate(parsed + [None]):
            if p and s is None:
                s = i
            elif not p and s is not None:
                runs.append((s, i))
                s = None
        found = None
        for rs, re_ in runs:
            stmts = parsed[rs:re_]
            sigs = {}
            ids = np.array([sigs.setdefault(p[3], len(sigs)) for p in stmts], dtype=np.int64)
            cand = _best(stmts, ids)
            if cand is None:
                continue
            start, period, count = cand
            start, count, kinds = _template(stmts, start, period, count)
            if count < 2:
                continue
            gain = (count - 1) * period
            if found is None or gain > found[0]:
                found = (gain, rs, stmts, start, period, count, kinds)
        if found is None:
            break
        _, rs, stmts, start, period, count, kinds = found
        # readers by position within the run (lines outside the run: far away)
        run_readers = {nm: [i - rs for i in ix] for nm, ix in readers.items()}
        helper, caller, rename, ni, no = _region_code(stmts, start, period, count, run_readers,
                                                      f"{base}{region}", f"R{region}_")
        if ni + 2 >= period:      # a call would be as long as the statements it replaces
            break
        a, b = rs + start, rs + start + period * count
        tail = [re.sub(r"\bt\d+\b", lambda m: rename.get(m.group(0), m.group(0)), line) for line in lines[b:]]
        caller = [re.sub(r"\bt\d+\b", lambda m: rename.get(m.group(0), m.group(0)), line) for line in caller]
        lines = lines[:a] + caller + tail
        helpers.append(helper)
    return lines, helpers


REP_MACRO = """#if defined(__GNUC__)
#define EOMC_REP __attribute__((noinline))
#else
#define EOMC_REP
#endif
"""


def _patched_build(argv):
    from eomc.compiler.emit import generate
    split_body = generate.split_body

    def split_rerolled(body, base, scratch="S_", restrict=False):
        if not base.endswith("_rhs_part"):
            return split_body(body, base, scratch, restrict)
        body, helpers = reroll(body, base[:-len("part")] + "rep")
        lines, parts = split_body(body, base, scratch, restrict)
        return lines, ([REP_MACRO] if helpers else []) + helpers + parts
    generate.split_body = split_rerolled
    from eomc.cli import main
    sys.argv = ["eomc", "build", *argv]
    return main()


if __name__ == "__main__":
    sys.exit(_patched_build(sys.argv[1:]))
