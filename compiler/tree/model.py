"""The tree IR: bodies connected by one-speed joints, as the recursive algorithms need it.

Every body has its own frame and origin (its mass centre).  Body ``i`` hangs from
``parent`` (``-1``: the ground) through a joint described in joint-local terms:

* ``rotation``  E(q_k): parent-frame components -> body-frame components;
* ``position``  r(q_k): the body origin relative to the parent's origin, in
  parent-frame components;
* ``motion``    S: the body's velocity relative to its parent (angular; linear
  velocity of its origin), in body-frame components, per unit of its speed
  u_k; constant (revolute and prismatic joints with fixed axes).  ``None`` for a
  fixed joint.
* ``armature``  per speed, an inertia added to the joint-space mass matrix's
  diagonal (M_ii += a_i; no velocity or gravity term): a motor's rotor inertia
  reflected through its gear, as MuJoCo's ``dof_armature``.  Empty (the
  default) means none, so a reader that never sets it is unaffected.

A joint of k > 1 speeds (a free joint with body-frame twist speeds, a planar
or cylindrical joint) has ``speed``/``motion`` ``None`` and lists its speeds
and their constant body-frame axes in ``speeds``/``motions`` instead: its
motion subspace is the 6xk matrix of those axes, and the recursions solve the
kxk joint-space inertia D = Sᵀ Iᴬ S in straight-line code.  Its rotation and
position then depend on the joint's own coordinates (several), and its
coordinates' rates q' = f(q, u) need not be the speeds: the recursion never
uses them, only ``Tree.kinematics`` (the Kane path's) does.  ``dofs`` gives
every body's (speed, axis) pairs uniformly.

Everything here is a SymPy expression in the mechanics objects (q(t), u(t),
parameters, inputs); the lowering renames them to C slots.  A tree says nothing
of *how* it was found (SymPy joints or hand-built frames, see
:mod:`.recognize`); the recursions (:mod:`.aba`, :mod:`.rnea`, :mod:`.crba`) read only this.
"""
from dataclasses import dataclass, field

import sympy as sm

__all__ = ["TreeBody", "Load", "Tree", "NotATree", "tree_exprs"]


class NotATree(ValueError):
    """The system is not a tree the recursion can take; the message names the joint or body."""


@dataclass(frozen=True)
class TreeBody:
    name: str
    joint: str                   # the joint's name (for messages)
    kind: str                    # "revolute", "prismatic", "fixed", or a multi-dof kind ("free", ...)
    parent: int                  # index of the parent body, -1 for the ground
    speed: object                # index into Tree.speeds, or None (fixed joint)
    rotation: sm.Matrix          # 3x3, E(q_k)
    position: sm.Matrix          # 3x1, r(q_k)
    motion: tuple                # 6 constants (S), or None
    mass: object
    inertia: sm.Matrix           # 3x3 about the mass centre, body-frame components
    speeds: tuple = ()           # a joint of k > 1 speeds: their indices into Tree.speeds
    motions: tuple = ()          # ... and their constant axes (k tuples of 6)
    armature: tuple = ()         # per speed, in ``dofs`` order: a joint-space inertia added to M's
                                 # diagonal (a rotor's inertia through its gear: MuJoCo's
                                 # dof_armature); () is none

    @property
    def armatures(self):
        """The armature of each speed in ``dofs`` order (zeros when the joint has none)."""
        if not self.armature:
            return (0,) * len(self.dofs)
        if len(self.armature) != len(self.dofs):
            raise NotATree(f"body {self.name} (joint {self.joint}): {len(self.armature)} armature values "
                           f"for {len(self.dofs)} speeds")
        return tuple(self.armature)

    @property
    def dofs(self):
        """((speed index, 6-tuple axis), ...): one pair per speed of the joint, () if fixed."""
        if self.speed is not None:
            return ((self.speed, self.motion),)
        return tuple(zip(self.speeds, self.motions))


@dataclass(frozen=True)
class Load:
    """A force and a moment on one body, about its origin.

    ``frame``: "body" (components in the body frame) or "world" (in the ground
    frame; rotated into the body by the body's world rotation, built recursively).
    """
    body: int
    frame: str
    moment: sm.Matrix            # 3x1
    force: sm.Matrix             # 3x1
    offset: sm.Matrix            # 3x1: the force's point of application from the origin, body frame


@dataclass(frozen=True)
class Tree:
    bodies: tuple                # TreeBody, parents before children
    coordinates: tuple           # q, as the Kane path orders them
    speeds: tuple                # u, as the Kane path orders them
    kinematics: tuple            # q' in q, u (one per coordinate)
    gravity: sm.Matrix           # 3x1 in ground components (zero when absent)
    loads: tuple                 # Load
    notes: tuple = ()            # how the reading went where it was not the direct way (str)
    # the holonomic constraints closing the tree (compiler/tree/constrained.Loops), or None; a
    # field, so a Tree rebuilt with dataclasses.replace (contacts, ...) keeps them
    loops: object = field(default=None, compare=False)
    # the index into ``coordinates`` of each quaternion's w (x, y, z follow): the integrators
    # keep these unit (free joints with floating_base="quaternion"); () when there are none
    quaternions: tuple = ()
    # ((coordinate, speed, torque), ...): each 1-dof joint's torque (force) on its child about
    # its axis, a function of its own coordinate and speed (damping, spring, limits, friction)
    # and inputs; read by the fixed-step integrator's NAME_implicit (compiler/tree/lower.py)
    joint_torques: tuple = field(default=(), compare=False)
    # the elastic energy the joints' limit springs store (compiler/tree/joint_laws.limit_energy),
    # a function of the coordinates and parameters, for the generated ``energy`` output; None
    # where the laws have no such potential (MJCF's unilateral limits)
    joint_energy: object = field(default=None, compare=False)
    # the potential of the joints' springs, Σ k/2 (q - q0)² (MJCF's stiffness and springref), and the
    # fixed tendons' (compiler/mjcf/tendon.py), for the generated ``energy`` output, and the names of
    # their parameters (k_/q0_<joint>, k_/L0_tendon_<name>), which then
    # no longer keep a model from the energy verdict (compiler/contact/tree.energy_blockers); None, ()
    spring_energy: object = field(default=None, compare=False)
    spring_parameters: tuple = field(default=(), compare=False)
    # the actuators' activation states its loads read (MJCF's act_<actuator>(t), extra states of
    # the Model): a generated ``energy`` output holds the servos' bias only, so a run is judged
    # only from a start with every activation at 0 (compiler/tree/lower.energy_text says so,
    # runtime/switching.energy_verdict reads it)
    activations: tuple = field(default=(), compare=False)

    @property
    def n(self):
        return len(self.bodies)


def tree_exprs(tree):
    """Every expression that defines ``tree`` (the generation cache's key, the checks for
    non-finite numbers), in a fixed order."""
    out = list(tree.kinematics) + list(tree.gravity)
    for b in tree.bodies:
        out += list(b.rotation) + list(b.position) + list(b.motion or ()) + [b.mass] + list(b.inertia)
        out += [c for m in b.motions for c in m] + list(b.armature)
    for load in tree.loads:
        out += list(load.moment) + list(load.force) + list(load.offset)
        out += list(getattr(load, "exprs", ()))      # a ground contact's parameters (compiler/contact)
    return [sm.sympify(e) for e in out]
