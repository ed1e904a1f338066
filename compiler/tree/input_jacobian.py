"""jac_r (d xdot / d inputs) through a C loop solve of M, where the analytic plan exists.

Why: jac_r's speed rows are M⁻¹ B, B = ∂τ/∂r the inputs' generalized forces (written
directly for joint-torque inputs, :func:`.lower._input_columns`: constants, mostly a 1 on the
driven joint's row).  The straight-line path built ABA's articulated inertias and the
per-column articulated solve as expressions of the state: 211-230 kB of C on G1, Talos and
the 80-link cart, a third of the default build's code, plus the residual's RNEA and solve in
the symbolic program.  Here the solve is one static C function, ``NAME_msolve`` (:func:`msolve_c`),
whose code does not grow with the model: it reads the kernels' inputs ``an[]`` (each body's
placement, axes, inertia, armature: the same block NAME_dyn_inputs computes once for jac_x,
jac_id and the loop-kernel functions, :mod:`.dynamics_kernel`), places the bodies in the
world (NAME_rd_place, :func:`.analytic.place_c`), factors M the articulated-body way (per dof U = IA s, D = sᵀ U + armature, IA -= U Uᵀ/D,
summed towards the root: no matrix stored, O(n) memory), then solves the columns with one
backward and one forward sweep per LANES of them (a loop over column blocks running the same
code; the block's columns share each dof's s, U, D: a vector register's worth of work per
load, which a column at a time made jac_r 2x slower per call than the straight-line solve on G1).

So jac_r is a few lines: its coordinate rows and B's entries stored (zero runs as loops), the
inputs, one call.  B's entries are the direct columns where the inputs act through joint
torques, else the residual's derivative along each input (the derivative pass: a force on a
body of a SymPy system, as the n-link cart's; there the residual is still built, but only B
is printed).  Used when the tree has the analytic plan (jac_x or jac_id or the loop kernel
asked it) and no extra first-order states; elsewhere jac_r keeps the straight-line path
(:mod:`.emit`).  With ground contacts or body-body pairs jac_r reads M's inputs alone (the
contact terms of an[] are the analytic jac_x's, on its own guarded copy;
:func:`.lower.contact_mass_inputs`), shared with the mass matrix's NAME_dyn.  Checked against that path to ~1e-12
(tests/compiler/tree/test_input_columns.py)."""
import sympy as sm

from .analytic import ANX, ARTICULATED_START_LINES, DOT6_LINE, IO_FROM_Y_LINES, place_call, tree_tables

# columns solved together: the tree's data (s, U, D per dof) read once per block; measured on G1
# (29 columns, 2026-11-29): 8 lanes 12.5 us a jac_r call, 4 lanes 14.5, one 26; the straight-line
# solve it replaced 13.5.  Fewer columns, fewer lanes (lanes_for): each lane is work.
LANES = 8


def lanes_for(ncol):
    """The block width of NAME_msolve for ``ncol`` columns: the smallest power of two that
    holds them, at most LANES."""
    lanes = 1
    while lanes < min(ncol, LANES):
        lanes *= 2
    return lanes

__all__ = ["lanes_for", "uses_input_solve", "msolve_c", "input_jacobian_body", "input_jacobian_ops", "INPUT_SOLVE_GROUPS"]

# jac_r's result groups on this path: the kinematic rows, B's entries, the kernels' inputs
INPUT_SOLVE_GROUPS = ("dkin_r", "dres_r", "dzd_r", ANX)


def uses_input_solve(plan, functions, nx, nq, nu):
    """Does jac_r solve through NAME_msolve (see the module doc)?"""
    return plan is not None and "jac_r" in functions and nx == nq + nu


def msolve_c(name, plan, lanes=LANES):
    """The C text of ``NAME_msolve(an, out, stride, row0, ncol)``: the rows ``row0 + speed``
    of ``out`` (``stride`` doubles apart) hold ``ncol`` right-hand sides in their first ``ncol``
    entries, replaced by M⁻¹ of them.  Returns EOMC_SINGULAR_MASS_MATRIX when an articulated
    inertia it divides by is not positive (as every function built on ABA), else 0.  ``lanes``:
    columns per block (:func:`lanes_for` of jac_r's inputs)."""
    nb, nd, o = plan.nb, plan.nd, plan.offsets
    return "\n".join([
        f"static double {name}_ms_dot(const double *a, const double *b)",
        "{",
        DOT6_LINE,
        "}",
        "",
        "/* out's speed rows <- M^-1 of them, on ncol columns (compiler/tree/input_jacobian.py):",
        "   M factored the articulated-body way from the kernels' inputs an[], then per block of",
        f"   {lanes} columns one sweep to the root (bias messages) and one to the leaves (accelerations). */",
        f"static int {name}_msolve(const double *an, double *out, int stride, int row0, int ncol)",
        "{",
        *tree_tables(plan),
        f"    double R[{9 * nb}], P[{3 * nb}], Y[{10 * nb}], Sw[{6 * nd}], IA[{36 * nb}], Ua[{6 * nd}], Di[{nd}];",
        f"    double Pb[{6 * lanes * nb}], yb[{lanes * nd}];   /* Pb: the messages p, then the accelerations a */",
        "    int b, i, j, e, l, c, c0, nc;",
        place_call(name),
        f"    for (b = 0; b < {nb}; b++) {{   /* each body's own 6x6 inertia, the articulated start */",
        "        const double *Yb = Y + 10 * b;",
        "        double IO[9];",
        *IO_FROM_Y_LINES,
        "        {",
        *ARTICULATED_START_LINES,
        "        }",
        "    }",
        f"    for (b = {nb - 1}; b >= 0; b--) {{   /* articulated inertias to the root: U, 1/D per dof */",
        "        double *Ib = IA + 36 * b;",
        "        for (e = d0[b] + nd[b] - 1; e >= d0[b]; e--) {",
        "            const double *s = Sw + 6 * e;",
        "            double *Ue = Ua + 6 * e, d;",
        "            for (i = 0; i < 6; i++)",
        "                Ue[i] = Ib[6 * i] * s[0] + Ib[6 * i + 1] * s[1] + Ib[6 * i + 2] * s[2]"
        " + Ib[6 * i + 3] * s[3] + Ib[6 * i + 4] * s[4] + Ib[6 * i + 5] * s[5];",
        f"            d = {name}_ms_dot(s, Ue) + an[{o['arm']} + e];",
        "            if (!(d > 0.0)) return EOMC_SINGULAR_MASS_MATRIX;",
        "            Di[e] = 1.0 / d;",
        "            for (i = 0; i < 6; i++)",
        "                for (j = 0; j < 6; j++) Ib[6 * i + j] -= Ue[i] * Ue[j] * Di[e];",
        "        }",
        "        if (par[b] >= 0)",
        "            for (i = 0; i < 36; i++) IA[36 * par[b] + i] += Ib[i];",
        "    }",
        f"    for (c0 = 0; c0 < ncol; c0 += {lanes}) {{   /* {lanes} columns at a time: one pass of the tree serves them */",
        f"        nc = ncol - c0 < {lanes} ? ncol - c0 : {lanes};",
        f"        for (e = 0; e < {nd}; e++)",
        f"            for (c = 0; c < {lanes}; c++) yb[{lanes} * e + c] = c < nc ? out[(row0 + row[e]) * stride + c0 + c] : 0.0;",
        f"        for (i = 0; i < {6 * lanes * nb}; i++) Pb[i] = 0.0;",
        f"        for (b = {nb - 1}; b >= 0; b--) {{   /* u = y - S.p, the parent's p += p + U u / D */",
        f"            double *p = Pb + {6 * lanes} * b;",
        "            for (e = d0[b] + nd[b] - 1; e >= d0[b]; e--) {",
        "                const double *s = Sw + 6 * e, *U = Ua + 6 * e;",
        f"                double *y = yb + {lanes} * e, w[{lanes}];",
        f"                for (c = 0; c < {lanes}; c++) {{",
        f"                    y[c] -= s[0] * p[c] + s[1] * p[{lanes} + c] + s[2] * p[{2 * lanes} + c]"
        f" + s[3] * p[{3 * lanes} + c] + s[4] * p[{4 * lanes} + c] + s[5] * p[{5 * lanes} + c];",
        "                    w[c] = y[c] * Di[e];",
        "                }",
        "                for (i = 0; i < 6; i++)",
        f"                    for (c = 0; c < {lanes}; c++) p[{lanes} * i + c] += U[i] * w[c];",
        "            }",
        "            if (par[b] >= 0)",
        f"                for (i = 0; i < {6 * lanes}; i++) Pb[{6 * lanes} * par[b] + i] += p[i];",
        "        }",
        f"        for (b = 0; b < {nb}; b++) {{   /* x = (u - U.a_parent) / D, a = a_parent + S x */",
        f"            double *a = Pb + {6 * lanes} * b;",
        "            l = par[b];",
        f"            for (i = 0; i < {6 * lanes}; i++) a[i] = l >= 0 ? Pb[{6 * lanes} * l + i] : 0.0;",
        "            for (e = d0[b]; e < d0[b] + nd[b]; e++) {",
        "                const double *s = Sw + 6 * e, *U = Ua + 6 * e;",
        f"                double *y = yb + {lanes} * e;",
        f"                for (c = 0; c < {lanes}; c++)",
        f"                    y[c] = (y[c] - (U[0] * a[c] + U[1] * a[{lanes} + c] + U[2] * a[{2 * lanes} + c]"
        f" + U[3] * a[{3 * lanes} + c] + U[4] * a[{4 * lanes} + c] + U[5] * a[{5 * lanes} + c])) * Di[e];",
        "                for (i = 0; i < 6; i++)",
        f"                    for (c = 0; c < {lanes}; c++) a[{lanes} * i + c] += s[i] * y[c];",
        "            }",
        "        }",
        f"        for (e = 0; e < {nd}; e++)",
        f"            for (c = 0; c < nc; c++) out[(row0 + row[e]) * stride + c0 + c] = yb[{lanes} * e + c];",
        "    }",
        "    return 0;",
        "}",
    ])


def _rows(program, nq, nu, nr):
    kin = program.result_exprs("dkin_r")
    vals = program.result_exprs("dres_r")
    rows = [(f"out[{i * nr + k}]", kin.get(("dkin_r", i, k), sm.S.Zero)) for i in range(nq) for k in range(nr)]
    rows += [(f"out[{(nq + i) * nr + k}]", vals.get(("dres_r", i, k), sm.S.Zero))
             for i in range(nu) for k in range(nr)]
    return rows


def input_jacobian_body(ctx, program, sym, nr, shared):
    """jac_r's C body: the coordinate rows and B stored, the inputs an[] (``shared``: from
    NAME_dyn_inputs), then NAME_msolve on B's nr columns in place."""
    from ..emit.bodies import IND, needed_assignments, store, temps
    from .emit import stores_zeroing_runs
    nq, nu, nx = ctx.nq, ctx.nu, ctx.nx
    plan = sym.analytic
    rows = _rows(program, nq, nu, nr)
    anx = sorted(program.result_exprs(ANX).items(), key=lambda kv: kv[0][1])
    exprs = [e for _, e in rows] + ([] if shared else [e for _, e in anx])
    pr = ctx.printer(program)
    body, used = stores_zeroing_runs(rows, pr, "k")
    lines = [f"{IND}double an[{plan.size}];", f"{IND}int status;"] + ([f"{IND}int k;"] if used else [])
    lines += temps(program, pr, needed_assignments(program.assignments, exprs))
    lines += body
    if shared:
        from .dynamics_kernel import INPUTS_CALL
        lines.append(IND + INPUTS_CALL.format(name=ctx.name))
    else:
        lines += [store(f"an[{k[1]}]", e, pr) for k, e in anx]
    lines += [f"{IND}status = {ctx.name}_msolve(an, out, {nr}, {nq}, {nr});",
              f"{IND}if (status) return status;",
              f"{IND}return {ctx.name}_finite(out, {nx * nr});"]
    return lines


def msolve_ops(plan, ncol):
    """Operations of one NAME_msolve call on ``ncol`` columns (counted from the C above,
    multiply-adds as one mul and one add): per body ~110 (placement, world inertia), per dof
    ~25 (its axis) and ~130 (U, D, the 6x6 update), per body 36 adds (IA to the parent); per
    column and dof 24 muls and 24 adds, per column and body 12 adds."""
    muls = 110 * plan.nb + 155 * plan.nd + ncol * 24 * plan.nd
    adds = 100 * plan.nb + 36 * plan.nb + 110 * plan.nd + ncol * (24 * plan.nd + 12 * plan.nb)
    return {"adds": adds, "muls": muls, "divs": plan.nd, "calls": 0}


def input_jacobian_ops(program, sym, nq, nu, nr):
    """Operations of :func:`input_jacobian_body`: its stores and their temporaries, the
    inputs, the solve."""
    from collections import Counter
    from ..emit.bodies import needed_assignments
    from ..ir.opcount import count_ops
    c = Counter(msolve_ops(sym.analytic, nr))
    exprs = [e for _, e in _rows(program, nq, nu, nr)] + list(program.result_exprs(ANX).values())
    for _, e in needed_assignments(program.assignments, exprs):
        count_ops(e, c)
    for e in exprs:
        count_ops(e, c)
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
