"""jvp of the recursive formulation: xdot and k directional derivatives J·d in one call.

As the recursive jac_x (see :mod:`.derivatives`), but along given directions
d = [dx; dp] instead of unit columns: ABA's u' once, then per direction the
tangent of RNEA's residual along dx (one O(n) tangent program, the state
seeds pointing at the direction), plus the unrolled parameter columns times
dp (computed only when some direction has a parameter part), and M⁻¹ by the
articulated-body recursion on ABA's factors.  J is never formed: k directions
cost O(k n), where jac_x costs O(n²).  Forward sensitivities use it.
"""
import sympy as sm

from ..emit.bodies import IND, store, temps, needed_assignments, split_on

__all__ = ["tree_jvp_body"]


def tree_jvp_body(ctx, program, W, G, seeds, nx, npar):
    nq, nu = ctx.nq, ctx.nu
    nd = nx + npar
    pr = ctx.printer(program)
    for j, g in enumerate(G):
        pr._names[g] = f"G[{j}]"
    for j, s in enumerate(W[nu:]):      # a closed tree's λ after u' (constrained.jacobian_symbols)
        pr._names[s] = f"w[{nu + j}]"
    ng = len(G)                         # nu, or nu + m rows on a closed tree
    first = nq + nu                      # the extra first-order states' rows follow
    gp = {k: e for k, e in program.result_exprs("dres_p").items() if e != 0}
    kp = {k: e for k, e in program.result_exprs("dkin_p").items() if e != 0}
    kp.update({("dkin_p", first + k[1], k[2]): e for k, e in program.result_exprs("dzd_p").items() if e != 0})
    pexprs = list(gp.values()) + list(kp.values())
    others = [e for key, e in program.results if key[0] not in ("dres_p", "dkin_p", "dzd_p")]
    p_only = ({t for t, _ in needed_assignments(program.assignments, pexprs)}
              - {t for t, _ in needed_assignments(program.assignments, others)})
    main = program.with_(assignments=tuple(a for a in program.assignments if a[0] not in p_only))
    once, rest = split_on(main, tuple(seeds) + tuple(G))
    before, after = split_on(main.with_(assignments=tuple(once)), W)
    tangent = program.result_exprs("tjv")
    sol = {k[1]: e for k, e in program.results if k[0] == "sol"}
    inner = needed_assignments(rest, tangent.values())
    solve = needed_assignments(rest, sol.values())
    solve = [a for a in solve if a not in inner] if inner else solve
    slot = {key: j for j, key in enumerate(sorted(gp) + sorted(kp))}
    decls = [f"double w[{len(W)}];", f"double G[{ng}];", "const double *dx;", "int i, d;"]
    if slot:
        decls += ["const double *dp;", f"double Gp[{len(slot)}] = {{0.0}};   /* set when a direction has a parameter part */", "int anyp = 0;"]
    lines = [f"{IND}{x}" for x in decls]
    lines += temps(program, pr, before)
    pivots = [pr.doprint(e) for k, e in program.results if k[0] == "Dpiv"]
    if pivots:
        lines.append(f"{IND}if ({' || '.join(f'!({d} > 0.0)' for d in pivots)}) "
                     f"return EOMC_SINGULAR_MASS_MATRIX;")
    ud = program.result_exprs("ud")
    lines += [store(f"w[{j}]", ud[("ud", j)], pr) for j in range(nu)]
    lam = program.result_exprs("lam")
    lines += [store(f"w[{nu + j}]", lam[("lam", j)], pr) for j in range(len(W) - nu)]
    lines += temps(program, pr, after)
    kin = program.result_exprs("kin")
    lines += [store(f"xdot[{i}]", kin.get(("kin", i), sm.S.Zero), pr) for i in range(nq)]
    lines += [f"{IND}xdot[{nq + j}] = w[{j}];" for j in range(nu)]
    zd = program.result_exprs("zd")
    lines += [store(f"xdot[{first + i}]", zd.get(("zd", i), sm.S.Zero), pr) for i in range(nx - first)]
    if slot:
        lines += [f"{IND}for (d = 0; d < k && !anyp; d++)",
                  f"{IND * 2}for (i = 0; i < {npar}; i++) if (dirs[(size_t)d * {nd} + {nx} + i] != 0.0) anyp = 1;",
                  f"{IND}if (anyp) {{"]
        lines += [IND + x for x in temps(program, pr, [a for a in program.assignments if a[0] in p_only])]
        lines += [IND + store(f"Gp[{j}]", (gp if key[0] == "dres_p" else kp)[key], pr)
                  for key, j in slot.items()]
        lines.append(f"{IND}}}")
    dkin = program.result_exprs("dkin")
    dkin.update({("dkin", first + k[1], k[2]): e for k, e in program.result_exprs("dzd").items()})
    body = ["{"] + [x[len(IND):] for x in temps(program, pr, inner)]
    body += [f"G[{i}] = {pr.doprint(tangent.get(('tjv', i), sm.S.Zero))};" for i in range(ng)]
    body.append("}")
    if gp:
        body += ["if (anyp) {", f"{IND}dp = dx + {nx};"]
        body += [f"{IND}G[{key[1]}] += Gp[{slot[key]}] * dp[{key[2]}];" for key in sorted(gp)]
        body.append("}")
    body.append("{")
    body += [x[len(IND):] for x in temps(program, pr, solve)]
    body += [f"out[(size_t)d * {nx} + {nq + i}] = {pr.doprint(sol.get(i, sm.S.Zero))};" for i in range(nu)]
    body.append("}")
    for i in list(range(nq)) + list(range(first, nx)):
        terms = [f"({pr.doprint(dkin[('dkin', i, c)])}) * dx[{c}]" for c in range(nx)
                 if dkin.get(("dkin", i, c), 0) != 0]
        terms += [f"(anyp ? Gp[{slot[key]}] * dx[{nx + key[2]}] : 0.0)" for key in sorted(kp) if key[1] == i]
        body.append(f"out[(size_t)d * {nx} + {i}] = {' + '.join(terms) or '0.0'};")
    lines.append(f"{IND}for (d = 0; d < k; d++) {{")
    lines.append(f"{IND * 2}dx = dirs + (size_t)d * {nd};")
    lines += [IND * 2 + x for x in body]
    lines.append(f"{IND}}}")
    lines.append(f"{IND}i = {ctx.name}_finite(xdot, {nx});")
    lines.append(f"{IND}if (i != EOMC_OK || k <= 0) return i;")
    lines.append(f"{IND}return {ctx.name}_finite(out, k * {nx});")
    return lines
