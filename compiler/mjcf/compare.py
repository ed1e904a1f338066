"""eomc's states <-> MuJoCo's, to check a built MJCF model against ``mj_forward`` (tests, benchmark).

Why a mapping: MuJoCo's ball and free joints carry a unit quaternion (4 coordinates),
eomc's body-XYZ angles (3) unless built with orientation="quaternion" (then the same
(w, x, y, z)); MuJoCo's free-joint linear velocity is in world
components, eomc's in body components.  Hinge and slide coordinates are the same.
So a state is drawn in eomc's coordinates and mapped to MuJoCo's; eomc's speed
derivatives are mapped to MuJoCo's qacc: for a free joint with R the body's
rotation, v_world = R v_body, so qacc_lin = R (v_body' + w x v_body); angular
speeds are body-frame in both.
"""
import numpy as np

from .treeir import MjcfTree

__all__ = ["to_mujoco", "from_mujoco", "qacc_of", "prepared"]


def _xyz_matrix(rx, ry, rz):
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _quat(R):
    import mujoco
    out = np.zeros(4)
    mujoco.mju_mat2Quat(out, np.ascontiguousarray(R).ravel())
    return out


def prepared(m):
    """``m`` with contacts, constraints and limits off (what eomc does not model; control clamping
    to ctrlrange stays on: eomc clamps as MuJoCo does)."""
    import mujoco
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT) \
        | int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    return m


def _quaternion(built, iq):
    """Whether the orientation coordinates at ``iq`` are a quaternion (orientation="quaternion")."""
    return iq in getattr(built.tree, "quaternions", ())


def _rotation(built, q, iq):
    """The rotation matrix of the orientation coordinates at ``iq`` (angles or quaternion)."""
    if _quaternion(built, iq):
        from .treeir import quat_matrix
        return quat_matrix(q[iq:iq + 4])
    return _xyz_matrix(*q[iq:iq + 3])


def to_mujoco(m, built: MjcfTree, q, u):
    """(qpos, qvel) of eomc's coordinates ``q`` and speeds ``u``."""
    qpos, qvel = np.array(m.qpos0, dtype=float), np.zeros(m.nv)
    for j, kind, iq, iu in built.joints:
        a, d = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        if kind in (2, 3):
            qpos[a], qvel[d] = q[iq], u[iu]
        elif kind == 1:
            qpos[a:a + 4] = _quat(_rotation(built, q, iq))
            qvel[d:d + 3] = u[iu:iu + 3]
        else:
            R = _rotation(built, q, iq + 3)
            qpos[a:a + 3] = q[iq:iq + 3]
            qpos[a + 3:a + 7] = _quat(R)
            qvel[d:d + 3] = R @ u[iu:iu + 3]
            qvel[d + 3:d + 6] = u[iu + 3:iu + 6]
    return qpos, qvel


def from_mujoco(m, built: MjcfTree, qpos, qvel):
    """(q, u): eomc's coordinates and speeds of MuJoCo's (qpos, qvel), the inverse of :func:`to_mujoco`."""
    from .treeir import quat_matrix
    from .model import _xyz_angles
    q, u = np.zeros(len(built.coordinates)), np.zeros(len(built.speeds))
    for j, kind, iq, iu in built.joints:
        a, d = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        if kind in (2, 3):
            q[iq], u[iu] = qpos[a], qvel[d]
        elif kind == 1:
            if _quaternion(built, iq):
                q[iq:iq + 4] = np.asarray(qpos[a:a + 4]) / np.linalg.norm(qpos[a:a + 4])
            else:
                q[iq:iq + 3] = _xyz_angles(quat_matrix(qpos[a:a + 4]))
            u[iu:iu + 3] = qvel[d:d + 3]
        else:
            R = quat_matrix(qpos[a + 3:a + 7])
            q[iq:iq + 3] = qpos[a:a + 3]
            if _quaternion(built, iq + 3):
                q[iq + 3:iq + 7] = np.asarray(qpos[a + 3:a + 7]) / np.linalg.norm(qpos[a + 3:a + 7])
            else:
                q[iq + 3:iq + 6] = _xyz_angles(R)
            u[iu:iu + 3] = R.T @ qvel[d:d + 3]
            u[iu + 3:iu + 6] = qvel[d + 3:d + 6]
    return q, u


def qacc_of(m, built: MjcfTree, q, u, du):
    """MuJoCo's qacc for eomc's state (q, u) and speed derivatives ``du``."""
    qacc = np.zeros(m.nv)
    for j, kind, iq, iu in built.joints:
        d = int(m.jnt_dofadr[j])
        n = {0: 6, 1: 3, 2: 1, 3: 1}[kind]
        qacc[d:d + n] = du[iu:iu + n]
        if kind == 0:
            R = _rotation(built, q, iq + 3)
            qacc[d:d + 3] = R @ (du[iu:iu + 3] + np.cross(u[iu + 3:iu + 6], u[iu:iu + 3]))
    return qacc

