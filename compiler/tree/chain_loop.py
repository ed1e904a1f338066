"""The rhs of a long chain of identical links as C loops over per-link arrays (ABA by passes).

Why: written straight-line, ABA's code grows with the tree (cart n = 40: 45 kB, n = 160:
186 kB) and from about 32 kB on the first-level instruction cache misses on every line of
every call: the rhs's time per operation grew 20 % from n = 20 to n = 160 and its time as
n^1.10 (benchmarks/results/cart_scaling.md, session 11).  Rolling the repeated link into a
routine called per link copies its inputs and outputs and was 10-17 % slower.  Here the
recursion itself is laid out by body: when a chain's bodies from some link on repeat one
pattern (the same joint, transform, mass and inertia up to their own coordinate and speed,
whose slots step by one from link to link), each of ABA's three passes over them is one C
``for`` loop whose body is generated once from that pattern:

1. outward: v_i = X_i v_parent + S_i u_i, c_i = v_i × S_i u_i, p_i = v_i ×* I_i v_i;
2. inward:  Iᴬ_i = I_i + (the child's Xᵀ Iᵃ X), pᴬ_i likewise; U_i, D_i, 1/D_i, u_i;
   hands Xᵀ Iᵃ X and Xᵀ pᵃ to the parent;
3. outward: a_i = X_i a_parent + c_i, u'_i = (u_i - U_iᵀ a_i)/D_i, a_i += S_i u'_i.

The value a pass hands from link to link (v, Iᴬ and pᴬ's contributions, a) stays in local
scalars (registers), only its structural nonzeros: the union of the patterns the chain can
reach (a planar chain's velocities have three entries, its inertias six).  What a later
pass reads of an earlier one (sin and cos, v, c, p, U, 1/D, u) is stored per link in
arrays sized by the link count.  Bodies before and after the repeated run (a cart, a tool)
are each one straight-line block of the same passes.  Every pass's body is an IR program
(the recursions' own code on symbols: :mod:`.aba`'s one-speed branch, step for step) run
through the optimizer's shared passes (CSE, folding, sin/cos sharing, powers), so the loop
body has the straight-line code's structural zeros and folded constants.

The results equal the straight-line rhs's up to rounding: the same operations per link,
except that the pivots' sum (the singularity threshold) is summed in pass 2's order and the
links' sin and cos come from the lanes' fdlibm kernels (within 1 ulp of libm's).  Chosen
(:func:`chain_loop_plan`) for an open chain of one-speed joints without contacts or extra
states whose repeated run has at least CHAIN_LOOP_MIN_LINKS links (4 by default: measured, see the
constant); every other tree keeps the straight-line rhs, byte for byte.  The links' sin and
cos are taken before the passes, four at a time (:func:`chain_loop_c`).  NAME_rhs_batch beside a
looped rhs rewrites the looped C into lanes (compiler/emit/batch.py): the build keeps this rhs,
and its lanes run the same passes.
"""
import re
from collections import Counter
from dataclasses import dataclass

import sympy as sm

from ..emit.batch import VECTOR_TRIG
from ..emit.bodies import IND, needed_assignments, store, temps
from ..emit.linsolve import PIVOT_TOL
from ..emit.printer import CPrinter
from ..ir import Program, c_names, count_program, symbols_of
from ..passes import finish_function, optimize_shared
from .construct import _add, _mul, _nz
from .lowered import LoweredBody
from .recorder import Recorder
from .spatial import (_dot, _root_acceleration, _sym6_plus, _times, cross_force, cross_motion, x_motion,
                      xt_force, xt_inertia_x)

__all__ = ["ChainLoop", "chain_loop_plan", "chain_loop_rhs_body", "chain_loop_ops", "chain_loop_c",
           "CHAIN_LOOP_MIN_LINKS", "VTRIG_GUARD"]

# The repeated run's length from which the rhs is looped (None: never).  Measured (benchmarks/
# results/cart_scaling.md, session 21, core 1): with the links' sin and cos in lanes the looped rhs
# is faster than the straight-line one on the cart from n = 4 (a run of 4 links: 116 vs 132 ns) to
# 160 (4703 vs 7365 ns), growing as n^1.00 against n^1.12; in one-model harnesses at 3 code
# placements: the cart with a run of 3 is 28 % slower looped (libm per link: no lanes below 4),
# with 4 8 % faster; a chain twisting in 3D (every carried entry nonzero) 15 % slower with 3
# looped links, even with 4, 13 % faster with 5.  Session 13's loops (a libm call per link, no
# ordering) were 4.5-20 % slower at every n.
CHAIN_LOOP_MIN_LINKS_DEFAULT = 4
CHAIN_LOOP_MIN_LINKS = CHAIN_LOOP_MIN_LINKS_DEFAULT

_LOWER = [(i, j) for i in range(6) for j in range(i + 1)]     # a symmetric 6x6's lower triangle
_VEC = {"v": 6, "T": 21, "f": 6, "a": 6}                        # carried values, by name: size
_PASS_OF = {"v": 1, "T": 2, "f": 2, "a": 3}


_SIN, _COS = sm.Symbol("_chain_sin", real=True), sm.Symbol("_chain_cos", real=True)


def _carried(kind, j):
    return sm.Symbol(f"_c{kind}{j}", real=True)


def _carried_name(kind, j):
    return f"c{kind}{j}"


@dataclass(frozen=True)
class Segment:
    """Bodies start..start + count - 1, looped when count > 1 (then ``q0``, ``s0``: the slots
    of the first body's coordinate and speed; body k's are q0 + k, s0 + k)."""
    start: int
    count: int
    q0: int
    s0: int
    Q: object               # the template's coordinate and speed symbols (None for a single body)
    U: object
    programs: tuple         # per pass 1..3: the optimized Program
    loads: tuple            # per pass: [(symbol, pass it was stored by, index in that pass's array)]
    stores: tuple           # per pass: [(result key index, symbol)] stored per body, by width
    carried_out: tuple      # per pass: [(kind, j, result index)] of the nonzero values handed on
    dpos: int               # pass 2's result index of the pivot D
    upos: int               # pass 3's result index of u'


@dataclass(frozen=True)
class ChainLoop:
    """The looped rhs (see the module doc): segments in body order, carried entries by kind."""
    segments: tuple
    carried: dict           # kind: sorted entries used anywhere
    nbodies: int
    trig: tuple = ()        # looped segments whose links' sin and cos come from NAME_chain_sincos


def _slot_index(layout, sym):
    return layout.x.index(sym)


def _template_body(tb, source, rec, subs):
    """A LoweredBody of ``tb`` with its own coordinate and speed replaced by ``subs``."""
    E, r, S, mass, inertia, arm = source
    sub = (lambda e: sm.sympify(e).xreplace(subs)) if subs else sm.sympify
    return LoweredBody(tb, rec, E.applyfunc(sub), r.applyfunc(sub), [sub(s) for s in S], sub(mass),
                       inertia.applyfunc(sub), None, None, [sub(a) for a in arm] if arm else None)


def _inline(expr, defs, memo):
    """``expr`` with the recorder's temporaries replaced by their definitions (a base body's
    load reads rotations the straight-line recorder named)."""
    expr = sm.sympify(expr)
    hit = [s for s in expr.free_symbols if s in defs]
    if not hit:
        return expr
    rep = {}
    for s in hit:
        if s not in memo:
            memo[s] = _inline(defs[s], defs, memo)
        rep[s] = memo[s]
    return expr.xreplace(rep)


def _steps(b, rec, speed, vin, Tin, fin, ain, root):
    """ABA's three passes on one body with symbolic neighbours: {pass: {kind: values}}.

    Step for step :func:`.aba.aba`'s one-speed branch and :func:`.velocities.velocities`
    (the same construction helpers, so the same structural zeros and operand order)."""
    vi = x_motion(b, vin)
    vj = [_mul(s, speed) for s in b.S]
    vi = rec.vec([_add((vi[k], vj[k])) for k in range(6)])
    ci = rec.vec(cross_motion(vi, vj))
    p = cross_force(vi, _times(b.I, vi))
    if b.fext is not None:
        p = [_add((p[k], -b.fext[k])) for k in range(6)]
    Tm = [[None] * 6 for _ in range(6)]
    for (i, j), x in zip(_LOWER, Tin):
        Tm[i][j] = Tm[j][i] = x
    IA = _sym6_plus(b.I, Tm)
    pA = [_add((p[k], fin[k])) for k in range(6)]
    Ii, pi = rec.sym6(IA), rec.vec(pA)
    U = rec.vec(_times(Ii, b.S))
    D = rec.let(_dot(b.S, U) + b.armature[0])
    Dinv = rec.let(1 / D)
    uu = rec.let(-_dot(b.S, pi))
    W = rec.vec([_mul(x, Dinv) for x in U])
    Ia = rec.sym6([[_add((Ii[r][s], -_mul(W[r], U[s]))) if s <= r else None for s in range(6)] for r in range(6)])
    Iac = _times(Ia, ci)
    pa = [_add((pi[k], Iac[k], _mul(W[k], uu))) for k in range(6)]
    out2 = {"D": [D]}
    if not root:
        pa = rec.vec(pa)
        T = xt_inertia_x(b, rec, Ia)
        out2["T"] = [T[i][j] for i, j in _LOWER]
        out2["f"] = xt_force(b, pa)
    ai = rec.vec([_add((x, y)) for x, y in zip(x_motion(b, ain), ci)])
    udd = rec.let((uu - _dot(U, ai)) * Dinv)
    ai = rec.vec([_add((ai[k], _mul(b.S[k], udd))) for k in range(6)])
    return {1: {"v": vi}, 2: out2, 3: {"a": ai, "udd": [udd]}}


def _pattern(values):
    return frozenset(j for j, x in enumerate(values) if _nz(x))


def _instance(b, source, defs, pats, root, subs, speed, gravity):
    """Run the three passes on body ``b``'s template with its carried inputs on ``pats``
    ({kind: entries}); returns (recorder, inputs {kind: values}, outputs)."""
    rec = Recorder()
    tb = _template_body(b, source, rec, subs)
    if b.fext is not None:
        memo = {}
        tb.fext = [_inline(x, defs, memo) for x in b.fext]
    ins = {kind: [_carried(kind, j) if j in pats[kind] else sm.S.Zero for j in range(n)]
           for kind, n in _VEC.items()}
    if root:
        ins["v"] = [0] * 6
        ins["a"] = _root_acceleration(gravity)
    out = _steps(tb, rec, speed, ins["v"], ins["T"], ins["f"], ins["a"], root)
    return rec, ins, out


def chain_loop_plan(tree, bodies, sources, defs, gravity, layout, functions, min_links=None):
    """The :class:`ChainLoop` of the rhs, or None where the tree keeps the straight-line rhs.

    Qualifies: an open chain (body i's parent is body i - 1), every joint of one speed, no
    contact loads, no extra states, and a run of at least ``min_links`` (CHAIN_LOOP_MIN_LINKS) consecutive bodies that
    repeat one pattern (the longest such run is looped; the bodies before and after it are
    one straight-line block each): the same E, r, S, mass, inertia and armature up to the body's own
    coordinate and speed, no load of its own, coordinate and speed slots stepping by one.
    ``sources``: per body (E, r, S, mass, inertia, armature) in slot symbols; ``defs``: the
    straight-line recorder's {temporary: definition} (a base body's load may read them)."""
    min_links = CHAIN_LOOP_MIN_LINKS if min_links is None else min_links
    if min_links is None:
        return None
    nq, nu = len(tree.coordinates), len(tree.speeds)
    n = len(bodies)
    if ("rhs" not in functions or len(layout.x) != nq + nu
            or n < min_links or any(ld.frame == "contact" for ld in tree.loads)):
        return None
    if any(b.parent != i - 1 or b.S is None or b.multi for i, b in enumerate(bodies)):
        return None
    speeds = layout.x[nq:nq + nu]
    own_q = [_own_coordinate(src, layout, nq) for src in sources]
    Q, U = sm.Symbol("_chain_q", real=True), sm.Symbol("_chain_u", real=True)

    def sig(i):
        # the root (body 0) is a block of its own: its passes start from rest and gravity, and
        # hand nothing to a parent (a run from body 0 looped every link as a root: wrong u')
        if i == 0 or own_q[i] is None or bodies[i].fext is not None:
            return None
        E, r, S, mass, inertia, arm = sources[i]
        sub = {layout.x[own_q[i]]: Q, speeds[bodies[i].speed]: U}
        return tuple(sm.sympify(e).xreplace(sub) for e in (*E, *r, *S, mass, *inertia, *(arm or ())))
    sigs = [sig(i) for i in range(n)]
    a, b = _longest_run(sigs, own_q, [body.speed for body in bodies])
    if b - a < min_links:
        return None
    segs = [(i, 1) for i in range(a)] + [(a, b - a)] + [(i, 1) for i in range(b, n)]

    def inst(s, pats):
        i, count = segs[s]
        b = bodies[i]
        subs = {layout.x[own_q[i]]: Q, speeds[b.speed]: U} if count > 1 else None
        return _instance(b, sources[i], defs, pats, i == 0, subs, U if count > 1 else speeds[b.speed], gravity)

    pats = _fixed_point(segs, inst)
    if pats is None:
        return None
    built = [inst(s, pats[s]) for s in range(len(segs))]
    live = _liveness(segs, built)
    segments = []
    for s, (i, count) in enumerate(segs):
        rec, _, out = built[s]
        segments.append(_segment(rec, out, live[s], i, count, layout, bodies[i].speed,
                                 own_q[i] if count > 1 else -1, Q if count > 1 else None,
                                 U if count > 1 else None))
    carried = {kind: tuple(sorted({j for ls in live for k, j in ls if k == kind})) for kind in _VEC}
    # the links' sin and cos in lanes before the passes (chain_loop_c); beside a lanes function
    # too (its own types and kernels are named apart: eomc_vd and NAME_v*, here eomc_cvd and
    # NAME_cl_v*), and NAME_rhs_batch's lanes take the same kernels per link (compiler/emit/batch.py)
    trig = tuple(si for si, seg in enumerate(segments) if seg.count > 1 and _reads_trig(seg))
    return ChainLoop(segments=tuple(segments), carried=carried, nbodies=n, trig=trig)


def _trig_of(seg):
    return {sm.sin(seg.Q): _SIN, sm.cos(seg.Q): _COS}


def _reads_trig(seg):
    """Does one of the segment's pass programs take sin or cos of the link's own coordinate?"""
    want = set(_trig_of(seg))
    return any(want & e.atoms(sm.sin, sm.cos) for prog in seg.programs
               for e in [e for _, e in prog.assignments] + [e for _, e in prog.results])


def _liveness(segs, built):
    """Per segment, the carried values it hands on that someone reads ({(kind, j)}): a value
    is live when the segment it goes to (the next one outward for v and a, inward for T and
    f; a loop's own next body too) reads it to compute its pivot, its u' or a live value of
    its own.  Why: the straight-line code's dead-code elimination drops what never reaches
    u' (a planar chain's inertias about the in-plane axes); a loop's carried values are
    outputs of its body, so they are pruned here instead (190 -> 161 operations per link on the cart)."""
    sym_of = {_carried(kind, j): (kind, j) for kind in _VEC for j in range(_VEC[kind])}

    def reads(rec, exprs):
        exprs = [sm.sympify(e) for e in exprs]
        got = set()
        for e in [e for _, e in needed_assignments(rec.assignments, exprs)] + exprs:
            got |= {sym_of[x] for x in symbols_of(e) if x in sym_of}
        return got

    def outputs(out):
        return {(kind, j): x for vals in out.values() for kind, xs in vals.items() if kind in _VEC
                for j, x in enumerate(xs) if _nz(x)}
    outs = [outputs(b[2]) for b in built]
    live = [set() for _ in segs]
    while True:
        used = [reads(built[s][0], [built[s][2][2]["D"][0], built[s][2][3]["udd"][0]]
                      + [outs[s][key] for key in live[s]]) for s in range(len(segs))]
        new = []
        for s, (_, count) in enumerate(segs):
            fwd = ({key for key in used[s + 1] if key[0] in "va"} if s + 1 < len(segs) else set())
            bwd = ({key for key in used[s - 1] if key[0] in "Tf"} if s > 0 else set())
            mine = used[s] if count > 1 else set()
            new.append((fwd | bwd | mine) & set(outs[s]))
        if new == live:
            return live
        live = new


def _longest_run(sigs, own_q, speed):
    """[a, b): the longest run of bodies with one signature whose coordinate and speed slots
    step by one (the first such run of that length)."""
    best, i, n = (0, 0), 0, len(sigs)
    while i < n:
        j = i + 1
        if sigs[i] is not None:
            while (j < n and sigs[j] == sigs[i] and own_q[j] == own_q[j - 1] + 1
                   and speed[j] == speed[j - 1] + 1):
                j += 1
            if j - i > best[1] - best[0]:
                best = (i, j)
        i = j
    return best


def _own_coordinate(source, layout, nq):
    """The x slot of the one coordinate a body's E and r read (None: none, several, or S,
    mass or inertia reading a state too)."""
    E, r, S, mass, inertia, _ = source
    xs = set(layout.x)
    qs = set().union(*(sm.sympify(e).free_symbols for e in (*E, *r))) & set(layout.x[:nq])
    if len(qs) != 1 or any(sm.sympify(e).free_symbols & xs for e in (*S, mass, *inertia)):
        return None
    return layout.x.index(qs.pop())


def _fixed_point(segs, inst):
    """Per segment, the carried entries that can be nonzero on entry ({kind: entries}): what
    the neighbouring segment hands on, and for a loop what its own body hands on, until no
    pattern grows (the carried values' structural zeros)."""
    pats = [{kind: frozenset() for kind in _VEC} for _ in segs]
    for _ in range(20):
        outs = [inst(s, pats[s])[2] for s in range(len(segs))]
        changed = False
        for s, (_, count) in enumerate(segs):
            new = {kind: set() for kind in _VEC}
            fwd = [s - 1] if s > 0 else []
            bwd = [s + 1] if s + 1 < len(segs) else []
            if count > 1:
                fwd, bwd = fwd + [s], bwd + [s]
            for t in fwd:
                new["v"] |= _pattern(outs[t][1]["v"])
                new["a"] |= _pattern(outs[t][3]["a"])
            for t in bwd:
                if "T" in outs[t][2]:
                    new["T"] |= _pattern(outs[t][2]["T"])
                    new["f"] |= _pattern(outs[t][2]["f"])
            for kind in _VEC:
                if not new[kind] <= pats[s][kind]:
                    pats[s][kind] = pats[s][kind] | frozenset(new[kind])
                    changed = True
        if not changed:
            return pats
    return None


def _segment(rec, out, live, start, count, layout, s0, q0, Q, U):
    """One segment's three pass programs: each pass computes the temporaries it is the first
    to need; what a later pass reads of an earlier one is stored per body (and loaded)."""
    assignments = rec.assignments
    carried_syms = {_carried(kind, j): kind for kind in _VEC for j in range(_VEC[kind])}
    results = {1: [], 2: [], 3: []}
    carried_out = {1: [], 2: [], 3: []}
    for p, vals in out.items():
        for kind, xs in vals.items():
            if kind in _VEC:
                for j, x in enumerate(xs):
                    if (kind, j) in live:
                        carried_out[p].append((kind, j, len(results[p])))
                        results[p].append(x)
    dpos, upos = len(results[2]), len(results[3])
    results[2].append(out[2]["D"][0])
    results[3].append(out[3]["udd"][0])
    owner = {s: _PASS_OF[kind] for s, kind in carried_syms.items()}
    for p in (1, 2, 3):
        for t, _ in needed_assignments(assignments, results[p]):
            owner.setdefault(t, p)
    mine = {p: [(t, e) for t, e in assignments if owner.get(t) == p] for p in (1, 2, 3)}
    stored, reads = {1: [], 2: [], 3: []}, {}
    for p in (1, 2, 3):
        used = set()
        for e in [e for _, e in mine[p]] + results[p]:
            used |= symbols_of(sm.sympify(e))
        reads[p] = sorted((s for s in used if owner.get(s, p) < p), key=lambda s: s.name)
        for s in reads[p]:
            if s not in stored[owner[s]]:
                stored[owner[s]].append(s)
    base = tuple(layout.x) + tuple(layout.p) + tuple(layout.r) + (layout.t,) + tuple(x for x in (Q, U) if x is not None)
    programs, loads = [], []
    for p in (1, 2, 3):
        res = [(("r", k), sm.sympify(e)) for k, e in enumerate(results[p])]
        res += [(("s", k), s) for k, s in enumerate(stored[p])]
        own = tuple(s for s, kind in carried_syms.items() if _PASS_OF[kind] == p)
        prog = Program(inputs=base + tuple(reads[p]) + own, assignments=tuple(mine[p]), results=tuple(res),
                       ntemp=rec.count)
        programs.append(finish_function(optimize_shared(prog), ("r", "s")))
        loads.append(tuple((s, owner[s], stored[owner[s]].index(s)) for s in reads[p]))
    return Segment(start=start, count=count, q0=q0, s0=s0, Q=Q, U=U, programs=tuple(programs),
                   loads=tuple(loads), stores=tuple(tuple(stored[p]) for p in (1, 2, 3)),
                   carried_out=tuple(tuple(carried_out[p]) for p in (1, 2, 3)), dpos=dpos, upos=upos)


def _block(ctx, plan, si, seg, p):
    """The C of pass ``p`` over one segment: a loop over its bodies, or one block."""
    loop = seg.count > 1
    prog = seg.programs[p - 1]
    k = "k" if loop else "0"
    nq = ctx.nq

    def at(array, width, j):
        return f"{array}[{width} * k + {j}]" if loop else f"{array}[{j}]"
    names = dict(ctx.slot_names)
    if loop:
        names[seg.Q] = f"x[{seg.q0} + k]"
        names[seg.U] = f"x[{nq + seg.s0} + k]"
    for kind in _VEC:
        for j in range(_VEC[kind]):
            names[_carried(kind, j)] = _carried_name(kind, j)
    for s, owner, j in seg.loads[p - 1]:
        names[s] = at(f"L{si}_{owner}", len(seg.stores[owner - 1]), j)
    if si in plan.trig:     # the link's sin and cos from the array NAME_chain_sincos filled
        rep = _trig_of(seg)
        prog = prog.with_(assignments=tuple((t, e.xreplace(rep)) for t, e in prog.assignments),
                          results=tuple((key, e.xreplace(rep)) for key, e in prog.results))
        names[_SIN], names[_COS] = f"SC{si}[2 * k]", f"SC{si}[2 * k + 1]"
    vals = dict(prog.results)
    outs = seg.carried_out[p - 1]
    width = len(seg.stores[p - 1])
    roots = [vals[("r", n)] for _, _, n in outs] + [vals[("s", j)] for j in range(width)]
    roots += [vals[("r", seg.dpos)]] if p == 2 else [vals[("r", seg.upos)]] if p == 3 else []
    prog = prog.with_(assignments=_by_first_use(prog.assignments, roots))
    names.update(c_names(prog))
    pr = CPrinter(names)
    body = [IND + line for line in temps(prog, pr)]
    body += [f"{IND * 2}const double o{n} = {pr.doprint(vals[('r', n)])};" for _, _, n in outs]
    body += [IND + store(at(f"L{si}_{p}", width, j), vals[("s", j)], pr) for j in range(width)]
    if p == 2:      # the pivots' sum and least: one test after the pass (chain_loop_rhs_body)
        body.append(f"{IND * 2}const double piv = {pr.doprint(vals[('r', seg.dpos)])};")
        body.append(f"{IND * 2}dsum += piv;")
        body.append(f"{IND * 2}dmin = piv < dmin ? piv : dmin;")
    if p == 3:
        body.append(IND + store(f"xdot[{nq + seg.s0} + {k}]" if loop else f"xdot[{nq + seg.s0}]",
                                vals[("r", seg.upos)], pr))
    written = {(kind, j): n for kind, j, n in outs}
    # every carried entry of the kinds this pass hands on: its value, or 0.0 where this body's
    # is zero or read by no one (a value an earlier segment left there must not pass on)
    kinds = {1: ("v",), 2: ("T", "f") if seg.start > 0 else (), 3: ("a",)}[p]
    for kind in kinds:
        for j in plan.carried[kind]:
            n = written.get((kind, j))
            body.append(f"{IND * 2}{_carried_name(kind, j)} = {f'o{n}' if n is not None else '0.0'};")
    if not loop:
        return [IND + "{"] + body + [IND + "}"]
    head = (f"for (k = {seg.count - 1}; k >= 0; k--) {{" if p == 2 else f"for (k = 0; k < {seg.count}; k++) {{")
    return [IND + head] + body + [IND + "}"]


def _by_first_use(assignments, roots):
    """``assignments`` reordered so that each is computed just before its first reader, depth
    first from ``roots`` in the order the C reads them (a post-order of the expression DAG).
    Why: gcc -O2 on x86 does not schedule before register allocation, so the source order is
    the order of the live ranges: the optimizer's order (every value as early as its operands
    allow) kept a loop body's early products live across the pivot's division, and pass 2
    spilled about 40 values to the stack per link."""
    defs = dict(assignments)
    seen, order = set(), []
    for root in roots:
        stack = [(sm.sympify(root), False)]
        while stack:
            e, expanded = stack.pop()
            if expanded:
                order.append((e, defs[e]))
                continue
            if e in defs:
                if e in seen:
                    continue
                seen.add(e)
                stack.append((e, True))
                body = defs[e]
            else:
                body = e
            deps = sorted((s for s in symbols_of(body) if s in defs and s not in seen), key=_first_read(body))
            stack += [(d, False) for d in reversed(deps)]
    rest = [(t, e) for t, e in assignments if t not in seen]
    return tuple(order) + tuple(rest)


def _first_read(expr):
    """Sort key: the position of a symbol in ``expr``'s printed form (operands in reading order)."""
    text = str(expr)
    return lambda s: (text.find(s.name), s.name)


def chain_loop_rhs_body(ctx, program, plan):
    """NAME_rhs as the looped passes (module doc); q' from the program's kinematics."""
    lines = []
    for kind in _VEC:
        if plan.carried[kind]:
            names = ", ".join(f"{_carried_name(kind, j)} = 0.0" for j in plan.carried[kind])
            lines.append(f"{IND}double {names};")
    for si, seg in enumerate(plan.segments):
        for p in (1, 2):
            if seg.stores[p - 1]:
                lines.append(f"{IND}double L{si}_{p}[{len(seg.stores[p - 1]) * seg.count}];")
    lines += [f"{IND}double SC{si}[{2 * plan.segments[si].count}];" for si in plan.trig]
    # dmin from DBL_MAX, not a nonfinite literal (none in generated C): an inf pivot makes the
    # sum inf and the test fail, as a NaN one makes it NaN
    lines += [f"{IND}double dsum = 0.0, dmin = DBL_MAX;", f"{IND}int k;"]
    for si in plan.trig:
        seg = plan.segments[si]
        lines.append(f"{IND}{ctx.name}_chain_sincos(x + {seg.q0}, {seg.count}, SC{si});")
    for si, seg in enumerate(plan.segments):
        lines += _block(ctx, plan, si, seg, 1)
    for si in reversed(range(len(plan.segments))):
        lines += _block(ctx, plan, si, plan.segments[si], 2)
    tol = CPrinter({}).doprint(PIVOT_TOL)
    # every pivot above the threshold iff the least is (a - t is monotone in a); a NaN pivot
    # makes the sum and so the threshold NaN: the test fails as the straight-line one's does
    lines.append(f"{IND}if (!(dmin - {tol} * dsum > 0.0)) return EOMC_SINGULAR_MASS_MATRIX;")
    for si, seg in enumerate(plan.segments):
        lines += _block(ctx, plan, si, seg, 3)
    pr = ctx.printer(program)
    kin = program.result_exprs("kin")
    lines += temps(program, pr, needed_assignments(program.assignments, kin.values()))
    lines += [store(f"xdot[{i}]", kin.get(("kin", i), 0.0), pr) for i in range(ctx.nq)]
    lines.append(f"{IND}return {ctx.name}_finite(xdot, {ctx.nx});")
    return lines


def chain_loop_ops(program, plan):
    """Operations of one looped rhs call: each pass program times its bodies, the pivots'
    sum and margins, and the kinematics."""
    c = Counter()
    for seg in plan.segments:
        for prog in seg.programs:
            for kind, m in count_program(prog).items():
                c[kind] += m * seg.count
    c["adds"] += 2 * plan.nbodies
    c["muls"] += 1
    kin = program.result_exprs("kin")
    c += count_program(program.with_(assignments=tuple(needed_assignments(program.assignments, kin.values())),
                                     results=tuple(kin.items())))
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}


VTRIG_GUARD = "EOMC_CHAIN_VTRIG"


def _lane_kernels(prefix):
    """batch.VECTOR_TRIG's reduction, kernels and sincos at four lanes under this file's own
    type names, without its libm switch (a preprocessor conditional inside the block would end
    the f32 target's cut of it: compiler/emit/target.without_cpu_dispatch)."""
    text = VECTOR_TRIG.format(p=prefix)
    start = text.index(f"static EOMC_VTARGET EOMC_VINLINE eomc_vd {prefix}_vtrig(")
    end = text.index(f"/* sin and cos of one angle from one reduction")
    text = text[:start] + text[end:]
    text = re.sub(r"#ifdef EOMC_BATCH_LIBM_TRIG\n.*?#else\n", "", text, flags=re.S).replace("#endif\n", "")
    assert "#" not in text.replace("#include", ""), "a preprocessor line left in the lanes kernels"
    return (text.replace("EOMC_VTARGET ", "").replace("EOMC_VINLINE", "inline __attribute__((always_inline))")
            .replace("EOMC_BATCH_LANES", "4").replace("eomc_vd", "eomc_cvd").replace("eomc_vu", "eomc_cvu"))


def chain_loop_c(name, plan):
    """C helpers of the looped rhs: ``NAME_chain_sincos(q, n, sc)``, sc[2k], sc[2k + 1] = sin and
    cos of q[k], k < n, where a looped segment takes them (else "").

    Why: the glibc call per link (sincos, ~110 instructions, the carried values saved around
    it) was a third of the looped rhs's instructions on the cart.  A chain's coordinates are
    adjacent in x, so the loop can take all its links' sin and cos four at a time, before the
    passes: batch.VECTOR_TRIG's fdlibm reduction and kernels in GNU C vectors (within 1 ulp of
    glibc's sin and cos; |q| >= 2^19 pi/2, inf and NaN lanes call libm), the last group
    overlapping the one before it so every link takes the lanes' bits.  Compiled where gcc or
    clang builds for AVX2 (``__AVX2__``: eomc's default flags on such a machine); elsewhere, and
    in the c99-f32 target, the helper is libm's sin and cos per link."""
    if not plan.trig:
        return ""
    p = f"{name}_cl"
    return "\n".join([
        f"#ifndef {VTRIG_GUARD}   /* the chain's sin and cos in four lanes (compiler/tree/chain_loop.py) */",
        "#if defined(__GNUC__) && defined(__AVX2__) && !defined(EOMC_NO_SIMD)",
        f"#define {VTRIG_GUARD} 1",
        "#else",
        f"#define {VTRIG_GUARD} 0",
        "#endif",
        "#endif",
        f"#if {VTRIG_GUARD}",
        "typedef double eomc_cvd __attribute__((vector_size(32)));",
        "typedef unsigned long long eomc_cvu __attribute__((vector_size(32)));",
        _lane_kernels(p),
        "",
        f"static int {name}_chain_vsincos(const double *restrict q, int n, double *restrict sc)",
        "{",
        "    int k, l;",
        "    if (n < 4) return 0;",
        "    for (k = 0;; k += 4) {",
        "        eomc_cvd a, s, c;",
        "        if (k > n - 4) k = n - 4;      /* the last group overlaps the one before it */",
        "        for (l = 0; l < 4; l++) a[l] = q[k + l];",
        f"        {p}_vsincos(a, &s, &c);",
        "        for (l = 0; l < 4; l++) {",
        "            sc[2 * (k + l)] = s[l];",
        "            sc[2 * (k + l) + 1] = c[l];",
        "        }",
        "        if (k == n - 4) return n;",
        "    }",
        "}",
        "#endif",
        "",
        f"static void {name}_chain_sincos(const double *restrict q, int n, double *restrict sc)",
        "{",
        "    int k = 0;",
        f"#if {VTRIG_GUARD}",
        f"    k = {name}_chain_vsincos(q, n, sc);",
        "#endif",
        "    for (; k < n; k++) {",
        "        const double s = sin(q[k]), c = cos(q[k]);",
        "        sc[2 * k] = s;",
        "        sc[2 * k + 1] = c;",
        "    }",
        "}",
    ])
