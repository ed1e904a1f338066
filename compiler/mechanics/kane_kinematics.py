"""Kinematic differential equations and motion constraints, as matrices.

    k_kq̇(q,t) q' + k_ku(q,t) u + f_k(q,t) = 0     -> q' = −k_kq̇⁻¹ (k_ku u + f_k)
    f_h(q,t) = 0                                  (configuration constraints)
    k_nh(q,t) u + f_nh(q,t) = 0                   (velocity constraints)
    k_dnh(q,t) u' + f_dnh(q,u,t) = 0              (their time derivative)

Dependent speeds are eliminated from Kane's equations with
A_rs = −B_dep⁻¹ B_ind (B = k_nh split into independent/dependent columns),
solved symbolically like SymPy does; the compiler can still solve the full
augmented system numerically, because the mass matrix keeps k_dnh as rows.
"""
import sympy as sm
from sympy.physics.mechanics import msubs
from sympy.physics.vector import dynamicsymbols

from eomc.runtime.errors import ModelError

from sympy.solvers.solveset import NonlinearError

from .plain import linear_coefficients

__all__ = ["linear_solver", "kinematic_matrices", "constraint_matrices", "NotLinearError"]


class NotLinearError(ModelError, NonlinearError):
    """An equation that must be linear in its unknowns is not.

    Also SymPy's ``NonlinearError``, which SymPy 1.14's KanesMethod raises for a
    nonlinear velocity constraint, so code (and SymPy's tests) catching that keeps working.
    """


def linear_solver(method):
    """'LU', 'auto' (see :func:`pivot_free_solve`), any Matrix.solve method name, or a
    callable f(A, b)."""
    if callable(method):
        return method
    if method == "auto":
        return pivot_free_solve
    if method in (None, "LU"):
        return lambda A, b: A.LUsolve(b)
    return lambda A, b: A.solve(b, method=method)


def pivot_free_solve(A, b):
    """Cramer's rule up to 3 unknowns, LU beyond.

    Why: SymPy's LUsolve pivots on the symbolic entries as they stand, so a
    pivot that vanishes at some state (the Whipple bicycle's at upright) becomes
    a division by zero in the generated code, although the matrix is regular
    there.  Cramer's rule divides by the determinant only, which is nonzero
    wherever the system can be solved at all; beyond 3 unknowns its expressions
    grow too fast, and LU is used.
    """
    if A.rows == A.cols and A.rows <= 3:
        return A.solve(b, method="CRAMER")
    return A.LUsolve(b)


def _split_linear(eqs, unknowns, others, role):
    """Coefficient matrices of eqs, linear in ``unknowns`` then ``others``, and the rest.

    Uses temporary Dummies so the coefficients are read without ``diff`` on
    functions of time.  Raises ModelError naming any equation that is not
    linear in them.
    """
    allv = list(unknowns) + list(others)
    dums = [sm.Dummy() for _ in allv]
    sub = dict(zip(allv, dums))
    back = dict(zip(dums, allv))
    A = sm.zeros(len(eqs), len(unknowns))
    B = sm.zeros(len(eqs), len(others))
    rest = sm.zeros(len(eqs), 1)
    for i, eq in enumerate(eqs):
        e = sm.sympify(eq).xreplace(sub)
        coeffs = linear_coefficients(e, dums)
        for j, c in enumerate(coeffs):
            bad = c.free_symbols & set(dums)
            if bad:
                names = ", ".join(sorted(str(back[d]).replace("(t)", "") for d in bad))
                raise NotLinearError(f"{role} #{i + 1} ({eq}) is not linear in {names}")
            if c == 0:
                continue
            c = c.xreplace(back)
            if j < len(unknowns):
                A[i, j] = c
            else:
                B[i, j - len(unknowns)] = c
        rest[i] = e.xreplace(dict.fromkeys(dums, 0)).xreplace(back)
    return A, B, rest


def _solve(A, b, solver, eqs, role):
    if A.is_diagonal():
        for i in range(A.rows):
            if A[i, i] == 0:
                raise ModelError(f"cannot solve the {role}s for the unknowns: {role} #{i + 1} "
                                 f"({eqs[i]}) does not contain its unknown")
        return sm.Matrix(b.rows, b.cols, lambda i, j: b[i, j] / A[i, i])
    try:
        x = solver(A, b)
    except (ValueError, ZeroDivisionError) as exc:
        listed = "; ".join(f"#{i + 1}: {e}" for i, e in enumerate(eqs))
        raise ModelError(f"the {role}s cannot be solved for their unknowns ({exc}); "
                         f"equations {listed}") from None
    if any(e.has(sm.zoo, sm.nan) for e in x):
        listed = "; ".join(f"#{i + 1}: {e}" for i, e in enumerate(eqs))
        raise ModelError(f"the {role}s cannot be solved for their unknowns (singular); "
                         f"equations {listed}")
    return x


def kinematic_matrices(kd_eqs, q, u, uaux, solver):
    """Return a dict of the implicit and explicit kinematic matrices and q' map."""
    t = dynamicsymbols._t
    qdot = [qi.diff(t) for qi in q]
    eqs = list(kd_eqs)
    if len(eqs) != len(q):
        qs = ", ".join(str(x).replace("(t)", "") for x in q)
        raise ModelError(f"{len(eqs)} kinematic differential equation(s) were given for "
                         f"{len(q)} coordinate(s) ({qs}); give exactly one per coordinate")
    k_kqdot, k_ku, f_k = _split_linear(eqs, qdot, u, "kinematic differential equation")
    for i in range(len(eqs)):
        if all(k_kqdot[i, j] == 0 for j in range(len(q))):
            raise ModelError(f"kinematic differential equation #{i + 1} ({eqs[i]}) contains no "
                             "coordinate derivative q', so the equations cannot be solved for q'")
    if not k_kqdot.is_diagonal() and len(q) <= 8 and sm.expand(k_kqdot.det()) == 0:
        raise ModelError("the kinematic differential equations cannot be solved for q' "
                         "(their q' coefficient matrix is singular): "
                         + "; ".join(f"#{i + 1}: {e}" for i, e in enumerate(eqs)))
    uaux_zero = dict.fromkeys(uaux, 0)
    f_k_explicit = _solve(k_kqdot, f_k, solver, eqs, "kinematic differential equation")
    k_ku_explicit = _solve(k_kqdot, k_ku, solver, eqs, "kinematic differential equation")
    qdot_rhs = sm.Matrix([
        -sm.Add(*[k_ku_explicit[i, j] * u[j] for j in range(len(u)) if k_ku_explicit[i, j] != 0],
                f_k_explicit[i])
        for i in range(len(q))])
    z = (lambda m: m.xreplace(uaux_zero)) if uaux_zero else (lambda m: m)
    return {
        "k_kqdot_implicit": k_kqdot,
        "k_ku_implicit": z(k_ku),
        "f_k_implicit": z(f_k),
        "k_ku": z(k_ku_explicit),
        "f_k": z(f_k_explicit),
        "qdot_u_map": dict(zip(qdot, qdot_rhs)),
    }


def constraint_matrices(config, vel, acc, u, udep, qdot_map, solver):
    """f_h, k_nh, f_nh, k_dnh, f_dnh and A_rs (empty matrices when unconstrained)."""
    t = dynamicsymbols._t
    f_h = sm.Matrix(config) if config else sm.Matrix()
    out = {"f_h": f_h, "k_nh": sm.Matrix(), "f_nh": sm.Matrix(), "k_dnh": sm.Matrix(),
           "f_dnh": sm.Matrix(), "Ars": sm.Matrix()}
    if not vel:
        return out
    o, m = len(u), len(udep)
    p = o - m
    vel = [msubs(sm.sympify(v), qdot_map) if qdot_map else sm.sympify(v) for v in vel]
    k_nh, _, rest = _split_linear(vel, u, [], "velocity constraint")
    f_nh = rest
    if acc:
        udot = [x.diff(t) for x in u]
        acc = [msubs(sm.sympify(a), qdot_map) if qdot_map else sm.sympify(a) for a in acc]
        k_dnh, _, f_dnh = _split_linear(acc, udot, [], "acceleration constraint")
    else:
        f_dnh = k_nh.diff(t) * sm.Matrix(u) + f_nh.diff(t)
        if qdot_map:
            f_dnh = msubs(f_dnh, qdot_map)
        k_dnh = k_nh
    B_ind, B_dep = k_nh[:, :p], k_nh[:, p:o]
    Ars = -_solve(B_dep, B_ind, solver, vel, "velocity constraint")
    out.update(k_nh=k_nh, f_nh=f_nh, k_dnh=k_dnh, f_dnh=f_dnh, Ars=Ars)
    return out
