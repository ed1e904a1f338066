"""C bodies of the recursive formulation's own functions (rhs, jac_x, jac_r, mass_matrix,
forcing, inverse_dynamics).

The rest (linearize, outputs, constraints) is emitted by the Kane path's code
from the same program (see :mod:`.lower`).
"""
import re
from collections import Counter

import sympy as sm

from ..emit.guards import guarded_temps
from ..emit.printer import CPrinter
from ..emit.bodies import IND, singular_guard, store, temps, extra_state_rows, needed_assignments, split_on
from ..ir import Names
from ..passes.timing import compiler_step
from ..ir.opcount import count_ops
from .zero_guards import with_threshold_guards

__all__ = ["tree_rhs_body", "tree_matrix_body", "tree_jacobian_body", "tree_jacobian_ops", "stores_zeroing_runs",
           "implicit_constants"]

ZERO_RUN = 8      # consecutive entries of one array set to zero: from this many on, one loop

_INDEXED = re.compile(r"^([A-Za-z_]\w*)\[(\d+)\]$")


def stores_zeroing_runs(pairs, pr, var):
    """The C lines of the stores ``pairs`` [(lvalue, expr)], where a run of at least ZERO_RUN
    consecutive entries of one array set to zero is one ``for`` loop on ``var``.

    Why: Jacobians are mostly structural zeros (jac_r's coordinate rows and residual columns,
    jac_x's coordinate rows, a branching tree's mass matrix); one line per zero was O(n²)
    lines: a 200-link chain's jac_r had 80,000 of them, each printed by SymPy, split into
    sub-functions and compiled.  Returns (lines, whether ``var`` is used)."""
    lines, used, i = [], False, 0
    keys = [_INDEXED.match(lv) for lv, _ in pairs]
    while i < len(pairs):
        lv, e = pairs[i]
        if keys[i] and e == 0:
            name, start = keys[i].group(1), int(keys[i].group(2))
            j = i + 1
            while (j < len(pairs) and pairs[j][1] == 0 and keys[j] and keys[j].group(1) == name
                   and int(keys[j].group(2)) == start + j - i):
                j += 1
            if j - i >= ZERO_RUN:
                lines.append(f"{IND}for ({var} = {start}; {var} < {start + j - i}; {var}++) {name}[{var}] = 0.0;")
                used, i = True, j
                continue
        lines.append(store(lv, e, pr))
        i += 1
    return lines, used


def tree_rhs_body(ctx, program, guards=()):
    """q' and u' straight from the ABA trace; an articulated inertia D not above 64·DBL_EPSILON
    times the sum of all of them (a body with nothing to resist turning about its axis, or a
    ball joint in gimbal lock) is EOMC_SINGULAR_MASS_MATRIX.  The "Dpiv" results are those
    margins (D - tol·sum, see aba.PIVOT_TOL), so the test is "every margin > 0".
    ``guards``: the contacts' broad phase (compiler/emit/guards.py), bodies far above the
    ground skipped) and the joint limits' sides, skipped inside the range (.zero_guards)."""
    program, guards = with_threshold_guards(program, guards or ())
    pr = ctx.printer(program)
    if guards:
        lines, pr = guarded_temps(program, pr, guards)
    else:
        lines = temps(program, pr)
    lines += singular_guard(program, pr)
    vals = dict(program.results)
    for i in range(ctx.nq):
        lines.append(store(f"xdot[{i}]", vals.get(("kin", i), 0.0), pr))
    for i in range(ctx.nu):
        lines.append(store(f"xdot[{ctx.nq + i}]", vals.get(("ud", i), 0.0), pr))
    lines += extra_state_rows(ctx, program, pr, "zd", "xdot")
    lines.append(f"{IND}return {ctx.name}_finite(xdot, {ctx.nx});")
    return lines


def tree_implicit_body(ctx, program, guards, size):
    """NAME_implicit's out[] (compiler/tree/lower.implicit_layout), with the contacts' broad
    phase (``guards``: each body's forces and its points' K, C slopes skipped far from the
    ground; compiler/tree/contacts.body_guards) and the finiteness check NAME_finite_wide
    (templates/model.c.j2: its 2000 outputs on the humanoid took 0.55 us with a branch per
    entry, 0.24 in four chains; 16 chains since session 15) and the pairs' slope block written
    into out[] by their loop (contact/table.slopes_into: no stores here for those entries)."""
    from ..contact.table import slopes_into
    from ..contact.ground_table import ground_into
    program, written = slopes_into(program, "imp")     # the pairs' loop writes its slopes into out[]
    program, ground = ground_into(program, "imp")       # and the ground points' loop its records
    program, guards = with_threshold_guards(program, guards or ())       # the limits' sides skipped inside
    pr = ctx.printer(program)
    if guards:
        lines, pr = guarded_temps(program, pr, guards)
    else:
        lines = temps(program, pr)
    vals = program.result_exprs("imp")
    stores = [(f"out[{i}]", vals.get(("imp", i), 0.0)) for i in range(size)
              if ("imp", i) not in written and ("imp", i) not in ground]
    body = [store(lv, e, pr) for lv, e in stores]
    ctx.constant_stores = implicit_constants(stores, body)
    lines += body
    lines.append(finite_return(ctx.name, program, pr, lines, written, size))
    return lines


def finite_return(name, program, pr, lines, written, size):
    """NAME_implicit's last line: NAME_finite_wide over out[0 .. size), or, when the pairs' loop
    wrote its slope block into out[off .. end) (``written``; contact/table.slopes_into) and its
    token is in reach of the return, NAME_finite_wide over out[0 .. off) and out[end .. size) when
    the token -- the sum of what the loop wrote into the block, its other entries the loop's zeros
    (or records a depth of 0 keeps: table.KEPT_BLOCK, read by no one) -- is finite, else over all of
    out[] (the same verdict: every entry finite).  Why: on gymnasium's humanoid
    the block is 2725 of the 4738 outputs, all but a few dozen of them zeros at every call, and the
    check read them all (session 25's perf: ~0.3 us of its ~7 us call in NAME_finite_wide)."""
    from ..contact.table import PairTableSlopesInto
    whole = f"{IND}return {name}_finite_wide(out, {size});"
    calls = [s for s, e in program.assignments if isinstance(e, PairTableSlopesInto)]
    if not written or len(calls) != 1 or not FINITE_BY_SUM:
        return whole
    off = min(i for _, i in written)
    end = max(i for _, i in written) + 1
    token = pr._names[calls[0]]
    if {i for _, i in written} != set(range(off, end)) or end > size or not any(
            line.startswith(f"{IND}const double {token} = eomc_pairs_slopes(") for line in lines):
        return whole
    if end == size:
        return (f"{IND}return {token} - {token} == 0.0 ? {name}_finite_wide(out, {off}) "
                f": {name}_finite_wide(out, {size});")
    # outputs after the block (NAME_implicit's energy, implicit_layout): checked apart, the block
    # skipped all the same (session 46: the humanoid's energy slot made the check whole again)
    return (f"{IND}return {token} - {token} == 0.0 ? ({name}_finite_wide(out, {off}) == EOMC_OK "
            f"? {name}_finite_wide(out + {end}, {size - end}) : EOMC_NONFINITE) "
            f": {name}_finite_wide(out, {size});")


# finite_return's short check (False: the whole out[] as before; for measuring)
FINITE_BY_SUM = True


def implicit_constants(stores, lines):
    """NAME_implicit's outputs that are numbers (M's and the slopes' structural zeros, N's
    ones: 450 of the ant's 1157), as (the body's lines that store them, the C lines of
    NAME_implicit_const that store them instead), or None when there are none.

    Why: the fixed step calls NAME_implicit once or more a step into the same two buffers,
    so it writes these once per run (NAME_implicit_const) and calls NAME_implicit_var, the
    body without them: 5 % of the ant's NAME_implicit (session 15, report-antfs.md).
    NAME_implicit itself stays the whole call (NAME_implicit_const, then NAME_implicit_var)
    for every other caller (compiler/emit/generate.py)."""
    const = [(lv, e, line) for (lv, e), line in zip(stores, lines)
             if isinstance(e, (int, float)) or (isinstance(e, sm.Basic) and e.is_Number)]
    if not const:
        return None
    pr = CPrinter({})
    body, used = stores_zeroing_runs([(lv, e) for lv, e, _ in const], pr, "k")
    return {line for _, _, line in const}, ([f"{IND}int k;"] if used else []) + body


def tree_matrix_body(ctx, program, fn):
    """mass_matrix (CRBA, group A: lower triangle), forcing (b) or inverse_dynamics (tau)."""
    pr = ctx.printer(program)
    lines = temps(program, pr)
    vals = dict(program.results)
    nu = ctx.nu
    if fn == "mass_matrix":
        # CRBA's M: the lower triangle; a tree closed by constraints: Kane's whole [NᵀM; J]
        full = any(k[0] == "A" and k[1] < k[2] for k in vals)
        pairs = [(f"out[{i * nu + j}]", vals.get(("A", i, j) if full else ("A", max(i, j), min(i, j)), 0.0))
                 for i in range(nu) for j in range(nu)]
        body, used = stores_zeroing_runs(pairs, pr, "k")
        lines = ([f"{IND}int k;"] if used else []) + lines + body
        out, size = "out", nu * nu
    elif fn == "forcing":
        lines += [store(f"out[{i}]", vals.get(("b", i), 0.0), pr) for i in range(nu)]
        out, size = "out", nu
    else:
        lines += [store(f"tau[{i}]", vals.get(("tau", i), 0.0), pr) for i in range(nu)]
        out, size = "tau", nu
    lines.append(f"{IND}return {ctx.name}_finite({out}, {size});")
    return lines


def _jacobian_plan(program, W, G, seeds, fn, nq, nx, nr):
    """:func:`_make_plan`, computed once per program and function (the C body and the op
    count both need it, and it is a large part of a big model's generate time); kept on
    the (immutable) program itself, so it lives exactly as long as the program."""
    args = (fn, tuple(W), tuple(G), tuple(seeds), nq, nx, nr)
    plans = program.__dict__.setdefault("_jacobian_plans", {})
    if args not in plans:
        with compiler_step("jacobian_plan"):
            plans[args] = _make_plan(program, W, G, seeds, fn, nq, nx, nr)
    return plans[args]


def _make_plan(program, W, G, seeds, fn, nq, nx, nr):
    """How a recursive jac_x / jac_r runs, for the C body and for the op count.

    Returns (program, once, stores, loops): the program with the temporaries
    :func:`_hoist` adds, ``once`` the assignments run once (ABA, the
    residual's values at the solved u', the unrolled derivatives), ``stores``
    [(lvalue, expr)] written once (w[] first: ``once`` reads it from its first
    assignment that depends on W on), ``loops`` [(first column, end column, column
    assignments, [(lvalue, expr)] of G, solve assignments, {row: (M⁻¹ G)_row})].
    Columns run the residual's tangent (seed ``dx = e_k``) or read the unrolled
    derivatives, then the articulated-body solve of G.
    """
    nu = len(G)
    sol = {k[1]: e for k, e in program.results if k[0] == "sol"}
    stores = [(f"w[{j}]", e) for k, e in program.results if k[0] == "ud" for j in (k[1],)]
    nud = len(stores)      # the speeds; a closed tree's λ follow u' in w (constrained.kkt_residual), so
    # G has nu + m rows there and the extra states' rows start at nq + nud, not nq + len(G)
    stores += [(f"w[{nud + k[1]}]", e) for k, e in program.results if k[0] == "lam"]
    if fn == "jac_x":
        kin, ncols = program.result_exprs("dkin"), nx
        stores += [(f"out[{i * ncols + k}]", kin.get(("dkin", i, k), sm.S.Zero))
                   for i in range(nq) for k in range(ncols)]
        stores += _extra_rows(program, "dzd", nq + nud, nx, ncols)     # after the speeds, not after λ
        tangents = [(g, start, end) for g, start, end in (("tq", 0, nq), ("tu", nq, nx))
                    if any(k[0] == g for k, _ in program.results)]
        unrolled = "dres" if not tangents else None
    else:   # jac_r, jac_p (nr: the number of inputs or parameters)
        tag = fn[-1]
        kin, ncols = program.result_exprs(f"dkin_{tag}"), nr
        stores += [(f"out[{i * ncols + k}]", kin.get((f"dkin_{tag}", i, k), sm.S.Zero))
                   for i in range(nq) for k in range(ncols)]
        stores += _extra_rows(program, f"dzd_{tag}", nq + nud, nx, ncols)
        tangents, unrolled = [], f"dres_{tag}"
    if unrolled:
        vals = program.result_exprs(unrolled)
        stores += [(f"Gm[{k * nu + i}]", vals.get((unrolled, i, k), sm.S.Zero))
                   for k in range(ncols) for i in range(nu)]
    columns = {g: program.result_exprs(g) for g, _, _ in tangents}
    exprs = [e for _, e in stores] + list(sol.values()) + list(program.result_exprs("Dpiv").values())
    exprs += [e for vals in columns.values() for e in vals.values()]
    needed = needed_assignments(program.assignments, exprs)
    if not any(e.free_symbols & set(W) for _, e in needed) and not any(
            e.free_symbols & set(W) for _, e in stores):
        stores = [(lv, e) for lv, e in stores if not lv.startswith("w[")]      # jac_r: no u'
        needed = needed_assignments(program.assignments, [e for _, e in stores] + exprs[len(stores):])
    prog = program.with_(assignments=tuple(needed))
    once, rest = split_on(prog, tuple(seeds) + tuple(G))
    solve = needed_assignments(rest, sol.values())
    loops = []
    if unrolled:
        loops.append((0, ncols, [], [], solve, sol))
    for g, start, end in tangents:
        vals = columns[g]
        inner = needed_assignments(rest, vals.values())
        loops.append((start, end, inner, [(f"G[{i}]", vals.get((g, i), sm.S.Zero)) for i in range(nu)],
                      solve, sol))
    return _hoist(program, once, stores, loops, set(seeds) | set(G))


def _extra_rows(program, group, first, nx, ncols):
    """(lvalue, expr) of the extra first-order states' rows first..nx of a Jacobian."""
    vals = program.result_exprs(group)
    return [(f"out[{i * ncols + k}]", vals.get((group, i - first, k), sm.S.Zero))
            for i in range(first, nx) for k in range(ncols)]


def _hoist(program, once, stores, loops, varying):
    """Move what the columns compute but do not change out of the loops.

    The tangent of a product keeps its other factors as they were, and those are
    often sums of values fixed for the whole call (``dE·(v - r×ω)``); and products
    of a constant and a fixed value multiply a seed.  Every largest such piece
    becomes one temporary computed once (value-numbered), instead of once per column.
    Returns (program with the new temporaries, once, stores, loops), as
    :func:`_jacobian_plan`.
    """
    varying = set(varying) | {t for loop in loops for t, _ in loop[2] + loop[4]}
    names = Names(program)
    memo, hoisted = {}, []

    def fixed(e):
        return not (e.free_symbols & varying)

    def name(e):
        if e.is_Atom or (e.is_Mul and len(e.args) == 2 and e.args[0] == -1 and e.args[1].is_Atom):
            return e
        hit = memo.get(e)
        if hit is None:
            hit = memo[e] = names.fresh()
            hoisted.append((hit, e))
        return hit

    def visit(e):
        if e.is_Atom:
            return e
        if fixed(e):
            return name(e)
        if e.is_Add or e.is_Mul:
            still = [a for a in e.args if fixed(a) and a != -1]
            if len(still) >= 2:
                rest = [visit(a) for a in e.args if not (fixed(a) and a != -1)]
                return e.func(*(rest + [name(e.func(*still))]))
        return e.func(*[visit(a) for a in e.args])

    def rewrite(pairs):
        return [(lv, visit(e)) for lv, e in pairs]

    done = {}
    new_loops = []
    for start, end, inner, gstores, solve, sol in loops:
        inner = [(t, done.setdefault(t, visit(e))) for t, e in inner]
        solve = [(t, done.setdefault(t, visit(e))) for t, e in solve]
        sol = {k: visit(e) for k, e in sol.items()}
        new_loops.append((start, end, inner, rewrite(gstores), solve, sol))
    once = list(once) + hoisted
    loop_assignments = [(t, done[t]) for t, _ in program.assignments if t in done]
    program = program.with_(assignments=tuple(once + loop_assignments), ntemp=names.count)
    return program, once, stores, new_loops



def name_loop_inputs(pr, once, exprs):
    """Name P[0], P[1], ... the values computed once (``once``) that the column loops read
    (``exprs``, in loop order), and return how many: they live in an array, not in hundreds
    of loop-invariant locals, which make C compilers' register allocation slow on large
    models.  Sorted by printed name (length first) so the C is the same for the same input."""
    defined = {t for t, _ in once}
    live, seen = [], set()
    for e in exprs:
        for s in e.free_symbols:
            if s in defined and s not in seen:
                seen.add(s)
                live.append(s)
    live.sort(key=lambda s: pr._names[s])
    live.sort(key=lambda s: len(pr._names[s]))
    for j, s in enumerate(live):
        pr._names[s] = f"P[{j}]"
    return len(live)

def tree_jacobian_body(ctx, program, W, G, seeds, fn, nr):
    """jac_x (d xdot/dx) or jac_r (d xdot/dr) of the recursive formulation: ABA's u' into w,
    then per column the residual's derivative G and u'-columns M⁻¹ G by the articulated-body
    recursion (no mass matrix, no factorization)."""
    nq, nu = ctx.nq, ctx.nu
    nx = ctx.nx     # q, u and the extra first-order states
    ncols = nx if fn == "jac_x" else nr     # nr: inputs (jac_r) or parameters (jac_p)
    program, once, stores, loops = _jacobian_plan(program, W, G, seeds, fn, nq, nx, nr)
    before, after = split_on(program.with_(assignments=tuple(once)), W)
    pr = ctx.printer(program)
    unrolled = any(not inner for _, _, inner, _, _, _ in loops)
    for j, g in enumerate(G):
        pr._names[g] = f"G[{j}]"
    for j, s in enumerate(W[nu:]):      # a closed tree's λ (constrained.jacobian_symbols)
        pr._names[s] = f"w[{nu + j}]"
    ng = len(G)           # nu, or nu + m on a closed tree (the constraints' rows)
    nlive = name_loop_inputs(pr, once, (e for _, _, inner, gstores, solve, sol in loops
                                        for e in [e for _, e in inner + solve] + [e for _, e in gstores]
                                        + list(sol.values())))
    decls = [f"double w[{len(W)}];"] if any(lv.startswith("w[") for lv, _ in stores) else []
    decls += ([f"double Gm[{ncols * ng}];", "const double *G;"] if unrolled else [f"double G[{ng}];"])
    if any(inner for _, _, inner, _, _, _ in loops):
        decls += [f"double dx[{nx}];", "int i;"]
    decls.append("int k;")
    decls += [f"double P[{nlive}];"] if nlive else []
    lines = [f"{IND}{d}" for d in decls]
    lines += temps(program, pr, before)
    lines += singular_guard(program, pr)
    lines += [store(lv, e, pr) for lv, e in stores if lv.startswith("w[")]
    lines += temps(program, pr, after)
    lines += stores_zeroing_runs([(lv, e) for lv, e in stores if not lv.startswith("w[")], pr, "k")[0]
    if any(inner for _, _, inner, _, _, _ in loops):
        lines.append(f"{IND}for (i = 0; i < {nx}; i++) dx[i] = 0.0;")
    for start, end, inner, gstores, solve, sol in loops:
        body = temps(program, pr, inner) + [store(lv, e, pr) for lv, e in gstores]
        if not inner:
            body.append(f"{IND}G = Gm + k * {ng};")
        body += temps(program, pr, solve)
        body += [store(f"out[{(nq + i) * ncols} + k]", sol.get(i, sm.S.Zero), pr) for i in range(nu)]
        lines.append(f"{IND}for (k = {start}; k < {end}; k++) {{")
        if inner:
            lines += [f"{IND * 2}dx[k] = 1.0;", f"{IND * 2}{{"]
        else:
            lines.append(f"{IND * 2}{{")
        lines += [IND * 2 + line for line in body]
        lines.append(f"{IND * 2}}}")
        if inner:
            lines.append(f"{IND * 2}dx[k] = 0.0;")
        lines.append(f"{IND}}}")
    lines.append(f"{IND}return {ctx.name}_finite(out, {nx * ncols});")
    return lines


def tree_jacobian_ops(program, W, G, seeds, fn, nq, nx, nr):
    """Operations of :func:`tree_jacobian_body`: the once-part, plus every column's part
    once per column."""
    _, once, stores, loops = _jacobian_plan(program, W, G, seeds, fn, nq, nx, nr)
    c = Counter()
    for _, e in once + stores:
        count_ops(e, c)
    for start, end, inner, gstores, solve, sol in loops:
        per = Counter()
        for _, e in inner + gstores + solve:
            count_ops(e, per)
        for e in sol.values():
            count_ops(e, per)
        for _ in range(end - start):
            c += per
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
