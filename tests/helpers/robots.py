"""Real robots for the URDF tests: files from example-robot-data, references from Pinocchio.

The URDF files are read from the installed ``example-robot-data`` wheel (a test
dependency), not copied here: each robot there carries its own licence.

eomc and Pinocchio order and parametrize joints differently; :class:`PinRef`
maps by joint name.  Floating base: eomc's coordinates are position + body XYZ
Euler angles with body-frame speeds (see eomc.compiler.urdf.joints);
Pinocchio's are position + quaternion (x, y, z, w) with the same body-frame
speeds (eomc's floating_base="quaternion": position + quaternion (w, x, y, z)), so speeds, accelerations, forces and the mass matrix compare entry
for entry and only the orientation is converted.
"""
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pinocchio as pin

__all__ = ["robot_path", "PinRef", "joints_of", "rotation_xyz", "relative_error"]

ROBOTS = {
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
    "finger_edu": "finger_edu_description/robots/finger_edu.urdf",
}


def robot_path(name):
    root = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    path = root / ROBOTS.get(name, name)
    assert path.is_file(), f"example-robot-data lacks {path}"
    return path


def rotation_xyz(a, b, c):
    """R = Rx(a) Ry(b) Rz(c): the floating joint's body XYZ Euler angles."""
    return pin.utils.rotate("x", a) @ pin.utils.rotate("y", b) @ pin.utils.rotate("z", c)


def relative_error(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


def _name(dynamic_symbol):
    return dynamic_symbol.func.__name__ if hasattr(dynamic_symbol, "func") else str(dynamic_symbol)


class PinRef:
    """Pinocchio's model of the same file, reading eomc-ordered vectors.

    ``joints``: eomc's moving joints in its order, as (name, URDF type) -- e.g.
    ``[(j.name, j.type) for j in system.urdf.tree.joints]``; a floating base
    comes first.  ``locked``: joints eomc locked at 0 (massless subtrees,
    ``tree.locked``), removed from Pinocchio's model with ``buildReducedModel``.  Pinocchio's continuous joints and planar joints keep an
    angle as (cos, sin); eomc keeps the angle.
    """

    def __init__(self, path, joints, floating=False, mimic=False, locked=()):
        root = pin.JointModelFreeFlyer() if floating else None
        self.model = (pin.buildModelFromUrdf(str(path), root, mimic=mimic) if floating
                      else pin.buildModelFromUrdf(str(path), mimic=mimic))
        if locked:      # joints eomc merged (massless subtrees): locked at 0 here too
            ids = [self.model.getJointId(name) for name in locked]
            self.model = pin.buildReducedModel(self.model, [i for i in ids if i < self.model.njoints],
                                               pin.neutral(self.model))
        self.data = self.model.createData()
        self.floating = floating
        self.parts, self.iq, self.iv, self.actuated = [], [], [], []     # parts: (eomc q index, kind, pinocchio q index)
        k = 0
        for name, kind in joints:
            jid = self.model.getJointId(name)
            if kind in ("floating", "floating_quaternion") and jid >= self.model.njoints:
                jid = 1           # eomc's --floating-base joint: Pinocchio's root_joint
            assert jid < self.model.njoints, f"Pinocchio has no joint {name}"
            iq, iv, nv = self.model.idx_qs[jid], self.model.idx_vs[jid], self.model.nvs[jid]
            self.parts.append((k, kind, iq))
            self.iv += list(range(iv, iv + nv))
            if kind in ("revolute", "continuous", "prismatic"):
                self.actuated += list(range(iv, iv + nv))
            k += {"floating": 6, "floating_quaternion": 7, "planar": 3}.get(kind, 1)
        self.iq = [iq for _, kind, iq in self.parts if kind in ("revolute", "prismatic")]
        assert len(self.iv) == self.model.nv, "eomc and Pinocchio disagree on the number of speeds"

    def q(self, q):
        out = np.zeros(self.model.nq)
        for k, kind, iq in self.parts:
            if kind == "floating":
                out[iq:iq + 3] = q[k:k + 3]
                out[iq + 3:iq + 7] = pin.Quaternion(rotation_xyz(*q[k + 3:k + 6])).coeffs()
            elif kind == "floating_quaternion":     # eomc (w, x, y, z), Pinocchio (x, y, z, w), unit
                w, x, y, z = np.asarray(q[k + 3:k + 7], dtype=float) / np.linalg.norm(q[k + 3:k + 7])
                out[iq:iq + 3] = q[k:k + 3]
                out[iq + 3:iq + 7] = [x, y, z, w]
            elif kind == "planar":
                out[iq:iq + 4] = [q[k], q[k + 1], np.cos(q[k + 2]), np.sin(q[k + 2])]
            elif kind == "continuous":
                out[iq:iq + 2] = [np.cos(q[k]), np.sin(q[k])]
            else:
                out[iq] = q[k]
        return out

    def v(self, v):
        out = np.zeros(self.model.nv)
        out[self.iv] = v
        return out

    def tau(self, tau_actuated):
        """Joint torques (eomc's inputs: the 1-dof joints; floating and planar are free) as Pinocchio's."""
        out = np.zeros(self.model.nv)
        out[self.actuated] = tau_actuated
        return out

    def aba(self, q, v, tau):
        return pin.aba(self.model, self.data, self.q(q), self.v(v), self.tau(tau))[self.iv]

    def rnea(self, q, v, a):
        return pin.rnea(self.model, self.data, self.q(q), self.v(v), self.v(a))[self.iv]

    def mass_matrix(self, q):
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.iv, self.iv)]


def joints_of(system):
    """(name, URDF type) of a from_urdf System's moving joints, in eomc's order."""
    return [(j.name, j.type) for j in system.urdf.tree.joints]
