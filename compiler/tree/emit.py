"""C bodies of the recursive formulation's own functions (rhs, mass_matrix, forcing, inverse_dynamics).

The rest (jac_x, jac_r, linearize, outputs, constraints) is emitted by the
Kane path's code from the same program (see :mod:`.lower`).
"""
from ..emit.bodies import _IND, _store, _temps

__all__ = ["tree_rhs_body", "tree_matrix_body"]


def tree_rhs_body(ctx, program):
    """q' and u' straight from the ABA trace; a non-positive articulated inertia D
    (a body with nothing to resist turning about its axis) is EOMC_SINGULAR_MASS_MATRIX."""
    pr = ctx.printer(program)
    lines = _temps(program, pr)
    pivots = [pr.doprint(e) for k, e in program.results if k[0] == "Dpiv"]
    if pivots:
        cond = " || ".join(f"!({d} > 0.0)" for d in pivots)
        lines.append(f"{_IND}if ({cond}) return EOMC_SINGULAR_MASS_MATRIX;")
    vals = dict(program.results)
    for i in range(ctx.nq):
        lines.append(_store(f"xdot[{i}]", vals.get(("kin", i), 0.0), pr))
    for i in range(ctx.nu):
        lines.append(_store(f"xdot[{ctx.nq + i}]", vals.get(("ud", i), 0.0), pr))
    lines.append(f"{_IND}return {ctx.name}_finite(xdot, {ctx.nq + ctx.nu});")
    return lines


def tree_matrix_body(ctx, program, fn):
    """mass_matrix (CRBA, group A: lower triangle), forcing (b) or inverse_dynamics (tau)."""
    pr = ctx.printer(program)
    lines = _temps(program, pr)
    vals = dict(program.results)
    nu = ctx.nu
    if fn == "mass_matrix":
        for i in range(nu):
            for j in range(nu):
                lines.append(_store(f"out[{i * nu + j}]", vals.get(("A", max(i, j), min(i, j)), 0.0), pr))
        out, size = "out", nu * nu
    elif fn == "forcing":
        lines += [_store(f"out[{i}]", vals.get(("b", i), 0.0), pr) for i in range(nu)]
        out, size = "out", nu
    else:
        lines += [_store(f"tau[{i}]", vals.get(("tau", i), 0.0), pr) for i in range(nu)]
        out, size = "tau", nu
    lines.append(f"{_IND}return {ctx.name}_finite({out}, {size});")
    return lines
