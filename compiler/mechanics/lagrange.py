"""eomc's LagrangesMethod: Lagrange's equations of the second kind, formed fast.

Same API as ``sympy.physics.mechanics.LagrangesMethod`` (SymPy 1.14) plus the
seed document's ``coneqs`` keyword and :meth:`LagrangesMethod.formed`.  The
derivation itself lives in :mod:`.lagrange_terms` (Hessians on plain symbols);
this module holds the user-facing object, its matrices and linearization.
"""
import sympy as sm
from sympy.utilities.iterables import iterable
from sympy.core.sorting import default_sort_key
from sympy.physics.vector import ReferenceFrame, dynamicsymbols
from sympy.physics.mechanics import Linearizer, find_dynamicsymbols, msubs

from eomc.runtime.errors import ModelError

from .lagrange_formed import formed_from_lagrange
from .linearizer import FastLinearizer
from .lagrange_terms import (PlainVariables, check_loads, constraint_terms,
                             generalized_forces, lagrange_mass_forcing)

__all__ = ["LagrangesMethod"]

_t = dynamicsymbols._t


def _as_matrix(eqs, what):
    """Column matrix of a list of constraint expressions (None -> empty)."""
    if eqs is None:
        return sm.Matrix()
    if isinstance(eqs, sm.MatrixBase):
        return sm.Matrix(list(eqs))
    try:
        items = [sm.sympify(e) for e in eqs]
    except (TypeError, sm.SympifyError):
        raise ModelError(f"{what} must be a list of expressions equal to zero") from None
    for e in items:
        if not isinstance(e, sm.Expr):
            raise ModelError(f"{what}: {e!r} is not a scalar expression")
    return sm.Matrix(items) if items else sm.Matrix()


def _validate_lagrangian(L):
    if isinstance(L, sm.MatrixBase) and L.shape == (1, 1):
        L = L[0]
    try:
        L = sm.sympify(L, strict=True)
    except (sm.SympifyError, TypeError):
        raise ModelError(
            f"the Lagrangian must be a scalar SymPy expression, got {type(L).__name__}: "
            f"{L!r}") from None
    if not isinstance(L, sm.Expr):
        raise ModelError(
            f"the Lagrangian must be a scalar SymPy expression, got {type(L).__name__}")
    return L


def _validate_coordinates(qs):
    if not iterable(qs) or isinstance(qs, str):
        raise ModelError("the generalized coordinates must be given as a list")
    qs = list(qs)
    seen = set()
    for q in qs:
        if not (isinstance(q, sm.core.function.AppliedUndef) and q.args == (_t,)):
            raise ModelError(
                f"generalized coordinate {q} is not a function of time; create it "
                "with dynamicsymbols()")
        if q in seen:
            raise ModelError(f"generalized coordinate {q} is given twice")
        seen.add(q)
    return qs


class LagrangesMethod:
    """Lagrange's equations of the second kind, with multipliers for constraints.

    ``LagrangesMethod(Lagrangian, qs, forcelist=None, bodies=None, frame=None,
    hol_coneqs=None, nonhol_coneqs=None, coneqs=None)``

    * ``hol_coneqs``: position-level constraints ``f_h(q, t) = 0``; they are
      differentiated with respect to time internally.
    * ``nonhol_coneqs``: velocity-level constraints ``c(q, q', t) = 0``.
    * ``coneqs`` (the seed document's name): velocity-level constraints, for
      example already-differentiated holonomic ones; treated like
      ``nonhol_coneqs``.
    * ``forcelist`` of ``(Point, Vector)`` / ``(ReferenceFrame, Vector)`` pairs
      (or ``Force``/``Torque``) needs the inertial ``frame``.

    The velocity-level constraints, in the order ``[d/dt hol_coneqs;
    nonhol_coneqs; coneqs]``, are ``c = C(q, t) q' + ... = 0``; there is one
    multiplier ``lam1, lam2, ...`` (dynamic symbols) per row.

    **Sign convention (identical to SymPy 1.14).**  ``lam_coeffs = -C`` and

    * ``eom = d/dt dL/dq' - dL/dq - Q + C^T lam`` (so the seed prints
      ``lam1 + 2*q1''``), while
    * ``mass_matrix = [m_d, lam_coeffs^T] = [m_d, -C^T]`` and ``forcing = f_d``
      with ``m_d q'' - f_d = d/dt dL/dq' - dL/dq - Q``.

    Hence the multipliers ``mu`` solved from ``mass_matrix_full x =
    forcing_full`` (by :meth:`rhs` and by the compiled model, which uses
    :meth:`formed`) are the *negatives* of the ``lam`` in ``eom``: with
    ``x = [q'; q''; mu]``, ``m_d q'' = f_d + C^T mu``, i.e. ``C^T mu`` is the
    generalized constraint force.  :meth:`solve_multipliers` returns the
    ``lam`` of ``eom`` (``= -mu``), as SymPy does.

    The speeds ``u`` are the coordinates' derivatives ``q'(t)``.
    """

    def __init__(self, Lagrangian, qs, forcelist=None, bodies=None, frame=None,
                 hol_coneqs=None, nonhol_coneqs=None, coneqs=None):
        self._L = sm.Matrix([_validate_lagrangian(Lagrangian)])
        self._q = sm.Matrix(_validate_coordinates(qs))
        self._qdots = self._q.diff(_t)
        self._qdoubledots = self._qdots.diff(_t)
        if forcelist is not None and not iterable(forcelist):
            raise ModelError("forcelist must be a list of (Point or ReferenceFrame, Vector) pairs")
        self._forcelist = list(forcelist) if forcelist else []
        check_loads(self._forcelist)
        if frame is not None and not isinstance(frame, ReferenceFrame):
            raise ModelError(f"frame must be a ReferenceFrame, got {frame!r}")
        if self._forcelist and frame is None:
            raise ModelError("a forcelist needs the inertial frame: pass frame=<ReferenceFrame>")
        self.inertial = frame
        self._bodies = bodies
        self._hol_coneqs = _as_matrix(hol_coneqs, "hol_coneqs")
        for h in self._hol_coneqs:
            self._check_order(h, f"the holonomic constraint {h} = 0 (hol_coneqs)", 0)
        self._nonhol_coneqs = _as_matrix(nonhol_coneqs, "nonhol_coneqs")
        self._seed_coneqs = _as_matrix(coneqs, "coneqs")
        rows = list(self._hol_coneqs.diff(_t)) + list(self._nonhol_coneqs) + list(self._seed_coneqs)
        self.coneqs = sm.Matrix(rows) if rows else sm.Matrix()
        self.eom = None
        self.lam_vec = sm.Matrix()
        self.lam_coeffs = sm.Matrix()
        self._m_d = self._f_d = self._m_cd = self._f_cd = sm.Matrix()

    # -- forming -----------------------------------------------------------
    def form_lagranges_equations(self):
        """Form and return ``eom`` (one row per coordinate, equal to zero)."""
        pv = PlainVariables(self._q)
        L = self._L[0]
        self._check_order(L, "the Lagrangian", 1)
        m_d, f_d = lagrange_mass_forcing(L, pv)
        if self._forcelist:
            f_d += generalized_forces(self._forcelist, self.inertial, pv)
        n = len(self._q)
        if self.coneqs:
            cons = list(self.coneqs)
            for c in cons:
                self._check_order(c, f"the constraint {c} = 0", 1)
            C, f_cd = constraint_terms(cons, pv)
            self.lam_vec = sm.Matrix(dynamicsymbols(f"lam1:{len(cons) + 1}"))
            self.lam_coeffs = -C
            self._m_cd = C
            self._f_cd = f_cd
        self._m_d = m_d
        self._f_d = f_d
        qdd = self._qdoubledots
        eom = sm.Matrix([sm.Add(*[self._m_d[i, j] * qdd[j] for j in range(n)]) - self._f_d[i]
                         for i in range(n)])
        if self.coneqs:
            eom -= self.lam_coeffs.T * self.lam_vec
        self.eom = eom
        return self.eom

    def _check_order(self, expr, what, order):
        """Refuse derivatives of the coordinates above ``order`` in ``expr``."""
        qs = set(self._q)
        for s in find_dynamicsymbols(expr):
            if isinstance(s, sm.Derivative) and s.expr in qs and s.derivative_count > order:
                raise ModelError(f"{what} contains {s}, a derivative of a coordinate of "
                                 f"order {s.derivative_count} (at most {order} allowed)")

    def _form_eoms(self):
        return self.form_lagranges_equations()

    def _need_eom(self):
        if self.eom is None:
            raise ModelError("Need to compute the equations of motion first: call "
                             "form_lagranges_equations()")

    # -- matrices ----------------------------------------------------------
    @property
    def mass_matrix(self):
        """``[m_d, lam_coeffs^T]``: n x (n + m) (just ``m_d`` without constraints)."""
        self._need_eom()
        if self.coneqs:
            return self._m_d.row_join(self.lam_coeffs.T)
        return self._m_d

    @property
    def mass_matrix_full(self):
        """Square (2n + m) matrix of ``[q'; q''; lam]``: kinematics, dynamics, constraints."""
        self._need_eom()
        n, m = len(self._q), len(self.coneqs)
        row1 = sm.eye(n).row_join(sm.zeros(n, n + m))
        row2 = sm.zeros(n, n).row_join(self.mass_matrix)
        if self.coneqs:
            row3 = sm.zeros(m, n).row_join(self._m_cd).row_join(sm.zeros(m, m))
            return row1.col_join(row2).col_join(row3)
        return row1.col_join(row2)

    @property
    def forcing(self):
        self._need_eom()
        return self._f_d

    @property
    def forcing_full(self):
        self._need_eom()
        if self.coneqs:
            return self._qdots.col_join(self._f_d).col_join(self._f_cd)
        return self._qdots.col_join(self._f_d)

    @property
    def q(self):
        return self._q

    @property
    def u(self):
        return self._qdots

    @property
    def bodies(self):
        return self._bodies

    @property
    def forcelist(self):
        return self._forcelist

    @property
    def loads(self):
        return self._forcelist

    def rhs(self, inv_method=None, **kwargs):
        """``mass_matrix_full^-1 forcing_full`` (symbolic; LU unless ``inv_method``)."""
        if inv_method is None:
            self._rhs = self.mass_matrix_full.LUsolve(self.forcing_full)
        else:
            self._rhs = (self.mass_matrix_full.inv(inv_method, try_block_diag=True)
                         * self.forcing_full)
        return self._rhs

    # -- linearization and multipliers ------------------------------------
    def to_linearizer(self, q_ind=None, qd_ind=None, q_dep=None, qd_dep=None,
                      linear_solver='LU', _cls=Linearizer):
        """A SymPy :class:`Linearizer` for these equations (SymPy 1.14 semantics).

        (``linearize`` passes eomc's :class:`~.linearizer.FastLinearizer` as ``_cls``.)
        """
        self._need_eom()
        q, u = self._q, self._qdots
        build = lambda x: sm.Matrix(x) if x else sm.Matrix()  # noqa: E731
        q_i, q_d, u_i, u_d = build(q_ind), build(q_dep), build(qd_ind), build(qd_dep)
        f_c, f_v = self._hol_coneqs, self.coneqs
        if len(q_d) != len(f_c) or len(u_d) != len(f_v):
            raise ModelError(f"Must supply {len(f_c)} dependent coordinates, and "
                             f"{len(f_v)} dependent speeds")
        if set(sm.Matrix([q_i, q_d])) != set(q):
            raise ModelError("Must partition q into q_ind and q_dep, with no extra or "
                             "missing symbols.")
        if set(sm.Matrix([u_i, u_d])) != set(u):
            raise ModelError("Must partition qd into qd_ind and qd_dep, with no extra "
                             "or missing symbols.")
        # eom = f_2 + f_3 + f_4: inertia (only q'' terms), the forcing, the multipliers.
        f_2 = self._m_d * self._qdoubledots
        f_3 = -self._f_d
        f_4 = -(self.lam_coeffs.T * self.lam_vec) if self.coneqs else sm.zeros(len(q), 1)
        insyms = set(sm.Matrix([q, u, self._qdoubledots, self.lam_vec]))
        r = sorted(find_dynamicsymbols(f_3, insyms), key=default_sort_key)
        for i in r:
            if i.diff(_t) in r:
                raise ModelError(f"Cannot linearize: both {i} and its derivative "
                                 "appear in the forcing terms")
        return _cls(u, -u, f_2, f_3, f_4, f_c, f_v, f_v.diff(_t), q, u, q_i,
                    q_d, u_i, u_d, r, self.lam_vec, linear_solver=linear_solver)

    def linearize(self, q_ind=None, qd_ind=None, q_dep=None, qd_dep=None,
                  linear_solver='LU', **kwargs):
        """As SymPy 1.14: ``(M, A, B, r)``, or ``(A, B, r)`` with ``A_and_B=True``.

        Without arguments the coordinates and speeds are all independent
        (allowed only without constraints).  ``op_point``, ``A_and_B`` and
        ``simplify`` are passed to :meth:`Linearizer.linearize`.
        """
        if q_ind is None and q_dep is None and not self._hol_coneqs:
            q_ind = list(self._q)
        if qd_ind is None and qd_dep is None and not self.coneqs:
            qd_ind = list(self._qdots)
        linearizer = self.to_linearizer(q_ind, qd_ind, q_dep, qd_dep,
                                        linear_solver=linear_solver, _cls=FastLinearizer)
        result = linearizer.linearize(**kwargs)
        return result + (linearizer.r,)

    def solve_multipliers(self, op_point=None, sol_type='dict'):
        """The ``lam`` of ``eom`` at ``op_point`` (``-mu``; see the class docstring)."""
        self._need_eom()
        k = len(self.lam_vec)
        if k == 0:
            raise ModelError("System has no lagrange multipliers to solve for.")
        if isinstance(op_point, dict):
            op = op_point
        elif op_point is None:
            op = {}
        elif iterable(op_point):
            op = {}
            for d in op_point:
                op.update(d)
        else:
            raise TypeError("op_point must be either a dictionary or an iterable of "
                            "dictionaries.")
        A = self.mass_matrix.col_join(-self.lam_coeffs.row_join(sm.zeros(k, k)))
        b = self._f_d.col_join(self._f_cd)
        sol = msubs(A, op).LUsolve(-msubs(b, op))[-k:]
        if sol_type == 'dict':
            return dict(zip(self.lam_vec, sol))
        if sol_type == 'Matrix':
            return sm.Matrix(sol)
        raise ValueError(f"Unknown sol_type {sol_type}.")

    # -- the compiler's view -------------------------------------------------
    def formed(self):
        """The method-neutral :class:`FormedSystem` (see :mod:`.lagrange_formed`).

        Memoized per formed ``eom`` so a warm ``eomc.compile`` does not walk the
        expressions again.
        """
        self._need_eom()
        cached = getattr(self, "_formed_cache", None)
        if cached is None or cached[0] is not self.eom:
            cached = self._formed_cache = (self.eom, formed_from_lagrange(self))
        return cached[1]
