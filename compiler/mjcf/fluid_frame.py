"""The fluid models' frames: a body's velocity in a geom's or its inertia's axes, and back.

One job, shared by the inertia-box model (:mod:`.fluid`) and the ellipsoid model
(:mod:`.fluid_ellipsoid`): both take the body's angular velocity and a point's velocity
minus the wind into a local frame fixed in the body, and add the local load, turned back
into body components, to the body's external load.
"""
import sympy as sm

from ..tree.spatial import cross

__all__ = ["relative_velocity", "add_body_load"]


def relative_velocity(v_i, arm, A, wind, poses, i, rec):
    """(ω, u) in the local frame whose axes are the rows-transposed ``A`` (local -> body rows):
    the body's angular velocity and the velocity of the point ``arm`` from its origin (None:
    the origin) minus the ``wind`` (world), each component named."""
    w_b, v_b = v_i[:3], list(v_i[3:])
    if arm is not None:
        v_b = [v_b[k] + c for k, c in enumerate(cross(w_b, arm))]
    if any(wind):
        R = poses.world_to_body(i)     # world -> body components (eomc.compiler.tree.placement)
        wind_b = [sum((R[r][k] * sm.Float(wind[k], 17) for k in range(3) if wind[k]), sm.S.Zero)
                  for r in range(3)]
        v_b = [v_b[r] - wind_b[r] for r in range(3)]

    def to_local(vec):          # body -> local components: Aᵀ vec
        return [rec.let(sum((A[k][r] * vec[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    return to_local(w_b), to_local(v_b)


def add_body_load(bodies, i, load):
    """Add ``load`` (moment; force: body components, about the origin) to body i's fext."""
    old = bodies[i].fext or [0] * 6
    bodies[i].fext = [old[k] + x for k, x in enumerate(load)]
