"""One table of joint kinds: per kind its coordinates, speeds, E(q), r(q), S and q' = N(q) u.

Why one table: a URDF revolute joint and an MJCF hinge are the same mobilizer, as are a URDF
floating base and an MJCF free joint; the readers must write them identically (the
generated C of a URDF robot and of its MJCF twin agree, and a third format should only
have to say which kind each of its joints is).  A reader names the kind (:data:`KINDS`) and
hands over the joint's site in its parent body -- R0 the joint frame's rotation, a its axis,
``base`` = p - c_p (the joint origin from the parent's mass centre), c the child's mass
centre, ``anchor`` s the point the joint turns about in the child frame (MJCF's
``jnt_pos``; None: the child frame's origin, URDF) -- and gets a :class:`Mobilizer` back: the
child body's rotation R_PC and origin r (mass centre, parent components), its motion
subspace S (one 6-vector, or k of them), q' per coordinate, and the joint's translation
(``shift``; the link origin from the parent's is p + shift).  (E = R_PCᵀ.)

- revolute: R_PC = R0 Rot(a, q - ref); r = base + R0 s + R_PC (c - s); S = (a, a × (c - s))
- prismatic: R_PC = R0; r = base + R0 (a (q - ref) + c); S = (0, a)
- ball: R_PC = R0 Rx Ry Rz (body XYZ angles) or R0 R(w, x, y, z) (quaternion); r as
  revolute; speeds the body-frame angular velocity
- free: R_PC = R0 Rf (Rf as ball; R0 omitted: MuJoCo's free joint, placed in the world);
  r = base + R0 (x, y, z) + R_PC c; speeds the child origin's velocity and the angular
  velocity in child components (Pinocchio's free-flyer)
- planar: in the frame A = R0 Z (Z turns z onto a): R_PC = A Rz(th) Zᵀ,
  r = base + A (x, y, 0) + R_PC c; speeds as Pinocchio's planar joint
- fixed: R_PC = R0; r = base + R0 c (a welded body)

The 3x3 and 3-vector algebra on numbers and symbols is :mod:`.joints`' (snap, lin, times,
cross, rotation_terms, z_to).
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm

from .joints import cross, lin, rotation_terms, snap, snapped, times, vec, z_to
from eomc.compiler import fixed_order as fo

__all__ = ["KINDS", "JointKind", "JointSite", "Mobilizer", "floating_rotation", "floating_kinematics",
           "quaternion_rotation", "quaternion_kinematics", "free_joint"]

_UNIT = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]


def floating_rotation(rx, ry, rz):
    """R = Rx Ry Rz (child components -> parent components) of body-fixed XYZ angles,
    entry for entry as SymPy's ``orient_body_fixed(..., 'xyz')`` gives ``parent.dcm(child)``."""
    cx, sx, cy, sy, cz, sz = sm.cos(rx), sm.sin(rx), sm.cos(ry), sm.sin(ry), sm.cos(rz), sm.sin(rz)
    Rx = sm.Matrix([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = sm.Matrix([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = sm.Matrix([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx * Ry * Rz


def floating_kinematics(q, u):
    """q' of a floating joint (as :class:`eomc.compiler.urdf.joints.FloatingJoint`): position' = R v,
    and the body-XYZ Euler rates of the body-frame angular velocity in closed form."""
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


@dataclass(frozen=True)
class JointSite:
    """Where a joint sits in its parent body, in numbers (``R0`` snapped, ``axis`` as read: numpy) and
    symbols (``base``, ``com``, ``anchor``: 3-lists), see the module docstring."""
    R0: object
    axis: object
    base: list
    com: list
    anchor: list = None          # None: the child frame's origin
    ref: float = 0.0             # the coordinate's value at the zero pose (MJCF's qpos0)
    quaternion: bool = False     # ball/free: a quaternion (w, x, y, z) instead of body XYZ angles
    placed: bool = True          # free: False for a joint placed in the world (no R0, no base)


@dataclass(frozen=True)
class Mobilizer:
    """A joint kind's answer for one joint: the child body's placement and motion."""
    kind: str                    # TreeBody.kind
    rotation: sm.Matrix          # E = R_PCᵀ
    position: sm.Matrix          # r
    motions: tuple               # S: one 6-tuple per speed
    kinematics: list             # q' per coordinate
    shift: list = None           # the joint's translation in parent components (None: none)
    w: object = None             # a quaternion's w coordinate

    def body(self, first, **common):
        """The TreeBody (``first``: its first speed's index; ``common``: name, joint, parent,
        mass, inertia, armature)."""
        from eomc.compiler.tree.model import TreeBody
        if len(self.motions) == 1:
            return TreeBody(kind=self.kind, speed=first, rotation=self.rotation, position=self.position,
                            motion=self.motions[0], **common)
        if not self.motions:
            return TreeBody(kind=self.kind, speed=None, rotation=self.rotation, position=self.position,
                            motion=None, **common)
        return TreeBody(kind=self.kind, speed=None, rotation=self.rotation, position=self.position, motion=None,
                        speeds=tuple(range(first, first + len(self.motions))), motions=self.motions, **common)


def _turned(R, c):
    """R c, terms with a zero c_k left out."""
    return [sum((R[r, k] * c[k] for k in range(3) if c[k] != 0), sm.S.Zero) for r in range(3)]


def _after(R0, Rj):
    """R0 Rj of a numeric R0 (snapped, zeros skipped) and a symbolic Rj."""
    return sm.Matrix(3, 3, lambda r, k: sum((snap(R0[r, m]) * Rj[m, k] for m in range(3)
                                             if snap(R0[r, m]) != 0), sm.S.Zero))


def _offset(value, ref):
    return value - snap(ref) if ref != 0 else value


def revolute(site, qs, us):
    a = snapped(site.axis)
    A, B, C = rotation_terms(site.R0, a)
    angle = _offset(qs[0], site.ref)
    cq, sq = sm.cos(angle), sm.sin(angle)
    R = sm.Matrix(3, 3, lambda r, k: lin((A[r, k], B[r, k], C[r, k]), (cq, sq, 1)))
    av = vec(a)
    if site.anchor is None:
        Rc = _turned(R, site.com)
        position = sm.Matrix([site.base[r] + Rc[r] for r in range(3)])
        return Mobilizer("revolute", R.T, position, (tuple(av) + tuple(cross(av, site.com)),), [us[0]])
    c_s = [site.com[r] - site.anchor[r] for r in range(3)]
    R0s = times(site.R0, site.anchor)
    Rc = _turned(R, c_s)
    position = sm.Matrix([site.base[r] + R0s[r] + Rc[r] for r in range(3)])
    return Mobilizer("revolute", R.T, position, (tuple(av) + tuple(cross(av, c_s)),), [us[0]])


def prismatic(site, qs, us):
    a = snapped(site.axis)
    shift = _offset(qs[0], site.ref)
    R0a = times(site.R0, [a[k] * shift for k in range(3)])
    R0c = times(site.R0, site.com)
    position = sm.Matrix([site.base[r] + R0c[r] + R0a[r] for r in range(3)])
    return Mobilizer("prismatic", sm.Matrix(site.R0.T).applyfunc(snap), position,
                     ((0, 0, 0) + tuple(vec(a)),), [us[0]], shift=R0a)


def ball(site, qs, us):
    quaternion = site.quaternion
    Rb = quaternion_rotation(*qs) if quaternion else floating_rotation(*qs)
    R = _after(site.R0, Rb)
    anchor = site.anchor if site.anchor is not None else [0, 0, 0]
    c_s = [site.com[r] - anchor[r] for r in range(3)]
    R0s = times(site.R0, anchor)
    Rc = _turned(R, c_s)
    position = sm.Matrix([site.base[r] + R0s[r] + Rc[r] for r in range(3)])
    motions = tuple(tuple(e_) + tuple(cross(list(e_), c_s)) for e_ in _UNIT)
    qdot = (quaternion_kinematics if quaternion else floating_kinematics)([0, 0, 0] + list(qs),
                                                                           [0, 0, 0] + list(us))[3:]
    return Mobilizer("3-speed", R.T, position, motions, qdot, w=qs[0] if quaternion else None)


def free(site, qs, us):
    Rf, qdot = free_joint(qs, us, site.quaternion)
    c = site.com
    motions = tuple((0, 0, 0) + e_ for e_ in _UNIT) + tuple(tuple(e_) + tuple(cross(list(e_), c)) for e_ in _UNIT)
    w = qs[3] if site.quaternion else None
    if not site.placed:
        Rc = _turned(Rf, c)
        position = sm.Matrix([qs[r] + Rc[r] for r in range(3)])
        return Mobilizer("free", Rf.T, position, motions, qdot, w=w)
    R = _after(site.R0, Rf)
    xyz = times(site.R0, qs[:3])
    Rc = _turned(R, c)
    position = sm.Matrix([site.base[r] + xyz[r] + Rc[r] for r in range(3)])
    return Mobilizer("free", R.T, position, motions, qdot, shift=xyz, w=w)


def planar(site, qs, us):
    Z = snapped(z_to(site.axis))
    Aj = snapped(fo.matmul(site.R0, Z))
    cth, sth = sm.cos(qs[2]), sm.sin(qs[2])
    # R_PC = Aj Rz(th) Zᵀ = P cos + Q sin + W
    Pm = snapped(fo.matmul(Aj, np.diag([1.0, 1.0, 0.0]), Z.T))
    Qm = snapped(fo.matmul(Aj, np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]), Z.T))
    Wm = snapped(fo.matmul(Aj, np.diag([0.0, 0.0, 1.0]), Z.T))
    R = sm.Matrix(3, 3, lambda r, k: lin((Pm[r, k], Qm[r, k], Wm[r, k]), (cth, sth, 1)))
    xy = times(Aj, [qs[0], qs[1], 0])
    Rc = _turned(R, site.com)
    position = sm.Matrix([site.base[r] + xy[r] + Rc[r] for r in range(3)])
    n = vec(Z[:, 2])
    motions = ((0, 0, 0) + tuple(vec(Z[:, 0])), (0, 0, 0) + tuple(vec(Z[:, 1])),
               tuple(n) + tuple(cross(n, site.com)))
    return Mobilizer("3-speed", R.T, position, motions,
                     [us[0] * cth - us[1] * sth, us[0] * sth + us[1] * cth, us[2]], shift=xy)


def fixed(site, qs, us):
    position = sm.Matrix(times(site.R0, site.com)) + sm.Matrix(site.base)
    return Mobilizer("fixed", sm.Matrix(site.R0.T).applyfunc(snap), position, (), [])


@dataclass(frozen=True)
class JointKind:
    """A row of the table: the kind's coordinate and speed name suffixes (``q_<joint>_<suffix>``;
    "" for a one-coordinate joint) and its mobilizer (``mobilize(site, qs, us)``)."""
    coordinates: tuple
    speeds: tuple
    mobilize: object
    quaternion_coordinates: tuple = None    # with JointSite.quaternion

    def suffixes(self, quaternion=False):
        """(coordinate suffixes, speed suffixes); ``quaternion``: a turning joint's quaternion
        coordinates (a kind without them keeps its own)."""
        if quaternion and self.quaternion_coordinates is not None:
            return self.quaternion_coordinates, self.speeds
        return self.coordinates, self.speeds


_ANGULAR = ("wx", "wy", "wz")
KINDS = {
    "revolute": JointKind(("",), ("",), revolute),
    "prismatic": JointKind(("",), ("",), prismatic),
    "ball": JointKind(("rx", "ry", "rz"), _ANGULAR, ball, ("qw", "qx", "qy", "qz")),
    "free": JointKind(("x", "y", "z", "rx", "ry", "rz"), ("vx", "vy", "vz") + _ANGULAR, free,
                      ("x", "y", "z", "qw", "qx", "qy", "qz")),
    "planar": JointKind(("x", "y", "th"), ("vx", "vy", "w"), planar),
    "fixed": JointKind((), (), fixed),
}
