"""The recursive formulation's Jacobians: inverse dynamics differentiated, then M⁻¹ by ABA.

The solved accelerations w = u'(x) satisfy ``tau(q, u, w) = 0`` (the joint forces
the loads leave over, RNEA with the loads as external forces), so with w held at
its solved value

    du'/dx_k = -M⁻¹ ∂tau/∂x_k = M⁻¹ G_k,    G_k = ∂res/∂x_k,  res = -tau(q, u, W).

* ``res`` is RNEA run on the symbols ``W`` (C: the array ``w`` the jac_x body
  fills from its own ABA): O(n) code.  Its derivative along one state is the
  tangent of that O(n) trace, so the 2n columns cost O(n²) in all, where
  differentiating M (CRBA) and b column by column cost O(n³) (and O(n²) code
  per column when unrolled).
* ``M⁻¹ G`` is the articulated-body recursion on the generalized force G alone
  (no velocity, no gravity), reusing ABA's U_i and 1/D_i: O(n) per column, with
  no mass matrix, no factorization, no dense solve.  The solve reads its right-hand
  side from symbols ``g_j`` (C: the array ``G``), so its code is written once and
  run in a loop over the columns.

jac_r is the same with the inputs' directions: inputs enter only as loads.
"""
import sympy as sm

from .spatial import _dot, x_motion, xt_force

__all__ = ["solve_symbols", "articulated_solve"]


def solve_symbols(nu):
    """The right-hand side ``g_j`` of :func:`articulated_solve` (C: ``G[j]``)."""
    return tuple(sm.Symbol(f"g_{j}", real=True) for j in range(nu))


def articulated_solve(bodies, rec, keep, g):
    """{speed index: (M⁻¹ g)_speed}: ABA with zero velocities, zero gravity, no loads
    and joint forces ``g``, from ABA's ``keep`` = {body: (U_i, 1/D_i)}."""
    n = len(bodies)
    p = [[0] * 6 for _ in range(n)]
    uu = [None] * n
    for i in reversed(range(n)):
        b = bodies[i]
        pi = rec.vec(p[i])
        if b.S is not None:
            U, Dinv = keep[i]
            uu[i] = rec.let(g[b.speed] - _dot(b.S, pi))
            s = rec.let(uu[i] * Dinv)
            pi = [pi[k] + U[k] * s for k in range(6)]
        elif b.multi:
            U, Dinv = keep[i]            # U: k rows of 6, Dinv: the factored kxk D
            uu[i] = rec.vec([g[s] - _dot(S, pi) for s, S in b.multi])
            s = Dinv.solve(uu[i])
            pi = [pi[k] + sum((U[m][k] * s[m] for m in range(len(s))), sm.S.Zero) for k in range(6)]
        if b.parent >= 0:
            f = xt_force(b, rec.vec(pi))
            p[b.parent] = [p[b.parent][k] + f[k] for k in range(6)]
    a, out = [None] * n, {}
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else [0] * 6
        ai = rec.vec(x_motion(b, ap))
        if b.S is not None:
            U, Dinv = keep[i]
            udd = rec.let((uu[i] - _dot(U, ai)) * Dinv)
            ai = [ai[k] + b.S[k] * udd for k in range(6)]
            out[b.speed] = udd
        elif b.multi:
            U, Dinv = keep[i]
            udd = Dinv.solve(rec.vec([uu[i][m] - _dot(U[m], ai) for m in range(len(b.multi))]))
            for m, (s, S) in enumerate(b.multi):
                ai = [ai[k] + S[k] * udd[m] for k in range(6)]
                out[s] = udd[m]
        a[i] = rec.vec(ai)
    return out
