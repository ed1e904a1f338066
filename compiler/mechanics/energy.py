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


def _single_frame(vector):
    """The one frame ``vector`` is written in, or None (zero or several frames)."""
    frames = {f for _, f in vector.args}
    return frames.pop() if len(frames) == 1 else None


def _squared(vector, frame):
    """``vector . vector`` with the vector expressed in ``frame`` first.

    A vector written in one frame only is squared there as it is: no
    direction cosines enter, so the result is as short as SymPy's (l**2*q'**2
    for a pendulum, not l**2*(sin**2 + cos**2)*q'**2).
    """
    frame = _single_frame(vector) or frame
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
    # Square in the frame the inertia is written in (constant there, as the
    # user wrote it), else in omega's one frame, else in the body's own frame.
    dyadic_frames = {f for _, v1, v2 in body.central_inertia.args for v in (v1, v2) for _, f in v.args}
    where = dyadic_frames.pop() if len(dyadic_frames) == 1 else _single_frame(omega)
    if where is None or dyadic_frames - {where}:
        where = body.frame
    try:
        w = omega.to_matrix(where)
        inertia = body.central_inertia.to_matrix(where)
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
