"""vjp and hvp: reverse mode on the straight-line program, for both formulations.

Both formulations write xdot = [kin(x); w; zd(x)] with the accelerations w solving a
residual that is linear in them, res(x, W) = 0 at W = w, ∂res/∂W = -M (Kane's
res = b - A·W; the recursive formulation's res = -RNEA(q, u, W)).  So for a weight
vector λ = [λ_q; λ_u; λ_z]:

    λᵀ ∂xdot/∂x = λ_qᵀ ∂kin/∂x + λ_zᵀ ∂zd/∂x + μᵀ ∂res/∂x,    M μ = λ_u (M symmetric),

one solve and **one reverse sweep** of the weighted sum L = λ_qᵀ kin + λ_zᵀ zd + μᵀ res
over the CSE'd program (:func:`~eomc.compiler.passes.adjoint`), for all states and
parameters at once: ``NAME_vjp``.

``NAME_hvp`` is the directional second derivative of λᵀ xdot, (∂²(λᵀ xdot)/∂x²)·v, by
forward over reverse.  With L(x, W, μ) as above (plus λ_uᵀ W) stationary in W and μ,

    H v = L_xx v + L_xW ẇ + ∂resᵀ/∂x ν,   ẇ = M⁻¹ ∂res/∂x v,   M ν = L_Wx v + L_WW ẇ

(L_WW = 0: res is linear in W).  So: the reverse sweep of L with respect to x and W,
its tangent along (v, ẇ) (:func:`~eomc.compiler.passes.tangent`), the residual's
tangent along v, and a second reverse sweep of νᵀ res; three solves with the one
factorization (Kane's LDLᵀ, the recursive formulation's articulated-body factors).

Requested only (``functions`` naming them).  They need M symmetric and no multipliers:
Kane's models with constraints and closed trees are refused with a message.
"""
import sympy as sm

from eomc.runtime.errors import ModelError
from ..passes.dce import dce
from .bodies import (IND, _load_dynamics, _solver_decls, extra_state_rows, needed_assignments,
                     singular_guard, store, temps)

__all__ = ["hess_id_requests", "hess_id_body", "hess_id_ops", "REVERSE_FUNCTIONS", "reverse_symbols", "reverse_requests", "reverse_body",
           "refuse_reverse", "reverse_nsolve"]

REVERSE_FUNCTIONS = ("vjp", "hvp")

# result groups of xdot's kinematic and extra-state rows (vjp writes xdot; hvp does not)
_XDOT_ROWS = ("kin", "zd")

# solves beyond the rhs's one (Kane's operation counts)
reverse_nsolve = {"vjp": 1, "hvp": 3}


def refuse_reverse(functions, why):
    """ModelError when vjp or hvp is asked of a system whose M is not symmetric positive
    (``why`` says what the system has)."""
    asked = [f for f in REVERSE_FUNCTIONS if f in functions]
    if asked:
        raise ModelError(f"{' and '.join(asked)} need the dynamics' matrix symmetric with no "
                         f"multipliers, but this system {why}; build without "
                         f"{', '.join(asked)} (jac_x and jvp are available)")


def reverse_symbols(nx, nw):
    """(λ, μ, ẇ, ν): the weights the caller gives (C ``lam``), the solved adjoint of the
    accelerations (``mu``), the accelerations' tangent (``wd``) and the second adjoint
    (``nv``)."""
    def make(label, n):
        return tuple(sm.Symbol(f"adj_{label}_{i}", real=True) for i in range(n))
    return make("lam", nx), make("mu", nw), make("wd", nw), make("nu", nw)


def reverse_requests(functions, layout, res_group, nq, nu, W, seeds):
    """(extra program inputs, derivative requests for optimize_shared) of vjp and hvp."""
    wanted = [f for f in REVERSE_FUNCTIONS if f in functions]
    if not wanted:
        return (), ()
    x, p = tuple(layout.x), tuple(layout.p)
    nx, nw = len(x), len(W)
    lam, mu, wd, nv = reverse_symbols(nx, nw)
    weights = {("kin", i): lam[i] for i in range(nq)}
    weights.update({("zd", j): lam[nq + nu + j] for j in range(nx - nq - nu)})
    weights.update({(res_group, j): mu[j] for j in range(nw)})
    requests = []
    inputs = lam + mu
    if "vjp" in wanted:
        requests.append((weights, x + p, "vj"))
    if "hvp" in wanted:
        W = tuple(W)
        requests += [(weights, x + W, "ha0"),
                     ("ha0", dict(zip(x + W, tuple(seeds) + wd)), "ha"),
                     (res_group, dict(zip(x, seeds)), "hr"),
                     ({(res_group, j): nv[j] for j in range(nw)}, x, "hb")]
        inputs += wd + nv
    return inputs, tuple(requests)


class _KaneSolves:
    """A factored by the solver's code (LDLᵀ), w from the dynamics; solves in place."""

    def __init__(self, ctx):
        self.ctx = ctx

    def decls(self, extra, status=True):
        return _solver_decls(self.ctx, extra)

    def prologue(self, program, pr, stage0):
        return temps(program, pr, stage0) + _load_dynamics(self.ctx, program, pr)

    def solve(self, program, pr, array):
        return [f"{IND}{self.ctx.solver.solve_call(array)};"]

    def excluded(self, program):
        return set()


class _TreeSolves:
    """u' by ABA (``ud``), M⁻¹ by the articulated-body recursion on ABA's factors
    (``sol``, reading ``G``), repeated in a block per solve."""

    def __init__(self, ctx, G):
        self.ctx, self.G = ctx, tuple(G)

    def decls(self, extra, status=True):
        return ([f"{IND}double w[{self.ctx.nu}];", f"{IND}double G[{self.ctx.nu}];"]
                + ([f"{IND}int status;"] if status else []) + [f"{IND}{d}" for d in extra])

    def excluded(self, program):
        dep, out = set(self.G), set()
        for t, e in program.assignments:
            if e.free_symbols & dep:
                dep.add(t)
                out.add(t)
        return out

    def prologue(self, program, pr, stage0):
        for j, g in enumerate(self.G):
            pr._names[g] = f"G[{j}]"
        lines = temps(program, pr, stage0)
        lines += singular_guard(program, pr)
        ud = program.result_exprs("ud")
        return lines + [store(f"w[{j}]", ud[("ud", j)], pr) for j in range(self.ctx.nu)]

    def solve(self, program, pr, array):
        nu = self.ctx.nu
        sol = {k[1]: e for k, e in program.results if k[0] == "sol"}
        excluded = self.excluded(program)
        block = needed_assignments([a for a in program.assignments if a[0] in excluded], sol.values())
        lines = [f"{IND}for (i = 0; i < {nu}; i++) G[i] = {array}[i];", f"{IND}{{"]
        lines += [IND + x for x in temps(program, pr, block)]
        lines += [f"{IND * 2}{array}[{i}] = {pr.doprint(sol.get(i, sm.S.Zero))};" for i in range(nu)]
        return lines + [f"{IND}}}"]


def _stages(assignments, order, excluded):
    """{stage: [assignments]}: a temporary's stage is the last of ``order`` (symbol sets,
    computed in that order at run time) it depends on, 0 for none; ``excluded`` are left out."""
    stage_of = {}
    for k, syms in enumerate(order, start=1):
        for s in syms:
            stage_of[s] = k
    out = {k: [] for k in range(len(order) + 1)}
    for t, e in assignments:
        if t in excluded:
            continue
        st = max((stage_of.get(s, 0) for s in e.free_symbols), default=0)
        stage_of[t] = st
        out[st].append((t, e))
    return out


def reverse_body(fn, ctx, program, sym, nx, npar, tree_g=None):
    """The C body of NAME_vjp or NAME_hvp; ``tree_g``: the recursive formulation's solve
    symbols (None: Kane's, solved with the factorization)."""
    solves = _KaneSolves(ctx) if tree_g is None else _TreeSolves(ctx, tree_g)
    if fn == "hvp":     # xdot's own rows are vjp's output, not hvp's: their temporaries would be unused C
        program = dce(program, {k[0] for k, _ in program.results} - set(_XDOT_ROWS))
    nq, nu, nw = ctx.nq, ctx.nu, len(sym.W)
    lam, mu, wd, nv = reverse_symbols(nx, nw)
    pr = ctx.printer(program)
    for arr, syms in (("lam", lam), ("mu", mu), ("wd", wd), ("nv", nv)):
        for j, s in enumerate(syms):
            pr._names[s] = f"{arr}[{j}]"
    excluded = solves.excluded(program)
    order = [tuple(sym.W), mu, tuple(sym.seeds), wd, nv]
    st = _stages(program.assignments, order, excluded)
    if fn == "vjp":
        return _vjp(ctx, program, pr, solves, st, nx, npar, nq, nu, nw)
    return _hvp(ctx, program, pr, solves, st, nx, nq, nu, nw)


def _vjp(ctx, program, pr, solves, st, nx, npar, nq, nu, nw):
    vj = program.result_exprs("vj")
    gx = [vj.get(("vj", k), sm.S.Zero) for k in range(nx)]
    gp = [vj.get(("vj", nx + k), sm.S.Zero) for k in range(npar)]
    later = st[2] + st[3] + st[4] + st[5]
    p_only = ({t for t, _ in needed_assignments(later, gp)}
              - {t for t, _ in needed_assignments(later, gx)})
    lines = solves.decls([f"double mu[{nw}];", "int i;"])
    lines += solves.prologue(program, pr, st[0])
    lines += temps(program, pr, st[1])
    kin = program.result_exprs("kin")
    lines.append(f"{IND}if (xdot) {{")
    body = [store(f"xdot[{i}]", kin.get(("kin", i), sm.S.Zero), pr) for i in range(nq)]
    body += [f"{IND}xdot[{nq + i}] = w[{i}];" for i in range(nu)]
    body += extra_state_rows(ctx, program, pr, "zd", "xdot")
    lines += [IND + b for b in body] + [f"{IND}}}"]
    lines.append(f"{IND}for (i = 0; i < {nw}; i++) mu[i] = lam[{nq} + i];")
    lines += solves.solve(program, pr, "mu")
    lines += temps(program, pr, [a for a in later if a[0] not in p_only])
    lines += [store(f"gx[{k}]", e, pr) for k, e in enumerate(gx)]
    if npar:
        lines.append(f"{IND}if (gp) {{")
        lines += [IND + x for x in temps(program, pr, [a for a in later if a[0] in p_only])]
        lines += [IND + store(f"gp[{k}]", e, pr) for k, e in enumerate(gp)]
        lines += [f"{IND * 2}status = {ctx.name}_finite(gp, {npar});",
                  f"{IND * 2}if (status != EOMC_OK) return status;", f"{IND}}}"]
    lines += [f"{IND}if (xdot) {{", f"{IND * 2}status = {ctx.name}_finite(xdot, {nx});",
              f"{IND * 2}if (status != EOMC_OK) return status;", f"{IND}}}",
              f"{IND}return {ctx.name}_finite(gx, {nx});"]
    return lines


def _hvp(ctx, program, pr, solves, st, nx, nq, nu, nw):
    ha = program.result_exprs("ha")
    hb = program.result_exprs("hb")
    hr = program.result_exprs("hr")
    lines = solves.decls([f"double mu[{nw}];", f"double wd[{nw}];", f"double nv[{nw}];",
                          "const double *dx = v;", "int i;"], status=False)
    lines += solves.prologue(program, pr, st[0])
    lines += temps(program, pr, st[1])
    lines.append(f"{IND}for (i = 0; i < {nw}; i++) mu[i] = lam[{nq} + i];")
    lines += solves.solve(program, pr, "mu")
    lines += temps(program, pr, st[2] + st[3])
    lines += [store(f"wd[{j}]", hr.get(("hr", j), sm.S.Zero), pr) for j in range(nw)]
    lines += solves.solve(program, pr, "wd")
    lines += temps(program, pr, st[4])
    lines += [store(f"nv[{j}]", ha.get(("ha", nx + j), sm.S.Zero), pr) for j in range(nw)]
    lines += solves.solve(program, pr, "nv")
    lines += temps(program, pr, st[5])
    for k in range(nx):
        a, b = ha.get(("ha", k), sm.S.Zero), hb.get(("hb", k), sm.S.Zero)
        lines.append(store(f"out[{k}]", _sum(a, b), pr))
    lines.append(f"{IND}return {ctx.name}_finite(out, {nx});")
    return lines


def hess_id_requests(layout, nu, seeds):
    """(extra inputs, requests) of hess_id: a reverse sweep of Σ e_i·τ_i over x, then its
    tangent along a unit state direction; the C loops i over τ's rows and k over columns."""
    x = tuple(layout.x)
    lam = reverse_symbols(len(x), 0)[0][:nu]
    return lam, (({("tau", i): lam[i] for i in range(nu)}, x, "hg0"),
                 ("hg0", dict(zip(x, seeds)), "hg"))


def hess_id_body(ctx, program, sym, nx):
    """NAME_hess_id: out[(i nx + j) nx + k] = ∂²τ_i/∂x_j∂x_k.  Per row i one reverse sweep
    (weights e_i), per column k its tangent (seed e_k): nu·nx tangents of a sweep, O(n²)
    calls of O(n) code, the code written once."""
    nu = ctx.nu
    lam = reverse_symbols(nx, 0)[0][:nu]
    program = dce(program, ("hg",))     # τ itself (its sweep's start) is not an output: unused C
    pr = ctx.printer(program)
    for j, s in enumerate(lam):
        pr._names[s] = f"lam[{j}]"
    st = _stages(program.assignments, [lam, tuple(sym.seeds)], set())
    hg = program.result_exprs("hg")
    lines = [f"{IND}double lam[{nu}];", f"{IND}double dx[{nx}];", f"{IND}int i, k;"]
    lines += temps(program, pr, st[0])
    lines += [f"{IND}for (i = 0; i < {nu}; i++) lam[i] = 0.0;",
              f"{IND}for (k = 0; k < {nx}; k++) dx[k] = 0.0;",
              f"{IND}for (i = 0; i < {nu}; i++) {{", f"{IND * 2}lam[i] = 1.0;", f"{IND * 2}{{"]
    lines += [IND * 2 + x for x in temps(program, pr, st[1])]
    lines += [f"{IND * 3}for (k = 0; k < {nx}; k++) {{", f"{IND * 4}dx[k] = 1.0;", f"{IND * 4}{{"]
    lines += [IND * 4 + x for x in temps(program, pr, st[2])]
    lines += [IND * 4 + store(f"out[((size_t)i * {nx} + {j}) * {nx} + k]", hg.get(("hg", j), sm.S.Zero), pr)
              for j in range(nx)]
    lines += [f"{IND * 4}}}", f"{IND * 4}dx[k] = 0.0;", f"{IND * 3}}}", f"{IND * 2}}}",
              f"{IND * 2}lam[i] = 0.0;", f"{IND}}}",
              f"{IND}return {ctx.name}_finite(out, {nu * nx * nx});"]
    return lines


def hess_id_ops(program, sym, nx, nu):
    """Operation counts of NAME_hess_id as it runs: the prologue once, the row sweep nu times,
    the column tangent and stores nu·nx times."""
    from ..ir import count_program
    lam = reverse_symbols(nx, 0)[0][:nu]
    program = dce(program, ("hg",))
    st = _stages(program.assignments, [lam, tuple(sym.seeds)], set())
    c = count_program(program.with_(assignments=tuple(st[0]), results=()))
    row = count_program(program.with_(assignments=tuple(st[1]), results=()))
    col = count_program(program.with_(assignments=tuple(st[2]), results=program.select(("hg",)).results))
    for _ in range(nu):
        c += row
    for _ in range(nu * nx):
        c += col
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}


def _sum(a, b):
    if a == 0:
        return b
    if b == 0:
        return a
    return sm.Add(a, b, evaluate=False)
