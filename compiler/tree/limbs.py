"""The rhs of a tree with twin limbs: one pair of C routines per limb shape, called per limb.

Why: written straight-line, ABA's code grows with the tree, and a humanoid's rhs (G1: 124 kB
of machine code) streams through the 32 kB first-level instruction cache on every call
(~2,080 L1i misses a call under cachegrind, IPC 2.9 against an arm's 3.4: session 18's
report-freebase.md).  But a humanoid's legs and arms come in pairs: the right leg is the
left one with other coordinate, speed, input and parameter slots (mirror images differ in
the parameters' values, not in the code's shape).  Here each such shape's code is generated
once, as two static functions run per limb with pointers to its own slots:

- ``NAME_limbK_in(xq, xu, pp, rr, vP, T, f, D, L)``: ABA's first two passes over the limb
  (velocities from its parent's velocity vP, articulated inertias and bias forces inward),
  handing Xᵀ Iᵃ X (T, the lower triangle) and Xᵀ pᵃ (f) to the parent, the pivots D, and in
  L what the third pass reads;
- ``NAME_limbK_out(xq, xu, pp, rr, L, aP, ud)``: the third pass, from the parent's
  acceleration aP to the limb's u'.

The rest of the tree (the core: the floating base, the waist) stays straight-line: its
recursions run with each limb's T and f as symbols added to the parent's Iᴬ, pᴬ
(:func:`.aba.aba`'s ``part``), and hand out the parents' velocities and accelerations.  The
pivots' singularity threshold sums the limbs' pivots with the core's.  Every pass is the
recursions' own code (:func:`.velocities.velocities`, :func:`.aba.aba`) run on symbols
through the optimizer's shared passes, so the values are the straight-line rhs's up to
rounding (the order of some sums differs).

A limb: the chain of one-speed joints from a body whose parent's subtree is not a chain down
to its leaf; twins: limbs whose bodies (rotation, position, axis, mass, inertia, armature,
load) are equal once each limb's coordinate, speed, parameter and input slots are counted from
its first ones (a parameter other limbs read too, a parent's, is read where it is) and the
numbers of their fixed rotations are set apart (those that differ, mirror images' signs, are
read from a table per limb).  A shape's routines run all its limbs at once, line by line in
turns (:func:`_interleaved`): each of their sub-functions is called once per limb in a row.
Chosen (:func:`limb_plan`) for an open tree without contacts, guards or extra states when
shapes of at least LIMB_MIN_SHAPE bodies hold at least LIMB_MIN_BODIES bodies in all; every
other tree keeps the straight-line rhs, byte for byte.  The rhs's sub-functions then take
near pointers whatever their length (split.WINDOW_MIN is for a whole rhs that fits the L1i).
A build with rhs_batch keeps the routines: its lanes run them too (``NAME_vlimb*``,
compiler/emit/batch.py; G1, 4 lanes: 3.1-3.6x this rhs against the straight-line lanes' 2.67-3.26x,
benchmarks/results/rhs_batch.md).
"""
from collections import Counter
from dataclasses import dataclass
from types import SimpleNamespace

import sympy as sm

from ..emit.bodies import IND, needed_assignments, store, temps
from ..emit.printer import CPrinter
from ..emit.split import split_body
from ..ir import Program, c_names, count_program, symbols_of
from ..passes import finish_function, optimize_shared
from .aba import aba
from .chain_loop import _inline
from .lowered import LoweredBody
from .recorder import Recorder
from .velocities import velocities

__all__ = ["LimbPlan", "limb_plan", "limbs_rhs_body", "limbs_ops", "LIMB_MIN_BODIES", "LIMB_GROUPS", "core_results",
           "limb_inputs"]

# Bodies in twin limbs from which the rhs calls limb routines; None: never.  Why 20 and shapes
# of at least LIMB_MIN_SHAPE bodies (measured, session 19, report-g1rhs.md; core 1, 4-9 file
# copies a variant): G1 (29 joints, its legs and arms: 26 bodies in 4 limbs of 2 shapes; rhs
# 118 -> 80 kB of machine code) 1976-1983 against 2158-2829 ns (quaternion), 1990-2025 against
# 2163-2199 ns (Euler angles) in most copies (a third of the Euler copies ran 2164-2280);
# Talos full body, whose mirrored legs and arms do not match (only 1- and 2-body gripper
# shapes did: no code saved), 6-16 % slower.  Go2's and Solo12's legs are 3 bodies.
LIMB_MIN_BODIES_DEFAULT = 20
LIMB_MIN_BODIES = LIMB_MIN_BODIES_DEFAULT
LIMB_MIN_SHAPE = 4

# the rhs's result groups with a plan: the core's u' and margins, the threshold, the limbs'
# parents' velocities and accelerations
LIMB_GROUPS = ("kin", "lud", "lDpiv", "lthr", "lvp", "lap")

_LOWER = [(i, j) for i in range(6) for j in range(i + 1)]
_KINDS = ("q", "u", "p", "r")


@dataclass(frozen=True)
class Shape:
    """One limb shape's two routines (optimized programs) and its sizes."""
    nbodies: int
    prog_in: object
    prog_out: object
    nstored: int
    speeds: tuple          # per u' result: its speed, counted from the limb's first
    absolute: tuple        # (parameter, C name) of those read at their own slot (shared with other limbs)


@dataclass(frozen=True)
class Instance:
    shape: int
    parent: int            # the limb's parent body (tree index)
    bodies: tuple          # its bodies (tree indices)
    base: tuple            # (q0, s0, p0, r0): its first coordinate, speed, parameter, input slot
    consts: tuple          # its values of the numbers its shape reads from a table


@dataclass(frozen=True)
class LimbPlan:
    shapes: tuple
    instances: tuple
    symbols: dict          # instance -> (T symbols (21), f symbols (6)); "dsum": the limbs' pivots' sum


def _rel(kind, j):
    return sm.Symbol(f"_l{kind}{j}", real=True)


def _children(bodies):
    ch = [[] for _ in bodies]
    for i, b in enumerate(bodies):
        if b.parent >= 0:
            ch[b.parent].append(i)
    return ch


def _chain(i, ch):
    """Body i's subtree as a list when it is a chain (each body one child at most), else None."""
    out = [i]
    while ch[out[-1]]:
        if len(ch[out[-1]]) > 1:
            return None
        out.append(ch[out[-1]][0])
    return out


def _limbs(bodies):
    ch = _children(bodies)
    found = []
    for i, b in enumerate(bodies):
        if b.parent < 0 or _chain(b.parent, ch) is not None:
            continue
        chain = _chain(i, ch)
        if chain is None or chain != list(range(i, i + len(chain))):
            continue
        if any(bodies[k].S is None or bodies[k].multi for k in chain):
            continue
        found.append(chain)
    return found


def _relative(exprs, layout, nq, nu, s_first, shared=frozenset()):
    """(the expressions in slots counted from the limb's first ones, base) or None (a slot of
    another kind: time, an extra state; a speed before the limb's first)."""
    index = {s: k for k, s in enumerate(layout.x)}
    pidx = {s: k for k, s in enumerate(layout.p)}
    ridx = {s: k for k, s in enumerate(layout.r)}
    free = set().union(*(sm.sympify(e).free_symbols for e in exprs))
    slots = {k: [] for k in _KINDS}
    for s in free:
        if s in index and index[s] < nq:
            slots["q"].append((index[s], s))
        elif s in index and index[s] < nq + nu:
            slots["u"].append((index[s] - nq, s))
        elif s in pidx and pidx[s] in shared:
            continue            # a parameter other limbs read too (a parent's): read as p[k]
        elif s in pidx:
            slots["p"].append((pidx[s], s))
        elif s in ridx:
            slots["r"].append((ridx[s], s))
        else:
            return None
    base = tuple(s_first if kind == "u" else min((k for k, _ in slots[kind]), default=0) for kind in _KINDS)
    if any(k < s_first for k, _ in slots["u"]):
        return None
    sub = {s: _rel(kind, k - b0) for kind, b0 in zip(_KINDS, base) for k, s in slots[kind]}
    return [sm.sympify(e).xreplace(sub) for e in exprs], base


def limb_plan(tree, bodies, defs, layout, functions, min_bodies=None):
    """The :class:`LimbPlan` of the rhs, or None where the tree keeps the straight-line rhs."""
    min_bodies = LIMB_MIN_BODIES if min_bodies is None else min_bodies
    if min_bodies is None:
        return None
    nq, nu = len(tree.coordinates), len(tree.speeds)
    if ("rhs" not in functions or len(layout.x) != nq + nu
            or any(ld.frame == "contact" for ld in tree.loads)):
        return None
    memo = {}
    groups = {}
    found = []
    for chain in _limbs(bodies):
        exprs, marks = [], []
        for k, i in enumerate(chain):
            E, r, S, mass, inertia, arm = bodies[i].source
            fext = [_inline(x, defs, memo) for x in bodies[i].fext] if bodies[i].fext is not None else []
            exprs += [*E, *r, *S, mass, *inertia, *(arm or ()), *fext]
            marks.append((len(fext), len(arm or ()), bodies[i].speed - bodies[chain[0]].speed))
        found.append((chain, exprs, marks))
    pset = set(layout.p)
    pidx = {s: k for k, s in enumerate(layout.p)}
    uses = Counter(pidx[s] for _, exprs, _ in found
                   for s in set().union(*(sm.sympify(e).free_symbols for e in exprs)) & pset)
    shared = frozenset(k for k, n in uses.items() if n > 1)
    for chain, exprs, marks in found:
        s_first = bodies[chain[0]].speed
        rel = _relative(exprs, layout, nq, nu, s_first, shared)
        if rel is None:
            continue
        rexprs, base = rel
        floats = []
        skeleton = tuple(_lift(e, floats) for e in rexprs)
        groups.setdefault((skeleton, tuple(marks)), []).append((chain, base, tuple(floats)))
    twins = [(key, g) for key, g in groups.items() if len(g) > 1 and len(key[1]) >= LIMB_MIN_SHAPE]
    if sum(len(chain) for _, g in twins for chain, _, _ in g) < min_bodies:
        return None
    shapes, instances, symbols = [], [], {}
    for (skeleton, marks), g in twins:
        values = list(zip(*[fl for _, _, fl in g]))          # per lifted number: its value in each limb
        keep = {_const(j): values[j][0] for j in range(len(values)) if len(set(values[j])) == 1}
        varying = [j for j in range(len(values)) if len(set(values[j])) > 1]
        renum = {_const(j): _table(n) for n, j in enumerate(varying)}
        template = [e.xreplace(keep).xreplace(renum) for e in skeleton]
        shapes.append(_shape(bodies, g[0][0], template, marks, layout, shared, len(varying)))
        for chain, base, fl in g:
            m = len(instances)
            instances.append(Instance(len(shapes) - 1, bodies[chain[0]].parent, tuple(chain), base,
                                      tuple(fl[j] for j in varying)))
            symbols[m] = (tuple(sm.Symbol(f"_lT{m}_{j}", real=True) for j in range(21)),
                          tuple(sm.Symbol(f"_lf{m}_{j}", real=True) for j in range(6)))
    symbols["dsum"] = sm.Symbol("_ldsum", real=True)
    return LimbPlan(shapes=tuple(shapes), instances=tuple(instances), symbols=symbols)


def _const(j):
    return sm.Symbol(f"_lc{j}", real=True)


def _table(j):
    return sm.Symbol(f"_lk{j}", real=True)


def _lift(e, out):
    """``e`` with each floating-point number replaced by a symbol _lc<j> (appended to ``out``),
    in the order of a walk over its tree: twin limbs whose fixed rotations are mirror images
    differ only there, and the numbers that differ are read from a table per limb."""
    e = sm.sympify(e)
    if e.is_Float:
        out.append(e)
        return _const(len(out) - 1)
    if not e.args or e.is_Atom:
        return e
    args = e.args
    if e.is_Add or e.is_Mul:      # their order follows the numbers' values: walk by shape instead
        args = sorted(args, key=_masked)
    n = len(out)
    try:
        return e.func(*[_lift(a, out) for a in args])
    except (ValueError, TypeError):     # a node that takes numbers only (see _masked): kept as it is
        del out[n:]
        return e


_FLOAT = sm.Symbol("_lfloat")


def _masked(e):
    """``e``'s shape: its floating-point numbers masked, but for those of a node that refuses
    symbols where it takes numbers (an MJCF actuator's clamp bounds, compiler/mjcf/clamp.py: the
    2-D walker's and cheetah's ctrlrange; masking them raised there), so twins must agree there
    and such a node's numbers are not read from a limb's table (_lift keeps it as it is)."""
    return sm.srepr(_mask(e))


def _mask(e):
    if e.is_Float:
        return _FLOAT
    if not e.args or e.is_Atom:
        return e
    try:
        return e.func(*[_mask(a) for a in e.args])
    except (ValueError, TypeError):     # a node that takes numbers only: compared as it is
        return e


def _shape(bodies, chain, template, marks, layout, shared, nconst):
    """The two routines of the limb ``chain`` (in its own relative slots, ``template``: its
    bodies' E, r, S, mass, inertia, armature and load, numbers that differ between twins as
    table symbols)."""
    rec = Recorder()
    lbodies = []
    o = 0
    for k, (i, (nf, na, sp)) in enumerate(zip(chain, marks)):
        b = bodies[i]
        e = template[o:o + 28 + na + nf]
        o += 28 + na + nf
        head = SimpleNamespace(parent=k - 1, speed=sp, name=b.name, joint=b.joint)
        lb = LoweredBody(head, rec, sm.Matrix(3, 3, e[0:9]), sm.Matrix(3, 1, e[9:12]), e[12:18],
                         e[18], sm.Matrix(3, 3, e[19:28]), None, None, e[28:28 + na] or None)
        lb.fext = e[28 + na:] or None
        lbodies.append(lb)
    # the loads' common subexpressions (a joint's law, in its child's and its parent's load, in
    # every component) named once, as the straight-line rhs's (Recorder.shared): inlined
    # for the twins' comparison, they came apart (SymPy distributes numbers over the sums)
    loaded = [lb for lb in lbodies if lb.fext is not None]
    shared_fext = rec.shared(x for lb in loaded for x in lb.fext)
    for j, lb in enumerate(loaded):
        lb.fext = list(shared_fext[6 * j:6 * j + 6])
    speeds = [_rel("u", j) for j in range(max(b.speed for b in lbodies) + 1)]
    VP = [sm.Symbol(f"_lvP{j}", real=True) for j in range(6)]
    AP = [sm.Symbol(f"_laP{j}", real=True) for j in range(6)]
    v, c = velocities(lbodies, rec, speeds, root_v=VP)
    part = {"root_a": AP, "hand": {}, "D": {}}
    out = aba(lbodies, rec, speeds, None, v, c, part=part)
    T, f = part["hand"]["T"], part["hand"]["f"]
    res_in = [T[i][j] for i, j in _LOWER] + list(f) + [part["D"][k] for k in range(len(lbodies))]
    res_out = [udd for _, udd, _ in out]
    assign = rec.assignments
    need_in = {t for t, _ in needed_assignments(assign, res_in)}
    need_out = needed_assignments(assign, res_out)
    dep = set(AP)
    late = set()
    for t, e in need_out:
        if symbols_of(sm.sympify(e)) & dep:
            dep.add(t)
            late.add(t)
    out_set = {t for t, _ in need_out}
    first = [(t, e) for t, e in assign if t in need_in or (t not in late and t in out_set)]
    second = [(t, e) for t, e in need_out if t in late]
    defined = {t for t, _ in first}
    used = set()
    for e in [e for _, e in second] + res_out:
        used |= symbols_of(sm.sympify(e))
    stored = sorted((s for s in used if s in defined), key=lambda s: int(s.name[2:]))
    top = max(len(layout.x), len(layout.p), len(layout.r))
    base = (tuple(_rel(kind, j) for kind in _KINDS for j in range(top)) + tuple(layout.p[k] for k in sorted(shared))
            + tuple(_table(j) for j in range(nconst)))
    prog_in = Program(inputs=base + tuple(VP), assignments=tuple(first),
                      results=tuple([(("r", k), sm.sympify(e)) for k, e in enumerate(res_in)]
                                    + [(("s", k), s) for k, s in enumerate(stored)]), ntemp=rec.count)
    prog_out = Program(inputs=base + tuple(stored) + tuple(AP), assignments=tuple(second),
                       results=tuple((("r", k), sm.sympify(e)) for k, e in enumerate(res_out)), ntemp=rec.count)
    prog_in = finish_function(optimize_shared(prog_in), ("r", "s"))
    prog_out = finish_function(optimize_shared(prog_out), ("r",))
    return Shape(nbodies=len(lbodies), prog_in=prog_in, prog_out=prog_out, nstored=len(stored),
                 speeds=tuple(k for k, _, _ in out),
                 absolute=tuple((layout.p[k], f"p[{k}]") for k in sorted(shared)))


def limb_inputs(plan):
    """The core program's inputs the limbs' routines compute: T, f per limb, the pivots' sum."""
    if plan is None:
        return ()
    return tuple(s for m in range(len(plan.instances)) for part in plan.symbols[m] for s in part) + (
        plan.symbols["dsum"],)


def core_results(bodies, rec, speeds, gravity, v, c, plan):
    """The core's results (groups LIMB_GROUPS but kin): ABA over the bodies outside the limbs,
    each limb's T and f added to its parent, the limbs' pivots' sum to the threshold."""
    from copy import copy
    from .spatial import _sym6_plus
    from .construct import _add
    inside = {i for inst in plan.instances for i in inst.bodies}
    core = [i for i in range(len(bodies)) if i not in inside]
    at = {i: k for k, i in enumerate(core)}
    cb = []
    for i in core:
        b = copy(bodies[i])
        b.parent = at[b.parent] if b.parent >= 0 else -1
        cb.append(b)
    inject = {}
    for m, inst in enumerate(plan.instances):
        Ts, fs = plan.symbols[m]
        Tm = [[None] * 6 for _ in range(6)]
        for (i, j), s in zip(_LOWER, Ts):
            Tm[i][j] = Tm[j][i] = s
        k = at[inst.parent]
        if k in inject:
            T0, f0 = inject[k]
            inject[k] = (_sym6_plus(T0, Tm), [_add((f0[j], fs[j])) for j in range(6)])
        else:
            inject[k] = (Tm, list(fs))
    part = {"inject": inject, "pivots": plan.symbols["dsum"], "a": {}, "thr": None}
    out = aba(cb, rec, speeds, gravity, [v[i] for i in core], [c[i] for i in core], part=part)
    res = []
    for k, udd, margin in out:
        res += [(("lud", k), udd), (("lDpiv", k), margin)]
    res.append((("lthr", 0), part["thr"]))
    for m, inst in enumerate(plan.instances):
        res += [(("lvp", 6 * m + j), v[inst.parent][j]) for j in range(6)]
        res += [(("lap", 6 * m + j), part["a"][at[inst.parent]][j]) for j in range(6)]
    return res


_ARGS = {"q": "xq", "u": "xu", "p": "pp", "r": "rr", "k": "kk"}


def _names(prog, extra, absolute):
    names = {s: f"{_ARGS[s.name[2]]}[{s.name[3:]}]" for s in prog.inputs
             if s.name[:2] == "_l" and s.name[2] in _ARGS and s.name[3:].isdigit()}
    names.update(dict(absolute))
    names.update(extra)
    names.update(c_names(prog))
    return CPrinter(names)


_IN_ARGS = (("const double *restrict ", "xq"), ("const double *restrict ", "xu"), ("const double *restrict ", "pp"),
            ("const double *restrict ", "rr"), ("const double *restrict ", "kk"))
_IN_OWN = _IN_ARGS + (("const double *restrict ", "vP"), ("double *restrict ", "T"), ("double *restrict ", "f"),
                      ("double *restrict ", "D"), ("double *restrict ", "L"))
_OUT_OWN = _IN_ARGS + (("const double *restrict ", "L"), ("const double *restrict ", "aP"),
                       ("double *restrict ", "ud"))


def _interleaved(fname, body, own, n):
    """One function running ``body`` for n limbs of one shape, its lines in turns (limb 0's
    first line, limb 1's, ..., then the second lines): each sub-function of the split body is
    called n times in a row, so its code is fetched once for all n (why: a shape's routine
    (an arm's: ~33 kB) does not fit the 32 kB instruction cache, so a call per limb fetched it
    anew for each)."""
    import re
    names = [a for _, a in own] + ["S_"]
    pat = re.compile(r"\b(" + "|".join(names) + r"|t[0-9]+)\b")     # t<k>: a body left unsplit
    copies = [[pat.sub(lambda m_: f"{m_.group(1)}_{i}" if m_.group(1)[0] == "t" and m_.group(1)[1:].isdigit()
                       else f"{m_.group(1)}{i}", line) for line in body] for i in range(n)]
    decls = [c[j] for c in copies for j, line in enumerate(body) if line.lstrip().startswith("double ")]
    rest = [c[j] for j, line in enumerate(body) if not line.lstrip().startswith("double ") for c in copies]
    sig = ", ".join(["const double *restrict p"] + [f"{t}{a}{i}" for i in range(n) for t, a in own])
    unused = [f"{IND}(void)p;"] + [f"{IND}(void){a}{i};" for i in range(n) for _, a in _IN_ARGS]
    return f"static void {fname}({sig})\n{{\n" + "\n".join(decls + rest + unused) + "\n}\n"


def _routines(name, plan):
    texts = []
    for m, inst in enumerate(plan.instances):
        if inst.consts:
            pr = CPrinter({})
            texts.append(f"static const double {name}_limb_k{m}[{len(inst.consts)}] = "
                         f"{{{', '.join(pr.doprint(v) for v in inst.consts)}}};\n")
    for k, sh in enumerate(plan.shapes):
        n = sum(1 for inst in plan.instances if inst.shape == k)
        VP = [sm.Symbol(f"_lvP{j}", real=True) for j in range(6)]
        AP = [sm.Symbol(f"_laP{j}", real=True) for j in range(6)]
        pin = _names(sh.prog_in, {s: f"vP[{j}]" for j, s in enumerate(VP)}, sh.absolute)
        vals = dict(sh.prog_in.results)
        body = temps(sh.prog_in, pin)
        body += [store(f"T[{j}]", vals[("r", j)], pin) for j in range(21)]
        body += [store(f"f[{j}]", vals[("r", 21 + j)], pin) for j in range(6)]
        body += [store(f"D[{j}]", vals[("r", 27 + j)], pin) for j in range(sh.nbodies)]
        body += [store(f"L[{j}]", vals[("s", j)], pin) for j in range(sh.nstored)]
        body, parts = split_body(body, f"{name}_limb{k}_in_part", restrict=True, windows=1)
        texts += parts
        texts.append(_interleaved(f"{name}_limb{k}_in", body, _IN_OWN, n))
        stored = [s for s in sh.prog_out.inputs if s.name.startswith("_t")]
        pout = _names(sh.prog_out, {**{s: f"aP[{j}]" for j, s in enumerate(AP)},
                                    **{s: f"L[{j}]" for j, s in enumerate(stored)}}, sh.absolute)
        vals = dict(sh.prog_out.results)
        body = temps(sh.prog_out, pout)
        body += [store(f"ud[{s}]", vals[("r", j)], pout) for j, s in enumerate(sh.speeds)]
        body, parts = split_body(body, f"{name}_limb{k}_out_part", restrict=True, windows=1)
        texts += parts
        texts.append(_interleaved(f"{name}_limb{k}_out", body, _OUT_OWN, n))
    return texts


def _kk(name, m, inst):
    return f"{name}_limb_k{m}" if inst.consts else "(const double *)0"


def limbs_rhs_body(ctx, program, plan):
    """NAME_rhs with the limbs' routines (module doc)."""
    ctx.parts.extend(_routines(ctx.name, plan))
    ctx.windows = 1         # near pointers in every run: the whole rhs is still beyond the L1i (split.WINDOW_MIN)
    pr = ctx.printer(program)
    ninst = len(plan.instances)
    for m in range(ninst):
        Ts, fs = plan.symbols[m]
        pr._names.update({s: f"lT[{21 * m + j}]" for j, s in enumerate(Ts)})
        pr._names.update({s: f"lf[{6 * m + j}]" for j, s in enumerate(fs)})
    pr._names[plan.symbols["dsum"]] = "lS[0]"     # an array: the splitter's parts take arrays (emit/split.py)
    offs, o = [], 0
    for inst in plan.instances:
        offs.append(o)
        o += plan.shapes[inst.shape].nbodies
    nstore = [plan.shapes[inst.shape].nstored for inst in plan.instances]
    lines = [f"{IND}double lvP[{6 * ninst}], laP[{6 * ninst}], lT[{21 * ninst}], lf[{6 * ninst}], lD[{o}], "
             f"lL[{sum(nstore)}], lS[1] = {{0.0}}, thr;", f"{IND}int k;"]
    vp = program.result_exprs("lvp")
    first = needed_assignments(program.assignments, list(vp.values()))
    done = {t for t, _ in first}
    lines += temps(program, pr, first)
    lines += [store(f"lvP[{j}]", vp[("lvp", j)], pr) for j in range(6 * ninst)]
    L0 = 0
    Loff = []
    for m, inst in enumerate(plan.instances):
        Loff.append(L0)
        L0 += nstore[m]

    def slots(inst, m):
        q0, s0, p0, r0 = inst.base
        return f"&x[{q0}], &x[{ctx.nq + s0}], &p[{p0}], &r[{r0}], {_kk(ctx.name, m, inst)}"
    for k in range(len(plan.shapes)):
        args = [f"{slots(inst, m)}, &lvP[{6 * m}], &lT[{21 * m}], &lf[{6 * m}], &lD[{offs[m]}], &lL[{Loff[m]}]"
                for m, inst in enumerate(plan.instances) if inst.shape == k]
        lines.append(f"{IND}{ctx.name}_limb{k}_in(p, {', '.join(args)});")
    lines.append(f"{IND}for (k = 0; k < {o}; k++) lS[0] += lD[k];")
    lines += temps(program, pr, [a for a in program.assignments if a[0] not in done])
    margins = [pr.doprint(e) for k, e in program.results if k[0] == "lDpiv"]
    lines.append(f"{IND}thr = {pr.doprint(program.result_exprs('lthr')[('lthr', 0)])};")
    cond = " || ".join(f"!({d} > 0.0)" for d in margins)
    lines.append(f"{IND}if ({cond}) return EOMC_SINGULAR_MASS_MATRIX;")
    lines.append(f"{IND}for (k = 0; k < {o}; k++) {{")
    lines.append(f"{IND * 2}if (!(lD[k] - thr > 0.0)) return EOMC_SINGULAR_MASS_MATRIX;")
    lines.append(f"{IND}}}")
    ap = program.result_exprs("lap")
    lines += [store(f"laP[{j}]", ap[("lap", j)], pr) for j in range(6 * ninst)]
    vals = dict(program.results)
    for i in range(ctx.nq):
        lines.append(store(f"xdot[{i}]", vals.get(("kin", i), 0.0), pr))
    inside = {inst.base[1] + s for inst in plan.instances for s in plan.shapes[inst.shape].speeds}
    for i in range(ctx.nu):
        if i not in inside:
            lines.append(store(f"xdot[{ctx.nq + i}]", vals.get(("lud", i), 0.0), pr))
    for k in range(len(plan.shapes)):
        args = [f"{slots(inst, m)}, &lL[{Loff[m]}], &laP[{6 * m}], &xdot[{ctx.nq + inst.base[1]}]"
                for m, inst in enumerate(plan.instances) if inst.shape == k]
        lines.append(f"{IND}{ctx.name}_limb{k}_out(p, {', '.join(args)});")
    lines.append(f"{IND}return {ctx.name}_finite(xdot, {ctx.nx});")
    return lines


def limbs_ops(program, plan):
    """Operations of one rhs call: the core's program, each limb's two routines, the pivots."""
    c = count_program(program)
    for inst in plan.instances:
        sh = plan.shapes[inst.shape]
        c += count_program(sh.prog_in) + count_program(sh.prog_out)
        c["adds"] += 2 * sh.nbodies
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
