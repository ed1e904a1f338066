"""mass_matrix, forcing and inverse_dynamics as one C loop kernel over the tree (CRBA and RNEA).

Why: written straight-line, CRBA's mass matrix is one expression per pair of a joint and a
joint of its support: O(n·depth) code, 11.6 MB of C on a 200-link chain (half of that
model's default build, which took minutes and gigabytes), and on G1 the three functions
together were 1.6 times the rhs's code.  As C loops over tree arrays their code does not
grow with the model: only the straight-line inputs do, the same per-body inputs the analytic
derivatives read (``an[]``, :mod:`.analytic`: each body's rotation E and position r from its
parent, its joints' axes, mass and inertia, body-frame load -- joint laws' values included --,
gravity, armature), computed from the program's own slot expressions so the optimizer shares
their sines and cosines.

``NAME_dyn(an, u, ud, tau, M)`` (:func:`dynamics_kernel_c`) places the bodies in the world
(NAME_rd_place, the placement the derivative kernel and NAME_msolve call too; world-frame spatial algebra, as the analytic kernel: a joint's axis, once placed, serves
every body it moves), then

- with ``tau``: RNEA -- velocities v, accelerations a (gravity as the root's acceleration),
  forces f = Y a + v ×* (Y v) - load summed towards the root, τ_i = S_iᵀ f + armature_i·u'_i;
- with ``M``: CRBA -- composite inertias Yᶜ summed towards the root, M_ac = S_aᵀ Yᶜ_b S_c for a
  dof c of body b and every dof a of b and its support (both triangles), armature on the
  diagonal; entries of unrelated dofs are left as the caller zeroed them.

forcing is -τ at u' = 0, inverse_dynamics τ at the given u', mass_matrix M.  Used where the
analytic plan exists (an open tree whose loads the kernel can read, above
TANGENT_MIN_STATES states); elsewhere the straight-line recursions stay.  Checked against
the straight-line functions (tests/compiler/tree/test_dynamics_kernel.py).
"""
from .analytic import ANX, DOT6_LINE, YMUL_LINES, place_call, tree_tables, world_load_lines

__all__ = ["dynamics_kernel_c", "has_dynamics_kernel", "dynamics_body", "dynamics_inputs", "dynamics_ops",
           "inputs_users", "INPUTS_CALL",
           "KERNEL_FUNCTIONS", "forcing_by_inverse_dynamics", "inverse_dynamics_by_implicit"]

# NAME_dyn_inputs(t, x, p, r, an): the straight-line inputs, one copy for all users (inputs_users)
INPUTS_SIGNATURE = (("double", "t"), ("const double *", "x"), ("const double *", "p"), ("const double *", "r"),
                    ("double *", "an"))

KERNEL_FUNCTIONS = ("mass_matrix", "forcing", "inverse_dynamics")

# its call, as every user writes it (the users' t, x, p, r are the function's own arguments)
INPUTS_CALL = "{name}_dyn_inputs(t, x, p, r, an);"


def has_dynamics_kernel(program, sym, fn):
    """Is ``fn`` computed by NAME_dyn (the compiler's choice: lower.dynamics_kernel_functions)?"""
    return (fn in getattr(sym, "dynamics_kernel", ()) and getattr(sym, "analytic", None) is not None
            and any(k[0] == ANX for k, _ in program.results))



def dynamics_kernel_c(name, plan):
    """The C text of ``NAME_dyn`` and its two small helpers (see the module doc)."""
    nb, nd, o = plan.nb, plan.nd, plan.offsets
    fn = f"{name}_dyn"
    lines = [
        f"static void {name}_dyn_ymul(const double *y, const double *x, double *out)",
        "{   /* out = Y x, Y = {m, c (= m p), I_O (xx yy zz xy xz yz)} */",
        *YMUL_LINES,
        "}",
        "",
        f"static double {name}_dyn_dot(const double *a, const double *b)",
        "{",
        DOT6_LINE,
        "}",
        "",
        f"/* RNEA (tau: tau_i at velocities u, accelerations ud, per dof) and CRBA (M, {plan.nd} x {plan.nd}",
        "   row-major by speed) over the tree, world frame (compiler/tree/dynamics_kernel.py). */",
        f"static void {fn}(const double *an, const double *u, const double *ud, double *tau, double *M)"
        " EOMC_RD_SCALAR;   /* (analytic.SCALAR_MACRO, defined with NAME_rd_place) */",
        f"static void {fn}(const double *an, const double *u, const double *ud, double *tau, double *M)",
        "{",
        *tree_tables(plan),
        f"    double R[{9 * nb}], P[{3 * nb}], V[{6 * nb}], A[{6 * nb}], Y[{10 * nb}], F[{6 * nb}], Sw[{6 * nd}];",
        "    int b, i, e, c, l, a;",
        place_call(name),
        f"    for (b = 0; tau && b < {nb}; b++) {{   /* RNEA's forward pass */",
        "        double *vb = V + 6 * b, *ab = A + 6 * b, *Yb = Y + 10 * b" + (", *Rb = R + 9 * b, *pb = P + 3 * b;"
                                                                           if plan.loads else ";"),
        "        double t[6], hm[6];",
        "        l = par[b];",
        "        if (l >= 0) {",
        "            for (i = 0; i < 6; i++) {",
        "                vb[i] = V[6 * l + i];",
        "                ab[i] = A[6 * l + i];",
        "            }",
        "        } else {",
        "            for (i = 0; i < 3; i++) {",
        "                vb[i] = vb[i + 3] = ab[i] = 0.0;",
        f"                ab[i + 3] = -an[{o['g']} + i];",
        "            }",
        "        }",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* v += S u */",
        "            const double *s = Sw + 6 * e;",
        "            for (i = 0; i < 6; i++) vb[i] += s[i] * u[e];",
        "        }",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* a = a_parent + S u' + v x (S u) */",
        "            const double *s = Sw + 6 * e;",
        "            t[0] = vb[1] * s[2] - vb[2] * s[1];",
        "            t[1] = vb[2] * s[0] - vb[0] * s[2];",
        "            t[2] = vb[0] * s[1] - vb[1] * s[0];",
        "            t[3] = vb[1] * s[5] - vb[2] * s[4] + vb[4] * s[2] - vb[5] * s[1];",
        "            t[4] = vb[2] * s[3] - vb[0] * s[5] + vb[5] * s[0] - vb[3] * s[2];",
        "            t[5] = vb[0] * s[4] - vb[1] * s[3] + vb[3] * s[1] - vb[4] * s[0];",
        "            for (i = 0; i < 6; i++) ab[i] += s[i] * ud[e] + t[i] * u[e];",
        "        }",
        "        {   /* f = Y a + v x* (Y v) - load */",
        "            double *fb = F + 6 * b;",
        f"            {name}_dyn_ymul(Yb, vb, hm);",
        f"            {name}_dyn_ymul(Yb, ab, fb);",
        "            fb[0] += vb[1] * hm[2] - vb[2] * hm[1] + vb[4] * hm[5] - vb[5] * hm[4];",
        "            fb[1] += vb[2] * hm[0] - vb[0] * hm[2] + vb[5] * hm[3] - vb[3] * hm[5];",
        "            fb[2] += vb[0] * hm[1] - vb[1] * hm[0] + vb[3] * hm[4] - vb[4] * hm[3];",
        "            fb[3] += vb[1] * hm[5] - vb[2] * hm[4];",
        "            fb[4] += vb[2] * hm[3] - vb[0] * hm[5];",
        "            fb[5] += vb[0] * hm[4] - vb[1] * hm[3];",
    ]
    if plan.loads:
        lines += world_load_lines(o, pad="    ")
    lines += [
        "        }",
        "    }",
        f"    for (b = {nb - 1}; b >= 0; b--) {{",
        "        const double *Yb = Y + 10 * b, *fb = F + 6 * b;",
        "        double fa[6];",
        "        if (tau)",
        "            for (e = d0[b]; e < d0[b] + nd[b]; e++)",
        f"                tau[row[e]] = {name}_dyn_dot(Sw + 6 * e, fb) + an[{o['arm']} + e] * ud[e];",
        "        if (M)",
        "            for (c = d0[b]; c < d0[b] + nd[b]; c++) {",
        "                const int rc = row[c];",
        f"                {name}_dyn_ymul(Yb, Sw + 6 * c, fa);",
        "                for (e = d0[b]; e <= c; e++)   /* the joint's own block, both triangles alike */",
        f"                    M[row[e] * {nd} + rc] = M[rc * {nd} + row[e]] = {name}_dyn_dot(Sw + 6 * e, fa)"
        f" + (e == c ? an[{o['arm']} + c] : 0.0);",
        "                for (l = par[b]; l >= 0; l = par[l])",
        "                    for (a = d0[l]; a < d0[l] + nd[l]; a++)",
        f"                        M[row[a] * {nd} + rc] = M[rc * {nd} + row[a]] = {name}_dyn_dot(Sw + 6 * a, fa);",
        "            }",
        "        l = par[b];",
        "        if (l >= 0) {   /* composite inertia and force */",
        "            for (i = 0; i < 10; i++) Y[10 * l + i] += Yb[i];",
        "            if (tau)",
        "                for (i = 0; i < 6; i++) F[6 * l + i] += fb[i];",
        "        }",
        "    }",
        "}",
    ]
    return "\n".join(lines)


def inputs_users(sym, functions):
    """The functions of ``functions`` that call NAME_dyn_inputs rather than computing the
    kernels' inputs an[] themselves: the loop kernel's (always), and the analytic jac_x and
    jac_id (and jac_r solved by NAME_msolve) beside at least one other user (alone, each keeps its own copy: one function, one
    copy, and its C as it was).  Why: the inputs are most of the analytic derivatives' code
    (cart n = 80: ~84 of jac_x's 90 kB), so a default build carried them twice.  jac_x stays
    on its own copy when jac_x_batch rewrites its lines into lanes (compiler/emit/batch.py
    lanes the body it reads, not a static function it calls)."""
    if getattr(sym, "analytic", None) is None:
        return ()
    dyn = getattr(sym, "dynamics_kernel", ())
    if getattr(sym, "mass_inputs", ()):     # contacts: M's inputs only, for NAME_dyn's M and NAME_msolve
        return tuple(f for f in functions if f in dyn or (f == "jac_r" and getattr(sym, "input_solve", False)))
    if sym.analytic.npair:      # block W is filled per column from the pairs' taped call, in each body
        return ()
    # jac_x keeps its own copy beside the contacts' broad phase (its an[] reads guarded temporaries)
    lanes_or_guards = "jac_x_batch" in functions or getattr(sym, "jac_guards", ())
    derivs = ("jac_id",) if lanes_or_guards else ("jac_x", "jac_id")
    if getattr(sym, "input_solve", False):      # jac_r through NAME_msolve (.input_jacobian)
        derivs += ("jac_r",)
    users = [f for f in functions if f in dyn or f in derivs]
    return tuple(users) if len(users) > 1 or set(users) & set(dyn) else ()


def dynamics_inputs(ctx, program, sym, own=True):
    """("dyn_inputs", lines, signature) of NAME_dyn_inputs: the kernel's inputs an[] from the
    program's own expressions (straight-line; every user calls it, so its code is there once:
    on a 80-link cart it is a third of the rhs's).  ``own``: the program is a kernel function's,
    all of whose temporaries feed an[]; else (jac_x's, jac_id's) only those an[] reads."""
    from ..emit.bodies import needed_assignments, store, temps
    from .law_loop import law_loops
    pr = ctx.printer(program)
    vals = program.result_exprs(ANX)
    assignments = program.assignments if own else needed_assignments(program.assignments, vals.values())
    loops = law_loops(ctx.name, sym.analytic, pr, program, assignments, vals)
    if loops is not None:       # the laws' slopes by shape (.law_loop): their temporaries left out
        rest = {k: e for k, e in vals.items() if k[1] not in loops[2]}
        drop = ({s for s, _ in needed_assignments(program.assignments, vals.values())}
                - {s for s, _ in needed_assignments(program.assignments, rest.values())})
        assignments, vals = [(s, e) for s, e in assignments if s not in drop], rest
    lines = temps(program, pr, assignments)
    lines += [store(f"an[{k[1]}]", e, pr) for k, e in sorted(vals.items(), key=lambda kv: kv[0][1])]
    if loops is None:
        return "dyn_inputs", lines, INPUTS_SIGNATURE
    return "dyn_inputs", lines + loops[0], INPUTS_SIGNATURE, loops[1]


def dynamics_body(ctx, program, sym, fn):
    """mass_matrix, forcing or inverse_dynamics: the kernel's inputs an[] (NAME_dyn_inputs),
    then one NAME_dyn call."""
    from ..emit.bodies import IND
    plan = sym.analytic
    nq, nu = ctx.nq, ctx.nu
    lines = [f"{IND}double an[{plan.size}];"]
    if fn == "mass_matrix":
        lines.append(f"{IND}int k;")
    else:
        lines += [f"{IND}static const int sp[{plan.nd}] = {{{', '.join(str(s) for s in plan.row)}}};",
                  f"{IND}double u[{plan.nd}], ud[{plan.nd}], tq[{nu}];", f"{IND}int e;"]
    lines.append(IND + INPUTS_CALL.format(name=ctx.name))
    if fn == "mass_matrix":
        lines += [f"{IND}for (k = 0; k < {nu * nu}; k++) out[k] = 0.0;",
                  f"{IND}{ctx.name}_dyn(an, NULL, NULL, NULL, out);",
                  f"{IND}return {ctx.name}_finite(out, {nu * nu});"]
        return lines
    acc = "udot[sp[e]]" if fn == "inverse_dynamics" else "0.0"
    lines += [f"{IND}for (e = 0; e < {plan.nd}; e++) {{",
              f"{IND * 2}u[e] = x[{nq} + sp[e]];",
              f"{IND * 2}ud[e] = {acc};",
              f"{IND}}}",
              f"{IND}{ctx.name}_dyn(an, u, ud, tq, NULL);"]
    if fn == "inverse_dynamics":
        lines += [f"{IND}for (e = 0; e < {nu}; e++) tau[e] = tq[e];",
                  f"{IND}return {ctx.name}_finite(tau, {nu});"]
    else:
        lines += [f"{IND}for (e = 0; e < {nu}; e++) out[e] = -tq[e];",
                  f"{IND}return {ctx.name}_finite(out, {nu});"]
    return lines


def forcing_by_inverse_dynamics(ctx):
    """forcing as -inverse_dynamics at u' = 0, one call (where both are straight-line RNEA: its
    code once; the call costs ~3 % over forcing's own copy, G1 1414 vs 1375 ns, while the copy
    was 150 kB of C and a second of G1's build, benchmarks/results/dynamics_kernel.md)."""
    from ..emit.bodies import IND
    nu = ctx.nu
    return [f"{IND}double ud0[{nu}];",
            f"{IND}int k, status;",
            f"{IND}for (k = 0; k < {nu}; k++) ud0[k] = 0.0;",
            f"{IND}status = {ctx.name}_inverse_dynamics(t, x, ud0, p, r, out, work);",
            f"{IND}for (k = 0; k < {nu}; k++) out[k] = -out[k];",
            f"{IND}return status;"]


def inverse_dynamics_by_implicit(ctx, layout):
    """inverse_dynamics as τ = M u' - f from NAME_implicit's M and f (``layout``: its out[]
    offsets, compiler/tree/lower.implicit_layout), one call, where the tree has contacts.

    Why: there RNEA's straight-line τ carried the contacts' and pairs' forces again (gymnasium
    humanoid 163 kB of C, ant 102 kB: a second of gcc and of generation each, issue 33's
    build bar), while NAME_implicit computes M and f with them for the fixed-step methods.
    The call costs NAME_implicit's time (its slopes too), not RNEA's: inverse_dynamics is not
    on an integrator's path.  Equal to RNEA to rounding (tests/compiler/tree/test_dynamics_kernel.py)."""
    from ..emit.bodies import IND
    nu, m, f = ctx.nu, layout["M"], layout["f"]
    return [f"{IND}double im[{layout['size']}];",
            f"{IND}int i, j, status;",
            f"{IND}status = {ctx.name}_implicit(t, x, p, r, im, work);",
            f"{IND}if (status) return status;",
            f"{IND}for (i = 0; i < {nu}; i++) {{",
            f"{IND * 2}double s = -im[{f} + i];",
            f"{IND * 2}for (j = 0; j < {nu}; j++) s += im[{m} + {nu} * i + j] * udot[j];",
            f"{IND * 2}tau[i] = s;",
            f"{IND}}}",
            f"{IND}return {ctx.name}_finite(tau, {nu});"]


def dynamics_ops(plan, fn):
    """Floating-point operations of one NAME_dyn call (counted from the C above, multiply-adds
    as one mul and one add): per body ~110 (placement, world inertia), per dof ~25 (its axis);
    RNEA ~120 per body and ~45 per dof more; CRBA ~36 per dof and 11 per (dof, support dof) pair."""
    pairs = sum(plan.dep)
    muls = 110 * plan.nb + 25 * plan.nd
    adds = 100 * plan.nb + 22 * plan.nd
    if fn == "mass_matrix":
        muls += 36 * plan.nd + 6 * (pairs + plan.nd) + 10 * plan.nb
        adds += 30 * plan.nd + 5 * (pairs + plan.nd) + 10 * plan.nb
    else:
        muls += 60 * plan.nb + 45 * plan.nd
        adds += 60 * plan.nb + 40 * plan.nd
    return {"adds": adds, "muls": muls, "divs": 0, "calls": 0}
