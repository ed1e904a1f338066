"""The inertia a joint's limit carries on a free-floating or planar-rooted MJCF robot (issue 29 item 5).

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
(:func:`eomc.compiler.urdf.treeir.joint_loads`).

Planar-rooted trees (unactuated root slides and hinges: gymnasium's walker2d, hopper,
half_cheetah, swimmer; dm_control's walker, hopper, cheetah) carry what they can turn: where the
root joints let the rest of the robot turn about the joint's axis while its subtree stands, the
carried inertia is MuJoCo's constraint mass of that row with the subtree held (min vᵀMv over the
speeds that keep the subtree still and turn the joint at unit rate, the rest's other joints free:
:func:`_held`).  With 1/``dof_invweight0`` (until session 9) these robots' limits were far softer
than MuJoCo's (5 s, no flags, past the limit: dm walker ankles 0.533 rad vs MuJoCo's 0.022,
gymnasium walker2d feet 0.229 vs 0.028, dm hopper knee 0.149 vs 0.082 on either side); with the
held inertia 0.052, 0.037, 0.087 (on the side the start is inside of: knee 0.054 vs 0.060, ankle
0.021 vs 0.026; benchmarks/results/limit_overshoot.md).  The rigid rest's inertia about the axis
(the free-joint rule) held them too tight where the hip lets the torso turn: walker ankles 0.014,
walker2d feet 0.018, dm hopper knee 0.030 and ankle 0.008 (3.4 times under MuJoCo's).  Free-joint
trees keep the rigid rule (dm_control's humanoid rests at MuJoCo's height with it: dm_suite.md).
"""
import math

import numpy as np
from eomc.compiler import fixed_order as fo

__all__ = ["carried_inertias"]


def _descendants(m, b):
    out = [b]
    for k in range(b + 1, m.nbody):     # MuJoCo lists a body after its parent
        if int(m.body_parentid[k]) in out:
            out.append(k)
    return out


def _root_moves(m, d, root):
    """The motions the tree's root joints give its root body, as the rows of MuJoCo's cdof (6-vector
    [rotation, translation] about the tree's centre of mass), or None where the root does not let
    the robot move as a whole: a free joint gives every motion; otherwise every root joint must be
    an unactuated slide or hinge (gymnasium's and dm_control's planar walker, hopper, cheetah:
    slide, slide, hinge).  A root joint an actuator drives (a cart, a shoulder) holds the rest
    of the robot as the world does."""
    import mujoco
    joints = range(int(m.body_jntadr[root]), int(m.body_jntadr[root]) + int(m.body_jntnum[root]))
    types = [int(m.jnt_type[k]) for k in joints]
    if int(mujoco.mjtJoint.mjJNT_FREE) in types:
        return "free"
    driven = {int(m.actuator_trnid[a][0]) for a in range(m.nu)
              if int(m.actuator_trntype[a]) in (int(mujoco.mjtTrn.mjTRN_JOINT),
                                                int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))}
    if not types or driven & set(joints) or any(t not in (int(mujoco.mjtJoint.mjJNT_SLIDE),
                                                          int(mujoco.mjtJoint.mjJNT_HINGE)) for t in types):
        return None
    return np.array([d.cdof[int(m.jnt_dofadr[k])] for k in joints])


def _reachable(moves, twist):
    """Whether the root joints can give the root body ``twist`` (the rest of the robot turning
    about the joint's axis, or sliding along it, while the joint's subtree stands still): the
    twist less its least-squares fit by the root's motions vanishes (pure Python, as _held)."""
    if isinstance(moves, str):
        return True
    rows = [list(map(float, r)) for r in moves]
    gram = [[_dot(r, c) for c in rows] for r in rows]
    coef = _solve(gram, [_dot(r, twist) for r in rows])
    fit = [_sum(coef[a] * rows[a][i] for a in range(len(rows))) for i in range(6)]
    scale = max([1.0] + [abs(float(t)) for t in twist])
    return max(abs(float(t) - f) for t, f in zip(twist, fit)) <= 1e-9 * scale


def carried_inertias(m):
    """joint id -> the inertia its limit carries (module docstring), for the limited hinges and
    slides of trees rooted in a free joint or in unactuated slides and hinges (a planar walker)
    that let the rest of the robot turn about the joint's axis (slide along it) while the
    joint's subtree stands; joints of other trees, and the root joints themselves, are left out."""
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
        if b == root:
            continue
        moves = _root_moves(m, d, root)
        if moves is None:
            continue
        a, o = np.asarray(d.xaxis[j]), np.asarray(d.xanchor[j])
        slide = int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
        twist = (np.concatenate([np.zeros(3), a]) if slide else
                 np.concatenate([a, np.cross(a, np.asarray(d.subtree_com[root]) - o)]))
        if not _reachable(moves, twist):
            continue
        below = set(_descendants(m, b))
        if not isinstance(moves, str):
            out[j] = _held(m, d, root, b, j, moves, below)
            continue
        rest = [k for k in range(1, m.nbody) if int(m.body_rootid[k]) == root and k not in below]
        if slide:
            out[j] = float(sum(m.body_mass[k] for k in rest))
            continue
        about = 0.0             # the rest of the robot's inertia about the joint's axis
        for k in rest:
            ak = fo.matmul(np.asarray(d.ximat[k]).reshape(3, 3).T, a)
            lever = fo.norm(np.cross(a, np.asarray(d.xipos[k]) - o))
            about += fo.dot(ak, np.asarray(m.body_inertia[k]) * ak) + float(m.body_mass[k]) * lever ** 2
        out[j] = about
    return out


def _held(m, d, root, b, j, moves, below):
    """The inertia joint ``j`` moves with its subtree (``below``) standing still, the rest of a
    planar-rooted robot free to move as its joints let it: min vᵀMv over the speeds that leave
    body ``b`` still and turn ``j`` at unit rate (MuJoCo's constraint mass of the limit's row
    with the subtree's contacts rigid, 1/(J M⁻¹ Jᵀ) after the Schur complement).  The root's
    slides and hinges take up the twist the path from the root to ``b`` gives (they can: the
    caller checked ``j``'s; a path joint they cannot follow is held); the other joints of the
    rest (the hips, the other leg) are free, which is why this is less than the rigid rest's
    inertia about the axis.  Pure Python sums in index order: the result is printed into the C
    (:mod:`eomc.compiler.fixed_order`)."""
    import mujoco
    nv = int(m.nv)
    M = np.zeros((nv, nv))
    mujoco.mj_crb(m, d)             # the mass matrix at qpos0 (mj_comPos ran)
    mujoco.mj_fullM(m, d, M)
    dofs = lambda k: range(int(m.body_dofadr[k]), int(m.body_dofadr[k]) + int(m.body_dofnum[k]))
    rdofs = list(dofs(root))
    path, k = [], b
    while k != root:
        path += [i for i in dofs(k) if _reachable(moves, np.asarray(d.cdof[i]))]
        k = int(m.body_parentid[k])
    jd = int(m.jnt_dofadr[j])
    above = _ancestors(m, b, root)      # the bodies from b's parent up to the root's child
    free = [i for k in range(1, m.nbody) if int(m.body_rootid[k]) == root and k != root and k not in below
            for i in dofs(k) if k not in above or i in path]
    R = [list(map(float, r)) for r in moves]
    gram = [[_dot(r, c) for c in R] for r in R]

    def speeds(unit):
        """the dof speeds (dict) for one unit of dof ``unit``, the root taking up the path's twist"""
        v = {unit: 1.0}
        if unit in path:
            t = list(map(float, d.cdof[unit]))
            x = _solve(gram, [_dot(r, t) for r in R])
            for a, i in enumerate(rdofs):
                v[i] = v.get(i, 0.0) - x[a]
        return v

    def inner(u, w):
        return _sum(u[a] * _sum(M[a, c] * w[c] for c in sorted(w)) for a in sorted(u))

    t0, cols = speeds(jd), [speeds(i) for i in free]
    if not cols:
        return inner(t0, t0)
    Q = [[inner(a, c) for c in cols] for a in cols]
    g = [inner(a, t0) for a in cols]
    return inner(t0, t0) - _dot(g, _solve(Q, g))


def _ancestors(m, b, root):
    """the bodies strictly between ``b`` and ``root``"""
    out, k = set(), int(m.body_parentid[b])
    while k != root:
        out.add(k)
        k = int(m.body_parentid[k])
    return out


def _sum(terms):
    out = 0.0
    for t in terms:
        out += t
    return out


def _dot(a, b):
    return _sum(float(x) * float(y) for x, y in zip(a, b))


def _solve(A, rhs):
    """A x = rhs for a small symmetric positive definite A (lists), Cholesky in index order."""
    n = len(rhs)
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for k in range(i + 1):
            s = A[i][k] - _sum(L[i][c] * L[k][c] for c in range(k))
            L[i][k] = math.sqrt(s) if i == k else s / L[k][k]
    y = [0.0] * n
    for i in range(n):
        y[i] = (rhs[i] - _sum(L[i][c] * y[c] for c in range(i))) / L[i][i]
    x = [0.0] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - _sum(L[c][i] * x[c] for c in range(i + 1, n))) / L[i][i]
    return x
