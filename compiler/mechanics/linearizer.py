"""eomc's linearizer: SymPy 1.14's ``Linearizer.linearize`` results, computed fast.

Same inputs (the general form f_0 ... f_4, f_c, f_v, f_a of Peterson, Gede
and Hubbard, "Symbolic linearization of equations of motion of constrained
multibody systems", 2015) and the same outputs as
``sympy.physics.mechanics.Linearizer.linearize``: ``(M, A, B)`` of
``M [q', u'] = A [q_ind, u_ind] + B r``, or with ``A_and_B=True`` the explicit
``(A, B)``.  Three things make it fast where SymPy's spends minutes (the
Whipple bicycle: ~95% of SymPy's time is ``Matrix.jacobian`` on Fr*, the rest
``msubs`` of the operating point into products of those Jacobians):

* Jacobians are taken on plain symbols (every ``q(t)``, ``u(t)``, ``q'``,
  ``u'``, input and multiplier replaced by a Dummy) with the memoizing
  differentiators of :mod:`.fastdiff`, so shared subtrees are differentiated once;
* with an operating point, :class:`~.fastdiff.PointDifferentiator` returns the
  Jacobians' values there directly (chain rule on the sub-expressions' values),
  before any product or solve -- equal to SymPy's substitute-at-the-end, since
  substitution commutes with differentiation-then-evaluation, sums, products
  and the solves -- so no large derivative is ever built;
* ``A_and_B=True`` solves ``M x = A`` by blocks: M is block lower triangular
  (the kinematic rows ``M_qq`` touch only q'), so the user's ``linear_solver``
  sees ``M_qq`` and the speed block separately instead of the whole matrix.

The results equal SymPy's (the tests check them numerically, and SymPy's own
test suite runs against them); the printed form may differ.
"""
from collections.abc import Iterable

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics.functions import _parse_linear_solver
from sympy.physics.mechanics.linearize import permutation_matrix
from sympy.physics.vector import dynamicsymbols

from .fastdiff import Differentiator, PointDifferentiator

__all__ = ["FastLinearizer", "dag_subs", "dynamic_atoms"]

_t = dynamicsymbols._t


def _mat(x):
    return sm.Matrix(x) if x is not None and len(x) else sm.Matrix()


def _op_dict(op_point):
    if isinstance(op_point, dict):
        return dict(op_point)
    if isinstance(op_point, Iterable):
        out = {}
        for op in op_point:
            out.update(op)
        return out
    return {}


def dag_subs(matrix, mapping):
    """``msubs(matrix, mapping)`` -- derivatives are leaves -- visiting each shared
    sub-expression once.

    Why: the equations of a large system are DAGs with heavily shared
    subtrees; ``msubs``/``xreplace`` walk them as trees (the bicycle's Fr*:
    ~700,000 node visits for a few thousand distinct nodes).
    """
    memo = {}

    def sub(e):
        got = memo.get(e)
        if got is None:
            if e in mapping:
                got = mapping[e]
            elif not e.args or e.is_Derivative:
                got = e
            else:
                args = [sub(a) for a in e.args]
                got = e if all(a is b for a, b in zip(args, e.args)) else e.func(*args)
            memo[e] = got
        return got
    return sm.Matrix(matrix.rows, matrix.cols, [sub(e) for e in matrix])


def dynamic_atoms(matrices):
    """Every ``f(t)`` and ``Derivative`` in the matrices (``find_dynamicsymbols``'s set),
    each shared sub-expression visited once."""
    seen, found = set(), set()
    stack = [e for m in matrices for e in m]
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        if e.is_Derivative or (isinstance(e, AppliedUndef) and _t in e.args):
            found.add(e)
        stack.extend(e.args)   # inside a Derivative too, as Basic.atoms does
    return found


class FastLinearizer:
    """Drop-in for SymPy's ``Linearizer`` (same constructor, attributes and ``linearize``)."""

    def __init__(self, f_0, f_1, f_2, f_3, f_4, f_c, f_v, f_a, q, u, q_i=None, q_d=None,
                 u_i=None, u_d=None, r=None, lams=None, linear_solver='LU'):
        self.linear_solver = _parse_linear_solver(linear_solver)
        self.f_0, self.f_1, self.f_2, self.f_3, self.f_4 = map(sm.Matrix, (f_0, f_1, f_2, f_3, f_4))
        self.f_c, self.f_v, self.f_a = map(sm.Matrix, (f_c, f_v, f_a))
        self.q, self.u = sm.Matrix(q), sm.Matrix(u)
        self.q_i, self.q_d, self.u_i, self.u_d = map(_mat, (q_i, q_d, u_i, u_d))
        self.r, self.lams = _mat(r), _mat(lams)
        self._qd = self.q.diff(_t)
        self._ud = self.u.diff(_t)
        dup = set(self._qd) & set(self.u)
        self._qd_dup = [x if x not in dup else sm.Dummy() for x in self._qd]
        self._dims = (len(self.f_c), len(self.f_v), len(self.q), len(self.u), len(self.r),
                      len(self.lams))
        self.perm_mat = self._permutation_matrix()
        self._plain = None

    # -- set-up ------------------------------------------------------------------
    def _permutation_matrix(self):
        l, m, n, o, s, k = self._dims
        Pqi = Pui = None
        if n:
            Pq = permutation_matrix(self.q, sm.Matrix([self.q_i, self.q_d]))
            Pqi = Pq[:, :n - l]
        if o:
            Pu = permutation_matrix(self.u, sm.Matrix([self.u_i, self.u_d]))
            Pui = Pu[:, :o - m]
        self._Pq_d = Pq[:, n - l:] if n else sm.Matrix()
        self._Pq_i = Pqi if n else sm.Matrix()
        self._Pu_d = Pu[:, o - m:] if o else sm.Matrix()
        self._Pu_i = Pui if o else sm.Matrix()
        col1 = sm.Matrix([Pqi if n else sm.zeros(0, n - l), sm.zeros(o + k, n - l)])
        col2 = sm.Matrix([sm.zeros(n, o - m), Pui if o else sm.zeros(0, o - m), sm.zeros(k, o - m)])
        if col1 and col2:
            return col1.row_join(col2)
        return col1 if col1 else col2

    def _to_plain(self):
        """Dummies for every dynamic symbol and derivative in the equations (once)."""
        if self._plain is not None:
            return self._plain
        mats = [self.f_0, self.f_1, self.f_2, self.f_3, self.f_4, self.f_c, self.f_v, self.f_a]
        atoms = dynamic_atoms(mats)
        atoms |= set(self.q) | set(self.u) | set(self._qd) | set(self._ud) | set(self.r)
        atoms |= set(self.lams)
        fwd = {a: sm.Dummy(str(a).replace("(t)", "")) for a in atoms
               if isinstance(a, sm.Derivative) or (isinstance(a, AppliedUndef) and _t in a.args)}
        back = {v: k for k, v in fwd.items()}
        plain = {name: dag_subs(mat, fwd) for name, mat in zip("f0 f1 f2 f3 f4 fc fv fa".split(), mats)}
        self._plain = (fwd, back, plain)
        return self._plain

    # -- pieces ---------------------------------------------------------------------
    def _jac(self, name, variables, D, sign=1):
        """Jacobian of the plain matrix ``name`` (a sum "f2+f3" allowed) at D's point."""
        fwd, back, plain = self._to_plain()
        rows = [plain[n] for n in name.split("+")]
        nrow = rows[0].rows
        cols = [fwd.get(v) for v in variables]
        out = sm.zeros(nrow, len(cols))
        for i in range(nrow):
            for j, x in enumerate(cols):
                if x is None:
                    continue
                d = sm.Add(*[D.diff(R[i], x) for R in rows])
                if d != 0:
                    out[i, j] = sign * d
        return out

    def _solve(self, A, b):
        return self.linear_solver(A, b)

    def _constraint_maps(self, D):
        """C_0, C_1, C_2 of the paper, at the operating point."""
        l, m, n, o, s, k = self._dims
        if l:
            fcq = self._jac("fc", self.q, D)
            C_0 = (sm.eye(n) - self._Pq_d * self._solve(fcq * self._Pq_d, fcq)) * self._Pq_i
        else:
            C_0 = sm.eye(n)
        if m:
            fvu = self._jac("fv", self.u, D)
            temp = fvu * self._Pu_d
            C_1 = -self._Pu_d * self._solve(temp, self._jac("fv", self.q, D)) if n else sm.zeros(o, n)
            C_2 = (sm.eye(o) - self._Pu_d * self._solve(temp, fvu)) * self._Pu_i
        else:
            C_1, C_2 = sm.zeros(o, n), sm.eye(o)
        return C_0, C_1, C_2

    # -- the result -------------------------------------------------------------------
    def linearize(self, op_point=None, A_and_B=False, simplify=False):
        """As ``sympy.physics.mechanics.Linearizer.linearize`` (SymPy 1.14)."""
        fwd, back, plain = self._to_plain()
        op = {}
        for key, val in _op_dict(op_point).items():
            key = sm.sympify(key)
            op[fwd.get(key, key)] = sm.sympify(val).xreplace(fwd)
        l, m, n, o, s, k = self._dims
        D = PointDifferentiator(back, op) if op else Differentiator(back)
        dyn = lambda M: M.xreplace(back)  # noqa: E731
        # the block rows of M and A: kinematics (n), constraints (m), dynamics (o - m + k)
        nd = o - m + k
        M_qq = self._jac("f0", self._qd, D)
        M_uqc = self._jac("fa", self._qd_dup, D) if n and m else sm.zeros(m, n)
        M_uqd = self._jac("f3", self._qd_dup, D) if n and nd else sm.zeros(nd, n)
        M_uuc = self._jac("fa", self._ud, D) if o and m else sm.zeros(m, o)
        M_uud = self._jac("f2", self._ud, D) if o and nd else sm.zeros(nd, o)
        M_uld = self._jac("f4", self.lams, D) if k and nd else sm.zeros(nd, k)
        A_qq = self._jac("f0+f1", self.q, D, -1)
        A_uqc = self._jac("fa", self.q, D, -1) if n and m else sm.zeros(m, n)
        A_uqd = self._jac("f2+f3+f4", self.q, D, -1) if n and nd else sm.zeros(nd, n)
        A_qu = self._jac("f1", self.u, D, -1) if o and n else sm.zeros(n, o)
        A_uuc = self._jac("fa", self.u, D, -1) if o and m else sm.zeros(m, o)
        A_uud = self._jac("f2+f3", self.u, D, -1) if o and nd else sm.zeros(nd, o)
        B_u = self._jac("f3", self.r, D, -1) if s and nd else None
        C_0, C_1, C_2 = self._constraint_maps(D)

        R = n + m + nd
        M = sm.Matrix.hstack(sm.Matrix.vstack(M_qq, M_uqc, M_uqd) if n else sm.zeros(R, 0),
                             sm.Matrix.vstack(sm.zeros(n, o), M_uuc, M_uud) if o else sm.zeros(R, 0),
                             sm.Matrix.vstack(sm.zeros(n + m, k), M_uld) if k else sm.zeros(R, 0))
        col1 = sm.Matrix.vstack((A_qq + A_qu * C_1) * C_0, (A_uqc + A_uuc * C_1) * C_0,
                                (A_uqd + A_uud * C_1) * C_0) if n else sm.zeros(R, 0)
        col2 = sm.Matrix.vstack(A_qu * C_2, A_uuc * C_2, A_uud * C_2) if o else sm.zeros(R, 0)
        Amat = col1.row_join(col2)
        Bmat = sm.zeros(n + m, s).col_join(B_u) if B_u is not None else sm.Matrix()
        if A_and_B:
            A_cont = self.perm_mat.T * self._block_solve(M, Amat, n)
            B_cont = self.perm_mat.T * self._block_solve(M, Bmat, n) if Bmat else Bmat
            A_cont, B_cont = dyn(A_cont), dyn(B_cont)
            if simplify:
                A_cont.simplify()
                B_cont.simplify()
            return A_cont, B_cont
        M, Amat, Bmat = dyn(M), dyn(Amat), dyn(Bmat)
        if simplify:
            M.simplify()
            Amat.simplify()
            Bmat.simplify()
        return M, Amat, Bmat

    def _block_solve(self, M, b, n):
        """M x = b for block lower-triangular M = [[M_qq, 0], [M_rq, M_rr]] (n kinematic rows)."""
        if n == 0 or n == M.rows or any(e != 0 for e in M[:n, n:]):
            return self._solve(M, b)
        x_q = self._solve(M[:n, :n], b[:n, :])
        rest = b[n:, :] - M[n:, :n] * x_q
        x_r = self._solve(M[n:, n:], rest)
        return x_q.col_join(x_r)
