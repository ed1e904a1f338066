"""A URDF's body tree straight to the recursive formulation's Tree IR: numbers and symbols only.

Why: the System route (:mod:`.system`, SymPy joints, then
:mod:`eomc.compiler.tree.recognize` reading the tree back) spends nearly all of
a large robot's build in SymPy's frame-graph searches (220 of 234 s for G1).
Here each joint is written down in joint-local terms directly -- the rotation
E(q) and offset r(q) of its body relative to its parent, the constant motion
axes S, the joint's loads -- from the numbers of :mod:`.tree`, in O(n).

The result is what the recognizer finds in the System of :mod:`.system` (the
tests compare the two): the same coordinates, speeds and state order, the same
parameters with the same names and defaults (zeros in the file stay literal
zeros; ``fold`` makes every value a literal), the same inputs, the same
kinematics q' = f(q, u), and the same bodies: the link frame as each body's
frame, its combined centre of mass as its origin.  Per joint, with R0 the
joint origin's rotation, a its axis, p its position (all in the parent body
frame), c the child's and c_p the parent's centre of mass, the joint's
E(q), r(q) (base = p - c_p), S and q' are its kind's in the table of joint kinds
(:mod:`eomc.compiler.multibody.joint_kinds`: revolute and continuous are ``revolute``,
floating and floating_quaternion ``free``).

Joint torques act on the child about a and on the parent about
R0 a; a prismatic joint's force acts at the child's link origin and at the
joint point of the parent.
"""
import math

import numpy as np
import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.tree.model import Tree
from eomc.compiler.tree.joint_laws import JointScale
from eomc.compiler.tree.recognize import effective_inertias

from ..multibody.joint_kinds import KINDS, JointSite
from ..multibody.joints import Parameters, actuation, snapped
from .tree import URDF_KINDS, coordinate_suffixes, identifier
from eomc.compiler import fixed_order as fo

__all__ = ["UrdfTree", "tree_ir"]

_T = dynamicsymbols._t


class UrdfTree:
    """What :func:`tree_ir` returns: the Tree and the names and values beside it."""

    def __init__(self, tree, coordinates, speeds, kinematics, parameters, inputs, source, offsets=()):
        self.tree = tree                  # eomc.compiler.tree.model.Tree
        self.coordinates = coordinates    # q(t), joint order
        self.speeds = speeds              # u(t)
        self.kinematics = kinematics      # q' per coordinate
        self.parameters = parameters      # Symbol -> URDF value
        self.inputs = inputs              # tau(t) per actuated joint, joint order
        self.source = source              # the urdf.tree.Tree
        self.offsets = offsets            # per body: its link origin from its parent's, parent frame


def tree_ir(tree, *, fold=False, gravity=9.81, laws=True, all_inertial=False):
    """The :class:`UrdfTree` of a :class:`.tree.Tree` (see the module docstring); ``laws``: the
    joints' declared limits, damping and friction (:func:`law_torque`) act, else they are ignored;
    ``all_inertial``: every body's mass, centre of mass and inertia entries are parameters,
    zeros included (what identification fits; the motion may still not reach some of them)."""
    params = Parameters(fold)
    inertias = joint_inertias(tree) if laws else None
    bodies, coordinates, speeds, kinematics, inputs, loads, offsets = [], [], [], [], [], [], []
    index, coms, quaternions = {}, {}, []
    torques, potentials = [], []
    for tj in tree.joints:
        body = tree.bodies[tj.child]
        s = identifier(body.name)
        mass = params(f"m_{s}", body.mass, all_inertial)
        c = [params(f"{k}_{s}", v, all_inertial) for k, v in zip(("cx", "cy", "cz"), body.com)]
        I = body.inertia
        e = {key: params(f"I{key}_{s}", I[i, j], all_inertial) for key, (i, j) in
             (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("xy", (0, 1)), ("xz", (0, 2)), ("yz", (1, 2)))}
        inertia = sm.Matrix([[e["xx"], e["xy"], e["xz"]], [e["xy"], e["yy"], e["yz"]],
                             [e["xz"], e["yz"], e["zz"]]])
        j = identifier(tj.name)
        p = [params(f"{k}_{j}", v) for k, v in zip("xyz", tj.position)]
        cp = coms[tj.parent] if tj.parent is not None else [0, 0, 0]
        base = [p[k] - cp[k] for k in range(3)]
        parent = index[tj.parent] if tj.parent is not None else -1
        R0 = snapped(tj.rotation)
        a = snapped(tj.axis)
        suffixes_q, suffixes_u = coordinate_suffixes(tj.type)
        qs = [dynamicsymbols(f"q_{j}" + (f"_{x}" if x else "")) for x in suffixes_q]
        us = [dynamicsymbols(f"u_{j}" + (f"_{x}" if x else "")) for x in suffixes_u]
        first = len(speeds)
        coordinates += qs
        speeds += us
        common = dict(name=s, joint=tj.name, parent=parent, mass=mass, inertia=inertia)
        if tj.type not in URDF_KINDS:
            raise NotImplementedError(f"joint type {tj.type}")
        site = JointSite(R0, tj.axis, base, c, quaternion=tj.type == "floating_quaternion")
        joint = KINDS[URDF_KINDS[tj.type]].mobilize(site, qs, us)
        bodies.append(joint.body(first, **common))
        offsets.append(sm.Matrix(p) if joint.shift is None else sm.Matrix([p[r] + joint.shift[r] for r in range(3)]))
        kinematics += joint.kinematics
        if joint.w is not None:
            quaternions.append(coordinates.index(joint.w))
        index[tj.child] = len(bodies) - 1
        coms[tj.child] = c
        if tj.type in ("revolute", "continuous", "prismatic"):
            tau = dynamicsymbols(f"tau_{j}")
            inputs.append(tau)
            if laws:
                tau = tau + law_torque(tree, tj, qs[0], us[0], params, inertias)
                potentials.append(law_energy(tree, tj, qs[0], params, inertias))
            torques.append((qs[0], us[0], tau))
            loads += actuation(tj.type == "prismatic", tau, a, R0, c, p, cp, index[tj.child], parent)
    g = params("g", gravity) if gravity else sm.S.Zero
    # what the motion cannot excite is dropped, as the System route does: only the symbols
    # the equations use become parameters
    bodies = effective_inertias(bodies, coordinates, speeds, kinematics)
    ir = Tree(bodies=tuple(bodies), coordinates=tuple(coordinates), speeds=tuple(speeds),
              kinematics=tuple(kinematics), gravity=sm.Matrix([0, 0, -g]), loads=tuple(loads),
              quaternions=tuple(quaternions),
              joint_torques=tuple(torques), joint_energy=_total(potentials))
    return UrdfTree(ir, tuple(coordinates), tuple(speeds), tuple(kinematics), params.values, inputs, tree,
                    tuple(offsets))


def pose_source(built, welds, shapes):
    """The animation's poses (eomc.compiler.tree.poses.TreePoseSource) of a :class:`UrdfTree`,
    without a System: one frame per link at its link origin, placed from its parent link by
    the joint's rotation and origin offset; links welded to a body or to the ground
    (``welds``) and the visuals (``shapes``) as the System route gives them; a line from
    each parent link to its child."""
    from eomc.compiler.tree.poses import TreePoseSource, welded_frames
    frames, points, lines = [], [("O", None)], []
    for i, body in enumerate(built.tree.bodies):
        frames.append((body.name, i, None, None))
        points.append((body.name, i))
        lines.append((0 if body.parent < 0 else body.parent + 1, len(points) - 1))
    return TreePoseSource(tuple(welded_frames(welds, frames)), tuple(points), tuple(lines), dict(built.parameters),
                          dict(shapes), tree=built.tree, steps=tuple(tuple(o) for o in built.offsets))


def joint_law(tree, tj):
    """The :class:`~eomc.compiler.tree.joint_laws.JointLaw` of a 1-dof joint's <limit> and
    <dynamics> (a continuous joint has no limits), checked: bad numbers are a
    ModelFileError at the joint's line."""
    from eomc.compiler.tree.joint_laws import JointLaw, JointLawError, check_law
    from eomc.runtime.errors import ModelFileError
    lower, upper = tj.limit if tj.limit is not None and tj.type != "continuous" else (None, None)
    law = JointLaw(tj.name, lower=lower, upper=upper, damping=tj.dynamics[0], friction=tj.dynamics[1])
    try:
        check_law(law)
    except JointLawError as exc:
        raise ModelFileError(str(exc), str(tree.path), tj.line) from None
    return law


def law_torque(tree, tj, q, u, params, inertias):  # inertias: joint -> JointScale
    """The joint-space torque (force) of the joint's declared limits, damping and friction."""
    from eomc.compiler.tree.joint_laws import joint_torque
    law = joint_law(tree, tj)
    if not law.active:
        return sm.S.Zero
    return joint_torque(q, u, law, params, identifier(tj.name), inertias[tj.name])


def law_energy(tree, tj, q, params, inertias):
    """The elastic energy of the joint's limit springs (joint_laws.limit_energy)."""
    from eomc.compiler.tree.joint_laws import limit_energy
    law = joint_law(tree, tj)
    return limit_energy(q, law, params, identifier(tj.name), inertias[tj.name]) if law.limited else sm.S.Zero


def _total(potentials):
    """Their sum, or None when one of them is not a potential (the energy leaves the limits out)."""
    return None if any(p is None for p in potentials) else sum(potentials, sm.S.Zero)


def joint_inertias(tree):
    """joint name -> the inertia its 1-dof motion moves at q = 0 with the other joints held
    (the mass matrix's diagonal entry: the subtree's composite inertia about the joint), the
    scale of the default limit stiffness and damping."""
    from .tree import _motion
    index = {j.child: k for k, j in enumerate(tree.joints)}
    composite = []
    for joint in tree.joints:
        body = tree.bodies[joint.child]
        c = np.asarray(body.com, dtype=float)
        cx = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
        I6 = np.zeros((6, 6))
        I6[:3, :3] = body.inertia + body.mass * fo.matmul(cx, cx.T)
        I6[:3, 3:], I6[3:, :3], I6[3:, 3:] = body.mass * cx, body.mass * cx.T, body.mass * np.eye(3)
        composite.append(I6)
    for k in range(len(tree.joints) - 1, -1, -1):
        joint = tree.joints[k]
        if joint.parent is None:
            continue
        E, r = joint.rotation.T, joint.position
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        X = np.zeros((6, 6))
        X[:3, :3], X[3:, 3:], X[3:, :3] = E, E, -fo.matmul(E, rx)
        composite[index[joint.parent]] = composite[index[joint.parent]] + fo.matmul(X.T, composite[k], X)
    out = {}
    for k, joint in enumerate(tree.joints):
        if joint.type in ("revolute", "continuous", "prismatic"):
            S = _motion(joint)
            out[joint.name] = float(fo.matmul(S.T, composite[k], S)[0, 0])
    loads = joint_loads(tree, inertias=out)
    return {name: JointScale(m, *loads[name]) for name, m in out.items()}


def _entry_speed(gravity, mass, reach, inertia, prismatic):
    """The speed at which a joint may enter its limit: its subtree moving at the speed a fall
    through ``reach`` (the farthest the subtree gets from the root's origin) gives, sqrt(2 g reach),
    at the subtree's radius of gyration about the axis (sqrt(inertia / mass)); a slide at that
    speed.  So a limit stops the subtree's own kinetic energy of that fall within
    :data:`~eomc.compiler.tree.joint_laws.ENTRY_GIVE`: the stiffness it needs,
    m (2 g reach) / (e ENTRY_GIVE)^2, is the subtree's mass m times that, whatever its inertia.
    Why: in a fixed arm's passive collapse the heavy links whip the light ones at the end
    (first hour s24-s25: Panda's hand roll entered its limit at 18.7 rad/s, its wrist at 37 rad/s,
    and went 0.04-0.06 rad past with the inertia rule's 10 ms time constant); the bound is above
    every entry speed measured there (Panda: 8-37 rad/s against 16-64)."""
    if not (mass > 0.0 and reach > 0.0 and inertia > 0.0):
        return 0.0
    fall = math.sqrt(2.0 * gravity * reach)
    return fall if prismatic else fall / math.sqrt(inertia / mass)


def joint_loads(tree, gravity=9.81, inertias=None):
    """joint name -> (load, carried, speed, own_load): the static torque (force) its limit may have to
    hold, at q = 0, the inertia it then carries, the speed it may enter a limit at
    (:func:`_entry_speed`; 0 without ``inertias``) and, on a floating-base robot for a joint whose
    subtree does not hold what the robot stands on (:func:`_support`), its own subtree's load
    (None otherwise: joint_laws.limit_gains then caps its stiffness, not its damping).  The load is the subtree's weight on its lever about
    the axis (all of it for a slide) and, on a floating-base robot, the rest of the robot's
    weight on the reach of the subtree (a knee holding up the body through its foot); the
    carried inertia is the rest of the robot's inertia about the joint's axis (what the joint
    turns when its subtree stands on the ground; 0 on a fixed base).  The reach is the farthest
    of the subtree's bodies' origins and centres of mass from the axis, and at least sqrt(2)
    times the subtree's radius of gyration about the axis
    (``inertias``: joint -> its effective inertia): the ground pushes on the subtree's surface,
    not its centre -- a solid cylinder's surface is sqrt(2) radii of gyration from its axis.
    Without that floor a roll joint along a limb (G1's wrist, whose hand lies on its axis) got
    the load of the hand's centre, 0.5 N·m, and went 0.087 rad past its limit when the hand
    landed (issue 29).  The subtree's own weight is also taken where its own joints can swing it
    off the axis (:func:`_swung_levers`): romeo's wrist roll, whose hand lies on its axis at q = 0,
    got k = 3.78 and went 0.167 rad past its limit once the wrist pitch swung the hand off it."""
    R, P, world, spin = {}, {}, {}, {}
    for joint in tree.joints:      # parents come first
        Rp = R[joint.parent] if joint.parent is not None else np.eye(3)
        Pp = P[joint.parent] if joint.parent is not None else np.zeros(3)
        R[joint.child] = fo.matmul(Rp, joint.rotation)
        P[joint.child] = Pp + fo.matmul(Rp, joint.position)
        body = tree.bodies[joint.child]
        world[joint.child] = (P[joint.child] + fo.matmul(R[joint.child], body.com), body.mass)
        spin[joint.child] = fo.matmul(R[joint.child], body.inertia, R[joint.child].T)
    floating = any(j.parent is None and j.type in ("floating", "floating_quaternion") for j in tree.joints)
    support = _support(P, world) if floating else set()
    total = sum(m for _, m in world.values())
    children, parent_of = {}, {}
    for joint in tree.joints:
        children.setdefault(joint.parent, []).append(joint.child)
        parent_of[joint.child] = joint.parent
    out = {}
    for joint in tree.joints:
        if joint.type not in ("revolute", "continuous", "prismatic"):
            continue
        stack, below = [joint.child], []
        while stack:
            b = stack.pop()
            below.append(b)
            stack.extend(children.get(b, ()))
        mass = sum(world[b][1] for b in below)
        rest = total - mass if floating else 0.0
        reach = max([fo.norm(world[b][0]) for b in below] + [fo.norm(P[b]) for b in below])
        speed = _entry_speed(gravity, mass, reach, (inertias or {}).get(joint.name, 0.0),
                             joint.type == "prismatic")
        if joint.type == "prismatic":
            out[joint.name] = (gravity * (mass + rest), rest, speed,
                               gravity * mass if floating and support.isdisjoint(below) else None)
            continue
        a = fo.matmul(R[joint.child], joint.axis)
        origin = P[joint.child]
        lever = lambda x: fo.norm(np.cross(a, x - origin))  # noqa: E731
        com = sum(world[b][0] * world[b][1] for b in below) / mass if mass > 0 else origin
        load, carried = gravity * mass * lever(com), 0.0
        # the subtree's own joints may swing its bodies off the axis (romeo's wrist roll: the hand
        # lies on the axis at q = 0, and the wrist's pitch swings it 0.06 m off): gravity's torque
        # about the axis is at most g·|a × ẑ|·Σ m_b·(farthest lever of b's centre)
        tilt = fo.norm(np.cross(a, np.array([0.0, 0.0, 1.0])))
        if tilt > 0.0 and len(below) > 1:
            swung = gravity * tilt * sum(world[b][1] * far for b, far in
                                         _swung_levers(joint.child, below, parent_of, P, world, lever).items())
            load = max(load, swung)
        own_load = None
        if floating:
            if support.isdisjoint(below):       # the robot does not stand on this subtree
                own_load = load
            reach = max([lever(world[b][0]) for b in below] + [lever(P[b]) for b in below])
            if inertias is not None and mass > 0:
                reach = max(reach, math.sqrt(2.0 * inertias[joint.name] / mass))
            load = max(load, gravity * rest * reach)
            inside = set(below)
            carried = sum(fo.matmul(a, spin[b], a) + world[b][1] * lever(world[b][0]) ** 2
                          for b in world if b not in inside)
        out[joint.name] = (load, carried, speed, own_load)
    return out


# A body within this fraction of the robot's height (its bodies' origins and centres of mass at
# q = 0) of its lowest is part of what a floating-base robot stands on (joint_loads: _support)
SUPPORT_BAND = 0.25


def _support(P, world):
    """The bodies a floating-base robot stands on at q = 0: those whose origin or centre of mass lies
    within SUPPORT_BAND of the robot's height above its lowest (the feet and shins of a standing
    robot; every body of one that lies flat).  Why: a joint whose subtree holds them carries the
    rest of the robot whenever it stands; any other (an arm, a gripper's finger) only when the robot
    lands on it, and its limit's stiffness is capped (joint_laws.limit_gains)."""
    low = {b: min(P[b][2], world[b][0][2]) for b in P}
    high = max(max(P[b][2], world[b][0][2]) for b in P)
    bottom = min(low.values())
    return {b for b, z in low.items() if z <= bottom + SUPPORT_BAND * (high - bottom)}


def _swung_levers(top, below, parent_of, P, world, lever):
    """body -> the farthest its centre of mass can be from a joint's axis when the joints inside
    the joint's subtree (``below``, rooted at ``top``, the body the joint moves) turn: ``top``'s
    own lever (it is rigid with the joint), a deeper body's at most the lever of the first inner
    joint's origin plus the lengths down the chain to its centre (the triangle inequality)."""
    reach = {}      # body -> the farthest its joint's origin can be from the axis
    out = {top: lever(world[top][0])}
    for b in below:     # parents before children (a depth-first walk from top)
        if b == top:
            continue
        up = parent_of[b]
        reach[b] = lever(P[b]) if up == top else reach[up] + fo.norm(P[b] - P[up])
        out[b] = reach[b] + fo.norm(world[b][0] - P[b])
    return out
