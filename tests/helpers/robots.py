"""Real robots for the URDF tests: files from example-robot-data, references from Pinocchio.

The URDF files are read from the installed ``example-robot-data`` wheel (a test
dependency), not copied here: each robot there carries its own licence.

eomc and Pinocchio order and parametrize joints differently; :class:`PinRef`
maps by joint name.  Floating base: eomc's coordinates are position + body XYZ
Euler angles with body-frame speeds (see eomc.compiler.urdf.joints);
Pinocchio's are position + quaternion (x, y, z, w) with the same body-frame
speeds, so speeds, accelerations, forces and the mass matrix compare entry
for entry and only the orientation is converted.
"""
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pinocchio as pin

__all__ = ["robot_path", "PinRef", "rotation_xyz", "relative_error"]

ROBOTS = {
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
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
    """Pinocchio's model of the same file, reading eomc-ordered vectors."""

    def __init__(self, path, state_names, floating=False, mimic=False):
        root = pin.JointModelFreeFlyer() if floating else None
        self.model = (pin.buildModelFromUrdf(str(path), root, mimic=mimic) if floating
                      else pin.buildModelFromUrdf(str(path), mimic=mimic))
        self.data = self.model.createData()
        self.floating = floating
        nq = len(state_names) // 2
        joints = [n[2:] for n in state_names[6 if floating else 0:nq]]
        ids = [self.model.getJointId(j) for j in joints]
        assert all(i < self.model.njoints for i in ids), "a joint eomc has is unknown to Pinocchio"
        self.iq = [self.model.idx_qs[i] for i in ids]
        self.iv = (list(range(6)) if floating else []) + [self.model.idx_vs[i] for i in ids]
        assert len(self.iv) == self.model.nv, "eomc and Pinocchio disagree on the number of speeds"

    def q(self, q):
        out = np.zeros(self.model.nq)
        if self.floating:
            out[:3] = q[:3]
            out[3:7] = pin.Quaternion(rotation_xyz(*q[3:6])).coeffs()
            q = q[6:]
        out[self.iq] = q
        return out

    def v(self, v):
        out = np.zeros(self.model.nv)
        out[self.iv] = v
        return out

    def tau(self, tau_actuated):
        """Joint torques (eomc's inputs: the non-floating joints) as Pinocchio's tau."""
        out = np.zeros(self.model.nv)
        out[self.iv[6 if self.floating else 0:]] = tau_actuated
        return out

    def aba(self, q, v, tau):
        return pin.aba(self.model, self.data, self.q(q), self.v(v), self.tau(tau))[self.iv]

    def rnea(self, q, v, a):
        return pin.rnea(self.model, self.data, self.q(q), self.v(v), self.v(a))[self.iv]

    def mass_matrix(self, q):
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.iv, self.iv)]
