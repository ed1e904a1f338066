"""Lagrange's equations of kinetic-energy terms ``c X**2`` in closed form.

Why: most Lagrangians are sums of ``c X**2`` with a constant ``c`` (a mass or
a principal moment of inertia over two) and ``X`` a velocity component,
affine in q'.  Differentiating such a term blindly gives ``dL/dq`` and
``(d2L/dq' dq) q'`` as two large expressions that cancel only
mathematically.  Written out, with ``J_i = dX/dq'_i`` (free of q'),

    M_ij += 2c J_i J_j
    f_i  += 2c (X K_i - J_i R),   R   = sum_j dX/dq_j q'_j + dX/dt,
                                  K_i = dX/dq_i - sum_j dJ_i/dq_j q'_j - dJ_i/dt,

and ``K_i`` is structurally zero whenever ``X`` is the time derivative of a
position (translation in an inertial frame), which leaves Kane's compact
``-m v_r . a`` form.  Everything else in L goes through the general Hessian
path of :mod:`.lagrange_terms`.
"""
import sympy as sm
from sympy.physics.vector import dynamicsymbols

__all__ = ["split_squares", "square_mass_forcing"]

_t = dynamicsymbols._t


def _squares_of(term, pv):
    """(c, [X, ...]) if ``term`` is ``c * X**2`` or ``c * (X1**2 + X2**2 + ...)``."""
    D = pv.differentiator
    consts, others = [], []
    for f in sm.Mul.make_args(term):
        (others if D.deps(f) else consts).append(f)
    if len(others) != 1:
        return None
    body = others[0]
    parts = sm.Add.make_args(body) if body.is_Add else (body,)
    if not all(p.is_Pow and p.exp == 2 for p in parts):
        return None
    qd = set(pv.qd)
    xs = [p.base for p in parts]
    for X in xs:
        if not D.deps(X) & qd:
            return None
        if any(D.deps(D.diff(X, v)) & qd for v in pv.qd):
            return None  # not affine in q'
    return sm.Mul(*consts), xs


def split_squares(L, pv):
    """Split L into ({c: [X, ...]}, rest) -- see the module docstring."""
    groups, rest = {}, []
    for term in sm.Add.make_args(L):
        found = _squares_of(term, pv)
        if found is None:
            rest.append(term)
        else:
            groups.setdefault(found[0], []).extend(found[1])
    return groups, sm.Add(*rest)


def _term_contributions(X, pv, m_terms, f_terms):
    d = pv.differentiator.diff
    n = len(pv.q)
    J = [d(X, v) for v in pv.qd]
    R = sm.Add(*[d(X, q) * v for q, v in zip(pv.q, pv.qd)]) + d(X, _t)
    for i in range(n):
        K = d(X, pv.q[i]) - sm.Add(*[d(J[i], q) * v for q, v in zip(pv.q, pv.qd)]) - d(J[i], _t)
        if K != 0:
            f_terms[i].append(X * K)
        if J[i] != 0:
            f_terms[i].append(-J[i] * R)
            for j in range(i, n):
                if J[j] != 0:
                    m_terms[i][j].append(J[i] * J[j])


def square_mass_forcing(groups, pv):
    """Mass matrix and forcing contributions of ``sum_c c * sum_X X**2``."""
    n = len(pv.q)
    M, f = sm.zeros(n, n), sm.zeros(n, 1)
    for c, xs in groups.items():
        m_terms = [[[] for _ in range(n)] for _ in range(n)]
        f_terms = [[] for _ in range(n)]
        for X in xs:
            _term_contributions(X, pv, m_terms, f_terms)
        for i in range(n):
            f[i] += 2 * c * sm.Add(*f_terms[i])
            for j in range(i, n):
                if m_terms[i][j]:
                    M[i, j] += 2 * c * sm.Add(*m_terms[i][j])
                    if j != i:
                        M[j, i] = M[i, j]
    return M, f
