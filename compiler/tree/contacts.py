"""Ground contacts (and other velocity-dependent loads) lowered into the recursion.

One job: each :class:`~eomc.compiler.contact.tree.ContactLoad` of a Tree becomes, with the
recursion's Recorder, its point's world position and velocity (the body placed along the
tree by :class:`.placement.Placement`, the point's velocity from the body's spatial
velocity), the contact law's force (:func:`eomc.compiler.contact.law.ground_forces`), and
that force and its moment added to the body's external load.  What a contact *is* (the
user's spec, its parameters, outputs and events) is :mod:`eomc.compiler.contact.tree`'s;
this module is the recursion's side of it (called by :mod:`.lower`).
"""
import sympy as sm

from ..contact.law import ground_forces, ground_jacobians
from ..contact.tree import ContactLoad, ContactValue, contact_outputs
from .placement import Placement
from .spatial import cross

__all__ = ["lower_contacts"]


def world_placement(bodies, rec):
    """The recursion's bodies (LoweredBody: E, r already named) placed in the world, their
    rotations named column by column (the order this lowering has always emitted)."""
    return Placement([b.parent for b in bodies], lambda i: bodies[i].E, lambda i: bodies[i].r, rec.let,
                     by_columns=True)


def lower_contacts(tree, bodies, rec, v, rename, implicit=None):
    """Add every ContactLoad's force to its body's ``fext`` (LoweredBody, body components
    about the origin); return {ContactValue placeholder: temporary}.

    ``v``: the bodies' spatial velocities [ω; v_origin] (body components, the recursion's);
    ``rename(expr, what)``: mechanics symbols -> slot symbols (parameters).  Other loads
    with a ``lower(bodies, rec, v, rename, placement)`` method (MJCF fluid forces:
    eomc.compiler.mjcf.fluid) are lowered here too, with the same placement.
    ``implicit``: a dict to fill for the fixed-step integrator's NAME_implicit (None: not
    built, no temporaries added), holding "step" (the C-printable unit step function); filled
    with "poses" (the placement) and "contacts", per contact (depth, contact point, its
    velocity, K, C of :func:`eomc.compiler.contact.law.ground_jacobians`), world."""
    contacts = contact_outputs(tree)
    others = [ld for ld in tree.loads if not isinstance(ld, ContactLoad) and hasattr(ld, "lower")]
    if not contacts and not others:
        return {}
    poses = world_placement(bodies, rec)
    if implicit is not None:
        implicit["poses"], implicit["contacts"] = poses, []
    for load in others:
        load.lower(bodies, rec, v, rename, poses)
    values = {}
    for index, load in enumerate(contacts):
        i = load.body
        what = f"contact {load.name} on body {tree.bodies[i].name}"
        off = [rename(x, what) for x in load.offset]
        params = {k: rename(s, what) for k, s in load.params.items()}
        poses.rotation(i)
        o = poses.origin(i)
        if load.shape is not None:      # an ellipsoid: its support point c - A n / sqrt(n A n)
            n_b = poses.to_body(i, load.normal)
            An = [sum((a * x for a, x in zip(row, n_b)), sm.S.Zero) for row in load.shape]
            s = rec.let(sm.sqrt(sum((x * y for x, y in zip(n_b, An)), sm.S.Zero)))
            off = [rec.let(off[k] - An[k] / s) for k in range(3)]
        w_b, v_b = v[i][:3], v[i][3:]
        vp_b = [v_b[k] + c for k, c in enumerate(cross(w_b, off))]
        centre = [rec.let(o[k] + x) for k, x in enumerate(poses.to_world(i, off))]
        velocity = rec.vec(poses.to_world(i, vp_b))
        omega = rec.vec(poses.to_world(i, w_b))
        forces = ground_forces(centre, velocity, omega, params, load.normal, rename(load.height, what),
                               let=rec.let)
        f_b = rec.vec(poses.to_body(i, forces.force))
        arm_b = poses.to_body(i, forces.point_offset)
        lever = [off[k] + arm_b[k] for k in range(3)]
        n_b = cross(lever, f_b)
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [old[k] + x for k, x in enumerate(n_b + f_b)]
        if implicit is not None:
            arm_w = forces.point_offset
            point = [rec.let(centre[k] + arm_w[k]) for k in range(3)]
            K, C = ground_jacobians(forces, implicit["step"], rec.let)
            implicit["contacts"].append({"depth": forces.depth, "point": point,
                                         "velocity": list(forces.parts["slip"]), "K": K, "C": C})
        quantities = [forces.normal, *forces.friction, forces.depth]     # OUTPUT_KINDS' order
        for kind, value in enumerate(quantities):
            values[ContactValue(index, kind)] = value
    return values
