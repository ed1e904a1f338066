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

__all__ = ["tree_of", "to_mujoco", "from_mujoco", "qacc_of", "prepared", "coupled_qacc", "rhs_error"]


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


def tree_of(m, model, **kwargs):
    """:func:`~.treeir.tree_ir` of the compiled MuJoCo model ``m`` in ``model``'s state layout, the
    tree the functions here map states with: ``model`` a built eomc model (quaternions where it has
    any: its ``quaternions``) or an :class:`~.model.MjcfModel` (its ``orientation``); ``kwargs``
    are tree_ir's (``actuators``, ``limits``, ``friction``: they do not change the layout).

    Why: eomc.compile builds MJCF ball and free joints as quaternions by default (session 30),
    while tree_ir's own default is body-XYZ angles; an oracle that built its own tree in the other
    layout mapped the states wrongly and silently (a root body's position still came out right)."""
    from .treeir import tree_ir
    if hasattr(model, "orientation"):
        quaternion = model.orientation == "quaternion"
    else:
        quaternion = bool(getattr(model, "quaternions", ()))
    built = tree_ir(m, quaternion=quaternion, **kwargs)
    nq = getattr(model, "nq", None)
    if nq is not None and nq != len(built.coordinates):
        raise ValueError(f"the model has {nq} coordinates, MuJoCo's tree in its layout {len(built.coordinates)}: "
                         f"not a build of this MuJoCo model")
    return built


def _layout(built, q):
    """``q``'s length checked against the tree's coordinates: a tree in the other orientation
    (angles for a quaternion build, or the reverse) would map every state wrongly."""
    if len(q) != len(built.coordinates):
        kind = "quaternions" if getattr(built.tree, "quaternions", ()) else "body-XYZ angles"
        raise ValueError(f"{len(q)} coordinates given, the tree has {len(built.coordinates)} (ball and free "
                         f"joints as {kind}): build the tree in the model's layout, tree_of(m, model)")


def to_mujoco(m, built: MjcfTree, q, u):
    """(qpos, qvel) of eomc's coordinates ``q`` and speeds ``u`` (``built``: :func:`tree_of` the model)."""
    _layout(built, q)
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
    _layout(built, q)
    qacc = np.zeros(m.nv)
    for j, kind, iq, iu in built.joints:
        d = int(m.jnt_dofadr[j])
        n = {0: 6, 1: 3, 2: 1, 3: 1}[kind]
        qacc[d:d + n] = du[iu:iu + n]
        if kind == 0:
            R = _rotation(built, q, iq + 3)
            qacc[d:d + 3] = R @ (du[iu:iu + 3] + np.cross(u[iu + 3:iu + 6], u[iu:iu + 3]))
    return qacc



def coupled_qacc(m, d):
    """MuJoCo's qacc with the file's active joint and tendon couplings (``<equality><joint>``,
    ``<equality><tendon>``) as exact constraints, as eomc models them; ``d`` after ``mj_forward``
    with constraints off (``prepared``), so ``d.qacc`` is the unconstrained a0 = M⁻¹ f.

    Why not MuJoCo's own constrained qacc: its equality is soft (solref/solimp), so it differs
    from an exact one by the softness; this is the exact answer from MuJoCo's own M, f and tendon
    Jacobians. Per coupling  g = L1 - L1_0 - P(L2 - L2_0) = 0 (for a joint coupling L = q):
    J = ∂L1/∂q - P'(d) ∂L2/∂q and J qacc = P''(d) L2'², so
    qacc = a0 - M⁻¹Jᵀ (J M⁻¹ Jᵀ)⁻¹ (J a0 - γ)."""
    import mujoco
    from .equality import couplings, tendon_couplings
    rows, gamma = [], []

    def unit(j):
        row = np.zeros(m.nv)
        row[int(m.jnt_dofadr[j])] = 1.0
        return row, float(d.qpos[int(m.jnt_qposadr[j])] - m.qpos0[int(m.jnt_qposadr[j])]), \
            float(d.qvel[int(m.jnt_dofadr[j])])

    def tendon(t):
        row = _ten_row(m, t)
        return row, float(d.ten_length[t]) - _tendon_length0(m, t), float(row @ d.qvel)

    flags = m.opt.disableflags        # prepared() switched constraints off: the couplings are the file's
    m.opt.disableflags = flags & ~int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    try:
        found = couplings(m)
        tied = tendon_couplings(m, [j1 for _, j1, _ in found])
    finally:
        m.opt.disableflags = flags
    items = [(e, unit(j1), unit(j2) if j2 is not None else None) for e, j1, j2 in found]
    for e, _, _, _ in tied:
        t1, t2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        items.append((e, tendon(t1), tendon(t2) if t2 >= 0 else None))
    for e, (r1, _, _), second in items:
        p = m.eq_data[e, :5]
        if second is None:
            rows.append(r1)
            gamma.append(0.0)
            continue
        r2, x, v = second
        slope = p[1] + 2 * p[2] * x + 3 * p[3] * x ** 2 + 4 * p[4] * x ** 3
        curve = 2 * p[2] + 6 * p[3] * x + 12 * p[4] * x ** 2
        rows.append(r1 - slope * r2)
        gamma.append(curve * v * v)
    a0 = np.array(d.qacc, dtype=float)
    if not rows:
        return a0
    M = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, M)      # MuJoCo 4 takes the MjData
    except TypeError:
        mujoco.mj_fullM(m, M, d.qM)   # 3.x the sparse qM
    J, g = np.array(rows), np.array(gamma)
    MiJt = np.linalg.solve(M, J.T)
    lam = np.linalg.solve(J @ MiJt, J @ a0 - g)
    return a0 - MiJt @ lam


def _ten_row(m, t):
    """Row t of a fixed tendon's Jacobian ∂L/∂qvel: its coefficients at its joints' dofs."""
    from .tendon import tendon_joints
    row = np.zeros(m.nv)
    for j, c in tendon_joints(m, t):
        row[int(m.jnt_dofadr[j])] += c
    return row


def _tendon_length0(m, t):
    """A fixed tendon's length at qpos0 (MuJoCo's L_0 of a tendon coupling): Σ c qpos0."""
    from .tendon import tendon_joints
    return sum(c * float(m.qpos0[int(m.jnt_qposadr[j])]) for j, c in tendon_joints(m, t))


def rhs_error(path, model, trials=4, seed=3):
    """max over random states of |eomc - MuJoCo| / max(1, |MuJoCo|) of qacc (and act_dot) for a
    ``model`` built from the MJCF file ``path`` with ``limits=False, geoms=False``: MuJoCo with
    contacts, constraints and limits off (:func:`prepared`), the file's couplings exact
    (:func:`coupled_qacc`, eomc's states put on them), activations (MuJoCo's ``act``) after q, u.
    The state mapping follows the model's orientation (quaternions when it has any)."""
    import warnings
    import mujoco
    from .model import check_model, load_mjmodel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m0 = load_mjmodel(path)
        motors = check_model(m0, path)
        built = tree_of(m0, model, actuators=motors, limits=False, friction=False)
        m = prepared(load_mjmodel(path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    nq, nv = len(built.coordinates), len(built.speeds)
    loops = getattr(built.tree, "loops", None)
    ndep = loops.n_dependent_coordinates if loops is not None else 0
    acts = [k for k in motors if m.actuator_dyntype[k]]
    if model.nx != nq + nv + len(acts):
        raise ValueError(f"{path}: the model has {model.nx} states, MuJoCo's mapping {nq + nv + len(acts)}")
    worst = 0.0
    for _ in range(trials):
        q, u, z = rng.uniform(-0.8, 0.8, nq), rng.uniform(-1.5, 1.5, nv), rng.uniform(-1, 1, len(acts))
        x = np.concatenate([q, u, z])
        if ndep:          # on the couplings: the dependent coordinates and speeds from the others
            x = model.consistent_state(x, fixed=list(model.state_names[:nq - ndep]))
            x[nq + nv:] = z
            q, u = x[:nq], x[nq:nq + nv]
        r = rng.uniform(-1.2, 1.2, len(motors))       # beyond ctrlrange too: both clamp
        xd = model.rhs(0.0, x, r=r) if motors else model.rhs(0.0, x)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        d.ctrl[:] = 0
        d.ctrl[motors] = r
        for i, k in enumerate(acts):
            d.act[m.actuator_actadr[k]] = z[i]
        mujoco.mj_forward(m, d)
        ref = coupled_qacc(m, d)
        if np.max(np.abs(ref)) <= 1e-3:
            raise ValueError(f"{path}: a random state that does not move: the comparison would say nothing")
        mine = qacc_of(m, built, q, u, xd[nq:nq + nv])
        worst = max(worst, np.max(np.abs(mine - ref)) / max(1.0, np.max(np.abs(ref))))
        if acts:
            act_dot = np.array([d.act_dot[m.actuator_actadr[k]] for k in acts])
            worst = max(worst, np.max(np.abs(xd[nq + nv:] - act_dot)) / max(1.0, np.max(np.abs(act_dot))))
    return worst
