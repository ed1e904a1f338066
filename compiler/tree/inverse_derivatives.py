"""jac_id: the derivatives of inverse dynamics, d tau / d x at given accelerations u'.

tau(q, u, u') = M(q) u' - f(q, u) is RNEA run on the given u' (the C array ``udot``)
with the model's own loads (gravity, joint laws, inputs) as external forces, the
same trace ``inverse_dynamics`` evaluates.  jac_id returns its Jacobian with respect
to the whole state x = [q; u; z], row-major nu x nx:

    out[i * nx + k] = d tau_i / d x_k

so ``out[:, :nq]`` is d tau/dq in the model's coordinates and ``out[:, nq:nq+nu]`` is
d tau/du; d tau/du' is the mass matrix (``mass_matrix``).  This is what
trajectory optimisers and MPC (Crocoddyl, ...) read, and what Pinocchio's
``computeRNEADerivatives`` returns (there with respect to its Lie-group tangent:
on a floating base, d tau/dq · K(q) with K = dq'/du, the kinematic matrix).

The columns are the tangents of RNEA's O(n) trace along one state each, the code
written once and run in a C loop over the columns (as jac_x's residual, see
:mod:`.derivatives`): code size O(n), work O(n) per column.  For a few states the
columns are unrolled instead (:data:`~eomc.compiler.emit.symbolic.TANGENT_MIN_STATES`).
"""
from collections import Counter

import sympy as sm

from ..emit.bodies import IND, store, temps, needed_assignments, split_on
from ..emit.symbolic import TANGENT_MIN_STATES
from ..ir.opcount import count_ops
from .rnea import rnea
from .emit import _hoist, name_loop_inputs

__all__ = ["inverse_dynamics_results", "inverse_dynamics_derivatives", "jac_id_body", "jac_id_ops"]

# result groups: tau itself, its unrolled derivative (i, k), its tangents along q- and u-seeds
TAU, UNROLLED, TANGENTS = "tid", "did", (("idq", "q"), ("idu", "u"))


def inverse_dynamics_results(bodies, rec, UD, gravity, v, c):
    """[(("tid", speed), tau)]: RNEA at the given accelerations ``UD`` (C: ``udot``)."""
    tau = rnea(bodies, rec, UD, gravity, v, c)
    return [((TAU, k), tau[k]) for k in range(len(UD))]


def inverse_dynamics_derivatives(layout, seeds, nq):
    """The derivative requests (source group, wrt, target group) for the shared optimizer:
    tangents along the coordinates' and the other states' seeds (``dx`` in C), or the
    unrolled Jacobian for a few states."""
    x = layout.x
    if len(x) > TANGENT_MIN_STATES:
        return [(TAU, dict(zip(x[:nq], seeds[:nq])), "idq"), (TAU, dict(zip(x[nq:], seeds[nq:])), "idu")]
    return [(TAU, x, UNROLLED)]


def _plan(program, seeds, nq, nu, nx):
    """(once assignments, [(lvalue, expr)] stores written once, loops [(first column, end
    column, column assignments, [(lvalue, expr)] of the column)]), cached on the program."""
    key = ("jac_id", tuple(seeds), nq, nu, nx)
    plans = program.__dict__.setdefault("_jacobian_plans", {})
    if key not in plans:
        plans[key] = _make_plan(program, seeds, nq, nu, nx)
    return plans[key]


def _make_plan(program, seeds, nq, nu, nx):
    unrolled = program.result_exprs(UNROLLED)
    stores = [(f"out[{i * nx + k}]", unrolled.get((UNROLLED, i, k), sm.S.Zero))
              for i in range(nu) for k in range(nx)] if unrolled else []
    blocks = [(g, 0 if which == "q" else nq, nq if which == "q" else nx) for g, which in TANGENTS
              if any(k[0] == g for k, _ in program.results)]
    columns = {g: program.result_exprs(g) for g, _, _ in blocks}
    exprs = [e for _, e in stores] + [e for vals in columns.values() for e in vals.values()]
    prog = program.with_(assignments=tuple(needed_assignments(program.assignments, exprs)))
    once, rest = split_on(prog, tuple(seeds))
    loops = []
    for g, start, end in blocks:
        vals = columns[g]
        inner = needed_assignments(rest, vals.values())
        col = [(f"out[{i * nx} + k]", vals.get((g, i), sm.S.Zero)) for i in range(nu)]
        loops.append((start, end, inner, col, [], {}))
    program, once, stores, loops = _hoist(program, once, stores, loops, set(seeds))
    return program, once, stores, [(s, e, inner, col) for s, e, inner, col, _, _ in loops]


def jac_id_body(ctx, program, seeds):
    """C body of NAME_jac_id (see the module docstring)."""
    nq, nu, nx = ctx.nq, ctx.nu, ctx.nx
    program, once, stores, loops = _plan(program, seeds, nq, nu, nx)
    pr = ctx.printer(program)
    nlive = name_loop_inputs(pr, once, (e for _, _, inner, col in loops
                                        for e in [e for _, e in inner] + [e for _, e in col]))
    decls = ([f"double dx[{nx}];", "int i, k;"] if loops else []) + ([f"double P[{nlive}];"] if nlive else [])
    lines = [f"{IND}{d}" for d in decls]
    lines += temps(program, pr, once)
    lines += [store(lv, e, pr) for lv, e in stores]
    if loops:
        lines.append(f"{IND}for (i = 0; i < {nx}; i++) dx[i] = 0.0;")
    for start, end, inner, col in loops:
        body = temps(program, pr, inner) + [store(lv, e, pr) for lv, e in col]
        lines += [f"{IND}for (k = {start}; k < {end}; k++) {{", f"{IND * 2}dx[k] = 1.0;", f"{IND * 2}{{"]
        lines += [IND * 2 + line for line in body]
        lines += [f"{IND * 2}}}", f"{IND * 2}dx[k] = 0.0;", f"{IND}}}"]
    lines.append(f"{IND}return {ctx.name}_finite(out, {nu * nx});")
    return lines


def jac_id_ops(program, seeds, nq, nu, nx):
    """Operations of :func:`jac_id_body`: the once-part, plus each column's part per column."""
    _, once, stores, loops = _plan(program, seeds, nq, nu, nx)
    c = Counter()
    for _, e in once + stores:
        count_ops(e, c)
    for start, end, inner, col in loops:
        per = Counter()
        for _, e in inner + col:
            count_ops(e, per)
        for _ in range(end - start):
            c += per
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
