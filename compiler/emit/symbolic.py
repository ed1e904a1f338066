"""Symbolic results of every generated function, before optimization.

The dynamics ``A(q,t)·w = b(q,u,t)``, ``w = [u'; λ]``, is never inverted
symbolically: rhs only needs A's structural nonzeros and b, the solve is
emitted as unrolled C (see :mod:`.linsolve`).  The Jacobians follow from
differentiating ``A·w = b`` at fixed ``w`` (the value the first solve gave,
read from the C array ``w`` through the symbols ``w_j``):

    dw/dx_k = A⁻¹ (∂b/∂x_k − ∂A/∂x_k · w),

so jac_x needs the columns ``G[:, k] = ∂(b − A·W)/∂x_k`` and the same factorization.
The residual ``res = b − A·W`` is a result group; its derivatives (and those of the
kinematics and constraints) are requested from :func:`~eomc.compiler.passes.differentiate`,
which works on the CSE'd program.
"""
import random
from dataclasses import dataclass

import sympy as sm

from eomc.runtime.errors import ModelError
from ..ir import Program
from .reverse import refuse_reverse, reverse_requests
from .sparse_lu import static_row_order

__all__ = ["FUNCTION_GROUPS", "HELPER_USERS", "Symbolic", "build_symbolic", "TANGENT_MIN_STATES"]

# Above this many states jac_x evaluates one tangent program per column in a C loop
# (code and generation time O(program)) instead of unrolling every column
# (O(program x states) code, a little faster to run).
TANGENT_MIN_STATES = 12

# Functions that read A and b through the shared static helper NAME_dynamics.
# jac_r is one: its columns A⁻¹ ∂(b − A·W)/∂r need A but only the few
# temporaries of ∂/∂r, so it calls the helper instead of repeating A's code.
# (jac_x does not: its columns need most of A's and b's temporaries anyway.)
# jac_p (d xdot / d parameters) is built as jac_r is, with the parameters' directions.
HELPER_USERS = ("rhs", "mass_matrix", "forcing", "inverse_dynamics", "jac_r", "jac_p")

# zd: z' of the extra first-order states (FormedSystem.extra_states), explicit like the
# kinematics; dzd / dzd_r / dzd_p: its rows of jac_x / jac_r / jac_p.
FUNCTION_GROUPS = {
    "rhs": ("kin", "zd"),            # + the dynamics helper (A, b)
    "jac_x": ("A", "b", "dkin", "G", "Gtq", "Gtu", "dzd"),
    "jac_r": ("dkin_r", "Gr", "dzd_r"),   # + the dynamics helper (A, b)
    "jac_p": ("dkin_p", "Gp", "dzd_p"),   # + the dynamics helper (A, b)
    "mass_matrix": (),                # the dynamics helper only
    "forcing": (),
    "inverse_dynamics": (),
    "outputs": ("out",),
    "constraints": ("con",),
    "constraints_jac": ("dcon",),
    "linearize": (),
    "events": ("ev",),
    "regressor": (),        # recursive formulation only (compiler/tree/regressor.py)
    # xdot and J·d, d = [dx; dp] given (sensitivities): state tangents, parameter columns
    # (one tangent along the whole state direction, Gtx, where jac_x loops Gtq and Gtu)
    "jvp": ("A", "b", "kin", "dkin", "G", "Gtx", "dkin_p", "Gp", "zd", "dzd", "dzd_p"),
    # wᵀ J and (∂²(λᵀ xdot)/∂x²)·v by reverse mode (compiler/emit/reverse.py)
    "vjp": ("A", "b", "kin", "zd", "res", "vj"),
    "hvp": ("A", "b", "kin", "zd", "res", "hr", "ha", "hb"),
    "hess_id": (),          # recursive formulation only (compiler/emit/reverse.py)
}


@dataclass(frozen=True)
class Symbolic:
    program: Program
    derivatives: tuple      # (source group, wrt symbols, target group) for optimize_shared
    nw: int                 # unknowns of the dynamics solve (nu + nλ)
    symmetric: bool         # A symmetric (LDLᵀ) or not (LU with pivoting)
    row_order: tuple        # compile-time row order of the unrolled LU
    pattern: frozenset      # structural nonzeros (i, j) of A
    W: tuple                # symbols of the solved w = [u'; λ]
    seeds: tuple            # tangent direction symbols (C array dx) of a looped jac_x
    UD: tuple               # symbols of inverse dynamics' given u'
    nhol: int
    nvel: int
    output_names: tuple
    event_names: tuple = ()
    solve_in: tuple = ()    # outputs/events that read u' or multipliers: they solve A w = b first
    regressor_bodies: tuple = ()     # column blocks of the regressor (recursive formulation)
    regressor_reference: tuple = ()  # per block: "link frame" or "mass centre"
    analytic: object = None          # recursive formulation: compiler/tree/analytic.AnalyticPlan
    dynamics_kernel: tuple = ()      # recursive: the functions NAME_dyn computes (compiler/tree/dynamics_kernel.py)
    inverse_dynamics_calls: str = ""  # recursive with contacts: τ = M u' - f from NAME_implicit's (tree/lower.py)
    forcing_calls: str = ""          # recursive: forcing is -inverse_dynamics at u' = 0, a call of it (tree/lower.py)
    function_groups: object = None   # per function, its result groups where they differ from the formulation's
    second_order: object = None      # recursive: (AnalyticPlan, nx) of hess_id's kernel (compiler/tree/second_order.py)
    second_order_note: str = ""      # recursive: which algorithm hess_id got and why (NAME.json "hess_id")
    energy: str = ""                 # what a generated ``energy`` output holds (NAME.json "energy"), or ""
    guards: tuple = ()               # rhs broad phase: (clearance, exports) (compiler/emit/guards.py)
    implicit_guards: tuple = ()      # NAME_implicit's: the exports with each point's K and C slopes
    implicit_pairs: tuple = ()       # NAME_implicit's body-body pair points after the ground's: (name, body a, body b)
    # NAME_implicit's out[] ends with the energy output (tree/lower.implicit_layout): True, else None
    # (the whole energy: a pairs' table's points' too since session 32, tree/contacts.ENERGY_IMPLICIT)
    implicit_energy: bool = None
    jac_guards: tuple = ()           # the analytic jac_x's: the exports with each point's world force, K and C
    chain_loop: object = None        # recursive: the rhs as loops over a repeated chain (compiler/tree/chain_loop.py)
    limbs: object = None             # recursive: the rhs with routines per limb shape (compiler/tree/limbs.py)
    mass_inputs: tuple = ()          # recursive, a plan with contacts: the an[] entries mass_matrix and jac_r read (tree/lower.contact_mass_inputs)
    input_solve: int = 0             # recursive: jac_r solves M by NAME_msolve, this many columns a block (compiler/tree/input_jacobian.py)
    body_loops: object = None        # recursive: {"energy": True, "poses": table shape} where NAME_energy / NAME_poses
                                     # are loops over the tree's bodies (compiler/tree/body_loops.py), else None


def _is_symmetric(A, seed=0):
    """Structurally equal mirror entries, or numerically equal at two random points."""
    n = A.shape[0]
    pairs = [(i, j) for i in range(n) for j in range(i) if A[i, j] != A[j, i]]
    if not pairs:
        return True
    rng = random.Random(seed)
    syms = sorted(A.free_symbols, key=lambda s: s.name)
    for _ in range(2):
        vals = {s: sm.Float(rng.uniform(0.3, 1.7)) for s in syms}
        for i, j in pairs:
            a, b = complex(A[i, j].xreplace(vals)), complex(A[j, i].xreplace(vals))
            if abs(a - b) > 1e-10 * max(1.0, abs(a), abs(b)):
                return False
    return True


def _check_structurally_regular(pattern, nw, speed_names, multipliers, by_speed):
    """A row or column of A that is identically zero makes every solve fail: say so at
    compile time, naming the speed (or multiplier) concerned.  ``by_speed``: row i is
    speed i's equation (no velocity constraints), so a zero row can be named too."""
    unknowns = list(speed_names) + [str(m) for m in multipliers]
    for i in range(nw):
        if not any((j, i) in pattern for j in range(nw)):
            what = (f"speed {unknowns[i]} has no inertia: its acceleration appears in no "
                    f"equation" if i < len(speed_names) else
                    f"multiplier {unknowns[i]} appears in no equation")
            raise ModelError(f"{what} (the mass matrix's column is identically zero), so the "
                             f"equations of motion cannot be solved; is a body's mass on the axis "
                             f"it turns about, or a link massless with nothing at its end?")
    for i in range(nw):
        if not any((i, j) in pattern for j in range(nw)):
            what = (f"the equation of speed {unknowns[i]}" if by_speed and i < len(speed_names)
                    else f"equation {i} of the dynamics")
            raise ModelError(f"{what} has an identically zero row in the mass matrix, so the "
                             f"equations of motion cannot be solved for the accelerations")


def _solved_quantities(formed, W, exprs=None):
    """Substitutions putting accelerations and multipliers in terms of the solved w = [u'; λ].

    u' -> w_i; q'' -> d/dt of the kinematics (then in q', u'); a Lagrange multiplier
    lam_k -> -w_{nu+k} (the FormedSystem's unknowns are mu = -lam, see lagrange_formed).
    ``exprs``: the expressions the substitutions are for: q'' only of the coordinates whose q''
    one of them holds (the others' entries would replace nothing).  Why: d/dt of every
    kinematic equation was taken at each call, for no output at all too (Talos' floating base:
    ~0.1 s of its build's generate per call, two to three calls a build).
    """
    t = sm.Symbol("t")
    ud = {s.diff(t): W[i] for i, s in enumerate(formed.speeds)}
    held = None if exprs is None else set().union(
        *(e.atoms(sm.Derivative) for e in exprs if isinstance(e, sm.Basic)))
    qdd = {q.diff(t, 2): k.diff(t) for q, k in zip(formed.coordinates, formed.kinematics)
           if held is None or q.diff(t, 2) in held}
    sign = -1 if formed.multipliers and formed.method == "lagrange" else 1   # only formed systems have λ
    lam = {m: sign * W[formed.nu + k] for k, m in enumerate(formed.multipliers)}
    return ud, qdd, lam


def reads_solve(formed, exprs):
    """Does any of ``exprs`` (outputs or events: {name: expression}) read the dynamics solve's
    unknowns -- a speed's derivative u', a coordinate's q'' or a Lagrange multiplier?  The test
    :func:`build_symbolic` makes (its ``solve_in``), on the expressions before their slots.

    Why: the recursive formulation builds M by CRBA and f by RNEA for outputs that read u' (the
    Kane path's code solves A·u' = b for them); G1's energy, the default output, reads none, and
    those recursions were 0.2-0.3 s of its default build's generate for code nothing printed."""
    if not exprs:
        return False
    W = tuple(sm.Symbol(f"w_{j}", real=True) for j in range(formed.nu + len(formed.multipliers)))
    values = [sm.sympify(e) for e in exprs.values()]
    ud, qdd, lam = _solved_quantities(formed, W, values)
    unknowns = set(W)
    for e in values:
        if ud or lam:
            e = e.xreplace(ud).xreplace(qdd).xreplace(ud).xreplace(lam)
        if getattr(e, "free_symbols", set()) & unknowns:
            return True
    return False


def _outputs(formed, layout, outputs, W=()):
    kin = {sm.Derivative(q, sm.Symbol("t")): k for q, k in zip(formed.coordinates, formed.kinematics)}
    values = {}
    for name, expr in (outputs or {}).items():
        if not str(name).isidentifier():
            raise ModelError(f"output name {name!r} is not an identifier")
        values[name] = sm.sympify(expr)
    ud, qdd, lam = _solved_quantities(formed, W, values.values()) if W and values else ({}, {}, {})
    names, exprs = [], []
    for name, e in values.items():
        if ud:
            e = e.xreplace(ud).xreplace(qdd).xreplace(ud)
        e = e.xreplace(kin).xreplace(lam)
        names.append(str(name))
        exprs.append(layout.apply(e, f"output {name!r}", keep=W))
    return tuple(names), exprs


def _extra_rates(formed, layout):
    """z' of the extra states in slot symbols; a coordinate's rate q' there is its kinematics.
    (u' and z' were refused when the states were read: compiler/model/states.py.)"""
    t = sm.Symbol("t")
    kin = {sm.Derivative(q, t): k for q, k in zip(formed.coordinates, formed.kinematics)}
    names = layout.state_names[formed.nq + formed.nu:]
    return [layout.apply(sm.sympify(e).xreplace(kin), f"the derivative of state {n}")
            for n, e in zip(names, getattr(formed, "extra_rhs", ()))]


def _dynamics(formed, layout):
    memo = {}
    A = formed.dynamics_matrix.applyfunc(lambda e: layout.apply(e, "the mass matrix", memo))
    b = [layout.apply(e, "the forcing vector", memo) for e in formed.dynamics_rhs]
    if A.shape != (len(b), len(b)) or len(b) != formed.nu + len(formed.multipliers):
        raise ModelError(f"dynamics matrix is {A.shape[0]}x{A.shape[1]} but the system has "
                         f"{formed.nu} speeds and {len(formed.multipliers)} multipliers")
    return A, b


def build_symbolic(formed, layout, functions, outputs=None, events=None, *, dynamics=None,
                   prelude=None, function_groups=None, helper_users=HELPER_USERS, extra_inputs=()):
    """The unoptimized program holding the result groups ``functions`` need.

    ``dynamics``: (A, b) already in slot symbols, instead of the formed system's
    (the recursive formulation: entries are temporaries of ``prelude`` =
    (assignments, ntemp, extra results)).
    """
    function_groups = FUNCTION_GROUPS if function_groups is None else function_groups
    groups = {g for f in functions for g in function_groups[f]}
    if set(functions) & set(helper_users):
        groups |= {"A", "b"}
    A, b = _dynamics(formed, layout) if dynamics is None else dynamics
    nw, nu = len(b), formed.nu
    W = tuple(sm.Symbol(f"w_{j}", real=True) for j in range(nw))
    names, outs = _outputs(formed, layout, outputs, W)
    event_names, evs = _outputs(formed, layout, events, W)
    solve_in = tuple(f for f, exprs in (("outputs", outs), ("events", evs))
                     if f in functions and any(e.free_symbols & set(W) for e in exprs))
    if solve_in:
        groups |= {"A", "b"}
    kin = [layout.apply(e, "the kinematic equations") for e in formed.kinematics]
    # Constraint equations for an actual model may not use velocity constraints via
    # Kane's motion rows; symmetry + no multipliers + no motion constraints => SPD.
    nvel = len(formed.velocity_constraints)
    symmetric = not formed.multipliers and nvel == 0 and _is_symmetric(A)
    if symmetric:
        A = sm.Matrix(nw, nw, lambda i, j: A[max(i, j), min(i, j)])
    pattern = frozenset((i, j) for i in range(nw) for j in range(nw) if A[i, j] != 0)
    _check_structurally_regular(pattern, nw, layout.state_names[formed.nq:], formed.multipliers,
                                by_speed=len(formed.velocity_constraints) == 0)
    row_order = tuple(range(nw)) if symmetric else static_row_order(A, pattern)
    seeds = tuple(sm.Symbol(f"sx_{j}", real=True) for j in range(len(layout.x)))
    UD = tuple(sm.Symbol(f"ud_{j}", real=True) for j in range(nu))
    res = []
    derivatives = []
    if "dkin" in groups or "dkin_r" in groups or "dkin_p" in groups:
        groups.add("kin")
        if "dkin" in groups:
            derivatives.append(("kin", layout.x, "dkin"))
        if "dkin_r" in groups:
            derivatives.append(("kin", layout.r, "dkin_r"))
        if "dkin_p" in groups:
            derivatives.append(("kin", layout.p, "dkin_p"))
    if "kin" in groups:
        res += [(("kin", i), e) for i, e in enumerate(kin)]
    zd = _extra_rates(formed, layout)
    if zd and groups & {"zd", "dzd", "dzd_r", "dzd_p"}:
        res += [(("zd", i), e) for i, e in enumerate(zd)]
        if "dzd" in groups:
            derivatives.append(("zd", layout.x, "dzd"))
        if "dzd_r" in groups:
            derivatives.append(("zd", layout.r, "dzd_r"))
        if "dzd_p" in groups:
            derivatives.append(("zd", layout.p, "dzd_p"))
    if "A" in groups:
        res += [(("A", i, j), A[i, j]) for (i, j) in sorted(pattern) if not symmetric or i >= j]
    if "b" in groups:
        res += [(("b", i), e) for i, e in enumerate(b)]
    reverse_inputs = ()
    if "res" in groups:      # vjp, hvp (Kane's: the recursive formulation's residual is "tres")
        if not symmetric or nw != nu:
            refuse_reverse(functions, "has constraints (multipliers or a non-symmetric matrix)")
        groups |= {"kin"}
        reverse_inputs, requests = reverse_requests(functions, layout, "res", formed.nq, nu, W, seeds)
    if "G" in groups or "Gr" in groups or "Gp" in groups or "res" in groups:
        res += [(("res", i), b[i] - sm.Add(*[A[i, j] * W[j] for j in range(nw) if (i, j) in pattern]))
                for i in range(nw)]
        if "G" in groups and len(layout.x) > TANGENT_MIN_STATES:
            nq = formed.nq
            if groups & {"Gtq", "Gtu"}:
                derivatives.append(("res", dict(zip(layout.x[:nq], seeds[:nq])), "Gtq"))
                derivatives.append(("res", dict(zip(layout.x[nq:], seeds[nq:])), "Gtu"))
            if "Gtx" in groups:
                derivatives.append(("res", dict(zip(layout.x, seeds)), "Gtx"))
        elif "G" in groups:
            derivatives.append(("res", layout.x, "G"))
        if "Gr" in groups:
            derivatives.append(("res", layout.r, "Gr"))
        if "Gp" in groups:
            derivatives.append(("res", layout.p, "Gp"))
        if reverse_inputs:
            derivatives += requests
    if "out" in groups:
        res += [(("out", i), e) for i, e in enumerate(outs)]
    if "ev" in groups:
        res += [(("ev", i), e) for i, e in enumerate(evs)]
    hol = [layout.apply(e, "a holonomic constraint") for e in formed.holonomic_constraints]
    vel = [layout.apply(e, "a velocity constraint") for e in formed.velocity_constraints]
    if "dcon" in groups:
        groups.add("con")
        derivatives.append(("con", layout.x, "dcon"))
    if "con" in groups:
        res += [(("con", i), e) for i, e in enumerate(hol + vel)]
    inputs = (layout.t,) + layout.x + layout.p + layout.r + W + UD + seeds + reverse_inputs + tuple(extra_inputs)
    if prelude is None:
        program = Program(inputs=inputs, results=tuple(res))
    else:
        assignments, ntemp, extra = prelude
        program = Program(inputs=inputs, assignments=tuple(assignments),
                          results=tuple(res) + tuple(r for r in extra if r[0][0] in groups),
                          ntemp=ntemp)
    return Symbolic(program=program, derivatives=tuple(derivatives), nw=nw, row_order=row_order,
                    seeds=seeds, symmetric=symmetric, pattern=pattern, W=W, UD=UD,
                    nhol=len(hol), nvel=len(vel), output_names=names, event_names=event_names,
                    solve_in=solve_in)
