"""The inertia a joint's limit carries on a free-floating MJCF robot (issue 29 item 5).

One job: the scale of the limit's spring-damper for a joint that may hold the robot up.
MuJoCo's soft limit is a constraint solved with the others: it drives the joint's acceleration
towards its reference -b·v - k·r (``solref``) whatever the joint moves, so a knee that catches a
falling body stops it within about v·tc/e, as it stops a swinging shin.  eomc's limit is a
spring-damper K = m·k, C = m·b (:func:`eomc.compiler.contact.mujoco_law.limit_spring`): with m
the joint's own inertia (1/``dof_invweight0``, the shin and foot for a knee) it met MuJoCo's
excursions where the limit stops the subtree alone (the ant's ankles: 0.064 rad vs 0.058), but
let gymnasium's humanoid, collapsing onto its knees, go 0.29 rad past them where MuJoCo's (same
contacts, no self-collisions) went 0.061 (benchmarks/results/limit_overshoot.md).  So on a
robot with a free joint the scale is at least the inertia the joint carries when its subtree
stands on the ground: the rest of the robot's inertia about the joint's axis (at qpos0), what
the joint then turns.  That inertia is not the scale itself: MuJoCo's solver regularises
the limit's row with its own inertia's diagonal approximation, so the scale saturates at
1/(1 - dmax) times the joint's own (:func:`eomc.compiler.contact.mujoco_law.limit_spring`,
``carried``).  Measured on a free torso pivoting onto its knee's limit
(tests/compiler/mjcf/test_mjcf_limits.py): MuJoCo's knee went 0.0446 rad past, eomc's 0.216 with
the leg's own inertia, 0.043 with the carried inertia as the scale, 0.057 with the saturating
one (whose scale is MuJoCo's solver's at the deepest step within 5 %); gymnasium's humanoid's
knees 0.003 rad past with the carried inertia as the scale (MuJoCo's 0.06, same contacts),
0.041-0.044 with the saturating one (its scale 18.5 times the shin's, the solver's 9.8: the
body above counts as rigid about the knee, while the hip lets the torso turn).
eomc's URDF rule carries the same inertia
(:func:`eomc.compiler.urdf.treeir.joint_loads`).  Models without a free joint (hopper, walker:
planar slides) keep 1/``dof_invweight0``.
"""
import numpy as np
from eomc.compiler import fixed_order as fo

__all__ = ["carried_inertias"]


def _descendants(m, b):
    out = [b]
    for k in range(b + 1, m.nbody):     # MuJoCo lists a body after its parent
        if int(m.body_parentid[k]) in out:
            out.append(k)
    return out


def carried_inertias(m):
    """joint id -> the inertia its limit carries (module docstring), for the limited hinges and
    slides of trees rooted in a free joint; joints of other trees are left out."""
    import mujoco
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    out = {}
    for j in range(m.njnt):
        if not m.jnt_limited[j] or int(m.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                                             int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        b = int(m.jnt_bodyid[j])
        root = int(m.body_rootid[b])
        free = [k for k in range(int(m.body_jntadr[root]), int(m.body_jntadr[root]) + int(m.body_jntnum[root]))
                if int(m.jnt_type[k]) == int(mujoco.mjtJoint.mjJNT_FREE)]
        if not free:
            continue
        below = set(_descendants(m, b))
        rest = [k for k in range(1, m.nbody) if int(m.body_rootid[k]) == root and k not in below]
        if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE):
            out[j] = float(sum(m.body_mass[k] for k in rest))
            continue
        a, o = np.asarray(d.xaxis[j]), np.asarray(d.xanchor[j])
        about = 0.0             # the rest of the robot's inertia about the joint's axis
        for k in rest:
            ak = fo.matmul(np.asarray(d.ximat[k]).reshape(3, 3).T, a)
            lever = fo.norm(np.cross(a, np.asarray(d.xipos[k]) - o))
            about += fo.dot(ak, np.asarray(m.body_inertia[k]) * ak) + float(m.body_mass[k]) * lever ** 2
        out[j] = about
    return out
