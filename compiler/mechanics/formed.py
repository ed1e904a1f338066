"""The method-neutral result of a derivation: what the compiler lowers to C.

Kane's and Lagrange's methods both end in the same shape,

    q' = kinematics(q, u, t)                      (nq rows)
    A(q, t) · [u'; λ] = b(q, u, t)                (nu + nλ rows)

    z' = extra_rhs(t, q, u, z, r)                 (nz rows, optional)

where λ are Lagrange multipliers (empty for Kane's method) and, for Kane's
method with motion constraints, the last rows of A are the differentiated
velocity constraints.  The third block z holds extra first-order states
(a muscle's activation, a motor's current, a controller's integrator): the
state is x = [q; u; z], and z may appear anywhere in the first two lines.  The compiler solves the second line numerically in C
and never sees KanesMethod or LagrangesMethod themselves.
"""
from dataclasses import dataclass

import sympy as sm

__all__ = ["FormedSystem", "StateSizes"]


class StateSizes:
    """nq, nu, nz of a record with ``coordinates``, ``speeds`` and ``extra_states``: the
    formed equations (:class:`FormedSystem`) and the multibody model as read
    (eomc.compiler.multibody.Model) both state x = [q; u; z]."""

    @property
    def nq(self):
        return len(self.coordinates)

    @property
    def nu(self):
        return len(self.speeds)

    @property
    def nz(self):
        return len(self.extra_states)


@dataclass(frozen=True)
class FormedSystem(StateSizes):
    method: str                      # "kane" or "lagrange"
    coordinates: tuple               # q: independent first, then dependent
    speeds: tuple                    # u: independent first, then dependent (Lagrange: the q')
    n_dependent_coordinates: int
    n_dependent_speeds: int
    kinematics: sm.Matrix            # nq x 1, explicit q'
    dynamics_matrix: sm.Matrix       # (nu + nλ) square; unknowns are [u'; λ]
    dynamics_rhs: sm.Matrix          # (nu + nλ) x 1
    multipliers: tuple               # λ symbols (Lagrange), else ()
    holonomic_constraints: sm.Matrix # nh x 1, f_h(q, t) = 0 (may be empty)
    velocity_constraints: sm.Matrix  # nv x 1, in q, u, t, = 0 (may be empty)
    inputs: tuple                    # specified dynamic symbols (neither q, u nor their derivatives)
    parameters: tuple                # constant symbols, sorted by name
    extra_states: tuple = ()         # z: extra first-order states (dynamic symbols), after q and u
    extra_rhs: tuple = ()            # z' = extra_rhs, one expression per extra state
