"""jvp of the recursive formulation: xdot and k directional derivatives J·d in one call.

As the recursive jac_x (see :mod:`.derivatives`), but along given directions
d = [dx; dp] instead of unit columns: ABA's u' once, then per direction the
tangent of RNEA's residual along dx (one O(n) tangent program, the state
seeds pointing at the direction), plus the parameter columns of the direction's
nonzero parameter entries (one column for a sensitivity's e_j), and M⁻¹ by the
articulated-body recursion on ABA's factors.  J is never formed: k directions
cost O(k n), where jac_x costs O(n²).  Forward sensitivities use it.
"""

import re

import sympy as sm

from ..emit.bodies import IND, LANES, parameter_directions, store, temps, needed_assignments, split_on

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
    gp = program.result_exprs("dres_p")
    kp = program.result_exprs("dkin_p")
    kp.update({("dkin_p", first + k[1], k[2]): e for k, e in program.result_exprs("dzd_p").items()})
    pcols, p_only, psetup, function = parameter_directions(program, pr, gp, kp, nx, npar,
                                                           f"{ctx.name}_jvp_pcols",
                                                           ("dres_p", "dkin_p", "dzd_p"))
    if function:
        ctx.parts.append(function)
    main = program.with_(assignments=tuple(a for a in program.assignments if a[0] not in p_only))
    once, rest = split_on(main, tuple(seeds) + tuple(G))
    before, after = split_on(main.with_(assignments=tuple(once)), W)
    tangent = program.result_exprs("tjv")
    sol = {k[1]: e for k, e in program.results if k[0] == "sol"}
    inner = needed_assignments(rest, tangent.values())
    solve = needed_assignments(rest, sol.values())
    solve = [a for a in solve if a not in inner] if inner else solve
    decls = [f"double w[{len(W)}];", f"double G[{ng}];", "const double *dx;", "int i, d;"]
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
    dkin = program.result_exprs("dkin")
    dkin.update({("dkin", first + k[1], k[2]): e for k, e in program.result_exprs("dzd").items()})
    lines += [IND + x for x in psetup]
    kin = []
    for i in list(range(nq)) + list(range(first, nx)):
        terms = [f"({pr.doprint(dkin[('dkin', i, c)])}) * dx[{c}]" for c in range(nx)
                 if dkin.get(("dkin", i, c), 0) != 0]
        kin.append(f"out[(size_t)d * {nx} + {i}] = {' + '.join(terms) or '0.0'};")
    scalar = ["{"] + [x[len(IND):] for x in temps(program, pr, inner)]
    scalar += [f"G[{i}] = {pr.doprint(tangent.get(('tjv', i), sm.S.Zero))};" for i in range(ng)]
    scalar.append("}")
    tail = pcols + ["{"] + [x[len(IND):] for x in temps(program, pr, solve)]
    tail += [f"out[(size_t)d * {nx} + {nq + i}] = {pr.doprint(sol.get(i, sm.S.Zero))};" for i in range(nu)]
    tail.append("}")
    if (inner and all(not pr._names[t].endswith("]") for t, _ in inner + solve)
            and not any(_ROUTINE_OUTPUTS.match(x) for x in temps(program, pr, inner + solve))):
        # (not when a routine's outputs are arrays the temporaries declare -- the pair table's
        # tangent call: the lanes write each temporary as a scalar and would lose the declaration)
        # the tangent and the articulated-body solve LANES directions at a time
        more, loop = _lanes(pr, seeds, G, nx, nd, nq, nu, ng, inner, tangent, solve, sol, kin, pcols,
                            scalar + tail)
        lines[len(decls):len(decls)] = [f"{IND}{x}" for x in more]
        lines += loop
    else:
        lines.append(f"{IND}for (d = 0; d < k; d++) {{")
        lines.append(f"{IND * 2}dx = dirs + (size_t)d * {nd};")
        lines += [IND * 2 + x for x in kin + scalar + tail]
        lines.append(f"{IND}}}")
    lines.append(f"{IND}i = {ctx.name}_finite(xdot, {nx});")
    lines.append(f"{IND}if (i != EOMC_OK || k <= 0) return i;")
    lines.append(f"{IND}return {ctx.name}_finite(out, k * {nx});")
    return lines


_ROUTINE_OUTPUTS = re.compile(r"\s*double \w+\[\d+\];")


def _lanes(pr, seeds, G, nx, nd, nq, nu, ng, inner, tangent, solve, sol, kin, pcols, single):
    """The loop over the directions with the tangent and the solve (M⁻¹ by the articulated-
    body recursion on ABA's factors) carried LANES directions at a time, as
    :func:`eomc.compiler.emit.bodies.lane_directions` does for Kane's tangent: one loop over
    the lanes around each chain, which the C compiler vectorizes; the solve is most of a
    recursive direction's cost.  Per direction first, the state rows and the parameter
    columns (into PT, added to the tangent's rows), long before the lanes' vector loads read
    them; a lone direction runs ``single`` (the scalar tangent, columns and solve).  Lanes
    past k repeat the group's last direction and are dropped."""
    names = dict(pr._names)
    names.update({sd: f"XT[{j}][ln]" for j, sd in enumerate(seeds)})
    names.update({g: f"GT[{j}][ln]" for j, g in enumerate(G)})
    lp = type(pr)(names)
    per = [f"dx = dirs + (size_t)d * {nd};"] + kin
    if pcols:       # the columns' function adds into G: zeroed before, copied into PT after
        per += [f"for (i = 0; i < {ng}; i++) G[i] = 0.0;"] + pcols
        per.append(f"for (i = 0; i < {ng}; i++) PT[i][ln] = G[i];")
    group = [f"for (i = 0; i < {ng}; i++) for (ln = 0; ln < {LANES}; ln++) PT[i][ln] = 0.0;",
             "for (ln = 0; ln < nl; ln++, d++) {"] + [IND + x for x in per] + ["}", "d -= nl;"]
    group += ["{",
              f"{IND}const double *D0 = dirs + (size_t)d * {nd}, *D1 = D0 + {nd};",
              f"{IND}const double *D2 = nl > 2 ? D1 + {nd} : D1, *D3 = nl > 3 ? D2 + {nd} : D2;",
              f"{IND}for (i = 0; i < {nx}; i++) {{",
              f"{IND * 2}XT[i][0] = D0[i]; XT[i][1] = D1[i]; XT[i][2] = D2[i]; XT[i][3] = D3[i];",
              f"{IND}}}", "}"]
    group.append(f"for (ln = 0; ln < {LANES}; ln++) {{")
    group += [f"{IND}const double {names[t]} = {lp.doprint(e)};" for t, e in inner]
    group += [f"{IND}GT[{i}][ln] = PT[{i}][ln] + ({lp.doprint(tangent.get(('tjv', i), sm.S.Zero))});"
              for i in range(ng)]
    group.append("}")
    group.append(f"for (ln = 0; ln < {LANES}; ln++) {{")
    group += [f"{IND}const double {names[t]} = {lp.doprint(e)};" for t, e in solve]
    group += [f"{IND}OT[{i}][ln] = {lp.doprint(sol.get(i, sm.S.Zero))};" for i in range(nu)]
    group.append("}")
    group += ["for (ln = 0; ln < nl; ln++, d++)",
              f"{IND}for (i = 0; i < {nu}; i++) out[(size_t)d * {nx} + {nq} + i] = OT[i][ln];",
              "continue;"]
    lines = [f"{IND}for (d = 0; d < k; ) {{",
             f"{IND * 2}nl = k - d < {LANES} ? k - d : {LANES};",
             f"{IND * 2}if (nl > 1) {{"] + [IND * 3 + x for x in group] + [f"{IND * 2}}}"]
    lines += [IND * 2 + x for x in [f"dx = dirs + (size_t)d * {nd};"] + kin + single]
    lines += [f"{IND * 2}d++;", f"{IND}}}"]
    decls = [f"double XT[{nx}][{LANES}];", f"double GT[{ng}][{LANES}];", f"double PT[{ng}][{LANES}];",
             f"double OT[{max(nu, 1)}][{LANES}];", "int ln, nl;"]
    return decls, lines
