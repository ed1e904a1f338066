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
frame), c the child's and c_p the parent's centre of mass:

- revolute/continuous: R_PC = R0 Rot(a, q); r = p - c_p + R_PC c; S = (a, a × c)
- prismatic: R_PC = R0; r = p - c_p + R0 (a q + c); S = (0, a)
- floating: R_PC = R0 Rx Ry Rz; r = p - c_p + R0 (x, y, z) + R_PC c; speeds the
  child point's velocity and the angular velocity in child components
  (floating_quaternion: R_PC = R0 R(w, x, y, z), :func:`quaternion_rotation`; the same speeds)
- planar: in the frame A = R0 Z (Z turns z onto a): R_PC = A Rz(th) Zᵀ,
  r = p - c_p + A (x, y, 0) + R_PC c; speeds as Pinocchio's planar joint

(E = R_PCᵀ.)  Joint torques act on the child about a and on the parent about
R0 a; a prismatic joint's force acts at the child's link origin and at the
joint point of the parent.
"""
import numpy as np
import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.tree.model import Tree, TreeBody
from eomc.compiler.tree.joint_laws import JointScale
from eomc.compiler.tree.recognize import effective_inertias

from ..multibody.joints import (Parameters, actuation, cross, lin, rotation_terms, snap, snapped, times, vec,
                               z_to)
from .tree import coordinate_suffixes, identifier

__all__ = ["UrdfTree", "tree_ir", "floating_rotation", "floating_kinematics", "quaternion_rotation",
           "quaternion_kinematics", "free_joint"]

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


def floating_rotation(rx, ry, rz):
    """R = Rx Ry Rz (child components -> parent components) of body-fixed XYZ angles,
    entry for entry as SymPy's ``orient_body_fixed(..., 'xyz')`` gives ``parent.dcm(child)``."""
    cx, sx, cy, sy, cz, sz = sm.cos(rx), sm.sin(rx), sm.cos(ry), sm.sin(ry), sm.cos(rz), sm.sin(rz)
    Rx = sm.Matrix([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = sm.Matrix([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = sm.Matrix([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx * Ry * Rz


def floating_kinematics(q, u):
    """q' of a floating joint (as :class:`.joints.FloatingJoint`): position' = R v, and the
    body-XYZ Euler rates of the body-frame angular velocity in closed form."""
    R = floating_rotation(*q[3:])
    velocity = R * sm.Matrix(u[:3])
    wx, wy, wz = u[3:]
    cy, sz, cz = sm.cos(q[4]), sm.sin(q[5]), sm.cos(q[5])
    rate_x = (wx * cz - wy * sz) / cy
    return [velocity[0], velocity[1], velocity[2], rate_x, wx * sz + wy * cz, wz - rate_x * sm.sin(q[4])]


def quaternion_rotation(w, x, y, z):
    """R (child components -> parent components) of the quaternion (w, x, y, z), a rotation for
    any nonzero length: R = I + s [[-(y²+z²), xy-wz, xz+wy], ...] with s = 2/(w²+x²+y²+z²)
    (the unit-quaternion formula with 2 replaced by 2/|q|²).  Why not assume |q| = 1: an
    integrator's step leaves |q| off 1 by its error (until the step's end normalises it), a
    Newton iterate or a caller's x0 by more; this way the rhs is the same at q and at any
    multiple of it -- the dynamics never sees |q| -- for one division, no sin/cos."""
    s = 2 / (w ** 2 + x ** 2 + y ** 2 + z ** 2)
    xx, yy, zz, xy, xz, yz, wx, wy, wz = x * x, y * y, z * z, x * y, x * z, y * z, w * x, w * y, w * z
    return sm.Matrix([[1 - s * (yy + zz), s * (xy - wz), s * (xz + wy)],
                      [s * (xy + wz), 1 - s * (xx + zz), s * (yz - wx)],
                      [s * (xz - wy), s * (yz + wx), 1 - s * (xx + yy)]])


def quaternion_kinematics(q, u):
    """q' of a quaternion free joint, q = (x, y, z, w, qx, qy, qz), u = (v, ω) in body
    components: position' = R v, and quat' = ½ quat ⊗ (0, ω) (Hamilton product; linear in
    the quaternion, so its length is constant along exact solutions)."""
    R = quaternion_rotation(*q[3:])
    velocity = R * sm.Matrix(u[:3])
    w, x, y, z = q[3:]
    a, b, c = u[3:]
    half = sm.Rational(1, 2)
    return [velocity[0], velocity[1], velocity[2],
            -half * (x * a + y * b + z * c), half * (w * a + y * c - z * b),
            half * (w * b + z * a - x * c), half * (w * c + x * b - y * a)]


def free_joint(qs, us, quaternion):
    """(R, q') of a free joint's coordinates ``qs`` (position, then 3 angles or a
    quaternion) and body-frame speeds ``us``."""
    if quaternion:
        return quaternion_rotation(*qs[3:]), quaternion_kinematics(qs, us)
    return floating_rotation(*qs[3:]), floating_kinematics(qs, us)


def tree_ir(tree, *, fold=False, gravity=9.81, laws=True):
    """The :class:`UrdfTree` of a :class:`.tree.Tree` (see the module docstring); ``laws``: the
    joints' declared limits, damping and friction (:func:`law_torque`) act, else they are ignored."""
    params = Parameters(fold)
    inertias = joint_inertias(tree) if laws else None
    bodies, coordinates, speeds, kinematics, inputs, loads, offsets = [], [], [], [], [], [], []
    index, coms, quaternions = {}, {}, []
    torques = []
    for tj in tree.joints:
        body = tree.bodies[tj.child]
        s = identifier(body.name)
        mass = params(f"m_{s}", body.mass)
        c = [params(f"{k}_{s}", v) for k, v in zip(("cx", "cy", "cz"), body.com)]
        I = body.inertia
        e = {key: params(f"I{key}_{s}", I[i, j]) for key, (i, j) in
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
        if tj.type in ("revolute", "continuous"):
            A, B, C = rotation_terms(R0, a)
            cq, sq = sm.cos(qs[0]), sm.sin(qs[0])
            R = sm.Matrix(3, 3, lambda r, k: lin((A[r, k], B[r, k], C[r, k]), (cq, sq, 1)))
            Rc = [sum((R[r, k] * c[k] for k in range(3) if c[k] != 0), sm.S.Zero) for r in range(3)]
            position = sm.Matrix([base[r] + Rc[r] for r in range(3)])
            av = vec(a)
            motion = tuple(av) + tuple(cross(av, c))
            bodies.append(TreeBody(kind="revolute", speed=first, rotation=R.T, position=position,
                                   motion=motion, **common))
            offsets.append(sm.Matrix(p))
            kinematics.append(us[0])
        elif tj.type == "prismatic":
            R0a = times(R0, [a[k] * qs[0] for k in range(3)])
            R0c = times(R0, c)
            position = sm.Matrix([base[r] + R0c[r] + R0a[r] for r in range(3)])
            motion = (0, 0, 0) + tuple(vec(a))
            bodies.append(TreeBody(kind="prismatic", speed=first, rotation=sm.Matrix(R0.T).applyfunc(snap),
                                   position=position, motion=motion, **common))
            offsets.append(sm.Matrix([p[r] + R0a[r] for r in range(3)]))
            kinematics.append(us[0])
        elif tj.type in ("floating", "floating_quaternion"):
            Rf, qdot = free_joint(qs, us, tj.type == "floating_quaternion")
            R = sm.Matrix(3, 3, lambda r, k: sum((snap(R0[r, m]) * Rf[m, k] for m in range(3)
                                                  if snap(R0[r, m]) != 0), sm.S.Zero))
            xyz = times(R0, qs[:3])
            Rc = [sum((R[r, k] * c[k] for k in range(3) if c[k] != 0), sm.S.Zero) for r in range(3)]
            position = sm.Matrix([base[r] + xyz[r] + Rc[r] for r in range(3)])
            unit = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
            motions = tuple((0, 0, 0) + e_ for e_ in unit) + tuple(
                tuple(e_) + tuple(cross(list(e_), c)) for e_ in unit)
            bodies.append(TreeBody(kind="free", speed=None, rotation=R.T, position=position, motion=None,
                                   speeds=tuple(range(first, first + 6)), motions=motions, **common))
            offsets.append(sm.Matrix([p[r] + xyz[r] for r in range(3)]))
            kinematics += qdot
            if tj.type == "floating_quaternion":
                quaternions.append(len(coordinates) - 4)
        elif tj.type == "planar":
            Z = snapped(z_to(tj.axis))
            Aj = snapped(R0 @ Z)
            cth, sth = sm.cos(qs[2]), sm.sin(qs[2])
            # R_PC = Aj Rz(th) Zᵀ = P cos + Q sin + W
            Pm = snapped(Aj @ np.diag([1.0, 1.0, 0.0]) @ Z.T)
            Qm = snapped(Aj @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]) @ Z.T)
            Wm = snapped(Aj @ np.diag([0.0, 0.0, 1.0]) @ Z.T)
            R = sm.Matrix(3, 3, lambda r, k: lin((Pm[r, k], Qm[r, k], Wm[r, k]), (cth, sth, 1)))
            xy = times(Aj, [qs[0], qs[1], 0])
            Rc = [sum((R[r, k] * c[k] for k in range(3) if c[k] != 0), sm.S.Zero) for r in range(3)]
            position = sm.Matrix([base[r] + xy[r] + Rc[r] for r in range(3)])
            n = vec(Z[:, 2])
            motions = ((0, 0, 0) + tuple(vec(Z[:, 0])), (0, 0, 0) + tuple(vec(Z[:, 1])),
                       tuple(n) + tuple(cross(n, c)))
            bodies.append(TreeBody(kind="3-speed", speed=None, rotation=R.T, position=position, motion=None,
                                   speeds=(first, first + 1, first + 2), motions=motions, **common))
            offsets.append(sm.Matrix([p[r] + xy[r] for r in range(3)]))
            kinematics += [us[0] * cth - us[1] * sth, us[0] * sth + us[1] * cth, us[2]]
        else:
            raise NotImplementedError(f"joint type {tj.type}")
        index[tj.child] = len(bodies) - 1
        coms[tj.child] = c
        if tj.type in ("revolute", "continuous", "prismatic"):
            tau = dynamicsymbols(f"tau_{j}")
            inputs.append(tau)
            if laws:
                tau = tau + law_torque(tree, tj, qs[0], us[0], params, inertias)
            torques.append((qs[0], us[0], tau))
            loads += actuation(tj.type == "prismatic", tau, a, R0, c, p, cp, index[tj.child], parent)
    g = params("g", gravity) if gravity else sm.S.Zero
    # what the motion cannot excite is dropped, as the System route does: only the symbols
    # the equations use become parameters
    bodies = effective_inertias(bodies, coordinates, speeds, kinematics)
    ir = Tree(bodies=tuple(bodies), coordinates=tuple(coordinates), speeds=tuple(speeds),
              kinematics=tuple(kinematics), gravity=sm.Matrix([0, 0, -g]), loads=tuple(loads),
              quaternions=tuple(quaternions),
              joint_torques=tuple(torques))
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
        I6[:3, :3] = body.inertia + body.mass * (cx @ cx.T)
        I6[:3, 3:], I6[3:, :3], I6[3:, 3:] = body.mass * cx, body.mass * cx.T, body.mass * np.eye(3)
        composite.append(I6)
    for k in range(len(tree.joints) - 1, -1, -1):
        joint = tree.joints[k]
        if joint.parent is None:
            continue
        E, r = joint.rotation.T, joint.position
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        X = np.zeros((6, 6))
        X[:3, :3], X[3:, 3:], X[3:, :3] = E, E, -E @ rx
        composite[index[joint.parent]] = composite[index[joint.parent]] + X.T @ composite[k] @ X
    loads = joint_loads(tree)
    out = {}
    for k, joint in enumerate(tree.joints):
        if joint.type in ("revolute", "continuous", "prismatic"):
            S = _motion(joint)
            out[joint.name] = JointScale(float((S.T @ composite[k] @ S)[0, 0]), loads[joint.name])
    return out


def joint_loads(tree, gravity=9.81):
    """joint name -> the static torque (force) its limit may have to hold, at q = 0: the
    subtree's weight on its lever about the axis (all of it for a slide) and, on a
    floating-base robot, the rest of the robot's weight on the lever of the subtree's
    farthest body (a knee holding up the body through its foot)."""
    R, P, world = {}, {}, {}
    for joint in tree.joints:      # parents come first
        Rp = R[joint.parent] if joint.parent is not None else np.eye(3)
        Pp = P[joint.parent] if joint.parent is not None else np.zeros(3)
        R[joint.child] = Rp @ np.asarray(joint.rotation, dtype=float)
        P[joint.child] = Pp + Rp @ np.asarray(joint.position, dtype=float)
        body = tree.bodies[joint.child]
        world[joint.child] = (P[joint.child] + R[joint.child] @ np.asarray(body.com, dtype=float), body.mass)
    floating = any(j.parent is None and j.type in ("floating", "floating_quaternion") for j in tree.joints)
    total = sum(m for _, m in world.values())
    children = {}
    for joint in tree.joints:
        children.setdefault(joint.parent, []).append(joint.child)
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
        if joint.type == "prismatic":
            out[joint.name] = gravity * (mass + (total - mass if floating else 0.0))
            continue
        a = R[joint.child] @ np.asarray(joint.axis, dtype=float)
        origin = P[joint.child]
        lever = lambda x: float(np.linalg.norm(np.cross(a, x - origin)))  # noqa: E731
        com = sum(world[b][0] * world[b][1] for b in below) / mass if mass > 0 else origin
        load = gravity * mass * lever(com)
        if floating:
            reach = max([lever(world[b][0]) for b in below] + [lever(P[b]) for b in below])
            load = max(load, gravity * (total - mass) * reach)
        out[joint.name] = load
    return out
