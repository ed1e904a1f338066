"""Turn a formed eomc LagrangesMethod into the compiler's :class:`FormedSystem`.

Choices (the compiler only sees the FormedSystem, so they are stated here):

* speeds are the derivative objects ``q_i'(t)`` (``Derivative(q_i(t), t)``),
  the kinematics is the identity ``q' = u``;
* all coordinates and speeds are states; constraints are enforced by the
  multipliers, so ``n_dependent_coordinates = n_dependent_speeds = 0``;
* ``dynamics_matrix = [[m_d, lam_coeffs^T], [m_cd, 0]]`` with unknowns
  ``[q''; mu]`` and ``dynamics_rhs = [f_d; f_cd]`` -- the lower right block of
  ``mass_matrix_full``/``forcing_full``; ``mu = -lam`` of ``eom`` (see
  :class:`LagrangesMethod`);
* ``holonomic_constraints`` are ``hol_coneqs``; ``velocity_constraints`` are
  all velocity-level constraints (differentiated holonomic ones included).
"""
import sympy as sm
from sympy.core.sorting import default_sort_key
from sympy.physics.mechanics import find_dynamicsymbols
from sympy.physics.vector import dynamicsymbols

from .formed import FormedSystem

__all__ = ["formed_from_lagrange", "inputs_and_parameters"]

_t = dynamicsymbols._t


def inputs_and_parameters(exprs, states):
    """Dynamic symbols other than ``states`` and constant symbols, both sorted by name."""
    inputs, params = set(), set()
    for e in exprs:
        inputs |= find_dynamicsymbols(e, exclude=states)
        params |= e.free_symbols
    params.discard(_t)
    inputs = tuple(sorted(inputs, key=default_sort_key))
    params = tuple(sorted(params, key=lambda s: (s.name, default_sort_key(s))))
    return inputs, params


def formed_from_lagrange(lm):
    """The FormedSystem of an eomc LagrangesMethod whose equations are formed."""
    n, m = len(lm.q), len(lm.coneqs)
    qd = lm.u
    A = lm.mass_matrix_full[n:, n:]
    b = lm.forcing_full[n:, :]
    states = set(lm.q) | set(qd) | set(lm._qdoubledots) | set(lm.lam_vec)
    inputs, params = inputs_and_parameters(
        [A, b, lm.coneqs, lm._hol_coneqs], states)
    return FormedSystem(
        method="lagrange",
        coordinates=tuple(lm.q),
        speeds=tuple(qd),
        n_dependent_coordinates=0,
        n_dependent_speeds=0,
        kinematics=sm.Matrix(qd),
        dynamics_matrix=A,
        dynamics_rhs=b,
        multipliers=tuple(lm.lam_vec),
        holonomic_constraints=sm.Matrix(lm._hol_coneqs) if lm._hol_coneqs else sm.zeros(0, 1),
        velocity_constraints=sm.Matrix(lm.coneqs) if m else sm.zeros(0, 1),
        inputs=inputs,
        parameters=params,
    )
