"""Closed loops on the tree: a spanning tree of joints plus loop-closing (holonomic) constraints.

A SymPy ``System`` whose joints form a tree and whose loops are closed by holonomic
constraints (a four-bar, a slider-crank, a five-bar or delta linkage: one joint of each
loop is left out and replaced by the constraints that it would enforce) is the tree's
dynamics plus a constraint solve, as in Featherstone's "Rigid Body Dynamics Algorithms"
ch. 8 and Drake's / Pinocchio's constrained dynamics:

    M u' = b + Jᵀ λ,      J u' = -γ            (n speeds, m constraints)

with M and b the spanning tree's (never formed: ABA gives a0 = M⁻¹ b, and the
articulated-body recursion on ABA's factors gives the columns Y = M⁻¹ Jᵀ, O(n) each),
then the m x m system S λ = -γ - J a0 with S = J Y (symmetric positive definite when the
constraints are independent; LDLᵀ unrolled) and u' = a0 + Y λ.  O(n·m + m³).

J and γ come from the System's velocity constraints f_v(q, u) = 0 (the time derivative
of the holonomic ones unless the user set others), with q' from the kinematics:
J = ∂f_v/∂u and γ = d f_v/dt at u' = 0 -- the rows Kane's path appends to its mass
matrix.  For the default f_v = d f_h/dt they are derived by forward-mode rates on the
CSE'd DAG of f_h (:func:`_rates_on_dag`: J's columns are f_h's derivatives along
∂q'/∂u_j, γ the second derivative along q'), named values kept in ``Loops.defs``: SymPy's
diff of the expanded expressions, O(n) rotations deep in an n-link chain, took most of
a 10-link chain's 8 s build (now 2.6 s).  That makes the result Kane's at *every* state, consistent or not: Kane's
equations are Nᵀ(M u' - b) = 0 with N = [I; A_rs] a basis of J's null space, plus
J u' = -γ; and Nᵀ(M u' - b) = 0 holds exactly when M u' - b lies in the range of Jᵀ.

State layout and meaning are the Kane path's for the same System: x = [q; u] with every
coordinate and speed (independent first, then dependent, as KanesMethod orders them);
rhs gives every u'.  ``mass_matrix``, ``forcing`` and ``inverse_dynamics`` return Kane's
form too ([Nᵀ M; J] and [Nᵀ b; -γ], A_rs = -J_d⁻¹ J_i from an unrolled elimination),
and outputs or events that read u' solve that system as on the Kane path.

A KanesMethod with dependent speeds (hand-built in relative coordinates, or the one a
System forms) is read the same way, its loops from its own constraint matrices
(:func:`loops_of_kane`: J = k_dnh, γ = f_dnh).

jac_x, jac_r, jac_p, jvp (and linearize, which calls jac_x and jac_r) differentiate the
KKT system's residual, not the solve: R = (b - M W + Jᵀ Λ; -(J W + γ)) at given W = u' and
Λ = λ (:func:`kkt_residual`) vanishes at the solved values, so by the implicit function
theorem [M  -Jᵀ; J  0] [du'; dλ] = ∂R/∂x (W, Λ held).  The program's forward-mode pass
(compiler/passes/diff.py, the tangents "tq"/"tu" the open tree's jac_x runs) differentiates
R, and each column is solved on the factors the rhs already made (:func:`kkt_solve`: the
articulated-body recursion for M⁻¹, S's LDLᵀ, Y = M⁻¹ Jᵀ): O(n + n·m + m²) per column,
nothing refactored, where differentiating through the LDLᵀ would carry its tangents
through every column.  The C keeps λ after u' in ``w`` and the m extra residual rows after
the n in ``G``.

Not generated here (ModelError naming it; Kane's formulation has no regressor either):
the regressor.  Nonholonomic constraints stay Kane's (the recogniser refuses them).
"""
from dataclasses import dataclass, replace

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics import mechanics as me

from eomc.runtime.errors import ModelError

from ..emit.linsolve import PIVOT_TOL
from .ldl import _LDL
from .derivatives import articulated_solve
from .model import NotATree

__all__ = ["Loops", "loops_of_system", "loops_of_kane", "tree_loops", "with_loops", "loop_exprs",
           "UNSUPPORTED", "check_functions", "lower_loops", "kane_form", "multiplier_symbols",
           "kkt_residual", "kkt_solve", "jacobian_symbols"]

_T = me.dynamicsymbols._t

# Functions the constrained tree does not generate (auto takes Kane's formulation for them).
UNSUPPORTED = ("regressor", "jac_id")


@dataclass(frozen=True)
class Loops:
    """The loop-closing constraints of a tree, in the mechanics objects' symbols."""
    holonomic: tuple          # f_h(q, t) = 0
    velocity: tuple           # f_v(q, u, t) = 0 (q' replaced by the kinematics)
    jacobian: tuple           # m rows of n: ∂f_v/∂u
    bias: tuple               # m: d f_v/dt at u' = 0 (γ)
    n_dependent_coordinates: int
    n_dependent_speeds: int
    joints: tuple = ()        # the joints the constraints tie (for messages)
    defs: tuple = ()          # ((symbol, expr), ...): named intermediate values J and γ read

    @property
    def m(self):
        return len(self.velocity)


def _nm(x):
    return str(x).replace("(t)", "")


def _dynamic(expr):
    return set(sm.sympify(expr).atoms(AppliedUndef))


def loops_of_system(system, coordinates, speeds, kinematics):
    """The Loops of a System with holonomic constraints (None without any).

    NotATree, naming what is wrong, for what the constrained tree does not take:
    nonholonomic constraints (Kane's formulation keeps those), dependent coordinates or
    speeds that do not match the constraints' count, velocity constraints that do not
    determine the dependent speeds."""
    hol = list(getattr(system, "holonomic_constraints", ()))
    nonhol = list(getattr(system, "nonholonomic_constraints", ()))
    q_dep, u_dep = list(getattr(system, "q_dep", ())), list(getattr(system, "u_dep", ()))
    if not (hol or nonhol or q_dep or u_dep):
        return None
    if nonhol:
        raise NotATree(f"the system has {len(nonhol)} nonholonomic constraint"
                       f"{'s' if len(nonhol) != 1 else ''}: the recursion takes loop-closing "
                       f"(holonomic) constraints only")
    if len(hol) != len(q_dep):
        raise NotATree(f"{len(hol)} holonomic constraint(s) but {len(q_dep)} dependent coordinate(s) "
                       f"({', '.join(_nm(x) for x in q_dep) or 'none'}): set q_dep to one coordinate "
                       f"per constraint")
    vel = list(system.velocity_constraints)
    if len(vel) != len(u_dep):
        raise NotATree(f"{len(vel)} velocity constraint(s) but {len(u_dep)} dependent speed(s) "
                       f"({', '.join(_nm(x) for x in u_dep) or 'none'}): set u_dep to one speed per "
                       f"constraint")
    q, u = list(coordinates), list(speeds)
    n, m = len(u), len(u_dep)
    if list(u[n - m:]) != u_dep:
        raise NotATree("the dependent speeds are not the last speeds of the system")
    qd = {qi.diff(_T): k for qi, k in zip(q, kinematics)}
    vel = [sm.sympify(e).xreplace(qd) for e in vel]
    leftover = [e for e in vel if e.has(sm.Derivative)]
    if leftover:
        raise NotATree(f"velocity constraint {leftover[0]} holds a derivative the kinematics do not give")
    if getattr(system, "_vel_constrs", None) is None and not any(c.has(_T) for c in
                                                                 _explicit_time(hol, q + u)):
        defs, jac, bias = _rates_on_dag(hol, q, u, kinematics)
    else:          # velocity constraints the user set: differentiated as they are
        defs, (jac, bias) = (), _rates_of(vel, q, u, kinematics)
    for i, row in enumerate(jac):
        if any(_dynamic(c) & set(u) for c in row):
            raise NotATree(f"velocity constraint {i + 1} is not linear in the speeds")
    atoms = set().union(*(_dynamic(c) for c in hol)) if hol else set()
    tied = tuple(j.name for j in system.joints
                 if atoms & (set(getattr(j, "coordinates", ())) | set(getattr(j, "speeds", ()))))
    return Loops(holonomic=tuple(sm.sympify(c) for c in hol), velocity=tuple(vel),
                 jacobian=tuple(tuple(r) for r in jac), bias=tuple(bias), n_dependent_coordinates=len(q_dep),
                 n_dependent_speeds=m, joints=tied, defs=tuple(defs))


def loops_of_kane(kane):
    """The Loops of a KanesMethod with dependent coordinates and speeds: its own constraint
    matrices (formed when it was made), so J u' = -γ are exactly the rows Kane's mass
    matrix appends: J = k_dnh, γ = f_dnh, and the velocity constraints k_nh u + f_nh."""
    qdep, udep = list(kane._qdep), list(kane._udep)
    if not (qdep or udep):
        return None
    if not udep:
        raise NotATree(f"dependent coordinates ({', '.join(_nm(x) for x in qdep)}) without dependent "
                       f"speeds: give the velocity constraints and u_dependent")
    if len(udep) > len(qdep):
        raise NotATree(f"{len(udep) - len(qdep)} of its velocity constraints are nonholonomic (more "
                       f"dependent speeds than dependent coordinates): the recursion takes "
                       f"loop-closing (holonomic) constraints only")
    k_nh, f_nh = sm.Matrix(kane._k_nh), sm.Matrix(kane._f_nh)
    k_dnh, f_dnh = sm.Matrix(kane._k_dnh), sm.Matrix(kane._f_dnh)
    if k_dnh.shape != k_nh.shape or any(sm.expand(a - b) != 0 for a, b in zip(k_dnh, k_nh)):
        raise NotATree("the acceleration constraints given are not the velocity constraints' "
                       "rate: the constrained tree takes loop-closing constraints")
    u = list(kane._u)
    vel = [sm.Add(*[k_nh[i, j] * u[j] for j in range(len(u))]) + f_nh[i] for i in range(k_nh.rows)]
    hol = list(kane._f_h) if kane._f_h.rows else []
    return Loops(holonomic=tuple(hol), velocity=tuple(vel),
                 jacobian=tuple(tuple(k_nh.row(i)) for i in range(k_nh.rows)),
                 bias=tuple(f_dnh), n_dependent_coordinates=len(qdep),
                 n_dependent_speeds=len(udep), joints=())


def _explicit_time(exprs, states):
    """``exprs`` with the coordinates and speeds taken out: what is left of t is explicit."""
    plain = {x: sm.Symbol(f"_s{k}") for k, x in enumerate(states)}
    return [sm.sympify(e).xreplace(plain) for e in exprs]


def _rates_of(vel, q, u, kinematics):
    """J = ∂f_v/∂u and γ = d f_v/dt at u' = 0 by SymPy's differentiation (velocity
    constraints the user gave)."""
    plain = {x: sm.Dummy(_nm(x)) for x in q + u}
    back = {v: k for k, v in plain.items()}
    jac, bias = [], []
    for e in vel:
        p = e.xreplace(plain)
        free = p.free_symbols
        jac.append(tuple(p.diff(plain[uj]).xreplace(back) if plain[uj] in free else sm.S.Zero
                         for uj in u))
        g = sm.Add(*[p.diff(plain[qk]).xreplace(back) * kin
                     for qk, kin in zip(q, kinematics) if plain[qk] in free])
        g += p.diff(_T).xreplace(back) if p.has(_T) else 0
        bias.append(g)
    return jac, bias


class _Names:
    """Deterministic names for the loops' intermediate values (identical input, identical C)."""

    def __init__(self):
        self.k = 0

    def __call__(self):
        self.k += 1
        return sm.Symbol(f"_loop{self.k}", real=True)

    def stream(self):
        while True:
            yield self()


def _forward(defs, outs, rates, fresh):
    """Forward-mode derivative through a DAG: ``defs`` [(symbol, expr)] in order, ``rates``
    {atom: its derivative} (absent: 0).  Returns (new defs, derivatives of ``outs``); each
    derivative of a def becomes one new named value, so the work and the result stay
    proportional to the DAG (SymPy's diff of the expanded tree is what took minutes)."""
    d = {a: r for a, r in rates.items() if r != 0}
    new = []
    for sym, e in defs:
        terms = [e.diff(a) * d[a] for a in e.free_symbols if a in d]
        if terms:
            ds = fresh()
            new.append((ds, sm.Add(*terms)))
            d[sym] = ds
    return new, [sm.Add(*[o.diff(a) * d[a] for a in o.free_symbols if a in d]) for o in outs], d


def _rates_on_dag(hol, q, u, kinematics):
    """(defs, J, γ) of the default velocity constraints f_v = d f_h/dt, computed on the CSE'd
    DAG of f_h: J's column j is f_h's derivative along ∂q'/∂u_j, f_v its derivative along q',
    and γ the derivative of f_v along q' with u' = 0."""
    fresh = _Names()
    plain = {x: sm.Symbol(f"_s{k}", real=True) for k, x in enumerate(q + u)}
    back = {v: k for k, v in plain.items()}
    pq, pu = [plain[x] for x in q], [plain[x] for x in u]
    kin = [sm.sympify(k).xreplace(plain) for k in kinematics]
    f = [sm.sympify(c).xreplace(plain) for c in hol]
    reps, f = sm.cse(f, symbols=fresh.stream(), order="none", list=True)
    base, defs = list(reps), list(reps)
    jac_cols = []
    for uj in pu:          # each column reads f_h's values only: one pass over them
        dk = {qk: k.diff(uj) for qk, k in zip(pq, kin) if uj in k.free_symbols}
        new, col, _ = _forward(base, f, dk, fresh)
        defs += new
        jac_cols.append(col)
    new, vel, dq = _forward(base, f, dict(zip(pq, kin)), fresh)
    defs += new
    # γ: d/dt of f_v (= vel) with u' = 0; D of f_h's values is known (dq), D of q is q'
    rates = {a: r for a, r in dq.items()}
    new2, gamma, _ = _forward(new, vel, rates, fresh)
    defs += new2
    jac = [[jac_cols[j][i] for j in range(len(pu))] for i in range(len(f))]
    unplain = lambda e: sm.sympify(e).xreplace(back)    # noqa: E731
    return ([(sym, unplain(e)) for sym, e in defs], [[unplain(c) for c in row] for row in jac],
            [unplain(g) for g in gamma])


def tree_loops(tree):
    """The Loops a tree carries (attached by the recogniser or a reader), or None."""
    return tree.loops


def attach(tree, loops):
    """``tree`` closed by ``loops`` (None: as it is)."""
    return tree if loops is None else replace(tree, loops=loops)


def loop_exprs(loops):
    """Every expression of the loops (for the cache key and the parameter list)."""
    if loops is None:
        return []
    out = list(loops.holonomic) + list(loops.velocity) + list(loops.bias)
    out += [c for row in loops.jacobian for c in row]
    out += [x for pair in loops.defs for x in pair]
    return [sm.sympify(e) for e in out] + [sm.Integer(loops.n_dependent_coordinates),
                                           sm.Integer(loops.n_dependent_speeds)]


def with_loops(formed, tree):
    """The Model of a tree (eomc.compiler.multibody) with its loops' constraints, dependent
    counts, and the parameters and inputs only the constraints name (a ground link's
    length appears nowhere else)."""
    loops = tree_loops(tree)
    if loops is None:
        return formed
    states = set(formed.coordinates) | set(formed.speeds)
    inputs, params = set(formed.inputs), set(formed.parameters)
    named = {sym for sym, _ in loops.defs}
    for e in loop_exprs(loops):
        inputs |= {a for a in e.atoms(AppliedUndef) if a not in states}
        params |= {s for s in e.free_symbols if s != _T and s not in named}
    out = replace(formed, n_dependent_coordinates=loops.n_dependent_coordinates,
                  n_dependent_speeds=loops.n_dependent_speeds,
                  holonomic_constraints=sm.Matrix(list(loops.holonomic)) if loops.holonomic
                  else sm.zeros(0, 1),
                  velocity_constraints=sm.Matrix(list(loops.velocity)),
                  inputs=tuple(sorted(inputs, key=str)),
                  parameters=tuple(sorted(params, key=lambda s: s.name)))
    return out


def check_functions(functions):
    """ModelError for the functions the constrained tree does not generate (see the module
    docstring): the regressor, which Kane's formulation does not build either."""
    bad = [f for f in UNSUPPORTED if f in functions]
    if bad:
        raise ModelError(f"recursive formulation: {', '.join(bad)} of a tree closed by constraints "
                         f"{'is' if len(bad) == 1 else 'are'} not generated (rhs, jac_x, jac_r, "
                         f"jac_p, jvp, linearize, mass_matrix, forcing, inverse_dynamics, outputs, "
                         f"events and constraints are): the regressor and jac_id need the open "
                         f"tree's inverse dynamics; leave {'it' if len(bad) == 1 else 'them'} out")


class _Where:
    name, joint = "the loop constraints", "closing the loops"


def lower_loops(loops, layout, rec):
    """J (m x n) and γ (m) in slot symbols, their named intermediate values (``Loops.defs``)
    and common subexpressions named in ``rec``.  The program's CSE pass leaves the trace's
    assignments as they are (the recursions name every value they make), so these
    expressions are CSE'd here, once, like Kane's results: without it a five-bar's rhs had
    2.5 times the operations."""
    keep = tuple(sym for sym, _ in loops.defs)
    n = len(loops.jacobian[0]) if loops.jacobian else 0
    raw = [e for _, e in loops.defs] + [c for row in loops.jacobian for c in row] + list(loops.bias)
    bad = next((e for e in raw if sm.sympify(e).has(sm.nan, sm.zoo, sm.oo, -sm.oo)), None)
    if bad is not None:
        raise ModelError(f"recursive formulation: the loop constraints have a non-finite "
                         f"constant ({bad}); no C is written")
    # one rename of everything (apply builds its substitution map per call)
    renamed = list(layout.apply(sm.Tuple(*raw), "the loop constraints", {}, keep=keep))
    named = {}
    for (sym, _), e in zip(loops.defs, renamed):
        named[sym] = rec.let(e.xreplace(named))
    exprs = [e.xreplace(named) for e in renamed[len(keep):]]
    replacements, reduced = sm.cse(exprs, symbols=sm.numbered_symbols("_loopcse", real=True),
                                   order="none", list=True)
    cse_named = {}
    for sym, e in replacements:
        cse_named[sym] = rec.let(e.xreplace(cse_named))
    reduced = [e.xreplace(cse_named) for e in reduced]
    m = len(loops.jacobian)
    J = [[rec.let(reduced[i * n + k]) if reduced[i * n + k] != 0 else sm.S.Zero for k in range(n)]
         for i in range(m)]
    gamma = [rec.let(e) for e in reduced[m * n:]]
    return J, gamma


def accelerations(J, gamma, bodies, rec, keep, free):
    """u' of the closed tree from ABA's ``free`` [(speed, u'_free, pivot margin)] and factors.

    Returns ([(speed, u', the tree's pivot margin)], [the m pivot margins of S = J M⁻¹ Jᵀ],
    (Y, the LDLᵀ of S, λ) for the derivatives' KKT solve, :func:`kkt_solve`)
    (each less PIVOT_TOL times S's trace: a configuration where the constraints are
    dependent -- a four-bar folded flat -- is EOMC_SINGULAR_MASS_MATRIX, as Kane's LU
    finds it)."""
    nu = len(free)
    a0 = {k: udd for k, udd, _ in free}
    tree_margin = {k: D for k, _, D in free}
    margins = []
    m = len(J)
    Y = [articulated_solve(bodies, rec, keep, J[j]) for j in range(m)]   # M⁻¹ Jᵀ, column j
    S = [[None] * m for _ in range(m)]
    for i in range(m):
        for j in range(i + 1):
            S[i][j] = S[j][i] = rec.let(sm.Add(*[J[i][k] * Y[j][k] for k in range(nu)
                                                 if J[i][k] != 0 and Y[j].get(k, 0) != 0]))
    r = [rec.let(-gamma[i] - sm.Add(*[J[i][k] * a0[k] for k in range(nu) if J[i][k] != 0]))
         for i in range(m)]
    try:
        ldl = _LDL(S, rec, _Where)
    except NotATree:
        raise NotATree("the loop constraints do not involve the motion of any body (J M⁻¹ Jᵀ "
                       "is singular as an expression)") from None
    lam = ldl.solve(r)
    threshold = rec.let(PIVOT_TOL * sm.Add(*[S[i][i] for i in range(m)]))
    margins += [rec.let(d - threshold) for d in ldl.d]
    out = [(k, rec.let(a0[k] + sm.Add(*[Y[j][k] * lam[j] for j in range(m) if Y[j].get(k, 0) != 0])),
            tree_margin[k]) for k in sorted(a0)]
    return out, margins, (Y, ldl, lam)


def multiplier_symbols(m):
    """Symbols of the solved multipliers λ in the derivatives' residual (C: ``w[nu + j]``,
    after u')."""
    return tuple(sm.Symbol(f"lam_{j}", real=True) for j in range(m))


def kkt_residual(tau_w, J, gamma, W, lam):
    """The closed tree's residual at given u' = W and λ = lam, whose derivatives (W and lam
    held) give the Jacobians' right-hand sides:

        R1 = b - M W + Jᵀ λ     (nu rows; ``tau_w`` = M W - b, RNEA at u' = W)
        R2 = -(J W + γ)         (m rows)

    Both vanish at the solved (u', λ); with G = ∂R/∂x the implicit function theorem gives
    [M  -Jᵀ; J  0] [du'; dλ] = G, solved by :func:`kkt_solve`."""
    nu, m = len(tau_w), len(J)
    r1 = [-tau_w[k] + sm.Add(*[J[i][k] * lam[i] for i in range(m) if J[i][k] != 0]) for k in range(nu)]
    r2 = [-(sm.Add(*[J[i][k] * W[k] for k in range(nu) if J[i][k] != 0]) + gamma[i]) for i in range(m)]
    return r1 + r2


def kkt_solve(bodies, rec, keep, J, parts, g):
    """du' of [M  -Jᵀ; J  0] [du'; dλ] = g (``g``: nu + m symbols) on the factors the rhs
    already has: y = M⁻¹ g₁ by the articulated-body recursion, dλ = S⁻¹ (g₂ - J y) by S's
    LDLᵀ, du' = y + Y dλ (Y = M⁻¹ Jᵀ).  O(n + n·m + m²) per column, nothing refactored."""
    Y, ldl, _ = parts
    m = len(J)
    nu = len(g) - m
    y = articulated_solve(bodies, rec, keep, g[:nu])
    r = [rec.let(g[nu + i] - sm.Add(*[J[i][k] * y[k] for k in range(nu) if J[i][k] != 0]))
         for i in range(m)]
    dlam = ldl.solve(r)
    return [rec.let(y[k] + sm.Add(*[Y[j][k] * dlam[j] for j in range(m) if Y[j].get(k, 0) != 0]))
            for k in range(nu)]


def jacobian_symbols(program, W, nu):
    """(W, G) of a recursive Jacobian program: the solved values' symbols (u', then the
    closed tree's λ) and the residual's right-hand side symbols (nu, or nu + m on a closed
    tree), read from the program's inputs."""
    from .derivatives import solve_symbols
    names = {s.name: s for s in program.inputs}
    lam = tuple(names[f"lam_{j}"] for j in range(len(names)) if f"lam_{j}" in names)
    ng = nu
    while f"g_{ng}" in names:
        ng += 1
    return tuple(W) + lam, solve_symbols(ng)


def kane_form(J, gamma, H, f, nu, rec):
    """Kane's mass matrix and forcing of the closed tree, [Nᵀ M; J] and [Nᵀ b; -γ]:
    N = [I; A_rs], A_rs = -J_d⁻¹ J_i (the dependent speeds are the last m).  ``H``: CRBA's
    {(i, j): M_ij}; ``f``: b = -RNEA(u' = 0)."""
    m = len(J)
    p = nu - m
    # A_rs by Gauss-Jordan on [J_d | J_i], unrolled (Kane's path solves the same system)
    aug = [[J[i][p + k] for k in range(m)] + [J[i][k] for k in range(p)] for i in range(m)]
    for c in range(m):
        piv = rec.let(1 / aug[c][c]) if aug[c][c] != 0 else None
        if piv is None:
            raise NotATree("the dependent speeds' columns of the velocity constraints have a "
                           "structural zero pivot; order u_dep so that each constraint names its "
                           "dependent speed")
        aug[c] = [rec.let(x * piv) for x in aug[c]]
        for i in range(m):
            if i != c and aug[i][c] != 0:
                fac = aug[i][c]
                aug[i] = [rec.let(aug[i][k] - fac * aug[c][k]) for k in range(m + p)]
    Ars = [[-aug[s][m + r] for r in range(p)] for s in range(m)]       # m x p
    M = sm.Matrix(nu, nu, lambda i, j: H.get((i, j), 0))
    A = sm.zeros(nu, nu)
    b = [None] * nu
    for r in range(p):
        for j in range(nu):
            A[r, j] = rec.let(M[r, j] + sm.Add(*[Ars[s][r] * M[p + s, j] for s in range(m)
                                                 if M[p + s, j] != 0]))
        b[r] = rec.let(f[r] + sm.Add(*[Ars[s][r] * f[p + s] for s in range(m)]))
    for s in range(m):
        for j in range(nu):
            A[p + s, j] = J[s][j]
        b[p + s] = -gamma[s]
    return A, b
