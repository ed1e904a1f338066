"""A URDF's links and joints as a tree of rigid bodies: fixed joints merged, checked.

URDF lists links and joints; dynamics needs bodies that move.  Links joined by
``fixed`` joints form one rigid body: their masses, centres of mass and
inertias are combined numerically (parallel-axis theorem) into the body named
after the group's first link, and joints hanging off a merged link get their
origin re-expressed in that body's frame.  With a fixed base, the root link
and everything welded to it are the ground.  Still plain numbers (numpy).

The checks here are the ones about the tree as a whole: one root, no loops,
inertias that can exist, names that stay distinct as C identifiers, something
to move.  Errors name the link or joint and its line in the file.  Real files
(example-robot-data) carry rounding and dummies that Pinocchio accepts, so
three things are warned about and repaired rather than refused (``file:line``
naming the link; several links of one kind share one warning naming each with its line):

- principal moments negative or missing the triangle inequality by a rounding
  amount (within 1e-9 of the largest moment): repaired;
- a triangle inequality missed by more on a tensor that is positive
  semi-definite, or any impossible inertia on a link welded into a body whose
  combined inertia is possible: kept as given -- the dynamics only need each
  moving body's combined inertia to be positive semi-definite, as in
  Pinocchio; a moving body whose own inertia is not is still an error;
- a moving link whose whole subtree carries no mass (a massless finger, a
  sensor frame on a joint): its joints are locked at q = 0 and it is merged
  into its parent, since nothing it could do changes the dynamics.

A moving body with a negative principal moment beyond rounding stays an error, unless
the caller opts in (``allow_nonphysical_inertia``: kept as given, one warning per link).

Everything walks the tree with explicit stacks, so depth costs no recursion
(a 1000-link chain reads in milliseconds).
"""
import warnings
from dataclasses import dataclass, field

import numpy as np

from eomc.runtime.errors import BuildNote, EomcNote, EomcWarning, GimbalLockWarning, ModelFileError

from ..multibody.joint_kinds import KINDS
from ..multibody.joints import identifier
from eomc.compiler import fixed_order as fo

__all__ = ["Body", "TreeJoint", "Tree", "build_tree", "identifier", "coordinate_suffixes", "check_mimics",
           "FLOATING_BASES", "floating_base_type", "URDF_KINDS"]

MOVING = ("revolute", "continuous", "prismatic", "floating", "planar")
ROUNDING = 1e-9          # relative to the largest principal moment

# each URDF joint type's row in the table of joint kinds (eomc.compiler.multibody.joint_kinds):
# a floating base is a free joint (body XYZ angles, or a quaternion)
URDF_KINDS = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic",
              "floating": "free", "floating_quaternion": "free", "planar": "planar"}


# --floating-base / floating_base=: how the added free joint turns.  "euler" (also True): body
# XYZ angles, 6 coordinates (singular at pitch +-90 deg); "quaternion": a unit quaternion
# (w, x, y, z), 7 coordinates, no singularity (the integrators keep it unit).  Both have the
# same 6 speeds (the joint origin's velocity and the angular velocity, body components).
FLOATING_BASES = ("euler", "quaternion")


def floating_base_type(floating_base):
    """The TreeJoint type of the free joint ``floating_base`` asks for (None: a fixed base):
    False/None -> None, True/"euler" -> "floating", "quaternion" -> "floating_quaternion";
    anything else a ValueError naming the choices."""
    if floating_base is None or floating_base is False:
        return None
    if floating_base is True or floating_base == "euler":
        return "floating"
    if floating_base == "quaternion":
        return "floating_quaternion"
    from eomc.runtime.errors import ModelError
    raise ModelError(f"floating_base={floating_base!r}: choose False, True (= 'euler': body XYZ angles) "
                     f"or 'quaternion'")


def coordinate_suffixes(kind):
    """(coordinate suffixes, speed suffixes) of a URDF joint type (the table's row); ((""), (""))
    for a 1-dof joint (and a fixed one, whose names are checked as if it moved)."""
    if kind not in URDF_KINDS:
        return ("",), ("",)
    return KINDS[URDF_KINDS[kind]].suffixes(kind == "floating_quaternion")


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
    limit: tuple = None        # the URDF's <limit> (lower, upper), None where absent
    dynamics: tuple = (0.0, 0.0)   # the URDF's <dynamics> (damping, friction)


@dataclass
class Tree:
    name: str
    path: object
    root: str                  # the root link
    bodies: dict               # name -> Body, parents before children
    joints: list               # TreeJoint, parents before children
    ground_links: list         # links welded to the world (fixed base)
    ignored: list              # notes on what was left out or repaired (each also warned about)
    locked: list = field(default_factory=list)   # joints locked at 0 (massless subtrees)
    # the reading it was built from (eomc.compiler.urdf.reader.UrdfRobot, with its parsed
    # document): what later steps need of the file (welded links, visuals) without reading it again
    robot: object = field(default=None, repr=False, compare=False)
    # the hinge triples' gimbal locks in reach (_check_gimbal_locks): {"joints": [P, J, K], "state":
    # q_J, "angle": J's angle there}, for the run's check that it did not pass one (runtime/diagnose.py)
    gimbal_locks: list = field(default_factory=list)


def _fail(robot, line, message):
    raise ModelFileError(message, str(robot.path), line)


def _warn(robot, line, message, notes, category=EomcWarning):
    where = f"{robot.path}:{line}: " if line else f"{robot.path}: "
    notes.append(message)
    warnings.warn(where + message, category, stacklevel=4)


def _parents_and_root(robot):
    """child link -> its joint, and the one root link; loops and forests are errors."""
    if not robot.links:
        _fail(robot, robot.line, f"robot '{robot.name}' has no <link>: nothing to build")
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
    done = set()             # links known to reach a root: each link is walked once (O(n))
    for start in robot.links:   # follow parents from every link: a repeat is a cycle
        seen, order, link = set(), [], start
        while link in parent_joint and link not in seen and link not in done:
            seen.add(link)
            order.append(link)
            link = parent_joint[link].parent
        if link in seen:
            cycle = order[order.index(link):]
            joint = parent_joint[cycle[0]]
            _fail(robot, joint.line, f"joint loop: the links {' -> '.join(cycle + [cycle[0]])} form a "
                                     f"cycle through their parent joints (joint '{joint.name}' is one); "
                                     f"URDF describes trees")
        done.update(order)
    roots = [name for name in robot.links if name not in parent_joint]
    if len(roots) > 1:
        lines = ", ".join(f"'{name}' (line {robot.links[name].line})" for name in roots[:5])
        more = f" and {len(roots) - 5} more" if len(roots) > 5 else ""
        _fail(robot, robot.links[roots[1]].line,
              f"{len(roots)} links have no parent joint: {lines}{more}; a URDF is one tree, so every "
              f"link but the root must be the child of a joint")
    return parent_joint, roots[0]


def _combine(body, items):
    """Mass, centre of mass and central inertia of (mass, com, inertia) items in one frame.

    An item of zero mass may still carry rotational inertia (Bolt's feet: mass 0, inertia
    5.7e-7): it adds its tensor and nothing else, as in Pinocchio.  A body of zero mass
    keeps its link origin as its centre."""
    mass = sum(m for m, _, _ in items)
    body.mass = mass
    massive = [item for item in items if item[0] > 0]
    if len(items) == 1 and massive:   # one massive link: its own numbers, without rounding through the sums
        body.com, body.inertia = items[0][1], items[0][2]
        return
    com = sum(m * c for m, c, _ in massive) / mass if mass > 0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, tensor in items:
        d = c - com
        inertia += tensor + m * (fo.dot(d, d) * np.eye(3) - np.outer(d, d))
    body.com, body.inertia = com, 0.5 * (inertia + inertia.T)


def _has_inertia(link):
    return link.mass > 0 or bool(np.any(link.inertia != 0))


def _moments(tensor):
    """(principal moments, their rotation, scale): scale the largest |moment| (0: none).

    Raises FloatingPointError when the tensor is too large for double precision."""
    with np.errstate(all="raise"):
        sym = 0.5 * (tensor + tensor.T)
        eig, vec = fo.eigh(sym)
    if not np.all(np.isfinite(eig)):
        raise FloatingPointError
    return eig, vec, float(np.max(np.abs(eig))) if eig.size else 0.0


def _describe(eig):
    """Principal moments for a message; those at rounding level (1e-12 of the largest) read 0,
    their sign and digits being noise."""
    scale = float(np.max(np.abs(eig))) if len(eig) else 0.0
    return ", ".join(f"{(e if abs(e) > 1e-12 * scale else 0.0):.6g}" for e in eig)


def _warn_repairs(robot, repairs, notes):
    """The rounding-level inertia repairs: one link keeps its sentence at its line; several
    share one warning naming each with its line (icub.urdf: seven links with moments like
    -1.4e-20 printed seven lines of noise)."""
    if len(repairs) == 1:
        link, eig, fixed = repairs[0]
        _warn(robot, link.line, f"link '{link.name}': principal moments {_describe(eig)} repaired "
                                f"to {_describe(fixed)} (a rounding-level violation)", notes)
    elif repairs:
        each = "; ".join(f"'{link.name}' (line {link.line}): {_describe(eig)} -> {_describe(fixed)}"
                         for link, eig, fixed in repairs)
        _warn(robot, robot.line, f"{len(repairs)} links' principal moments miss a physical inertia by a "
                                 f"rounding-level amount and were repaired: {each}", notes)


def _link_inertia(robot, link, repairs):
    """Check one link's inertia: 'ok', 'impossible' (beyond rounding; the caller decides),
    repairing rounding-level misses in place (listed in ``repairs`` for one warning)."""
    if link.mass < 0:
        _fail(robot, link.line, f"link '{link.name}' has a negative mass ({link.mass:g})")
    try:
        eig, vec, scale = _moments(link.inertia)
    except (FloatingPointError, np.linalg.LinAlgError):
        _fail(robot, link.line, f"link '{link.name}': its inertia tensor is too large to handle in "
                                f"double precision (entries up to {np.max(np.abs(link.inertia)):.3g})")
    if scale == 0.0:
        return "ok"
    # rounding is judged against the larger of the largest moment and the link's mass
    # moment about its own origin (a point mass off the origin: 1e-20 entries are noise)
    tol = ROUNDING * max(scale, link.mass * fo.dot(link.com, link.com))
    miss = 2 * eig.max() - eig.sum()
    if eig.min() >= 0 and miss <= 0:
        return "ok"
    if eig.min() >= -tol and miss <= tol:          # rounding: repair, say so
        fixed = np.maximum(eig, 0.0)
        deficit = 2 * fixed.max() - fixed.sum()
        if deficit > 0:                            # raise the two smaller moments to close it
            order = np.argsort(fixed)
            fixed[order[:2]] += deficit / 2
        link.inertia = fo.matmul(vec, np.diag(fixed), vec.T)
        repairs.append((link, eig, fixed))        # said by _warn_repairs, all in one warning
        return "ok"
    return "negative" if eig.min() < -tol else "triangle"


def _check_body(robot, body, joint, verdicts, notes, kept, allow_nonphysical=False):
    """A moving body's combined inertia must be positive semi-definite; links whose own
    tensors are impossible are accepted (with a warning) when the combination is possible.
    ``allow_nonphysical`` (the user's opt-in, ``allow_nonphysical_inertia``): a negative
    principal moment beyond rounding is kept as given too, with a warning naming the link
    (Pinocchio loads such files; the mass matrix may then be indefinite)."""
    bad = [name for name in body.links if verdicts.get(name, "ok") != "ok"]
    if not bad:
        return
    try:
        eig, _, scale = _moments(body.inertia)
    except (FloatingPointError, np.linalg.LinAlgError):
        eig, scale = np.array([-np.inf]), 1.0
    tol = ROUNDING * max(scale, 1e-300)
    for name in bad:
        link = robot.links[name]
        leig = _moments(link.inertia)[0]
        if verdicts[name] == "negative" and (eig.min() < -tol or len(body.links) == 1):
            if allow_nonphysical:
                whole = (f"; the body '{body.name}' it is welded into: {_describe(eig)}"
                         if len(body.links) > 1 else "")
                _warn(robot, link.line, f"link '{name}' (moved by joint '{joint.name}'): its inertia "
                                        f"tensor is not physically possible (principal moments "
                                        f"{_describe(leig)}{whole}); kept as given "
                                        f"(allow_nonphysical_inertia): the mass matrix may be indefinite",
                      notes)
                continue
            _fail(robot, link.line, f"link '{name}': its inertia tensor is not physically possible "
                                    f"(principal moments {_describe(leig)}: they must be non-negative "
                                    f"and obey the triangle inequality; a negative one beyond rounding "
                                    f"can make the mass matrix indefinite; allow_nonphysical_inertia=True / "
                                    f"--allow-nonphysical-inertia builds it anyway, as Pinocchio does)")
        own = verdicts[name] == "triangle" and len(body.links) == 1
        kept.append((link, leig, verdicts[name], None if own else (body.name, joint.name)))


def _warn_kept(robot, kept, notes):
    """The impossible link tensors kept as given (a triangle miss on a body of its own, or any
    miss welded into a possible body), in one BuildNote line: which links, that nothing needs
    doing, and where the details are.  Why short: it reads as a problem to solve, and Allegro's,
    HyQ's and ANYmal's took 600-840 characters (first hour s26).  The details -- each link's
    line, principal moments, the miss and the body it is welded into -- are the note's
    ``details`` (one line a link), which ``eomc inspect`` prints."""
    if not kept:
        return
    def detail(link, leig, verdict, into):
        m = np.sort(np.asarray(leig, dtype=float))
        miss = (f"a negative moment {m[0]:.3g}" if verdict == "negative" and m[0] < 0
                else f"{m[0]:.3g} + {m[1]:.3g} < {m[2]:.3g}")
        return (f"link '{link.name}' (line {link.line}): principal moments {_describe(leig)} ({miss})"
                + ("" if into is None or into[0] == link.name else
                   f", welded into body '{into[0]}' (moved by joint '{into[1]}')"))
    triangle = all(verdict == "triangle" for _, _, verdict, _ in kept)
    names = [link.name for link, _, _, _ in kept]
    which = (f"link '{names[0]}': its inertia tensor" if len(kept) == 1 else
             f"{len(kept)} links' inertia tensors ({', '.join(names[:4])}{', ...' if len(names) > 4 else ''})")
    message = (f"{which} {'miss' if len(kept) > 1 else 'misses'} the triangle inequality" if triangle
               else f"{which} {'are' if len(kept) > 1 else 'is'} not physically possible")
    message += ("; kept as given, as Pinocchio does (the dynamics need only each moving body's moments to be "
                "non-negative, and they are): nothing to do; eomc inspect gives the moments")
    line = kept[0][0].line if len(kept) == 1 else robot.line
    notes.append(message)
    note = BuildNote(f"{robot.path}:{line}: {message}" if line else f"{robot.path}: {message}")
    note.details = tuple(detail(*k) for k in kept)
    warnings.warn(note, stacklevel=3)


def _check_names(robot, joints, bodies):
    """Joint and link names must stay distinct as C identifiers (q_<joint>, m_<link>, ...)."""
    taken = {}
    for joint in joints:
        coords, speeds = coordinate_suffixes(joint.type)
        ident = identifier(joint.name)
        for prefix, suffixes in (("q", coords), ("u", speeds)):
            for suffix in suffixes:
                name = f"{prefix}_{ident}" + (f"_{suffix}" if suffix else "")
                other = taken.get(name)
                if other is not None and other is not joint:
                    _fail(robot, joint.line, f"joint '{joint.name}' and joint '{other.name}' (line "
                                             f"{other.line}) both give the C name {name}; rename one "
                                             f"(names become C identifiers: characters other than "
                                             f"letters, digits and _ turn into _)")
                taken[name] = joint
    seen = {}
    for body in bodies.values():
        ident = identifier(body.name)
        if ident in seen:
            other = seen[ident]
            _fail(robot, body.line, f"link '{body.name}' and link '{other.name}' (line {other.line}) "
                                    f"both give the C name {ident} (parameters m_{ident}, ...); rename "
                                    f"one")
        seen[ident] = body


def _carries_mass(robot, children, root):
    """link -> whether it or any link below it (through any joint) has mass or inertia; no recursion."""
    order, stack = [], [root]
    while stack:
        link = stack.pop()
        order.append(link)
        stack.extend(j.child for j in children.get(link, ()))
    carries = {}
    for link in reversed(order):
        carries[link] = _has_inertia(robot.links[link]) or any(carries[j.child] for j in children.get(link, ()))
    return carries


def _subtree(children, link):
    out, stack = [], [link]
    while stack:
        name = stack.pop()
        out.append(name)
        stack.extend(j.child for j in children.get(name, ()))
    return out


def build_tree(robot, floating_base=False, allow_nonphysical_inertia=False):
    """The :class:`Tree` of ``robot`` (a reader.UrdfRobot); see the module docstring.
    ``allow_nonphysical_inertia``: keep moving bodies whose principal moments are negative
    beyond rounding, with a warning per link, instead of refusing the file."""
    parent_joint, root = _parents_and_root(robot)
    notes, locked = [], []
    repairs = []
    verdicts = {name: _link_inertia(robot, link, repairs) for name, link in robot.links.items()}
    _warn_repairs(robot, repairs, notes)
    children = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint)
    carries = _carries_mass(robot, children, root)
    bodies, joints, ground, merged = {}, [], [], []
    items = {}   # body name -> [(mass, com, inertia)] in the body frame
    owner = {}   # body name -> the TreeJoint that moves it

    def start(link_name, joint):
        bodies[link_name] = Body(link_name, robot.links[link_name].line, [link_name])
        items[link_name] = []
        joints.append(joint)
        owner[link_name] = joint

    # an explicit stack of work items, popped in the order the recursive walk visited them
    # (depth first, joints in file order): ("visit", link, body it is welded into (None:
    # ground), link frame in that body) or ("start", TreeJoint): a moving joint's new body
    stack = []
    free_type = floating_base_type(floating_base)
    if free_type:
        if not carries[root]:
            _fail(robot, robot.links[root].line, f"--floating-base: the robot has no mass at all "
                                                 f"(root link '{root}' and everything on it)")
        stack.append(("start", TreeJoint(f"{root}_floating", robot.links[root].line, free_type, None,
                                         root, np.eye(3), np.zeros(3), np.array([1.0, 0.0, 0.0]))))
    else:
        stack.append(("visit", root, None, np.eye(4)))
    while stack:
        item = stack.pop()
        if item[0] == "start":
            joint = item[1]
            start(joint.child, joint)
            stack.append(("visit", joint.child, joint.child, np.eye(4)))
            continue
        _, link_name, body_name, transform = item
        link = robot.links[link_name]
        if body_name is None:
            ground.append(link_name)
        else:
            if link_name != body_name:
                bodies[body_name].links.append(link_name)
            if _has_inertia(link):
                rotation, position = transform[:3, :3], transform[:3, 3]
                items[body_name].append((link.mass, fo.matmul(rotation, link.com) + position,
                                         fo.matmul(rotation, link.inertia, rotation.T)))
        pending = []
        for joint in children.get(link_name, ()):
            origin = fo.matmul(transform, joint.origin)
            if joint.type in MOVING and not carries[joint.child]:
                _lock(robot, joint, children, body_name if body_name else link_name, locked, merged)
            if joint.type == "fixed" or not carries[joint.child]:
                pending.append(("visit", joint.child, body_name, origin))
                continue
            pending.append(("start", TreeJoint(joint.name, joint.line, joint.type, body_name, joint.child,
                                               origin[:3, :3].copy(), origin[:3, 3].copy(), joint.axis,
                                               joint.mimic, joint.limit, joint.dynamics)))
        stack.extend(reversed(pending))      # the first joint's subtree first, as recursion did
    _warn_merged(robot, merged, notes)
    if not joints:
        _fail(robot, robot.line, f"robot '{robot.name}' has no moving joint (only fixed joints"
                                 f"{' and massless links' if locked else ''}): a model without states; "
                                 f"give it a moving joint, or use --floating-base / floating_base=True "
                                 f"to let the whole robot move")
    _order_parents_first(joints)
    bodies = {j.child: bodies[j.child] for j in joints}
    kept = []
    for joint in joints:
        body = bodies[joint.child]
        _combine(body, items[body.name])
        _check_body(robot, body, joint, verdicts, notes, kept, allow_nonphysical_inertia)
    _warn_kept(robot, kept, notes)
    grounded = [robot.links[name] for name in ground if verdicts.get(name, "ok") != "ok"]
    if len(grounded) == 1:   # welded to the world: they move nothing, so only note it, shortly
        link = grounded[0]
        _warn(robot, link.line, f"link '{link.name}': its inertia tensor is not physically possible "
                                f"(principal moments {_describe(_moments(link.inertia)[0])}); ignored: it is "
                                f"welded to the ground", notes, EomcNote)
    elif grounded:
        each = ", ".join(f"link '{link.name}' (line {link.line})" for link in grounded)
        _warn(robot, robot.line, f"{len(grounded)} links welded to the ground have inertia tensors that are not "
                                 f"physically possible; ignored (they move nothing): {each}", notes, EomcNote)
    _check_names(robot, joints, bodies)
    tree = Tree(robot.name, robot.path, root, bodies, joints, ground, notes, locked, robot)
    _check_resisted(robot, tree)
    _check_gimbal_locks(robot, tree, notes)
    return tree


def _order_parents_first(joints):
    """The depth-first walk already lists parents first; assert it cheaply."""
    seen = {None}
    for joint in joints:
        assert joint.parent in seen, joint.name
        seen.add(joint.child)


def _lock(robot, joint, children, into, locked, merged):
    """A moving joint whose subtree carries no mass: lock it (and everything below) at 0."""
    if joint.name in locked:      # below one locked already
        return
    below = _subtree(children, joint.child)
    moving = [j.name for link in below for j in children.get(link, ()) if j.type in MOVING]
    locked += [joint.name] + moving
    others = f", nor do the {len(below) - 1} link(s) below it" if len(below) > 1 else ""
    joints = f"; joints {', '.join([joint.name] + moving)} locked at 0" if moving else ""
    link = robot.links[joint.child]
    mesh = " (it has only mesh geometry: eomc does not compute mass from meshes)" if (
        link.meshes and not link.has_inertial) else ""
    merged.append((link.line, f"link '{joint.child}' (moved by joint '{joint.name}', line {joint.line})"
                             f" carries no mass{mesh}{others}: merged into '{into}'", joints))


def _warn_merged(robot, merged, notes):
    """The massless moving subtrees merged into their parents: one keeps its sentence at its
    line; several share one warning naming each (romeo.urdf: eight finger chains, eight lines)."""
    if len(merged) == 1:
        line, what, joints = merged[0]
        _warn(robot, line, f"{what} as if welded{joints}; it cannot change the dynamics", notes)
    elif merged:
        each = "; ".join(what + (f" ({joints[2:]})" if joints else "") for _, what, joints in merged)
        _warn(robot, robot.line, f"{len(merged)} moving links carry no mass and cannot change the dynamics: each "
                                 f"is merged into its parent as if welded, its joints locked at 0: {each}", notes)


def _check_resisted(robot, tree):
    """Every speed must move some mass: a joint whose subtree has no inertia along its motion
    (a point mass on its own axis, a massless link carrying only a massless chain) would give a
    singular mass matrix.  Numerically at q = 0: the subtree's composite inertia about the
    joint (Featherstone's CRBA, one backward pass)."""
    index = {j.child: k for k, j in enumerate(tree.joints)}
    n = len(tree.joints)
    composite = [None] * n
    placement = []          # (E: parent->child components, r: child origin in parent) at q = 0
    for joint in tree.joints:
        body = tree.bodies[joint.child]
        I6 = np.zeros((6, 6))
        c = body.com
        cx = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
        I6[:3, :3] = body.inertia + body.mass * fo.matmul(cx, cx.T)
        I6[:3, 3:] = body.mass * cx
        I6[3:, :3] = body.mass * cx.T
        I6[3:, 3:] = body.mass * np.eye(3)
        composite[index[joint.child]] = I6
        placement.append((joint.rotation.T, joint.position))
    for k in range(n - 1, -1, -1):
        joint = tree.joints[k]
        if joint.parent is None:
            continue
        E, r = placement[k]
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        X = np.zeros((6, 6))           # motion transform parent -> child (about the link origins)
        X[:3, :3], X[3:, 3:], X[3:, :3] = E, E, -fo.matmul(E, rx)
        p = index[joint.parent]
        composite[p] = composite[p] + fo.matmul(X.T, composite[k], X)
    for k, joint in enumerate(tree.joints):
        S = _motion(joint)
        D = fo.matmul(S.T, composite[k], S)
        scale = max(np.max(np.abs(composite[k])), 1e-300)
        if fo.eigvalsh(0.5 * (D + D.T)).min() <= 1e-12 * scale:
            _fail(robot, joint.line, f"joint '{joint.name}' moves no inertia along its motion: link "
                                     f"'{joint.child}' and what it carries have no mass or inertia "
                                     f"that resists it (a mass on the axis it turns about?); its "
                                     f"acceleration would be undefined")


GIMBAL_MARGIN = 0.1      # rad: how far past a limit a hit may go (human.urdf: up to 0.07)
GIMBAL_REMEDY = 0.15     # rad: how far inside the gimbal lock the suggested limit goes


def _gimbal_angles(p, j, k):
    """The angles θ (in (-π, π]) where R(j, θ) k is parallel to p (unit vectors; j the middle
    joint's axis, p the outer axes in its frame at θ = 0); () where the axes never line up."""
    out = []
    a = float(np.dot(j, k))
    for sign in (1.0, -1.0):
        target = sign * np.asarray(p, dtype=float)
        if abs(a - float(np.dot(j, target))) > 1e-9:
            continue
        kp, tp = k - a * j, target - a * j
        if np.linalg.norm(kp) < 1e-9:          # k along j: lined up always, or never
            continue
        out.append(float(np.arctan2(np.dot(j, np.cross(kp, tp)), np.dot(kp, tp))))
    return tuple(out)


def _rotation_only(body, point_tol=1e-12):
    """True when ``body`` has no inertia about its own frame's origin (no mass, or a point
    mass there): turning it about any axis through that origin moves nothing."""
    c = body.com
    inertia = body.inertia + body.mass * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    return float(np.max(np.abs(inertia))) <= point_tol


def _check_gimbal_locks(robot, tree, notes):
    """Three hinges P -> J -> K whose axes meet in one point, with no inertia between them
    (massless links, as URDF writes a ball joint: human.urdf's hips and shoulders), are Euler
    angles of one rotation: where J's angle turns K's axis onto P's, the two line up and their
    opposite motion moves nothing, so the mass matrix is singular there (gimbal lock) and a run
    that reaches it stops.  A soft limit lets a joint a little past it, so a lock within
    GIMBAL_MARGIN of J's range is in reach.  One warning for all such triples, with the
    ``--param`` limits that keep a run GIMBAL_REMEDY away (a narrower range than the file's)."""
    hinge = ("revolute", "continuous")
    by_child = {j.child: j for j in tree.joints}
    found = []
    for J in tree.joints:
        P = by_child.get(J.parent)
        if (J.type not in hinge or P is None or P.type not in hinge or J.mimic or P.mimic
                or np.linalg.norm(J.position) > 1e-12
                or not _rotation_only(tree.bodies[J.parent]) or not _rotation_only(tree.bodies[J.child])):
            continue
        p = fo.matmul(J.rotation.T, np.asarray(P.axis, dtype=float))
        j = np.asarray(J.axis, dtype=float)
        for K in tree.joints:
            if K.parent != J.child or K.type not in hinge or K.mimic or np.linalg.norm(K.position) > 1e-12:
                continue
            k = fo.matmul(K.rotation, np.asarray(K.axis, dtype=float))
            lo, hi = J.limit if (J.type == "revolute" and J.limit is not None) else (-np.inf, np.inf)
            for base in _gimbal_angles(p, j / np.linalg.norm(j), k / np.linalg.norm(k)):
                for theta in (base - 2 * np.pi, base, base + 2 * np.pi):
                    if lo - GIMBAL_MARGIN <= theta <= hi + GIMBAL_MARGIN:
                        found.append((P, J, K, theta, lo, hi))
    if not found:
        return
    tree.gimbal_locks = [{"joints": [P.name, J.name, K.name], "state": f"q_{identifier(J.name)}",
                          "angle": float(theta)} for P, J, K, theta, _, _ in found]
    parts, remedy, seen = [], [], set()
    for P, J, K, theta, lo, hi in found:
        if abs(theta - hi) <= GIMBAL_MARGIN:
            where = f"its upper limit {hi:.6g}"
        elif abs(theta - lo) <= GIMBAL_MARGIN:
            where = f"its lower limit {lo:.6g}"
        elif np.isfinite(lo):
            where = f"inside its range [{lo:.6g}, {hi:.6g}]"
        else:
            where = "a continuous joint: no limit keeps it away"
        parts.append(f"{P.name}, {J.name}, {K.name} at q_{identifier(J.name)} = {theta:.6g} ({where})")
        if np.isfinite(lo) and (J.name, theta) not in seen:
            seen.add((J.name, theta))
            side, value = ("hi", theta - GIMBAL_REMEDY) if theta > 0 else ("lo", theta + GIMBAL_REMEDY)
            remedy.append(f"limit_{side}_{identifier(J.name)}={value:.4g}")
    fix = (f"; to keep a run clear of them, narrow the file's ranges: --param {' '.join(remedy)}"
           if remedy else "")
    _warn(robot, robot.line, f"{len(found)} hinge triple{'s' if len(found) > 1 else ''} with axes through one "
                             f"point and no inertia between them (Euler angles of one rotation) "
                             f"{'reach their' if len(found) > 1 else 'reaches its'} gimbal lock: {'; '.join(parts)}. There the first and last axes line up, nothing "
                             f"resists their opposite motion (the mass matrix is singular): a run that gets "
                             f"there stops, or steps across it with a warning{fix}", notes, GimbalLockWarning)


def _motion(joint):
    """6xk motion subspace about the child link origin, child components, at q = 0."""
    a = np.asarray(joint.axis, dtype=float)
    if joint.type in ("revolute", "continuous"):
        return np.concatenate([a, np.zeros(3)])[:, None]
    if joint.type == "prismatic":
        return np.concatenate([np.zeros(3), a])[:, None]
    if joint.type in ("floating", "floating_quaternion"):
        return np.eye(6)
    # planar: two slides in the plane normal to the axis, a turn about it
    z = a
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - fo.dot(helper, z) * z
    x /= fo.norm(x)
    y = np.cross(z, x)
    S = np.zeros((6, 3))
    S[3:, 0], S[3:, 1], S[:3, 2] = x, y, z
    return S


def check_mimics(robot, joints):
    """Mimic tags, when they are used (``mimic=True``): a target that moves, no chains, a
    multiplier that is not zero.  (Ignored tags are not checked, as Pinocchio ignores them.)"""
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
        if joint.mimic[1] == 0:
            _fail(robot, joint.line, f"joint '{joint.name}' mimics '{target.name}' with multiplier 0: "
                                     f"it would stay at its offset {joint.mimic[2]:g}; make it a fixed "
                                     f"joint instead")
