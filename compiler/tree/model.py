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

Everything here is a SymPy expression in the mechanics objects (q(t), u(t),
parameters, inputs); the lowering renames them to C slots.  A tree says nothing
of *how* it was found (SymPy joints or hand-built frames, see
:mod:`.recognize`); the algorithms in :mod:`.algorithms` read only this.
"""
from dataclasses import dataclass

import sympy as sm

__all__ = ["TreeBody", "Load", "Tree", "NotATree"]


class NotATree(ValueError):
    """The system is not a tree the recursion can take; the message names the joint or body."""


@dataclass(frozen=True)
class TreeBody:
    name: str
    joint: str                   # the joint's name (for messages)
    kind: str                    # "revolute", "prismatic" or "fixed"
    parent: int                  # index of the parent body, -1 for the ground
    speed: object                # index into Tree.speeds, or None (fixed joint)
    rotation: sm.Matrix          # 3x3, E(q_k)
    position: sm.Matrix          # 3x1, r(q_k)
    motion: tuple                # 6 constants (S), or None
    mass: object
    inertia: sm.Matrix           # 3x3 about the mass centre, body-frame components


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

    @property
    def n(self):
        return len(self.bodies)
