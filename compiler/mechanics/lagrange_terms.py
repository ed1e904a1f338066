"""Lagrange's equations, term by term: the fast core of :class:`LagrangesMethod`.

Why this module exists: SymPy's LagrangesMethod differentiates the Jacobian
``dL/dq'`` with respect to time through SymPy's function machinery and then
takes a Jacobian with respect to ``q''``.  Both steps are slow and build
large expressions.  Here

* ``q, q', q''`` and ``t`` are independent leaves of a memoized
  differentiator (:mod:`.fastdiff`), so no derivative goes through time;
* kinetic-energy squares ``c X**2`` are done in closed form
  (:mod:`.lagrange_squares`); the rest of L gives the mass matrix as the
  Hessian ``d2L/dq'2`` (symmetric: only the upper triangle is differentiated)
  and the forcing as ``dL/dq - (d2L/dq' dq) q' - d2L/dq' dt``, the time
  derivative of the momenta written out by the chain rule;
* ``Q`` are the generalized forces of the force list (partial velocities).

No ``simplify``/``expand`` is called anywhere.  Explicit time dependence
(``t`` itself or specified dynamic symbols such as an input ``F(t)``) is
kept: ``d/dt`` sees only it, e.g. giving ``F'(t)``.
"""
import sympy as sm
from sympy.physics.vector import ReferenceFrame, Point, Vector, dynamicsymbols

from eomc.runtime.errors import ModelError

from .fastdiff import Differentiator
from .lagrange_squares import split_squares, square_mass_forcing

__all__ = ["PlainVariables", "lagrange_mass_forcing", "constraint_terms",
           "generalized_forces", "total_time_derivative", "check_loads"]

_t = dynamicsymbols._t


class PlainVariables:
    """The coordinates q(t), their derivatives q', q'' and a differentiator for them.

    Derivatives are taken directly on the expressions in q(t), q'(t): the
    :class:`Differentiator` treats q, q', q'' and t as independent leaves.
    Node types it does not know are differentiated after swapping q, q', q''
    for plain ``Dummy`` symbols (so ``d/dt`` sees only explicit time).
    """

    def __init__(self, q):
        self.q = list(q)
        self.qd = [qi.diff(_t) for qi in self.q]
        self.qdd = [qi.diff(_t) for qi in self.qd]
        n = len(self.q)
        x = [sm.Dummy(f"x{i}") for i in range(n)]
        v = [sm.Dummy(f"v{i}") for i in range(n)]
        a = [sm.Dummy(f"a{i}") for i in range(n)]
        # xreplace works top-down, so q'(t) is matched before the q(t) inside it.
        self.to_plain = dict(zip(self.qdd, a))
        self.to_plain.update(zip(self.qd, v))
        self.to_plain.update(zip(self.q, x))
        self.to_dynamic = {s: d for d, s in self.to_plain.items()}
        self.differentiator = Differentiator(self.q + self.qd + self.qdd + [_t],
                                             fallback=self._fallback)

    def _fallback(self, node, var):
        plain_var = self.to_plain.get(var, var)
        return node.xreplace(self.to_plain).diff(plain_var).xreplace(self.to_dynamic)

    def plain(self, expr):
        """``expr`` with q, q', q'' replaced by plain symbols."""
        return sm.sympify(expr).xreplace(self.to_plain)


def total_time_derivative(expr, pv, with_acceleration=True):
    """Return (dexpr/dq', rest) with d/dt expr = (dexpr/dq')·q'' + rest.

    ``rest = sum_j dexpr/dq_j q'_j + dexpr/dt`` (explicit time dependence).
    """
    d = pv.differentiator.diff
    coeffs = [d(expr, vj) for vj in pv.qd] if with_acceleration else None
    rest = sm.Add(*[d(expr, xj) * vj for xj, vj in zip(pv.q, pv.qd)])
    rest += d(expr, _t)
    return coeffs, rest


def lagrange_mass_forcing(L, pv):
    """Mass matrix ``m_d`` and forcing ``f_d`` (without loads) of ``L(q, q', t)``.

    Lagrange's equations read ``m_d q'' = f_d + Q`` with
    ``m_d = d2L/dq'2`` and ``f_d = dL/dq - (d2L/dq' dq) q' - d2L/dq' dt``.
    Terms ``c X**2`` are done in closed form (:mod:`.lagrange_squares`).
    """
    groups, L = split_squares(L, pv)
    M_sq, f_sq = square_mass_forcing(groups, pv)
    M, f = _hessian_mass_forcing(L, pv)
    return M + M_sq, f + f_sq


def _hessian_mass_forcing(L, pv):
    """The general path: differentiate L itself."""
    n = len(pv.q)
    d = pv.differentiator.diff
    momenta = [d(L, vi) for vi in pv.qd]
    M = sm.zeros(n, n)
    f = sm.zeros(n, 1)
    for i, p in enumerate(momenta):
        for j in range(i, n):
            M[i, j] = d(p, pv.qd[j])
            if j != i:
                M[j, i] = M[i, j]
        _, rest = total_time_derivative(p, pv, with_acceleration=False)
        f[i] = d(L, pv.q[i]) - rest
    return M, f


def constraint_terms(coneqs, pv):
    """For velocity-level constraints ``c(q, q', t) = 0``: (C, f_cd).

    ``C = dc/dq'``; the time-differentiated constraints are
    ``m_cd q'' = f_cd`` with ``m_cd = C`` and ``f_cd = -(dc/dq q' + dc/dt)``.
    """
    m, n = len(coneqs), len(pv.q)
    C = sm.zeros(m, n)
    f_cd = sm.zeros(m, 1)
    for k, c in enumerate(coneqs):
        coeffs, rest = total_time_derivative(c, pv)
        for j in range(n):
            C[k, j] = coeffs[j]
        f_cd[k] = -rest
    return C, f_cd


def check_loads(forcelist):
    """Validate every force-list item's shape up front (ModelError naming the item)."""
    for index, item in enumerate(forcelist):
        _load_pair(item, index)


def _load_pair(item, index):
    """(location, vector) of one force-list item, or a ModelError naming it."""
    try:
        location, vector = item
    except (TypeError, ValueError):
        raise ModelError(
            f"forcelist item {index} ({item!r}) is not a (Point, Vector) or "
            "(ReferenceFrame, Vector) pair") from None
    if not isinstance(location, (Point, ReferenceFrame)):
        raise ModelError(
            f"forcelist item {index}: the load's location {location!r} is neither "
            "a Point (force) nor a ReferenceFrame (torque)")
    if vector == 0:
        vector = Vector(0)
    if not isinstance(vector, Vector):
        raise ModelError(
            f"forcelist item {index}: the load on {location} is {vector!r}, "
            "which is not a sympy.physics.vector Vector")
    return location, vector


def _velocity(location, frame, index):
    """Velocity of a point, or angular velocity of a frame, in ``frame``."""
    try:
        if isinstance(location, Point):
            return location.vel(frame)
        return location.ang_vel_in(frame)
    except ValueError as exc:
        kind = "point" if isinstance(location, Point) else "frame"
        raise ModelError(
            f"forcelist item {index}: the velocity of {kind} {location} in frame "
            f"{frame} is undefined ({exc})") from None


def generalized_forces(forcelist, frame, pv):
    """Generalized forces ``Q_i = sum (d vel / d q'_i) . F`` of a force list."""
    n = len(pv.q)
    Q = [sm.S.Zero] * n
    qd_set = set(pv.qd)
    for index, item in enumerate(forcelist):
        location, vector = _load_pair(item, index)
        if vector == Vector(0):
            continue
        vel = _velocity(location, frame, index)
        for comp, comp_frame in vel.args:
            if comp_frame != frame and qd_set & comp_frame.dcm(frame).atoms(sm.Derivative):
                # orientation depends on q': differentiate in the inertial frame
                part = Vector([(comp, comp_frame)]).express(frame)
                comp, comp_frame = part.args[0] if part.args else (sm.zeros(3, 1), frame)
            d = pv.differentiator.diff
            for i, vi in enumerate(pv.qd):
                partial = comp.applyfunc(lambda e: d(e, vi))
                if partial.is_zero_matrix:
                    continue
                Q[i] += Vector([(partial, comp_frame)]).dot(vector)
    return sm.Matrix(Q)
