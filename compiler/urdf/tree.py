"""A URDF's links and joints as a tree of rigid bodies: fixed joints merged, checked.

URDF lists links and joints; dynamics needs bodies that move.  Links joined by
``fixed`` joints form one rigid body: their masses, centres of mass and
inertias are combined numerically (parallel-axis theorem) into the body named
after the group's first link, and joints hanging off a merged link get their
origin re-expressed in that body's frame.  With a fixed base, the root link
and everything welded to it are the ground.  Still plain numbers (numpy).

The checks here are the ones about the tree as a whole: one root, no loops, a
mass on every moving body, inertias that can exist.  Errors name the link or
joint and its line in the file.
"""
from dataclasses import dataclass, field

import numpy as np

from eomc.runtime.errors import ModelFileError

__all__ = ["Body", "TreeJoint", "Tree", "build_tree"]

MOVING = ("revolute", "continuous", "prismatic", "floating", "planar")


@dataclass
class Body:
    """A rigid body: one link, or several welded by fixed joints."""
    name: str                  # the first link of the group; its frame is the body frame
    line: int
    links: list                # every link merged into this body, the first one first
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))       # in the body frame
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about com, body frame


@dataclass
class TreeJoint:
    """A moving joint between two bodies (parent None: the world)."""
    name: str
    line: int
    type: str
    parent: str                # body name, or None for the world (ground)
    child: str                 # body name
    rotation: np.ndarray       # joint frame (= child body frame at q = 0) in the parent body frame
    position: np.ndarray       # joint frame origin in the parent body frame
    axis: np.ndarray           # unit axis in the joint frame
    mimic: tuple = None        # (joint, multiplier, offset) or None


@dataclass
class Tree:
    name: str
    path: object
    root: str                  # the root link
    bodies: dict               # name -> Body, parents before children
    joints: list               # TreeJoint, parents before children
    ground_links: list         # links welded to the world (fixed base)
    ignored: list              # notes on what was left out (e.g. massless fixed links)


def _fail(robot, line, message):
    raise ModelFileError(message, str(robot.path), line)


def _homogeneous(rotation, position):
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = rotation, position
    return transform


def _parents_and_root(robot):
    """child link -> its joint, and the one root link; loops and forests are errors."""
    parent_joint = {}
    for joint in robot.joints:
        if joint.child in parent_joint:
            other = parent_joint[joint.child]
            _fail(robot, joint.line, f"joint loop: link '{joint.child}' is the child of joint "
                                     f"'{other.name}' (line {other.line}) and of joint '{joint.name}'; "
                                     f"URDF describes trees (close loops with constraints instead)")
        if joint.child == joint.parent:
            _fail(robot, joint.line, f"joint '{joint.name}' joins link '{joint.child}' to itself")
        parent_joint[joint.child] = joint
    for start in robot.links:   # follow parents from every link: a repeat is a cycle
        seen, link = [], start
        while link in parent_joint and link not in seen:
            seen.append(link)
            link = parent_joint[link].parent
        if link in seen:
            cycle = seen[seen.index(link):]
            joint = parent_joint[cycle[0]]
            _fail(robot, joint.line, f"joint loop: the links {' -> '.join(cycle + [cycle[0]])} form a "
                                     f"cycle through their parent joints (joint '{joint.name}' is one); "
                                     f"URDF describes trees")
    roots = [name for name in robot.links if name not in parent_joint]
    if len(roots) > 1:
        lines = ", ".join(f"'{name}' (line {robot.links[name].line})" for name in roots)
        _fail(robot, robot.links[roots[1]].line,
              f"{len(roots)} links have no parent joint: {lines}; a URDF is one tree, so every link "
              f"but the root must be the child of a joint")
    return parent_joint, roots[0]


def _combine(body, items):
    """Mass, centre of mass and central inertia of (mass, com, inertia) items in one frame."""
    mass = sum(m for m, _, _ in items)
    body.mass = mass
    if mass <= 0.0:
        return
    if len(items) == 1:   # one massive link: its own numbers, without rounding through the sums
        body.com, body.inertia = items[0][1], items[0][2]
        return
    com = sum(m * c for m, c, _ in items) / mass
    inertia = np.zeros((3, 3))
    for m, c, tensor in items:
        d = c - com
        inertia += tensor + m * (d @ d * np.eye(3) - np.outer(d, d))
    body.com, body.inertia = com, 0.5 * (inertia + inertia.T)


def _check_inertia(robot, link):
    if link.mass < 0:
        _fail(robot, link.line, f"link '{link.name}' has a negative mass ({link.mass:g})")
    eig = np.linalg.eigvalsh(0.5 * (link.inertia + link.inertia.T))
    scale = max(1.0, float(np.max(np.abs(eig))))
    if eig.min() < -1e-9 * scale or 2 * eig.max() - eig.sum() > 1e-9 * scale:
        _fail(robot, link.line, f"link '{link.name}': its inertia tensor is not physically possible "
                                f"(principal moments {', '.join(f'{e:.6g}' for e in eig)}: they must "
                                f"be non-negative and obey the triangle inequality)")


def _massless(robot, body, joint):
    link = robot.links[body.name]
    welded = [name for name in body.links if name != body.name]
    also = f" (nor do the links welded to it: {', '.join(welded)})" if welded else ""
    if not any(robot.links[name].has_inertial for name in body.links):
        hint = (" -- it has only mesh geometry, and eomc does not compute mass properties from "
                "meshes" if link.meshes else "")
        _fail(robot, link.line, f"link '{link.name}' is moved by joint '{joint.name}' but has no "
                                f"<inertial>{also}{hint}; give it a <mass> and an <inertia>")
    _fail(robot, link.line, f"link '{link.name}' is moved by joint '{joint.name}' but has zero mass"
                            f"{also}; a moving link needs a positive <mass value=...>")


def build_tree(robot, floating_base=False):
    """The :class:`Tree` of ``robot`` (a reader.UrdfRobot); see the module docstring."""
    parent_joint, root = _parents_and_root(robot)
    for link in robot.links.values():
        _check_inertia(robot, link)
    children = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint)
    bodies, joints, ground, ignored = {}, [], [], []
    items = {}   # body name -> [(mass, com, inertia)] in the body frame

    def visit(link_name, body_name, transform):
        """Walk the links welded into body ``body_name`` (None: ground); ``transform``: link in body."""
        link = robot.links[link_name]
        if body_name is None:
            ground.append(link_name)
        else:
            if link_name != body_name:
                bodies[body_name].links.append(link_name)
            if link.mass > 0:
                rotation, position = transform[:3, :3], transform[:3, 3]
                items[body_name].append((link.mass, rotation @ link.com + position,
                                         rotation @ link.inertia @ rotation.T))
        for joint in children.get(link_name, ()):
            origin = transform @ joint.origin
            if joint.type == "fixed":
                visit(joint.child, body_name, origin)
                continue
            start(joint.child, TreeJoint(joint.name, joint.line, joint.type, body_name, joint.child,
                                         origin[:3, :3].copy(), origin[:3, 3].copy(), joint.axis,
                                         joint.mimic))

    def start(link_name, joint):
        bodies[link_name] = Body(link_name, robot.links[link_name].line, [link_name])
        items[link_name] = []
        joints.append(joint)
        visit(link_name, link_name, np.eye(4))

    if floating_base:
        start(root, TreeJoint(f"{root}_floating", robot.links[root].line, "floating", None, root,
                              np.eye(3), np.zeros(3), np.array([1.0, 0.0, 0.0])))
    else:
        visit(root, None, np.eye(4))
    for joint in joints:
        body = bodies[joint.child]
        _combine(body, items[body.name])
        if body.mass <= 0.0:
            _massless(robot, body, joint)
    _check_mimics(robot, joints)
    return Tree(robot.name, robot.path, root, bodies, joints, ground, ignored)


def _check_mimics(robot, joints):
    by_name = {j.name: j for j in joints}
    for joint in joints:
        if joint.mimic is None:
            continue
        target = by_name.get(joint.mimic[0])
        if target is None:
            _fail(robot, joint.line, f"joint '{joint.name}' mimics '{joint.mimic[0]}', which is not a "
                                     f"moving joint of this robot")
        if target.mimic is not None:
            _fail(robot, joint.line, f"joint '{joint.name}' mimics '{target.name}', which itself mimics "
                                     f"'{target.mimic[0]}'; chains of mimic joints are not supported")
