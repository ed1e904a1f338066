"""C bodies of jac_id and jac_x on the analytic RNEA derivatives (:mod:`.analytic`).

jac_id: the kernel's inputs (``an[]``, straight-line), then one call of
``NAME_rnea_derivs`` writing d tau/dx into ``out``.

jac_x: ABA's u' into ``w`` and the kinematic rows as before; the kernel at u' = w
writes -d tau/dx (= the residual's derivative, see :mod:`.derivatives`) into the
u'-rows of ``out`` and multiplies them by M⁻¹ in place (M from the kernel's own
composite inertias, factored LᵀDL over the tree: no straight-line solve code).
"""
from collections import Counter

import sympy as sm

from ..emit.bodies import IND, singular_guard, store, temps, needed_assignments, split_on
from ..emit.guards import guarded_temps
from ..ir.opcount import count_ops
from .analytic import ANX, analytic_ops, call_lines
from .emit import _extra_rows, stores_zeroing_runs

__all__ = ["has_analytic", "analytic_jac_id_body", "analytic_jac_x_body", "analytic_body_ops"]


def has_analytic(program, sym):
    return sym.analytic is not None and any(k[0] == ANX for k, _ in program.results)


def _inputs(program, pr):
    """an[]'s stores, but for the entries the ground points' loop writes in place (block G:
    compiler/contact/ground_table.ground_into)."""
    from ..contact.ground_table import ground_into
    _, written = ground_into(program, ANX)
    vals = program.result_exprs(ANX)
    return [store(f"an[{k[1]}]", e, pr) for k, e in sorted(vals.items(), key=lambda kv: kv[0][1])
            if k not in written]


def _shared_inputs(ctx):
    """an[] from NAME_dyn_inputs (.dynamics_kernel.inputs_users), computed once for all its users."""
    from .dynamics_kernel import INPUTS_CALL
    return [IND + INPUTS_CALL.format(name=ctx.name)]


TPW = "tpw"     # the pairs' wrench tangents along one state column (lower.py), into an[] block W


def _pair_split(program, sym):
    """(assignments run once, those run per column): the latter depend on the seeds dx, the
    tangent of the pairs' wrenches (block W of the kernel's inputs, :func:`.analytic._pair_lines`)."""
    if not sym.analytic.npair or sym.analytic.table >= 0:     # (the kernel forms them itself)
        return list(program.assignments), []
    return split_on(program, sym.seeds)


def _pair_columns(ctx, program, sym, pr, inner):
    """C: per state column k, the pairs' wrench tangents (seed dx = e_k: the table's forward-mode
    twin, compiler/contact/table.py) into an[] block W, before the kernel reads them; only the
    columns that move a body of a pair in contact at this state (:func:`_column_gate`), the
    others' block W zero."""
    plan = sym.analytic
    if not plan.npair or plan.table >= 0:   # (the kernel calls the twin itself: analytic._kernel_pair_lines)
        return []
    nx, n6, w0 = ctx.nx, 6 * plan.npair, plan.offsets["W"]
    vals = program.result_exprs(TPW)
    body = temps(program, pr, needed_assignments(inner, vals.values()))
    body += [store(f"an[{w0} + {n6} * kp + {i}]", vals.get((TPW, i), sm.S.Zero), pr)
             for i in range(n6)]
    gate = _column_gate(ctx, plan, inner)
    skip = ([f"{IND * 3}if (!on[kp]) {{   /* no body of a pair in contact moves along it: zero */",
             f"{IND * 4}for (j = 0; j < {n6}; j++) an[{w0} + {n6} * kp + j] = 0.0;",
             f"{IND * 4}continue;", f"{IND * 3}}}"] if gate else [])
    return ([f"{IND}{{   /* the body-body pairs' wrench tangents, per state column (analytic.py, block W) */",
             f"{IND * 2}double dx[{nx}];",
             f"{IND * 2}int kp;"]
            + gate
            + [f"{IND * 2}for (kp = 0; kp < {nx}; kp++) dx[kp] = 0.0;",
               f"{IND * 2}for (kp = 0; kp < {nx}; kp++) {{"]
            + skip
            + [f"{IND * 3}dx[kp] = 1.0;", f"{IND * 3}{{"]
            + [IND * 3 + line for line in body]
            + [f"{IND * 3}}}", f"{IND * 3}dx[kp] = 0.0;", f"{IND * 2}}}", f"{IND}}}"])


def _column_gate(ctx, plan, inner):
    """C: ``on[k]`` = column k moves a body of a pair with a point in contact at this state (the
    table's taped call flags its pairs, compiler/contact/table.py): the columns of the dofs on
    the body's path to the root, coordinate and speed.  The others' tangents are exactly zero
    (the table's inputs of a body depend on the state only through those; its offsets and law
    parameters not at all, checked here: else no gate).  Why: every column ran the table
    bodies' input tangents and the twin: the gymnasium humanoid's jac_x 61 µs with no pair in
    contact (trees-only 14 µs), 175 µs at rest."""
    from ..contact.table import PairTableDot
    dot = next((e for _, e in inner if isinstance(e, PairTableDot)), None)
    if dot is None:
        return []
    t = dot.table
    if not all(x.is_Number and x == 0 for x in dot.args[4 + 18 * len(t.bodies):]):
        return []
    ends = {j: e for j, _, e in plan.pairs}
    moves = []
    for j in range(len(t.bodies)):
        cols, a = [0] * ctx.nx, ends.get(j, -1)
        while a >= 0:
            for q in plan.coordinate_columns(a):     # (a quaternion joint's: all its coordinates)
                cols[q] = 1
            cols[ctx.nq + plan.row[a]] = 1
            a = plan.lam[a]
        moves.append(cols)
    pb = [[t.shapes[sa][0], t.shapes[sb][0]] for _, sa, sb, *_ in t.pairs]
    flags = t.noutput + t.ninput
    return [f"{IND * 2}static const unsigned char mv[{len(moves)}][{ctx.nx}] = {{"
            + ", ".join("{" + ", ".join(map(str, c)) + "}" for c in moves) + "};",
            f"{IND * 2}static const int pb[{len(pb)}][2] = {{" + ", ".join(f"{{{a}, {b}}}" for a, b in pb) + "};",
            f"{IND * 2}unsigned char on[{ctx.nx}] = {{0}};",
            f"{IND * 2}int j, c;",
            f"{IND * 2}for (kp = 0; kp < {len(pb)}; kp++)",
            f"{IND * 3}if (PT_[{flags} + kp] != 0.0)",
            f"{IND * 4}for (j = 0; j < 2; j++)",
            f"{IND * 5}if (pb[kp][j] >= 0) for (c = 0; c < {ctx.nx}; c++) on[c] |= mv[pb[kp][j]][c];"]


def analytic_jac_id_body(ctx, program, sym, shared=False):
    """``shared``: an[] from NAME_dyn_inputs instead of this body's own copy."""
    plan = sym.analytic
    pr = ctx.printer(program)
    lines = [f"{IND}double an[{plan.size}];"]
    if shared:
        lines += _shared_inputs(ctx)
    else:
        once, inner = _pair_split(program, sym)
        lines += temps(program, pr, once)
        lines += _inputs(program, pr)
        lines += _pair_columns(ctx, program, sym, pr, inner)
    lines += call_lines(ctx.name, plan, IND, "x", "udot", 0, "1.0", ctx.nx, ctx.nq)
    lines.append(f"{IND}return {ctx.name}_rd_finite(out, {ctx.nu * ctx.nx});")
    return lines


def _own_ud(sym, nq, nu, nx):
    """jac_x's kernel finds u' itself (articulated solve, no extra states): no ABA code here."""
    return sym.analytic.solver == "aba" and nx == nq + nu


def _jac_x_plan(program, W, G, nq, nu, nx, own=False, shared=False):
    """(temporaries, stores of u' into w, the kinematic and extra rows); ``shared``: an[] is
    NAME_dyn_inputs', so its temporaries are left out."""
    key = ("analytic_jac_x", tuple(W), tuple(G), nq, nu, nx, own, shared)
    plans = program.__dict__.setdefault("_jacobian_plans", {})
    if key not in plans:
        stores = [] if own else [(f"w[{k[1]}]", e) for k, e in program.results if k[0] == "ud"]
        kin = program.result_exprs("dkin")
        rows = [(f"out[{i * nx + k}]", kin.get(("dkin", i, k), sm.S.Zero)) for i in range(nq) for k in range(nx)]
        rows += _extra_rows(program, "dzd", nq + nu, nx, nx)
        anx = [] if shared else list(program.result_exprs(ANX).values())
        anx += list(program.result_exprs(TPW).values())      # the pairs' (block W): split off below
        exprs = [e for _, e in stores + rows] + anx
        if not own:
            exprs += list(program.result_exprs("Dpiv").values())
        plans[key] = (needed_assignments(program.assignments, exprs), stores, rows)
    return plans[key]


def _guarded(program, pr, assignments, readers, guards):
    """(C lines of ``assignments``, the printer for what follows): with the ground contacts'
    broad phase (``guards``, compiler/tree/contacts.body_guards with the world forces) when
    there is one -- a body clear of the ground skips its points' laws and slopes, which are
    then ±0, as the kernel's compare of each depth expects -- else plain temporaries.
    ``readers``: the expressions read after them."""
    if not guards:
        return temps(program, pr, assignments), pr
    roots = tuple((("r", i), e) for i, e in enumerate(readers))
    return guarded_temps(program.with_(assignments=tuple(assignments), results=roots), pr, guards)


def analytic_jac_x_body(ctx, program, sym, W, G, shared=False):
    """``shared``: an[] from NAME_dyn_inputs instead of this body's own copy (never with the
    contacts' guards: dynamics_kernel.inputs_users)."""
    plan = sym.analytic
    nq, nu, nx = ctx.nq, ctx.nu, ctx.nx
    own = _own_ud(sym, nq, nu, nx)
    once, stores, rows = _jac_x_plan(program, W, G, nq, nu, nx, own, shared)
    once, inner = _pair_split(program.with_(assignments=tuple(once)), sym)
    pr = ctx.printer(program)
    guards = getattr(sym, "jac_guards", ())
    anx = [] if shared else list(program.result_exprs(ANX).values())
    if own:
        head, pr = _guarded(program, pr, once, [e for _, e in rows + inner] + anx, guards)
        body, used = stores_zeroing_runs(rows, pr, "k")     # the coordinate rows: mostly zeros
        lines = [f"{IND}double an[{plan.size}];"] + ([f"{IND}int k;"] if used else [])
        lines += head
        lines += body
        lines += _shared_inputs(ctx) if shared else _inputs(program, pr)
        lines += _pair_columns(ctx, program, sym, pr, inner)
        lines += call_lines(ctx.name, plan, IND, "x", None, nq, "-1.0", nx, nq, 1)
        lines.append(f"{IND}return {ctx.name}_rd_finite(out, {nx * nx});")
        return lines
    before, after = split_on(program.with_(assignments=tuple(once)), W)
    readers = ([e for _, e in after + stores + rows + inner] + anx
               + [e for k, e in program.results if k[0] == "Dpiv"])
    head, pr = _guarded(program, pr, before, readers, guards)
    body, used = stores_zeroing_runs(rows, pr, "k")     # the coordinate rows: mostly zeros
    decls = [f"double w[{nu}];", f"double an[{plan.size}];"] + (["int k;"] if used else [])
    lines = [f"{IND}{d}" for d in decls]
    lines += head
    lines += singular_guard(program, pr)
    lines += [store(lv, e, pr) for lv, e in stores]
    lines += temps(program, pr, after)
    lines += body
    lines += _shared_inputs(ctx) if shared else _inputs(program, pr)
    lines += _pair_columns(ctx, program, sym, pr, inner)
    lines += call_lines(ctx.name, plan, IND, "x", "w", nq, "-1.0", nx, nq, 1)
    lines.append(f"{IND}return {ctx.name}_rd_finite(out, {nx * nx});")
    return lines


def analytic_body_ops(fn, program, sym, W, G, nq, nu, nx):
    """Operations of the bodies above: the straight-line part, the kernel (counted from its
    C, :func:`~.analytic.analytic_ops`, the solve included for jac_x)."""
    c = Counter(analytic_ops(sym.analytic, nq + nu if fn == "jac_x" else 0))
    if fn == "jac_id":
        for _, e in program.assignments:
            count_ops(e, c)
        for e in program.result_exprs(ANX).values():
            count_ops(e, c)
    else:
        once, stores, rows = _jac_x_plan(program, W, G, nq, nu, nx, _own_ud(sym, nq, nu, nx))
        for _, e in list(once) + stores + rows:
            count_ops(e, c)
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
