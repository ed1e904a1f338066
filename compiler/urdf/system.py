"""A :class:`Tree` as a SymPy mechanics ``System`` built from SymPy's own joint classes.

Per moving body (a link, with the links welded to it merged in): a
``RigidBody`` whose frame is the link frame and whose mass centre is the
combined centre of mass.  Per moving joint: ``PinJoint`` (revolute,
continuous), ``PrismaticJoint`` or :class:`FloatingJoint` from its parent
body's joint point and a constant interframe (the joint origin's rotation).
The world is the system's fixed frame ``N`` (z up) with gravity ``-g N.z``.

Names (``s`` = the joint's or link's name made a C identifier):

- coordinates ``q_s``, speeds ``u_s``; a floating joint has ``q_s_x, q_s_y,
  q_s_z, q_s_rx, q_s_ry, q_s_rz`` and ``u_s_vx, u_s_vy, u_s_vz, u_s_wx,
  u_s_wy, u_s_wz`` (see :mod:`.joints`)
- inputs ``tau_s``: the torque (revolute) or force (prismatic) each actuated
  joint applies to its child; floating joints are unactuated
- parameters, per body ``m_s``, ``cx_s cy_s cz_s`` (centre of mass in the link
  frame), ``Ixx_s Iyy_s Izz_s Ixy_s Ixz_s Iyz_s`` (about the centre of mass,
  link frame); per joint ``x_s y_s z_s`` (origin in the parent body frame);
  and ``g``.  Entries that are exactly zero in the file stay literal zeros, so
  structure the URDF does not have costs nothing; rotations (rpy) and axes
  are literal numbers.

Mimic joints (``<mimic joint=A multiplier=k offset=c>``) become a holonomic
constraint ``q_B = k q_A + c`` with ``q_B`` and ``u_B`` dependent, when
``mimic=True``; otherwise (default) they move freely, as in Pinocchio's
default URDF reader.  A mimic joint has no input of its own.
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm
from sympy.physics import mechanics as sme

from eomc.runtime.errors import ModelFileError

from ..multibody.frames import TreeFrame
from ..multibody.joints import z_to
from .joints import FloatingJoint, PlanarJoint
from .tree import check_mimics, identifier
from eomc.compiler import fixed_order as fo

__all__ = ["UrdfSystem", "system_from_tree", "make_system", "identifier"]

_SNAP = 1e-12


def make_system(newtonian):
    """The System class eomc compiles.  One place to swap in eomc's own System at merge."""
    return sme.System.from_newtonian(newtonian)


def _snap(value):
    """Exact 0 and ±1 for numbers within 1e-12 of them (rpy of 90° in double precision)."""
    for exact in (0, 1, -1):
        if abs(value - exact) < _SNAP:
            return sm.Integer(exact)
    return sm.Float(float(value), 17)


def _number(rotation):
    """A 3x3 numpy rotation as a SymPy matrix of snapped literals."""
    return sm.Matrix(3, 3, [_snap(v) for v in np.asarray(rotation, dtype=float).ravel()])


@dataclass
class UrdfSystem:
    """What :func:`system_from_tree` returns: the System and what eomc needs beside it."""
    system: object              # sympy.physics.mechanics.System (or eomc's, see make_system)
    parameters: dict            # Symbol -> URDF value
    inputs: list                # joint torque/force dynamic symbols, in joint order
    joints: dict                # joint name -> SymPy joint
    bodies: dict                # body name -> RigidBody
    tree: object                # the tree.Tree it came from
    gravity: object = 0         # g (its symbol, or the number when folded; 0: no gravity)

    def model(self, poses=False):
        """The multibody Model of the reading this System was built from (its links, welded
        ones included, as frames; its tree's symbols are this System's), read again from
        nothing: what frame outputs of a from_urdf System passed in as an object name.
        ``poses``: with the welded links' placements and the visuals (``welds``, ``shapes``)."""
        from .model import UrdfModel, model_of_robot
        return model_of_robot(self.tree.robot, self.tree,
                              UrdfModel(self.tree.path, fold_parameters=not self.parameters), poses)

    def energy(self):
        """The bodies' kinetic energy and their potential in the System's gravity (``-g N.z``):
        m g z of each mass centre above the world origin, the joints' offsets included, as the
        recursive form's ``energy`` output counts them (compiler/tree/contacts._energy).  Why:
        Kane's form of a URDF robot with limits gets the same ``energy`` output as the recursive
        one (eomc.compiler.urdf.model._kane_energy adds the limits' springs), so auto may pick
        either by cost and the run's energy verdict is there with both."""
        from ..mechanics.energy import kinetic_energy
        N, origin = self.system.frame, self.system.fixed_point
        bodies = list(self.bodies.values())
        energy = kinetic_energy(N, *bodies)
        if self.gravity != 0:
            energy += sm.Add(*[b.mass * self.gravity * b.masscenter.pos_from(origin).dot(N.z) for b in bodies])
        return energy


class _Parameters:
    """Named symbols for non-zero numbers; exact zeros (and ``fold``) stay literal."""

    def __init__(self, fold):
        self.fold, self.values, self.taken = fold, {}, set()

    def __call__(self, name, value, keep=False):
        """``keep``: a symbol even at 0 (a joint limit's position: a knee's range starts at 0,
        and the runtime finds a limit by its parameter, runtime/switching.find_switches)."""
        value = float(value)
        if value == 0.0 and not (keep and not self.fold):
            return sm.Integer(0)
        if self.fold:
            return _snap(value)
        base, index = name, 2
        while name in self.taken:
            name, index = f"{base}_{index}", index + 1
        self.taken.add(name)
        symbol = sm.Symbol(name)
        self.values[symbol] = value
        return symbol


def _vector(frame, components):
    return sum((c * axis for c, axis in zip(components, (frame.x, frame.y, frame.z))), sme.Vector(0))


def _body(body, params, keep_zero=False):
    s = identifier(body.name)
    frame = TreeFrame(f"F_{s}")
    mass = params(f"m_{s}", body.mass, keep_zero)
    com = [params(f"{c}_{s}", v, keep_zero) for c, v in zip(("cx", "cy", "cz"), body.com)]
    I = body.inertia
    entries = {key: params(f"I{key}_{s}", I[i, j], keep_zero) for key, (i, j) in
               (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)),
                ("xy", (0, 1)), ("xz", (0, 2)), ("yz", (1, 2)))}
    masscenter = sme.Point(f"G_{s}")
    dyadic = sme.inertia(frame, entries["xx"], entries["yy"], entries["zz"],
                         entries["xy"], entries["yz"], entries["xz"])
    rigid = sme.RigidBody(s, masscenter, frame, mass, (dyadic, masscenter))
    return rigid, com


def system_from_tree(tree, *, fold=False, mimic=False, gravity=9.81, laws=True, all_inertial=False):
    """Build the :class:`UrdfSystem` of a :class:`tree.Tree` (see the module docstring); ``laws``:
    the joints' limits, damping and friction act (as in :func:`.treeir.law_torque`);
    ``all_inertial``: every body's 10 inertial entries are parameters, zeros included."""
    from .treeir import joint_inertias, law_torque
    if mimic:
        check_mimics(tree, tree.joints)
    params = _Parameters(fold)
    inertias = joint_inertias(tree) if laws else None
    N = TreeFrame("N")
    origin = sme.Point("O")
    origin.set_vel(N, 0)
    world = sme.RigidBody("world", origin, N, sm.Integer(0), (sme.inertia(N, 0, 0, 0), origin))
    system = make_system(world)
    bodies, coms, joints, inputs, loads = {}, {}, {}, [], []
    for tj in tree.joints:
        child, com = _body(tree.bodies[tj.child], params, all_inertial)
        bodies[tj.child], coms[tj.child] = child, com
        s = identifier(tj.name)
        position = [params(f"{axis}_{s}", v) for axis, v in zip("xyz", tj.position)]
        if tj.parent is None:
            parent_frame, parent_point = N, origin.locatenew(f"P_{s}", _vector(N, position))
            parent = world
        else:
            parent = bodies[tj.parent]
            parent_frame = parent.frame
            offset = [p - c for p, c in zip(position, coms[tj.parent])]
            parent_point = parent.masscenter.locatenew(f"P_{s}", _vector(parent_frame, offset))
        interframe = TreeFrame(f"J_{s}")
        child_interframe = None
        if tj.type == "planar":   # interframes whose z is the plane's normal
            align = z_to(tj.axis)
            interframe.orient_explicit(parent_frame, _number(fo.matmul(tj.rotation, align)))
            child_interframe = TreeFrame(f"K_{s}")
            child_interframe.orient_explicit(child.frame, _number(align))
        else:
            interframe.orient_explicit(parent_frame, _number(tj.rotation))
        child_point = child.masscenter.locatenew(f"C_{s}", _vector(child.frame, [-c for c in com]))
        axis = _vector(interframe, [_snap(v) for v in tj.axis])
        joint = _joint(tj, s, parent, child, parent_point, child_point, interframe, axis,
                       child_interframe)
        joints[tj.name] = joint
        _set_velocities(N, parent, joint)
        _add_joint(system, joint, dependent=mimic and tj.mimic is not None)
        if tj.type in ("revolute", "continuous", "prismatic") and not (mimic and tj.mimic):
            tau = sme.dynamicsymbols(f"tau_{s}")
            inputs.append(tau)
            law = law_torque(tree, tj, joint.coordinates[0], joint.speeds[0], params, inertias) if laws else 0
            if law == 0:
                loads += _actuation(tj.type, tau, joint, parent_frame, child, parent_point, child_point)
            else:
                loads += _body_actuation(tj, tau + law, parent_frame, child, parent_point, child_point)
    if mimic:
        _add_mimics(system, tree, joints)
    g = params("g", gravity) if gravity else 0
    if gravity:
        system.apply_uniform_gravity(-g * N.z)
    if loads:
        system.add_loads(*loads)
    return UrdfSystem(system, params.values, inputs, joints, bodies, tree, g)



def _set_velocities(N, parent, joint):
    """Angular velocity of the child and velocities in N of its mass centre and the joint points.

    SymPy would find these on demand by searching the graphs of frames and
    points (and, at a prismatic joint, warn that it found two paths).  Set
    here, parent to child along the tree, each one is expressed in its own
    body's frame -- the child's angular velocity ω_parent + ω_joint, a point's
    ``d/dt r + v(neighbour)`` -- as Featherstone's recursions keep body-frame
    quantities: each step then costs one joint rotation instead of a chain of
    them.  Measured on the rhs: UR5 1,797 -> 1,355 operations, Panda
    6,452 -> 5,231 (SymPy's own on-demand search gives the former).
    """
    frame = joint.child.frame
    frame.set_ang_vel(N, frame.ang_vel_in(N).express(frame))

    def from_point(point, base, in_frame, relative=None):
        rate = point.pos_from(base).dt(N) if relative is None else relative
        point.set_vel(N, (rate + base.vel(N)).express(in_frame))
    child, P, C = joint.child.masscenter, joint.parent_point, joint.child_point
    from_point(P, parent.masscenter, parent.frame)
    if isinstance(joint, (FloatingJoint, PlanarJoint)):
        # through the joint's own speeds, not d/dt of its position coordinates,
        # which Kane would replace by the rotated speeds R v
        from_point(C, P, frame, C.vel(parent.frame) + parent.frame.ang_vel_in(N).cross(C.pos_from(P)))
        from_point(child, C, frame)
        return
    from_point(child, parent.masscenter, frame)
    from_point(C, child, frame)


def _add_joint(system, joint, dependent=False):
    """Like ``System.add_joints``, but in a fixed order (SymPy's goes through sets)."""
    system.add_coordinates(*joint.coordinates, independent=not dependent)
    system.add_speeds(*joint.speeds, independent=not dependent)
    system.add_kdes(*joint.kdes)
    system.add_bodies(joint.child)
    system.add_joints(joint)


def _joint(tj, s, parent, child, parent_point, child_point, interframe, axis, child_interframe=None):
    from sympy.physics.mechanics import PinJoint, PrismaticJoint
    q, u = sme.dynamicsymbols(f"q_{s} u_{s}")
    common = dict(parent_point=parent_point, child_point=child_point, parent_interframe=interframe)
    if tj.type in ("revolute", "continuous"):
        return PinJoint(tj.name, parent, child, q, u, joint_axis=axis, **common)
    if tj.type == "prismatic":
        return PrismaticJoint(tj.name, parent, child, q, u, joint_axis=axis, **common)
    if tj.type == "floating":
        qs = sme.dynamicsymbols(" ".join(f"q_{s}_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")))
        us = sme.dynamicsymbols(" ".join(f"u_{s}_{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz")))
        return FloatingJoint(tj.name, parent, child, qs, us, **common)
    if tj.type == "floating_quaternion":
        from eomc.runtime.errors import ModelError
        raise ModelError(f"joint {tj.name}: a quaternion floating base (floating_base='quaternion') is "
                         f"lowered by the recursive formulation only (formulation 'recursive' or 'auto'); "
                         f"Kane's formulation takes floating_base='euler' (body XYZ angles)")
    if tj.type == "planar":
        qs = sme.dynamicsymbols(" ".join(f"q_{s}_{c}" for c in ("x", "y", "th")))
        us = sme.dynamicsymbols(" ".join(f"u_{s}_{c}" for c in ("vx", "vy", "w")))
        return PlanarJoint(tj.name, parent, child, qs, us, child_interframe=child_interframe, **common)
    raise NotImplementedError(f"joint type {tj.type}")


def _actuation(kind, tau, joint, parent_frame, child, parent_point, child_point):
    axis = joint.joint_axis.normalize()
    if kind == "prismatic":
        return [sme.Force(child_point, tau * axis), sme.Force(parent_point, -tau * axis)]
    return [sme.Torque(child.frame, tau * axis), sme.Torque(parent_frame, -tau * axis)]


def _body_actuation(tj, tau, parent_frame, child, parent_point, child_point):
    """:func:`_actuation` with the axis in the child's frame (the same numbers: URDF's axis is in
    the joint frame, which is the child link frame) and the reaction's in the parent's (R0 a).

    Why not the joint frame: a torque whose magnitude depends on q (a limit's spring) would
    no longer have constant components in the child frame at q = 0, which is how the tree
    reader (:func:`eomc.compiler.tree.recognize._body_components`) decides a load is a
    body-frame one; here both frames are the bodies' own, as in :mod:`.treeir`."""
    a = [_snap(v) for v in tj.axis]
    back = [_snap(v) for v in fo.matmul(tj.rotation, tj.axis)]
    on_child, on_parent = _vector(child.frame, [tau * v for v in a]), _vector(parent_frame, [-tau * v for v in back])
    if tj.type == "prismatic":
        return [sme.Force(child_point, on_child), sme.Force(parent_point, on_parent)]
    return [sme.Torque(child.frame, on_child), sme.Torque(parent_frame, on_parent)]


def _add_mimics(system, tree, joints):
    """q_B = k q_A + c and u_B = k u_A for each mimic joint B of A (B's q and u are dependent)."""
    position, velocity = [], []
    for tj in tree.joints:
        if tj.mimic is None:
            continue
        target, k, c = tj.mimic
        B, A = joints[tj.name], joints[target]
        if len(B.coordinates) != 1 or len(A.coordinates) != 1:
            raise ModelFileError(f"joint '{tj.name}' mimics '{target}': only 1-dof joints can mimic and "
                                 f"be mimicked", str(tree.path), tj.line)
        position.append(B.coordinates[0] - (_snap(k) * A.coordinates[0] + _snap(c)))
        velocity.append(B.speeds[0] - _snap(k) * A.speeds[0])
    system.add_holonomic_constraints(*position)
    system.velocity_constraints = velocity
