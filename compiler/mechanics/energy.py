"""Kinetic energy and the Lagrangian, built compactly.

Why: SymPy's ``kinetic_energy`` forms ``v . v`` for a velocity whose terms
live in many frames; the dot product multiplies every pair of frames' DCMs,
so a chain of n links gets O(n^2) terms per body (O(n^3) in all) and
Lagrange's method then differentiates all of them.  Here each velocity is
expressed in one frame first (the inertial frame for translation, the body
frame for rotation) and squared component-wise: O(n) terms per body.  The
value is identical; only the printed form differs.  Same signatures and
errors as ``sympy.physics.mechanics.kinetic_energy`` / ``Lagrangian``.
"""
import sympy as sm
from sympy.physics.mechanics import Particle, RigidBody, potential_energy
from sympy.physics.vector import ReferenceFrame

__all__ = ["kinetic_energy", "Lagrangian"]


def _squared(vector, frame):
    """``vector . vector`` with the vector expressed in ``frame`` first."""
    try:
        comps = vector.to_matrix(frame)
    except ValueError:  # no orientation path to ``frame``: use SymPy's pairing
        return vector.dot(vector)
    return sm.Add(*[c ** 2 for c in comps])


def _body_kinetic_energy(body, frame):
    if isinstance(body, Particle):
        return body.mass * _squared(body.point.vel(frame), frame) / 2
    translational = body.mass * _squared(body.masscenter.vel(frame), frame) / 2
    omega = body.frame.ang_vel_in(frame)
    try:
        w = omega.to_matrix(body.frame)
        inertia = body.central_inertia.to_matrix(body.frame)
    except ValueError:
        return translational + omega.dot(body.central_inertia.dot(omega)) / 2
    rotational = sm.Add(*[w[i] * inertia[i, j] * w[j]
                          for i in range(3) for j in range(3) if inertia[i, j] != 0])
    return translational + rotational / 2


def kinetic_energy(frame, *body):
    """Kinetic energy of particles and rigid bodies in ``frame`` (SymPy's signature)."""
    if not isinstance(frame, ReferenceFrame):
        raise TypeError('Please enter a valid ReferenceFrame')
    ke = sm.S.Zero
    for e in body:
        if isinstance(e, (RigidBody, Particle)):
            ke += _body_kinetic_energy(e, frame)
        else:
            raise TypeError('*body must have only Particle or RigidBody')
    return ke


def Lagrangian(frame, *body):
    """``kinetic_energy(frame, *body) - potential_energy(*body)`` (SymPy's signature)."""
    if not isinstance(frame, ReferenceFrame):
        raise TypeError('Please supply a valid ReferenceFrame')
    for e in body:
        if not isinstance(e, (RigidBody, Particle)):
            raise TypeError('*body must have only Particle or RigidBody')
    return kinetic_energy(frame, *body) - potential_energy(*body)
