"""Random branching joint trees for property tests (a hypothesis strategy and a builder).

Body ``i`` hangs from a random earlier body (or the ground) through a PinJoint
about a random integer axis, a PrismaticJoint along one or a SphericalJoint (body-
or space-fixed angles, random order), at random parent and child points; it is a point mass (a massless-inertia RigidBody) or a rigid body
with a full (products included) inertia; its joint may carry a torque or force
input acting between child and parent (a ball joint: a torque about the random
axis).  ``build`` returns an unformed SymPy ``System`` (gravity along -N.z) and its inputs.

``tree(free=True)``: the first body hangs from the ground on a free joint (the
URDF reader's FloatingJoint: 6 speeds, body-frame twist), and every other root
may too; a free body is always rigid (a point mass could not turn).
"""
import sympy as sm
from hypothesis import strategies as st
from sympy.physics import mechanics as sme

from eomc.compiler.urdf.joints import FloatingJoint

_vec = st.tuples(*[st.integers(-1, 1)] * 3)


@st.composite
def tree(draw, max_bodies=4, ball=True, free=False):
    n = draw(st.integers(2 if free else 1, max(max_bodies, 2) if free else max_bodies))
    bodies = []
    for i in range(n):
        # free=True: mostly children of earlier bodies (a floating base with limbs), some roots
        parents = st.sampled_from(list(reversed(range(i))) + [-1]) if free and i else st.integers(-1, i - 1)
        bodies.append({
            "parent": draw(parents),
            "kind": draw(st.sampled_from(["pin", "pin", "slider", "ball"] if ball else ["pin", "slider"])),
            "rotation": draw(st.sampled_from([("BODY", 123), ("SPACE", 123), ("BODY", 313),
                                              ("SPACE", 231)])),
            "axis": draw(_vec.filter(any)),
            "parent_point": draw(_vec),
            "child_point": draw(_vec.filter(any)),
            "rigid": draw(st.booleans()),
            "products": draw(st.booleans()),
            "load": draw(st.booleans()),
        })
        if free and bodies[-1]["parent"] < 0 and (i == 0 or draw(st.booleans())):
            bodies[-1]["kind"] = "free"
    return bodies


def build(spec):
    """(System, inputs) of the tree ``spec`` (joint equations not formed)."""
    n = sum({"ball": 3, "free": 6}.get(b["kind"], 1) for b in spec)
    qs = iter(sme.dynamicsymbols(f"q1:{n + 1}"))
    us = iter(sme.dynamicsymbols(f"u1:{n + 1}"))
    g = sm.Symbol("g")
    ground = sme.RigidBody("ground")
    made, joints, loads, inputs = [], [], [], []
    for i, b in enumerate(spec):
        body = sme.RigidBody(f"body{i}", mass=sm.Symbol(f"m{i}"))
        F = body.frame
        if b["rigid"] or b["kind"] in ("ball", "free"):   # a point mass on a ball joint cannot turn
            ixx, iyy, izz = sm.symbols(f"ixx{i} iyy{i} izz{i}")
            # products small enough that the inertia stays positive definite
            pr = [sm.Symbol(f"i{d}{i}") / 8 if b["products"] else 0 for d in ("xy", "yz", "zx")]
            body.inertia = (sme.inertia(F, 2 + ixx, 2 + iyy, 2 + izz, *pr), body.masscenter)
        else:
            body.inertia = (sme.inertia(F, 0, 0, 0), body.masscenter)
        parent = ground if b["parent"] < 0 else made[b["parent"]]
        P = parent.frame
        axis = sum((c * d for c, d in zip(b["axis"], (P.x, P.y, P.z))), sme.Vector(0))
        ppoint = sum((c * d for c, d in zip(b["parent_point"], (P.x, P.y, P.z))), sme.Vector(0))
        cpoint = sum((c * d for c, d in zip(b["child_point"], (F.x, F.y, F.z))), sme.Vector(0))
        name = f"joint{i}"
        if b["kind"] == "free":
            j = FloatingJoint(name, parent, body, [next(qs) for _ in range(6)],
                              [next(us) for _ in range(6)], parent_point=ppoint, child_point=cpoint)
        elif b["kind"] == "ball":
            j = sme.SphericalJoint(name, parent, body, [next(qs) for _ in range(3)],
                                   [next(us) for _ in range(3)], parent_point=ppoint,
                                   child_point=cpoint, rot_type=b["rotation"][0],
                                   rot_order=b["rotation"][1])
        elif b["kind"] == "pin":
            j = sme.PinJoint(name, parent, body, next(qs), next(us), parent_point=ppoint,
                             child_point=cpoint, joint_axis=axis)
        else:
            j = sme.PrismaticJoint(name, parent, body, next(qs), next(us), parent_point=ppoint,
                                   child_point=cpoint, joint_axis=axis)
        joints.append(j)
        made.append(body)
        if b["load"]:
            T = sme.dynamicsymbols(f"T{i}")
            inputs.append(T)
            if b["kind"] != "slider":
                loads += [sme.Torque(F, T * axis), sme.Torque(P, -T * axis)]
            else:
                loads += [sme.Force(body.masscenter, T * axis)]
                if b["parent"] >= 0:
                    loads.append(sme.Force(parent.masscenter, -T * axis))
    system = sme.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.frame.z)
    if loads:
        system.add_loads(*loads)
    return system, inputs
