"""C bodies of the generated functions, from each function's optimized program.

Expressions arrive here as IR; everything is printed by :class:`CPrinter`;
the templates only glue the pieces together.
"""
import re

from ..ir import c_names, needed_assignments, symbols_of
from . import seed_pairs
from .printer import CPrinter
from .split import split_body
from .signatures import SIGNATURES

__all__ = ["BodyContext", "extra_state_rows", "plain_body", "solved_plain_body", "rhs_body", "jacobian_body", "tangent_jacobian_body",
           "helper_jacobian_body", "needed_assignments",
           "linearize_body", "split_on", "dynamics_helper", "matrix_body",
           "void_unused", "jvp_body", "parameter_directions", "lane_directions", "IND", "temps", "store"]

IND = "    "    # one level of indentation in a generated function body


class BodyContext:
    """What every body needs: sizes, the solver, C names of input slots."""

    def __init__(self, name, nq, nu, nw, solver, slot_names, symmetric, pattern):
        self.name, self.nq, self.nu, self.nw = name, nq, nu, nw
        self.solver, self.slot_names = solver, slot_names
        self.symmetric, self.pattern = symmetric, pattern
        self.split = False      # some body was cut into sub-functions (emit.split)
        self.nz = 0             # extra first-order states, after q and u in x (set by the generator)
        self.functions = ()     # the functions generated with this one (set by the generator)
        self.parts = []         # static functions the body being generated calls (emitted before it)
        self.solver_parts = []  # static functions emitted right after the solver's (see jvp_body)
        # NAME_implicit's constant outputs (compiler/tree/emit.implicit_constants; taken by the generator)
        self.constant_stores = None
        # the body's own near-pointer threshold for its split (emit/split.py's windows: an int, statements of
        # a run), where it knows better than the formulation (compiler/tree/limbs.py); taken by the generator
        self.windows = None

    @property
    def nx(self):
        return self.nq + self.nu + self.nz

    def printer(self, program):
        names = dict(self.slot_names)
        names.update(c_names(program))
        return CPrinter(names)


def temps(program, printer, assignments=None):
    """C lines of ``assignments`` (default: all of ``program``'s), one temporary each."""
    assignments = program.assignments if assignments is None else assignments
    names = printer._names
    out = []
    for s, e in assignments:
        declare = getattr(e, "c_declaration", None)   # a call writing its outputs into a local array
        if declare is not None:
            out.append(f"{IND}{declare()}")
        out.append(f"{IND}{'' if names[s].endswith(']') else 'const double '}{names[s]} = {printer.doprint(e)};")
        if getattr(e, "c_token", False) and not names[s].endswith("]"):     # a call's token no one reads
            out.append(f"{IND}(void){names[s]};")
    return out


def store(lvalue, expr, printer):
    """One C line: ``lvalue = expr;``."""
    return f"{IND}{lvalue} = {printer.doprint(expr)};"


def plain_body(ctx, program, group, shape, out="out"):
    """Assign a vector (rows,) or a row-major matrix (rows, cols) result group to ``out``."""
    pr = ctx.printer(program)
    lines = temps(program, pr)
    vals = program.result_exprs(group)
    if len(shape) == 1:
        for i in range(shape[0]):
            lines.append(store(f"{out}[{i}]", vals.get((group, i), 0.0), pr))
        size = shape[0]
    else:
        rows, cols = shape
        for i in range(rows):
            for k in range(cols):
                lines.append(store(f"{out}[{i * cols + k}]", vals.get((group, i, k), 0.0), pr))
        size = rows * cols
    lines.append(f"{IND}return {ctx.name}_finite({out}, {size});")
    return lines


def solved_plain_body(ctx, program, group, shape, out="out"):
    """plain_body after solving A·w = b: outputs that read u' or multipliers (w[j])."""
    lines = _solver_decls(ctx) + [_call_dynamics(ctx)] + _factor_and_solve(ctx)
    return lines + plain_body(ctx, program, group, shape, out)


def _solver_decls(ctx, extra=()):
    s = ctx.solver
    lines = [f"{IND}double F[{s.fsize}];", f"{IND}double w[{ctx.nw}];"]
    if s.pivots:
        lines.append(f"{IND}int piv[{s.npiv}];")
    lines += [f"{IND}{d}" for d in extra]
    lines.append(f"{IND}int status;")
    return lines


def _store_dynamics(ctx, program, pr):
    lines = []
    if ctx.solver.pivots or ctx.solver.reads_lower:
        # the dense LU reads every entry, the loop LDLT every lower one: structural zeros too
        nonzero = {(k[1], k[2]) for k, _ in program.results if k[0] == "A"}
        lines += [f"{IND}F[{i * ctx.nw + j}] = 0.0;" for i in range(ctx.nw)
                  for j in range(i + 1 if ctx.solver.reads_lower else ctx.nw) if (i, j) not in nonzero]
    for (key, e) in program.results:
        if key[0] == "A":
            lines.append(store(f"F[{key[1] * ctx.nw + key[2]}]", e, pr))
        elif key[0] == "b":
            lines.append(store(f"w[{key[1]}]", e, pr))
    return lines


def _factor_and_solve(ctx):
    s = ctx.solver
    return [f"{IND}status = {s.factor_call()};",
              f"{IND}if (status != EOMC_OK) return status;",
              f"{IND}{s.solve_call('w')};"]


def _load_dynamics(ctx, program, pr):
    return _store_dynamics(ctx, program, pr) + _factor_and_solve(ctx)


DYNAMICS_SIGNATURE = (("double", "t"), ("const double *", "x"), ("const double *", "p"),
                      ("const double *", "r"), ("double *", "F"), ("double *", "w"))


def dynamics_helper(ctx, program):
    """``static void NAME_dynamics(t, x, p, r, F, w)``: A into F, b into w.  rhs,
    mass_matrix, forcing and inverse_dynamics call it, so its code is compiled once."""
    pr = ctx.printer(program)
    lines, parts = split_body(temps(program, pr) + _store_dynamics(ctx, program, pr),
                              f"{ctx.name}_dynamics_part")
    ctx.split = ctx.split or bool(parts)
    text = "\n".join(lines)
    # only the arguments it reads, so callers of a model without inputs never touch r
    sig = [(c, a) for c, a in DYNAMICS_SIGNATURE if a in "Fw" or re.search(rf"\b{a}\b", text)]
    ctx.helper_args = [a for _, a in sig]
    args = ", ".join(f"{c}{a}" if c.endswith("*") else f"{c} {a}" for c, a in sig)
    return "".join(p + "\n" for p in parts) + f"static void {ctx.name}_dynamics({args})\n{{\n{text}\n}}\n"


def _call_dynamics(ctx):
    return f"{IND}{ctx.name}_dynamics({', '.join(ctx.helper_args)});"


def rhs_body(ctx, program):
    """q' from the kinematics, u' from the factorized A·w = b, z' of the extra states."""
    pr = ctx.printer(program)
    lines = _solver_decls(ctx) + temps(program, pr)
    for (key, e) in program.results:
        if key[0] == "kin":
            lines.append(store(f"xdot[{key[1]}]", e, pr))
    lines += extra_state_rows(ctx, program, pr, "zd", "xdot")
    lines += [_call_dynamics(ctx)] + _factor_and_solve(ctx)
    lines += [f"{IND}xdot[{ctx.nq + i}] = w[{i}];" for i in range(ctx.nu)]
    lines.append(f"{IND}return {ctx.name}_finite(xdot, {ctx.nx});")
    return lines


def extra_state_rows(ctx, program, pr, group, out, ncols=None):
    """Stores of the extra states' rows (after q and u): z' itself (``ncols`` None) or its
    derivatives ``(group, i, k)``, row-major with ``ncols`` columns."""
    vals = program.result_exprs(group)
    first = ctx.nq + ctx.nu
    if ncols is None:
        return [store(f"{out}[{first + i}]", vals.get((group, i), 0.0), pr) for i in range(ctx.nz)]
    return [store(f"{out}[{(first + i) * ncols + k}]", vals.get((group, i, k), 0.0), pr)
            for i in range(ctx.nz) for k in range(ncols)]


def split_on(program, symbols):
    """Assignments that do not / do depend (transitively) on ``symbols``, order kept."""
    dep = set(symbols)
    before, after = [], []
    for target, e in program.assignments:
        if symbols_of(e) & dep:
            dep.add(target)
            after.append((target, e))
        else:
            before.append((target, e))
    return before, after



def tangent_jacobian_body(ctx, program, W, seeds, ncols, blocks):
    """d xdot / dx with tangent programs run once per column (unit seed dx = e_k).

    ``blocks``: (result group, first column, end column); one tangent program per
    block of columns (the coordinates' and the speeds'), so a speed column does not
    run the coordinates' much larger tangent."""
    nw, nq, nu = ctx.nw, ctx.nq, ctx.nu
    pr = ctx.printer(program)
    before, rest = split_on(program, W + seeds)
    stage2, stage3 = split_on(program.with_(assignments=tuple(rest)), seeds)
    per_block = []
    for group, start, end in blocks:
        gvals = program.result_exprs(group)
        per_block.append((gvals, needed_assignments(stage3, gvals.values()), start, end))
    # values the loops read live in an array, not in hundreds of loop-invariant locals
    # (which make C compilers' register allocation slow on large models)
    defined = {t for t, _ in before + stage2}
    live = []
    for gvals, inner, _, _ in per_block:
        for e in [e for _, e in inner] + list(gvals.values()):
            live += [s for s in e.free_symbols if s in defined and s not in live]
    live.sort(key=lambda s: pr._names[s])
    live.sort(key=lambda s: len(pr._names[s]))
    for j, s in enumerate(live):
        pr._names[s] = f"P[{j}]"
    lines = _solver_decls(ctx, [f"double G[{nw}];", f"double dx[{ncols}];", "int i, k;"]
                          + ([f"double P[{len(live)}];"] if live else []))
    lines += temps(program, pr, before)
    lines += _load_dynamics(ctx, program, pr)
    lines += temps(program, pr, stage2)
    kvals = program.result_exprs("dkin")
    for i in range(nq):
        for k in range(ncols):
            lines.append(store(f"out[{i * ncols + k}]", kvals.get(("dkin", i, k), 0.0), pr))
    lines += extra_state_rows(ctx, program, pr, "dzd", "out", ncols)
    lines.append(f"{IND}for (i = 0; i < {ncols}; i++) dx[i] = 0.0;")
    for gvals, inner, start, end in per_block:
        group = next(iter(gvals))[0] if gvals else None
        body = temps(program, pr, inner)
        body += [store(f"G[{i}]", gvals.get((group, i), 0.0), pr) for i in range(nw)]
        lines += [f"{IND}for (k = {start}; k < {end}; k++) {{",
                  f"{IND * 2}dx[k] = 1.0;", f"{IND * 2}{{"]
        lines += [IND * 2 + line for line in body]
        lines += [f"{IND * 2}}}",
                  f"{IND * 2}dx[k] = 0.0;",
                  f"{IND * 2}{ctx.solver.solve_call('G')};",
                  f"{IND * 2}for (i = 0; i < {nu}; i++) out[({nq} + i) * {ncols} + k] = G[i];",
                  f"{IND}}}"]
    lines.append(f"{IND}return {ctx.name}_finite(out, {ctx.nx * ncols});")
    return lines


def _solve_columns(ctx, program, pr, ncols, kin_group, g_group):
    """Store G and the kinematic rows, then one solve per column of G into ``out``."""
    nw, nq, nu = ctx.nw, ctx.nq, ctx.nu
    gvals = program.result_exprs(g_group)
    lines = [store(f"G[{k * nw + i}]", gvals.get((g_group, i, k), 0.0), pr)
             for k in range(ncols) for i in range(nw)]
    kvals = program.result_exprs(kin_group)
    lines += [store(f"out[{i * ncols + k}]", kvals.get((kin_group, i, k), 0.0), pr)
              for i in range(nq) for k in range(ncols)]
    zgroup = {"dkin": "dzd", "dkin_r": "dzd_r", "dkin_p": "dzd_p"}[kin_group]
    lines += extra_state_rows(ctx, program, pr, zgroup, "out", ncols)
    return lines + [f"{IND}for (k = 0; k < {ncols}; k++) {{",
                    f"{IND * 2}{ctx.solver.solve_call(f'G + k * {nw}')};",
                    f"{IND * 2}for (i = 0; i < {nu}; i++) out[({nq} + i) * {ncols} + k] = G[k * {nw} + i];",
                    f"{IND}}}",
                    f"{IND}return {ctx.name}_finite(out, {ctx.nx * ncols});"]


def jacobian_body(ctx, program, W, ncols, kin_group, g_group):
    """d xdot / d(x or r): one factorization, then one solve per column of G."""
    pr = ctx.printer(program)
    before, after = split_on(program, W)
    lines = _solver_decls(ctx, [f"double G[{ncols * ctx.nw}];", "int i, k;"])
    lines += temps(program, pr, before)
    lines += _load_dynamics(ctx, program, pr)
    lines += temps(program, pr, after)
    return lines + _solve_columns(ctx, program, pr, ncols, kin_group, g_group)


def helper_jacobian_body(ctx, program, W, ncols, kin_group, g_group):
    """d xdot / dr with A from the dynamics helper: factor once, solve for w only when the
    columns read it (A depends on r), then one solve per column of G."""
    pr = ctx.printer(program)
    s = ctx.solver
    lines = _solver_decls(ctx, [f"double G[{ncols * ctx.nw}];", "int i, k;"])
    lines += [_call_dynamics(ctx), f"{IND}status = {s.factor_call()};",
              f"{IND}if (status != EOMC_OK) return status;"]
    if any(e.free_symbols & set(W) for _, e in program.assignments + program.results):
        lines.append(f"{IND}{s.solve_call('w')};")
    lines += temps(program, pr)
    return lines + _solve_columns(ctx, program, pr, ncols, kin_group, g_group)


def linearize_body(ctx, has_inputs):
    """A = jac_x, B = jac_r (B untouched when the model has no inputs)."""
    n = ctx.name
    lines = [f"{IND}int status = {n}_jac_x(t, x, p, r, A, work);"]
    if has_inputs:
        lines += [f"{IND}if (status != EOMC_OK) return status;",
                  f"{IND}return {n}_jac_r(t, x, p, r, B, work);"]
    else:
        lines.append(f"{IND}return status;")
    return lines


def _entry(ctx, i, j):
    """C text of A[i][j] as the dynamics helper stored it (0.0 if structurally zero)."""
    if ctx.symmetric:
        i, j = max(i, j), min(i, j)
    return f"F[{i * ctx.nw + j}]" if (i, j) in ctx.pattern else "0.0"


def matrix_body(ctx, fn):
    """mass_matrix, forcing or inverse_dynamics from the dynamics helper's A and b."""
    nu = ctx.nu
    lines = [f"{IND}double F[{ctx.nw * ctx.nw}];", f"{IND}double w[{ctx.nw}];",
             _call_dynamics(ctx)]
    if fn == "mass_matrix":
        lines += [f"{IND}out[{i * nu + j}] = {_entry(ctx, i, j)};"
                  for i in range(nu) for j in range(nu)]
        out, size = "out", nu * nu
    elif fn == "forcing":
        lines += [f"{IND}out[{i}] = w[{i}];" for i in range(nu)]
        out, size = "out", nu
    else:
        for i in range(nu):
            terms = [f"{_entry(ctx, i, j)} * udot[{j}]" for j in range(nu)
                     if _entry(ctx, i, j) != "0.0"]
            lines.append(f"{IND}tau[{i}] = {' + '.join(terms) or '0.0'} - w[{i}];")
        out, size = "tau", nu
    lines.append(f"{IND}return {ctx.name}_finite({out}, {size});")
    return lines


def void_unused(function, lines, signature=None):
    """Prefix ``(void)arg;`` for every signature argument the body does not read."""
    text = "\n".join(lines)
    signature = SIGNATURES[function] if signature is None else signature
    unused = [a for _, a in signature if not re.search(rf"\b{a}\b", text)]
    return "\n".join([f"{IND}(void){a};" for a in unused] + lines)


PCOLS_ARGS = ("x", "p", "r", "w", "PC")     # arrays a parameter-column function may read


def parameter_directions(program, pr, gp, kp, nx, npar, fname, groups):
    """A jvp's parameter part, per direction (``dx`` = the direction): for every nonzero
    dp[j], column j of the residual's and the kinematic rows' parameter derivatives times
    dp[j] (G[i] += ..., the direction's out row += ...).

    Column by column, in a switch: a sensitivity direction has one nonzero parameter entry
    (d = [S_j; e_j]), so a direction costs one column, not every parameter's columns (the
    n-link cart's 18 columns cost 2.6 rhs a call, one column about 0.15) nor a tangent
    along dp (a whole tangent of A and b: 1.1 rhs).  ``gp``: {(group, row, j): expr} of the
    residual rows (into G), ``kp``: {(group, row, j): expr} of the state rows written
    directly; the temporaries each column reads that the rest of the function does not are
    computed inside its case.  ``groups``: the result groups of these derivatives (the rest
    of the function is every other group).

    The switch is a function of its own, ``fname`` (not inlined), called once per
    direction; the jvp's temporaries it reads are copied once into an array ``PC`` before
    the loop over directions (``setup``).  Why: inside the loop, the cases' loop-invariant
    products of those temporaries were hoisted by the C compiler and kept live across the
    tangent for the one case a direction runs (8-link cart, one direction: 413 -> 385 ns
    a call; the column's own work, alone in the loop, 371).

    Returns (the call, the assignments computed only inside the cases, setup lines to put
    before the loop over directions, the function's C text); all empty without columns.
    """
    nz = {key: e for key, e in list(gp.items()) + list(kp.items()) if e != 0}
    others = [e for key, e in program.results if key[0] not in groups]
    own = ({t for t, _ in needed_assignments(program.assignments, nz.values())}
           - {t for t, _ in needed_assignments(program.assignments, others)})
    if not nz:
        return [], own, [], ""
    assigned = [a for a in program.assignments if a[0] in own]
    cases = []
    for j in range(npar):
        col = sorted(key for key in nz if key[2] == j)
        if col:
            cases.append((j, col, needed_assignments(assigned, [nz[k] for k in col])))
    defined = {t for t, _ in program.assignments} - own
    read = {s for _, col, inner in cases for e in [e for _, e in inner] + [nz[k] for k in col]
            for s in e.free_symbols if s in defined and not pr._names[s].endswith("]")}
    spill = sorted(read, key=lambda s: (len(pr._names[s]), pr._names[s]))
    names = dict(pr._names)
    names.update({s: f"PC[{i}]" for i, s in enumerate(spill)})
    cp = type(pr)(names)
    setup = ([f"double PC[{len(spill)}];"] + [f"PC[{i}] = {pr._names[s]};" for i, s in enumerate(spill)]
             if spill else [])
    body = [f"for (j = 0; j < {npar}; j++) {{",
            f"{IND}if (dp[j] == 0.0) continue;",
            f"{IND}switch (j) {{"]
    for j, col, inner in cases:
        body.append(f"{IND}case {j}: {{")
        body += [IND + line for line in temps(program, cp, inner)]
        body += [f"{IND * 2}{'G' if key in gp else 'o'}[{key[1]}] += "
                 f"({cp.doprint(nz[key])}) * dp[{j}];" for key in col]
        body.append(f"{IND * 2}break;")
        body.append(f"{IND}}}")
    body += [f"{IND}default: break;", f"{IND}}}", "}"]
    text = "\n".join(body)
    # the arrays the cases read from the jvp's scope: not the ones a case declares itself (a pair
    # table's tangent outputs, ``double PD..._[n];``) nor a compound literal's type (``(const double[n])``)
    local = set(re.findall(r"\bdouble\s+([A-Za-z_]\w*)\[", text))
    used = set(re.findall(r"\b([A-Za-z_]\w*)\[", text)) - {"G", "o", "dp", "double"} - local
    reads = [a for a in PCOLS_ARGS if a in used] + sorted(used - set(PCOLS_ARGS))
    scalar_t = re.search(r"\bt\b", text) is not None
    writes = [(a, arg) for a, arg in (("G", "G"), ("o", f"out + (size_t)d * {nx}"))
              if re.search(rf"\b{a}\[", text)]
    sig = ((["double t"] if scalar_t else []) + [f"const double *{a}" for a in reads]
           + ["const double *dp"] + [f"double *{a}" for a, _ in writes])
    function = "\n".join(["#if defined(__GNUC__)", "__attribute__((noinline))", "#endif",
                          f"static void {fname}({', '.join(sig)})", "{", f"{IND}int j;"]
                         + [IND + line for line in body] + ["}"])
    args = (["t"] if scalar_t else []) + reads + [f"dx + {nx}"] + [arg for _, arg in writes]
    call = f"{fname}({', '.join(args)});"
    return [call], own, setup, function


LANES = 4   # directions a jvp's tangent carries at once (see lane_directions)


def lane_directions(pr, seeds, nx, nd, tangents, ng, kin, scalar, tail, lane_solve=None):
    """The loop over a jvp's k directions, the tangent carried LANES directions at a time.

    Why: one direction's tangent is a long chain of scalar products of the primal's
    temporaries with the direction; LANES directions in one loop ``for (ln = 0; ln < LANES;
    ln++)`` around the same chain read each primal temporary once for all of them, and the C
    compiler turns the loop into vector instructions (2 doubles wide under plain -O2 on
    x86-64).  The lanes' results land in GT[row][lane]; the parameter columns and the
    stores stay per direction (``tail``), and so does the solve unless ``lane_solve`` is
    given: (the parameter-column lines, the call solving GT's lanes in place, the first out
    row the solution fills).  Then each direction's parameter columns go into its lane and
    one vectorized solve serves them all (linsolve.Solver.lanes_code; 8-link cart, four
    directions 609 -> 551 ns a call); a four-lane LDLᵀ substitution in scalar code had
    measured slower than four scalar ones (600 -> 753 ns; their latency chains overlap).
    A lone direction (k = 1, or the last of an odd group) runs the scalar tangent and solve
    as before, so one direction costs what it did.  Lanes past k repeat the group's last
    direction (no reads past ``dirs``) and are dropped.

    ``tangents``: [(assignments, {row: expr}, first)] per tangent program (first: '=' into
    the rows, else '+='); ``seeds``: the direction's state symbols (seed j = state j);
    ``kin``/``scalar``/``tail``: C lines (one indentation level less than the loop body) of
    the directly written state rows, the scalar tangent into G, and what follows per
    direction.  Returns (declarations, loop lines).
    """
    names = dict(pr._names)
    names.update({sd: f"XT[{j}][ln]" for j, sd in enumerate(seeds)})
    lp = type(pr)(names)
    lane = [f"for (ln = 0; ln < {LANES}; ln++) {{"]
    for assignments, rows, first in tangents:
        lane += [f"{IND}const double {names[t]} = {lp.doprint(e)};" for t, e in assignments]
        lane += [f"{IND}GT[{i}][ln] {'=' if first else '+='} {lp.doprint(e)};" for i, e in sorted(rows.items())]
    lane.append("}")
    group = [f"{IND}for (ln = 0; ln < {LANES}; ln++) {{",
             f"{IND * 2}dx = dirs + (size_t)(d + (ln < nl ? ln : nl - 1)) * {nd};",
             f"{IND * 2}for (i = 0; i < {nx}; i++) XT[i][ln] = dx[i];",
             f"{IND}}}"]
    group += [IND + x for x in lane]
    per = [f"dx = dirs + (size_t)d * {nd};"] + kin
    after = []
    if lane_solve is None:
        per += ["if (nl > 1) {", f"{IND}for (i = 0; i < {ng}; i++) G[i] = GT[i][ln];", "} else {"]
        per += [IND + x for x in scalar] + ["}"] + tail
    else:               # the parameter columns add into G: each lane out of GT and back in
        pcols, call, row = lane_solve
        solve = tail[len(pcols):]
        if pcols:
            per += ["if (nl > 1) {", f"{IND}for (i = 0; i < {ng}; i++) G[i] = GT[i][ln];", "} else {"]
            per += [IND + x for x in scalar] + ["}"] + pcols
            per += ["if (nl > 1) {", f"{IND}for (i = 0; i < {ng}; i++) GT[i][ln] = G[i];", "} else {"]
        else:
            per += ["if (nl == 1) {"] + [IND + x for x in scalar]
        per += [IND + x for x in solve] + ["}"]
        after = ["if (nl > 1) {", f"{IND}{call}",
                 f"{IND}for (ln = 0; ln < nl; ln++) {{",
                 f"{IND * 2}for (i = 0; i < {ng}; i++) out[(size_t)(d - nl + ln) * {nx} + {row} + i] = GT[i][ln];",
                 f"{IND}}}", "}"]
    lines = [f"{IND}for (d = 0; d < k; ) {{",
             f"{IND * 2}nl = k - d < {LANES} ? k - d : {LANES};",
             f"{IND * 2}if (nl > 1) {{"] + [IND * 2 + x for x in group] + [f"{IND * 2}}}"]
    lines.append(f"{IND * 2}for (ln = 0; ln < nl; ln++, d++) {{")
    lines += [IND * 3 + x for x in per]
    lines += [f"{IND * 2}}}"] + [IND * 2 + x for x in after] + [f"{IND}}}"]
    decls = [f"double XT[{nx}][{LANES}];", f"double GT[{ng}][{LANES}];", "int ln, nl;"]
    return decls, lines


def jvp_body(ctx, program, W, seeds, nx, npar, blocks, more=False):
    """xdot and k directional derivatives J·d (J = d xdot/d[x; p]) in one call, for forward
    sensitivities: A and b are evaluated and factored once, then per direction the
    residual's tangent along d's state part (the looped jac_x's tangent programs,
    ``blocks``, with the seed array pointing at the direction) or, for few states, the
    unrolled columns G times it, plus the parameter columns of d's nonzero parameter
    entries (:func:`parameter_directions`), and one solve.  J itself is never formed.  The
    tangent's entries that depend on two seeds with opposite coefficients (the n-link cart's
    mass-matrix pairs) are written as the coefficient times the seeds' difference
    (:mod:`.seed_pairs`: fewer products, the tangent being bound by its multiplications), and
    its one-seed monomials read the primal's products (``-(l sin q) dq`` for
    ``(-sin q dq) l``: :func:`.seed_pairs.seed_monomials`).

    ``dirs``: k rows of nx + nparam (state part, then parameter part); ``out``: k rows of nx.

    ``more`` (NAME_jvp_more): the same code with the direction loop wrapped so that, once the
    k directions are out, the callback ``more`` may hand back further directions (and where
    their rows go), run once with the primal already computed: Radau's staggered sensitivities
    carry their second iteration in the first iteration's call (runtime/c/eomc_integrators.c).
    The static helpers jvp's body added (the parameter columns, the lanes solve) are jvp's.
    """
    nw, nq, nu = ctx.nw, ctx.nq, ctx.nu
    nd = nx + npar
    pr = ctx.printer(program)
    zfirst = ctx.nq + ctx.nu
    gp = program.result_exprs("Gp")
    kp = program.result_exprs("dkin_p")
    kp.update(((("dkin_p", zfirst + key[1], key[2]), e) for key, e in program.result_exprs("dzd_p").items()))
    pcols, p_only, psetup, function = parameter_directions(program, pr, gp, kp, nx, npar, f"{ctx.name}_jvp_pcols",
                                                             ("Gp", "dkin_p", "dzd_p"))
    if function and not more:
        ctx.parts.append(function)
    main = program.with_(assignments=tuple(a for a in program.assignments if a[0] not in p_only))
    before, rest = split_on(main, W + seeds)
    stage2, stage3 = split_on(main.with_(assignments=tuple(rest)), seeds)
    extra = [f"double G[{nw}];", "const double *dx;", "int i, d;"]
    lines = _solver_decls(ctx, extra)
    lines += temps(program, pr, before)
    lines += _load_dynamics(ctx, program, pr)
    lines += temps(program, pr, stage2)
    kin = program.result_exprs("kin")
    lines += [store(f"xdot[{i}]", kin.get(("kin", i), 0.0), pr) for i in range(nq)]
    lines += [f"{IND}xdot[{nq + i}] = w[{i}];" for i in range(nu)]
    lines += extra_state_rows(ctx, program, pr, "zd", "xdot")
    kvals = program.result_exprs("dkin")
    kvals.update(((("dkin", zfirst + key[1], key[2]), e) for key, e in program.result_exprs("dzd").items()))
    kin = []
    for i in list(range(nq)) + list(range(zfirst, nx)):     # q rows, then the extra states' rows
        terms = [f"({pr.doprint(kvals[('dkin', i, k)])}) * dx[{k}]" for k in range(nx)
                 if kvals.get(("dkin", i, k), 0) != 0]
        kin.append(f"out[(size_t)d * {nx} + {i}] = {' + '.join(terms) or '0.0'};")
    body, tangents = [], []
    if blocks:
        first = True
        for group, _, _ in blocks:
            gvals = program.result_exprs(group)
            inner = needed_assignments(stage3, gvals.values())
            if seed_pairs.SEED_PAIRS:   # two-seed entries as a coefficient times a seed difference
                inner = needed_assignments(seed_pairs.seed_pairs(inner, seeds, dict(before + stage2)),
                                           gvals.values())
            if seed_pairs.SEED_MONOMIALS:   # one-seed monomials on the primal's products
                inner, gvals = seed_pairs.seed_monomials(inner, gvals, seeds, dict(before + stage2))
                inner = needed_assignments(inner, gvals.values())
            body += ["{"] + [line[len(IND):] if line.startswith(IND) else line
                             for line in temps(program, pr, inner)]
            op = "=" if first else "+="
            body += [f"G[{i}] {op} {pr.doprint(gvals.get((group, i), 0.0))};" for i in range(nw)]
            body.append("}")
            tangents.append((inner, {i: gvals.get((group, i), 0.0) for i in range(nw)}, first))
            first = False
    else:
        gvals = program.result_exprs("G")
        for i in range(nw):
            terms = [f"({pr.doprint(gvals[('G', i, k)])}) * dx[{k}]" for k in range(nx)
                     if gvals.get(("G", i, k), 0) != 0]
            body.append(f"G[{i}] = {' + '.join(terms) or '0.0'};")
    lines += [IND + x for x in psetup]
    tail = pcols + [f"{ctx.solver.solve_call('G')};",
                    f"for (i = 0; i < {nu}; i++) out[(size_t)d * {nx} + {nq} + i] = G[i];"]
    if tangents:        # the tangent programs LANES directions at a time
        lanes = ctx.solver.lanes_code(LANES) if nw == nu else None
        if lanes and not more:   # next to the scalar solve: among the jvp's parts, the same code measured
            ctx.solver_parts.append(lanes[1])   # 576-595 ns a call at k = 4, not 551 (placement)
        decls, loop = lane_directions(pr, seeds, nx, nd, tangents, nw, kin, body, tail,
                                      lane_solve=lanes and (pcols, f"{lanes[0]}(F, GT);", nq))
        lines[len(_solver_decls(ctx, extra)):len(_solver_decls(ctx, extra))] = [IND + x for x in decls]
    else:
        loop = [f"{IND}for (d = 0; d < k; d++) {{", f"{IND * 2}dx = dirs + (size_t)d * {nd};"]
        loop += [IND * 2 + line for line in kin + body + tail]
        loop.append(f"{IND}}}")
    if more:
        loop = ([f"{IND}for (;;) {{"] + [IND + line for line in loop]
                + [f"{IND * 2}if (!more) break;", f"{IND * 2}k = more(mctx, &dirs, &out);",
                   f"{IND * 2}if (k <= 0) break;", f"{IND * 2}more = 0;", f"{IND}}}"])
    lines += loop
    lines.append(f"{IND}status = {ctx.name}_finite(xdot, {nx});")
    lines.append(f"{IND}if (status != EOMC_OK || k <= 0) return status;")
    lines.append(f"{IND}return {ctx.name}_finite(out, k * {nx});")
    return lines


def singular_guard(program, pr):
    """The line that returns EOMC_SINGULAR_MASS_MATRIX when an articulated inertia the
    recursion divides by (the program's "Dpiv" results) is not positive: every function
    built on ABA checks them before its first division. Empty without such results."""
    pivots = [pr.doprint(e) for k, e in program.results if k[0] == "Dpiv"]
    if not pivots:
        return []
    cond = " || ".join(f"!({d} > 0.0)" for d in pivots)
    return [f"{IND}if ({cond}) return EOMC_SINGULAR_MASS_MATRIX;"]
