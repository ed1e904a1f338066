"""A Tree -> the unoptimized program of the recursive formulation.

The program's result groups, all computed from one value-numbered trace:

    kin        q' (the kinematics, as Kane's path writes them)
    ud, Dpiv   u' by ABA, and the articulated inertias D_i it divides by (rhs)
    tau        M·u' - f by RNEA at given u' (inverse_dynamics)
    A, b       M by CRBA and f = -RNEA(u' = 0) (mass_matrix, forcing, and outputs or events
               that read u', which the Kane path's code solves A·u' = b for; an energy
               output alone reads none: emit.symbolic.reads_solve)
    sol        M⁻¹·g by the articulated-body recursion, g the symbols ``g_j``
    tq, tu     jac_x: the tangent, along one coordinate / one speed (seed ``sx``), of
               res = -RNEA(u' = W) with W the solved u' (``w_j``); the C code runs it and
               ``sol`` once per column (see :mod:`.derivatives`).  ``dres``: the same
               unrolled over the columns, for a few states
               On a tree closed by constraints res is the KKT system's residual (nu + m rows,
               at W and the solved λ, group ``lam``) and ``sol`` its tangent solve
               (:func:`.constrained.kkt_residual`, :func:`.constrained.kkt_solve`)
    dres_r     jac_r: d res / d inputs
    dres_p     jac_p: d res / d parameters (masses, lengths, gravity, ...), as jac_r
    zd, dzd, dzd_r, dzd_p   z' of the extra first-order states and its jac_x / jac_r /
               jac_p rows (the Kane path's groups, from build_symbolic)

Coordinates and speeds are the Kane path's (same layout), so states are
interchangeable and every function agrees with the Kane formulation.
"""
from dataclasses import replace

import sympy as sm

from eomc.runtime.errors import ModelError

from ..emit.reverse import hess_id_requests, refuse_reverse, reverse_requests
from ..passes.timing import compiler_step
from ..emit.symbolic import TANGENT_MIN_STATES, build_symbolic, reads_solve
from .aba import aba
from .chain_loop import chain_loop_plan
from .limbs import LIMB_GROUPS, core_results, limb_inputs, limb_plan
from .crba import crba, implicit_mass_matrix, world_screws
from .lowered import LoweredBody
from .recorder import Recorder
from .rnea import rnea
from .velocities import velocities
from .joint_laws import ramp, secant_friction, step
from .constrained import (accelerations, check_functions, kane_form, kkt_residual, kkt_solve,
                          lower_loops, multiplier_symbols, tree_loops)
from .derivatives import articulated_solve, solve_symbols
from .dynamics_kernel import KERNEL_FUNCTIONS
from .input_jacobian import INPUT_SOLVE_GROUPS, lanes_for, uses_input_solve
from .model import NotATree
from .spatial import cross
from .contacts import BODY_ENERGY, deferred_energy
from ..contact.ground_table import wanted as ground_table_wanted

__all__ = ["TREE_FUNCTION_GROUPS", "TREE_HELPER_USERS", "build_tree_symbolic", "energy_text"]

TREE_FUNCTION_GROUPS = {
    "rhs": ("kin", "ud", "Dpiv", "zd"),
    "jac_x": ("ud", "lam", "Dpiv", "dkin", "tq", "tu", "dres", "sol", "dzd", "anx", "tpw"),
    "jac_r": ("ud", "lam", "Dpiv", "dkin_r", "dres_r", "sol", "dzd_r"),
    "jac_p": ("ud", "lam", "Dpiv", "dkin_p", "dres_p", "sol", "dzd_p"),
    "mass_matrix": ("A", "anx"),         # anx: the loop kernel's inputs (see .dynamics_kernel)
    "forcing": ("b", "anx"),
    "inverse_dynamics": ("tau", "anx"),
    "outputs": ("out",),
    "constraints": ("con",),
    "constraints_jac": ("dcon",),
    "linearize": (),
    "regressor": ("Y",),
    "jvp": ("ud", "lam", "Dpiv", "kin", "dkin", "dkin_p", "tjv", "dres_p", "sol", "zd", "dzd", "dzd_p"),   # see .jvp
    "events": ("ev",),
    "jac_id": ("did", "idq", "idu", "anx", "tpw"),     # see .inverse_derivatives, .analytic (tpw: the pairs' wrench tangents)
    # reverse mode (compiler/emit/reverse.py)
    "vjp": ("ud", "Dpiv", "kin", "zd", "sol", "vj"),
    "hvp": ("ud", "Dpiv", "kin", "zd", "sol", "hr", "ha", "hb"),
    "hess_id": ("tau", "hg"),
    "implicit": ("imp",),                # see implicit_layout
}
TREE_HELPER_USERS = ()
# the straight-line mass_matrix, forcing and inverse_dynamics read A, b, tau; where the loop kernel
# computes one of them it reads only the kernel's inputs anx (see .dynamics_kernel)
_OWN_GROUPS = {"mass_matrix": ("A",), "forcing": ("b",), "inverse_dynamics": ("tau",)}

# Which of mass_matrix, forcing and inverse_dynamics the loop kernel NAME_dyn computes: those
# whose threshold the tree's size reaches, size = entries of M's triangle (pairs of a dof and a
# dof of its support; n(n+1)/2 on a chain of n).  Measured (benchmarks/results/dynamics_kernel.md,
# kernel / straight-line time per call): mass_matrix 1.8-2.1 at 44-231 pairs (Panda, Go2, cart
# n = 20), 1.14 at 341 (G1), 1.18 at 3321 (cart n = 80); forcing and inverse_dynamics 2.2-4.7
# everywhere.  But straight-line code grows: CRBA's as the pairs (G1 295 kB, cart n = 80 1.4 MB,
# a 200-link chain 11.6 MB), RNEA's as the tree (G1 ~150 kB).  G1's default build was 10.8 s CPU
# with all three straight-line and 9.8 s with only mass_matrix from the kernel, over its 9 s
# target (issue 30); so from G1's size up all three come from the kernel, below it none.
DYN_KERNEL_MIN_PAIRS = {"mass_matrix": 300, "forcing": 300, "inverse_dynamics": 300}


def dynamics_kernel_functions(plan, functions):
    """The functions of ``functions`` that NAME_dyn (.dynamics_kernel) computes for this tree.

    Why by size: the kernel is slower at run time than the straight-line recursions (whose
    constants -- axes, masses, inertias -- the optimizer folds, and which need no world
    inertias) but its code does not grow with the model, while straight-line CRBA's is one
    expression per pair, O(n·depth), and RNEA's O(n)."""
    pairs = sum(plan.dep) + plan.nd
    return tuple(f for f in KERNEL_FUNCTIONS if f in functions and pairs >= DYN_KERNEL_MIN_PAIRS[f])


# A tree with ground contacts or body-body pairs (and the analytic plan): mass_matrix from NAME_dyn
# and jac_r from NAME_msolve on M's inputs alone (contact_mass_inputs), inverse_dynamics as
# M u' - f from NAME_implicit's (dynamics_kernel.inverse_dynamics_by_implicit), forcing a call of
# it.  False: their straight-line copies, each with the contacts' and pairs' forces again (the
# C before session 14; benchmarks/bench_mjcf_build.py compares the two).
CONTACT_KERNELS = True


def contact_mass_inputs(plan):
    """The indices of an[] that NAME_dyn's mass matrix and NAME_msolve read (each body's
    placement E, r, its axes S, inertia I, gravity g, the armature), for a plan with ground
    contacts or body-body pairs.

    Why: there the loads' block F, the laws' slopes L and the contacts' block G are guarded
    contact terms that only the analytic jac_x reads (with its own copy of an[]); M has no
    contact term, so mass_matrix and jac_r take the loop kernels (a few kB of C) on these
    inputs rather than straight-line CRBA and ABA solves of their own (gymnasium humanoid:
    131 and 151 kB of C, issue 33's build time)."""
    o = plan.offsets
    ends = sorted(o.values()) + [plan.size]

    def block(name):
        return range(o[name], min(e for e in ends if e > o[name]))
    return tuple(i for name in ("E", "r", "S", "I", "g", "arm") for i in block(name))


_NONFINITE = (sm.nan, sm.zoo, sm.oo, -sm.oo)


def _rename(layout, memo, what, absent):
    """Slot symbols; ``absent``: symbols Kane's equations do not contain (an inertia about
    an axis nothing turns about), which therefore cannot change the result: set to zero.
    A non-finite constant (a load's 0/0 once became NAN in the C) is refused here, naming
    the body, joint or load it came from."""
    def ren(e):
        e = sm.sympify(e)
        if e.has(*_NONFINITE):
            raise ModelError(f"recursive formulation: {what} has a non-finite constant ({e}); "
                             f"no C is written")
        return layout.apply(e.xreplace(absent) if absent else e, what, memo)
    return ren


def _absent(tree, layout):
    from sympy.physics.mechanics import dynamicsymbols
    exprs = [e for b in tree.bodies for e in list(b.inertia) + [b.mass] + list(b.armature)] + list(tree.gravity)
    exprs += [e for ld in tree.loads for e in list(ld.moment) + list(ld.force) + list(ld.offset)]
    free = set().union(*(sm.sympify(e).free_symbols for e in exprs)) if exprs else set()
    return {s: 0 for s in free if s not in layout.subs and s != dynamicsymbols._t}


def _lowered_bodies(tree, layout, rec, memo=None, absent=None):
    """The tree's bodies in slot symbols with their loads; ``memo``: the rename's (Layout.apply),
    shared with the build's later renames of the same expressions (the joint laws, _analytic,
    _input_columns); ``absent``: :func:`_absent` (worked out here when None)."""
    memo = {} if memo is None else memo
    world_rot = {}

    def rotation0(i):
        """World -> body i components (recursive, named; built only for world loads)."""
        if i not in world_rot:
            E = bodies[i].E
            p = tree.bodies[i].parent
            if p < 0:
                world_rot[i] = E
            else:
                R = rotation0(p)
                world_rot[i] = [[rec.let(sum((E[r][k] * R[k][s] for k in range(3)), sm.S.Zero))
                                 for s in range(3)] for r in range(3)]
        return world_rot[i]

    bodies = []
    absent = _absent(tree, layout) if absent is None else absent
    for b in tree.bodies:
        what = f"body {b.name} (joint {b.joint})"
        ren = _rename(layout, memo, what, absent)
        E = b.rotation.applyfunc(ren)
        r = b.position.applyfunc(ren)
        S = None if b.motion is None else [ren(s) for s in b.motion]
        multi = [(k, [ren(s) for s in m]) for k, m in zip(b.speeds, b.motions)] or None
        arm = [ren(a) for a in b.armatures] if b.armature else None
        mass, inertia = ren(b.mass), b.inertia.applyfunc(ren)
        bodies.append(LoweredBody(b, rec, E, r, S, mass, inertia, None, multi, arm))
        bodies[-1].source = (E, r, S, mass, inertia, arm)      # in slot symbols: .chain_loop's pattern
    loads = [load for load in tree.loads if load.frame != "contact"]   # contacts: lowered with the velocities (_contacts)
    renamed = []
    for load in loads:
        ren = _rename(layout, memo, f"a load on body {tree.bodies[load.body].name}", absent)
        renamed.append(([ren(x) for x in load.moment], [ren(x) for x in load.force]))
    shared = rec.shared(e for n, f in renamed for e in n + f)
    for k, load in enumerate(loads):
        i = load.body
        ren = _rename(layout, memo, f"a load on body {tree.bodies[i].name}", absent)
        n, f = shared[6 * k:6 * k + 3], shared[6 * k + 3:6 * k + 6]
        if load.frame == "world":
            R = rotation0(i)
            n = [sum((R[r][k] * n[k] for k in range(3)), sm.S.Zero) for r in range(3)]
            f = [sum((R[r][k] * f[k] for k in range(3)), sm.S.Zero) for r in range(3)]
        off = [ren(x) for x in load.offset]
        n = [n[k] + c for k, c in enumerate(cross(off, f))]
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [old[k] + v for k, v in enumerate(n + f)]
    gravity = [_rename(layout, memo, "gravity", absent)(g) for g in tree.gravity]
    return bodies, gravity


def build_tree_symbolic(tree, formed, layout, functions, outputs=None, events=None, implicit_energy=False,
                        body_loops=False):
    """Symbolic (as :func:`~eomc.compiler.emit.symbolic.build_symbolic`) from the recursions.
    ``implicit_energy``: NAME_implicit ends with the energy output (:func:`implicit_layout`).
    ``body_loops``: the ``energy`` output is read by NAME_energy alone (NAME_outputs its call), which
    may then sum the bodies' shares in a loop over the tree (:mod:`.body_loops`; ``sym.body_loops``
    says whether it does).
    NAME_rhs_batch's lanes are the rhs's code rewritten (compiler/emit/batch.py), a looped chain's
    (tree/chain_loop.py) and the limb routines (tree/limbs.py) included: its wish changes nothing here."""
    rec = Recorder()
    loops = tree_loops(tree)           # a tree closed by constraints: see .constrained
    if loops is not None:
        check_functions(functions)
        refuse_reverse(functions, "is a tree closed by constraints")
    try:
        renamed = {}        # Layout.apply's memo for the renames with _absent (the loads' laws: once)
        absent = _absent(tree, layout)      # (once: it walks every inertia, mass and load)
        bodies, gravity = _lowered_bodies(tree, layout, rec, renamed, absent)
        nq, nu = len(tree.coordinates), len(tree.speeds)
        speeds = layout.x[nq:nq + nu]
        v, c = velocities(bodies, rec, speeds)
        # "energy": NAME_implicit ends with the energy output (implicit_layout) where the model is
        # built for the lanes rollout (implicit_batch), whose energy watch reads it there: elsewhere
        # it would cost every fixed step's call (3-4 % of gymnasium humanoid's) for nothing
        implicit = {"step": step, "energy": implicit_energy} if "implicit" in functions else None
        wants_energy = "outputs" in functions and _asks_energy(outputs)
        guards = []
        # the bodies' part of the energy left for :func:`_bodies_energy` to decide (a loop or straight-line)
        deferred = {} if body_loops and wants_energy else None
        # the joint laws' derivatives, one differentiation per shape of law for the analytic
        # jac_x and NAME_implicit together (analytic._law_slopes)
        law_memo = {}
        # the analytic jac_x's contact terms (compiler/tree/analytic.py), where it may be asked
        ground = ({} if loops is None and set(functions) & {"jac_id", "jac_x"}
                  and len(layout.x) > TANGENT_MIN_STATES else None)
        contact_values = _contacts(tree, bodies, rec, v, layout, implicit,
                                   ((gravity, speeds) if deferred is None else (gravity, speeds, deferred))
                                   if wants_energy else None, guards, ground,
                                   bool(set(functions) & {"hvp", "hess_id"}), ground_table_wanted(functions))
        extra, keep, chain, limbs = [], {}, None, None
        if loops is not None:
            J, gamma = lower_loops(loops, layout, rec)
        jac = set(functions) & {"jac_x", "jac_r", "jac_p", "jvp", "vjp", "hvp"}
        if "rhs" in functions or jac:
            out, margins = aba(bodies, rec, speeds, gravity, v, c, keep=keep), []
            if loops is not None:      # u' = a0 + M⁻¹Jᵀλ; the m pivots of J M⁻¹ Jᵀ join ABA's
                out, margins, kkt = accelerations(J, gamma, bodies, rec, keep, out)
                extra += [(("lam", j), lam) for j, lam in enumerate(kkt[2])]
            if loops is None and not guards:
                chain = chain_loop_plan(tree, bodies, [b.source for b in bodies], dict(rec.assignments),
                                        gravity, layout, functions)
            if loops is None and not guards and chain is None:
                limbs = limb_plan(tree, bodies, dict(rec.assignments), layout, functions)
                if limbs is not None:
                    extra += core_results(bodies, rec, speeds, gravity, v, c, limbs)
            for k, udd, D in out:
                extra.append((("ud", k), udd))
                extra.append((("Dpiv", k), D))
            extra += [(("Dpiv", nu + j), D) for j, D in enumerate(margins)]
        UD = tuple(sm.Symbol(f"ud_{j}", real=True) for j in range(nu))
        jacobian, more = [], ()
        analytic, anx = None, []
        dyn, planned, grounded = (), False, False     # the functions the loop kernel computes (see dynamics_kernel_functions)
        if loops is None and set(functions) & {"jac_id", "jac_x", *KERNEL_FUNCTIONS} and len(layout.x) > TANGENT_MIN_STATES:
            # the laws' slopes named in rec (their CSE once per shape), but for hess_id, whose
            # law Hessians differentiate them (second_order.with_law_hessians)
            analytic, anx = _analytic(tree, bodies, gravity, layout, functions, ground,
                                      None if "hess_id" in functions else rec.let, law_memo, renamed, absent)
            # a plan with ground contacts or pairs serves jac_x and jac_id, and NAME_dyn only its
            # mass matrix (NAME_dyn has no contact terms; M has none): see contact_mass_inputs
            contacted = analytic is not None and bool(analytic.contacts or analytic.npair)
            dyn = (dynamics_kernel_functions(analytic, functions) if analytic is not None and not contacted
                   else ("mass_matrix",) if contacted and CONTACT_KERNELS and "mass_matrix" in functions else ())
            planned = analytic is not None
            grounded = planned and contacted
            if analytic is not None and not dyn and not set(functions) & {"jac_id", "jac_x"}:
                analytic, anx = None, []
        # forcing and inverse_dynamics both straight-line: forcing is -τ at u' = 0, a call of
        # inverse_dynamics (RNEA's code once; only where the plan exists, small trees unchanged)
        by_id = (planned and (CONTACT_KERNELS or not grounded) and {"forcing", "inverse_dynamics"} <= set(functions)
                 and not {"forcing", "inverse_dynamics"} & set(dyn))
        # with contacts, inverse_dynamics is M u' - f from NAME_implicit's (RNEA's straight-line
        # τ would carry every contact force again: dynamics_kernel.inverse_dynamics_by_implicit)
        id_by_implicit = (CONTACT_KERNELS and grounded and {"implicit", "inverse_dynamics"} <= set(functions)
                          and "hess_id" not in functions)
        direct = None
        if "jac_r" in functions and loops is None and jac:
            direct = _input_columns(tree, layout, renamed, absent)
        # jac_r's M⁻¹ through NAME_msolve (.input_jacobian)
        input_solve = (uses_input_solve(analytic, functions, len(layout.x), nq, nu)
                       and (CONTACT_KERNELS or not analytic.contacts))
        # the analytic jac_x needs no residual, nor jac_r solved by NAME_msolve on direct columns
        if jac - ({"jac_x"} if analytic is not None else set()) - ({"jac_r"} if input_solve and direct else set()):
            W = tuple(sm.Symbol(f"w_{j}", real=True) for j in range(nu))
            tau_w = rnea(bodies, rec, W, gravity, v, c)
            if loops is None:
                sol = articulated_solve(bodies, rec, keep, solve_symbols(nu))
                res, more = [-tau_w[k] for k in range(nu)], ()
            else:     # the KKT system's residual and solve (see constrained.kkt_residual)
                lam = multiplier_symbols(len(J))
                res = kkt_residual(tau_w, J, gamma, W, lam)
                sol = kkt_solve(bodies, rec, keep, J, kkt, solve_symbols(len(res)))
                more = solve_symbols(len(res))[nu:] + lam
            jacobian = ([(("tres", k), e) for k, e in enumerate(res)]
                        + [(("sol", k), sol[k]) for k in range(nu)])
        if analytic is not None:
            jacobian += anx
            if analytic.npair and analytic.table >= 0:     # the kernel calls the table's tangent itself
                from ..contact.table import PairTableKernelTape
                info = ground["pair_call"]
                jacobian.append((("tpw", 0), PairTableKernelTape(sm.Integer(info["table"]), info["call"])))
            elif analytic.npair:      # the pairs' wrenches, whose tangents (tpw) fill the kernel's block W
                jacobian += [(("pw", 6 * j + k), x) for j, (_, w) in enumerate(ground["pairs"])
                             for k, x in enumerate(w)]
        jacobian += direct or []
        # inverse_dynamics from the loop kernel where the analytic plan exists (.dynamics_kernel);
        # hess_id's reverse path differentiates RNEA's trace, its analytic kernel does not (and
        # then τ's temporaries, unread, would land in NAME_dyn_inputs, which prints every
        # temporary of its program: a cart of 40 links did not compile, udot undeclared there)
        from .second_order import second_order_plan
        hess_trace = "hess_id" in functions and (analytic is None or second_order_plan(analytic)[0] is None)
        if (("inverse_dynamics" in functions and "inverse_dynamics" not in dyn and not id_by_implicit)
                or hess_trace) and loops is None:
            tau = rnea(bodies, rec, UD, gravity, v, c)
            extra += [(("tau", k), tau[k]) for k in range(nu)]
        if "jac_id" in functions and analytic is None:        # d tau / d x (compiler/tree/inverse_derivatives.py)
            from .inverse_derivatives import inverse_dynamics_results
            jacobian += inverse_dynamics_results(bodies, rec, UD, gravity, v, c)
        regressor = None
        if "regressor" in functions:
            from .regressor import regressor_results
            entries, *regressor = regressor_results(tree, bodies, rec, layout, UD, gravity, v, c)
            extra += entries
        # outputs and events that read u' solve A·u' = b (the Kane path's code)
        need_ab = _NEED_AB - set(dyn) - ({"forcing"} if by_id else set())   # the kernel's, or a call: neither
        if set(functions) & need_ab or ("outputs" in functions and reads_solve(formed, outputs)) or (
                "events" in functions and reads_solve(formed, events)) or (loops and "inverse_dynamics" in functions):
            if set(functions) & need_ab == {"forcing"} and not (outputs or events or loops):
                A = _structure(tree)    # forcing alone: CRBA not computed (M from the kernel)
            else:
                poses = implicit.get("poses") if implicit is not None else None
                if poses is not None:      # the tree is placed in the world: M there where cheaper (.crba)
                    implicit["screws"] = world_screws(bodies, rec, poses)
                    H = implicit_mass_matrix(bodies, rec, poses, implicit["screws"])
                else:
                    H = crba(bodies, rec)
                A = sm.Matrix(nu, nu, lambda i, j: H.get((i, j), 0))
            f0 = rnea(bodies, rec, [0] * nu, gravity, v, c)
            b = [-f0[k] for k in range(nu)]
            if loops is not None:       # Kane's form [Nᵀ M; J], [Nᵀ b; -γ]
                A, b = kane_form(J, gamma, H, b, nu, rec)
                if "inverse_dynamics" in functions:
                    extra += [(("tau", k), rec.let(sm.Add(*[A[k, j] * UD[j] for j in range(nu)])
                                                   - b[k])) for k in range(nu)]
        elif loops is not None:   # not computed: Kane's form is dense
            A, b = sm.ones(nu, nu), [0] * nu
        else:   # not computed: a stand-in with M's structure (for the metadata)
            A, b = _structure(tree), [0] * nu
        if implicit is not None:
            from ..contact.tree import ENERGY, ENERGY_IMPLICIT
            energy = (contact_values.get(ENERGY_IMPLICIT, contact_values.get(ENERGY))
                      if wants_energy and implicit["energy"] else None)
            extra += _implicit_results(tree, bodies, formed, layout, A, b, implicit, nq, nu, law_memo, renamed,
                                       energy)
    except NotATree as exc:
        raise ModelError(f"recursive formulation: {exc}") from None
    groups = {**TREE_FUNCTION_GROUPS, "rhs": LIMB_GROUPS} if limbs is not None else TREE_FUNCTION_GROUPS
    sym = build_symbolic(formed, layout, functions, outputs, events, dynamics=(A, b),
                         prelude=(rec.assignments, rec.count, sorted(extra, key=_order)),
                         function_groups={**groups,
                                          **{f: ("anx",) if f in dyn else () if f == "forcing" and by_id
                                             or f == "inverse_dynamics" and id_by_implicit else g
                                             for f, g in _OWN_GROUPS.items()},
                                          **({"jac_r": INPUT_SOLVE_GROUPS} if input_solve else {})}
                         if planned else groups,
                         helper_users=TREE_HELPER_USERS,
                         extra_inputs=limb_inputs(limbs) + ((BODY_ENERGY,) if deferred else ()))
    if chain is not None:
        sym = replace(sym, chain_loop=chain)
    if limbs is not None:
        sym = replace(sym, limbs=limbs)
    if contact_values:
        sym = _with_contact_values(sym, contact_values)
    if guards:
        sym = replace(sym, guards=tuple(guards))
    if implicit is not None and implicit.get("guards"):
        sym = replace(sym, implicit_guards=tuple(implicit["guards"]))
    if implicit is not None and implicit.get("pair_loads"):
        sym = replace(sym, implicit_pairs=tuple((ld.name if ld.part < 0 else f"{ld.name}:{ld.part}", ld.a.body, ld.b.body)
                                                for ld in implicit["pair_loads"]))
    if analytic is not None and analytic.contacts and ground.get("guards"):
        sym = replace(sym, jac_guards=tuple(ground["guards"]))
    if wants_energy:
        sym = replace(sym, energy=energy_text(tree),
                      implicit_energy=True if implicit and implicit["energy"] else None)
    if regressor:
        sym = replace(sym, regressor_bodies=regressor[0], regressor_reference=regressor[1])
    if analytic is not None:
        sym = replace(sym, analytic=analytic, dynamics_kernel=dyn)
    if by_id:
        sym = replace(sym, forcing_calls="inverse_dynamics")
    if id_by_implicit:
        sym = replace(sym, inverse_dynamics_calls="implicit")
    if planned and set(KERNEL_FUNCTIONS) - set(dyn):     # straight-line ones print only their own temps
        sym = replace(sym, function_groups={**TREE_FUNCTION_GROUPS,
                                            **{f: g for f, g in _OWN_GROUPS.items() if f not in dyn}})
    if grounded and analytic is not None and CONTACT_KERNELS:    # mass_matrix (NAME_dyn), jac_r (NAME_msolve): M's inputs
        sym = replace(sym, mass_inputs=contact_mass_inputs(analytic))
    if input_solve:
        sym = replace(sym, input_solve=lanes_for(len(layout.r)),
                      function_groups={**(sym.function_groups or TREE_FUNCTION_GROUPS), "jac_r": INPUT_SOLVE_GROUPS})
    if "hess_id" in functions:      # second-order inverse dynamics (compiler/emit/reverse.py)
        if loops is not None:
            raise ModelError("hess_id (second-order inverse dynamics) is not generated for a tree "
                             "closed by constraints")
        from .second_order import (ANH, second_order_note, second_order_plan, with_k_derivatives,
                                   with_law_hessians)
        hp, hvals = (analytic, anx) if analytic is not None else _analytic(tree, bodies, gravity, layout, functions)
        hp, why = second_order_plan(hp)
        if hp is not None:      # the analytic kernel (compiler/tree/second_order.py)
            hp, hvals = with_law_hessians(hp, hvals, layout.x, nq)
            hp, hvals = with_k_derivatives(hp, hvals, layout.x)
            sym = replace(sym, program=sym.program.with_(
                results=sym.program.results + tuple(((ANH, k[1]), e) for k, e in hvals)),
                second_order=(hp, len(layout.x)), second_order_note=second_order_note(hp, why),
                function_groups={**(sym.function_groups or TREE_FUNCTION_GROUPS), "hess_id": (ANH,)})
        else:
            inputs, requests = hess_id_requests(layout, nu, sym.seeds)
            sym = replace(sym, program=sym.program.with_(inputs=sym.program.inputs + inputs),
                          derivatives=sym.derivatives + requests, second_order_note=second_order_note(None, why))
    if limbs is not None:       # the rhs reads the core's results (.limbs)
        sym = replace(sym, function_groups={**(sym.function_groups or TREE_FUNCTION_GROUPS), "rhs": LIMB_GROUPS})
    if deferred:
        sym = _bodies_energy(sym, rec, deferred["energy"], functions)
    if not jacobian:
        return sym
    return _with_jacobians(sym, layout, functions, nq, jacobian, more, analytic is not None, direct is not None)


def _bodies_energy(sym, rec, deferred, functions):
    """``sym`` with the energy's bodies' part (left out by lower_contacts, :data:`.contacts.BODY_ENERGY`)
    summed by NAME_energy's loop over the tree where NAME_dyn_inputs and NAME_rd_place are in the
    file (:func:`.body_loops.placed`: ``sym.body_loops``), else straight-line, as it was
    (:func:`.contacts.deferred_energy`: the same program)."""
    from .body_loops import placed
    if placed(sym, functions):
        return replace(sym, body_loops={**(sym.body_loops or {}), "energy": True})
    program = sym.program
    assignments, total = deferred_energy(rec, program.assignments, deferred)
    results = tuple((k, e.xreplace({BODY_ENERGY: total}) if isinstance(e, sm.Basic) and e.has(BODY_ENERGY) else e)
                    for k, e in program.results)
    return replace(sym, program=program.with_(assignments=tuple(assignments), results=results,
                                              inputs=tuple(s for s in program.inputs if s is not BODY_ENERGY)))


def _input_columns(tree, layout, renamed=None, absent=None):
    """jac_r's residual columns d res/d r written directly, [(("dres_r", i, k), expr)], when
    every input acts through the joints' own torques (``Tree.joint_torques``: a URDF's or
    MJCF's actuated joints), else None (then the residual is differentiated, the tangent).

    Why: a joint's torque acts on its child about the axis with its reaction on the parent,
    the generalized force e_i·τ_i; but differentiating the recursion sees the pair in two
    frames, and the ancestors' rows become expressions that are zero only numerically
    (sin² + cos² - 1 and the like): O(n·depth) temporaries, 19,900 columns' entries on a
    200-link chain, all computed, stored and solved.  Directly, column k holds ∂τ_i/∂r_k
    on the rows i of the joints r_k drives (a motor: 1.0 on its own joint's row).

    Checked: every load that reads an input is on a body one of that input's joints
    connects (the child or its parent), so no other load carries it.

    ``renamed``, ``absent``: :func:`_lowered_bodies`' rename memo and :func:`_absent` (the loads
    and joint laws were renamed there and in :func:`_analytic` already: G1's default build
    renamed them all again here, ~0.04 s); None: its own."""
    torques = getattr(tree, "joint_torques", ())
    rs = set(layout.r)
    if not torques or not rs:
        return None
    absent = _absent(tree, layout) if absent is None else absent
    memo = {} if renamed is None else renamed
    speed_of = {u: k for k, u in enumerate(tree.speeds)}
    owner = {s: i for i, b in enumerate(tree.bodies) for s, _ in b.dofs}
    cols, allowed = {}, {}
    for q, u, tau in torques:
        if u not in speed_of or speed_of[u] not in owner:
            return None
        k = speed_of[u]
        t = _rename(layout, memo, f"the torque of the joint of speed {layout.state_names[len(tree.coordinates) + k]}",
                    absent)(tau)
        child, free = owner[k], t.free_symbols      # (once: SymPy walks the tree on every call)
        for j, rj in enumerate(layout.r):
            if rj in free:
                d = sm.diff(t, rj)
                if d.free_symbols & rs:     # not linear in the inputs: leave it to the tangent
                    return None
                cols[(k, j)] = cols.get((k, j), sm.S.Zero) + d
                allowed.setdefault(rj, set()).update({child, tree.bodies[child].parent})
    for load in tree.loads:
        exprs = list(load.moment) + list(load.force) + list(load.offset) + list(getattr(load, "exprs", ()))
        for e in exprs:
            for rj in _rename(layout, memo, f"a load on body {tree.bodies[load.body].name}", absent)(e).free_symbols & rs:
                if load.frame != "body" or load.body not in allowed.get(rj, ()):
                    return None
    return [(("dres_r", i, j), e) for (i, j), e in sorted(cols.items()) if e != 0]


def _analytic(tree, bodies, gravity, layout, functions, ground=None, let=None, law_memo=None, renamed=None,
              absent=None):
    """(plan, results) of the analytic RNEA derivatives (:mod:`.analytic`) for jac_x and jac_id,
    or (None, []) where the tree does not qualify (then both keep the tangent path).

    Asked only above TANGENT_MIN_STATES states: below, the unrolled columns are faster
    (measured, benchmarks/results/derivatives.md: cart n = 4 jac_x 0.55 vs 1.4 µs, UR10
    1.6 vs 2.0 µs), and their C stays as it was.  ``law_memo``: analytic._law_slopes'; ``renamed``:
    the rename's memo of :func:`_lowered_bodies` (the laws it renamed in the loads); ``absent``:
    :func:`_absent` (worked out here when None)."""
    from .analytic import analytic_plan
    absent = _absent(tree, layout) if absent is None else absent
    memo = {} if renamed is None else renamed
    return analytic_plan(tree, bodies, gravity, layout, lambda e, what: _rename(layout, memo, what, absent)(e),
                         (ground or {}).get("contacts"), let, (ground or {}).get("pairs"),
                         _kernel_table(ground, layout), law_memo)


def _kernel_table(ground, layout):
    """The pairs' table id when the analytic kernel forms its inputs' tangents itself (the
    shapes' offsets and the laws' parameters do not read the state: the bodies' placements and
    velocities are all that move along a state column; compiler/tree/analytic.py), else None
    (then block W, filled per column from the table's tangent code)."""
    info = (ground or {}).get("pair_call")
    if not info:
        return None
    xs = set(layout.x)
    if any(getattr(e, "free_symbols", set()) & xs for e in info["fixed"]):
        return None
    return info["table"]


def energy_text(tree):
    """What the generated ``energy`` output holds (NAME.json "energy"; the runtime's verdict reads
    "joint limits" in it to trust the limits' springs counted, runtime/switching.py)."""
    from ..contact.pairs import PairLoad
    from ..contact.tree import ContactLoad
    text = "kinetic, gravity" + (" and the ground contacts' elastic energy"
                                 if any(isinstance(ld, ContactLoad) for ld in tree.loads) else "")
    if any(isinstance(ld, PairLoad) for ld in tree.loads):
        text += ", the body-body contacts' elastic energy"
    if getattr(tree, "spring_energy", None) is not None:
        servos = any(n.startswith("bias") for n in getattr(tree, "spring_parameters", ()))
        text += (", the springs' potential (joints, fixed tendons" + (", servos' bias at zero control"
                                                                         if servos else "") + ")")
    text += " and the joint limits' springs" if getattr(tree, "joint_energy", None) else ""
    if getattr(tree, "activations", ()):      # the runtime's verdict reads it (energy_verdict)
        from eomc.runtime.switching import ACTIVATIONS_AT_REST
        text += f"; {ACTIVATIONS_AT_REST}"
    return text


def _asks_energy(outputs):
    """Does an output read the passive tree's ``energy`` placeholder (contact/tree.ENERGY)?"""
    from ..contact.tree import ENERGY
    return any(getattr(e, "has", None) and e.has(ENERGY) for e in (outputs or {}).values())


def _contacts(tree, bodies, rec, v, layout, implicit=None, energy=None, guards=None, ground=None, second=False,
              table=False):
    """Ground contacts (eomc.compiler.contact.tree): their forces into the bodies' ``fext``
    from the world positions and velocities of their points, built recursively with ``rec``;
    returns {placeholder of a contact output or event: its temporary}."""
    if energy is None and not any(load.frame == "contact" for load in tree.loads):
        return {}
    from .contacts import lower_contacts
    memo = {}
    with compiler_step("contacts"):
        return lower_contacts(tree, bodies, rec, v, lambda e, what: _rename(layout, memo, what, None)(e),
                              implicit, energy, guards, ground, second, table)


def implicit_layout(nq, nu, ncontact, energy=False):
    """Offsets into out[] of NAME_implicit (runtime/c/eomc_fixedstep.c reads it so):

        M      nu*nu   the mass matrix, row-major (both triangles)
        f      nu      the forcing (M u' = f)
        qd     nq      q' at (q, u)
        N      nq*nu   dq'/du (q' is linear in u: q'(q, u + du) = q' + N du)
        screw  6*nu    per speed, its motion in the world: (ω, v0), the velocity of a point p
                       of a body it moves is ω x p + v0 per unit speed
        joint  2*nu    per speed, -d(joint law)/du and -d(joint law)/dq (0: none)
        contact 25 per contact: depth, point (3), its velocity (3), K (9), C (9), world
                       (compiler/contact/law.ground_jacobians); the ground contacts, then the
                       body-body pairs' points (their second body's motion relative to the first:
                       compiler/contact/pairs.law_slopes; depth and point 0 where the pair's
                       broad phase skips it)
        energy 1       (``energy``: built with implicit_batch and an ``energy`` output) that
                       output at the call's state (a pairs' table's points' elastic energy summed
                       by its slopes loop: ENERGY_IMPLICIT): the fixed step makes the terms at every
                       step's end anyway, so the lanes rollout's energy watch reads it there instead
                       of calling NAME_energy (19-20 % of G1's lanes rollout, session 18;
                       eomc_implicit.energy)"""
    out, pos = {}, 0
    for key, size in (("M", nu * nu), ("f", nu), ("qd", nq), ("N", nq * nu), ("screw", 6 * nu),
                      ("joint", 2 * nu), ("contact", 25 * ncontact)):
        out[key] = pos
        pos += size
    if energy:
        out["energy"] = pos
        pos += 1
    out["size"] = pos
    return out


def _implicit_results(tree, bodies, formed, layout, A, b, implicit, nq, nu, law_memo=None, renamed=None,
                      energy=None):
    """The ("imp", k) results of NAME_implicit, laid out as :func:`implicit_layout`.

    ``law_memo``: :func:`.analytic._law_slopes`' memo: the joint laws' slopes are SymPy's
    derivatives taken once per shape of law (the analytic jac_x's, when it was planned); each
    law's own diff was a quarter of gymnasium ant's generate phase.  ``renamed``: the rename's
    memo of :func:`_lowered_bodies` (the laws it renamed in the loads: not rebuilt again, 3 % of
    the humanoid's generate phase).  Sound: a law renamed here holds no :func:`_absent` symbol
    (it would have no slot), so its key is the one the loads' rename used."""
    from .analytic import _law_slopes
    law_memo = {} if law_memo is None else law_memo
    contacts = implicit.get("contacts", []) + implicit.get("pairs", [])    # as implicit_metadata lists them
    at = implicit_layout(nq, nu, len(contacts), energy is not None)
    out = {} if energy is None else {at["energy"]: energy}
    for i in range(nu):
        for j in range(nu):
            out[at["M"] + i * nu + j] = A[max(i, j), min(i, j)]
        out[at["f"] + i] = b[i]
    speeds = layout.x[nq:nq + nu]
    kin = [layout.apply(e, "the kinematic equations") for e in formed.kinematics]
    for i, e in enumerate(kin):
        out[at["qd"] + i] = e
        for j, u in enumerate(speeds):
            out[at["N"] + i * nu + j] = sm.diff(e, u)
    # named with M (.crba.world_screws); none in a tree without contacts placed in the world (the fast
    # path reads the screws for its contacts' Jacobians only)
    for k, screw in implicit.get("screws", {}).items():
        for a in range(6):
            out[at["screw"] + 6 * k + a] = screw[a]
    coords = list(tree.coordinates)
    speed_of = {u: k for k, u in enumerate(tree.speeds)}
    memo = {} if renamed is None else renamed
    for q, u, tau in getattr(tree, "joint_torques", ()):
        if u not in speed_of or q not in coords or tau == 0:
            continue
        k, qi = speed_of[u], coords.index(q)
        what = f"the law of the joint of speed {layout.state_names[nq + k]}"
        # |a| as 2 ramp(a) - a before differentiating: SymPy's d|a| divides by |a| (0/0 where a
        # unilateral limit is not engaged); ramp's derivative is the step function
        t = layout.apply(tau, what, memo).replace(sm.Abs, lambda a: 2 * ramp(a) - a)
        qs, us = layout.x[qi], layout.x[nq + k]
        # the friction's slope in u is its secant (joint_laws.secant_tanh: the tangent, nil in a
        # fast slip, left the friction explicit and the step gained energy)
        dq, du = _law_slopes(secant_friction(t, us), qs, us, law_memo)
        out[at["joint"] + 2 * k] = -du
        if sm.simplify(kin[qi] - us) == 0:        # q' = u: dq/du of the step is h
            out[at["joint"] + 2 * k + 1] = -dq
    for c, item in enumerate(contacts):
        base = at["contact"] + 25 * c
        vals = ([item["depth"]] + list(item["point"]) + list(item["velocity"])
                + [x for row in item["K"] for x in row] + [x for row in item["C"] for x in row])
        for a, e in enumerate(vals):
            out[base + a] = e
    return [(("imp", k), e) for k, e in sorted(out.items()) if e != 0]


def _with_contact_values(sym, values):
    """Outputs and events that name a contact's force or depth: the placeholder replaced by
    the temporary the recursion computed (the same value the rhs uses).  Which results hold a
    placeholder: one walk each for the placeholders' types (``e.has(*values)`` walked each
    result once per placeholder: 5 % of gymnasium humanoid's generate phase)."""
    kinds = tuple({type(k) for k in values})

    def holds(e):
        return hasattr(e, "atoms") and not values.keys().isdisjoint(e.atoms(*kinds))
    results = tuple((key, e.xreplace(values) if holds(e) else e) for key, e in sym.program.results)
    return replace(sym, program=sym.program.with_(results=results))


def _with_jacobians(sym, layout, functions, nq, jacobian, more=(), analytic=False, direct_r=False):
    """Add the residual and the M⁻¹ solve to the program, and ask for their derivatives
    (``analytic``: jac_x and jac_id take theirs from :mod:`.analytic` instead; ``direct_r``:
    jac_r's columns are among ``jacobian`` already, see :func:`_input_columns`)."""
    derivatives = []
    if "jac_id" in functions and not analytic:
        from .inverse_derivatives import inverse_dynamics_derivatives
        derivatives += inverse_dynamics_derivatives(layout, sym.seeds, nq)
    plan = getattr(sym, "analytic", None)
    if analytic and plan is not None and plan.npair and plan.table < 0 and set(functions) & {"jac_x", "jac_id"}:
        # the pairs' wrench along one state column (seeds dx = e_k), per column: block W (.analytic)
        derivatives.append(("pw", dict(zip(layout.x, sym.seeds)), "tpw"))
    if "jac_x" in functions and not analytic:
        if len(layout.x) > TANGENT_MIN_STATES:
            derivatives += [("tres", dict(zip(layout.x[:nq], sym.seeds[:nq])), "tq"),
                            ("tres", dict(zip(layout.x[nq:], sym.seeds[nq:])), "tu")]
        else:
            derivatives.append(("tres", layout.x, "dres"))
    if "jac_r" in functions and not direct_r:
        derivatives.append(("tres", layout.r, "dres_r"))
    if "jac_p" in functions or "jvp" in functions:
        derivatives.append(("tres", layout.p, "dres_p"))
    if "jvp" in functions:     # one tangent along a whole state direction (seeds = the direction)
        derivatives.append(("tres", dict(zip(layout.x, sym.seeds)), "tjv"))
    reverse_inputs, requests = reverse_requests(functions, layout, "tres", nq, len(sym.UD), sym.W, sym.seeds)
    derivatives += requests
    more = tuple(more) + reverse_inputs
    # ``more``: a closed tree's g_nu.. (constraint rows) and λ symbols (constrained.kkt_residual)
    program = sym.program.with_(inputs=sym.program.inputs + solve_symbols(len(sym.UD)) + tuple(more),
                                results=sym.program.results + tuple(jacobian))
    return replace(sym, program=program, derivatives=sym.derivatives + tuple(derivatives))


_NEED_AB = {"mass_matrix", "forcing", "implicit"}


def _structure(tree):
    """1 where M can be nonzero: speeds on one root-to-leaf path."""
    nu = len(tree.speeds)
    A = [[0] * nu for _ in range(nu)]          # lists, then one Matrix: O(n²) SymPy setitems were 0.4 s at n = 200
    for i, b in enumerate(tree.bodies):
        for speed, _ in b.dofs:
            j = i
            while j >= 0:
                for other, _ in tree.bodies[j].dofs:
                    A[speed][other] = A[other][speed] = 1
                j = tree.bodies[j].parent
    return sm.Matrix(nu, nu, [x for row in A for x in row])


def _order(item):
    key = item[0]
    return (key[0], key[1:])
